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
    mirror_floor_scene_with_gain(probe_radiance, 1.0)
}

/// The same with the RIB's `Exposure` gain: the image holds `LEVEL` (the renderer applies the
/// gain to the image), the layers `LEVEL / gain` (they are written before it).
fn mirror_floor_scene_with_gain(probe_radiance: f32, gain: f32) -> (ViewerScene, Vec<bool>) {
    let (w, h) = (512u32, 512u32);
    let n = (w * h) as usize;
    let linear = [LEVEL, LEVEL, LEVEL, 1.0].repeat(n);
    let backdrop = viewer::Backdrop::from_linear(w, h, linear, 1.0).unwrap();
    let tone_map = viewer::ToneMap { gain, gamma: 1.0 };
    let mut s =
        ViewerScene::with_backdrop(cornell_camera(), backdrop, cornell_depth(), vec![], tone_map).unwrap();
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
                layers.reflected[k] = [LEVEL / gain; 3];
                layers.indirect[k] = [LEVEL / gain; 3];
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

/// The floor pixels away from the sphere's outline, each with whether its mirror direction
/// meets the sphere (an f64 ray test from the pixel's surface point).
fn floor_reflections(
    s: &ViewerScene,
    floor: &[bool],
    mask: &[u8],
    centre: DVec3,
    radius: f64,
) -> Vec<(usize, bool)> {
    let eye = s.camera().world_from_camera().transform_point3(DVec3::ZERO);
    let mut out = Vec::new();
    for j in 0..512u32 {
        for i in 0..512u32 {
            let k = (j * 512 + i) as usize;
            if !floor[k] || next_to_mask(mask, 512, k) {
                continue;
            }
            let p = floor_point(s, i, j).unwrap();
            let view = (p - eye).normalize();
            out.push((k, ray_sphere(p, DVec3::new(view.x, -view.y, view.z), centre, radius).is_some()));
        }
    }
    out
}

/// A white matte sphere above a mirror floor, lit by a uniform probe field of radiance `L` (so
/// its radiance is `L` everywhere): every floor pixel whose mirror direction meets the sphere
/// (an f64 ray test from the pixel's surface point) shows `REFLECTANCE L`, every other floor
/// pixel keeps at least `LEVEL` (the sphere's occlusion of indirect light leaves a specular
/// reflection's light to the traced direction, and what that direction sees gains only the
/// sphere's bounce light); at most 2 % of the pixels may disagree about
/// the hit (the reflection's silhouette, where f32 and f64 rays part). Both compositing modes
/// give the same colour, and so do a still frame and a frame after a move.
#[test]
fn a_mirror_floor_shows_the_sphere_it_reflects() {
    let l = 0.6f32;
    let (s, floor) = mirror_floor_scene(l);
    let (centre, radius) = (DVec3::new(0.1, -0.55, 0.1), 0.3);
    let live = white_matte(centre, radius);
    let (linear, mask) = render(&s, &live, CompositeMode::Fullscreen);
    let (mut hits, mut misses, mut disagree) = (0, 0, 0);
    for (k, hit) in floor_reflections(&s, &floor, &mask, centre, radius) {
        let got = linear[4 * k];
        let shows_sphere = (got - REFLECTANCE * l).abs() <= 2e-3;
        // The mirror also sees the sphere's bounce light on the walls, and nothing there
        // loses light (no lights; the walls' indirect light is not in the layers).
        let keeps_level = got >= LEVEL;
        assert!(shows_sphere || keeps_level, "floor pixel ({}, {}): {got}", k % 512, k / 512);
        if hit != shows_sphere {
            disagree += 1;
        }
        if hit {
            hits += 1;
        } else {
            misses += 1;
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

/// Under an `Exposure` gain of 2 the layers are half the image: a floor pixel whose mirror
/// direction meets the sphere trades its `reflected` light, scaled by the gain as the image
/// is, for the sphere's radiance times the gain, `2 REFLECTANCE L` (the pass once subtracted
/// `reflected` unscaled, `LEVEL / 2` too much light left).
#[test]
fn a_mirror_floor_under_an_exposure_gain_shows_the_sphere_in_the_images_units() {
    let (l, gain) = (0.3f32, 2.0f32);
    let (s, floor) = mirror_floor_scene_with_gain(l, gain);
    let (centre, radius) = (DVec3::new(0.1, -0.55, 0.1), 0.3);
    let (linear, mask) = render(&s, &white_matte(centre, radius), CompositeMode::Fullscreen);
    let (mut hits, mut right) = (0, 0);
    for (k, hit) in floor_reflections(&s, &floor, &mask, centre, radius) {
        if hit {
            hits += 1;
            right += usize::from((linear[4 * k] - gain * REFLECTANCE * l).abs() <= 4e-3);
        }
    }
    assert!(hits > 500, "{hits} reflections of the sphere");
    assert!(right * 50 >= hits * 49, "{right} of {hits} pixels show the sphere at the gain");
}

/// Whether world point `x` lies in front of the surface the Cornell depth table sees along its
/// pixel's ray (in the box's free space: nothing the eye sees is nearer), and whether it lies on
/// that surface (within `1e-3`): what the depth table says of a point, without the viewer.
fn against_the_depth(s: &ViewerScene, x: DVec3) -> (bool, bool) {
    let raster = raster_of(s.camera(), x);
    if raster.x < 0.0 || raster.y < 0.0 || raster.x >= 512.0 || raster.y >= 512.0 {
        return (false, false);
    }
    let (i, j) = (raster.x as u32, raster.y as u32);
    let Some(r) = s.depth().get(i, j).filter(|r| r.is_finite()) else { return (false, false) };
    let eye = s.camera().world_from_camera().transform_point3(DVec3::ZERO);
    let d = (x - eye).length();
    let ray = s.camera().pixel_centre_ray(i, j);
    let seen = s.camera().world_from_camera().transform_point3(ray.origin + ray.direction * f64::from(r));
    (d < (seen - eye).length() - 1e-3, (seen - eye).length() - d < 1e-2 && (x.z - seen.z).abs() < 1e-3)
}

/// A mirror floor reflecting the back wall in a black sphere's shadow from a point light: a
/// floor pixel whose mirror direction meets the back wall (f64; only where the depth table sees
/// that wall point and the whole segment to it lies in front of what the eye sees, so that the
/// box's blocks hide neither) and no sphere shows `LEVEL` less the reflectance times the point
/// light's light that the sphere takes from that wall point (the wall's light is all the point
/// light's: an f64 segment-sphere test toward the light). The sphere is black, so it sends the
/// wall no bounce light. Per pixel within 1e-3 but on the shadow's edge (the wall pixel's
/// footprint against one f64 point: at most 4 % of the shadowed pixels); before the pass
/// showed the shadow, the floor kept `LEVEL` everywhere.
#[test]
fn a_mirror_floor_shows_the_shadow_a_sphere_casts_on_the_wall() {
    let (w, h) = (512u32, 512u32);
    let light = DVec3::new(-0.95, 0.3, 0.9);
    let (centre, radius) = (DVec3::new(-0.82, -0.5, -0.45), 0.18);
    let point = viewer::LiveLight::Point { position: light, colour: Vec3::ONE };
    let mut s = flat_cornell(LEVEL, vec![point]);
    let eye = s.camera().world_from_camera().transform_point3(DVec3::ZERO);
    let fingerprint = sidecar::depth_fingerprint(s.depth().values());
    let mut layers =
        sidecar::LightLayers::new(w, h, fingerprint, vec![sidecar::LightSource::new(0, "pointlight")]);
    let mut mirror = vec![None; (w * h) as usize];
    for j in 0..h {
        for i in 0..w {
            let k = (j * w + i) as usize;
            let Some(p) = floor_point(&s, i, j) else {
                // The back wall's light is all the point light's; the rest's comes from nothing
                // the sphere blocks.
                layers.albedo[k] = [0.8; 3];
                layers.normal[k] = [0.0, 0.0, 1.0];
                layers.light[0][k] = [LEVEL; 3];
                continue;
            };
            layers.normal[k] = [0.0, 1.0, 0.0];
            layers.reflectance[k] = [REFLECTANCE; 3];
            layers.reflected[k] = [LEVEL; 3];
            layers.indirect[k] = [LEVEL; 3];
            mirror[k] = Some(p);
        }
    }
    s.set_light_layers(SceneLayers { layers, layer_of_light: vec![Some(0)], area_samples: vec![vec![]] })
        .unwrap();
    let material = Material { colour: Vec3::ZERO, ka: 0.0, kd: 1.0, ks: 0.0, ..Material::default() };
    let live = LiveObjects { sphere: Some(Sphere { centre, radius, material }), meshes: Vec::new() };
    let (linear, mask) = render(&s, &live, CompositeMode::Fullscreen);
    let (mut shadowed, mut lit, mut wrong) = (0, 0, 0);
    for (k, p) in mirror.iter().enumerate() {
        let Some(p) = *p else { continue };
        if next_to_mask(&mask, w as usize, k) {
            continue;
        }
        let view = (p - eye).normalize();
        let dir = DVec3::new(view.x, -view.y, view.z);
        if dir.z >= 0.0 || ray_sphere(p, dir, centre, radius).is_some() {
            continue;
        }
        let f = p + dir * ((-1.0 - p.z) / dir.z);
        let free = (1..60).all(|t| against_the_depth(&s, p + (f - p) * (f64::from(t) / 64.0)).0);
        if f.x.abs() >= 0.99 || f.y >= 0.99 || !free || !against_the_depth(&s, f).1 {
            continue;
        }
        let to_light = light - f;
        let blocked =
            ray_sphere(f, to_light.normalize(), centre, radius).is_some_and(|t| t < to_light.length());
        let want = LEVEL - if blocked { REFLECTANCE * LEVEL } else { 0.0 };
        let got = linear[4 * k];
        if blocked {
            shadowed += 1;
        } else {
            lit += 1;
        }
        if (got - want).abs() > 1e-3 {
            wrong += 1;
        }
    }
    assert!(shadowed > 500 && lit > 500, "{shadowed} reflections of the shadow, {lit} of the lit wall");
    assert!(wrong * 25 <= shadowed, "{wrong} floor pixels off, {shadowed} reflecting the shadow");
}
