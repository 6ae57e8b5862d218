//! Single-core throughput of the depth-table text path and the remap on a 4096 x 4096 table,
//! measured in **CPU time of the measuring thread** (`/proc/thread-self/schedstat`, Linux) as
//! well as wall time, so that figures taken on a shared machine still say what one core does.
//! The criterion benchmarks (`benches/depth.rs`) measure wall time.
//!
//! `cargo run --release -p depth-remap --example table_throughput`

use depth_remap::*;
use glam::DVec3;
use std::time::Instant;

const SIZE: u32 = 4096;

/// Nanoseconds this thread has run on a CPU, when the kernel tells us.
fn thread_cpu_ns() -> Option<u64> {
    let text = std::fs::read_to_string("/proc/thread-self/schedstat").ok()?;
    text.split_whitespace().next()?.parse().ok()
}

/// Runs `f` `runs` times; returns the best wall and the best CPU seconds of one run.
fn measure<T>(runs: usize, mut f: impl FnMut() -> T) -> (f64, Option<f64>) {
    let (mut best_wall, mut best_cpu) = (f64::INFINITY, None::<f64>);
    for _ in 0..runs {
        let cpu0 = thread_cpu_ns();
        let t0 = Instant::now();
        std::hint::black_box(f());
        let wall = t0.elapsed().as_secs_f64();
        let cpu = match (cpu0, thread_cpu_ns()) {
            (Some(a), Some(b)) => Some((b - a) as f64 * 1e-9),
            _ => None,
        };
        best_wall = best_wall.min(wall);
        best_cpu = match (best_cpu, cpu) {
            (Some(b), Some(c)) => Some(b.min(c)),
            (None, c) => c,
            (b, None) => b,
        };
    }
    (best_wall, best_cpu)
}

fn main() {
    let camera = Camera::new(CameraSettings {
        x_resolution: SIZE,
        y_resolution: SIZE,
        projection: Projection::Perspective { fov_degrees: 40.0 },
        camera_from_world: glam::dcamera::lh::view::look_at_mat4(
            DVec3::new(0.3, 1.0, -6.0),
            DVec3::ZERO,
            DVec3::Y,
        ),
        ..CameraSettings::default()
    })
    .unwrap();
    // A sphere in front of a slanted wall, misses down the left edge (as in benches/depth.rs).
    let mut values = Vec::with_capacity((SIZE * SIZE) as usize);
    for j in 0..SIZE {
        for i in 0..SIZE {
            let ray = camera.pixel_centre_world_ray(i, j);
            let b = ray.origin.dot(ray.direction);
            let disc = b * b - (ray.origin.length_squared() - 1.0);
            let t = if disc >= 0.0 {
                -b - disc.sqrt()
            } else {
                let n = DVec3::new(0.2, 0.0, 1.0);
                let t = (2.0 - n.dot(ray.origin)) / n.dot(ray.direction);
                if t > 0.0 && i > 64 { t } else { f64::INFINITY }
            };
            values.push(t as f32);
        }
    }
    let table = DepthTable::new(SIZE, SIZE, values).unwrap();
    let text = table.to_text(1);
    let mb = text.len() as f64 / 1e6;
    let pixels = f64::from(SIZE * SIZE);
    println!("4096 x 4096 table: {:.1} MB of text ({:.2} bytes per value)\n", mb, text.len() as f64 / pixels);
    println!("| operation (one thread) | wall | CPU | per CPU second |");
    println!("|---|---|---|---|");
    let row = |name: &str, (wall, cpu): (f64, Option<f64>), amount: f64, unit: &str| {
        let cpu_text = cpu.map_or("n/a".to_string(), |c| format!("{:.0} ms", c * 1e3));
        let rate = amount / cpu.unwrap_or(wall);
        println!("| {name} | {:.0} ms | {cpu_text} | {rate:.0} {unit} |", wall * 1e3);
    };
    let options = ParseOptions { threads: 1, ..ParseOptions::default() };
    row("format text", measure(3, || table.to_text(1)), mb, "MB/s");
    row("parse text", measure(3, || DepthTable::parse_with(&text, options).unwrap()), mb, "MB/s");
    let range = camera.eye_depth_range(&table).unwrap();
    let planes = choose_near_far(range, camera.clipping(), NearFarPolicy::default());
    for (name, convention, infinite_far) in [
        ("remap, reversed-Z infinite", DepthConvention::WgpuReversed, true),
        ("remap, OpenGL finite", DepthConvention::Gl, false),
    ] {
        let mapping = camera.depth_mapping(convention, NearFar { infinite_far, ..planes }).unwrap();
        let (wall, cpu) =
            measure(3, || remap_depth_table(&camera, &table, &mapping, DepthOutput::Window, 1).unwrap());
        let ns = cpu.unwrap_or(wall) * 1e9 / pixels;
        println!(
            "| {name} | {:.0} ms | {} | {ns:.1} ns/pixel |",
            wall * 1e3,
            cpu.map_or("n/a".into(), |c| format!("{:.0} ms", c * 1e3))
        );
    }
}
