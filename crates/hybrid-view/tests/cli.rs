//! The `hybrid-view` command line end to end (CONTRACTS.md §5): replica, masks against analytic
//! ground truth, errors and exit codes, the window against headless. GPU tests: they need an
//! adapter (lavapipe in CI) and, for the window, an X display (`cargo xtask test` starts Xvfb).

use glam::DVec3;
use std::path::{Path, PathBuf};
use std::process::{Command, Output};

fn shared() -> PathBuf {
    PathBuf::from(concat!(env!("CARGO_MANIFEST_DIR"), "/../../../shared"))
}

fn cornell() -> PathBuf {
    shared().join("reference/cornell")
}

/// A scratch directory for one test.
fn scratch(name: &str) -> tempfile::TempDir {
    tempfile::Builder::new().prefix(&format!("hybrid-view-{name}-")).tempdir().unwrap()
}

fn hybrid_view(args: &[&str]) -> Output {
    let output =
        Command::new(env!("CARGO_BIN_EXE_hybrid-view")).args(args).output().expect("run hybrid-view");
    eprintln!("stderr: {}", String::from_utf8_lossy(&output.stderr));
    output
}

fn s(p: &Path) -> &str {
    p.to_str().unwrap()
}

/// A 512x512 image in which neighbouring pixels differ.
fn write_noise_png(path: &Path, w: u32, h: u32) -> image::RgbaImage {
    let mut state = 0x2545_F491_4F6C_DD1Du64;
    let img = image::RgbaImage::from_fn(w, h, |_, _| {
        state ^= state << 13;
        state ^= state >> 7;
        state ^= state << 17;
        let b = state.to_le_bytes();
        image::Rgba([b[0], b[1], b[2], 255])
    });
    img.save(path).unwrap();
    img
}

#[test]
fn headless_replica_in_both_modes() {
    let scratch_dir = scratch("replica");
    let dir = scratch_dir.path();
    let input = dir.join("in.png");
    let img = write_noise_png(&input, 512, 512);
    for mode in ["points", "fullscreen"] {
        let shot = dir.join(format!("{mode}.png"));
        let mask = dir.join(format!("{mode}-mask.png"));
        let out = hybrid_view(&[
            s(&input),
            s(&cornell().join("depth-analytic.depth")),
            s(&cornell().join("cornell.rib")),
            "--headless",
            "--mode",
            mode,
            "--screenshot",
            s(&shot),
            "--mask",
            s(&mask),
        ]);
        assert_eq!(out.status.code(), Some(0), "{mode}");
        let got = image::open(&shot).unwrap().to_rgba8();
        assert!(got == img, "{mode}: the screenshot differs from the input image");
        let m = image::open(&mask).unwrap().to_luma8();
        assert!(m.pixels().all(|p| p.0[0] == 0), "{mode}: the mask is not empty");
    }
}

/// The mask of `--sphere` against the analytic ground truth (the exact depth table of the
/// Cornell box), including where the sphere passes behind the tall box and cuts through a wall.
#[test]
fn sphere_masks_match_the_analytic_ground_truth() {
    let scratch_dir = scratch("masks");
    let dir = scratch_dir.path();
    let input = dir.join("in.png");
    write_noise_png(&input, 512, 512);
    let rib = cornell().join("cornell.rib");
    let depth_path = cornell().join("depth-analytic.depth");
    let loaded = rib_parser::load_scene(&rib, &rib_parser::LoadOptions::default()).unwrap();
    let camera = depth_remap::Camera::new(loaded.scene.camera.clone()).unwrap();
    let table = depth_remap::DepthTable::read(&depth_path).unwrap();
    for (what, centre, radius) in [
        ("behind the tall box", DVec3::new(-0.35, 0.25, -0.8), 0.25),
        ("through the red wall", DVec3::new(-1.0, 0.2, 0.0), 0.3),
    ] {
        let mask_path = dir.join("mask.png");
        let sphere = format!("{},{},{}", centre.x, centre.y, centre.z);
        let radius_text = radius.to_string();
        let out = hybrid_view(&[
            s(&input),
            s(&depth_path),
            s(&rib),
            "--headless",
            "--sphere",
            &sphere,
            "--radius",
            &radius_text,
            "--mask",
            s(&mask_path),
        ]);
        assert_eq!(out.status.code(), Some(0));
        let mask = image::open(&mask_path).unwrap().to_luma8();
        let c = camera.camera_from_world().transform_point3(centre);
        let (mut both, mut either, mut occluded) = (0u32, 0u32, 0u32);
        for j in 0..512 {
            for i in 0..512 {
                let ray = camera.pixel_centre_ray(i, j);
                let f = ray.origin - c;
                let b = f.dot(ray.direction);
                let q = f - b * ray.direction;
                let disc = radius * radius - q.dot(q);
                let hit = (disc >= 0.0).then(|| -b - disc.sqrt());
                let d = f64::from(table.get(i, j).unwrap());
                let truth = hit.is_some_and(|t| t < d);
                occluded += u32::from(hit.is_some_and(|t| t >= d));
                let got = mask.get_pixel(i, j).0[0] == 255;
                both += u32::from(truth && got);
                either += u32::from(truth || got);
            }
        }
        let iou = f64::from(both) / f64::from(either);
        eprintln!("{what}: IoU {iou}, {either} pixels, {occluded} occluded");
        assert!(occluded > 100, "{what}: partly hidden by the scene");
        assert!(iou >= 0.99, "{what}: IoU {iou}");
    }
}

#[test]
fn size_mismatch_names_both_sizes() {
    let scratch_dir = scratch("mismatch");
    let dir = scratch_dir.path();
    let input = dir.join("small.png");
    write_noise_png(&input, 256, 200);
    let out = hybrid_view(&[
        s(&input),
        s(&cornell().join("depth-analytic.depth")),
        s(&cornell().join("cornell.rib")),
        "--headless",
    ]);
    assert_eq!(out.status.code(), Some(1));
    let err = String::from_utf8_lossy(&out.stderr);
    assert!(err.contains("256x200") && err.contains("512x512"), "{err}");
}

#[test]
fn malformed_inputs_fail_with_exit_code_1() {
    let scratch_dir = scratch("malformed");
    let dir = scratch_dir.path();
    let input = dir.join("in.png");
    write_noise_png(&input, 4, 2);
    let bad_depth = dir.join("bad.depth");
    std::fs::write(&bad_depth, "1 2 3 4\n1 nan 3 4\n").unwrap();
    let rib = dir.join("tiny.rib");
    std::fs::write(&rib, "Format 4 2 1\nProjection \"perspective\" \"fov\" [40]\nWorldBegin\nWorldEnd\n")
        .unwrap();
    let out = hybrid_view(&[s(&input), s(&bad_depth), s(&rib), "--headless"]);
    assert_eq!(out.status.code(), Some(1));
    assert!(String::from_utf8_lossy(&out.stderr).contains("bad.depth"));

    let not_an_image = dir.join("text.png");
    std::fs::write(&not_an_image, "hello").unwrap();
    let good_depth = dir.join("good.depth");
    std::fs::write(&good_depth, "1 2 3 4\n1 2 3 inf\n").unwrap();
    let out = hybrid_view(&[s(&not_an_image), s(&good_depth), s(&rib), "--headless"]);
    assert_eq!(out.status.code(), Some(1));

    let bad_rib = dir.join("bad.rib");
    std::fs::write(&bad_rib, "Format 4 2 1\nWorldBegin\nSphere 1 \"oops\"\n").unwrap();
    let out = hybrid_view(&[s(&input), s(&good_depth), s(&bad_rib), "--headless"]);
    assert_eq!(out.status.code(), Some(1));
    assert!(String::from_utf8_lossy(&out.stderr).contains("bad.rib:"));

    let out = hybrid_view(&[s(&dir.join("missing.png")), s(&good_depth), s(&rib), "--headless"]);
    assert_eq!(out.status.code(), Some(1));

    // And a good run on the tiny scene: the replica holds for a 4x2 image too.
    let shot = dir.join("shot.png");
    let out = hybrid_view(&[s(&input), s(&good_depth), s(&rib), "--headless", "--screenshot", s(&shot)]);
    assert_eq!(out.status.code(), Some(0));
    assert!(image::open(&shot).unwrap().to_rgba8() == image::open(&input).unwrap().to_rgba8());
}

#[test]
fn bad_command_lines_exit_with_2() {
    for args in [
        vec![],
        vec!["a.png", "a.depth"],
        vec!["a.png", "a.depth", "a.rib", "--sphere", "1,2"],
        vec!["a.png", "a.depth", "a.rib", "--radius", "-1"],
        vec!["a.png", "a.depth", "a.rib", "--mode", "triangles"],
        vec!["a.png", "a.depth", "a.rib", "--frames", "0"],
        vec!["a.png", "a.depth", "a.rib", "--no-such-flag"],
    ] {
        let out = hybrid_view(&args);
        assert_eq!(out.status.code(), Some(2), "{args:?}");
    }
    let out = hybrid_view(&["--help"]);
    assert_eq!(out.status.code(), Some(0));
}

/// An OpenEXR image is shown with the one display encoding (the RIB's Exposure 1 1: sRGB, with
/// Quantize's dither), and `--screenshot OUT.exr` gives its linear values back bit for bit.
#[test]
fn exr_input_is_displayed_with_srgb_and_written_back_linear() {
    let scratch_dir = scratch("exr");
    let dir = scratch_dir.path();
    let exr = cornell().join("reference-path-11520spp.exr");
    let (shot, linear_shot) = (dir.join("shot.png"), dir.join("shot.exr"));
    for out in [&shot, &linear_shot] {
        let out = hybrid_view(&[
            s(&exr),
            s(&cornell().join("depth-analytic.exr")),
            s(&cornell().join("cornell.rib")),
            "--headless",
            "--screenshot",
            s(out),
        ]);
        assert_eq!(out.status.code(), Some(0), "{}", String::from_utf8_lossy(&out.stderr));
    }
    let got = image::open(&shot).unwrap().to_rgba8();
    let linear = image::open(&exr).unwrap().to_rgba32f();
    let encoding = viewer::DisplayEncoding::for_float_image(1.0);
    assert_eq!(encoding.transfer, viewer::DisplayTransfer::Srgb);
    let width = linear.width();
    for ((x, y, g), l) in got.enumerate_pixels().zip(linear.pixels()) {
        for c in 0..3 {
            assert_eq!(g.0[c], encoding.encode(l.0[c], x, y, width, c as u32), "pixel ({x}, {y})");
        }
        assert_eq!(g.0[3], 255);
    }
    let back = image::open(&linear_shot).unwrap().to_rgb32f();
    assert_eq!(back.dimensions(), linear.dimensions());
    for (b, l) in back.pixels().zip(linear.pixels()) {
        for c in 0..3 {
            assert_eq!(b.0[c].to_bits(), l.0[c].to_bits());
        }
    }
}

/// The window shows what a headless run writes (needs an X display; fails without one).
#[test]
fn window_screenshot_equals_headless() {
    assert!(std::env::var_os("DISPLAY").is_some(), "no X display: run `cargo xtask test`, which starts Xvfb");
    let scratch_dir = scratch("window");
    let dir = scratch_dir.path();
    let input = dir.join("in.png");
    write_noise_png(&input, 512, 512);
    let common = [
        s(&input).to_string(),
        s(&cornell().join("depth-analytic.depth")).to_string(),
        s(&cornell().join("cornell.rib")).to_string(),
        "--sphere".into(),
        "0.2,-0.3,0.2".into(),
        "--radius".into(),
        "0.25".into(),
    ];
    let window_shot = dir.join("window.png");
    let headless_shot = dir.join("headless.png");
    let mut args: Vec<&str> = common.iter().map(String::as_str).collect();
    args.extend(["--frames", "2", "--screenshot", s(&window_shot)]);
    assert_eq!(hybrid_view(&args).status.code(), Some(0));
    let mut args: Vec<&str> = common.iter().map(String::as_str).collect();
    args.extend(["--headless", "--screenshot", s(&headless_shot)]);
    assert_eq!(hybrid_view(&args).status.code(), Some(0));
    let a = image::open(&window_shot).unwrap().to_rgba8();
    let b = image::open(&headless_shot).unwrap().to_rgba8();
    assert!(a == b, "the window's frame differs from the headless frame");
}
