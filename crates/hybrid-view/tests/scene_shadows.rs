//! The scene's own shadows on live objects: a matte sphere composited with `--live` under a
//! point light that a shelf of the scene partly hides is as dark where the shelf shadows it as
//! the ray tracer renders the same sphere in the scene (direct lighting, so a shadowed point
//! gets nothing). Without the scene's triangles in the viewer the shadowed half was lit.

mod common;

use common::{LIVE, composite_live, render_rib};

const LIGHT: &str = "LightSource \"pointlight\" 1 \"intensity\" [3] \"from\" [1.5 2.5 -1]";

/// A floor, and a shelf at height 1.5 whose edge runs between the light and the sphere, so its
/// shadow covers about half of the sphere's visible pixels.
fn scene(live: bool) -> String {
    format!(
        "Format 96 96 1\nProjection \"perspective\" \"fov\" [40]\nTranslate 0 -0.5 5\nWorldBegin\n{LIGHT}\n\
         AttributeBegin\n  Surface \"matte\"\n  Polygon \"P\" [-4 0 -4  -4 0 4  4 0 4  4 0 -4]\nAttributeEnd\n\
         AttributeBegin\n  Surface \"matte\"\n  Polygon \"P\" [0.85 1.5 -3  0.85 1.5 2  3 1.5 2  3 1.5 -3]\nAttributeEnd\n\
         {}WorldEnd\n",
        if live { LIVE } else { "" }
    )
}

#[test]
fn a_live_sphere_in_a_scene_shadow_gets_no_direct_light_there_as_the_ray_tracer_renders_it() {
    let dir = tempfile::Builder::new().prefix("hybrid-view-scene-shadows-").tempdir().unwrap();
    let truth = render_rib(&scene(true), None);
    let composite = composite_live(dir.path(), &scene(false), &["--stats"]);
    let stderr = &composite.stderr;
    assert!(stderr.contains("scene shadows on live objects: 4 triangles"), "{stderr}");
    let (mask, composite) = (composite.mask, composite.image);
    let (mut sum_composite, mut sum_truth, mut inside) = ([0.0f64; 3], [0.0f64; 3], 0);
    let (mut dark, mut dark_but_lit) = (0, 0);
    for (k, (m, c)) in mask.pixels().zip(composite.pixels()).enumerate() {
        // Whole sphere pixels only: the ray tracer's edge pixels blend in the floor.
        let (x, y) = ((k % 96) as i32, (k / 96) as i32);
        let interior = (-1..=1).all(|dy| {
            (-1..=1).all(|dx| {
                let (xx, yy) = (x + dx, y + dy);
                (0..96).contains(&xx)
                    && (0..96).contains(&yy)
                    && mask.get_pixel(xx as u32, yy as u32).0[0] == 255
            })
        });
        if m.0[0] != 255 || !interior {
            continue;
        }
        inside += 1;
        for ch in 0..3 {
            sum_composite[ch] += f64::from(c.0[ch]);
            sum_truth[ch] += f64::from(truth[k][ch]);
        }
        // Fully in the shelf's shadow in the truth (direct light only: nothing reaches it).
        if truth[k][0] == 0.0 {
            dark += 1;
            dark_but_lit += usize::from(c.0[0] > 1e-3);
        }
    }
    assert!(inside > 300 && dark > 60, "{inside} pixels inside, {dark} of them in the shelf's shadow");
    // Pixels on the shadow's edge (16 samples of the truth against one of the viewer) may differ.
    assert!(dark_but_lit * 10 <= dark, "{dark_but_lit} of {dark} shadowed pixels lit");
    for ch in 0..3 {
        let ratio = sum_composite[ch] / sum_truth[ch];
        assert!((ratio - 1.0).abs() < 0.05, "channel {ch}: composite / ray traced = {ratio}");
    }
}
