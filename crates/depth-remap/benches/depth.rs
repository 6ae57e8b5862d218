//! Benchmarks on a 4096 x 4096 table (the size the issue asks about):
//! - remapping radial depth to window depth (time per pixel), one thread and all threads;
//! - formatting and parsing the ASCII table (MB/s of text), one thread and all threads;
//! - writing and reading files (text and OpenEXR), atomic write included.
//!
//! `cargo bench -p depth-remap --bench depth` (figures in `docs/depth-mapping.md`).

use criterion::{BenchmarkId, Criterion, Throughput, criterion_group, criterion_main};
use depth_remap::*;
use glam::DVec3;
use std::hint::black_box;
use std::time::Duration;

const SIZE: u32 = 4096;

fn camera() -> Camera {
    Camera::new(CameraSettings {
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
    .unwrap()
}

/// A Cornell-box-like table: a sphere in front of a slanted wall, a few misses at the edge.
fn table(camera: &Camera) -> DepthTable {
    let mut values = Vec::with_capacity((SIZE * SIZE) as usize);
    for j in 0..SIZE {
        for i in 0..SIZE {
            let ray = camera.pixel_centre_world_ray(i, j);
            let b = ray.origin.dot(ray.direction);
            let c = ray.origin.length_squared() - 1.0;
            let disc = b * b - c;
            let t = if disc >= 0.0 {
                -b - disc.sqrt()
            } else {
                // Plane z = 2 - 0.2 x.
                let n = DVec3::new(0.2, 0.0, 1.0);
                let denom = n.dot(ray.direction);
                let t = (2.0 - n.dot(ray.origin)) / denom;
                if t > 0.0 && i > 64 { t } else { f64::INFINITY }
            };
            values.push(t as f32);
        }
    }
    DepthTable::new(SIZE, SIZE, values).unwrap()
}

fn benches(c: &mut Criterion) {
    let camera = camera();
    let table = table(&camera);
    let pixels = u64::from(SIZE * SIZE);
    let threads = std::thread::available_parallelism().map_or(1, |n| n.get());

    let range = camera.eye_depth_range(&table).unwrap();
    let planes = choose_near_far(range, camera.clipping(), NearFarPolicy::default());
    let mut group = c.benchmark_group("remap_4096");
    group.sample_size(10).measurement_time(Duration::from_secs(8)).throughput(Throughput::Elements(pixels));
    for (name, convention, infinite_far) in [
        ("reversed_infinite", DepthConvention::WgpuReversed, true),
        ("gl_finite", DepthConvention::Gl, false),
    ] {
        let mapping = camera.depth_mapping(convention, NearFar { infinite_far, ..planes }).unwrap();
        for t in [1, threads] {
            group.bench_with_input(BenchmarkId::new(name, format!("{t}_threads")), &t, |b, &t| {
                b.iter(|| remap_depth_table(&camera, &table, &mapping, DepthOutput::Window, t).unwrap())
            });
        }
    }
    group.finish();

    let text = table.to_text(1);
    let mut group = c.benchmark_group("text_4096");
    group
        .sample_size(10)
        .measurement_time(Duration::from_secs(10))
        .throughput(Throughput::Bytes(text.len() as u64));
    for t in [1, threads] {
        group.bench_with_input(BenchmarkId::new("format", format!("{t}_threads")), &t, |b, &t| {
            b.iter(|| black_box(table.to_text(t)))
        });
        group.bench_with_input(BenchmarkId::new("parse", format!("{t}_threads")), &t, |b, &t| {
            let options = ParseOptions { threads: t, ..ParseOptions::default() };
            b.iter(|| DepthTable::parse_with(black_box(&text), options).unwrap())
        });
    }
    group.finish();

    let scratch = tempfile::Builder::new().prefix("depth-remap-bench-").tempdir().unwrap();
    let dir = scratch.path();
    let mut group = c.benchmark_group("file_4096");
    group.sample_size(10).measurement_time(Duration::from_secs(10));
    for name in ["table.depth", "table.exr"] {
        let path = dir.join(name);
        // Text in MB/s of text; OpenEXR in pixels per second.
        group.throughput(if name.ends_with(".exr") {
            Throughput::Elements(pixels)
        } else {
            Throughput::Bytes(text.len() as u64)
        });
        group.bench_function(BenchmarkId::new("write", name), |b| b.iter(|| table.write(&path).unwrap()));
        group.bench_function(BenchmarkId::new("read", name), |b| b.iter(|| DepthTable::read(&path).unwrap()));
    }
    group.finish();
}

criterion_group!(depth, benches);
criterion_main!(depth);
