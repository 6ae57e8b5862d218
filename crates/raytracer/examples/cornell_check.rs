//! Renders the reference Cornell box and prints the relative MSE against Mitsuba's image.
//! Usage: cornell_check [SPP] [CROP x0 x1 y0 y1 as fractions]

use raytracer::render::{RenderOptions, render};
use std::path::PathBuf;
use std::time::Instant;

fn main() {
    let args: Vec<String> = std::env::args().collect();
    let spp: u32 = args.get(1).and_then(|s| s.parse().ok()).unwrap_or(16);
    let dir = PathBuf::from(concat!(env!("CARGO_MANIFEST_DIR"), "/../../../shared/reference/cornell"));
    let mut scene =
        rib_parser::load_scene(&dir.join("cornell.rib"), &rib_parser::LoadOptions::default()).unwrap().scene;
    if args.len() >= 6 {
        let f = |i: usize| args[i].parse::<f64>().unwrap();
        scene.camera.crop_window = depth_remap::CropWindow { xmin: f(2), xmax: f(3), ymin: f(4), ymax: f(5) };
    }
    let start = Instant::now();
    let out = render(&scene, &RenderOptions { spp: Some(spp), seed: 1, ..RenderOptions::default() }).unwrap();
    let secs = start.elapsed().as_secs_f64();
    let reference = image::open(dir.join("reference-path-11520spp.exr")).unwrap().to_rgb32f();
    let img = &out.image;
    let mut sum = 0.0f64;
    let mut n = 0.0f64;
    let mut mean_ours = [0.0f64; 3];
    let mut mean_ref = [0.0f64; 3];
    for y in 0..img.height {
        for x in 0..img.width {
            let ours = img.pixels[(y * img.width + x) as usize];
            let r = reference.get_pixel(x + img.x_offset, y + img.y_offset);
            for c in 0..3 {
                let (a, b) = (f64::from(ours[c]), f64::from(r[c]));
                sum += (a - b) * (a - b) / (b * b + 0.01);
                n += 1.0;
                mean_ours[c] += a;
                mean_ref[c] += b;
            }
        }
    }
    let px = f64::from(img.width * img.height);
    println!(
        "spp {spp}: {secs:.2} s, relMSE {:.3e}, mean ours {:.4} {:.4} {:.4}, reference {:.4} {:.4} {:.4}, rays/s {:.3e}",
        sum / n,
        mean_ours[0] / px,
        mean_ours[1] / px,
        mean_ours[2] / px,
        mean_ref[0] / px,
        mean_ref[1] / px,
        mean_ref[2] / px,
        out.stats.rays_per_second()
    );
}
