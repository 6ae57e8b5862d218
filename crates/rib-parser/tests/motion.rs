//! `MotionBegin`/`MotionEnd` around transformations: the keys each shape and instance carries,
//! the transformation at shutter open, and what stays a first-sample approximation.

use glam::{DMat4, DVec3};
use rib_parser::{LoadOptions, load_bytes};

fn load(text: &str) -> rib_parser::Loaded {
    load_bytes("motion.rib", text.as_bytes().to_vec(), &LoadOptions::default())
        .unwrap_or_else(|e| panic!("{}", e.render()))
}

fn translation(x: f64, y: f64, z: f64) -> DMat4 {
    DMat4::from_translation(DVec3::new(x, y, z))
}

#[test]
fn a_translation_block_gives_the_shape_one_key_per_time() {
    let loaded = load(
        "Shutter 0 1\nWorldBegin\nTranslate 0 0 5\nMotionBegin [0 1]\nTranslate -1 0 0\nTranslate 1 0 0\nMotionEnd\n\
         Scale 2 2 2\nSphere 1 -1 1 360\nSphere 1 -1 1 360\nWorldEnd\n",
    );
    let shape = &loaded.scene.shapes[0];
    let motion = shape.motion.as_ref().expect("the sphere moves");
    assert_eq!(motion.times(), &[0.0, 1.0]);
    let scale = DMat4::from_scale(DVec3::splat(2.0));
    assert_eq!(motion.matrices(), &[translation(-1.0, 0.0, 5.0) * scale, translation(1.0, 0.0, 5.0) * scale]);
    // The static transformation is the one at shutter open.
    assert_eq!(shape.world_from_object, translation(-1.0, 0.0, 5.0) * scale);
    assert!(motion.at(0.5).abs_diff_eq(translation(0.0, 0.0, 5.0) * scale, 1e-12));
    assert!(!loaded.render_warnings().contains("warning"), "{}", loaded.render_warnings());
}

#[test]
fn shutter_open_places_the_static_transformation_and_blocks_restore_the_motion() {
    let loaded = load(
        "Shutter 0.5 1\nWorldBegin\nTransformBegin\nMotionBegin [0 1]\nTranslate 0 0 0\nTranslate 2 0 0\nMotionEnd\n\
         Sphere 1 -1 1 360\nTransformEnd\nSphere 1 -1 1 360\n\
         MotionBegin [0 1]\nTransform [1 0 0 0 0 1 0 0 0 0 1 0 0 0 0 1]\nTransform [1 0 0 0 0 1 0 0 0 0 1 0 0 4 0 1]\nMotionEnd\n\
         Sphere 1 -1 1 360\nWorldEnd\n",
    );
    let shapes = &loaded.scene.shapes;
    assert!(shapes[0].world_from_object.abs_diff_eq(translation(1.0, 0.0, 0.0), 1e-12));
    assert!(shapes[1].motion.is_none());
    assert_eq!(shapes[1].world_from_object, DMat4::IDENTITY);
    assert!(shapes[2].world_from_object.abs_diff_eq(translation(0.0, 2.0, 0.0), 1e-12));
    assert_eq!(shapes[2].motion.as_ref().unwrap().matrices()[1], translation(0.0, 4.0, 0.0));
}

#[test]
fn moving_instances_and_the_first_sample_fallbacks() {
    let loaded = load(
        "Shutter 0 1\nWorldBegin\nObjectBegin 1\nSphere 1 -1 1 360\nObjectEnd\n\
         MotionBegin [0 1]\nRotate 0 0 0 1\nRotate 90 0 0 1\nMotionEnd\nObjectInstance 1\nWorldEnd\n",
    );
    let inst = &loaded.scene.instances[0];
    assert!(
        inst.motion
            .as_ref()
            .unwrap()
            .at(0.5)
            .abs_diff_eq(DMat4::from_rotation_z(std::f64::consts::FRAC_PI_4), 1e-12)
    );

    // Attributes inside a motion block keep their first sample, with a warning.
    let loaded = load(
        "WorldBegin\nMotionBegin [0 1]\nColor [1 0 0]\nColor [0 1 0]\nMotionEnd\nSphere 1 -1 1 360\nWorldEnd\n",
    );
    assert_eq!(loaded.scene.shapes.len(), 1);
    let text = loaded.render_warnings();
    assert!(text.contains("motion blur of lights and attributes"), "{text}");

    // A moving camera keeps its keys (tests/scene.rs has the rest); a projective key cannot be
    // a camera, so the camera at shutter open is used, with a warning.
    let loaded = load(
        "MotionBegin [0 1]\nTranslate 0 0 5\nTranslate 1 0 5\nMotionEnd\nWorldBegin\nSphere 1 -1 1 360\nWorldEnd\n",
    );
    assert!(loaded.scene.render.camera_motion.is_some());
    assert!(!loaded.render_warnings().contains("warning"), "{}", loaded.render_warnings());
    let loaded = load(
        "Translate 0 0 5\nMotionBegin [0 1]\nConcatTransform [1 0 0 0 0 1 0 0 0 0 1 0 0 0 0 1]\nConcatTransform [1 0 0 0 0 1 0 0 0 0 1 0.5 0 0 0 1]\nMotionEnd\nWorldBegin\nSphere 1 -1 1 360\nWorldEnd\n",
    );
    assert!(loaded.scene.render.camera_motion.is_none());
    let text = loaded.render_warnings();
    assert!(text.contains("camera's motion block is projective or singular"), "{text}");
}

#[test]
fn a_block_whose_transformations_do_not_match_its_times_is_a_located_error() {
    let e = load_bytes(
        "motion.rib",
        b"WorldBegin\nMotionBegin [0 0.5 1]\nTranslate 1 0 0\nTranslate 2 0 0\nMotionEnd\nWorldEnd\n"
            .to_vec(),
        &LoadOptions::default(),
    )
    .unwrap_err()
    .render();
    assert!(
        e.contains("motion.rib:5:1: error: MotionBegin gives 3 times but the block has 2 transformations"),
        "{e}"
    );
}
