//! Live objects under RenderMan's point, spot and distant lights are as bright as the ray
//! tracer renders the same object: both apply RenderMan's convention that these lights'
//! `diffuse()` has no `1/pi` (`rib_parser::scene::RENDERMAN_DELTA_LIGHT_SCALE`). A matte sphere
//! composited with `--live` over a direct-lit render of a floor is compared, inside the
//! viewer's mask, with the ray tracer's render of the scene with the sphere in it.

use raytracer::integrators::IntegratorKind;
use raytracer::output::{OutputSettings, write_image};
use raytracer::render::{RenderOptions, render};
use std::path::Path;
use std::process::Command;

const LIVE: &str = "AttributeBegin\n  Color [0.9 0.6 0.3]\n  Surface \"matte\"\n  \
    Translate 0.2 0.5 0.1\n  Sphere 0.5 -0.5 0.5 360\nAttributeEnd\n";

fn scene(light: &str, live: bool) -> String {
    format!(
        "Format 96 96 1\nProjection \"perspective\" \"fov\" [40]\nTranslate 0 -0.5 5\nWorldBegin\n{light}\n\
         AttributeBegin\n  Surface \"matte\"\n  Polygon \"P\" [-4 0 -4  -4 0 4  4 0 4  4 0 -4]\nAttributeEnd\n{}WorldEnd\n",
        if live { LIVE } else { "" }
    )
}

/// Renders `rib` with direct lighting; writes the image (and the depth table) when asked.
fn render_rib(rib: &str, outputs: Option<(&Path, &Path)>) -> Vec<[f32; 4]> {
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

#[test]
fn live_objects_under_delta_lights_are_as_bright_as_the_ray_tracer_renders_them() {
    let lights = [
        ("point", "LightSource \"pointlight\" 1 \"intensity\" [3] \"from\" [1.5 2.5 -1]"),
        (
            "spot",
            "LightSource \"spotlight\" 1 \"intensity\" [4] \"from\" [-1 3 -1] \"to\" [0.2 0.5 0.1] \
             \"coneangle\" [0.6] \"conedeltaangle\" [0.1] \"beamdistribution\" [2]",
        ),
        ("distant", "LightSource \"distantlight\" 1 \"intensity\" [0.8] \"from\" [1 2 -1.5] \"to\" [0 0 0]"),
    ];
    let dir = tempfile::Builder::new().prefix("hybrid-view-delta-lights-").tempdir().unwrap();
    for (name, light) in lights {
        let (image, depth, rib) = (
            dir.path().join("without.exr"),
            dir.path().join("without.depth"),
            dir.path().join("without.rib"),
        );
        let without = scene(light, false);
        std::fs::write(&rib, &without).unwrap();
        render_rib(&without, Some((&image, &depth)));
        let truth = render_rib(&scene(light, true), None);
        let live = dir.path().join("live.rib");
        std::fs::write(&live, LIVE).unwrap();
        let (shot, mask) = (dir.path().join("shot.exr"), dir.path().join("mask.png"));
        let p = |p: &Path| p.to_str().unwrap().to_string();
        let out = Command::new(env!("CARGO_BIN_EXE_hybrid-view"))
            .args([p(&image), p(&depth), p(&rib), "--headless".into(), "--live".into(), p(&live)])
            .args(["--screenshot".into(), p(&shot), "--mask".into(), p(&mask)])
            .output()
            .unwrap();
        assert_eq!(out.status.code(), Some(0), "{name}: {}", String::from_utf8_lossy(&out.stderr));
        let composite = image::open(&shot).unwrap().to_rgb32f();
        let mask = image::open(&mask).unwrap().to_luma8();
        let (mut sum_composite, mut sum_truth, mut inside) = ([0.0f64; 3], [0.0f64; 3], 0);
        for (k, (m, c)) in mask.pixels().zip(composite.pixels()).enumerate() {
            // Whole sphere pixels only: the ray tracer's edge pixels blend in the floor.
            let (x, y) = ((k % 96) as u32, (k / 96) as u32);
            let interior = [(-1i32, 0i32), (1, 0), (0, -1), (0, 1)].iter().all(|(dx, dy)| {
                let (xx, yy) = (x as i32 + dx, y as i32 + dy);
                (0..96).contains(&xx)
                    && (0..96).contains(&yy)
                    && mask.get_pixel(xx as u32, yy as u32).0[0] == 255
            });
            if m.0[0] != 255 || !interior {
                continue;
            }
            inside += 1;
            for ch in 0..3 {
                sum_composite[ch] += f64::from(c.0[ch]);
                sum_truth[ch] += f64::from(truth[k][ch]);
            }
        }
        assert!(inside > 300, "{name}: {inside} pixels inside");
        for ch in 0..3 {
            let ratio = sum_composite[ch] / sum_truth[ch];
            assert!((ratio - 1.0).abs() < 0.04, "{name}, channel {ch}: composite / ray traced = {ratio}");
        }
    }
}
