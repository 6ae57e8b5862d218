//! Ray-tracing benchmarks (run by `cargo xtask bench-raytracer`): for the Cornell box and a large
//! corpus mesh, world build time and size, primary-ray throughput of our traversal against
//! obvhs' own traversal on the same BVH, and a full render. Prints Markdown tables.
//!
//! Usage: `bench [--spp N] [--repeat N]`.

use glam::Vec3;
use rayon::prelude::*;
use raytracer::diagnostics::Diagnostics;
use raytracer::render::{CameraRays, RenderOptions, pixel_footprint, render};
use raytracer::world::{Ray, World};
use std::path::PathBuf;
use std::time::Instant;

struct Case {
    name: &'static str,
    path: PathBuf,
}

fn main() {
    let mut spp = 16u32;
    let mut repeat = 3usize;
    let mut args = std::env::args().skip(1);
    while let Some(a) = args.next() {
        match a.as_str() {
            "--spp" => spp = args.next().and_then(|v| v.parse().ok()).unwrap_or(spp),
            "--repeat" => repeat = args.next().and_then(|v| v.parse().ok()).unwrap_or(repeat),
            _ => {}
        }
    }
    let shared = PathBuf::from(concat!(env!("CARGO_MANIFEST_DIR"), "/../../../shared"));
    let cases = [
        Case { name: "Cornell box", path: shared.join("reference/cornell/cornell.rib") },
        Case {
            name: "Killeroo (NURBS, RibTools)",
            path: shared.join(
                "rib-corpus/dpasca__RibTools/DistribSrc__base__TestScenes__KillerooNURBS__killeroo.rib",
            ),
        },
    ];
    println!("| scene | pixels | triangles | world build | BVH build | BVH nodes | BVH + triangles |");
    println!("|---|---|---|---|---|---|---|");
    let mut worlds = Vec::new();
    for case in &cases {
        let loaded = rib_parser::load_scene(&case.path, &Default::default()).expect("scene loads");
        let scene = loaded.scene;
        let camera = depth_remap::Camera::new(scene.camera.clone()).unwrap();
        let start = Instant::now();
        let world = World::build(
            &scene,
            camera.eye_position(),
            pixel_footprint(&camera),
            &mut Diagnostics::default(),
        )
        .unwrap();
        let build = start.elapsed();
        let s = &world.stats;
        let (w, h) = camera.resolution();
        println!(
            "| {} | {}x{} | {} | {:.3} s | {:.3} s | {} | {:.1} MiB |",
            case.name,
            w,
            h,
            s.triangles,
            build.as_secs_f64(),
            s.bvh_build_time.as_secs_f64(),
            s.bvh_nodes,
            s.bvh_bytes as f64 / 1048576.0
        );
        worlds.push((case, scene, camera, world));
    }

    println!();
    println!("Primary rays (pixel-centre rays, closest hit), million rays per second:");
    println!();
    println!(
        "| scene | ours, 1 thread | obvhs traversal + our triangle test, 1 thread | obvhs traversal + obvhs RtTriangle, 1 thread | ours, all threads |"
    );
    println!("|---|---|---|---|---|");
    for (case, _scene, camera, world) in &worlds {
        let cam_rays = CameraRays::new(camera.clone(), &world.render_from_world);
        let (w, h) = camera.resolution();
        let rays: Vec<Ray> = (0..h)
            .flat_map(|j| (0..w).map(move |i| (i, j)))
            .filter_map(|(i, j)| cam_rays.pixel_centre_ray(i, j).map(|r| r.0))
            .collect();
        let time = |f: &dyn Fn() -> usize| {
            let mut best = f64::INFINITY;
            let mut hits = 0;
            for _ in 0..repeat {
                let t = Instant::now();
                hits = f();
                best = best.min(t.elapsed().as_secs_f64());
            }
            (rays.len() as f64 / best / 1e6, hits)
        };
        let (ours, hits_ours) = time(&|| rays.iter().filter(|r| world.intersect(r).is_some()).count());
        let (ours_mt, _) = time(&|| rays.par_iter().filter(|r| world.intersect(r).is_some()).count());
        let (obvhs_ours, obvhs_native, hits_obvhs) = match world.single_level_triangles() {
            Some((bvh, tris)) => {
                let (a, hits) = time(&|| {
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
                });
                let rt: Vec<obvhs::rt_triangle::RtTriangle> = tris
                    .iter()
                    .map(|p| obvhs::rt_triangle::RtTriangle::new(p[0].into(), p[1].into(), p[2].into()))
                    .collect();
                let (b, _) = time(&|| {
                    rays.iter()
                        .filter(|r| {
                            bvh.closest_with_obvhs_traversal(r.origin, r.direction, r.t_max, |ray, slot| {
                                rt[slot as usize].intersect(ray)
                            })
                            .is_some()
                        })
                        .count()
                });
                (format!("{a:.2}"), format!("{b:.2}"), hits)
            }
            None => ("n/a".into(), "n/a".into(), hits_ours),
        };
        assert_eq!(hits_ours, hits_obvhs, "{}: the traversals disagree on hits", case.name);
        println!("| {} | {ours:.2} | {obvhs_ours} | {obvhs_native} | {ours_mt:.2} |", case.name);
    }

    println!();
    println!("Full renders ({spp} samples per pixel, the scene's integrator and filter):");
    println!();
    println!("| scene | integrator | threads | render time | rays | M rays/s |");
    println!("|---|---|---|---|---|---|");
    for (case, scene, _camera, _world) in &worlds {
        let out = render(scene, &RenderOptions { spp: Some(spp), ..Default::default() }).unwrap();
        let s = &out.stats;
        println!(
            "| {} | {} | {} | {:.2} s | {} | {:.2} |",
            case.name,
            s.integrator,
            s.threads,
            s.time_render.as_secs_f64(),
            s.rays.total(),
            s.rays_per_second() / 1e6
        );
    }
    let _ = Vec3::ZERO;
}
