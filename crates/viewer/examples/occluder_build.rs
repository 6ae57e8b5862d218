//! Times `viewer::occluders::FlatBvh::build`, the hierarchy of the viewer's shadow rays, on a
//! tessellated sphere and on scattered triangles, and says how deep the hierarchies are (the
//! shaders' traversal stack holds 40 entries).
//!
//! `cargo run --release -p viewer --example occluder_build [TRIANGLES]` (default 2^20, the
//! scene budget `MAX_SCENE_OCCLUDER_TRIANGLES`).

use glam::Vec3;
use std::time::Instant;
use viewer::Mesh;
use viewer::occluders::{FlatBvh, MAX_SCENE_OCCLUDER_TRIANGLES};

/// Levels from the root to the deepest leaf.
fn depth(bvh: &FlatBvh) -> u32 {
    let mut deepest = 0;
    let mut stack = vec![(0u32, 1u32)];
    while let Some((k, d)) = stack.pop() {
        let Some(n) = bvh.nodes.get(k as usize) else { continue };
        deepest = deepest.max(d);
        if n[7].to_bits() == 0 {
            let first = n[3].to_bits();
            stack.extend([(first, d + 1), (first + 1, d + 1)]);
        }
    }
    deepest
}

/// `n` unit-sized triangles spread over a cube of side 100 by the R3 low-discrepancy sequence
/// (Roberts' generalised golden ratio): scattered, and the same on every run.
fn scattered(n: usize) -> Vec<[Vec3; 3]> {
    const G: f64 = 1.220_744_084_605_759_5;
    let step = [1.0 / G, 1.0 / (G * G), 1.0 / (G * G * G)];
    let at = |k: f64, offset: f64| {
        Vec3::new(
            (offset + k * step[0]).fract() as f32,
            (offset + k * step[1]).fract() as f32,
            (offset + k * step[2]).fract() as f32,
        )
    };
    (0..n)
        .map(|k| {
            let c = at(k as f64, 0.5) * 100.0 - 50.0;
            // Corners from further along the sequence: orientations vary from one to the next.
            [0.1, 0.3, 0.7].map(|o| c + at(7.0 * k as f64, o) - 0.5)
        })
        .collect()
}

fn sphere(n: usize) -> Vec<[Vec3; 3]> {
    // rings * segments * 2 triangles, segments = 2 rings.
    let rings = ((n as f64 / 4.0).sqrt().ceil() as u32).max(2);
    let mesh = Mesh::unit_sphere(rings, 2 * rings);
    let mut tris: Vec<[Vec3; 3]> =
        mesh.indices.chunks_exact(3).map(|t| [0, 1, 2].map(|k| mesh.positions[t[k] as usize])).collect();
    tris.truncate(n);
    tris
}

fn main() {
    let n = std::env::args().nth(1).and_then(|a| a.parse().ok()).unwrap_or(MAX_SCENE_OCCLUDER_TRIANGLES);
    for (name, tris) in [("sphere", sphere(n)), ("scattered", scattered(n))] {
        let mut best = f64::INFINITY;
        let mut bvh = FlatBvh::default();
        for _ in 0..3 {
            let start = Instant::now();
            bvh = FlatBvh::build(&tris);
            best = best.min(start.elapsed().as_secs_f64());
        }
        println!(
            "{name}: {} triangles, {} nodes, depth {}, build {:.1} ms (best of 3)",
            bvh.triangles.len(),
            bvh.nodes.len(),
            depth(&bvh),
            best * 1e3
        );
    }
}
