//! `MotionBegin`/`MotionEnd` around geometry (deformation): the keys a shape carries, its shape
//! at shutter open, and the warnings for keys that cannot deform.

use glam::Vec3;
use rib_parser::scene::Shape;
use rib_parser::{LoadOptions, load_bytes};

fn load(text: &str) -> rib_parser::Loaded {
    load_bytes("deform.rib", text.as_bytes().to_vec(), &LoadOptions::default())
        .unwrap_or_else(|e| panic!("{}", e.render()))
}

#[test]
fn matching_keys_make_one_deforming_shape() {
    let loaded = load(
        "Shutter 0 1\nWorldBegin\nMotionBegin [0 1]\nSphere 1 -1 1 360\nSphere 2 -2 2 180\nMotionEnd\n\
         MotionBegin [0 0.5 1]\nPolygon \"P\" [0 0 0 1 0 0 0 1 0]\nPolygon \"P\" [1 0 0 2 0 0 1 1 0]\n\
         Polygon \"P\" [3 0 0 4 0 0 3 1 0]\nMotionEnd\nWorldEnd\n",
    );
    assert!(!loaded.render_warnings().contains("warning"), "{}", loaded.render_warnings());
    let shapes = &loaded.scene.shapes;
    assert_eq!(shapes.len(), 2);
    let d = shapes[0].deformation.as_ref().expect("the sphere deforms");
    assert_eq!(d.times(), &[0.0, 1.0]);
    assert_eq!(
        *shapes[0].shape,
        Shape::Sphere { radius: 1.0, z_min: -1.0, z_max: 1.0, theta_max_degrees: 360.0 }
    );
    assert_eq!(d.at(0.5), Shape::Sphere { radius: 1.5, z_min: -1.5, z_max: 1.5, theta_max_degrees: 270.0 });
    let d = shapes[1].deformation.as_ref().expect("the polygon deforms");
    let Shape::Polygons(m) = d.at(0.75) else { panic!("a polygon") };
    assert_eq!(m.positions[0], Vec3::new(2.0, 0.0, 0.0));
    assert!(loaded.scene.has_motion_blur());
}

#[test]
fn the_static_shape_is_the_one_at_shutter_open() {
    let loaded = load(
        "Shutter 0.5 1\nWorldBegin\nMotionBegin [0 1]\nDisk 0 1 360\nDisk 2 1 360\nMotionEnd\nWorldEnd\n",
    );
    let shape = &loaded.scene.shapes[0];
    assert_eq!(*shape.shape, Shape::Disk { height: 1.0, radius: 1.0, theta_max_degrees: 360.0 });
    assert!(shape.deformation.is_some());
}

#[test]
fn keys_that_differ_keep_the_first_with_a_located_warning() {
    // Another request type.
    let loaded = load(
        "Shutter 0 1\nWorldBegin\nMotionBegin [0 1]\nSphere 1 -1 1 360\nCylinder 1 -1 1 360\nMotionEnd\nWorldEnd\n",
    );
    let text = loaded.render_warnings();
    assert!(text.contains("deform.rib:5:1: warning") && text.contains("Cylinder after Sphere"), "{text}");
    assert!(text.contains("the first key is used"), "{text}");
    assert!(loaded.scene.shapes[0].deformation.is_none());
    assert!(matches!(*loaded.scene.shapes[0].shape, Shape::Sphere { radius: 1.0, .. }));
    // Another vertex count.
    let loaded = load(
        "Shutter 0 1\nWorldBegin\nMotionBegin [0 1]\nPolygon \"P\" [0 0 0 1 0 0 0 1 0]\n\
         Polygon \"P\" [0 0 0 1 0 0 1 1 0 0 1 0]\nMotionEnd\nWorldEnd\n",
    );
    let text = loaded.render_warnings();
    assert!(text.contains("vertex indices"), "{text}");
    assert!(loaded.scene.shapes[0].deformation.is_none());
    // Fewer requests than times.
    let loaded = load(
        "Shutter 0 1\nWorldBegin\nMotionBegin [0 0.5 1]\nSphere 1 -1 1 360\nSphere 2 -2 2 360\nMotionEnd\nWorldEnd\n",
    );
    let text = loaded.render_warnings();
    assert!(text.contains("gives 3 times but the block has 2 geometry requests"), "{text}");
    assert_eq!(loaded.scene.shapes.len(), 1);
    assert!(loaded.scene.shapes[0].deformation.is_none());
}

#[test]
fn a_deforming_shape_round_trips_through_the_writer() {
    let loaded = load(
        "Shutter 0 1\nWorldBegin\nBasis \"bezier\" 3 \"bezier\" 3\nMotionBegin [0 1]\n\
         Patch \"bicubic\" \"P\" [0 0 0 1 0 0 2 0 0 3 0 0 0 1 0 1 1 0 2 1 0 3 1 0 0 2 0 1 2 0 2 2 0 3 2 0 0 3 0 1 3 0 2 3 0 3 3 0]\n\
         Patch \"bicubic\" \"P\" [0 0 1 1 0 0 2 0 0 3 0 0 0 1 0 1 1 0 2 1 0 3 1 0 0 2 0 1 2 0 2 2 0 3 2 0 0 3 0 1 3 0 2 3 0 3 3 0]\n\
         MotionEnd\nWorldEnd\n",
    );
    assert!(!loaded.render_warnings().contains("warning"), "{}", loaded.render_warnings());
    let text = rib_parser::writer::write_scene(&loaded.scene);
    let again = load(&text);
    assert!(!again.render_warnings().contains("warning"), "{}\n{text}", again.render_warnings());
    assert_eq!(again.scene.shapes.len(), 1);
    assert_eq!(again.scene.shapes[0].shape, loaded.scene.shapes[0].shape);
    assert_eq!(again.scene.shapes[0].deformation, loaded.scene.shapes[0].deformation);
}

#[test]
fn float_primitive_variables_are_interpolated_and_the_others_are_the_first_keys() {
    let loaded = load(
        "Shutter 0 1\nWorldBegin\nMotionBegin [0 1]\n\
         Polygon \"P\" [0 0 0 1 0 0 0 1 0] \"N\" [0 0 1 0 0 1 0 0 1] \"uniform string name\" [\"a\"]\n\
         Polygon \"P\" [0 0 0 1 0 0 0 1 0] \"N\" [0 1 0 0 1 0 0 1 0] \"uniform string name\" [\"b\"]\n\
         MotionEnd\nWorldEnd\n",
    );
    assert!(!loaded.render_warnings().contains("warning"), "{}", loaded.render_warnings());
    let d = loaded.scene.shapes[0].deformation.as_ref().expect("the normals deform");
    let Shape::Polygons(m) = d.at(0.25) else { panic!("a polygon") };
    assert_eq!(m.primvars.floats("N").unwrap()[..3], [0.0, 0.25, 0.75]);
    let name = m.primvars.get("name").unwrap();
    assert_eq!(name.values, rib_parser::scene::ParamValues::Strings(vec!["a".into()]));
}
