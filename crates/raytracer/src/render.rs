//! Rendering a scene: camera rays, tiles in parallel, the filtered image and the depth table.
//!
//! Determinism: every pixel sample draws its numbers from a generator seeded by
//! `(seed, pixel, sample index)`, and each output pixel sums the filtered samples of its
//! neighbourhood in a fixed order. An image is therefore identical for any thread count, any
//! tiling and any `CropWindow`: the pixels of a crop render are bit for bit the same pixels of the
//! full-frame render (tiles that cover a frame merge exactly).

use crate::accel::X86_64V3;
use crate::diagnostics::{Diagnostics, Warning};
use crate::film::{DepthImage, Filter, Image};
use crate::integrators::{Integrator, IntegratorKind, PrepareContext, RayCounters};
use crate::layered_render::{LayerPlan, assemble, render_layered};
use crate::lens::ThinLens;
use crate::sampler::PixelSampler;
use crate::world::{PixelFootprint, Ray, World, WorldError, WorldStats};
use depth_remap::camera::WorldRay;
use depth_remap::{Camera, CameraError};
use glam::{DMat4, DVec2, DVec3, Vec2, Vec3};
use rayon::prelude::*;
use rib_parser::motion::TransformMotion;
use rib_parser::scene::{LightKind, Scene};
use std::sync::Arc;
use std::sync::atomic::{AtomicU64, Ordering};
use std::time::{Duration, Instant};

/// Called with `(pixels done, pixels total)` as tiles finish.
pub type ProgressFn = Arc<dyn Fn(u64, u64) + Send + Sync>;

/// How to render, beyond what the scene says.
#[derive(Clone, Default)]
pub struct RenderOptions {
    /// Worker threads (`None`: all cores).
    pub threads: Option<usize>,
    /// Samples per pixel, overriding `PixelSamples`.
    pub spp: Option<u32>,
    /// Seed of every random number.
    pub seed: u64,
    /// Integrator, overriding `SurfaceIntegrator`.
    pub integrator: Option<IntegratorKind>,
    /// Compute the depth table (the caller decides from the scene's request or `--depth`).
    pub depth: bool,
    /// Render the sidecar's light layers too (docs/sidecar.md): full frames rendered in one
    /// pass only.
    pub layers: bool,
    pub progress: Option<ProgressFn>,
    /// Render passes until this much time has gone by since the render started (at least one
    /// pass; [`crate::passes`]).
    pub time_budget: Option<Duration>,
    /// Stop sampling a pixel once its estimated relative error is below this
    /// ([`crate::passes`]).
    pub target_error: Option<f32>,
    /// Run the path integrator as a wavefront ([`crate::wavefront`]) where the render
    /// qualifies: `Some(true)` asks for it, `Some(false)` keeps the scalar integrator, `None`
    /// takes [`WAVEFRONT_BY_DEFAULT`]. Images are the same either way.
    pub wavefront: Option<bool>,
}

/// Whether qualifying path-traced renders run as a wavefront unless asked otherwise: yes, as
/// it took less CPU time on the Cornell box (docs/performance.md, round 7).
pub const WAVEFRONT_BY_DEFAULT: bool = true;

impl std::fmt::Debug for RenderOptions {
    fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
        f.debug_struct("RenderOptions")
            .field("threads", &self.threads)
            .field("spp", &self.spp)
            .field("seed", &self.seed)
            .field("integrator", &self.integrator)
            .field("depth", &self.depth)
            .field("layers", &self.layers)
            .field("time_budget", &self.time_budget)
            .field("target_error", &self.target_error)
            .field("wavefront", &self.wavefront)
            .finish()
    }
}

/// What a render measured, for `--stats`.
#[derive(Clone, Debug, Default)]
pub struct RenderStats {
    pub integrator: String,
    /// The integrator's own `--stats` lines.
    pub integrator_stats: Vec<String>,
    pub samples_per_pixel: u32,
    pub threads: usize,
    pub width: u32,
    pub height: u32,
    pub world: WorldStats,
    pub rays: RayCounters,
    pub depth_rays: u64,
    pub time_build: Duration,
    /// Integrator preparation (e.g. photon tracing).
    pub time_prepare: Duration,
    pub time_render: Duration,
    pub time_depth: Duration,
    /// Baking the sidecar's probes (zero without layers).
    pub time_probes: Duration,
    /// Baking the sidecar's reflection probes (zero without layers).
    pub time_reflections: Duration,
    /// What was skipped and why, with counts.
    pub skipped: Vec<(String, usize)>,
    /// The photon mapper's maps, timings and counts (`photonmap` only).
    pub photon: Option<crate::photon::PhotonStats>,
    /// What a render in passes did (progressive photon mapping, `--time`, `--target-error`).
    pub passes: Option<crate::passes::PassStats>,
    /// True when the path integrator ran as a wavefront ([`crate::wavefront`]).
    pub wavefront: bool,
}

impl RenderStats {
    /// Rays per second over the render phase (camera, bounce and shadow rays).
    pub fn rays_per_second(&self) -> f64 {
        let t = self.time_render.as_secs_f64();
        if t > 0.0 { self.rays.total() as f64 / t } else { 0.0 }
    }
}

/// A finished render.
#[derive(Clone, Debug)]
pub struct RenderOutput {
    pub image: Image,
    pub depth: Option<DepthImage>,
    /// The light layers, when asked for and the render is a full frame in one pass.
    pub layers: Option<sidecar::LightLayers>,
    /// The irradiance probes, baked with the layers.
    pub probes: Option<sidecar::ProbeGrid>,
    /// The reflection probes, baked with the layers.
    pub reflections: Option<sidecar::ReflectionProbes>,
    /// The caustic photons and their estimates' kernels, with the layers and depth table where
    /// the photon mapper has a caustic map.
    pub caustics: Option<sidecar::CausticPhotons>,
    pub stats: RenderStats,
    pub warnings: Vec<Warning>,
}

/// Why a scene cannot be rendered.
#[derive(Debug, thiserror::Error)]
#[non_exhaustive]
pub enum RenderError {
    #[error("invalid camera: {0}")]
    Camera(#[from] CameraError),
    #[error("{0}")]
    World(#[from] WorldError),
    #[error("the image would have {pixels} pixels, more than the limit of {limit}")]
    TooLarge { pixels: u64, limit: u64 },
    #[error("cannot start worker threads: {0}")]
    Threads(String),
}

/// Images larger than this are refused rather than allocated.
pub const MAX_PIXELS: u64 = 1 << 28;

/// Pixels per tile side.
pub(crate) const TILE: u32 = 32;

/// Camera rays in render space, clipped to `Clipping`: depth_remap's world rays (unit length
/// in world units, so `t` is a distance in scene units) moved to render space.
#[derive(Clone, Debug)]
pub struct CameraRays {
    pub camera: Camera,
    render_from_world: DMat4,
    near: f64,
    far: f64,
    /// The `DepthOfField` lens; `None` is a pinhole.
    lens: Option<ThinLens>,
    /// A moving camera ([`World::camera_motion`]); `None` when it stays.
    motion: Option<Arc<TransformMotion>>,
    /// For a perspective camera, the render-space origin its pinhole rays all share (the eye,
    /// [`CameraRays::clip`]'s transform of depth_remap's world origin, made once), or `None`
    /// where that is not finite (no ray) or the camera is orthographic. Made from `camera` as
    /// `new` was given it (nothing changes `camera` after that).
    eye: Option<DVec3>,
}

impl CameraRays {
    pub fn new(camera: Camera, render_from_world: &DMat4) -> CameraRays {
        let c = camera.clipping();
        let near = if c.near.is_finite() && c.near > 0.0 { c.near } else { 0.0 };
        let far = if c.far.is_finite() && c.far > near { c.far } else { f64::INFINITY };
        let eye = camera
            .is_perspective()
            .then(|| render_from_world.transform_point3(camera.world_ray_through_raster(DVec2::ZERO).origin))
            .filter(|o| o.is_finite());
        CameraRays { camera, render_from_world: *render_from_world, near, far, lens: None, motion: None, eye }
    }

    /// The same rays through a thin lens (`DepthOfField`); a lens without aperture is a pinhole.
    pub fn with_lens(mut self, lens: Option<ThinLens>) -> CameraRays {
        self.lens = lens.filter(|l| l.radius > 0.0 && l.radius.is_finite() && l.focal_distance > 0.0);
        self
    }

    /// The same rays from a camera that moves as `motion` says ([`World::camera_motion`]).
    pub fn with_motion(mut self, motion: Option<Arc<TransformMotion>>) -> CameraRays {
        self.motion = motion;
        self
    }

    /// The ray of [`CameraRays::lens_ray`] taken by the camera at shutter fraction `time`, and
    /// carrying that time. Without camera motion it is that ray unmoved; the depth table keeps
    /// using the pinhole ray at shutter open ([`CameraRays::pixel_centre_ray`]). Inlined into
    /// the tile loop, with [`CameraRays::lens_ray`] and [`CameraRays::ray`]: out of line, the
    /// ray and its origin went back through memory at each of the three calls. A lens and a
    /// moving camera are calls.
    #[inline(always)]
    pub fn lens_ray_at(&self, raster: DVec2, lens_u: Vec2, time: f32) -> Option<(Ray, DVec3)> {
        let (ray, origin) = self.lens_ray(raster, lens_u)?;
        let Some(motion) = &self.motion else {
            return Some((Ray { time, ..ray }, origin));
        };
        self.moved(motion, (ray, origin), time)
    }

    /// The camera ray `(ray, origin)` of shutter open as `motion` moves it to shutter fraction
    /// `time` ([`CameraRays::lens_ray_at`]).
    #[inline(never)]
    fn moved(
        &self,
        motion: &TransformMotion,
        (ray, origin): (Ray, DVec3),
        time: f32,
    ) -> Option<(Ray, DVec3)> {
        let m = motion.at(f64::from(time));
        let moved_origin = m.transform_point3(origin);
        let direction = m.transform_vector3(ray.direction.as_dvec3());
        // The clipping range is a distance along the ray: it scales with the direction.
        let scale = direction.length() / ray.direction.as_dvec3().length();
        if !(scale.is_finite() && scale > 0.0 && moved_origin.is_finite()) {
            return None;
        }
        let moved = Ray {
            origin: moved_origin.as_vec3(),
            direction: (direction / direction.length()).as_vec3(),
            t_min: (f64::from(ray.t_min) * scale) as f32,
            t_max: (f64::from(ray.t_max) * scale) as f32,
            time,
        };
        Some((moved, moved_origin))
    }

    /// Whether camera rays need a lens sample (a pair of sampler dimensions) each.
    pub fn has_lens(&self) -> bool {
        self.lens.is_some()
    }

    /// The ray through a raster position and the lens point `lens_u` picks (uniform in
    /// `[0, 1)^2`), in render space; the pinhole ray of [`CameraRays::ray`] without a lens.
    #[inline(always)]
    pub fn lens_ray(&self, raster: DVec2, lens_u: Vec2) -> Option<(Ray, DVec3)> {
        match self.lens {
            None => self.ray(raster),
            Some(lens) => self.thin_lens_ray(lens, raster, lens_u),
        }
    }

    /// [`CameraRays::lens_ray`] through `lens`.
    #[inline(never)]
    fn thin_lens_ray(&self, lens: ThinLens, raster: DVec2, lens_u: Vec2) -> Option<(Ray, DVec3)> {
        let bent = lens.refract(self.camera.ray_through_raster(raster), lens_u);
        let world_from_camera = self.camera.world_from_camera();
        let direction_world = world_from_camera.transform_vector3(bent.direction);
        let world_length = direction_world.length();
        let wr = WorldRay {
            origin: world_from_camera.transform_point3(bent.origin),
            direction: direction_world / world_length,
        };
        // Camera-space z grows by `direction.z` per camera-space unit, `world_length` world units.
        self.clip(wr, bent.direction.z / world_length)
    }

    /// The ray through a raster position, in render space, with its `f64` origin. A
    /// perspective camera's is depth_remap's world ray (its direction, from the screen position
    /// converted once) from the eye found once, the same bits as [`CameraRays::to_render`] of
    /// [`Camera::world_ray_through_raster`] gives.
    #[inline(always)]
    pub fn ray(&self, raster: DVec2) -> Option<(Ray, DVec3)> {
        if !self.camera.is_perspective() {
            let wr = self.camera.world_ray_through_raster(raster);
            return self.to_render(wr, raster);
        }
        let eye = self.eye?;
        let s = self.camera.raster_to_screen(raster);
        let direction = self.camera.world_direction_at_screen(s);
        // The eye is finite (`CameraRays::new`).
        self.clip_finite(eye, direction, self.camera.eye_depth_per_radial_at_screen(s.x, s.y))
    }

    /// *The* ray through the centre of pixel `(i, j)` (depth_remap's definition), in render space.
    pub fn pixel_centre_ray(&self, i: u32, j: u32) -> Option<(Ray, DVec3)> {
        let wr = self.camera.pixel_centre_world_ray(i, j);
        self.to_render(wr, depth_remap::camera::pixel_centre(i, j))
    }

    fn to_render(&self, wr: WorldRay, raster: DVec2) -> Option<(Ray, DVec3)> {
        let s = self.camera.raster_to_screen(raster);
        self.clip(wr, self.camera.eye_depth_per_radial_at_screen(s.x, s.y))
    }

    /// `wr` in render space with its clipping range; camera-space z (where the clipping planes
    /// are) grows by `dz_dt` per unit of world distance along it.
    fn clip(&self, wr: WorldRay, dz_dt: f64) -> Option<(Ray, DVec3)> {
        let o = self.render_from_world.transform_point3(wr.origin);
        if !o.is_finite() {
            return None;
        }
        self.clip_finite(o, wr.direction, dz_dt)
    }

    /// [`CameraRays::clip`] of the ray from the finite render-space point `o` along the world
    /// direction `direction`.
    #[inline(always)]
    fn clip_finite(&self, o: DVec3, direction: DVec3, dz_dt: f64) -> Option<(Ray, DVec3)> {
        // For a positive `dz_dt`, being below infinity is being finite (a comparison, where
        // `is_finite` was a dozen integer instructions on the bits).
        if !(direction.is_finite() && dz_dt > 0.0 && dz_dt < f64::INFINITY) {
            return None;
        }
        let t_near = self.near / dz_dt;
        let t_far = self.far / dz_dt;
        let ray = Ray {
            origin: o.as_vec3(),
            direction: direction.as_vec3(),
            t_min: t_near as f32,
            t_max: if t_far.is_finite() { t_far as f32 } else { f32::INFINITY },
            time: 0.0,
        };
        Some((ray, o))
    }
}

/// The size of a pixel for the tessellation: the smaller pixel dimension, as an angle for a
/// perspective camera or a length for an orthographic one (a rigid camera transform assumed).
pub fn pixel_footprint(camera: &Camera) -> PixelFootprint {
    let (w, h) = camera.resolution();
    let sw = camera.screen_window();
    let per_pixel =
        ((sw.right - sw.left).abs() / f64::from(w)).min((sw.top - sw.bottom).abs() / f64::from(h));
    match camera.tan_half_fov() {
        // Screen units are tan(fov/2) per unit at the centre; an angle is at least that small.
        Some(t) => PixelFootprint::Perspective { radians_per_pixel: (per_pixel * t).atan() },
        None => {
            let centre = glam::DVec2::new(f64::from(w), f64::from(h)) * 0.5;
            let view_direction = camera.world_ray_through_raster(centre).direction;
            PixelFootprint::Orthographic { size: per_pixel, view_direction }
        }
    }
}

/// The integrator a scene asks for; without `SurfaceIntegrator`, path tracing when the scene
/// has area lights (a physically based scene), RenderMan-style direct lighting otherwise.
pub fn choose_integrator(scene: &Scene, diagnostics: &mut Diagnostics) -> IntegratorKind {
    match &scene.render.surface_integrator {
        Some(call) => {
            let (kind, warning) = IntegratorKind::from_call(call);
            if let Some(w) = warning {
                diagnostics.warn_once(Some(&call.loc), w);
            }
            kind
        }
        None => {
            if scene.lights.iter().any(|l| matches!(l.kind, LightKind::Area { .. })) {
                IntegratorKind::Path {
                    max_depth: crate::integrators::UNBOUNDED_DEPTH,
                    rr_depth: crate::integrators::DEFAULT_RR_DEPTH,
                }
            } else {
                IntegratorKind::DirectLighting { max_depth: 5 }
            }
        }
    }
}

/// Renders `scene`.
pub fn render(scene: &Scene, options: &RenderOptions) -> Result<RenderOutput, RenderError> {
    let mut builder = rayon::ThreadPoolBuilder::new();
    if let Some(n) = options.threads {
        builder = builder.num_threads(n.max(1));
    }
    let pool = builder.build().map_err(|e| RenderError::Threads(e.to_string()))?;
    let threads = pool.current_num_threads();
    pool.install(|| render_in_pool(scene, options, threads))
}

fn render_in_pool(
    scene: &Scene,
    options: &RenderOptions,
    threads: usize,
) -> Result<RenderOutput, RenderError> {
    let mut diagnostics = Diagnostics::default();
    let camera = Camera::new(scene.camera.clone())?;
    let (full_w, full_h) = camera.resolution();
    let pixels = u64::from(full_w) * u64::from(full_h);
    if pixels > MAX_PIXELS {
        return Err(RenderError::TooLarge { pixels, limit: MAX_PIXELS });
    }

    let build_start = Instant::now();
    let world = World::build(scene, camera.eye_position(), pixel_footprint(&camera), &mut diagnostics)?;
    let time_build = build_start.elapsed();
    let lens = scene.render.depth_of_field.as_ref().map(ThinLens::from_depth_of_field);
    let rays = CameraRays::new(camera, &world.render_from_world)
        .with_lens(lens)
        .with_motion(world.camera_motion.clone());

    let kind = options.integrator.unwrap_or_else(|| choose_integrator(scene, &mut diagnostics));
    let prepare_start = Instant::now();
    let mut integrator = kind.prepare(
        &world,
        PrepareContext { seed: options.seed, threads, caustic_paths: options.layers && options.depth },
    );
    let mut time_prepare = prepare_start.elapsed();
    let filter = crate::film::filter_from_settings(&scene.render.pixel_filter).unwrap_or_else(|why| {
        diagnostics.warn_once(None, format!("{why}: using gaussian 2 2"));
        Filter::RENDERMAN_DEFAULT
    });
    // PixelSamples x y asks for x * y samples; the sampler stratifies any count.
    let spp = match options.spp {
        Some(n) => n.clamp(1, 1 << 20),
        None => {
            let (x, y) = scene.render.pixel_samples;
            let s = |v: f32| if v.is_finite() { v.round().clamp(1.0, 4096.0) as u32 } else { 1 };
            (s(x) * s(y)).min(1 << 20)
        }
    };

    let (x0, x1, y0, y1) = rays.camera.crop_pixel_bounds();
    let (w, h) = (x1.saturating_sub(x0), y1.saturating_sub(y0));
    // Whether the path integrator runs as a wavefront, decided once for the render. The light
    // and transmission layers and the probe bakes come with `layers`; their hooks are on the
    // scalar path.
    let wavefront = if !options.wavefront.unwrap_or(WAVEFRONT_BY_DEFAULT) {
        Err("not asked for")
    } else if options.layers {
        Err("sidecar layers")
    } else {
        crate::wavefront::supports(&world, &kind)
    };

    // Image.
    let render_start = Instant::now();
    // The whole frame, not the crop: a crop's or a tile's pixels are then the full frame's, bit for
    // bit (docs/scale-out.md), at the price of each tile building the whole view's state.
    let view = crate::integrators::ViewContext {
        rays: &rays,
        bounds: (0, 0, full_w, full_h),
        seed: options.seed,
        spp,
    };
    let view_counters = integrator.prepare_view(&world, &view);
    let frame = Frame {
        world: &world,
        rays: &rays,
        filter: &filter,
        spp,
        seed: options.seed,
        bounds: (x0, y0, x1, y1),
        progress: options.progress.clone(),
        wavefront: wavefront.ok(),
    };
    let total = u64::from(w) * u64::from(h);
    let full_frame = (x0, y0, w, h) == (0, 0, full_w, full_h);
    let mut layer_pixels = None;
    let (pixels_out, mut counters, pass_stats) =
        match crate::passes::PassPlan::new(integrator.as_ref(), options, spp) {
            Some(plan) => {
                let r = crate::passes::render_passes(&frame, integrator, &plan, build_start);
                integrator = r.last;
                time_prepare += r.time_prepare;
                (r.pixels, r.counters, Some(r.stats))
            }
            None if options.layers && full_frame => {
                let plan = LayerPlan::new(&world, scene);
                let (pixels, layered, counters) = render_layered(&frame, integrator.as_ref(), &plan);
                layer_pixels = Some((plan, layered));
                (pixels, counters, None)
            }
            None => {
                let (pixels, counters) = frame.render(integrator.as_ref(), 0, None);
                (pixels, counters, None)
            }
        };
    let time_render = render_start.elapsed();
    counters.add(&view_counters);

    // Probes go with the layers.
    let probes_start = Instant::now();
    let mut probes = None;
    if layer_pixels.is_some()
        && let Some((grid, c)) = crate::probe_bake::bake_probes(
            &world,
            integrator.as_ref(),
            options.seed,
            crate::probe_bake::ProbeLimits::default(),
        )
    {
        counters.add(&c);
        probes = Some(grid);
    }
    let time_probes = probes_start.elapsed();
    let reflections_start = Instant::now();
    let mut reflections = None;
    if layer_pixels.is_some()
        && let Some((probes, c)) = crate::reflection_bake::bake_reflections(
            &world,
            integrator.as_ref(),
            options.seed,
            crate::reflection_bake::ReflectionLimits::default(),
        )
    {
        counters.add(&c);
        reflections = Some(probes);
    }
    let time_reflections = reflections_start.elapsed();
    // The caustic photons go with the layers, where the photon mapper has a caustic map.
    let caustics = if layer_pixels.is_some() && options.depth {
        integrator.caustic_photons(&world, &rays)
    } else {
        None
    };

    // Depth: only when asked for.
    let depth_start = Instant::now();
    let depth = options.depth.then(|| {
        let values: Vec<f32> = (y0..y1)
            .into_par_iter()
            .flat_map_iter(|j| {
                let world = &world;
                let rays = &rays;
                (x0..x1).map(move |i| depth_of(world, rays, i, j))
            })
            .collect();
        DepthImage { width: w, height: h, x_offset: x0, y_offset: y0, values }
    });
    let time_depth = if options.depth { depth_start.elapsed() } else { Duration::ZERO };

    diagnostics.skipped.extend(integrator.skipped());
    for w in integrator.warnings() {
        diagnostics.warn_once(None, w);
    }
    let mut integrator_stats = integrator.stats();
    if matches!(kind, IntegratorKind::Path { .. }) {
        integrator_stats.push(match wavefront {
            Ok(_) => format!("paths: wavefront, batches of up to {}", crate::wavefront::BATCH),
            Err(why) => format!("paths: scalar ({why})"),
        });
    }
    if let Some(p) = &pass_stats {
        integrator_stats.extend(p.lines());
    }
    let stats = RenderStats {
        integrator: integrator.name(),
        integrator_stats,
        passes: pass_stats,
        time_prepare,
        samples_per_pixel: spp,
        threads,
        width: w,
        height: h,
        world: world.stats.clone(),
        rays: counters,
        depth_rays: if options.depth { total } else { 0 },
        time_build,
        time_render,
        time_depth,
        time_probes,
        time_reflections,
        skipped: diagnostics.skipped.clone(),
        photon: integrator.photon_stats(),
        wavefront: wavefront.is_ok(),
    };
    let image = Image {
        width: w,
        height: h,
        x_offset: x0,
        y_offset: y0,
        full_width: full_w,
        full_height: full_h,
        pixels: pixels_out,
    };
    let layers = layer_pixels.map(|(plan, layered)| assemble(scene, &plan, &image, &layered, depth.as_ref()));
    let fingerprint = depth.as_ref().map_or(0, |d| sidecar::depth_fingerprint(&d.values));
    let probes = probes.map(|p| sidecar::ProbeGrid { depth_fingerprint: fingerprint, ..p });
    let reflections = reflections.map(|r| sidecar::ReflectionProbes { depth_fingerprint: fingerprint, ..r });
    let caustics = caustics.map(|c| sidecar::CausticPhotons { depth_fingerprint: fingerprint, ..c });
    Ok(RenderOutput {
        image,
        depth,
        layers,
        probes,
        reflections,
        caustics,
        stats,
        warnings: diagnostics.warnings,
    })
}

/// What every pass of a render shares: the world, the camera rays, the filter and the pixels.
pub(crate) struct Frame<'a> {
    pub world: &'a World,
    pub rays: &'a CameraRays,
    pub filter: &'a Filter,
    /// Samples per pixel of one pass.
    pub spp: u32,
    pub seed: u64,
    /// `(x0, y0, x1, y1)`: the pixels rendered (the crop window), full-frame coordinates.
    pub bounds: (u32, u32, u32, u32),
    pub progress: Option<ProgressFn>,
    /// The path integrator's settings when it runs as a wavefront.
    pub wavefront: Option<crate::wavefront::PathSettings>,
}

impl Frame<'_> {
    pub fn width(&self) -> u32 {
        self.bounds.2 - self.bounds.0
    }

    pub fn height(&self) -> u32 {
        self.bounds.3 - self.bounds.1
    }

    /// Renders every pixel (or those `active` marks, row-major over the bounds; the others are
    /// left zero) with samples `first_sample..first_sample + spp` of each pixel.
    pub fn render(
        &self,
        integrator: &dyn Integrator,
        first_sample: u32,
        active: Option<&[bool]>,
    ) -> (Vec<[f32; 4]>, RayCounters) {
        let (x0, y0, x1, y1) = self.bounds;
        let (w, h) = (self.width(), self.height());
        let mut tiles = Vec::new();
        let mut ty = y0;
        while ty < y1 {
            let mut tx = x0;
            while tx < x1 {
                tiles.push((tx, ty, (tx + TILE).min(x1), (ty + TILE).min(y1)));
                tx += TILE;
            }
            ty += TILE;
        }
        let total = u64::from(w) * u64::from(h);
        let done = AtomicU64::new(0);
        let tile_results: Vec<(Vec<[f32; 4]>, RayCounters)> = tiles
            .par_iter()
            .map(|&tile| {
                let r = render_tile(self, integrator, first_sample, active, tile);
                let n = u64::from(tile.2 - tile.0) * u64::from(tile.3 - tile.1);
                let d = done.fetch_add(n, Ordering::Relaxed) + n;
                if let Some(p) = &self.progress {
                    p(d, total);
                }
                r
            })
            .collect();
        let mut pixels_out = vec![[0.0f32; 4]; (w * h) as usize];
        let mut counters = RayCounters::default();
        for (&(tx0, ty0, tx1, ty1), (tile, c)) in tiles.iter().zip(&tile_results) {
            counters.add(c);
            let tw = tx1 - tx0;
            for y in ty0..ty1 {
                for x in tx0..tx1 {
                    pixels_out[((y - y0) * w + (x - x0)) as usize] =
                        tile[((y - ty0) * tw + (x - tx0)) as usize];
                }
            }
        }
        (pixels_out, counters)
    }
}

/// Distance along the pixel-centre ray of pixel `(i, j)` to the first surface it stops at
/// (fully transparent surfaces, `Opacity 0`, are passed), `inf` for a miss. The distance is
/// measured in `f64` from the ray's origin to the hit point.
pub fn depth_of(world: &World, rays: &CameraRays, i: u32, j: u32) -> f32 {
    let Some((mut ray, origin)) = rays.pixel_centre_ray(i, j) else { return f32::INFINITY };
    for _ in 0..256 {
        let Some(hit) = world.intersect(&ray) else { return f32::INFINITY };
        let si = world.interaction(&ray, &hit);
        if world.material(si.attributes).opacity != Vec3::ZERO {
            return (si.p64 - origin).length() as f32;
        }
        ray.t_min = hit.t;
    }
    f32::INFINITY
}

/// One sample: raster position and what the integrator returned.
#[derive(Clone, Copy)]
struct Sample {
    x: f32,
    y: f32,
    rgb: Vec3,
    alpha: f32,
}

/// Renders the pixels `[x0, x1) x [y0, y1)`: samples of the pixels within the filter's reach
/// (inside or outside the frame), then each pixel's filtered sum in a fixed order.
/// Pixels `active` leaves out (and samples no active pixel's filter reaches) are skipped.
fn render_tile(
    frame: &Frame,
    integrator: &dyn Integrator,
    first_sample: u32,
    active: Option<&[bool]>,
    tile: (u32, u32, u32, u32),
) -> (Vec<[f32; 4]>, RayCounters) {
    #[cfg(target_arch = "x86_64")]
    if let Some(v3) = frame.world.x86_64_v3 {
        // SAFETY: the token exists only on a CPU with these features.
        return unsafe { render_tile_v3(v3, frame, integrator, first_sample, active, tile) };
    }
    render_tile_inlined(None, frame, integrator, first_sample, active, tile)
}

/// [`render_tile`] compiled for x86-64-v3, as the wavefront's batch is
/// ([`crate::wavefront::render_batch`]): the camera ray, the samplers made per sample, their
/// first pairs (with SIMD, [`Sampler::uniform2_v3`](crate::sampler::Sampler::uniform2_v3)) and
/// the filtered sums get the VEX encodings. The same bits: Rust never fuses a multiply and an
/// add by itself, and the SIMD pairs are the scalar ones.
#[cfg(target_arch = "x86_64")]
#[target_feature(enable = "avx2,fma,bmi1,bmi2,lzcnt,popcnt")]
fn render_tile_v3(
    v3: X86_64V3,
    frame: &Frame,
    integrator: &dyn Integrator,
    first_sample: u32,
    active: Option<&[bool]>,
    tile: (u32, u32, u32, u32),
) -> (Vec<[f32; 4]>, RayCounters) {
    render_tile_inlined(Some(v3), frame, integrator, first_sample, active, tile)
}

/// The body of [`render_tile`]; `v3` as for [`Sampler::uniform2_v3`](crate::sampler::Sampler::uniform2_v3).
#[inline(always)]
fn render_tile_inlined(
    v3: Option<X86_64V3>,
    frame: &Frame,
    integrator: &dyn Integrator,
    first_sample: u32,
    active: Option<&[bool]>,
    (x0, y0, x1, y1): (u32, u32, u32, u32),
) -> (Vec<[f32; 4]>, RayCounters) {
    let (world, rays, filter, spp, seed) = (frame.world, frame.rays, frame.filter, frame.spp, frame.seed);
    let (fx0, fy0, fx1, fy1) = frame.bounds;
    let fw = (fx1 - fx0) as usize;
    let is_active = |x: i64, y: i64| -> bool {
        match active {
            None => true,
            Some(mask) => {
                x >= i64::from(fx0)
                    && x < i64::from(fx1)
                    && y >= i64::from(fy0)
                    && y < i64::from(fy1)
                    && mask[(y - i64::from(fy0)) as usize * fw + (x - i64::from(fx0)) as usize]
            }
        }
    };
    let (mx, my) = filter.pixel_margin();
    if active.is_some() && !(y0..y1).any(|y| (x0..x1).any(|x| is_active(i64::from(x), i64::from(y)))) {
        return (vec![[0.0f32; 4]; ((x1 - x0) * (y1 - y0)) as usize], RayCounters::default());
    }
    // A sample is needed when an active pixel's filter reaches its pixel.
    let needed = |px: i64, py: i64| -> bool {
        active.is_none()
            || ((py - i64::from(my)).max(i64::from(y0))..=(py + i64::from(my)).min(i64::from(y1) - 1)).any(
                |y| {
                    ((px - i64::from(mx)).max(i64::from(x0))..=(px + i64::from(mx)).min(i64::from(x1) - 1))
                        .any(|x| is_active(x, y))
                },
            )
    };
    let (sx0, sy0) = (x0 as i64 - i64::from(mx), y0 as i64 - i64::from(my));
    let (sx1, sy1) = (x1 as i64 + i64::from(mx), y1 as i64 + i64::from(my));
    let sw = (sx1 - sx0) as usize;
    let spp = spp as usize;
    let mut samples = Vec::with_capacity(sw * (sy1 - sy0) as usize * spp);
    let mut counters = RayCounters::default();
    // The wavefront's camera rays with their samplers and the index of their sample, in three
    // lists so that the batches borrow the samplers instead of copying them out; each as large
    // as the tile's samples from the start (grown by doubling, their copies were 0.7% of a
    // Cornell box render).
    let wavefront_samples = if frame.wavefront.is_some() { samples.capacity() } else { 0 };
    let (mut slots, mut cameras, mut samplers) = (
        Vec::with_capacity(wavefront_samples),
        Vec::with_capacity(wavefront_samples),
        Vec::with_capacity(wavefront_samples),
    );
    for py in sy0..sy1 {
        for px in sx0..sx1 {
            if !needed(px, py) {
                samples.extend((0..spp).map(|_| Sample {
                    x: px as f32,
                    y: py as f32,
                    rgb: Vec3::ZERO,
                    alpha: 0.0,
                }));
                continue;
            }
            let pixel_sampler = PixelSampler::new(seed, px, py);
            for s in 0..spp as u32 {
                let mut sampler = pixel_sampler.sample(first_sample.wrapping_add(s));
                // The first pair of dimensions places the sample in the pixel (stratified).
                let jitter = sampler.uniform2_v3(v3);
                let x = px as f64 + f64::from(jitter.x);
                let y = py as f64 + f64::from(jitter.y);
                // A lens sample only where there is a lens, so pinhole images stay as they were.
                let lens_u = if rays.has_lens() { sampler.uniform2_v3(v3) } else { Vec2::ZERO };
                // A time sample only where something moves, so still images stay as they were.
                let time = if world.motion_blur { sampler.uniform_v3(v3) } else { 0.0 };
                let r = match rays.lens_ray_at(DVec2::new(x, y), lens_u, time) {
                    Some((ray, _)) if frame.wavefront.is_some() => {
                        slots.push(samples.len());
                        cameras.push(ray);
                        samplers.push(sampler);
                        Default::default()
                    }
                    Some((ray, _)) => {
                        world.over_background(integrator.li(world, ray, &mut sampler, &mut counters))
                    }
                    None => Default::default(),
                };
                samples.push(Sample { x: x as f32, y: y as f32, rgb: r.rgb, alpha: r.alpha });
            }
        }
    }
    if let Some(settings) = frame.wavefront {
        let batch = crate::wavefront::BATCH;
        for ((slots, cameras), samplers) in
            slots.chunks(batch).zip(cameras.chunks(batch)).zip(samplers.chunks_mut(batch))
        {
            let radiance = crate::wavefront::render_batch(world, settings, cameras, samplers, &mut counters);
            for (&k, r) in slots.iter().zip(radiance) {
                let r = world.over_background(r);
                (samples[k].rgb, samples[k].alpha) = (r.rgb, r.alpha);
            }
        }
    }
    let tw = (x1 - x0) as usize;
    let mut out = vec![[0.0f32; 4]; tw * (y1 - y0) as usize];
    for y in y0..y1 {
        for x in x0..x1 {
            if !is_active(i64::from(x), i64::from(y)) {
                continue;
            }
            let (cx, cy) = (x as f32 + 0.5, y as f32 + 0.5);
            let mut sum = [0.0f64; 4];
            let mut weight = 0.0f64;
            for qy in (y as i64 - i64::from(my))..=(y as i64 + i64::from(my)) {
                for qx in (x as i64 - i64::from(mx))..=(x as i64 + i64::from(mx)) {
                    let base = (((qy - sy0) as usize) * sw + (qx - sx0) as usize) * spp;
                    for s in &samples[base..base + spp] {
                        let wgt = filter.weight(s.x - cx, s.y - cy);
                        if wgt != 0.0 {
                            let wgt = f64::from(wgt);
                            sum[0] += wgt * f64::from(s.rgb.x);
                            sum[1] += wgt * f64::from(s.rgb.y);
                            sum[2] += wgt * f64::from(s.rgb.z);
                            sum[3] += wgt * f64::from(s.alpha);
                            weight += wgt;
                        }
                    }
                }
            }
            let v = if weight != 0.0 {
                [
                    (sum[0] / weight) as f32,
                    (sum[1] / weight) as f32,
                    (sum[2] / weight) as f32,
                    (sum[3] / weight) as f32,
                ]
            } else {
                [0.0; 4]
            };
            out[(y - y0) as usize * tw + (x - x0) as usize] = v.map(|c| if c.is_finite() { c } else { 0.0 });
        }
    }
    (out, counters)
}

#[cfg(all(test, target_arch = "x86_64"))]
mod tests {
    use super::*;

    /// The tile loop's x86-64-v3 copy gives the baseline copy's pixels and ray counts bit for
    /// bit, through the scalar path tracer and the wavefront, over a whole frame and a tile
    /// inside it: a box of matte walls lit by an area quad, seen through a thin lens (the lens
    /// pair) and, in a second scene, with a moving wall and an open shutter (the time sample).
    #[test]
    fn x86_64_v3_tile_matches_the_baseline() {
        let Some(v3) = X86_64V3::detect() else {
            eprintln!("skipped: this CPU lacks x86-64-v3");
            return;
        };
        let walls = |moving: &str| {
            format!(
                "WorldBegin\nSurface \"matte\"\n\
                 AttributeBegin\nAreaLightSource \"arealight\" 2 \"intensity\" [6]\n\
                 Polygon \"P\" [-0.3 0.99 0.2 0.3 0.99 0.2 0.3 0.99 0.7 -0.3 0.99 0.7]\nAttributeEnd\n\
                 Polygon \"P\" [-1 -1 -1 1 -1 -1 1 -1 1 -1 -1 1]\n\
                 Polygon \"P\" [-1 1 -1 1 1 -1 1 1 1 -1 1 1]\n\
                 Polygon \"P\" [-1 -1 1 1 -1 1 1 1 1 -1 1 1]\n\
                 AttributeBegin\nColor [0.7 0.2 0.2]\n{moving}\n\
                 Polygon \"P\" [-1 -1 -1 -1 1 -1 -1 1 1 -1 -1 1]\nAttributeEnd\nWorldEnd\n"
            )
        };
        let camera = "Format 24 16 1\nProjection \"perspective\" \"fov\" [60]\n";
        let ribs = [
            format!("{camera}DepthOfField 2.8 0.4 2.5\nTranslate 0 0 2.5\n{}", walls("")),
            format!(
                "{camera}Shutter 0 1\nTranslate 0 0 2.5\n{}",
                walls("MotionBegin [0 1]\nTranslate 0 0 0\nTranslate 0.3 0 0\nMotionEnd")
            ),
        ];
        let (mut lens, mut motion, mut wavefronts) = (false, false, 0);
        for rib in ribs {
            let scene = rib_parser::load_bytes("tile.rib", rib.into_bytes(), &Default::default())
                .unwrap_or_else(|e| panic!("{}", e.render()))
                .scene;
            let camera = Camera::new(scene.camera.clone()).expect("the camera");
            let world = World::build(
                &scene,
                camera.eye_position(),
                pixel_footprint(&camera),
                &mut Diagnostics::default(),
            )
            .expect("the world builds");
            let rays = CameraRays::new(camera, &world.render_from_world)
                .with_lens(scene.render.depth_of_field.as_ref().map(ThinLens::from_depth_of_field))
                .with_motion(world.camera_motion.clone());
            lens |= rays.has_lens();
            motion |= world.motion_blur;
            let kind = IntegratorKind::Path { max_depth: 6, rr_depth: 3 };
            let integrator =
                kind.prepare(&world, PrepareContext { seed: 5, threads: 1, caustic_paths: false });
            for wavefront in [None, crate::wavefront::supports(&world, &kind).ok()] {
                wavefronts += usize::from(wavefront.is_some());
                let frame = Frame {
                    world: &world,
                    rays: &rays,
                    filter: &Filter::RENDERMAN_DEFAULT,
                    spp: 3,
                    seed: 5,
                    bounds: (0, 0, 24, 16),
                    progress: None,
                    wavefront,
                };
                for tile in [(0, 0, 24, 16), (5, 3, 13, 11)] {
                    let bits = |(pixels, counters): (Vec<[f32; 4]>, RayCounters)| {
                        (pixels.iter().map(|p| p.map(f32::to_bits)).collect::<Vec<_>>(), counters)
                    };
                    let baseline =
                        bits(render_tile_inlined(None, &frame, integrator.as_ref(), 7, None, tile));
                    // SAFETY: an `X86_64V3` exists only on a CPU with these features.
                    let lanes =
                        bits(unsafe { render_tile_v3(v3, &frame, integrator.as_ref(), 7, None, tile) });
                    assert_eq!(lanes, baseline, "tile {tile:?}, wavefront {}", wavefront.is_some());
                    assert!(baseline.0.iter().any(|p| p[0] != 0), "the tile is lit");
                }
            }
        }
        assert!(lens && motion && wavefronts > 0, "lens {lens}, motion {motion}, wavefronts {wavefronts}");
    }
}
