//! Shadow-map lights (`shadowspot`, `shadowpoint`, `shadowdistant`) become the standard lights
//! they extend, `MakeShadow` and shadow-map frames are superseded by ray-traced shadows, and
//! `Imager "background"` is kept with its colour.

use glam::Vec3;
use rib_parser::builder::background_color;
use rib_parser::scene::LightKind;
use rib_parser::{LoadOptions, load_bytes};

fn load_with(rib: &str, frame: Option<i32>) -> rib_parser::Loaded {
    let options = LoadOptions { frame, ..LoadOptions::default() };
    load_bytes("test.rib", rib.as_bytes().to_vec(), &options).unwrap_or_else(|e| panic!("{}", e.render()))
}

fn load(rib: &str) -> rib_parser::Loaded {
    load_with(rib, None)
}

fn kinds(loaded: &rib_parser::Loaded) -> Vec<LightKind> {
    loaded.scene.lights.iter().map(|l| l.kind.clone()).collect()
}

#[test]
fn shadow_map_lights_are_their_standard_lights() {
    let params = [
        (
            "spot",
            r#""intensity" [75] "lightcolor" [1 .5 .25] "from" [5 5 -5] "to" [0 0 0] "coneangle" [0.5] "conedeltaangle" [0.05] "beamdistribution" [3]"#,
        ),
        ("point", r#""intensity" [4] "lightcolor" [1 1 .5] "from" [1 2 3]"#),
        ("distant", r#""intensity" [0.7] "from" [0 10 0] "to" [1 0 0]"#),
    ];
    for (kind, p) in params {
        let shadowed = load(&format!(
            "WorldBegin\nTranslate 1 0 0\nLightSource \"shadow{kind}\" 1 {p} \"string shadowname\" [\"x.shad\"] \"float blur\" [0.03] \"float bias\" [0.1] \"float samples\" [16]\nWorldEnd\n"
        ));
        let standard = load(&format!(
            "WorldBegin\nTranslate 1 0 0\nLightSource \"{}light\" 1 {p}\nWorldEnd\n",
            if kind == "spot" { "spot".to_string() } else { kind.to_string() }
        ));
        assert_eq!(kinds(&shadowed), kinds(&standard), "shadow{kind}");
        assert!(!matches!(kinds(&shadowed)[0], LightKind::Other), "shadow{kind}");
        // One note for the ignored shadow-map parameters, never "not a standard light".
        let warnings = shadowed.render_warnings();
        assert_eq!(warnings.matches("shadows are ray traced exactly").count(), 1, "{warnings}");
        assert!(!warnings.contains("not a standard light"), "{warnings}");
    }
    // Defaults are the standard light's: from (0 0 0), to (0 0 1), 30 and 5 degrees, beam 2.
    let bare = load("WorldBegin\nLightSource \"shadowspot\" 1\nLightSource \"shadowspot\" 2\nWorldEnd\n");
    assert_eq!(
        kinds(&bare)[0],
        LightKind::Spot {
            position: glam::DVec3::ZERO,
            direction: glam::DVec3::Z,
            intensity: 1.0,
            color: Vec3::ONE,
            cone_angle: 30f32.to_radians(),
            cone_delta_angle: 5f32.to_radians(),
            beam_distribution: 2.0,
        }
    );
    assert!(bare.render_warnings().is_empty(), "{}", bare.render_warnings());
    // Their from/to are checked as the standard light's are.
    let err = load_bytes(
        "t.rib",
        b"WorldBegin\nLightSource \"shadowdistant\" 1 \"from\" [1 1 1] \"to\" [1 1 1]\nWorldEnd\n".to_vec(),
        &LoadOptions::default(),
    )
    .unwrap_err()
    .render();
    assert!(err.contains("\"from\" and \"to\" are the same point"), "{err}");
}

const SHADOW_PASS_SCENE: &str = r#"
Display "light.z" "zfile" "z"
FrameBegin 1
  WorldBegin
    Sphere 1 -1 1 360
  WorldEnd
FrameEnd
MakeShadow "light.z" "light.shad"
Display "image.tif" "file" "rgba"
FrameBegin 2
  WorldBegin
    LightSource "shadowspot" 1 "shadowname" ["light.shad"]
    Sphere 1 -1 1 360
    Sphere 2 -2 2 360
  WorldEnd
FrameEnd
"#;

#[test]
fn shadow_map_passes_and_make_shadow_are_superseded() {
    let loaded = load(SHADOW_PASS_SCENE);
    // The image frame is kept, the shadow-map frame skipped.
    assert_eq!(loaded.scene.frame, Some(2));
    assert_eq!(loaded.scene.shapes.len(), 2);
    assert!(loaded.frames[0].shadow_pass && !loaded.frames[1].shadow_pass);
    assert_eq!(loaded.superseded_shadow_maps.len(), 1);
    assert_eq!(loaded.superseded_shadow_maps[0].line, 8);
    assert!(!loaded.render_warnings().contains("MakeShadow"), "{}", loaded.render_warnings());
    // Asking for the shadow pass still gets it.
    assert_eq!(load_with(SHADOW_PASS_SCENE, Some(1)).scene.shapes.len(), 1);
    // A file whose only world is a depth pass renders that world.
    let only = load("Display \"d.z\" \"shadow\" \"z\"\nWorldBegin\nSphere 1 -1 1 360\nWorldEnd\n");
    assert_eq!(only.scene.shapes.len(), 1);
}

#[test]
fn imager_background_spellings() {
    let cases = [
        (r#""color background" [0.2 0.4 0.6]"#, Some(Vec3::new(0.2, 0.4, 0.6))),
        (r#""background" [1 1 1]"#, Some(Vec3::ONE)),
        (r#""color bgcolor" [0.5 0.5 0.5]"#, Some(Vec3::splat(0.5))),
        (r#""color" [.6 .6 .8]"#, Some(Vec3::new(0.6, 0.6, 0.8))),
        ("", None),
    ];
    for (params, expected) in cases {
        let loaded = load(&format!("Imager \"background\" {params}\nWorldBegin\nWorldEnd\n"));
        let imager = loaded.scene.render.imager.as_ref().expect("the imager is kept");
        assert_eq!(imager.name, "background");
        assert_eq!(background_color(&imager.params), expected, "{params}");
        assert_eq!(loaded.render_warnings().contains("no colour"), expected.is_none(), "{params}");
    }
    // Inside the world block too (Aqsis's hand.rib sets it there).
    let inside = load("WorldBegin\nImager \"background\" \"color\" [1 1 1]\nWorldEnd\n");
    let imager = inside.scene.render.imager.as_ref().expect("the imager is kept");
    assert_eq!(background_color(&imager.params), Some(Vec3::ONE));
    assert!(inside.render_warnings().is_empty(), "{}", inside.render_warnings());
    let other = load("Imager \"MOSAICbackground\"\nWorldBegin\nWorldEnd\n");
    assert!(other.render_warnings().contains("shader program"), "{}", other.render_warnings());
}

#[test]
fn corpus_shadow_scenes_keep_their_lit_frame() {
    let corpus = concat!(env!("CARGO_MANIFEST_DIR"), "/../../../shared/rib-corpus/aqsis__aqsis/");
    for (file, frame, maps, spots) in [
        ("examples__features__shadows__softshadow.rib", 2, 1, 1),
        ("examples__scenes__vase__vase.rib", 3, 2, 2),
    ] {
        let path = std::path::Path::new(corpus).join(file);
        let loaded = rib_parser::load_scene(&path, &LoadOptions::default())
            .unwrap_or_else(|e| panic!("{}", e.render()));
        assert_eq!(loaded.scene.frame, Some(frame), "{file}");
        assert_eq!(loaded.superseded_shadow_maps.len(), maps, "{file}");
        let n = kinds(&loaded).iter().filter(|k| matches!(k, LightKind::Spot { .. })).count();
        assert_eq!(n, spots, "{file}");
    }
}
