//! Loading the inputs and running the viewer, headless or in a window.

use crate::args::Settings;
use crate::convert::{self, Skipped};
use depth_remap::Camera;
use glam::{DVec3, Vec3};
use std::time::{Duration, Instant};
use viewer::window::{self, WindowSettings};
use viewer::{
    Backdrop, Compositor, CompositorSettings, FrameInfo, Gpu, LiveObjects, LiveUpdate, Material,
    ShadowSettings, Sphere, ViewerError, ViewerScene,
};

/// Simulated frame rate of headless runs: frame `k` happens at `k / HEADLESS_FRAME_RATE` s.
pub const HEADLESS_FRAME_RATE: f64 = 60.0;

/// A failure after the command line was accepted: the scene, the image, the depth table or the
/// rendering (exit code 1, CONTRACTS.md §5).
#[derive(Debug)]
pub struct Failure(pub String);

impl From<ViewerError> for Failure {
    fn from(e: ViewerError) -> Self {
        Failure(e.to_string())
    }
}

/// Everything loaded and checked, ready to show.
pub struct Prepared {
    pub scene: ViewerScene,
    pub compositor: CompositorSettings,
    pub live: LiveObjects,
    /// World-space bounds of the scene's shapes (the default device centre of the haptics).
    pub bounds: Option<(DVec3, DVec3)>,
    pub skipped: Skipped,
    /// The RIB scene itself (the haptics tessellate its surfaces).
    pub rib: rib_parser::scene::Scene,
    /// Whether the scene's triangles carry their materials to the near field (on unless
    /// `--no-near-field`).
    pub near_field: bool,
}

impl Prepared {
    /// Tessellates the RIB scene once at `tolerance` and binds its triangles as the scene's own
    /// shadows on live objects (shadow rays); returns the meshes for the haptics to share.
    pub fn tessellate_scene(
        &mut self,
        tolerance: &tessellate::Tolerance,
        stats: bool,
    ) -> tessellate::SceneMeshes {
        let meshes = crate::scene_occluders::tessellate_once(&self.rib, tolerance, stats);
        self.scene.set_occluders(crate::scene_occluders::scene_occluders(&meshes));
        // Without materials the near field is off and costs nothing (near_field.wgsl).
        if self.near_field {
            self.scene.set_occluder_materials(crate::scene_occluders::scene_materials(&self.rib, &meshes));
        }
        meshes
    }
}

/// Reads the RIB, the image and the depth table and checks they belong together.
pub fn prepare(settings: &Settings) -> Result<Prepared, Failure> {
    let loaded = rib_parser::load_scene(&settings.scene, &rib_parser::LoadOptions::default())
        .map_err(|e| Failure(e.render().trim_end().to_string()))?;
    let warnings = loaded.render_warnings();
    if !warnings.trim().is_empty() {
        eprint!("{warnings}");
    }
    let rib = loaded.scene;
    let camera = Camera::new(rib.camera.clone())
        .map_err(|e| Failure(format!("{}: the camera: {e}", settings.scene.display())))?;
    let tone = convert::tone_map(&rib);
    // Float images (EXR) from lrt-depth carry the gain already; live objects get it too, and
    // both are displayed with one encoding (viewer::display).
    let image = Backdrop::read(&settings.image, tone.gamma)?;
    let depth = depth_remap::DepthTable::read(&settings.depth).map_err(|e| Failure(e.to_string()))?;
    let mut skipped = Skipped::default();
    let sourced = convert::live_lights_with_sources(&rib, &mut skipped);
    let lights = sourced.iter().map(|l| l.light.clone()).collect();
    convert::camera_effects(&rib, &mut skipped);
    let bounds = convert::scene_bounds(&rib);
    // Sizes first, naming the files: the image against its depth table and the RIB's Format.
    let (iw, ih) = (image.width, image.height);
    if (depth.width(), depth.height()) != (iw, ih) {
        return Err(Failure(format!(
            "size mismatch: the image {} is {iw}x{ih} but the depth table {} is {}x{}",
            settings.image.display(),
            settings.depth.display(),
            depth.width(),
            depth.height()
        )));
    }
    if camera.resolution() != (iw, ih) {
        let (cw, ch) = camera.resolution();
        return Err(Failure(format!(
            "size mismatch: the image {} is {iw}x{ih} but the Format of {} is {cw}x{ch}",
            settings.image.display(),
            settings.scene.display()
        )));
    }
    let pixel_filter = convert::pixel_filter(&rib, &mut skipped);
    let mut scene = ViewerScene::with_backdrop(camera, image, depth, lights, tone)?;
    scene.set_pixel_filter(pixel_filter);
    if settings.shadows.is_some() {
        attach_light_layers(settings, &mut scene, &sourced, rib.lights.len())?;
    }
    attach_probes(settings, &mut scene)?;
    attach_reflections(settings, &mut scene)?;
    attach_caustics(settings, &mut scene)?;
    let mut live = LiveObjects { sphere: initial_sphere(settings, &scene), meshes: Vec::new() };
    if let Some(path) = &settings.live {
        let objects = crate::live_rib::read_live_rib(path).map_err(Failure)?;
        objects.add_to(&mut live, &std::sync::Arc::new(viewer::Mesh::unit_sphere(48, 96)));
    }
    let compositor = CompositorSettings {
        mode: settings.mode,
        depth: settings.depth_settings,
        depth_range: None,
        shadows: settings.shadows.map(|strength| ShadowSettings { strength, light: None }),
        antialias: settings.antialias,
        own_shadow_maps: true,
        near_field_maps: true,
        bounce_light: settings.bounce_light,
        occlusion_from_behind: settings.occlusion_from_behind,
        shadow_bounce: settings.shadow_bounce,
        amortise_while_moving: settings.amortise_while_moving,
        reduce_while_moving: settings.reduce_while_moving,
        settle_at_rest: settings.settle_at_rest,
        cursor_map_while_moving: true,
        keep_frame_at_rest: settings.keep_frame_at_rest,
    };
    Ok(Prepared { scene, compositor, live, bounds, skipped, rib, near_field: settings.near_field })
}

/// Finds the light layers `lrt-depth` wrote for this render (docs/sidecar.md: next to the depth
/// table, else next to the image) and binds them to the live lights, so live objects' shadows
/// remove exactly the occluded share of each light. Without them, says what is approximated.
fn attach_light_layers(
    settings: &Settings,
    scene: &mut ViewerScene,
    sourced: &[convert::SourcedLight],
    scene_lights: usize,
) -> Result<(), Failure> {
    let candidates = sidecar::SidecarPaths::candidates(&settings.image, &settings.depth);
    let Some(path) = candidates.iter().map(|c| &c.layers).find(|p| p.exists()) else {
        let looked: Vec<String> = candidates.iter().map(|c| c.layers.display().to_string()).collect();
        eprintln!(
            "note: no light layers ({}): live objects' shadows darken a fixed share of one light's pixels (--shadow-strength) and leave indirect light as it is, and they reflect no light onto the scene",
            looked.join(", ")
        );
        return Ok(());
    };
    let (width, height) = scene.size();
    let expect = sidecar::LayerExpectation {
        width,
        height,
        depth_fingerprint: Some(sidecar::depth_fingerprint(scene.depth().values())),
    };
    let layers = sidecar::read_layers(path, &expect, sidecar::ReadLimits::default())
        .map_err(|e| Failure(e.to_string()))?;
    let n = layers.lights.len();
    if n != scene_lights {
        return Err(Failure(format!(
            "{}: error: the light layers list {n} lights but {} has {scene_lights}",
            path.display(),
            settings.scene.display()
        )));
    }
    let layer_of_light = sourced
        .iter()
        .map(|l| {
            (!matches!(l.light, viewer::LiveLight::Ambient { .. }))
                .then(|| sidecar::light_layer_of(l.scene_index, n))
        })
        .collect();
    let area_samples = sourced.iter().map(|l| l.area_samples.clone()).collect();
    scene
        .set_light_layers(viewer::SceneLayers { layers, layer_of_light, area_samples })
        .map_err(|e| Failure(format!("{}: error: {e}", path.display())))?;
    Ok(())
}

/// Finds the irradiance probes `lrt-depth` wrote for this render (docs/sidecar.md) and lights
/// live objects' diffuse reflection with them. Without them, says what is approximated.
fn attach_probes(settings: &Settings, scene: &mut ViewerScene) -> Result<(), Failure> {
    let candidates = sidecar::SidecarPaths::candidates(&settings.image, &settings.depth);
    let Some(path) = candidates.iter().map(|c| &c.probes).find(|p| p.exists()) else {
        let looked: Vec<String> = candidates.iter().map(|c| c.probes.display().to_string()).collect();
        eprintln!(
            "note: no irradiance probes ({}): live objects are lit by the RIB's lights alone, without the scene's indirect light or its shadows",
            looked.join(", ")
        );
        return Ok(());
    };
    let fingerprint = sidecar::depth_fingerprint(scene.depth().values());
    let probes = sidecar::read_probes(path, Some(fingerprint)).map_err(|e| Failure(e.to_string()))?;
    scene.set_probes(probes);
    Ok(())
}

/// Finds the reflection probes `lrt-depth` wrote for this render (docs/sidecar.md): glossy live
/// surfaces reflect the scene's prefiltered radiance. Without them, says what is approximated.
fn attach_reflections(settings: &Settings, scene: &mut ViewerScene) -> Result<(), Failure> {
    let candidates = sidecar::SidecarPaths::candidates(&settings.image, &settings.depth);
    let Some(path) = candidates.iter().map(|c| &c.reflections).find(|p| p.exists()) else {
        eprintln!("{}", sidecar::reflections_absent_note(&candidates[0].reflections));
        return Ok(());
    };
    let fingerprint = sidecar::depth_fingerprint(scene.depth().values());
    let Some(probes) =
        sidecar::read_reflections(path, Some(fingerprint)).map_err(|e| Failure(e.to_string()))?
    else {
        eprintln!("{}", sidecar::reflections_absent_note(path));
        return Ok(());
    };
    scene.set_reflections(probes).map_err(|e| Failure(format!("{}: error: {e}", path.display())))
}

/// Finds the caustic photons `lrt-depth` wrote for this render (docs/sidecar.md): live spheres
/// then take the caustic light whose photons they block. A render without a caustic map has
/// none, and nothing is said.
fn attach_caustics(settings: &Settings, scene: &mut ViewerScene) -> Result<(), Failure> {
    let candidates = sidecar::SidecarPaths::candidates(&settings.image, &settings.depth);
    let Some(path) = candidates.iter().map(|c| &c.caustics).find(|p| p.exists()) else {
        return Ok(());
    };
    let fingerprint = sidecar::depth_fingerprint(scene.depth().values());
    let caustics =
        sidecar::read_caustics(path, scene.size(), Some(fingerprint)).map_err(|e| Failure(e.to_string()))?;
    scene.set_caustics(caustics).map_err(|e| Failure(format!("{}: error: {e}", path.display())))
}

/// The sphere at start: where `--sphere` puts it; in a window without `--sphere`, in front of
/// the surface at the image centre so the keyboard and mouse can move it; headless without
/// `--sphere`, none (the frame is then the input image).
fn initial_sphere(settings: &Settings, scene: &ViewerScene) -> Option<Sphere> {
    let centre = match settings.sphere {
        Some(c) => c,
        None if settings.headless => return None,
        None => default_position(scene),
    };
    let camera = scene.camera();
    let eye_distance = camera.camera_from_world().transform_point3(centre).length();
    let radius = settings.radius.unwrap_or(if eye_distance > 0.0 { 0.03 * eye_distance } else { 0.1 });
    Some(Sphere { centre, radius, material: cursor_material(settings) })
}

/// The sphere's material from `--unlit` and `--sphere-colour`.
pub fn cursor_material(settings: &Settings) -> Material {
    let mut material =
        if settings.unlit { Material::unlit(Vec3::new(0.1, 0.25, 0.9)) } else { Material::default() };
    if let Some(c) = settings.sphere_colour {
        material.colour = c.as_vec3();
    }
    material
}

/// A quarter of the way from the surface at the image centre to the eye.
fn default_position(scene: &ViewerScene) -> DVec3 {
    let camera = scene.camera();
    let (w, h) = scene.size();
    let eye = camera.world_from_camera().transform_point3(DVec3::ZERO);
    match scene.surface_point(w / 2, h / 2).or_else(|| scene.visible_centroid()) {
        Some(p) => p + (eye - p) * 0.25,
        None => {
            let ray = camera.pixel_centre_ray(w / 2, h / 2);
            camera.world_from_camera().transform_point3(ray.origin + ray.direction)
        }
    }
}

/// Runs headless: `frames` frames (1 by default) with `updater` moving the live objects in
/// simulated time, then writes the screenshot and mask of the last frame.
pub fn headless(
    settings: &Settings,
    prepared: Prepared,
    mut updater: Option<&mut dyn LiveUpdate>,
) -> Result<(), Failure> {
    let gpu = Gpu::new(settings.backends)?;
    let mut compositor = Compositor::new(&gpu, &prepared.scene, prepared.compositor)?;
    let mut live = prepared.live;
    let frames = settings.frames.unwrap_or(1);
    // The first of several frames draws every pass in full: timed alone when it is the only one.
    let first_timed = u64::from(frames > 1);
    let mut times = Vec::with_capacity(frames.min(1 << 20) as usize);
    // Each frame's CPU time (every thread of the process: lavapipe's rasterisers do the GPU's
    // work), listed with `--stats` to see single slow frames such as the first at rest.
    let mut cpu_times = Vec::with_capacity(times.capacity());
    for index in 0..frames {
        let info = FrameInfo { index, time_s: index as f64 / HEADLESS_FRAME_RATE };
        if let Some(u) = updater.as_mut() {
            u.update(&mut live, &info);
        }
        compositor.set_pass_timing(settings.pass_times && index >= first_timed);
        let (start, cpu_start) = (Instant::now(), viewer::compositor::process_cpu_time());
        compositor.render(&live)?;
        compositor.wait_idle()?;
        if times.len() < (1 << 20) {
            times.push(start.elapsed());
            let cpu = cpu_start.zip(viewer::compositor::process_cpu_time());
            cpu_times.push(cpu.map(|(a, b)| b.saturating_sub(a)));
        }
    }
    if settings.screenshot.is_some() || settings.mask.is_some() {
        let frame = compositor.read_back()?;
        if let Some(path) = &settings.screenshot {
            if viewer::compositor::is_exr_path(path) {
                compositor.read_back_linear()?.write_exr(path)?;
            } else {
                frame.colour.write_png(path)?;
            }
        }
        if let Some(path) = &settings.mask {
            frame.write_mask_png(path)?;
        }
    }
    if settings.stats {
        print_stats(&compositor, &prepared.scene, &prepared.skipped, &live, &times);
        print_each_frame(&times, &cpu_times);
        if let Some((lo, hi)) = prepared.bounds {
            eprintln!("scene bounds: {lo} .. {hi}");
        }
    }
    if settings.pass_times {
        print_pass_times(&compositor);
    }
    Ok(())
}

/// Each frame's wall and CPU time (`--stats`, the first 1000 frames).
fn print_each_frame(times: &[Duration], cpu_times: &[Option<Duration>]) {
    let ms = |d: Duration| format!("{:.0}", d.as_secs_f64() * 1e3);
    let each: Vec<String> = times
        .iter()
        .zip(cpu_times)
        .take(1000)
        .map(|(&wall, cpu)| format!("{}/{}", ms(wall), cpu.map_or("-".to_string(), ms)))
        .collect();
    eprintln!("each frame, wall/CPU ms: {}", each.join(" "));
}

/// Each pass's time per frame timed (`--pass-times`), the frames it ran in, and the sum.
fn print_pass_times(compositor: &Compositor) {
    let (passes, frames) = compositor.pass_times();
    let per_frame = |d: Duration| d.as_secs_f64() * 1e3 / f64::from(frames.max(1));
    eprintln!(
        "pass times over {frames} frame(s) (the first of several is not timed), per frame (CPU of the process's threads, wall):"
    );
    let (mut cpu_sum, mut wall_sum) = (Some(Duration::ZERO), Duration::ZERO);
    for p in &passes {
        let cpu = p.cpu.map_or("-".to_string(), |c| format!("{:.1} ms", per_frame(c)));
        eprintln!("  {:<40} {:>10} {:>10.1} ms  (in {} frame(s))", p.pass, cpu, per_frame(p.wall), p.frames);
        cpu_sum = cpu_sum.zip(p.cpu).map(|(a, b)| a + b);
        wall_sum += p.wall;
    }
    let cpu = cpu_sum.map_or("-".to_string(), |c| format!("{:.1} ms", per_frame(c)));
    eprintln!("  {:<40} {:>10} {:>10.1} ms", "all passes", cpu, per_frame(wall_sum));
}

/// Runs in a window until it is closed (or for `--frames` frames).
pub fn windowed(
    settings: &Settings,
    prepared: Prepared,
    updater: Option<Box<dyn LiveUpdate>>,
) -> Result<(), Failure> {
    let scene = prepared.scene;
    let window_settings = WindowSettings {
        title: format!("hybrid-view: {}", settings.image.display()),
        frames: settings.frames,
        screenshot: settings.screenshot.clone(),
        mask: settings.mask.clone(),
        backends: settings.backends,
    };
    let outcome = window::run(scene, prepared.compositor, window_settings, prepared.live, updater)?;
    if settings.stats {
        eprintln!("adapter: {}", outcome.adapter);
        eprintln!("frames: {}", outcome.frames);
        if let Some(s) = outcome.live.sphere {
            eprintln!("sphere at exit: {},{},{} radius {}", s.centre.x, s.centre.y, s.centre.z, s.radius);
        }
    }
    Ok(())
}

fn print_stats(
    compositor: &Compositor,
    scene: &ViewerScene,
    skipped: &Skipped,
    live: &LiveObjects,
    times: &[Duration],
) {
    let p = compositor.projection();
    let s = compositor.settings();
    eprintln!("adapter: {}", compositor.gpu().describe());
    eprintln!("image: {}x{}", scene.size().0, scene.size().1);
    eprintln!("mode: {}", s.mode.name());
    let planes = p.planes();
    eprintln!(
        "depth buffer: {:?}, {}; near {} far {}",
        s.depth.format,
        s.depth.convention,
        planes.near,
        if planes.infinite_far { "infinite".to_string() } else { planes.far.to_string() }
    );
    eprintln!("lights: {} used by the live objects", scene.lights().len());
    let f = scene.pixel_filter();
    match compositor.antialias_off() {
        None => {
            eprintln!("live edges: 4 samples per pixel, filtered {:?} {} {}", f.kind, f.x_width, f.y_width)
        }
        Some(why) => eprintln!("live edges: pixel centres only ({why})"),
    }
    if let Some(p) = scene.probes() {
        let [x, y, z] = p.counts;
        eprintln!("irradiance probes: {x}x{y}x{z}, live objects' diffuse light");
    }
    if let Some(p) = scene.reflections() {
        let [x, y, z] = p.counts;
        eprintln!("reflection probes: {x}x{y}x{z}, live objects' glossy reflection");
    }
    let casters =
        usize::from(live.sphere.is_some()) + live.meshes.iter().filter(|m| m.exact_sphere.is_some()).count();
    match (compositor.shadow_light(), s.shadows, &live.sphere) {
        (_, Some(_), _) if scene.light_layers().is_some() && (casters > 0 || !live.meshes.is_empty()) => {
            eprintln!(
                "shadows: exact, from the light layers ({} layers), cast by {casters} sphere(s) and {} other live mesh(es)",
                scene.light_layers().map_or(0, |l| l.layers.light.len()),
                live.meshes.iter().filter(|m| m.exact_sphere.is_none()).count()
            )
        }
        (Some(k), Some(sh), Some(_)) => eprintln!("shadows: from light {k}, strength {}", sh.strength),
        (_, None, _) => eprintln!("shadows: off (--no-shadows)"),
        (_, _, None) => eprintln!("shadows: skipped (no sphere)"),
        (None, _, _) => eprintln!("shadows: skipped (no light that casts shadows)"),
    }
    eprintln!("scene shadows on live objects: {}", compositor.scene_shadows_summary());
    eprintln!("bounce light onto the scene: {}", compositor.bounce_light_summary());
    eprintln!("shadows' second bounce: {}", compositor.shadow_bounce_summary());
    match (s.amortise_while_moving, s.reduce_while_moving) {
        (true, true) => eprintln!(
            "while live objects move: the area lights' layered shadows gathered at one pixel in \
             {s}x{s}, the bounce light at one in {b}x{b}, the shadows' second bounce at one in \
             {l}x{l}, spread along each surface; the cursor sphere shaded once per texel of a \
             {m}x{m} map of its radiance over its half facing the eye, its diffuse light from its \
             radiosity map; {rest} (--exact-while-moving: every frame exact)",
            s = viewer::compositor::MOVING_SHADOW_STRIDE,
            m = viewer::compositor::MOVING_SPHERE_MAP_TEXELS,
            b = viewer::compositor::MOVING_BOUNCE_STRIDE,
            l = viewer::compositor::MOVING_LOSS_STRIDE,
            rest = if s.settle_at_rest {
                format!(
                    "at rest the exact layered shadows drawn over several frames, {} pixels a \
                     frame at most, then the exact bounce light and second bounce, {} pixels a \
                     frame at most (--settle-in-one-frame: exact from the second frame at rest)",
                    viewer::compositor::SETTLE_SHADOW_PIXELS,
                    viewer::compositor::SETTLE_PIXELS
                )
            } else {
                "exact from the second frame at rest".to_string()
            }
        ),
        (true, false) => eprintln!(
            "while live objects move: the shadows' second bounce redrawn in one of {} bands a frame, \
             exact from the second frame at rest (--exact-while-moving: every frame exact)",
            viewer::compositor::SHADOW_BOUNCE_BANDS
        ),
        (false, _) => {}
    }
    if let Some(note) = compositor.live_shadows_note() {
        eprintln!("live meshes' shadows: {note}");
    }
    for w in &skipped.warnings {
        eprintln!("skipped: {w}");
    }
    if !times.is_empty() {
        let mut sorted: Vec<f64> = times.iter().map(|t| t.as_secs_f64() * 1e3).collect();
        sorted.sort_by(f64::total_cmp);
        let mean = sorted.iter().sum::<f64>() / sorted.len() as f64;
        eprintln!(
            "frames: {}, frame time (render + wait) mean {:.3} ms, median {:.3} ms, min {:.3} ms",
            sorted.len(),
            mean,
            sorted[sorted.len() / 2],
            sorted[0]
        );
    }
}
