//! Frame time of the compositor, headless: each compositing mode at 512^2 and 2048^2, with the
//! cursor sphere and its shadow in view (a typical interactive frame). One iteration is
//! `render` + waiting for the GPU, so it is the whole frame's latency.
//!
//! The `lit` benches add what `lrt-depth`'s sidecars give the illusion's frames (light layers
//! with albedo and normals, an irradiance probe, the area light's samples), so the layered
//! shadows, the bounce light and the shadows' second bounce run, and move the sphere by 1 cm
//! every frame as the haptic cursor does: the frame a user gets (issue 10's target: at most
//! twice the plain `fullscreen/512`). The group `frame-cpu` measures the plain and the lit
//! frames in CPU time of the process's threads (lavapipe's rasteriser threads do the GPU's
//! work), steadier than wall time on a shared machine; and the lit frames at rest and moving
//! with the room's walls bound as the scene's triangles and a reflection probe, without and with
//! the walls' materials (`-no-near-field`, `-near-field`: what `hybrid-view` binds with
//! `--no-near-field` and by default), and with a glossy floor as well (`-glossy-floor`: the
//! scene's glossy lobes, which see the sphere, as in `examples/room`). A frame at rest with the
//! last exact frame's inputs is kept (`CompositorSettings::keep_frame_at_rest`), which the plain
//! frames turn off (the baseline draws every frame) and `fullscreen-lit-rest-drawn-near-field`
//! too (the first frame at rest).
//! `fullscreen-lit-stop-worst-near-field` (and `-glossy-floor`) is the dearest frame after the
//! sphere stops, as `hybrid-view` draws them (settling, `compositor/settle.rs`);
//! `FRAME_STOP_TIMES=1` prints each.
//!
//! Run: `cargo bench -p viewer --bench frame` (results in docs/viewer.md and docs/viewer-frame-time.md);
//! `FRAME_PASS_TIMES=lit-moving cargo bench -p viewer --bench frame -- frame-cpu/` also prints
//! each pass's CPU time of the named lit frames.

mod rooms;

use criterion::measurement::WallTime;
use criterion::{BenchmarkGroup, Criterion, SamplingMode, criterion_group, criterion_main};
use glam::DVec3;
use rooms::{
    STOP_FRAMES, STOP_MOVES, bind_room_scene, lit_room, room, sphere_at, stop_frames_with_reflections,
};
use std::time::{Duration, Instant};
use viewer::{
    Backends, CompositeMode, Compositor, CompositorSettings, Gpu, LiveObjects, Material, Sphere, ViewerScene,
};

fn frame_time(c: &mut Criterion) {
    let gpu = Gpu::new(Backends::default()).expect("a GPU adapter (lavapipe: cargo xtask install-test-deps)");
    eprintln!("adapter: {}", gpu.describe());
    let live = LiveObjects {
        sphere: Some(Sphere {
            centre: DVec3::new(0.2, -0.6, -0.3),
            radius: 0.3,
            material: Material::default(),
        }),
        meshes: Vec::new(),
    };
    let mut group = c.benchmark_group("frame");
    group.sample_size(10).warm_up_time(Duration::from_secs(1)).measurement_time(Duration::from_secs(4));
    for size in [512u32, 2048] {
        let scene = room(size);
        for mode in [CompositeMode::Points, CompositeMode::Fullscreen] {
            let settings =
                CompositorSettings { mode, keep_frame_at_rest: false, ..CompositorSettings::default() };
            let mut compositor = Compositor::new(&gpu, &scene, settings).expect("compositor");
            // The first frame uploads the point cloud; keep it out of the measurement.
            compositor.render(&live).expect("render");
            compositor.wait_idle().expect("wait");
            group.bench_function(format!("{}/{size}", mode.name()), |b| {
                b.iter(|| {
                    compositor.render(&live).expect("render");
                    compositor.wait_idle().expect("wait");
                })
            });
        }
    }
    // Where the time goes (full-screen mode): the backdrop alone, then with the sphere but
    // without its shadow pass.
    let no_sphere = LiveObjects::default();
    for size in [512u32, 2048] {
        let scene = room(size);
        for (what, live, shadows) in [("backdrop-only", &no_sphere, true), ("sphere-no-shadow", &live, false)]
        {
            let settings = CompositorSettings {
                shadows: if shadows { CompositorSettings::default().shadows } else { None },
                keep_frame_at_rest: false,
                ..CompositorSettings::default()
            };
            let mut compositor = Compositor::new(&gpu, &scene, settings).expect("compositor");
            group.bench_function(format!("fullscreen-{what}/{size}"), |b| {
                b.iter(|| {
                    compositor.render(live).expect("render");
                    compositor.wait_idle().expect("wait");
                })
            });
        }
    }
    group.finish();
}

/// Benchmarks `frame` as `id` in `group`, in CPU time of the process's threads where the
/// platform says it (else wall time).
fn bench_cpu(group: &mut BenchmarkGroup<'_, WallTime>, id: &str, mut frame: impl FnMut()) {
    group.bench_function(id, |b| {
        b.iter_custom(|iters| {
            let (cpu, wall) = (viewer::compositor::process_cpu_time(), Instant::now());
            for _ in 0..iters {
                frame();
            }
            match (cpu, viewer::compositor::process_cpu_time()) {
                (Some(before), Some(after)) => after.saturating_sub(before),
                _ => wall.elapsed(),
            }
        })
    });
}

/// The lit frames (see [`lit_frame_time`]): name, whether the sphere moves,
/// `amortise_while_moving` and `reduce_while_moving`. `lit-moving` is the frame `hybrid-view`
/// draws by default while the sphere moves; `lit-moving-bands` has the second bounce in bands
/// and the bounce light at full resolution instead.
const LIT_FRAMES: [(&str, bool, bool, bool); 4] = [
    ("lit-rest", false, false, true),
    ("lit-moving-exact", true, false, true),
    ("lit-moving", true, true, true),
    ("lit-moving-bands", true, true, false),
];

/// A compositor of the lit room with `amortise` and `reduce`, its first frame drawn.
fn lit_compositor(gpu: &Gpu, scene: &ViewerScene, amortise: bool, reduce: bool) -> Compositor {
    let settings = CompositorSettings {
        amortise_while_moving: amortise,
        reduce_while_moving: reduce,
        ..CompositorSettings::default()
    };
    let mut compositor = Compositor::new(gpu, scene, settings).expect("compositor");
    compositor.render(&sphere_at(0)).expect("render");
    compositor.wait_idle().expect("wait");
    compositor
}

/// The lit room's frame at 512^2 (see the module's notes), in wall time: the sphere at rest
/// (the maps drawn once), moving 1 cm a frame drawn exactly, amortised (the viewer's default)
/// and in bands.
fn lit_frame_time(c: &mut Criterion) {
    let gpu = Gpu::new(Backends::default()).expect("a GPU adapter (lavapipe: cargo xtask install-test-deps)");
    let mut group = c.benchmark_group("frame");
    // A moving frame drawn exactly takes seconds on lavapipe: the fewest samples criterion takes,
    // one frame each (flat sampling; linear sampling would take 55 frames).
    group
        .sample_size(10)
        .sampling_mode(SamplingMode::Flat)
        .warm_up_time(Duration::from_secs(1))
        .measurement_time(Duration::from_secs(10));
    let scene = lit_room(512, false);
    for (what, moving, amortise, reduce) in LIT_FRAMES {
        let mut compositor = lit_compositor(&gpu, &scene, amortise, reduce);
        let mut frame = 0;
        group.bench_function(format!("fullscreen-{what}/512"), |b| {
            b.iter(|| {
                if moving {
                    frame += 1;
                }
                compositor.render(&sphere_at(frame)).expect("render");
                compositor.wait_idle().expect("wait");
            })
        });
    }
    group.finish();
}

/// The plain frame and the lit frames but the exact moving one, in CPU time (see the module's
/// notes): issue 10's ratio is `frame-cpu/fullscreen-lit-moving/512` over
/// `frame-cpu/fullscreen/512`.
fn cpu_frame_time(c: &mut Criterion) {
    let gpu = Gpu::new(Backends::default()).expect("a GPU adapter (lavapipe: cargo xtask install-test-deps)");
    let mut group = c.benchmark_group("frame-cpu");
    group
        .sample_size(10)
        .sampling_mode(SamplingMode::Flat)
        .warm_up_time(Duration::from_secs(1))
        .measurement_time(Duration::from_secs(10));
    let plain = room(512);
    // The plain frame draws every frame, as it did when issue 10 took its time as the baseline:
    // kept at rest (the default since 2026-11-27) it would cost next to nothing.
    let keep_off = CompositorSettings { keep_frame_at_rest: false, ..CompositorSettings::default() };
    let mut compositor = Compositor::new(&gpu, &plain, keep_off).expect("compositor");
    let live = sphere_at(0);
    bench_cpu(&mut group, "fullscreen/512", || {
        compositor.render(&live).expect("render");
        compositor.wait_idle().expect("wait");
    });
    let scene = lit_room(512, false);
    // The lit frames at rest and moving again with the scene's triangles and a reflection probe
    // bound, without and with the triangles' materials (the near field and the traced glossy
    // lobes off and on, as `hybrid-view --no-near-field` and its default), and with a glossy
    // floor (the scene's own glossy lobes, which see the sphere).
    let (mut triangles, mut near, mut glossy) =
        (lit_room(512, false), lit_room(512, false), lit_room(512, true));
    bind_room_scene(&mut triangles, false, false);
    bind_room_scene(&mut near, true, false);
    bind_room_scene(&mut glossy, true, true);
    let frames = LIT_FRAMES.into_iter().filter(|f| f.0 != "lit-moving-exact");
    let pair = || LIT_FRAMES.into_iter().filter(|f| f.0 == "lit-rest" || f.0 == "lit-moving");
    let runs = frames
        .map(|f| (f, &scene, ""))
        .chain(pair().map(|f| (f, &triangles, "-no-near-field")))
        .chain(pair().map(|f| (f, &near, "-near-field")))
        .chain(pair().map(|f| (f, &glossy, "-glossy-floor")));
    for ((what, moving, amortise, reduce), scene, suffix) in runs {
        let mut compositor = lit_compositor(&gpu, scene, amortise, reduce);
        let mut frame = 0;
        bench_cpu(&mut group, &format!("fullscreen-{what}{suffix}/512"), || {
            if moving {
                frame += 1;
            }
            compositor.render(&sphere_at(frame)).expect("render");
            compositor.wait_idle().expect("wait");
        });
        let name = format!("{what}{suffix}");
        if std::env::var("FRAME_PASS_TIMES").is_ok_and(|names| names.split(',').any(|n| n == name)) {
            print_pass_times(&mut compositor, &name, moving, &mut frame);
        }
    }
    // The frame at rest with the scene's triangles and materials bound drawn every frame, as the
    // first frame after a move draws it (`lit-rest-drawn-near-field`).
    let settings = CompositorSettings { amortise_while_moving: false, keep_frame_at_rest: false, ..keep_off };
    let mut compositor = Compositor::new(&gpu, &near, settings).expect("compositor");
    compositor.render(&sphere_at(0)).expect("render");
    compositor.wait_idle().expect("wait");
    bench_cpu(&mut group, "fullscreen-lit-rest-drawn-near-field/512", || {
        compositor.render(&sphere_at(0)).expect("render");
        compositor.wait_idle().expect("wait");
    });
    let mut frame = 0;
    if std::env::var("FRAME_PASS_TIMES")
        .is_ok_and(|names| names.split(',').any(|n| n == "lit-rest-drawn-near-field"))
    {
        print_pass_times(&mut compositor, "lit-rest-drawn-near-field", false, &mut frame);
    }
    // The frames after the sphere stops, as `hybrid-view` draws them by default (amortised while
    // moving, settling at rest, the frame kept once exact), with the scene's triangles and
    // materials bound, without and with the glossy floor (`bench_stop`).
    let settings = CompositorSettings {
        amortise_while_moving: true,
        settle_at_rest: true,
        keep_frame_at_rest: true,
        ..CompositorSettings::default()
    };
    let print = std::env::var("FRAME_STOP_TIMES").is_ok();
    for (scene, suffix, stop_frames) in
        [(&near, "near-field", STOP_FRAMES), (&glossy, "glossy-floor", stop_frames_with_reflections(&glossy))]
    {
        bench_stop(
            &mut group,
            &gpu,
            scene,
            settings,
            &format!("fullscreen-lit-stop-worst-{suffix}/512"),
            stop_frames,
            print,
        );
    }
    group.finish();
}

/// The dearest frame after the sphere stops in `scene` (`fullscreen-lit-stop-worst-*`): each
/// iteration moves the sphere for `STOP_MOVES` frames, untimed, then times `stop_frames` frames
/// at rest, and counts the dearest; with `print` every frame's time.
fn bench_stop(
    group: &mut BenchmarkGroup<'_, WallTime>,
    gpu: &Gpu,
    scene: &ViewerScene,
    settings: CompositorSettings,
    id: &str,
    stop_frames: usize,
    print: bool,
) {
    let mut compositor = Compositor::new(gpu, scene, settings).expect("compositor");
    compositor.render(&sphere_at(0)).expect("render");
    compositor.wait_idle().expect("wait");
    let mut frame = 0;
    group.bench_function(id, |b| {
        b.iter_custom(|iters| {
            let mut worst_sum = Duration::ZERO;
            for _ in 0..iters {
                for _ in 0..STOP_MOVES {
                    frame += 1;
                    compositor.render(&sphere_at(frame)).expect("render");
                    compositor.wait_idle().expect("wait");
                }
                let mut times = Vec::with_capacity(stop_frames);
                for _ in 0..stop_frames {
                    let (cpu, wall) = (viewer::compositor::process_cpu_time(), Instant::now());
                    compositor.render(&sphere_at(frame)).expect("render");
                    compositor.wait_idle().expect("wait");
                    times.push(match (cpu, viewer::compositor::process_cpu_time()) {
                        (Some(before), Some(after)) => after.saturating_sub(before),
                        _ => wall.elapsed(),
                    });
                }
                if print {
                    let ms: Vec<String> =
                        times.iter().map(|t| format!("{:.1}", t.as_secs_f64() * 1e3)).collect();
                    println!("frames after the stop, CPU ms: {}", ms.join(" "));
                }
                worst_sum += times.into_iter().max().unwrap_or_default();
            }
            worst_sum
        })
    });
}

/// With `FRAME_PASS_TIMES` naming it (`lit-moving`, `lit-rest-near-field`, ...; a comma-separated
/// list), a CPU-timed lit frame's passes over 8 more frames
/// (`Compositor::set_pass_timing`: a pass's CPU time of the process, as `hybrid-view
/// --pass-times` prints it), so that a moving frame's cost can be split where the ratio is
/// measured.
fn print_pass_times(compositor: &mut Compositor, name: &str, moving: bool, frame: &mut u32) {
    compositor.set_pass_timing(true);
    for _ in 0..8 {
        if moving {
            *frame += 1;
        }
        compositor.render(&sphere_at(*frame)).expect("render");
        compositor.wait_idle().expect("wait");
    }
    compositor.set_pass_timing(false);
    let (times, frames) = compositor.pass_times();
    println!("pass times of {name} over {frames} frames, per frame (CPU, wall):");
    for t in times.iter().filter(|t| t.frames > 0) {
        let cpu = t.cpu.map_or(f64::NAN, |c| c.as_secs_f64() * 1e3 / f64::from(frames));
        let wall = t.wall.as_secs_f64() * 1e3 / f64::from(frames);
        println!("  {:<44} {cpu:8.1} ms {wall:8.1} ms", t.pass);
    }
}

criterion_group!(benches, frame_time, lit_frame_time, cpu_frame_time);
criterion_main!(benches);
