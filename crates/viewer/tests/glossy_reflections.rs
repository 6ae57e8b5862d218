//! GPU tests of live spheres seen in the scene's glossy lobes (`specular.wgsl`, `fs_glossy`): a
//! pixel whose primary hit has the ray tracer's Blinn lobe (the sidecar's `glossy` and
//! `glossy_exponent` layers) changes by the lobe's integral over the directions that meet the
//! sphere of the sphere's radiance less what it hides, checked against an f64 integral of the
//! same lobe (raytracer::bsdf's Blinn `D G / (4 cos_o cos_i)`) over the Cornell box's exact
//! depth table.

mod common;

use common::*;
use glam::{DVec3, Vec3};
use std::f64::consts::PI;
use viewer::{CompositeMode, Compositor, CompositorSettings, LiveObjects, Material, SceneLayers, Sphere};

const LEVEL: f32 = 0.5;
const KS: f64 = 0.8;
const EXPONENT: f64 = 20.0;
/// Half-vector strata of the f64 reference, per side.
const STRATA: usize = 48;

/// The directions of the Blinn lobe at a surface of normal `n` seen from `v` (unit, world
/// space), stratified by the half vector as raytracer::bsdf samples it, each with its
/// `f cos / pdf` per unit Ks.
fn lobe_directions(n: DVec3, v: DVec3) -> Vec<(DVec3, f64)> {
    let helper = if n.x.abs() > 0.9 { DVec3::Y } else { DVec3::X };
    let t = helper.cross(n).normalize();
    let b = n.cross(t);
    let cos_o = n.dot(v);
    let mut out = Vec::with_capacity(STRATA * STRATA);
    for i in 0..STRATA {
        for j in 0..STRATA {
            let u1 = (i as f64 + 0.5) / STRATA as f64;
            let u2 = (j as f64 + 0.5) / STRATA as f64;
            let cos_h = u1.powf(1.0 / (EXPONENT + 1.0));
            let sin_h = (1.0 - cos_h * cos_h).max(0.0).sqrt();
            let phi = 2.0 * PI * u2;
            let h = t * (sin_h * phi.cos()) + b * (sin_h * phi.sin()) + n * cos_h;
            let o_dot_h = v.dot(h);
            let l = 2.0 * o_dot_h * h - v;
            let cos_l = n.dot(l);
            if o_dot_h <= 0.0 || cos_l <= 0.0 {
                out.push((l, 0.0));
                continue;
            }
            let g = (2.0 * cos_h * cos_o / o_dot_h).min(2.0 * cos_h * cos_l / o_dot_h).min(1.0);
            out.push((l, (EXPONENT + 2.0) / (EXPONENT + 1.0) * g * o_dot_h / cos_o));
        }
    }
    out
}

/// A white matte sphere of radiance `l` (a uniform probe field) over a metal floor (Blinn lobe
/// `KS`, `EXPONENT`, no diffuse albedo) of the flat Cornell backdrop whose light layers are
/// black (so the sphere hides no light and casts no shadow the floor could reflect; one corner
/// pixel has an albedo, so that the bounce light's data are bound). Every floor pixel must
/// change by `KS` times the f64 integral of `l` over the lobe's directions that meet the sphere:
/// summed over the floor within 5 %, and pixel by pixel within a relative mean squared error of
/// 0.1 (the viewer traces 64 directions per pixel and shades 8). Without the pass the floor
/// keeps its value and the test fails.
#[test]
fn a_metal_floor_shows_the_blurred_sphere_it_reflects() {
    let (w, h) = (512u32, 512u32);
    let l = 0.9f32;
    let mut s = flat_cornell(LEVEL, vec![]);
    let eye = s.camera().world_from_camera().transform_point3(DVec3::ZERO);
    let fingerprint = sidecar::depth_fingerprint(s.depth().values());
    let mut layers = sidecar::LightLayers::new(w, h, fingerprint, vec![]);
    let mut lobes = vec![None; (w * h) as usize];
    for j in 0..h {
        for i in 0..w {
            let k = (j * w + i) as usize;
            layers.normal[k] = [0.0, 1.0, 0.0];
            match floor_point(&s, i, j) {
                Some(p) => {
                    layers.glossy[k] = [KS as f32; 3];
                    layers.glossy_exponent[k] = [EXPONENT as f32; 3];
                    lobes[k] = Some((p, lobe_directions(DVec3::Y, (eye - p).normalize())));
                }
                None if k == 0 => layers.albedo[k] = [0.8; 3],
                None => {}
            }
        }
    }
    s.set_light_layers(SceneLayers { layers, layer_of_light: vec![], area_samples: vec![] }).unwrap();
    s.set_probes(uniform_probe([l; 3]));
    let (centre, radius) = (DVec3::new(0.1, -0.55, 0.1), 0.3);
    let material = Material { colour: Vec3::ONE, ka: 0.0, kd: 1.0, ks: 0.0, ..Material::default() };
    let live = LiveObjects { sphere: Some(Sphere { centre, radius, material }), meshes: Vec::new() };
    let settings = CompositorSettings { mode: CompositeMode::Fullscreen, ..Default::default() };
    let mut c = Compositor::new(&gpu(), &s, settings).unwrap();
    c.render(&live).unwrap();
    let linear = c.read_back_linear().unwrap().rgba;
    let mask = c.read_back().unwrap().mask;
    let (mut sum_got, mut sum_want, mut squared_error, mut squared_want, mut pixels) =
        (0.0, 0.0, 0.0, 0.0, 0);
    for (k, lobe) in lobes.iter().enumerate() {
        let Some((p, directions)) = lobe else { continue };
        if next_to_mask(&mask, w as usize, k) || (k % 3) != 0 {
            continue;
        }
        let met: f64 = directions
            .iter()
            .filter(|(d, weight)| *weight > 0.0 && ray_sphere(*p, *d, centre, radius).is_some())
            .map(|(_, weight)| weight)
            .sum::<f64>()
            / directions.len() as f64;
        let want = KS * met * f64::from(l);
        let got = f64::from(linear[4 * k]) - f64::from(LEVEL);
        sum_got += got;
        sum_want += want;
        squared_error += (got - want) * (got - want);
        squared_want += want * want;
        pixels += 1;
    }
    assert!(pixels > 5_000 && sum_want > 1.0, "{pixels} floor pixels, change {sum_want}");
    assert!((sum_got - sum_want).abs() <= 0.05 * sum_want, "the floor changes by {sum_got}, not {sum_want}");
    let relative = squared_error / squared_want;
    assert!(relative <= 0.1, "relative squared error {relative} per pixel");
}
