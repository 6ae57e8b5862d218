//! Ray-tracing benchmarks (run by `cargo xtask bench-raytracer`): for the Cornell box and a large
//! corpus mesh, world build time and size, primary-ray throughput of our traversal against
//! obvhs' own traversal on the same BVH, and a full render; then, one thread each, rays per
//! second for primary, shadow and incoherent rays against obvhs' traversal and an estimated
//! limit, and path-traced samples per CPU-second for the Cornell box, room, caustics and
//! Killeroo (`docs/performance.md`). Prints Markdown tables.
//!
//! Usage: `bench [--spp N] [--repeat N] [--path-spp N] [--paths scalar|wavefront]`;
//! `LRT_SHARED=DIR` finds the shared scenes when the checkout is not beside them. `--paths`
//! runs the path tracing rows with the scalar integrator or as a wavefront where the scene
//! qualifies (default: the renderer's choice).

use glam::Vec3;
use rayon::prelude::*;
use raytracer::accel::TraversalRay;
use raytracer::diagnostics::Diagnostics;
use raytracer::integrators::{DEFAULT_RR_DEPTH, IntegratorKind, UNBOUNDED_DEPTH};
use raytracer::lights::LightSampleContext;
use raytracer::render::{CameraRays, RenderOptions, pixel_footprint, render};
use raytracer::sampling::{Rng, sample_uniform_sphere};
use raytracer::shapes::{RayShear, intersect_triangle};
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
    let mut path_spp = 4u32;
    let mut wavefront = None;
    let mut args = std::env::args().skip(1);
    while let Some(a) = args.next() {
        match a.as_str() {
            "--spp" => spp = args.next().and_then(|v| v.parse().ok()).unwrap_or(spp),
            "--repeat" => repeat = args.next().and_then(|v| v.parse().ok()).unwrap_or(repeat),
            "--path-spp" => path_spp = args.next().and_then(|v| v.parse().ok()).unwrap_or(path_spp),
            "--paths" => wavefront = args.next().map(|v| v == "wavefront"),
            _ => {}
        }
    }
    // The project's `../shared` (beside the checkout); `LRT_SHARED` names it from a worktree
    // elsewhere.
    let shared = std::env::var_os("LRT_SHARED")
        .map(PathBuf::from)
        .unwrap_or_else(|| PathBuf::from(concat!(env!("CARGO_MANIFEST_DIR"), "/../../../shared")));
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

    ray_kinds(&worlds, repeat);
    samples_per_cpu_second(&shared, path_spp, wavefront);
}

/// Primary, shadow and incoherent rays of each world, one thread: ours against obvhs' own
/// traversal (with our watertight triangle test), with the traversal's node visits and
/// triangle tests per ray and the estimated limit (see `LIMIT_*`).
fn ray_kinds(worlds: &[(&Case, rib_parser::scene::Scene, depth_remap::Camera, World)], repeat: usize) {
    println!();
    println!("Rays per second per thread by kind (million; closest hit, shadow = any hit):");
    println!();
    println!(
        "| scene | rays | ours | obvhs traversal | ours / obvhs | nodes / ray | triangles / ray | triangle tests / ray as run, ours / obvhs | estimated limit | ours / limit |"
    );
    println!("|---|---|---|---|---|---|---|---|---|---|");
    for (case, _scene, camera, world) in worlds {
        let Some((bvh, tris)) = world.single_level_triangles() else { continue };
        let cam_rays = CameraRays::new(camera.clone(), &world.render_from_world);
        let (w, h) = camera.resolution();
        let primary: Vec<Ray> = (0..h)
            .flat_map(|j| (0..w).map(move |i| (i, j)))
            .filter_map(|(i, j)| cam_rays.pixel_centre_ray(i, j).map(|r| r.0))
            .collect();
        let mut rng = Rng::new(17, 3);
        let mut shadow = Vec::new();
        let mut incoherent = Vec::new();
        for ray in &primary {
            let Some(hit) = world.intersect(ray) else { continue };
            let si = world.interaction(ray, &hit);
            let set = world.light_set(si.attributes);
            if let Some((light, _)) = set.pick(rng.uniform()) {
                let ctx = LightSampleContext { p: si.p, p_error: si.p_error, n: si.ng, p64: si.p64 };
                if let Some(ls) = world.lights[light as usize].sample_li(&ctx, rng.uniform2()) {
                    shadow.push(match ls.p_light {
                        Some((p, err, n)) => si.spawn_ray_to(p, err, n),
                        None => si.spawn_ray(ls.wi),
                    });
                }
            }
            let mut d = sample_uniform_sphere(rng.uniform2());
            if d.dot(si.ng) * si.wo.dot(si.ng) < 0.0 {
                d = -d;
            }
            incoherent.push(si.spawn_ray(d));
        }
        let best = |f: &dyn Fn() -> usize| {
            let mut best = f64::INFINITY;
            for _ in 0..repeat {
                let t = Instant::now();
                std::hint::black_box(f());
                best = best.min(t.elapsed().as_secs_f64());
            }
            best
        };
        let closest_obvhs = |r: &Ray| {
            let shear = RayShear::new(r.origin, r.direction).unwrap();
            bvh.closest_with_obvhs_traversal(r.origin, r.direction, r.t_max, |ray, slot| {
                let p = &tris[slot as usize];
                intersect_triangle(&shear, p[0], p[1], p[2], ray.tmax)
                    .filter(|h| h.t > r.t_min)
                    .map_or(f32::INFINITY, |h| h.t)
            })
            .is_some()
        };
        let occluded_obvhs = |r: &Ray| {
            let shear = RayShear::new(r.origin, r.direction).unwrap();
            bvh.occluded_with_obvhs_traversal(r.origin, r.direction, r.t_max, |ray, slot| {
                let p = &tris[slot as usize];
                intersect_triangle(&shear, p[0], p[1], p[2], ray.tmax)
                    .filter(|h| h.t > r.t_min)
                    .map_or(f32::INFINITY, |h| h.t)
            })
        };
        let counts = |rays: &[Ray]| {
            let (mut nodes, mut prims) = (0u64, 0u64);
            for r in rays {
                let shear = RayShear::new(r.origin, r.direction).unwrap();
                let Some(mut tray) = TraversalRay::new(r.origin, r.direction, r.t_min, r.t_max) else {
                    continue;
                };
                let (n, p) = bvh.closest_counting(&mut tray, |tr, slot| {
                    let t = &tris[slot as usize];
                    intersect_triangle(&shear, t[0], t[1], t[2], tr.t_max)
                        .map(|h| h.t)
                        .filter(|&t| t > r.t_min)
                });
                nodes += u64::from(n);
                prims += u64::from(p);
            }
            let n = rays.len().max(1) as f64;
            (nodes as f64 / n, prims as f64 / n)
        };
        // Triangle tests per ray as each traversal runs the query (shadow rays stop at the first
        // blocker): ours, and obvhs' (whose node test skips boxes left before `t = 1e-4`, so
        // it does not test the leaf a ray leaving a surface starts in).
        let tests_as_run = |rays: &[Ray], is_shadow: bool| {
            let (mut ours, mut theirs) = (0u64, 0u64);
            for r in rays {
                let shear = RayShear::new(r.origin, r.direction).unwrap();
                let Some(tray) = TraversalRay::new(r.origin, r.direction, r.t_min, r.t_max) else {
                    continue;
                };
                let test = |slot: u32, t_max: f32| {
                    let p = &tris[slot as usize];
                    intersect_triangle(&shear, p[0], p[1], p[2], t_max).map(|h| h.t).filter(|&t| t > r.t_min)
                };
                let mut obvhs_test = |ray: &obvhs::ray::Ray, slot: u32| {
                    theirs += 1;
                    test(slot, ray.tmax).unwrap_or(f32::INFINITY)
                };
                if is_shadow {
                    bvh.occluded_with_obvhs_traversal(r.origin, r.direction, r.t_max, &mut obvhs_test);
                    bvh.any(&tray, |tr, slot| {
                        ours += 1;
                        test(slot, tr.t_max).is_some()
                    });
                } else {
                    bvh.closest_with_obvhs_traversal(r.origin, r.direction, r.t_max, &mut obvhs_test);
                    let mut tray = tray;
                    bvh.closest(&mut tray, |tr, slot| {
                        ours += 1;
                        test(slot, tr.t_max)
                    });
                }
            }
            let n = rays.len().max(1) as f64;
            (ours as f64 / n, theirs as f64 / n)
        };
        let kinds: [(&str, &[Ray], bool); 3] =
            [("primary", &primary, false), ("shadow", &shadow, true), ("incoherent", &incoherent, false)];
        for (kind, rays, is_shadow) in kinds {
            let ours = if is_shadow {
                best(&|| rays.iter().filter(|r| world.transmittance(r) == Vec3::ZERO).count())
            } else {
                best(&|| rays.iter().filter(|r| world.intersect(r).is_some()).count())
            };
            let theirs = if is_shadow {
                best(&|| rays.iter().filter(|r| occluded_obvhs(r)).count())
            } else {
                best(&|| rays.iter().filter(|r| closest_obvhs(r)).count())
            };
            let (nodes, prims) = counts(rays);
            let (ours_run, theirs_run) = tests_as_run(rays, is_shadow);
            let n = rays.len() as f64;
            let (ours, theirs) = (n / ours / 1e6, n / theirs / 1e6);
            let limit = LIMIT_CLOCK_HZ * LIMIT_IPC
                / (LIMIT_RAY_INSTRUCTIONS
                    + nodes * LIMIT_NODE_INSTRUCTIONS
                    + prims * LIMIT_TRIANGLE_INSTRUCTIONS)
                / 1e6;
            println!(
                "| {} | {kind} | {ours:.2} | {theirs:.2} | {:.2} | {nodes:.2} | {prims:.2} | {ours_run:.2} / {theirs_run:.2} | {limit:.1} | {:.2} |",
                case.name,
                ours / theirs,
                ours / limit
            );
        }
    }
    println!();
    println!(
        "Estimated limit: {:.1} GHz x {} instructions per cycle / ({} per ray + {} per 8-wide node \
         visit + {} per triangle test) instructions, an Embree-like AVX2 kernel; the BVHs fit in \
         cache here, so memory bandwidth is not the bound.",
        LIMIT_CLOCK_HZ / 1e9,
        LIMIT_IPC,
        LIMIT_RAY_INSTRUCTIONS,
        LIMIT_NODE_INSTRUCTIONS,
        LIMIT_TRIANGLE_INSTRUCTIONS
    );
}

/// The machine's clock (`/proc/cpuinfo`: AMD EPYC at 2.0 GHz).
const LIMIT_CLOCK_HZ: f64 = 2.0e9;
/// Sustained instructions per cycle of a well-scheduled SIMD kernel on this core.
const LIMIT_IPC: f64 = 3.0;
/// Per-ray setup (reciprocal direction, octant, shear): about 20 instructions.
const LIMIT_RAY_INSTRUCTIONS: f64 = 20.0;
/// One 8-wide node against one ray with AVX2: 6 plane loads and conversions, 6 FMAs, 4
/// min/max, a compare, a mask and the stack push: about 30 instructions.
const LIMIT_NODE_INSTRUCTIONS: f64 = 30.0;
/// One watertight triangle test amortised over a 4- or 8-wide SIMD leaf: about 15 instructions.
const LIMIT_TRIANGLE_INSTRUCTIONS: f64 = 15.0;

/// User + system CPU seconds of this process so far (`/proc/self/stat`, clock ticks of 10 ms).
fn cpu_seconds() -> f64 {
    let stat = std::fs::read_to_string("/proc/self/stat").unwrap_or_default();
    // Fields after the command name (which is in parentheses and may hold spaces).
    let rest = stat.rsplit_once(')').map_or("", |(_, r)| r);
    let fields: Vec<&str> = rest.split_whitespace().collect();
    let ticks = |i: usize| fields.get(i).and_then(|v| v.parse::<f64>().ok()).unwrap_or(0.0);
    // utime and stime are fields 14 and 15 of the whole line, 12 and 13 after the name.
    (ticks(11) + ticks(12)) / 100.0
}

fn load_average() -> String {
    std::fs::read_to_string("/proc/loadavg")
        .map(|l| l.split_whitespace().take(3).collect::<Vec<_>>().join(" "))
        .unwrap_or_else(|_| "n/a".into())
}

/// Path-traced samples per CPU-second, one thread, each scene at `spp` (the path integrator
/// forced, unbounded depth, Russian roulette from depth 5, as the Mitsuba comparison).
fn samples_per_cpu_second(shared: &std::path::Path, spp: u32, wavefront: Option<bool>) {
    let root = PathBuf::from(concat!(env!("CARGO_MANIFEST_DIR"), "/../.."));
    let scenes = [
        ("cornell", shared.join("reference/cornell/cornell.rib")),
        ("room", root.join("examples/room/room.rib")),
        ("caustics", root.join("examples/caustics/caustics.rib")),
        (
            "killeroo",
            shared.join(
                "rib-corpus/dpasca__RibTools/DistribSrc__base__TestScenes__KillerooNURBS__killeroo.rib",
            ),
        ),
    ];
    println!();
    println!("Path tracing, one thread, {spp} samples per pixel:");
    println!();
    println!(
        "| scene | pixels | samples | rays / sample | CPU s | wall s | samples per CPU-s | load (1, 5, 15 min) |"
    );
    println!("|---|---|---|---|---|---|---|---|");
    for (name, path) in scenes {
        let loaded = rib_parser::load_scene(&path, &Default::default()).expect("scene loads");
        let load = load_average();
        let options = RenderOptions {
            spp: Some(spp),
            threads: Some(1),
            integrator: Some(IntegratorKind::Path { max_depth: UNBOUNDED_DEPTH, rr_depth: DEFAULT_RR_DEPTH }),
            wavefront,
            ..Default::default()
        };
        let (cpu0, wall0) = (cpu_seconds(), Instant::now());
        let out = render(&loaded.scene, &options).unwrap();
        let (cpu, wall) = (cpu_seconds() - cpu0, wall0.elapsed().as_secs_f64());
        let s = &out.stats;
        let samples = u64::from(s.width) * u64::from(s.height) * u64::from(spp);
        let name = if s.wavefront { format!("{name} (wavefront)") } else { name.to_string() };
        println!(
            "| {name} | {}x{} | {samples} | {:.2} | {cpu:.2} | {wall:.2} | {:.3} M | {load} |",
            s.width,
            s.height,
            s.rays.total() as f64 / samples as f64,
            samples as f64 / cpu.max(1e-9) / 1e6
        );
    }
}
