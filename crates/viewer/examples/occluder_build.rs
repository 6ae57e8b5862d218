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

fn scattered(n: usize) -> Vec<[Vec3; 3]> {
    let mut s = 0x9e37_79b9_7f4a_7c15u64;
    let mut next = || {
        s ^= s << 13;
        s ^= s >> 7;
        s ^= s << 17;
        (s >> 40) as f32 / (1u64 << 24) as f32
    };
    (0..n)
        .map(|_| {
            let c = Vec3::new(next(), next(), next()) * 100.0 - 50.0;
            let mut corner = || c + Vec3::new(next(), next(), next()) - 0.5;
            [corner(), corner(), corner()]
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
