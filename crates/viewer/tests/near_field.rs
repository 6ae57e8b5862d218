//! GPU tests of the irradiance probes' light on a live surface near a large scene surface
//! (docs/viewer-lighting.md, "The scene near a live object"): the probes sit a grid spacing
//! apart, so a sphere beside a wall would get the light the probes saw around it; within a
//! spacing the scene's triangles say what the fragment sees and the reflection probes what the
//! surfaces there send. Checked against the irradiance integrated over the hemisphere in f64.

mod common;

use common::*;
use glam::{DVec3, Vec3};
use std::f64::consts::PI;
use viewer::occluders::SceneOccluders;
use viewer::{CompositeMode, Compositor, CompositorSettings, LiveObjects, Material, Sphere, ViewerScene};

const CENTRE: DVec3 = DVec3::new(0.0, -0.2, 0.0);
const RADIUS: f64 = 0.3;
/// Radiance of the probe field: what the irradiance probes saw around them.
const FAR: f64 = 1.0;
/// Radiance of the wall beside the sphere, which no irradiance probe resolves.
const WALL: f64 = 0.2;

/// A square wall in the plane x = CENTRE.x - RADIUS - 0.15 (0.15 from the sphere), 1.4 on a side
/// about the sphere's centre: it hides nearly half of the hemisphere of the sphere's left side.
fn wall() -> Vec<[DVec3; 3]> {
    let x = CENTRE.x - RADIUS - 0.15;
    let c = [
        DVec3::new(x, CENTRE.y - 0.7, CENTRE.z - 0.7),
        DVec3::new(x, CENTRE.y + 0.7, CENTRE.z - 0.7),
        DVec3::new(x, CENTRE.y + 0.7, CENTRE.z + 0.7),
        DVec3::new(x, CENTRE.y - 0.7, CENTRE.z + 0.7),
    ];
    vec![[c[0], c[1], c[2]], [c[0], c[2], c[3]]]
}

fn meets(p: DVec3, dir: DVec3, tris: &[[DVec3; 3]]) -> bool {
    tris.iter().any(|t| {
        let (e1, e2) = (t[1] - t[0], t[2] - t[0]);
        let pv = dir.cross(e2);
        let det = e1.dot(pv);
        let tv = p - t[0];
        let (u, qv) = (tv.dot(pv) / det, tv.cross(e1));
        let v = dir.dot(qv) / det;
        u >= 0.0 && v >= 0.0 && u + v <= 1.0 && e2.dot(qv) / det > 0.0
    })
}

/// Irradiance at p (unit normal n) where the wall sends WALL and every other direction FAR: the
/// cosine-weighted hemisphere in 64 x 64 strata, in f64.
fn irradiance(p: DVec3, n: DVec3, tris: &[[DVec3; 3]]) -> f64 {
    let (t, b) = n.any_orthonormal_pair();
    let strata = 64;
    let mut sum = 0.0;
    for a in 0..strata {
        for c in 0..strata {
            let r = ((a as f64 + 0.5) / strata as f64).sqrt();
            let phi = 2.0 * PI * (c as f64 + 0.5) / strata as f64;
            let d = t * (r * phi.cos()) + b * (r * phi.sin()) + n * (1.0 - r * r).sqrt();
            sum += if meets(p, d, tris) { WALL } else { FAR };
        }
    }
    PI * sum / (strata * strata) as f64
}

/// One reflection probe right of the sphere that sees every point (its distance map reaches 10
/// in every direction) and radiance `l` in every direction.
fn reflection_probe(l: f32) -> sidecar::ReflectionProbes {
    let n = sidecar::REFLECTION_TEXELS;
    let levels = sidecar::reflection_levels(&vec![[l; 3]; n * n]);
    sidecar::ReflectionProbes {
        depth_fingerprint: 0,
        origin: [0.6, CENTRE.y as f32, CENTRE.z as f32],
        spacing: [1.0; 3],
        counts: [1, 1, 1],
        radiance: levels,
        distance: vec![10.0; n * n],
    }
}

/// The Cornell camera's scene with a uniform irradiance probe of radiance FAR and grid spacing
/// 2 (the near field reaches 2), the wall bound as the scene's triangles and `reflections`.
fn scene(reflections: sidecar::ReflectionProbes) -> ViewerScene {
    let mut s = cornell_scene(vec![]);
    let mut probes = uniform_probe([FAR as f32; 3]);
    probes.spacing = [2.0; 3];
    s.set_probes(probes);
    s.set_occluders(SceneOccluders { triangles: wall() });
    s.set_reflections(reflections).unwrap();
    s
}

/// A white Lambertian sphere's linear frame and mask.
fn render(scene: &ViewerScene) -> (Vec<f32>, Vec<u8>) {
    let gpu = gpu();
    let material = Material { colour: Vec3::ONE, ka: 0.0, kd: 1.0, ks: 0.0, ..Material::default() };
    let live =
        LiveObjects { sphere: Some(Sphere { centre: CENTRE, radius: RADIUS, material }), meshes: Vec::new() };
    let settings = CompositorSettings { mode: CompositeMode::Fullscreen, ..Default::default() };
    let mut c = Compositor::new(&gpu, scene, settings).unwrap();
    c.render(&live).unwrap();
    (c.read_back_linear().unwrap().rgba, c.read_back().unwrap().mask)
}

/// Interior pixels of the sphere away from its silhouette: (pixel index, world point, normal).
fn interior(scene: &ViewerScene, mask: &[u8]) -> Vec<(usize, DVec3, DVec3)> {
    let camera = scene.camera();
    let (w, _) = scene.size();
    (0..mask.len())
        .filter(|&k| mask[k] == 255 && inside_mask(mask, w as usize, k))
        .filter_map(|k| {
            let ray = camera.pixel_centre_world_ray(k as u32 % w, k as u32 / w);
            let t = ray_sphere(ray.origin, ray.direction, CENTRE, RADIUS)?;
            let p = ray.origin + t * ray.direction;
            let n = (p - CENTRE) / RADIUS;
            (n.dot(-ray.direction) > 0.05).then_some((k, p, n))
        })
        .collect()
}

/// A white matte sphere 0.15 from a wall of radiance 0.2 in a probe field of radiance 1 has
/// radiance E / pi, E the irradiance over its hemisphere with the wall in it: on the side
/// facing the wall down to about 0.6. The probes alone give 1 everywhere (the wall is far
/// closer than their spacing), so the check fails without the near field.
#[test]
fn a_sphere_beside_a_wall_gets_the_wall_s_light_instead_of_the_field_s() {
    let s = scene(reflection_probe(WALL as f32));
    let (linear, mask) = render(&s);
    let tris = wall();
    let (mut checked, mut shaded, mut total_error, mut worst, mut field_error) = (0, 0, 0.0, 0.0f64, 0.0);
    for (k, p, n) in interior(&s, &mask) {
        let want = irradiance(p, n, &tris) / PI;
        let got = f64::from(linear[4 * k]);
        let error = (got - want).abs();
        total_error += error;
        worst = worst.max(error);
        field_error += (FAR - want).abs();
        checked += 1;
        shaded += usize::from(want < 0.9 * FAR);
    }
    assert!(checked > 5000, "{checked}");
    assert!(shaded > 1000, "{shaded} pixels see the wall");
    // Sixteen directions resolve the wall's share of the hemisphere to about a sixteenth, so a
    // pixel may be off by up to 0.8 / 16 per direction that falls either side of the wall's edge.
    let (mean, field_mean) = (total_error / checked as f64, field_error / checked as f64);
    assert!(
        mean < 0.03 && mean < 0.25 * field_mean,
        "mean error {mean} (the field alone: {field_mean}), worst {worst}"
    );
    assert!(worst < 0.12, "mean error {mean}, worst {worst}");
}

/// Where no reflection probe sees the near surface (its distance map stops short of it), nothing
/// says what light the surface sends, and the probe field's light stays as it is.
#[test]
fn a_near_surface_no_reflection_probe_sees_leaves_the_field_alone() {
    let mut probe = reflection_probe(WALL as f32);
    probe.distance.iter_mut().for_each(|d| *d = 0.05);
    let s = scene(probe);
    let (linear, mask) = render(&s);
    let pixels = interior(&s, &mask);
    assert!(pixels.len() > 5000, "{}", pixels.len());
    for (k, _, _) in pixels {
        let got = linear[4 * k];
        assert!((got - FAR as f32).abs() < 1e-4, "pixel {k}: {got}");
    }
}
