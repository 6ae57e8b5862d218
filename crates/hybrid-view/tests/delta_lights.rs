//! Live objects under RenderMan's point, spot and distant lights are as bright as the ray
//! tracer renders the same object: both apply RenderMan's convention that these lights'
//! `diffuse()` has no `1/pi` (`rib_parser::scene::RENDERMAN_DELTA_LIGHT_SCALE`). A matte sphere
//! composited with `--live` over a direct-lit render of a floor is compared, inside the
//! viewer's mask, with the ray tracer's render of the scene with the sphere in it.

mod common;

use common::{LIVE, composite_live, render_rib};

fn scene(light: &str, live: bool) -> String {
    format!(
        "Format 96 96 1\nProjection \"perspective\" \"fov\" [40]\nTranslate 0 -0.5 5\nWorldBegin\n{light}\n\
         AttributeBegin\n  Surface \"matte\"\n  Polygon \"P\" [-4 0 -4  -4 0 4  4 0 4  4 0 -4]\nAttributeEnd\n{}WorldEnd\n",
        if live { LIVE } else { "" }
    )
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
        let truth = render_rib(&scene(light, true), None);
        let composite = composite_live(dir.path(), &scene(light, false), &[]);
        let (mask, composite) = (composite.mask, composite.image);
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
