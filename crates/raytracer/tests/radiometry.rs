//! Integrators against closed forms: furnaces (an emitting, reflecting enclosure has radiance
//! `Le / (1 - albedo)` everywhere) and RenderMan's matte under a point light.

use glam::{DVec3, Vec3};
use raytracer::integrators::IntegratorKind;
use raytracer::render::{RenderOptions, render};
use raytracer::testing::{SceneBuilder, shader, sphere_furnace};
use rib_parser::scene::{Attributes, LightKind};

fn options(integrator: IntegratorKind, spp: u32) -> RenderOptions {
    RenderOptions {
        spp: Some(spp),
        seed: 7,
        integrator: Some(integrator),
        threads: Some(2),
        ..RenderOptions::default()
    }
}

const PATH: IntegratorKind = IntegratorKind::Path { max_depth: 1024, rr_depth: 5 };

#[test]
fn sphere_furnace_path_traced_is_le_over_one_minus_albedo() {
    let out = render(&sphere_furnace(), &options(PATH, 64)).unwrap();
    let mean = out.image.mean_rgb();
    assert!((mean - Vec3::splat(2.0)).abs().max_element() < 0.03, "mean {mean}");
    // Every pixel: no leaks, no NaN.
    for p in &out.image.pixels {
        assert!(p[0].is_finite() && p[0] > 1.0 && p[3] == 1.0, "{p:?}");
    }
}

#[test]
fn sphere_furnace_direct_lighting_is_one_bounce() {
    let out =
        render(&sphere_furnace(), &options(IntegratorKind::DirectLighting { max_depth: 5 }, 16)).unwrap();
    let mean = out.image.mean_rgb();
    assert!((mean - Vec3::splat(1.5)).abs().max_element() < 0.02, "mean {mean}");
}

/// A closed cube of polygons whose faces point inward, emitting 0.5 and with albedo 0.75: L = 2.
#[test]
fn cube_furnace_path_traced() {
    let mut b =
        SceneBuilder::perspective(12, 12, 70.0, DVec3::new(0.2, -0.1, 0.0), DVec3::new(0.0, 0.3, -1.0));
    let light = b.light(LightKind::Area { intensity: 0.5, color: Vec3::ONE }, "arealight");
    let a = b.attributes(Attributes {
        color: Vec3::splat(0.75),
        surface: Some(shader("matte", &[("Kd", 1.0), ("Ka", 0.0)])),
        area_light: Some(light),
        ..Attributes::default()
    });
    let c = |x: f32, y: f32, z: f32| Vec3::new(x, y, z);
    let faces = [
        [c(-1., -1., -1.), c(1., -1., -1.), c(1., -1., 1.), c(-1., -1., 1.)], // floor, +y
        [c(-1., 1., -1.), c(-1., 1., 1.), c(1., 1., 1.), c(1., 1., -1.)],     // ceiling, -y
        [c(-1., -1., -1.), c(-1., 1., -1.), c(1., 1., -1.), c(1., -1., -1.)], // back, +z
        [c(-1., -1., 1.), c(1., -1., 1.), c(1., 1., 1.), c(-1., 1., 1.)],     // front, -z
        [c(-1., -1., -1.), c(-1., -1., 1.), c(-1., 1., 1.), c(-1., 1., -1.)], // left, +x
        [c(1., -1., -1.), c(1., 1., -1.), c(1., 1., 1.), c(1., -1., 1.)],     // right, -x
    ];
    for f in &faces {
        let n = (f[1] - f[0]).cross(f[2] - f[0]);
        let centre = (f[0] + f[1] + f[2] + f[3]) / 4.0;
        // Wind every face so that its normal points into the cube (emission goes inward).
        let mut f = *f;
        if n.dot(-centre) < 0.0 {
            f.reverse();
        }
        b.polygon(&f, a);
    }
    let out = render(&b.build(), &options(PATH, 64)).unwrap();
    let mean = out.image.mean_rgb();
    assert!((mean - Vec3::splat(2.0)).abs().max_element() < 0.04, "mean {mean}");
}

/// A matte plane lit by a point light straight above: RenderMan's `Kd Cs I cos / d^2`.
#[test]
fn matte_under_point_light_matches_renderman() {
    let mut b = SceneBuilder::perspective(9, 9, 10.0, DVec3::new(0.0, 5.0, 0.0), DVec3::ZERO);
    b.light(
        LightKind::Point { position: DVec3::new(0.0, 2.0, 0.0), intensity: 8.0, color: Vec3::ONE },
        "pointlight",
    );
    let a = b.attributes(Attributes {
        color: Vec3::new(0.5, 0.25, 1.0),
        surface: Some(shader("matte", &[("Kd", 0.8), ("Ka", 0.0)])),
        ..Attributes::default()
    });
    b.light_everything();
    b.polygon(
        &[
            Vec3::new(-5.0, 0.0, -5.0),
            Vec3::new(-5.0, 0.0, 5.0),
            Vec3::new(5.0, 0.0, 5.0),
            Vec3::new(5.0, 0.0, -5.0),
        ],
        a,
    );
    let mut scene = b.build();
    scene.render.pixel_filter =
        rib_parser::scene::PixelFilter { name: "box".into(), x_width: 1.0, y_width: 1.0 };
    let out = render(&scene, &options(IntegratorKind::DirectLighting { max_depth: 5 }, 1)).unwrap();
    // The centre pixel sees the point under the light: cos = 1, d = 2.
    let centre = out.image.rgb(4, 4);
    let expected = Vec3::new(0.5, 0.25, 1.0) * 0.8 * 8.0 / 4.0;
    assert!(
        (centre - expected).abs().max_element() < 0.01 * expected.max_element(),
        "{centre} vs {expected}"
    );
}
