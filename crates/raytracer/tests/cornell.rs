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
