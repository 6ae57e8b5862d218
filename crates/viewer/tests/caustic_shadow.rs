//! GPU test of the caustic light live spheres block (docs/viewer-specular.md, "Caustics that live objects
//! block"): over the Cornell box's exact depth, photons from a point under the ceiling reach the
//! floor through a specular vertex each; every backdrop pixel must lose exactly what the f64
//! reference (`sidecar::CausticPhotons::blocked_loss`) says the blocked photons brought it, in
//! both compositing modes, and nothing without a blocking sphere.

mod common;

use common::*;
use glam::{DVec3, Vec3};
use viewer::{CompositeMode, Compositor, CompositorSettings, LiveObjects, Material, Sphere};

const LEVEL: f32 = 0.5;

/// Kernels on the floor pixels (radius 0.05, filter from the file, reflectance 0.5 / pi), and a
/// 40x20 grid of photons on the floor in front of the boxes: light point -> a specular vertex
/// at y = 0 -> straight down to the floor.
fn caustics(scene: &viewer::ViewerScene) -> sidecar::CausticPhotons {
    let (w, h) = scene.size();
    let mut pixels = vec![sidecar::CausticPixel::default(); (w * h) as usize];
    for j in 0..h {
        for i in 0..w {
            if let Some(p) = floor_point(scene, i, j) {
                let weight = 0.5 / std::f32::consts::PI / (std::f32::consts::PI * 0.0025);
                pixels[(j * w + i) as usize] = sidecar::CausticPixel {
                    position: p.as_vec3().to_array(),
                    normal: [0.0, 1.0, 0.0],
                    radius2: 0.0025,
                    weight: [weight, 0.8 * weight, 0.6 * weight],
                };
            }
        }
    }
    let (mut photons, mut segments) = (Vec::new(), Vec::new());
    for b in 0..20 {
        for a in 0..40 {
            let (x, z) = (-0.3 + 0.015 * a as f32, 0.6 + 0.015 * b as f32);
            photons.push(sidecar::CausticPhoton {
                position: [x, -1.0, z],
                normal: [0.0, 1.0, 0.0],
                power: [2e-4, 2e-4, 3e-4],
                first_segment: segments.len() as u32,
                segment_count: 2,
            });
            segments.push([[0.0, 0.9, 0.75], [x, 0.0, z]]);
            segments.push([[x, 0.0, z], [x, -1.0, z]]);
        }
    }
    let fingerprint = sidecar::depth_fingerprint(scene.depth().values());
    sidecar::CausticPhotons {
        depth_fingerprint: fingerprint,
        width: w,
        height: h,
        filter: sidecar::CausticFilter::Cone { k: 1.1 },
        photons,
        segments,
        pixels,
    }
}

fn sphere(centre: DVec3, radius: f64) -> LiveObjects {
    LiveObjects {
        sphere: Some(Sphere { centre, radius, material: Material::unlit(Vec3::new(0.0, 0.0, 1.0)) }),
        meshes: Vec::new(),
    }
}

#[test]
fn backdrop_pixels_lose_exactly_the_caustic_light_of_the_blocked_photons() {
    let gpu = gpu();
    let mut scene = flat_cornell(LEVEL, Vec::new());
    let photons = caustics(&scene);
    scene.set_caustics(photons.clone()).unwrap();
    // One sphere across the first segments (light -> specular vertex), one across the second
    // (specular vertex -> floor), one that blocks nothing.
    let cases = [
        (DVec3::new(0.1, 0.45, 0.75), 0.06),
        (DVec3::new(-0.15, -0.5, 0.75), 0.1),
        (DVec3::new(0.7, 0.5, -0.6), 0.1),
    ];
    for mode in [CompositeMode::Fullscreen, CompositeMode::Points] {
        let mut c = Compositor::new(&gpu, &scene, CompositorSettings { mode, ..Default::default() }).unwrap();
        for (centre, radius) in cases {
            c.render(&sphere(centre, radius)).unwrap();
            let linear = c.read_back_linear().unwrap();
            let frame = c.read_back().unwrap();
            let reference = photons.blocked_loss(&[(centre.to_array(), radius)]);
            let (mut dimmed, mut checked) = (0, 0);
            for_each_backdrop_point(&scene, &frame.mask, 1, Skip::NearMask, |i, j, k, _| {
                for (c, lost) in reference[k].iter().enumerate() {
                    let expected = f64::from(LEVEL) - lost;
                    let got = f64::from(linear.rgba[4 * k + c]);
                    assert!(
                        (got - expected).abs() <= 2e-6,
                        "{mode:?} {centre}: pixel ({i}, {j}) {got} vs {expected}"
                    );
                }
                dimmed += usize::from(reference[k][0] > 1e-3);
                checked += 1;
            });
            assert!(checked > 100_000, "{checked} pixels checked");
            if centre.z > 0.0 {
                assert!(dimmed > 500, "{mode:?} {centre}: {dimmed} pixels dimmed");
            } else {
                assert_eq!(dimmed, 0);
            }
        }
    }
}

#[test]
fn caustics_of_another_frame_size_are_refused() {
    let mut scene = flat_cornell(LEVEL, Vec::new());
    let mut photons = caustics(&scene);
    photons.width = 256;
    assert!(scene.set_caustics(photons).unwrap_err().to_string().contains("256"));
}
