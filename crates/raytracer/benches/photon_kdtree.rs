//! The photon map's own kd-tree against `kiddo` (a well-kept kd-tree crate) on photon-like
//! data: points on the six faces of a box, as photons on the walls of a Cornell box.
//! Measures building and the two queries a photon mapper makes: the 50 nearest within a radius
//! (density estimates) and the single nearest (radiance-photon lookups).
//!
//! `cargo bench -p raytracer --bench photon_kdtree`; results in docs/photon-mapping.md.

use criterion::{BenchmarkId, Criterion, criterion_group, criterion_main};
use glam::Vec3;
use kiddo::{ImmutableKdTree, SquaredEuclidean};
use raytracer::photon::kdtree::{KdTree, KnnHeap};
use raytracer::sampling::Rng;
use std::hint::black_box;
use std::num::NonZeroUsize;

/// `n` points uniformly on the faces of the cube `[-1, 1]^3`.
fn box_points(n: usize, seed: u64) -> Vec<Vec3> {
    let mut rng = Rng::new(seed, 1);
    (0..n)
        .map(|_| {
            let face = rng.below(6);
            let (a, b) = (rng.uniform() * 2.0 - 1.0, rng.uniform() * 2.0 - 1.0);
            let s = if face.is_multiple_of(2) { -1.0 } else { 1.0 };
            match face / 2 {
                0 => Vec3::new(s, a, b),
                1 => Vec3::new(a, s, b),
                _ => Vec3::new(a, b, s),
            }
        })
        .collect()
}

fn bench(c: &mut Criterion) {
    let queries = box_points(4096, 99);
    let max_d2 = 0.03f32;
    let k = 50;
    let mut group = c.benchmark_group("photon_kdtree");
    group.sample_size(10);
    for n in [100_000usize, 1_000_000] {
        let points = box_points(n, 7);
        let arrays: Vec<[f32; 3]> = points.iter().map(|p| p.to_array()).collect();
        group.bench_with_input(BenchmarkId::new("build/own", n), &points, |b, p| {
            b.iter(|| KdTree::build(black_box(p.clone())))
        });
        group.bench_with_input(BenchmarkId::new("build/kiddo", n), &arrays, |b, a| {
            b.iter(|| ImmutableKdTree::<f32, 3>::new_from_slice(black_box(a)).expect("builds"))
        });
        let own = KdTree::build(points.clone());
        let kd = ImmutableKdTree::<f32, 3>::new_from_slice(&arrays).expect("builds");
        group.bench_function(BenchmarkId::new("knn50/own", n), |b| {
            let mut heap = KnnHeap::new(k);
            b.iter(|| {
                let mut found = 0;
                for q in &queries {
                    own.knn(*q, max_d2, &mut heap, |_| true);
                    found += heap.len();
                }
                found
            })
        });
        group.bench_function(BenchmarkId::new("knn50/kiddo", n), |b| {
            b.iter(|| {
                let mut found = 0;
                for q in &queries {
                    let r = kd
                        .query(&q.to_array())
                        .nearest_n::<SquaredEuclidean<f32>>(NonZeroUsize::new(k).expect("k > 0"))
                        .within(max_d2)
                        .unsorted()
                        .execute();
                    found += r.len();
                }
                found
            })
        });
        group.bench_function(BenchmarkId::new("nearest/own", n), |b| {
            b.iter(|| queries.iter().filter(|q| own.nearest(**q, max_d2, |_| true).is_some()).count())
        });
        group.bench_function(BenchmarkId::new("nearest/kiddo", n), |b| {
            b.iter(|| {
                queries
                    .iter()
                    .filter(|q| {
                        kd.query(&q.to_array()).nearest_one::<SquaredEuclidean<f32>>().execute().distance
                            < max_d2
                    })
                    .count()
            })
        });
    }
    group.finish();
}

criterion_group!(benches, bench);
criterion_main!(benches);
