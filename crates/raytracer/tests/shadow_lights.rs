//! RenderMan's shadow-map lights rendered with exact ray-traced shadows, and
//! `Imager "background"`, read from RIB as a user writes them.

use glam::Vec3;
use raytracer::integrators::IntegratorKind;
use raytracer::render::{RenderOptions, RenderOutput, render};
use rib_parser::{LoadOptions, load_bytes};

/// A 9x9 view straight down from 5 units onto a matte plane at y = 0 (box filter, 1 sample),
/// with `light` and `extra` requests in the world.
fn scene_rib(light: &str, extra: &str, plane_half: f32) -> String {
    let h = plane_half;
    format!(
        r#"Format 9 9 1
PixelFilter "box" 1 1
Projection "perspective" "fov" [10]
{extra}
Rotate -90 1 0 0
Translate 0 -5 0
WorldBegin
  {light}
  Sides 2
  Color [0.5 0.25 1]
  Surface "matte" "Kd" [0.8] "Ka" [0]
  Polygon "P" [-{h} 0 -{h}  -{h} 0 {h}  {h} 0 {h}  {h} 0 -{h}]
WorldEnd
"#
    )
}

fn occluder() -> &'static str {
    "AttributeBegin\n  Translate 0 1 0\n  Sphere 0.25 -0.25 0.25 360\n  AttributeEnd"
}

fn draw(rib: &str) -> RenderOutput {
    let loaded = load_bytes("shadow.rib", rib.as_bytes().to_vec(), &LoadOptions::default())
        .unwrap_or_else(|e| panic!("{}", e.render()));
    let options = RenderOptions {
        spp: Some(1),
        seed: 3,
        integrator: Some(IntegratorKind::DirectLighting { max_depth: 5 }),
        threads: Some(2),
        ..RenderOptions::default()
    };
    render(&loaded.scene, &options).unwrap()
}

const SPOT_PARAMS: &str =
    r#""intensity" [8] "from" [0 2 0] "to" [0 0 0] "coneangle" [0.6] "conedeltaangle" [0.1]"#;

#[test]
fn shadowspot_is_the_spotlight_with_exact_shadows() {
    let shadowspot = format!(
        r#"LightSource "shadowspot" 1 {SPOT_PARAMS} "shadowname" ["spot.shad"] "blur" [0.05] "samples" [16]"#
    );
    let spotlight = format!(r#"LightSource "spotlight" 1 {SPOT_PARAMS}"#);

    // Unoccluded: RenderMan's matte under a spotlight on its axis, Kd Cs I / d^2 (cos = 1,
    // inside the cone's full-intensity core).
    let open = draw(&scene_rib(&shadowspot, "", 5.0));
    let expected = Vec3::new(0.5, 0.25, 1.0) * 0.8 * 8.0 / 4.0;
    let centre = open.image.rgb(4, 4);
    assert!(
        (centre - expected).abs().max_element() < 0.01 * expected.max_element(),
        "{centre} vs {expected}"
    );
    assert_eq!(open.image.pixels, draw(&scene_rib(&spotlight, "", 5.0)).image.pixels);

    // A sphere between the light and the plane: the plane points whose path to the light it
    // blocks (pixel 8 of the middle row, seen past the sphere) are exactly black, as with the
    // standard spotlight, which the ray tracer always shadows.
    let lit = open.image.rgb(8, 4);
    assert!(lit.min_element() > 0.1, "{lit}");
    let light_and_occluder = format!("{shadowspot}\n  {}", occluder());
    let shadowed = draw(&scene_rib(&light_and_occluder, "", 5.0));
    assert_eq!(shadowed.image.rgb(8, 4), Vec3::ZERO);
    let spot_and_occluder = format!("{spotlight}\n  {}", occluder());
    assert_eq!(shadowed.image.pixels, draw(&scene_rib(&spot_and_occluder, "", 5.0)).image.pixels);
}

#[test]
fn shadowpoint_and_shadowdistant_are_point_and_distant_lights() {
    for (shadowed, standard) in [
        (
            r#"LightSource "shadowpoint" 1 "intensity" [8] "from" [0 2 0] "sfpx" ["a.shad"]"#,
            r#"LightSource "pointlight" 1 "intensity" [8] "from" [0 2 0]"#,
        ),
        (
            r#"LightSource "shadowdistant" 1 "intensity" [2] "from" [1 3 0] "to" [0 0 0] "shadowname" ["d.shad"]"#,
            r#"LightSource "distantlight" 1 "intensity" [2] "from" [1 3 0] "to" [0 0 0]"#,
        ),
    ] {
        let a = draw(&scene_rib(&format!("{shadowed}\n  {}", occluder()), "", 5.0));
        let b = draw(&scene_rib(&format!("{standard}\n  {}", occluder()), "", 5.0));
        assert!(a.image.mean_rgb().max_element() > 0.05, "{shadowed}: lit");
        assert_eq!(a.image.pixels, b.image.pixels, "{shadowed}");
    }
}

#[test]
fn imager_background_fills_where_rays_miss() {
    let light = format!(r#"LightSource "spotlight" 1 {SPOT_PARAMS}"#);
    let background = r#"Imager "background" "color background" [0.2 0.4 0.6]"#;
    // A small plane: the corners of the frame see nothing.
    let plain = draw(&scene_rib(&light, "", 0.3));
    let with_bg = draw(&scene_rib(&light, background, 0.3));
    let corner = with_bg.image.pixels[0];
    assert_eq!([corner[0], corner[1], corner[2], corner[3]], [0.2, 0.4, 0.6, 0.0]);
    assert_eq!(plain.image.pixels[0], [0.0; 4]);
    // Covered pixels are unchanged (alpha 1 leaves nothing of the background).
    let c = 4 * 9 + 4;
    assert_eq!(with_bg.image.pixels[c], plain.image.pixels[c]);
    assert_eq!(with_bg.image.pixels[c][3], 1.0);
}
