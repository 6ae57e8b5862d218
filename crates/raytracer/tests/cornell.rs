//! The Cornell box of `../shared/reference/cornell` against Mitsuba 3's converged image and the
//! analytic depth table: a downsized check in the normal suite (a crop of the frame at a modest
//! sample count, with a tolerance that accounts for its noise). `cargo xtask cornell-check`
//! runs the full-frame, converged comparison.

use depth_remap::DepthTable;
use raytracer::render::{RenderOptions, render};
use std::path::PathBuf;

fn reference_dir() -> PathBuf {
    PathBuf::from(concat!(env!("CARGO_MANIFEST_DIR"), "/../../../shared/reference/cornell"))
}

fn load_scene() -> rib_parser::scene::Scene {
    let path = reference_dir().join("cornell.rib");
    rib_parser::load_scene(&path, &rib_parser::LoadOptions::default()).expect("the reference RIB loads").scene
}

#[test]
fn depth_table_matches_the_analytic_one() {
    let scene = load_scene();
    let out = render(
        &scene,
        &RenderOptions { spp: Some(1), depth: true, threads: Some(2), ..RenderOptions::default() },
    )
    .unwrap();
    let depth = out.depth.unwrap();
    let reference = DepthTable::read(reference_dir().join("depth-analytic.depth")).unwrap();
    assert_eq!((depth.width, depth.height), (reference.width(), reference.height()));
    let mut worst = 0.0f64;
    let mut mismatched_misses = 0;
    for (i, (&ours, &theirs)) in depth.values.iter().zip(reference.values()).enumerate() {
        if ours.is_infinite() || theirs.is_infinite() {
            if ours != theirs {
                mismatched_misses += 1;
                eprintln!("pixel {} {}: ours {ours}, reference {theirs}", i % 512, i / 512);
            }
            continue;
        }
        worst = worst.max((f64::from(ours) - f64::from(theirs)).abs() / f64::from(theirs));
    }
    assert!(worst < 1e-5, "worst relative depth error {worst}");
    assert_eq!(mismatched_misses, 0);
}

/// Relative squared error of `x` against the reference value `r` (the metric of the reference's
/// README: `(x - r)^2 / (r^2 + 0.01)`).
fn rel_sq(x: f64, r: f64) -> f64 {
    (x - r) * (x - r) / (r * r + 0.01)
}

/// A 128x128 crop (the tall box, its shadow, both walls) at 16 samples per pixel, twice with
/// different seeds. Averaged over 8x8 blocks, the renders must agree with Mitsuba's image as
/// well as their own noise allows: the error against the reference stays within a few times
/// the noise measured from the two renders' difference, which catches any bias above a couple
/// of percent. The means must also agree within 1%.
#[test]
fn image_matches_the_mitsuba_reference_within_noise() {
    let mut scene = load_scene();
    scene.camera.crop_window = depth_remap::CropWindow { xmin: 0.25, xmax: 0.5, ymin: 0.5, ymax: 0.75 };
    let runs: Vec<_> = [1u64, 2]
        .iter()
        .map(|&seed| {
            render(&scene, &RenderOptions { spp: Some(16), seed, threads: Some(2), ..Default::default() })
                .unwrap()
                .image
        })
        .collect();
    let reference = image::open(reference_dir().join("reference-path-11520spp.exr")).unwrap().to_rgb32f();
    let (w, h) = (runs[0].width, runs[0].height);
    assert_eq!((w, h), (128, 128));
    let block = 8;
    let (mut err, mut noise, mut n) = (0.0f64, 0.0f64, 0.0f64);
    let mut sums = [[0.0f64; 3]; 2];
    for by in 0..h / block {
        for bx in 0..w / block {
            let mut a = [[0.0f64; 3]; 2];
            let mut r = [0.0f64; 3];
            for y in by * block..(by + 1) * block {
                for x in bx * block..(bx + 1) * block {
                    let p = reference.get_pixel(x + runs[0].x_offset, y + runs[0].y_offset);
                    for c in 0..3 {
                        r[c] += f64::from(p[c]);
                        for k in 0..2 {
                            a[k][c] += f64::from(runs[k].pixels[(y * w + x) as usize][c]);
                        }
                    }
                }
            }
            let m = f64::from(block * block);
            for c in 0..3 {
                let (a0, a1, rc) = (a[0][c] / m, a[1][c] / m, r[c] / m);
                err += rel_sq(0.5 * (a0 + a1), rc);
                // Variance of the two-render mean, estimated from their difference.
                noise += (a0 - a1) * (a0 - a1) / 4.0 / (rc * rc + 0.01);
                n += 1.0;
                sums[0][c] += a0 + a1;
                sums[1][c] += 2.0 * rc;
            }
        }
    }
    let (err, noise) = (err / n, noise / n);
    eprintln!("block relMSE {err:.3e}, noise {noise:.3e}");
    assert!(err < 3.0 * noise + 1e-4, "block relMSE {err:.3e} against noise {noise:.3e}");
    for (c, (ours, theirs)) in sums[0].iter().zip(&sums[1]).enumerate() {
        let ratio = ours / theirs;
        assert!((ratio - 1.0).abs() < 0.01, "channel {c}: mean ratio {ratio}");
    }
}
