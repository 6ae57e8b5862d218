//! Proxy update time per haptic tick against triangle count, and BVH build time.
//!
//! The scene is a bumpy height field of 1e3 .. 1e6 triangles over a 1 m square; the device
//! presses 2 mm into it (proxy radius 5 mm) and slides in a circle at 0.1 m/s (a stroke) and at
//! 1 m/s (a fast swipe), with friction. One iteration is one full tick: mapping, the proxy's
//! swept-sphere updates, friction, force and safety.
//!
//! Run: `cargo bench -p haptics --bench proxy` (figures in docs/haptics.md).

use criterion::{BenchmarkId, Criterion, criterion_group, criterion_main};
use glam::DVec3;
use haptics::*;
use std::hint::black_box;
use std::sync::Arc;

fn height(x: f64, y: f64) -> f64 {
    0.02 * (std::f64::consts::TAU * 3.0 * x).sin() * (std::f64::consts::TAU * 2.0 * y).cos()
}

/// About `triangles` triangles: a `n x n` grid of quads over [-0.5, 0.5]^2.
fn terrain(triangles: usize) -> CollisionMesh {
    let n = ((triangles as f64 / 2.0).sqrt().round() as usize).max(1);
    let mut positions = Vec::with_capacity((n + 1) * (n + 1));
    for j in 0..=n {
        for i in 0..=n {
            let x = -0.5 + i as f64 / n as f64;
            let y = -0.5 + j as f64 / n as f64;
            positions.push(DVec3::new(x, y, height(x, y)));
        }
    }
    let row = n as u32 + 1;
    let mut tris = Vec::with_capacity(2 * n * n);
    for j in 0..n as u32 {
        for i in 0..n as u32 {
            let a = j * row + i;
            tris.push([a, a + 1, a + row + 1]);
            tris.push([a, a + row + 1, a + row]);
        }
    }
    let mut mesh = CollisionMesh::new(DVec3::ZERO);
    mesh.push_indexed(&positions, &tris, None, MaterialId(0)).unwrap();
    mesh
}

const SIZES: [usize; 4] = [1_000, 10_000, 100_000, 1_000_000];

fn proxy_tick(c: &mut Criterion) {
    let mut group = c.benchmark_group("proxy_tick");
    let radius = 0.005;
    for &size in &SIZES {
        let world = Arc::new(CollisionWorld::new(terrain(size)));
        eprintln!(
            "{} triangles: BVH built in {:.1} ms ({} nodes, depth {})",
            world.mesh().triangle_count(),
            world.build_time().as_secs_f64() * 1e3,
            world.bvh().node_count(),
            world.bvh().depth()
        );
        for speed in [0.1, 1.0] {
            // A circle of radius 0.2 m, 2 mm below where the proxy rests, one sample per tick.
            let ticks = (std::f64::consts::TAU * 0.2 / speed * 1000.0) as usize;
            let path: Vec<DVec3> = (0..ticks)
                .map(|k| {
                    let a = std::f64::consts::TAU * k as f64 / ticks as f64;
                    let (x, y) = (0.2 * a.cos(), 0.2 * a.sin());
                    DVec3::new(x, y, height(x, y) + radius - 0.002)
                })
                .collect();
            let specs = SimulatedDevice::default_specs();
            let materials = MaterialTable::uniform(Material {
                stiffness: 1000.0,
                static_friction: 0.3,
                dynamic_friction: 0.2,
            });
            let mapping = WorkspaceMapping::new(DVec3::ZERO, 1.0).unwrap();
            let mut renderer = HapticRenderer::new(
                Arc::clone(&world),
                materials,
                &specs,
                mapping,
                RenderSettings::new(radius),
            );
            // Settle on the surface first.
            let sample =
                |p: DVec3| DeviceSample { position: p, orientation: None, buttons: 0, timestamp: 0.0 };
            renderer.tick(0.0, &sample(path[0] + DVec3::Z * 0.02), 1e-3);
            for k in 0..100 {
                renderer.tick(0.0, &sample(path[0]), 1e-3);
                black_box(k);
            }
            let mut k = 0usize;
            group.bench_with_input(
                BenchmarkId::new(format!("{speed} m/s"), world.mesh().triangle_count()),
                &size,
                |b, _| {
                    b.iter(|| {
                        k = (k + 1) % path.len();
                        black_box(renderer.tick(k as f64 * 1e-3, &sample(path[k]), 1e-3))
                    })
                },
            );
        }
    }
    group.finish();
}

fn bvh_build(c: &mut Criterion) {
    let mut group = c.benchmark_group("bvh_build");
    group.sample_size(10);
    for &size in &SIZES {
        let mesh = terrain(size);
        group.bench_with_input(BenchmarkId::from_parameter(mesh.triangle_count()), &mesh, |b, mesh| {
            b.iter(|| black_box(Bvh::build(mesh)))
        });
    }
    group.finish();
}

criterion_group!(benches, proxy_tick, bvh_build);
criterion_main!(benches);
