//! Unit tests of the BSDF and its lobes.

use super::*;
use crate::sampling::Rng;

fn frame() -> Frame {
    Frame::from_z(Vec3::Z)
}

/// Monte Carlo estimate of the albedo `∫ f cos` by sampling, and a check that f/pdf agree
/// with f() and pdf() evaluated separately.
fn albedo(bsdf: &Bsdf, wo: Vec3, n: usize) -> Vec3 {
    let mut rng = Rng::new(11, 3);
    let mut sum = Vec3::ZERO;
    for _ in 0..n {
        if let Some(s) =
            bsdf.sample(wo, rng.uniform(), rng.uniform2(), TransportMode::Radiance, LobeFlags::ALL)
        {
            sum += s.f * s.wi.dot(bsdf.ng).abs() / s.pdf;
            if !s.is_specular() {
                let f = bsdf.f(wo, s.wi, LobeFlags::ALL);
                let p = bsdf.pdf(wo, s.wi, LobeFlags::ALL);
                assert!((f - s.f).length() <= 1e-4 * (1.0 + f.length()));
                assert!((p - s.pdf).abs() <= 1e-4 * (1.0 + p));
            }
        }
    }
    sum / n as f32
}

/// The lobe sets the materials build: matte, plastic, metal, shinymetal, mirror, glass,
/// and a diffuse lobe under a mirror.
fn material_like_bsdfs(frame: Frame, ng: Vec3) -> Vec<Bsdf> {
    let sets: [&[Lobe]; 7] = [
        &[Lobe::Lambert { r: Vec3::new(0.7, 0.5, 0.2) }],
        &[Lobe::Lambert { r: Vec3::splat(0.45) }, Lobe::Blinn { ks: Vec3::splat(0.5), exponent: 10.0 }],
        &[Lobe::Blinn { ks: Vec3::new(0.9, 0.6, 0.3), exponent: 250.0 }],
        &[
            Lobe::Blinn { ks: Vec3::splat(0.3), exponent: 1.0 },
            Lobe::SpecularReflection { r: Vec3::splat(0.6) },
        ],
        &[Lobe::SpecularReflection { r: Vec3::ONE }],
        &[Lobe::Dielectric { eta: 1.5, r: Vec3::ONE, t: Vec3::ONE }],
        &[Lobe::Lambert { r: Vec3::splat(0.3) }, Lobe::SpecularReflection { r: Vec3::splat(0.6) }],
    ];
    sets.iter()
        .map(|lobes| {
            let mut b = Bsdf::new(frame, ng);
            for &l in *lobes {
                b.add(l);
            }
            b
        })
        .collect()
}

fn bits(f: Vec3, pdf: f32) -> [u32; 4] {
    [f.x.to_bits(), f.y.to_bits(), f.z.to_bits(), pdf.to_bits()]
}

/// The one-pass evaluation (`f_and_pdf`, and the pass `sample` makes after choosing a
/// direction) gives exactly the bits of the separate `f` and `pdf` evaluations, for every
/// material's lobes, over directions on both sides, with a shading normal tilted off the
/// geometric one, under every mask.
#[test]
fn one_pass_evaluation_is_bit_identical_to_separate_f_and_pdf() {
    use crate::sampling::sample_uniform_sphere;
    let ns = Vec3::new(0.2, -0.1, 1.0).normalize();
    let frame = Frame::from_z_and_tangent(ns, Vec3::X);
    let masks = [LobeFlags::ALL, LobeFlags::NON_SPECULAR, LobeFlags::DIFFUSE | LobeFlags::REFLECTION];
    let mut rng = Rng::new(5, 9);
    let mut nonzero = 0;
    for bsdf in material_like_bsdfs(frame, Vec3::Z) {
        for _ in 0..4000 {
            let wo = sample_uniform_sphere(rng.uniform2());
            let wi = sample_uniform_sphere(rng.uniform2());
            for mask in masks {
                let (f, pdf) = bsdf.f_and_pdf(wo, wi, mask);
                assert_eq!(bits(f, pdf), bits(bsdf.f(wo, wi, mask), bsdf.pdf(wo, wi, mask)), "{bsdf:?}");
                let (lo, li) = (frame.to_local(wo), frame.to_local(wi));
                for reflect in [false, true] {
                    let total = bsdf.total_weight(mask);
                    let (f, pdf) = bsdf.f_pdf_local(lo, li, reflect, total, non_specular(mask));
                    let separate = (
                        bsdf.f_local(lo, li, reflect, non_specular(mask)),
                        bsdf.pdf_local(lo, li, total, non_specular(mask)),
                    );
                    assert_eq!(bits(f, pdf), bits(separate.0, separate.1));
                }
                nonzero += usize::from(pdf > 0.0);
            }
            for lobe in bsdf.lobes() {
                let (f, pdf) = lobe_f_pdf(lobe, frame.to_local(wo), frame.to_local(wi));
                let (lo, li) = (frame.to_local(wo), frame.to_local(wi));
                assert_eq!(bits(f, pdf), bits(lobe_f(lobe, lo, li), lobe_pdf(lobe, lo, li)));
            }
        }
    }
    // The directions exercised the lobes, not only their zero branches.
    assert!(nonzero > 10_000, "{nonzero}");
}

/// A sampled non-specular direction carries the value and density that `f` and `pdf` give
/// for it.
#[test]
fn samples_carry_f_and_pdf_of_the_whole_bsdf() {
    let mut rng = Rng::new(2, 8);
    for bsdf in material_like_bsdfs(frame(), Vec3::Z) {
        for _ in 0..2000 {
            let wo = crate::sampling::sample_uniform_sphere(rng.uniform2());
            let Some(s) =
                bsdf.sample(wo, rng.uniform(), rng.uniform2(), TransportMode::Radiance, LobeFlags::ALL)
            else {
                continue;
            };
            if !s.is_specular() {
                assert_eq!(
                    bits(s.f, s.pdf),
                    bits(bsdf.f(wo, s.wi, LobeFlags::ALL), bsdf.pdf(wo, s.wi, LobeFlags::ALL))
                );
            }
        }
    }
}

#[test]
fn lambert_albedo_is_r() {
    let mut b = Bsdf::new(frame(), Vec3::Z);
    b.add(Lobe::Lambert { r: Vec3::new(0.2, 0.5, 0.8) });
    let a = albedo(&b, Vec3::new(0.3, 0.1, 0.9).normalize(), 20_000);
    assert!((a - Vec3::new(0.2, 0.5, 0.8)).abs().max_element() < 1e-3, "{a}");
}

#[test]
fn blinn_is_energy_bounded_and_consistent() {
    for e in [1.0, 10.0, 100.0] {
        let mut b = Bsdf::new(frame(), Vec3::Z);
        b.add(Lobe::Blinn { ks: Vec3::ONE, exponent: e });
        let a = albedo(&b, Vec3::new(0.3, 0.0, 0.95).normalize(), 40_000);
        assert!(a.x > 0.3 && a.x <= 1.05, "exponent {e}: albedo {a}");
    }
}

#[test]
fn mixed_lobes_sum_their_albedos() {
    // A diffuse and a mirror lobe: the sampled estimate of the albedo must be their sum
    // (the non-specular density must count the chance of picking the mirror).
    let mut b = Bsdf::new(frame(), Vec3::Z);
    b.add(Lobe::Lambert { r: Vec3::splat(0.3) });
    b.add(Lobe::SpecularReflection { r: Vec3::splat(0.6) });
    let a = albedo(&b, Vec3::new(0.2, 0.1, 0.95).normalize(), 40_000);
    assert!((a.x - 0.9).abs() < 0.01, "{a}");
}

#[test]
fn fresnel_limits() {
    assert!((fresnel_dielectric(1.0, 1.5) - 0.04).abs() < 1e-6);
    assert_eq!(fresnel_dielectric(0.0, 1.5), 1.0);
    // Total internal reflection from inside beyond the critical angle.
    assert_eq!(fresnel_dielectric(-0.3, 1.5), 1.0);
    assert!((fresnel_dielectric(-1.0, 1.5) - 0.04).abs() < 1e-6);
}

#[test]
fn glass_conserves_energy_in_importance_mode() {
    let mut b = Bsdf::new(frame(), Vec3::Z);
    b.add(Lobe::Dielectric { eta: 1.5, r: Vec3::ONE, t: Vec3::ONE });
    let mut rng = Rng::new(1, 2);
    let wo = Vec3::new(0.5, 0.0, 0.8).normalize();
    let mut sum = 0.0;
    let n = 20_000;
    for _ in 0..n {
        let s =
            b.sample(wo, rng.uniform(), rng.uniform2(), TransportMode::Importance, LobeFlags::ALL).unwrap();
        sum += s.f.x * s.wi.z.abs() / s.pdf;
        if s.flags.intersects(LobeFlags::TRANSMISSION) {
            // Snell's law.
            let sin_o = (1.0 - wo.z * wo.z).sqrt();
            let sin_i = (1.0 - s.wi.z * s.wi.z).sqrt();
            assert!((sin_o - 1.5 * sin_i).abs() < 1e-5);
        }
    }
    assert!((sum / n as f32 - 1.0).abs() < 1e-4);
}

#[test]
fn masks_select_parts() {
    let mut b = Bsdf::new(frame(), Vec3::Z);
    b.add(Lobe::Lambert { r: Vec3::splat(0.5) });
    b.add(Lobe::SpecularReflection { r: Vec3::splat(0.5) });
    let wo = Vec3::new(0.0, 0.6, 0.8);
    let mut rng = Rng::new(4, 4);
    for _ in 0..100 {
        let s = b
            .sample(wo, rng.uniform(), rng.uniform2(), TransportMode::Radiance, LobeFlags::SPECULAR_ALL)
            .unwrap();
        assert!(s.is_specular());
        let s = b
            .sample(wo, rng.uniform(), rng.uniform2(), TransportMode::Radiance, LobeFlags::NON_SPECULAR)
            .unwrap();
        assert!(!s.is_specular());
    }
    assert_eq!(b.count_matching(LobeFlags::DIFFUSE | LobeFlags::REFLECTION), 1);
}
