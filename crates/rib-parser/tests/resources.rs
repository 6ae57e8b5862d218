//! `Resource "name" "attributes"`: save, and restore (or ricpp's "load") of the subsets PRMan's
//! `RiResource` names.

use glam::{DVec3, Vec3};
use rib_parser::scene::*;
use rib_parser::{LoadOptions, load_bytes};

fn load(rib: &str) -> rib_parser::Loaded {
    load_bytes("test.rib", rib.as_bytes().to_vec(), &LoadOptions::default())
        .unwrap_or_else(|e| panic!("{}", e.render()))
}

/// A state saved with red, `Sides 1`, a bilinear basis... then changed to the opposite and a
/// `Resource` restore of `subset` before one sphere.
fn restored(operation: &str, subset: &str) -> (rib_parser::Loaded, usize) {
    let rib = format!(
        "WorldBegin\n\
         Color [1 0 0]\nSurface \"plastic\"\nSides 1\nMatte 1\nBasis \"catmull-rom\" 1 \"catmull-rom\" 1\n\
         Translate 1 0 0\n\
         Resource \"saved\" \"attributes\" \"string operation\" \"save\"\n\
         Color [0 0 1]\nSurface \"matte\"\nSides 2\nMatte 0\nBasis \"bezier\" 3 \"bezier\" 3\nReverseOrientation\n\
         Translate 0 5 0\n\
         Resource \"saved\" \"attributes\" \"string operation\" \"{operation}\" \"string subset\" \"{subset}\"\n\
         Sphere 1 -1 1 360\n\
         Patch \"bicubic\" \"P\" [0 0 0 1 0 0 2 0 0 3 0 0 0 1 0 1 1 0 2 1 0 3 1 0 0 2 0 1 2 0 2 2 0 3 2 0 0 3 0 1 3 0 2 3 0 3 3 0]\n\
         WorldEnd\n"
    );
    let loaded = load(&rib);
    assert_eq!(loaded.scene.shapes.len(), 2, "{}", loaded.render_warnings());
    (loaded, 0)
}

fn attributes(loaded: &rib_parser::Loaded, shape: usize) -> &Attributes {
    loaded.scene.attributes_of(loaded.scene.shapes[shape].attributes)
}

fn offset(loaded: &rib_parser::Loaded) -> DVec3 {
    loaded.scene.shapes[0].world_from_object.w_axis.truncate()
}

fn surface_name(a: &Attributes) -> &str {
    a.surface.as_ref().map(|s| s.name.as_str()).unwrap_or("")
}

fn patch_basis(loaded: &rib_parser::Loaded) -> Basis {
    match &*loaded.scene.shapes[1].shape {
        Shape::Patches(p) => p.u_basis,
        other => panic!("expected a patch, got {other:?}"),
    }
}

#[test]
fn each_subset_restores_its_own_attributes() {
    let blue = Vec3::new(0.0, 0.0, 1.0);
    let red = Vec3::new(1.0, 0.0, 0.0);
    let moved = DVec3::new(1.0, 5.0, 0.0);
    let saved_place = DVec3::new(1.0, 0.0, 0.0);

    let (l, s) = restored("restore", "shading");
    let a = attributes(&l, s);
    assert_eq!((a.color, surface_name(a)), (red, "plastic"));
    assert_eq!((a.sides, a.matte, a.reverse_orientation), (2, false, true));
    assert_eq!(offset(&l), moved);

    let (l, s) = restored("restore", "geometrymodification");
    let a = attributes(&l, s);
    assert_eq!((a.color, surface_name(a)), (blue, "matte"));
    assert_eq!((a.sides, a.reverse_orientation, a.matte), (1, false, false));

    let (l, s) = restored("restore", "hiding");
    let a = attributes(&l, s);
    assert_eq!((a.color, a.sides, a.matte), (blue, 2, true));

    let (l, _) = restored("restore", "geometrydefinition");
    assert_eq!(patch_basis(&l).step, 1, "the Catmull-Rom basis comes back");
    let (l, _) = restored("restore", "shading");
    assert_eq!(patch_basis(&l).step, 3, "shading leaves the Bezier basis");

    let (l, s) = restored("restore", "transform");
    assert_eq!(attributes(&l, s).color, blue);
    assert_eq!(offset(&l), saved_place);

    let (l, s) = restored("restore", "shading,transform");
    assert_eq!((attributes(&l, s).color, offset(&l)), (red, saved_place));

    let (l, s) = restored("restore", "all");
    let a = attributes(&l, s);
    assert_eq!((a.color, a.sides, a.matte, a.reverse_orientation), (red, 1, true, false));
    assert_eq!(offset(&l), saved_place);
    assert_eq!(patch_basis(&l).step, 1);
}

#[test]
fn load_is_a_restore() {
    for subset in ["all", "shading", "transform", "hiding"] {
        let (restore, s) = restored("restore", subset);
        let (load, _) = restored("load", subset);
        assert_eq!(attributes(&restore, s), attributes(&load, s), "{subset}");
        assert_eq!(offset(&restore), offset(&load), "{subset}");
        assert_eq!(load.diagnostics.warning_count(), 0, "{}", load.render_warnings());
    }
}

#[test]
fn unknown_subsets_and_handles_are_reported() {
    let loaded = load(
        "WorldBegin\nResource \"a\" \"attributes\" \"string operation\" \"save\"\n\
         Resource \"a\" \"attributes\" \"string operation\" \"restore\" \"string subset\" \"lighting\"\nWorldEnd\n",
    );
    let w = loaded.render_warnings();
    assert!(
        w.contains("test.rib:3:1: warning: Resource \"a\": unknown subset \"lighting\" (all, shading, geometrymodification, geometrydefinition, hiding or transform); ignored"),
        "{w}"
    );
    let e = match load_bytes(
        "test.rib",
        b"WorldBegin\nResource \"b\" \"attributes\" \"string operation\" \"load\"\nWorldEnd\n".to_vec(),
        &LoadOptions::default(),
    ) {
        Ok(_) => panic!("a load of a resource never saved is an error"),
        Err(e) => e.render(),
    };
    assert!(
        e.contains(
            "test.rib:2:1: error: Resource \"b\" \"attributes\" load: no resource of that name was saved"
        ),
        "{e}"
    );
}
