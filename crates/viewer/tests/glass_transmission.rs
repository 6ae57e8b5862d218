//! GPU tests of live spheres seen through the scene's glass (`transmission.wgsl`): a pixel whose
//! primary hit transmits (the sidecar's transmission layers) shows `transmittance` times the
//! sphere's radiance where its exit ray meets the sphere before the surface the render saw,
//! instead of the `transmitted` light, and keeps its value elsewhere; checked against an f64
//! refraction of each pixel's camera ray through a glass sphere and an f64 ray-sphere test.

mod common;

use common::*;
use glam::{DVec3, Vec3};
use viewer::{
    CompositeMode, Compositor, CompositorSettings, LiveObjects, Material, SceneLayers, Sphere, ViewerScene,
};

const LEVEL: f32 = 0.5;
const TRANSMITTANCE: f32 = 0.8;
const ETA: f64 = 1.5;
const RADIANCE: f32 = 0.6;
/// The glass sphere (world space), in front of the box's back wall.
const GLASS: (DVec3, f64) = (DVec3::new(-0.1, -0.2, 0.3), 0.45);

/// An exit ray: origin, unit direction, distance to the box's walls.
type ExitRay = (DVec3, DVec3, f64);

/// The Cornell camera and depth with a flat backdrop of `LEVEL`, no lights and a uniform probe
/// field; the pixels whose
/// camera ray meets the glass sphere transmit `TRANSMITTANCE`, and all their light (`LEVEL`)
/// came through the glass (`transmitted` and `indirect`). Returns each pixel's exit ray.
fn glass_scene() -> (ViewerScene, Vec<Option<ExitRay>>) {
    let (mut s, exits) = glass_scene_lit_by(vec![]);
    // All the scene's light is indirect, from a uniform surround, so the share of it a sphere
    // takes from a surface is its occlusion of indirect light there.
    s.set_probes(uniform_probe([LEVEL; 3]));
    (s, exits)
}

/// `glass_scene` lit by `lights` (their light in no layer) and without probes.
fn glass_scene_lit_by(lights: Vec<viewer::LiveLight>) -> (ViewerScene, Vec<Option<ExitRay>>) {
    let (w, h) = (512u32, 512u32);
    let unlayered = vec![None; lights.len()];
    let mut s = flat_cornell(LEVEL, lights);
    let fingerprint = sidecar::depth_fingerprint(s.depth().values());
    let mut layers = sidecar::LightLayers::new(w, h, fingerprint, vec![]);
    let mut exits = vec![None; (w * h) as usize];
    for (k, origin, dir) in world_pixel_rays(s.camera(), w, h) {
        layers.normal[k] = [0.0, 0.0, 1.0];
        let Some((o, d)) = glass_exit_ray(origin, dir, GLASS, ETA) else { continue };
        let distance = to_the_box_walls(o, d);
        exits[k] = Some((o, d, distance));
        layers.transmittance[k] = [TRANSMITTANCE; 3];
        layers.transmitted[k] = [LEVEL; 3];
        layers.indirect[k] = [LEVEL; 3];
        layers.transmission_origin[k] = o.as_vec3().to_array();
        layers.transmission_direction[k] = d.as_vec3().to_array();
        layers.transmission_distance[k] = [distance as f32; 3];
    }
    let area_samples = vec![vec![]; unlayered.len()];
    s.set_light_layers(SceneLayers { layers, layer_of_light: unlayered, area_samples }).unwrap();
    (s, exits)
}

/// An unlit sphere of radiance `RADIANCE`: what the pass shows of it is its own business.
/// The spheres' occlusion of indirect light at `p` with normal `n` for a sphere (`centre`,
/// `radius`): `cos (r / d)^2`, faded out between 6 and 8 radii, at most 1 (shadows.wgsl,
/// indirect_occlusion), in f64.
fn occlusion(p: DVec3, n: DVec3, centre: DVec3, radius: f64) -> f64 {
    let to = centre - p;
    let d = to.length();
    if d <= radius {
        return 1.0;
    }
    let (e0, e1) = (6.0 * radius, 8.0 * radius);
    let t = ((d - e0) / (e1 - e0)).clamp(0.0, 1.0);
    let fade = 1.0 - t * t * (3.0 - 2.0 * t);
    (n.dot(to / d).max(0.0) * (radius / d).powi(2) * fade).min(1.0)
}

fn unlit(centre: DVec3, radius: f64) -> LiveObjects {
    let material = Material { colour: Vec3::splat(RADIANCE), unlit: true, ..Material::default() };
    LiveObjects { sphere: Some(Sphere { centre, radius, material }), meshes: Vec::new() }
}

fn render(scene: &ViewerScene, live: &LiveObjects) -> (Vec<f32>, Vec<u8>) {
    let settings = CompositorSettings { mode: CompositeMode::Fullscreen, ..Default::default() };
    let mut c = Compositor::new(&gpu(), scene, settings).unwrap();
    c.render(live).unwrap();
    (c.read_back_linear().unwrap().rgba, c.read_back().unwrap().mask)
}

/// An unlit sphere behind the glass sphere: every glass pixel whose exit ray meets it (f64)
/// shows `TRANSMITTANCE RADIANCE`, every other glass pixel keeps `LEVEL` less the sphere's
/// occlusion of indirect light at the surface its exit ray meets (the shadow pass's, at the
/// glass, is given back: the transmitted light has its own ray); at most 2 % of the pixels may disagree
/// about the hit (the refracted silhouette, where f32 and f64 rays part). A sphere beyond the
/// box's wall, which the exit rays meet only behind it, changes no glass pixel. A still frame
/// and a frame after a move equal a fresh compositor's.
#[test]
fn a_glass_sphere_shows_the_sphere_behind_it() {
    let (s, exits) = glass_scene();
    let (centre, radius) = (DVec3::new(0.0, -0.3, -0.45), 0.3);
    let live = unlit(centre, radius);
    let (linear, mask) = render(&s, &live);
    let (mut hits, mut misses, mut disagree) = (0, 0, 0);
    for (k, exit) in exits.iter().enumerate() {
        let Some((o, d, distance)) = *exit else { continue };
        if next_to_mask(&mask, 512, k) {
            continue;
        }
        let got = linear[4 * k];
        let hit = ray_sphere(o, d, centre, radius).is_some_and(|t| t < distance);
        let shows_sphere = (got - TRANSMITTANCE * RADIANCE).abs() <= 2e-3;
        // The surface seen through the glass loses what the sphere hides of its indirect light.
        let seen = LEVEL * (1.0 - occlusion(o + distance * d, -d, centre, radius) as f32);
        let keeps_level = (got - seen).abs() <= 1e-3;
        assert!(shows_sphere || keeps_level, "glass pixel {k}: {got}");
        if hit != shows_sphere {
            disagree += 1;
        }
        if hit {
            hits += 1;
        } else {
            misses += 1;
        }
    }
    assert!(hits > 500 && misses > 500, "{hits} views of the sphere through the glass, {misses} others");
    assert!(disagree * 50 <= hits, "{disagree} of {hits} pixels disagree about the view through the glass");

    // Beyond the back wall (z < -1) the sphere is seen through the glass nowhere.
    let far = (DVec3::new(0.0, -0.3, -1.6), 0.5);
    let (behind, behind_mask) = render(&s, &unlit(far.0, far.1));
    for (k, exit) in exits.iter().enumerate() {
        let Some((o, d, distance)) = *exit else { continue };
        if behind_mask[k] == 0 && !next_to_mask(&behind_mask, 512, k) {
            let seen = LEVEL * (1.0 - occlusion(o + distance * d, -d, far.0, far.1) as f32);
            assert!((behind[4 * k] - seen).abs() <= 1e-3, "glass pixel {k}: {} vs {seen}", behind[4 * k]);
        }
    }

    let settings = CompositorSettings { mode: CompositeMode::Fullscreen, ..Default::default() };
    let mut c = Compositor::new(&gpu(), &s, settings).unwrap();
    c.render(&unlit(DVec3::new(0.3, -0.4, -0.3), 0.2)).unwrap();
    c.render(&live).unwrap();
    assert!(c.read_back_linear().unwrap().rgba == linear, "a frame after a move differs from a fresh one");
    c.render(&live).unwrap();
    assert!(c.read_back_linear().unwrap().rgba == linear, "a still frame differs from the first");
}

/// A point light before the box and an unlit sphere between the glass sphere and the back wall,
/// no probes: every glass pixel whose exit ray meets no sphere shows `LEVEL`, or nothing where
/// the sphere hides the light from the surface the exit ray meets (an f64 segment-sphere test
/// from that point toward the light: its light is all the point light's). Per pixel within
/// 1e-3 but on the shadow's edge (at most 4 % of the shadowed pixels); before the pass took the
/// shadow there, it took only the sphere's occlusion of indirect light.
#[test]
fn glass_shows_the_shadow_a_sphere_casts_behind_it() {
    let light = DVec3::new(0.95, -0.1, -0.3);
    let point = viewer::LiveLight::Point { position: light, colour: Vec3::ONE };
    let (s, exits) = glass_scene_lit_by(vec![point]);
    let (centre, radius) = (DVec3::new(0.5, -0.2, -0.75), 0.2);
    let (linear, mask) = render(&s, &unlit(centre, radius));
    let (mut shadowed, mut lit, mut wrong) = (0, 0, 0);
    for (k, exit) in exits.iter().enumerate() {
        let Some((o, d, distance)) = *exit else { continue };
        if next_to_mask(&mask, 512, k) || ray_sphere(o, d, centre, radius).is_some_and(|t| t < distance) {
            continue;
        }
        let x = o + distance * d;
        let to_light = light - x;
        if (-d).dot(to_light) <= 0.0 {
            continue;
        }
        let blocked =
            ray_sphere(x, to_light.normalize(), centre, radius).is_some_and(|t| t < to_light.length());
        let want = if blocked { 0.0 } else { LEVEL };
        if blocked {
            shadowed += 1;
        } else {
            lit += 1;
        }
        if (linear[4 * k] - want).abs() > 1e-3 {
            wrong += 1;
        }
    }
    assert!(shadowed > 300 && lit > 300, "{shadowed} glass pixels see the shadow, {lit} the lit walls");
    assert!(wrong * 25 <= shadowed, "{wrong} glass pixels off, {shadowed} seeing the shadow");
}
