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

use criterion::measurement::WallTime;
use criterion::{BenchmarkGroup, Criterion, SamplingMode, criterion_group, criterion_main};
use depth_remap::{Camera, CameraSettings, Projection};
use glam::{DMat4, DVec3, Vec3};
use std::time::{Duration, Instant};
use viewer::{
    Backends, CompositeMode, Compositor, CompositorSettings, DepthTable, Gpu, LiveLight, LiveObjects,
    Material, Rgba8Image, SceneLayers, Sphere, ToneMap, ViewerScene,
};

/// The Cornell room without its boxes (five walls, the eye 3.9 in front of the back wall) at
/// `size^2`, with analytic radial depths.
fn room(size: u32) -> ViewerScene {
    room_and_normals(size).0
}

/// The glossy floor's lobe weight (`Ks`) and Blinn exponent (`1 / roughness`) in the
/// `-glossy-floor` benches.
const FLOOR_KS: f32 = 0.3;
const FLOOR_EXPONENT: f32 = 20.0;

/// The area light's emitting quad, a centimetre below the ceiling, as two triangles.
const LIGHT_QUAD: [[DVec3; 3]; 2] = {
    let c = [
        DVec3::new(-0.23, 0.99, -0.18),
        DVec3::new(0.23, 0.99, -0.18),
        DVec3::new(0.23, 0.99, 0.2),
        DVec3::new(-0.23, 0.99, 0.2),
    ];
    [[c[0], c[1], c[2]], [c[0], c[2], c[3]]]
};

/// [`room`] with what the illusion's renders come with: light layers (the wall's normal, an
/// albedo of 0.7, direct light 0.3 and indirect light 0.1 everywhere), the area light's 256
/// samples and one irradiance probe of uniform radiance 0.2. With `glossy_floor` the floor is
/// plastic as well: its pixels get a Blinn lobe ([`FLOOR_KS`], [`FLOOR_EXPONENT`]) in the
/// layers, which turns on the glossy lobes' passes (the room of `examples/room` has one).
fn lit_room(size: u32, glossy_floor: bool) -> ViewerScene {
    let (mut scene, normals) = room_and_normals(size);
    let fingerprint = sidecar::depth_fingerprint(scene.depth().values());
    let mut layers =
        sidecar::LightLayers::new(size, size, fingerprint, vec![sidecar::LightSource::new(0, "arealight")]);
    for (k, normal) in normals.iter().enumerate() {
        if let Some(n) = normal {
            layers.normal[k] = n.as_vec3().to_array();
            layers.albedo[k] = [0.7; 3];
            layers.light[0][k] = [0.3; 3];
            layers.indirect[k] = [0.1; 3];
        }
    }
    if glossy_floor {
        let floor = |n: &Option<DVec3>| n.is_some_and(|n| n.y > 0.5);
        layers.glossy = normals.iter().map(|n| if floor(n) { [FLOOR_KS; 3] } else { [0.0; 3] }).collect();
        layers.glossy_exponent =
            normals.iter().map(|n| if floor(n) { [FLOOR_EXPONENT; 3] } else { [0.0; 3] }).collect();
    }
    let area_samples = vec![viewer::light_layers::area_samples(&LIGHT_QUAD, 256)];
    scene
        .set_light_layers(SceneLayers { layers, layer_of_light: vec![Some(0)], area_samples })
        .expect("layers");
    let texels = sidecar::VISIBILITY_TEXELS * sidecar::VISIBILITY_TEXELS;
    let mut sh = [[0.0f32; 3]; 9];
    sh[0] = [0.2 * 0.282_094_8 * 4.0 * std::f32::consts::PI; 3];
    scene.set_probes(sidecar::ProbeGrid {
        depth_fingerprint: fingerprint,
        origin: [0.0; 3],
        spacing: [1.0; 3],
        counts: [1, 1, 1],
        radiance_sh: vec![sh],
        visibility: vec![[10.0, 100.0]; texels],
        emitters_seen: false,
    });
    scene
}

/// [`room`] and each pixel's wall normal (world space, into the room; `None` where no wall).
/// The room's five walls (x = +-1, y = +-1, z = -1, open toward the eye) as the scene's
/// triangles (the scene's shadows on the sphere, which `hybrid-view` always binds) and a
/// reflection probe at the centre seeing radiance 0.2 a unit away (the sphere's default
/// material has a glossy lobe); with `materials` the walls are matte of albedo 0.7 as the layers
/// have them, which turns on the near field and the glossy lobes traced through the scene; with
/// `glossy_floor` too the floor is plastic of the same albedo, with the layers' lobe.
fn bind_room_scene(scene: &mut ViewerScene, materials: bool, glossy_floor: bool) {
    let texels = sidecar::REFLECTION_TEXELS;
    let radiance = sidecar::reflection_levels(&vec![[0.2f32; 3]; texels * texels]);
    scene
        .set_reflections(sidecar::ReflectionProbes {
            depth_fingerprint: sidecar::depth_fingerprint(scene.depth().values()),
            origin: [0.0; 3],
            spacing: [1.0; 3],
            counts: [1, 1, 1],
            radiance,
            distance: vec![1.0; texels * texels],
            specular: Vec::new(),
        })
        .expect("reflection probe");
    let v = |x: f64, y: f64, z: f64| DVec3::new(x, y, z);
    let quads = [
        [v(-1.0, -1.0, -1.0), v(1.0, -1.0, -1.0), v(1.0, -1.0, 1.0), v(-1.0, -1.0, 1.0)],
        [v(-1.0, 1.0, -1.0), v(1.0, 1.0, -1.0), v(1.0, 1.0, 1.0), v(-1.0, 1.0, 1.0)],
        [v(-1.0, -1.0, -1.0), v(1.0, -1.0, -1.0), v(1.0, 1.0, -1.0), v(-1.0, 1.0, -1.0)],
        [v(-1.0, -1.0, -1.0), v(-1.0, 1.0, -1.0), v(-1.0, 1.0, 1.0), v(-1.0, -1.0, 1.0)],
        [v(1.0, -1.0, -1.0), v(1.0, 1.0, -1.0), v(1.0, 1.0, 1.0), v(1.0, -1.0, 1.0)],
    ];
    let triangles: Vec<[DVec3; 3]> =
        quads.iter().flat_map(|q| [[q[0], q[1], q[2]], [q[0], q[2], q[3]]]).collect();
    // The floor is the first quad: its two triangles get the second material.
    let mut of_triangle = vec![0; triangles.len()];
    of_triangle[..2].fill(1);
    scene.set_occluders(viewer::occluders::SceneOccluders { triangles });
    if materials {
        let wall = viewer::occluders::SceneMaterial { diffuse: Vec3::splat(0.7), ..Default::default() };
        let floor = if glossy_floor {
            viewer::occluders::SceneMaterial {
                glossy: Vec3::splat(FLOOR_KS),
                exponent: FLOOR_EXPONENT,
                ..wall
            }
        } else {
            wall
        };
        scene.set_occluder_materials(viewer::occluders::SceneMaterials {
            materials: vec![wall, floor],
            of_triangle,
        });
    }
}

fn room_and_normals(size: u32) -> (ViewerScene, Vec<Option<DVec3>>) {
    let camera_from_world =
        DMat4::from_scale(DVec3::new(1.0, 1.0, -1.0)) * DMat4::from_translation(DVec3::new(0.0, 0.0, -3.9));
    let camera = Camera::new(CameraSettings {
        x_resolution: size,
        y_resolution: size,
        projection: Projection::Perspective { fov_degrees: 39.3077 },
        camera_from_world,
        ..CameraSettings::default()
    })
    .expect("camera");
    let world_from_camera = camera.world_from_camera();
    let mut values = Vec::with_capacity((size * size) as usize);
    let mut normals = Vec::with_capacity((size * size) as usize);
    let mut pixels = Vec::with_capacity((size * size * 4) as usize);
    for j in 0..size {
        for i in 0..size {
            let ray = camera.pixel_centre_ray(i, j);
            let o = world_from_camera.transform_point3(ray.origin);
            let d = world_from_camera.transform_vector3(ray.direction);
            // Walls: x = +-1, y = +-1, z = -1 (the box is open towards the eye).
            let (mut best, mut normal) = (f64::INFINITY, None);
            for (axis, plane) in [(0, 1.0), (0, -1.0), (1, 1.0), (1, -1.0), (2, -1.0)] {
                let t = (plane - o[axis]) / d[axis];
                if t > 0.0 {
                    let p = o + d * t;
                    if p.x.abs() <= 1.0 + 1e-9
                        && p.y.abs() <= 1.0 + 1e-9
                        && p.z <= 1.0
                        && p.z >= -1.0 - 1e-9
                        && t < best
                    {
                        best = t;
                        let mut n = DVec3::ZERO;
                        n[axis] = -plane;
                        normal = Some(n);
                    }
                }
            }
            values.push(best as f32);
            normals.push(normal);
            pixels.extend_from_slice(&[(i % 256) as u8, (j % 256) as u8, ((i ^ j) % 256) as u8, 255]);
        }
    }
    let depth = DepthTable::new(size, size, values).expect("depths");
    let image = Rgba8Image { width: size, height: size, pixels };
    let light = LiveLight::Area {
        centroid: DVec3::new(0.0, 0.99, 0.0),
        normal: Some(DVec3::NEG_Y),
        two_sided: false,
        radiance: Vec3::new(18.4, 14.0, 6.75),
        area: 0.17,
        radius: 0.23,
    };
    (ViewerScene::new(camera, image, depth, vec![light], ToneMap::default()).expect("scene"), normals)
}

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

/// The sphere of the lit benches in frame `frame`: back and forth over 40 cm along x above the
/// floor, 1 cm a frame.
fn sphere_at(frame: u32) -> LiveObjects {
    let step = f64::from(frame % 80);
    let x = -0.2 + 0.01 * if step < 40.0 { step } else { 80.0 - step };
    LiveObjects {
        sphere: Some(Sphere {
            centre: DVec3::new(x, -0.6, -0.3),
            radius: 0.3,
            material: Material::default(),
        }),
        meshes: Vec::new(),
    }
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

/// Frames the sphere moves before it stops in `fullscreen-lit-stop-worst-near-field`.
const STOP_MOVES: u32 = 3;
/// Frames timed after it stops: the backdrop's settling frames at 512^2 (the layered shadows',
/// `SETTLE_SHADOW_PIXELS` of their scissor a frame, 4 at most; the maps'; the rows',
/// `SETTLE_PIXELS` a frame), the sphere's (7 or 8 for the bench's sphere,
/// `SETTLE_SPHERE_PIXELS` of its bounds a frame) and the first kept ones.
const STOP_FRAMES: usize = {
    let frame = 512 * 512;
    let shadows = frame / viewer::compositor::SETTLE_SHADOW_PIXELS as usize;
    shadows + 1 + frame / viewer::compositor::SETTLE_PIXELS as usize + 10
};
/// [`STOP_FRAMES`] for `scene` at 512^2, whose frame shows the cursor sphere in reflections (the
/// glossy floor), at most: the bounce light's bands, a mirror's frame, the sphere's glossy lobes
/// in bands of the rows with a lobe (`SETTLE_REFLECTION_PIXELS / 512` rows a band at least, the
/// reflections' rectangle being no wider than the frame), then the loss's bands (settle.rs).
fn stop_frames_with_reflections(scene: &ViewerScene) -> usize {
    let layers = &scene.light_layers().expect("light layers").layers;
    let glossy_rows = layers.glossy.chunks(512).filter(|row| row.iter().any(|ks| *ks != [0.0; 3])).count();
    let rows_a_band = (viewer::compositor::SETTLE_REFLECTION_PIXELS as usize / 512).max(1);
    STOP_FRAMES
        + 512 * 512 / viewer::compositor::SETTLE_PIXELS as usize
        + 1
        + glossy_rows.div_ceil(rows_a_band)
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
