//! Renders every RIB file given on the command line that parses, small and at one sample per
//! pixel, and reports time, warnings and any non-finite value.

use raytracer::render::{RenderOptions, render};
use std::time::Instant;

fn main() {
    for path in std::env::args().skip(1) {
        let loaded = match rib_parser::load_scene(std::path::Path::new(&path), &Default::default()) {
            Ok(l) => l,
            Err(_) => continue,
        };
        let mut scene = loaded.scene;
        let (w, h) = (scene.camera.x_resolution, scene.camera.y_resolution);
        let k = (f64::from(w.max(h)) / 64.0).max(1.0);
        scene.camera.x_resolution = ((f64::from(w) / k).round() as u32).max(1);
        scene.camera.y_resolution = ((f64::from(h) / k).round() as u32).max(1);
        let start = Instant::now();
        match render(
            &scene,
            &RenderOptions { spp: Some(1), depth: true, threads: Some(2), ..Default::default() },
        ) {
            Ok(out) => {
                let bad = out.image.pixels.iter().flatten().filter(|v| !v.is_finite()).count()
                    + out
                        .depth
                        .as_ref()
                        .map_or(0, |d| d.values.iter().filter(|v| v.is_nan() || **v < 0.0).count());
                let hits =
                    out.depth.as_ref().map_or(0, |d| d.values.iter().filter(|v| v.is_finite()).count());
                println!(
                    "{:7.2}s {:>6} tris {:>3} quads {:>4}/{:>4} hits bad {bad} warn {} mean {:.3} {}",
                    start.elapsed().as_secs_f64(),
                    out.stats.world.triangles,
                    out.stats.world.quadrics,
                    hits,
                    out.image.pixels.len(),
                    out.warnings.len(),
                    out.image.mean_rgb().x,
                    path.rsplit('/').next().unwrap_or(&path)
                );
                for w in out.warnings.iter().take(3) {
                    println!("          {w}");
                }
            }
            Err(e) => println!("  error {e}: {path}"),
        }
    }
}
