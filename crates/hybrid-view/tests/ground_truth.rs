//! Co-location against the ray tracer's own renders: the Cornell box rendered once with a
//! constant-colour sphere and once without; the second is composited with `--sphere` at the same
//! position, and the sphere's mask must match the first render (CONTRACTS.md §5, issue 6),
//! including where the sphere passes behind the tall box and where it cuts through a wall.
//!
//! Two ground truths:
//! - the depth tables: the sphere is visible at a pixel exactly where the with-sphere table is
//!   nearer than the without-sphere one (pixel-centre rays, no antialiasing): the masks must
//!   agree everywhere except where the two distances agree to 1e-5;
//! - the colours: the sphere's coverage of each pixel from the two renders (box filter),
//!   thresholded at one half: IoU >= 0.99, disagreements only on antialiased boundary pixels
//!   (coverage between 0.05 and 0.95).
//!
//! The normal suite renders with the `raytracer` library (what `lrt-depth` runs) at 384x384;
//! `cargo xtask colocation` runs the ignored test, which renders with the `lrt-depth` binary
//! itself at the scene's 512x512.

use raytracer::integrators::IntegratorKind;
use raytracer::render::{RenderOptions, render};
use std::path::{Path, PathBuf};
use std::process::Command;

const CASES: [(&str, [f64; 3], f64); 2] = [
    ("passing behind the tall box", [-0.35, 0.25, -0.8], 0.25),
    ("cutting through the red wall", [-1.0, 0.2, 0.0], 0.3),
];

/// The Cornell RIB at `size`, direct lighting only (so a pixel is `alpha * sphere + s *
/// background`), with the sphere when asked, writing its outputs to `outputs` when given.
fn cornell_rib(size: u32, sphere: Option<([f64; 3], f64)>, outputs: Option<(&Path, &Path)>) -> String {
    let path = concat!(env!("CARGO_MANIFEST_DIR"), "/../../../shared/reference/cornell/cornell.rib");
    let mut text = std::fs::read_to_string(path).unwrap();
    text = text.replace(
        "Format 512 512 1",
        &format!("Format {size} {size} 1\nSurfaceIntegrator \"directlighting\""),
    );
    if let Some((image, depth)) = outputs {
        text = text
            .replace("\"cornell.exr\"", &format!("\"{}\"", image.display()))
            .replace("[\"cornell.depth\"]", &format!("[\"{}\"]", depth.display()));
    }
    if let Some(([x, y, z], r)) = sphere {
        text = text.replace(
            "WorldEnd",
            &format!(
                "  AttributeBegin\n    Color [0 0 1]\n    Surface \"constant\"\n    Translate {x} {y} {z}\n    Sphere {r} {} {r} 360\n  AttributeEnd\nWorldEnd",
                -r
            ),
        );
    }
    text
}

struct Render {
    size: u32,
    rgb: Vec<[f32; 3]>,
    depth: depth_remap::DepthTable,
}

fn render_with_library(rib: &str, size: u32) -> Render {
    let loaded = rib_parser::load_bytes("cornell.rib", rib.as_bytes().to_vec(), &Default::default()).unwrap();
    let options = RenderOptions {
        threads: None,
        spp: Some(16),
        seed: 7,
        integrator: Some(IntegratorKind::DirectLighting { max_depth: 1 }),
        depth: true,
        layers: false,
        progress: None,
        ..Default::default()
    };
    let out = render(&loaded.scene, &options).unwrap();
    let rgb = out.image.pixels.iter().map(|p| [p[0], p[1], p[2]]).collect();
    Render { size, rgb, depth: out.depth.unwrap().to_table().unwrap() }
}

fn s(p: &Path) -> &str {
    p.to_str().unwrap()
}

/// A scratch directory for one test, removed when the test ends.
fn scratch(name: &str) -> tempfile::TempDir {
    tempfile::Builder::new().prefix(&format!("hybrid-view-{name}-")).tempdir().unwrap()
}

/// Runs `hybrid-view --headless --sphere ... --mask` and returns the mask.
fn composite_mask(
    image: &Path,
    depth: &Path,
    rib: &Path,
    centre: [f64; 3],
    radius: f64,
    dir: &Path,
) -> Vec<u8> {
    let mask_path = dir.join("mask.png");
    let sphere = format!("{},{},{}", centre[0], centre[1], centre[2]);
    let radius_text = radius.to_string();
    let out = Command::new(env!("CARGO_BIN_EXE_hybrid-view"))
        .args([s(image), s(depth), s(rib), "--headless", "--sphere", &sphere])
        .args(["--radius", &radius_text, "--mask", s(&mask_path)])
        .output()
        .unwrap();
    assert_eq!(out.status.code(), Some(0), "{}", String::from_utf8_lossy(&out.stderr));
    image::open(&mask_path).unwrap().to_luma8().into_raw()
}

/// Compares the composited mask with both ground truths and asserts the agreement.
fn check(what: &str, without: &Render, with: &Render, mask: &[u8]) {
    let n = (without.size * without.size) as usize;
    assert_eq!(mask.len(), n);
    let (mut both, mut either, mut off) = (0usize, 0usize, 0usize);
    for (k, &m) in mask.iter().enumerate() {
        let (d0, d1) = (without.depth.values()[k], with.depth.values()[k]);
        let truth = d1 < d0;
        let got = m == 255;
        both += usize::from(truth && got);
        either += usize::from(truth || got);
        off += usize::from(truth != got && (d0 - d1).abs() > 1e-5 * d0);
    }
    let iou_depth = both as f64 / either as f64;
    // Coverage alpha of the blue, unlit sphere: with one light and direct lighting only a pixel
    // is alpha * (0, 0, 1) + s * background, so red gives s and blue then gives alpha.
    let (mut both_c, mut either_c, mut off_c) = (0usize, 0usize, 0usize);
    for (k, &m) in mask.iter().enumerate() {
        let (b, c) = (without.rgb[k], with.rgb[k]);
        let alpha = if b[0] > 1e-6 { c[2] - c[0] * b[2] / b[0] } else { c[2] };
        let truth = alpha >= 0.5;
        let got = m == 255;
        both_c += usize::from(truth && got);
        either_c += usize::from(truth || got);
        off_c += usize::from(truth != got && !(0.05..=0.95).contains(&alpha));
    }
    let iou_colour = both_c as f64 / either_c as f64;
    eprintln!(
        "{what} ({0}x{0}): depth IoU {iou_depth:.5} ({off} off, {either} px), colour IoU {iou_colour:.5} \
         ({off_c} off the antialiased boundary)",
        without.size
    );
    assert!(either > 300, "{what}: the sphere is visible");
    assert!(iou_depth >= 0.999 && off == 0, "{what}: depth IoU {iou_depth}, {off} pixels off");
    assert!(iou_colour >= 0.99, "{what}: colour IoU {iou_colour}");
    assert_eq!(off_c, 0, "{what}: disagreements away from antialiased boundary pixels");
}

#[test]
fn sphere_mask_matches_the_ray_traced_sphere() {
    let size = 384;
    let scratch_dir = scratch("ground-truth");
    let dir = scratch_dir.path();
    let without = render_with_library(&cornell_rib(size, None, None), size);
    // hybrid-view's inputs: the image (any 8-bit encoding will do for masks), the depth table
    // and the RIB, all without the sphere.
    let image_path = dir.join("without.png");
    let bytes: Vec<u8> =
        without.rgb.iter().flat_map(|c| c.map(|v| (v.clamp(0.0, 1.0) * 255.0).round() as u8)).collect();
    image::RgbImage::from_raw(size, size, bytes).unwrap().save(&image_path).unwrap();
    let depth_path = dir.join("without.depth");
    without.depth.write(&depth_path).unwrap();
    let rib_path = dir.join("cornell.rib");
    std::fs::write(&rib_path, cornell_rib(size, None, None)).unwrap();
    for (what, centre, radius) in CASES {
        let with = render_with_library(&cornell_rib(size, Some((centre, radius)), None), size);
        let mask = composite_mask(&image_path, &depth_path, &rib_path, centre, radius, dir);
        check(what, &without, &with, &mask);
    }
}

/// Renders `rib` with the `lrt-depth` binary named by `LRT_DEPTH` and reads its outputs.
fn render_with_lrt_depth(
    lrt_depth: &Path,
    rib: &str,
    dir: &Path,
    name: &str,
    size: u32,
) -> (Render, PathBuf, PathBuf) {
    let image = dir.join(format!("{name}.exr"));
    let depth = dir.join(format!("{name}.depth"));
    let rib_path = dir.join(format!("{name}.rib"));
    std::fs::write(&rib_path, rib).unwrap();
    let out = Command::new(lrt_depth).args([s(&rib_path), "--spp", "16", "--quiet"]).output().unwrap();
    assert_eq!(out.status.code(), Some(0), "lrt-depth: {}", String::from_utf8_lossy(&out.stderr));
    let rgb = image::open(&image).unwrap().to_rgb32f().pixels().map(|p| p.0).collect();
    let table = depth_remap::DepthTable::read(&depth).unwrap();
    (Render { size, rgb, depth: table }, image, depth)
}

/// The same check with `lrt-depth` itself at the scene's full 512x512: run by
/// `cargo xtask colocation`, which builds `lrt-depth` and sets `LRT_DEPTH`.
#[test]
#[ignore = "renders with the lrt-depth binary at 512x512; run by `cargo xtask colocation`"]
fn lrt_depth_renders_agree_at_full_resolution() {
    let lrt_depth =
        PathBuf::from(std::env::var_os("LRT_DEPTH").expect("LRT_DEPTH: the lrt-depth binary to test with"));
    let size = 512;
    let scratch_dir = scratch("lrt-depth-ground-truth");
    let dir = scratch_dir.path();
    let without_rib = cornell_rib(size, None, Some((&dir.join("without.exr"), &dir.join("without.depth"))));
    let (without, image, depth) = render_with_lrt_depth(&lrt_depth, &without_rib, dir, "without", size);
    let rib_path = dir.join("without.rib");
    for (k, (what, centre, radius)) in CASES.into_iter().enumerate() {
        let name = format!("with{k}");
        let rib = cornell_rib(
            size,
            Some((centre, radius)),
            Some((&dir.join(format!("{name}.exr")), &dir.join(format!("{name}.depth")))),
        );
        let (with, _, _) = render_with_lrt_depth(&lrt_depth, &rib, dir, &name, size);
        let mask = composite_mask(&image, &depth, &rib_path, centre, radius, dir);
        check(what, &without, &with, &mask);
    }
}
