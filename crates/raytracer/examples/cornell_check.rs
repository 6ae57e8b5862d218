//! The full Cornell-box check (run by `cargo xtask cornell-check`): renders
//! `../shared/reference/cornell/cornell.rib` with the path tracer, full frame, and compares it
//! with Mitsuba 3's converged image (relative MSE below 1e-3) and the analytic depth table
//! (relative 1e-5 everywhere, misses included).
//!
//! Usage: `cornell_check [--spp N] [--threads N] [--save DIR]` (default 256 samples per pixel).

use depth_remap::DepthTable;
use raytracer::render::{RenderOptions, render};
use std::path::PathBuf;
use std::process::ExitCode;
use std::time::Instant;

fn main() -> ExitCode {
    let mut spp = 256u32;
    let mut threads = None;
    let mut save = None;
    let mut args = std::env::args().skip(1);
    while let Some(a) = args.next() {
        let mut value = || args.next().unwrap_or_default();
        match a.as_str() {
            "--spp" => spp = value().parse().unwrap_or(spp),
            "--threads" => threads = value().parse().ok(),
            "--save" => save = Some(PathBuf::from(value())),
            other => {
                eprintln!("cornell_check: unknown argument {other}");
                return ExitCode::from(2);
            }
        }
    }
    let dir = PathBuf::from(concat!(env!("CARGO_MANIFEST_DIR"), "/../../../shared/reference/cornell"));
    let loaded = match rib_parser::load_scene(&dir.join("cornell.rib"), &rib_parser::LoadOptions::default()) {
        Ok(l) => l,
        Err(e) => {
            eprint!("{}", e.render());
            return ExitCode::FAILURE;
        }
    };
    let start = Instant::now();
    let options = RenderOptions { spp: Some(spp), threads, depth: true, seed: 1, ..RenderOptions::default() };
    let out = match render(&loaded.scene, &options) {
        Ok(o) => o,
        Err(e) => {
            eprintln!("cornell_check: {e}");
            return ExitCode::FAILURE;
        }
    };
    let seconds = start.elapsed().as_secs_f64();
    let reference = match image::open(dir.join("reference-path-11520spp.exr")) {
        Ok(i) => i.to_rgb32f(),
        Err(e) => {
            eprintln!("cornell_check: reference image: {e}");
            return ExitCode::FAILURE;
        }
    };
    let img = &out.image;
    let (mut rel, mut n) = (0.0f64, 0.0f64);
    let mut means = [[0.0f64; 3]; 2];
    for y in 0..img.height {
        for x in 0..img.width {
            let ours = img.pixels[(y * img.width + x) as usize];
            let r = reference.get_pixel(x, y);
            for c in 0..3 {
                let (a, b) = (f64::from(ours[c]), f64::from(r[c]));
                rel += (a - b) * (a - b) / (b * b + 0.01);
                n += 1.0;
                means[0][c] += a;
                means[1][c] += b;
            }
        }
    }
    let rel = rel / n;
    let px = f64::from(img.width * img.height);
    let depth = out.depth.as_ref().map(|d| d.values.clone()).unwrap_or_default();
    let analytic = match DepthTable::read(dir.join("depth-analytic.depth")) {
        Ok(t) => t,
        Err(e) => {
            eprintln!("cornell_check: {e}");
            return ExitCode::FAILURE;
        }
    };
    let mut worst_depth = 0.0f64;
    let mut miss_mismatch = 0;
    for (&a, &b) in depth.iter().zip(analytic.values()) {
        if a.is_finite() && b.is_finite() {
            worst_depth = worst_depth.max((f64::from(a) - f64::from(b)).abs() / f64::from(b));
        } else if a != b {
            miss_mismatch += 1;
        }
    }
    let s = &out.stats;
    println!(
        "cornell-check: {spp} spp, {} threads, render {:.1} s ({seconds:.1} s with build), {:.2} M rays/s",
        s.threads,
        s.time_render.as_secs_f64(),
        s.rays_per_second() / 1e6
    );
    println!(
        "cornell-check: image relMSE {rel:.3e} (bar 1e-3); mean RGB ours {:.4} {:.4} {:.4}, Mitsuba {:.4} {:.4} {:.4}",
        means[0][0] / px,
        means[0][1] / px,
        means[0][2] / px,
        means[1][0] / px,
        means[1][1] / px,
        means[1][2] / px
    );
    println!(
        "cornell-check: depth worst relative error {worst_depth:.3e} (bar 1e-5), {miss_mismatch} miss mismatches"
    );
    if let Some(dir) = save {
        let _ = std::fs::create_dir_all(&dir);
        let settings = raytracer::output::OutputSettings {
            exposure: loaded.scene.render.exposure,
            quantize: loaded.scene.render.quantize,
            alpha: false,
        };
        if let Err(e) = raytracer::output::write_image(&dir.join("cornell.exr"), "openexr", img, &settings) {
            eprintln!("cornell_check: {e}");
        }
    }
    let ok = rel < 1e-3 && worst_depth < 1e-5 && miss_mismatch == 0 && depth.len() == analytic.values().len();
    if ok {
        println!("cornell-check: ok");
        ExitCode::SUCCESS
    } else {
        println!("cornell-check: FAILED");
        ExitCode::FAILURE
    }
}
