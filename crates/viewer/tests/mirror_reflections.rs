//! GPU tests of live spheres seen in the scene's specular reflections (`bounce.wgsl`,
//! `reflection_change`): a pixel whose primary hit reflects specularly (the sidecar's
//! `reflectance` and `reflected` layers) shows `reflectance` times the sphere's radiance where
//! its mirror direction meets the sphere, instead of the `reflected` light, and keeps its value
//! elsewhere; checked against a ray-sphere test in f64 over the Cornell box's exact depth table.

mod common;

use common::*;
use glam::{DVec3, Vec3};
use viewer::{
    CompositeMode, Compositor, CompositorSettings, LiveObjects, Material, SceneLayers, Sphere, ViewerScene,
};

const LEVEL: f32 = 0.5;
const REFLECTANCE: f32 = 0.8;

/// The Cornell camera and depth with a flat backdrop of `LEVEL`, no lights, and a mirror floor:
/// its pixels reflect `REFLECTANCE` specularly and all their light (`LEVEL`) is `reflected`
/// (and `indirect`); the other surfaces have a diffuse albedo (so the bounce pass runs) and no
/// indirect light (so the spheres' occlusion of it takes nothing from them).
fn mirror_floor_scene(probe_radiance: f32) -> (ViewerScene, Vec<bool>) {
    let (w, h) = (512u32, 512u32);
    let n = (w * h) as usize;
    let mut s = flat_cornell(LEVEL, vec![]);
    let fingerprint = sidecar::depth_fingerprint(s.depth().values());
    let mut layers = sidecar::LightLayers::new(w, h, fingerprint, vec![]);
    let mut floor = vec![false; n];
    for j in 0..h {
        for i in 0..w {
            let k = (j * w + i) as usize;
            floor[k] = floor_point(&s, i, j).is_some();
            layers.normal[k] = [0.0, 1.0, 0.0];
            if floor[k] {
                layers.reflectance[k] = [REFLECTANCE; 3];
                layers.reflected[k] = [LEVEL; 3];
                layers.indirect[k] = [LEVEL; 3];
            } else {
                layers.albedo[k] = [0.8; 3];
            }
        }
    }
    s.set_light_layers(SceneLayers { layers, layer_of_light: vec![], area_samples: vec![] }).unwrap();
    s.set_probes(uniform_probe([probe_radiance; 3]));
    (s, floor)
}

fn white_matte(centre: DVec3, radius: f64) -> LiveObjects {
    let material = Material { colour: Vec3::ONE, ka: 0.0, kd: 1.0, ks: 0.0, ..Material::default() };
    LiveObjects { sphere: Some(Sphere { centre, radius, material }), meshes: Vec::new() }
}

fn render(scene: &ViewerScene, live: &LiveObjects, mode: CompositeMode) -> (Vec<f32>, Vec<u8>) {
    let settings = CompositorSettings { mode, ..Default::default() };
    let mut c = Compositor::new(&gpu(), scene, settings).unwrap();
    c.render(live).unwrap();
    (c.read_back_linear().unwrap().rgba, c.read_back().unwrap().mask)
}

/// A white matte sphere above a mirror floor, lit by a uniform probe field of radiance `L` (so
/// its radiance is `L` everywhere): every floor pixel whose mirror direction meets the sphere
/// (an f64 ray test from the pixel's surface point) shows `REFLECTANCE L`, every other floor
/// pixel keeps `LEVEL` exactly (the sphere's occlusion of indirect light leaves a specular
/// reflection's light to the traced direction); at most 2 % of the pixels may disagree about
/// the hit (the reflection's silhouette, where f32 and f64 rays part). Both compositing modes
/// give the same colour, and so do a still frame and a frame after a move.
#[test]
fn a_mirror_floor_shows_the_sphere_it_reflects() {
    let l = 0.6f32;
    let (s, floor) = mirror_floor_scene(l);
    let (centre, radius) = (DVec3::new(0.1, -0.55, 0.1), 0.3);
    let live = white_matte(centre, radius);
    let (linear, mask) = render(&s, &live, CompositeMode::Fullscreen);
    let eye = s.camera().world_from_camera().transform_point3(DVec3::ZERO);
    let (mut hits, mut misses, mut disagree) = (0, 0, 0);
    for j in 0..512u32 {
        for i in 0..512u32 {
            let k = (j * 512 + i) as usize;
            if !floor[k] || next_to_mask(&mask, 512, k) {
                continue;
            }
            let p = floor_point(&s, i, j).unwrap();
            let view = (p - eye).normalize();
            let dir = DVec3::new(view.x, -view.y, view.z);
            let got = linear[4 * k];
            let hit = ray_sphere(p, dir, centre, radius).is_some();
            let shows_sphere = (got - REFLECTANCE * l).abs() <= 2e-3;
            let keeps_level = got == LEVEL;
            assert!(shows_sphere || keeps_level, "floor pixel ({i}, {j}): {got}");
            if hit != shows_sphere {
                disagree += 1;
            }
            if hit {
                hits += 1;
            } else {
                misses += 1;
            }
        }
    }
    assert!(hits > 500 && misses > 10_000, "{hits} reflections of the sphere, {misses} others");
    assert!(disagree * 50 <= hits, "{disagree} of {hits} pixels disagree about the reflection");
    let (points, _) = render(&s, &live, CompositeMode::Points);
    assert!(points == linear, "the two compositing paths differ");
    // The pass keeps what it drew: a still frame copies it back, a frame after a move draws it
    // again, and both equal a fresh compositor's frame.
    let settings = CompositorSettings { mode: CompositeMode::Fullscreen, ..Default::default() };
    let mut c = Compositor::new(&gpu(), &s, settings).unwrap();
    c.render(&white_matte(DVec3::new(-0.3, -0.4, 0.2), 0.2)).unwrap();
    c.render(&live).unwrap();
    assert!(c.read_back_linear().unwrap().rgba == linear, "a frame after a move differs from a fresh one");
    c.render(&live).unwrap();
    assert!(c.read_back_linear().unwrap().rgba == linear, "a still frame differs from the first");
}
