//! The window shows exactly what a headless run writes. Needs an X display: `cargo xtask test`
//! runs the suite against its own Xvfb; without a display this test fails (it never skips).
//! One test per binary: winit allows one event loop per process.

mod common;

use common::*;
use glam::DVec3;
use viewer::window::{self, WindowSettings};
use viewer::{CompositeMode, Compositor, CompositorSettings, LiveObjects, Material, Sphere};

#[test]
fn window_frame_equals_the_headless_frame() {
    assert!(std::env::var_os("DISPLAY").is_some(), "no X display: run `cargo xtask test`, which starts Xvfb");
    let scene = cornell_scene(vec![cornell_light()]);
    let live = LiveObjects {
        sphere: Some(Sphere {
            centre: DVec3::new(0.2, -0.2, 0.1),
            radius: 0.25,
            material: Material::default(),
        }),
        meshes: Vec::new(),
    };
    let settings = CompositorSettings { mode: CompositeMode::Points, ..CompositorSettings::default() };
    let scratch = tempfile::Builder::new().prefix("viewer-window-test-").tempdir().unwrap();
    let dir = scratch.path();
    let screenshot = dir.join("window.png");
    let mask = dir.join("mask.png");
    // Moves the sphere a little each frame, as a haptic device would.
    let mut step = 0u64;
    let updater = move |live: &mut LiveObjects, frame: &viewer::FrameInfo| {
        assert_eq!(frame.index, step);
        step += 1;
        if let Some(s) = live.sphere.as_mut() {
            s.centre.x += 0.01;
        }
    };
    let outcome = window::run(
        scene.clone(),
        settings,
        WindowSettings {
            title: "viewer test".into(),
            frames: Some(3),
            screenshot: Some(screenshot.clone()),
            mask: Some(mask.clone()),
            ..WindowSettings::default()
        },
        live,
        Some(Box::new(updater)),
    )
    .expect("the window runs");
    assert_eq!(outcome.frames, 3);
    let moved = outcome.live.sphere.unwrap().centre;
    assert!((moved.x - 0.23).abs() < 1e-12, "the updater ran once per frame: {moved}");

    // The same frame headless.
    let gpu = gpu();
    let mut c = Compositor::new(&gpu, &scene, settings).unwrap();
    c.render(&outcome.live).unwrap();
    let frame = c.read_back().unwrap();
    // What the surface showed, read back from it (lavapipe's X11 surfaces allow copies).
    let presented = outcome.presented.as_ref().expect("the presented frame was read back");
    assert!(presented.pixels == frame.colour.pixels, "the presented frame differs from the headless frame");
    let shown = image::open(&screenshot).unwrap().to_rgba8();
    assert_eq!((shown.width(), shown.height()), (512, 512));
    assert!(shown.as_raw() == &frame.colour.pixels, "the window's frame differs from the headless frame");
    let shown_mask = image::open(&mask).unwrap().to_luma8();
    assert!(shown_mask.as_raw() == &frame.mask);
    assert!(frame.mask.contains(&255));
}
