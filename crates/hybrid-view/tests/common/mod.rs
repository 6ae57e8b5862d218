//! What the tests that compare a `--live` composite with the ray tracer's render share: the
//! live sphere, rendering a RIB with direct lighting, and compositing the sphere over a render.

use raytracer::integrators::IntegratorKind;
use raytracer::output::{OutputSettings, write_image};
use raytracer::render::{RenderOptions, render};
use std::path::Path;
use std::process::Command;

/// The live object: a matte sphere of radius 0.5 resting on the floor `y = 0`.
pub const LIVE: &str = "AttributeBegin\n  Color [0.9 0.6 0.3]\n  Surface \"matte\"\n  \
    Translate 0.2 0.5 0.1\n  Sphere 0.5 -0.5 0.5 360\nAttributeEnd\n";

/// Renders `rib` with direct lighting; writes the image (and the depth table) when asked.
pub fn render_rib(rib: &str, outputs: Option<(&Path, &Path)>) -> Vec<[f32; 4]> {
    let loaded = rib_parser::load_bytes("scene.rib", rib.as_bytes().to_vec(), &Default::default()).unwrap();
    let options = RenderOptions {
        threads: Some(2),
        spp: Some(16),
        seed: 3,
        integrator: Some(IntegratorKind::DirectLighting { max_depth: 1 }),
        depth: true,
        layers: false,
        ..Default::default()
    };
    let out = render(&loaded.scene, &options).unwrap();
    if let Some((image, depth)) = outputs {
        let settings =
            OutputSettings { exposure: Default::default(), quantize: Default::default(), alpha: false };
        write_image(image, "openexr", &out.image, &settings).unwrap();
        out.depth.unwrap().to_table().unwrap().write(depth).unwrap();
    }
    out.image.pixels
}

/// A `--live` composite of [`LIVE`] over the render of `without` (a RIB without it), made in
/// `dir`: the linear screenshot, the live mask and hybrid-view's standard error.
pub struct Composite {
    pub image: image::Rgb32FImage,
    pub mask: image::GrayImage,
    // Each test binary compiles this module; not every one reads the standard error.
    #[allow(dead_code)]
    pub stderr: String,
}

/// Renders `without`, composites [`LIVE`] over it with `hybrid-view` (plus `extra_args`) and
/// returns the composite; the process must succeed.
pub fn composite_live(dir: &Path, without: &str, extra_args: &[&str]) -> Composite {
    let (image, depth, rib) = (dir.join("without.exr"), dir.join("without.depth"), dir.join("without.rib"));
    std::fs::write(&rib, without).unwrap();
    render_rib(without, Some((&image, &depth)));
    let live = dir.join("live.rib");
    std::fs::write(&live, LIVE).unwrap();
    let (shot, mask) = (dir.join("shot.exr"), dir.join("mask.png"));
    let p = |p: &Path| p.to_str().unwrap().to_string();
    let out = Command::new(env!("CARGO_BIN_EXE_hybrid-view"))
        .args([p(&image), p(&depth), p(&rib), "--headless".into(), "--live".into(), p(&live)])
        .args(["--screenshot".into(), p(&shot), "--mask".into(), p(&mask)])
        .args(extra_args)
        .output()
        .unwrap();
    let stderr = String::from_utf8_lossy(&out.stderr).into_owned();
    assert_eq!(out.status.code(), Some(0), "{stderr}");
    Composite {
        image: image::open(&shot).unwrap().to_rgb32f(),
        mask: image::open(&mask).unwrap().to_luma8(),
        stderr,
    }
}
