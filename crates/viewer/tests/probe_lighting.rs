//! GPU test of live objects lit by the renderer's irradiance probes (docs/sidecar.md): their
//! diffuse light is the probes' SH irradiance, not the bare lights'.

mod common;

use common::*;
use glam::{DVec3, Vec3};
use viewer::{CompositeMode, Compositor, CompositorSettings, LiveLight, LiveObjects, Material, Sphere};

/// One probe in a uniform environment of radiance `l`: its only SH coefficient is
/// `l * 4 pi * Y00`.
fn uniform_probe(l: [f32; 3]) -> sidecar::ProbeGrid {
    let mut sh = [[0.0f32; 3]; 9];
    let y00 = 0.282_094_8 * 4.0 * std::f32::consts::PI;
    sh[0] = l.map(|v| v * y00);
    let texels = sidecar::VISIBILITY_TEXELS * sidecar::VISIBILITY_TEXELS;
    sidecar::ProbeGrid {
        depth_fingerprint: 0,
        origin: [0.0, 0.0, 0.0],
        spacing: [1.0, 1.0, 1.0],
        counts: [1, 1, 1],
        radiance_sh: vec![sh],
        visibility: vec![[10.0, 100.0]; texels],
    }
}

/// A white Lambertian sphere (Kd 1, no Ka, no Ks) in a uniform environment of radiance `l`
/// has radiance `l` at every visible point; the RIB's point light adds nothing diffuse.
#[test]
fn a_white_matte_sphere_in_a_uniform_probe_field_has_the_field_s_radiance() {
    let gpu = gpu();
    let l = [0.3f32, 0.5, 0.7];
    let light = LiveLight::Point { position: DVec3::new(0.0, 0.9, 0.0), colour: Vec3::splat(5.0) };
    let mut scene = cornell_scene(vec![light]);
    scene.set_probes(uniform_probe(l));
    let material = Material { colour: Vec3::ONE, ka: 0.0, kd: 1.0, ks: 0.0, ..Material::default() };
    let live = LiveObjects {
        sphere: Some(Sphere { centre: DVec3::new(0.0, -0.2, 0.0), radius: 0.3, material }),
        meshes: Vec::new(),
    };
    let mut c = Compositor::new(
        &gpu,
        &scene,
        CompositorSettings { mode: CompositeMode::Fullscreen, ..Default::default() },
    )
    .unwrap();
    c.render(&live).unwrap();
    let linear = c.read_back_linear().unwrap();
    let mask = c.read_back().unwrap().mask;
    let mut inside = 0;
    for (k, &m) in mask.iter().enumerate() {
        if m == 255 {
            inside += 1;
            for (ch, want) in l.iter().enumerate() {
                let got = linear.rgba[4 * k + ch];
                assert!((got - want).abs() < 1e-4 * want.max(1.0), "pixel {k} channel {ch}: {got} vs {want}");
            }
        }
    }
    assert!(inside > 1000, "inside {inside}");
}
