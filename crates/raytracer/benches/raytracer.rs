//! Criterion benchmarks: primary rays through the Cornell box with our traversal and with
//! obvhs' own on the same BVH, and the two triangle tests. The larger study (a corpus mesh, full
//! renders, Markdown tables) is `cargo xtask bench-raytracer`.

use criterion::{Criterion, Throughput, criterion_group, criterion_main};
use raytracer::diagnostics::Diagnostics;
use raytracer::render::{CameraRays, pixel_footprint};
use raytracer::world::{Ray, World};
use std::hint::black_box;
use std::path::PathBuf;

fn cornell() -> (World, Vec<Ray>) {
    let path =
        PathBuf::from(concat!(env!("CARGO_MANIFEST_DIR"), "/../../../shared/reference/cornell/cornell.rib"));
    let scene = rib_parser::load_scene(&path, &Default::default()).unwrap().scene;
    let camera = depth_remap::Camera::new(scene.camera.clone()).unwrap();
    let world =
        World::build(&scene, camera.eye_position(), pixel_footprint(&camera), &mut Diagnostics::default())
            .unwrap();
    let rays = CameraRays::new(camera, &world.render_from_world);
    // Every fourth pixel in each direction: 16384 rays.
    let list = (0..128u32)
        .flat_map(|j| (0..128u32).map(move |i| (4 * i, 4 * j)))
        .filter_map(|(i, j)| rays.pixel_centre_ray(i, j).map(|r| r.0))
        .collect();
    (world, list)
}

fn primary_rays(c: &mut Criterion) {
    let (world, rays) = cornell();
    let mut group = c.benchmark_group("cornell primary rays");
    group.throughput(Throughput::Elements(rays.len() as u64));
    group.bench_function("ours", |b| {
        b.iter(|| rays.iter().filter(|r| world.intersect(black_box(r)).is_some()).count())
    });
    let (bvh, tris) = world.single_level_triangles().unwrap();
    group.bench_function("obvhs traversal, our triangle test", |b| {
        b.iter(|| {
            rays.iter()
                .filter(|r| {
                    let shear = raytracer::shapes::RayShear::new(r.origin, r.direction).unwrap();
                    bvh.closest_with_obvhs_traversal(r.origin, r.direction, r.t_max, |ray, slot| {
                        let p = &tris[slot as usize];
                        raytracer::shapes::intersect_triangle(&shear, p[0], p[1], p[2], ray.tmax)
                            .map_or(f32::INFINITY, |h| h.t)
                    })
                    .is_some()
                })
                .count()
        })
    });
    let rt: Vec<obvhs::rt_triangle::RtTriangle> = tris
        .iter()
        .map(|p| obvhs::rt_triangle::RtTriangle::new(p[0].into(), p[1].into(), p[2].into()))
        .collect();
    group.bench_function("obvhs traversal, obvhs RtTriangle", |b| {
        b.iter(|| {
            rays.iter()
                .filter(|r| {
                    bvh.closest_with_obvhs_traversal(r.origin, r.direction, r.t_max, |ray, slot| {
                        rt[slot as usize].intersect(ray)
                    })
                    .is_some()
                })
                .count()
        })
    });
    group.finish();
}

criterion_group! {
    name = benches;
    config = Criterion::default().sample_size(20);
    targets = primary_rays
}
criterion_main!(benches);
