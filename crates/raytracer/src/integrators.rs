//! Surface integrators: `directlighting` (Whitted-style), `path` (unbiased path tracing with
//! multiple importance sampling and Russian roulette, the project's ground truth) and
//! `photonmap` ([`crate::photon`]).
//!
//! An integrator is an [`IntegratorKind`] (what the RIB asked for, with its parameters) made
//! ready for a world by [`IntegratorKind::prepare`] into an [`Integrator`]. The building blocks
//! are public so that other integrators (the photon mapper) share them:
//! [`find_surface`] resolves partially transparent surfaces, [`sample_one_light`] and
//! [`direct_from_light`] estimate direct lighting with multiple importance sampling, and
//! [`RayCounters`] counts rays for `--stats`.

use crate::accel::X86_64V3;
use crate::bsdf::{Bsdf, LobeFlags, TransportMode};
use crate::lights::{Light, LightLiSample, LightSampleContext};
use crate::materials::Material;
use crate::math::average;
use crate::photon::{PhotonMapSettings, PhotonMapper, PhotonStats};
use crate::sampler::Sampler;
use crate::sampling::power_heuristic;
use crate::world::{Ray, SurfaceInteraction, World};
use glam::Vec3;
use rib_parser::scene::ShaderCall;

/// Rays traced, by kind.
#[derive(Clone, Copy, Debug, Default, PartialEq, Eq)]
pub struct RayCounters {
    pub camera: u64,
    pub bounce: u64,
    pub shadow: u64,
}

impl RayCounters {
    pub fn add(&mut self, other: &RayCounters) {
        self.camera += other.camera;
        self.bounce += other.bounce;
        self.shadow += other.shadow;
    }

    pub fn total(&self) -> u64 {
        self.camera + self.bounce + self.shadow
    }
}

/// Which integrator renders the image, with its parameters.
#[derive(Clone, Copy, Debug, PartialEq)]
pub enum IntegratorKind {
    /// Direct lighting from every light, specular reflection and refraction followed to
    /// `max_depth` (pbrt-v1/LRT `directlighting`, default depth 5).
    DirectLighting { max_depth: u32 },
    /// Unidirectional path tracing with next-event estimation and MIS; Russian roulette after
    /// `rr_depth` bounces; `max_depth` bounces at most (default effectively unbounded).
    Path { max_depth: u32, rr_depth: u32 },
    /// Photon mapping with final gathering (pbrt-v1/v2 `photonmap`); see [`crate::photon`].
    PhotonMap(PhotonMapSettings),
}

/// Largest path depth used when a RIB does not limit it: deep enough to be unbiased in
/// practice (Russian roulette ends paths long before), finite so no path runs forever.
pub const UNBOUNDED_DEPTH: u32 = 1024;

impl IntegratorKind {
    /// The integrator named by `SurfaceIntegrator`, with its parameters. Returns the kind and a
    /// warning when the name is not one of ours.
    pub fn from_call(call: &ShaderCall) -> (IntegratorKind, Option<String>) {
        let depth = |default: u32| {
            call.params
                .ints("maxdepth")
                .and_then(|v| v.first().copied())
                .map(|d| d.max(0) as u32)
                .or_else(|| {
                    call.params.float("maxdepth").filter(|d| d.is_finite()).map(|d| d.max(0.0) as u32)
                })
                .unwrap_or(default)
                .min(UNBOUNDED_DEPTH)
        };
        let rr = || {
            call.params
                .ints("rrdepth")
                .and_then(|v| v.first().copied())
                .map(|d| d.max(1) as u32)
                .unwrap_or(DEFAULT_RR_DEPTH)
        };
        match call.name.as_str() {
            "directlighting" | "whitted" => (IntegratorKind::DirectLighting { max_depth: depth(5) }, None),
            "path" => (IntegratorKind::Path { max_depth: depth(UNBOUNDED_DEPTH), rr_depth: rr() }, None),
            "photonmap" => {
                let (settings, notes) = PhotonMapSettings::from_params(&call.params);
                (IntegratorKind::PhotonMap(settings), (!notes.is_empty()).then(|| notes.join("; ")))
            }
            other => (
                IntegratorKind::Path { max_depth: depth(UNBOUNDED_DEPTH), rr_depth: rr() },
                Some(format!("surface integrator \"{other}\" is not available: using \"path\"")),
            ),
        }
    }

    pub fn name(&self) -> &'static str {
        match self {
            IntegratorKind::DirectLighting { .. } => "directlighting",
            IntegratorKind::Path { .. } => "path",
            IntegratorKind::PhotonMap(_) => "photonmap",
        }
    }
}

/// Russian roulette starts after this many bounces by default (as in the Mitsuba reference).
pub const DEFAULT_RR_DEPTH: u32 = 5;

/// Radiance and coverage of a camera ray.
#[derive(Clone, Copy, Debug, Default, PartialEq)]
pub struct Radiance {
    pub rgb: Vec3,
    pub alpha: f32,
}

/// The most partially transparent layers a ray passes before it is stopped.
const MAX_TRANSPARENT_LAYERS: u32 = 256;

/// The first surface along `ray` that the ray stops at, resolving partial opacity
/// stochastically (fully transparent surfaces are passed; a surface with opacity `Os` stops the
/// ray with probability `mean(Os)`). Returns the surface and the weight of the choices made.
pub fn find_surface(
    world: &World,
    ray: Ray,
    sampler: &mut Sampler,
    counter: &mut u64,
) -> Option<(SurfaceInteraction, Vec3)> {
    find_surface_or_escape(world, ray, sampler, counter).ok()
}

/// [`find_surface`], telling a ray that leaves the scene (`Err`, with the weight of the
/// partially transparent surfaces it passed, which tints what it sees of an environment) from
/// one stopped after too many layers (`Err(Vec3::ZERO)`).
pub fn find_surface_or_escape(
    world: &World,
    ray: Ray,
    sampler: &mut Sampler,
    counter: &mut u64,
) -> Result<(SurfaceInteraction, Vec3), Vec3> {
    find_surface_or_escape_inlined(world, ray, sampler, counter)
}

/// [`find_surface_or_escape`], inlined into the path tracer's loop: called out of line, the
/// surface interaction was copied twice on its way out (the result, then the match).
#[inline(always)]
fn find_surface_or_escape_inlined(
    world: &World,
    mut ray: Ray,
    sampler: &mut Sampler,
    counter: &mut u64,
) -> Result<(SurfaceInteraction, Vec3), Vec3> {
    let mut weight = Vec3::ONE;
    for _ in 0..MAX_TRANSPARENT_LAYERS {
        *counter += 1;
        let Some(hit) = world.intersect(&ray) else { return Err(weight) };
        let si = world.interaction(&ray, &hit);
        let opacity = world.material(si.attributes).opacity;
        if opacity == Vec3::ONE {
            return Ok((si, weight));
        }
        let p_stop = average(opacity).clamp(0.0, 1.0);
        if p_stop > 0.0 && sampler.uniform() < p_stop {
            return Ok((si, weight * opacity / p_stop));
        }
        if p_stop >= 1.0 {
            return Ok((si, weight));
        }
        weight *= (Vec3::ONE - opacity) / (1.0 - p_stop);
        // Continue on the far side of this surface, same direction.
        let next = si.spawn_ray(ray.direction);
        let travelled = hit.t;
        ray = Ray {
            origin: next.origin,
            direction: ray.direction,
            t_min: 0.0,
            t_max: if ray.t_max.is_finite() { (ray.t_max - travelled).max(0.0) } else { f32::INFINITY },
            time: ray.time,
        };
    }
    Err(Vec3::ZERO)
}

pub(crate) fn light_context(si: &SurfaceInteraction) -> LightSampleContext {
    LightSampleContext { p: si.p, p_error: si.p_error, n: si.ng, p64: si.p64 }
}

/// How a direct-lighting estimate combines its strategies.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum DirectStrategy {
    /// Light sampling only, unweighted (for lights no BSDF sample can hit: all weights are 1).
    LightOnly,
    /// Light sampling weighted by the power heuristic against BSDF sampling that the caller
    /// does itself (a path tracer's next bounce).
    LightWithMisWeight,
    /// Both light and BSDF sampling here, combined with the power heuristic.
    Both,
}

/// The light sample `ls` of a light picked with probability `pick_probability` reaching `si`
/// past the scene (one shadow ray), as an estimate: `f` is the BSDF's value times the cosine
/// toward the sample and `bsdf_pdf` its density there, weighted by the power heuristic when
/// `mis`. Zero when the shadow ray is blocked. The scalar and the wavefront path integrators
/// both estimate with it, so their images stay bit-identical. Always inlined: the wavefront's
/// x86-64-v3 batch then compiles it (and the shadow ray's ends) with its own features, and
/// passes its token `v3` for the ends' offsets in lanes; the scalar integrator passes `None`.
#[inline(always)]
#[allow(clippy::too_many_arguments)]
pub(crate) fn visible_light_estimate(
    v3: Option<X86_64V3>,
    world: &World,
    si: &SurfaceInteraction,
    ls: &LightLiSample,
    (f, bsdf_pdf): (Vec3, f32),
    pick_probability: f32,
    mis: bool,
    counters: &mut RayCounters,
) -> Vec3 {
    let shadow = match ls.p_light {
        Some((p, err, n)) => si.spawn_ray_to_v3(v3, p, err, n),
        None => si.spawn_ray_inlined(v3, ls.wi),
    };
    counters.shadow += 1;
    let tr = world.transmittance(&shadow);
    if tr == Vec3::ZERO {
        Vec3::ZERO
    } else if ls.is_delta {
        f * ls.li * tr / pick_probability
    } else {
        let light_pdf = pick_probability * ls.pdf;
        let w = if mis { power_heuristic(light_pdf, bsdf_pdf) } else { 1.0 };
        f * ls.li * tr * (w / light_pdf)
    }
}

/// Light from one light toward `si` (see [`DirectStrategy`]). `pick_probability` is the
/// probability with which the caller chose this light.
#[allow(clippy::too_many_arguments)]
pub fn direct_from_light(
    world: &World,
    si: &SurfaceInteraction,
    bsdf: &Bsdf,
    light_index: u32,
    pick_probability: f32,
    mask: LobeFlags,
    sampler: &mut Sampler,
    counters: &mut RayCounters,
    strategy: DirectStrategy,
) -> Vec3 {
    let light = &world.lights[light_index as usize];
    let mis = strategy != DirectStrategy::LightOnly && !light.is_delta();
    let mut total = Vec3::ZERO;
    let wo = si.wo;
    if let Some(ls) = light.sample_li(&light_context(si), sampler.uniform2()) {
        // MIS needs the BSDF's density toward the light as well as its value: one evaluation.
        let (f, bsdf_pdf) = if mis && !ls.is_delta {
            bsdf.f_and_pdf(wo, ls.wi, mask)
        } else {
            (bsdf.f(wo, ls.wi, mask), 0.0)
        };
        let f = f * ls.wi.dot(bsdf.frame.z).abs();
        if f != Vec3::ZERO && ls.li != Vec3::ZERO {
            total +=
                visible_light_estimate(None, world, si, &ls, (f, bsdf_pdf), pick_probability, mis, counters);
        }
    }
    if strategy == DirectStrategy::Both && !light.is_delta() {
        // BSDF sampling toward the same light.
        if let Some(bs) = bsdf.sample(
            wo,
            sampler.uniform(),
            sampler.uniform2(),
            TransportMode::Radiance,
            non_specular(mask),
        ) {
            let f = bs.f * bs.wi.dot(bsdf.frame.z).abs();
            if f != Vec3::ZERO && bs.pdf > 0.0 {
                let ray = si.spawn_ray(bs.wi);
                counters.shadow += 1;
                match world.intersect(&ray) {
                    Some(hit) => {
                        let li_si = world.interaction(&ray, &hit);
                        if li_si.emitter == Some(light_index) {
                            let le = light.emitted(li_si.ng, li_si.wo);
                            if le != Vec3::ZERO {
                                let light_pdf =
                                    pick_probability * light.pdf_li(si.p64, bs.wi, li_si.p64, li_si.ng);
                                let w = power_heuristic(bs.pdf, light_pdf);
                                // Partially transparent occluders between are ignored here; they
                                // are rare and the light-sampling half accounts for them.
                                total += f * le * (w / bs.pdf);
                            }
                        }
                    }
                    // The ray leaves the scene: an environment light is what it sees.
                    None if matches!(light, Light::Environment(_)) => {
                        let le = light.escaped(bs.wi);
                        if le != Vec3::ZERO {
                            let light_pdf = pick_probability * light.pdf_escaped(bs.wi);
                            total += f * le * (power_heuristic(bs.pdf, light_pdf) / bs.pdf);
                        }
                    }
                    None => {}
                }
            }
        }
    }
    crate::light_layers::direct(light_index, total);
    total
}

fn non_specular(mask: LobeFlags) -> LobeFlags {
    mask & LobeFlags::NON_SPECULAR
}

/// Next-event estimation with one light chosen from the surface's light set by power, weighted
/// for MIS against the BSDF sample the caller follows next (which must weight the emitters it
/// hits with the complementary weight, as [`PathTracer`]'s `li` does).
#[inline]
pub fn sample_one_light(
    world: &World,
    si: &SurfaceInteraction,
    bsdf: &Bsdf,
    mask: LobeFlags,
    sampler: &mut Sampler,
    counters: &mut RayCounters,
) -> Vec3 {
    let set = world.light_set(si.attributes);
    let Some((light, p)) = set.pick(sampler.uniform()) else { return Vec3::ZERO };
    direct_from_light(world, si, bsdf, light, p, mask, sampler, counters, DirectStrategy::LightWithMisWeight)
}

/// [`surface_terms`] of a material without them under the ambient light `ambient`: the sum
/// with its three terms zero, bit for bit. NaN under an infinite ambient light, as before;
/// under a finite one, `+0` in every channel, which the wavefront takes without looking the
/// light set up (`surface_terms_are_zero_under_a_finite_ambient_light`).
#[inline(always)]
pub(crate) fn no_surface_terms(ambient: Vec3) -> Vec3 {
    Vec3::ZERO + Vec3::ZERO * ambient + Vec3::ZERO
}

/// Emission, self-emission and ambient light at a surface reached by a ray (all but the
/// emission of lights, which the integrators weight themselves).
#[inline]
pub fn surface_terms(world: &World, si: &SurfaceInteraction, material: &Material) -> Vec3 {
    let set = world.light_set(si.attributes);
    if !material.has_surface_terms() {
        return no_surface_terms(set.ambient);
    }
    material.self_emission(si.ns, si.wo, si.st, si.st_width)
        + material.ambient_reflectance(si.st, si.st_width) * set.ambient
        + material.environment_reflection(si.ns, si.wo)
}

/// Radiance of the environment lights seen along a ray that leaves the scene in direction
/// `dir`.
pub fn escaped(world: &World, dir: Vec3) -> Vec3 {
    let dir = dir.normalize_or_zero();
    if world.environment_lights.is_empty() || dir == Vec3::ZERO {
        return Vec3::ZERO;
    }
    world.environment_lights.iter().map(|&e| world.lights[e as usize].escaped(dir)).sum()
}

/// A camera ray that leaves the scene: the environment it sees (no coverage) through surfaces
/// of weight `through`, recorded as emission seen by the camera for the light layers.
pub fn camera_escaped(world: &World, dir: Vec3, through: Vec3) -> Radiance {
    let le = sanitize(through * escaped(world, dir));
    crate::light_layers::camera_escaped(le);
    Radiance { rgb: le, alpha: 0.0 }
}

/// A surface integrator ready to render: made from an [`IntegratorKind`] and the world by
/// [`IntegratorKind::prepare`], which may do work first (a photon mapper shoots its photons
/// there). Rendering calls [`Integrator::li`] from many threads.
pub trait Integrator: Sync {
    /// The name `--stats` reports.
    fn name(&self) -> String;
    /// Radiance and coverage along a camera ray.
    fn li(&self, world: &World, ray: Ray, sampler: &mut Sampler, counters: &mut RayCounters) -> Radiance;
    /// Extra `--stats` lines: what was built, skipped and why.
    fn stats(&self) -> Vec<String> {
        Vec::new()
    }
    /// What the integrator skipped and why, with counts (merged into `RenderStats::skipped`).
    fn skipped(&self) -> Vec<(String, usize)> {
        Vec::new()
    }
    /// Warnings from preparing (e.g. photon shooting stopped early).
    fn warnings(&self) -> Vec<String> {
        Vec::new()
    }
    /// The photon mapper's statistics (`photonmap` only).
    fn photon_stats(&self) -> Option<PhotonStats> {
        None
    }
    /// Work that depends on the view, done once before the image (the photon mapper's
    /// irradiance cache), in the render's thread pool; returns the rays it traced.
    fn prepare_view(&mut self, _world: &World, _view: &ViewContext) -> RayCounters {
        RayCounters::default()
    }
    /// Passes a render with this integrator takes by default (`None`: one pass, unless
    /// `--time` or `--target-error` ask for more); see [`crate::passes`].
    fn default_passes(&self) -> Option<u32> {
        None
    }
    /// The integrator of the next pass when it differs from this one (progressive photon
    /// mapping: new photons, a smaller radius); `None` renders the next pass with this one.
    /// Called once the pass is rendered: an integrator that returns a successor may free what
    /// only its pass reads first, so that the two are not held at once.
    fn next_pass(&mut self, _world: &World) -> Option<Box<dyn Integrator>> {
        None
    }
    /// The sidecar's caustics file for the view of `rays` (the photon mapper's caustic map, when
    /// prepared with `PrepareContext::caustic_paths`); `None` for a render without one.
    fn caustic_photons(
        &self,
        _world: &World,
        _rays: &crate::render::CameraRays,
    ) -> Option<sidecar::CausticPhotons> {
        None
    }
}

/// The view an image is rendered from: its camera rays, its pixels (`(x0, y0, x1, y1)`, the
/// whole frame even for a crop, so that a crop's pixels are the full frame's), the render's seed
/// and its samples per pixel (of one pass).
#[derive(Clone, Copy, Debug)]
pub struct ViewContext<'a> {
    pub rays: &'a crate::render::CameraRays,
    pub bounds: (u32, u32, u32, u32),
    pub seed: u64,
    pub spp: u32,
}

/// Preparation of an integrator: threads are the render's pool (already installed), `seed` the
/// render's seed.
#[derive(Clone, Copy, Debug)]
pub struct PrepareContext {
    pub seed: u64,
    pub threads: usize,
    /// Keep what the sidecar's caustics file needs (the caustic photons' paths).
    pub caustic_paths: bool,
}

impl IntegratorKind {
    /// The integrator, ready to render `world`.
    pub fn prepare(&self, world: &World, context: PrepareContext) -> Box<dyn Integrator> {
        match *self {
            IntegratorKind::PhotonMap(settings) => {
                let settings = PhotonMapSettings { caustic_paths: context.caustic_paths, ..settings };
                Box::new(PhotonMapper::prepare(world, settings, context.seed))
            }
            IntegratorKind::DirectLighting { max_depth } => Box::new(DirectLighting { max_depth }),
            IntegratorKind::Path { max_depth, rr_depth } => Box::new(PathTracer { max_depth, rr_depth }),
        }
    }
}

/// `SurfaceIntegrator "directlighting"`.
#[derive(Clone, Copy, Debug)]
pub struct DirectLighting {
    pub max_depth: u32,
}

impl Integrator for DirectLighting {
    fn name(&self) -> String {
        "directlighting".into()
    }

    fn li(&self, world: &World, ray: Ray, sampler: &mut Sampler, counters: &mut RayCounters) -> Radiance {
        let mut camera = 0;
        let r = whitted(world, ray, 0, self.max_depth, sampler, counters, &mut camera);
        counters.camera += camera.min(1);
        counters.bounce += camera.saturating_sub(1);
        r
    }
}

/// `SurfaceIntegrator "path"`.
#[derive(Clone, Copy, Debug)]
pub struct PathTracer {
    pub max_depth: u32,
    pub rr_depth: u32,
}

impl Integrator for PathTracer {
    fn name(&self) -> String {
        "path".into()
    }

    fn li(&self, world: &World, ray: Ray, sampler: &mut Sampler, counters: &mut RayCounters) -> Radiance {
        path(world, ray, self.max_depth, self.rr_depth, sampler, counters)
    }
}

fn whitted(
    world: &World,
    ray: Ray,
    depth: u32,
    max_depth: u32,
    sampler: &mut Sampler,
    counters: &mut RayCounters,
    rays: &mut u64,
) -> Radiance {
    let (si, weight) = match find_surface_or_escape(world, ray, sampler, rays) {
        Ok(found) => found,
        Err(through) if depth == 0 => return camera_escaped(world, ray.direction, through),
        Err(through) => {
            return Radiance { rgb: sanitize(through * escaped(world, ray.direction)), alpha: 0.0 };
        }
    };
    let material = world.material(si.attributes);
    if material.holdout {
        return Radiance { rgb: Vec3::ZERO, alpha: 0.0 };
    }
    let mut l = surface_terms(world, &si, material);
    if let Some(e) = si.emitter {
        l += world.lights[e as usize].emitted(si.ng, si.wo);
    }
    let bsdf = material.bsdf(si.wo, si.ng, si.ns, si.n_outward, si.dpdu, si.st, si.st_width);
    if depth == 0 {
        crate::light_layers::primary_vertex(world, &si, material, &bsdf, weight);
    }
    let directions = bsdf.specular_directions(si.wo, TransportMode::Radiance);
    let chain = crate::transmission_layers::vertex(depth, si.p, &bsdf, directions);
    if !bsdf.is_black() {
        if bsdf.has_non_specular() {
            let set = world.light_set(si.attributes);
            for &light in &set.lights {
                l += direct_from_light(
                    world,
                    &si,
                    &bsdf,
                    light,
                    1.0,
                    LobeFlags::ALL,
                    sampler,
                    counters,
                    DirectStrategy::Both,
                );
            }
            crate::light_layers::end_primary();
        }
        if depth < max_depth {
            for (k, (wi, w, flags)) in directions.into_iter().enumerate() {
                if w == Vec3::ZERO {
                    continue;
                }
                let link = crate::transmission_layers::branch(chain == Some(k), si.p, wi, w, weight);
                let mut sub = 0;
                let r = whitted(world, si.spawn_ray(wi), depth + 1, max_depth, sampler, counters, &mut sub);
                crate::transmission_layers::after_branch(link, r.rgb);
                counters.bounce += sub;
                l += w * r.rgb;
                if depth == 0 && flags.intersects(LobeFlags::REFLECTION) {
                    crate::light_layers::primary_reflection(w * r.rgb);
                }
            }
        }
    }
    Radiance { rgb: sanitize(l * weight), alpha: 1.0 }
}

/// Replaces non-finite or negative values by zero so nothing invalid reaches the film.
#[inline]
pub fn sanitize(c: Vec3) -> Vec3 {
    let f = |v: f32| if v.is_finite() && v > 0.0 { v } else { 0.0 };
    Vec3::new(f(c.x), f(c.y), f(c.z))
}

/// What the path tracer's ray leaving the scene sees of the environment lights, with path
/// weight `beta`: all of it for camera rays and after specular bounces, else weighted by the
/// power heuristic against the light sample taken at the previous vertex `prev`.
pub(crate) fn escaped_with_mis(
    world: &World,
    dir: Vec3,
    beta: Vec3,
    depth: u32,
    specular_bounce: bool,
    prev: Option<(glam::DVec3, f32, rib_parser::scene::AttributesId)>,
) -> Vec3 {
    if depth == 0 {
        return camera_escaped(world, dir, beta).rgb;
    }
    let dir = dir.normalize_or_zero();
    let mut l = Vec3::ZERO;
    for &e in &world.environment_lights {
        let light = &world.lights[e as usize];
        let le = light.escaped(dir);
        if le == Vec3::ZERO {
            continue;
        }
        match prev {
            Some((_, pdf_bsdf, attrs)) if !specular_bounce => {
                let pick = world.light_set(attrs).pmf(e);
                if pick > 0.0 {
                    let c = beta * le * power_heuristic(pdf_bsdf, pick * light.pdf_escaped(dir));
                    l += c;
                    if depth == 1 {
                        crate::light_layers::direct_via_bsdf(e, c);
                    }
                }
            }
            _ => l += beta * le,
        }
    }
    l
}

fn path(
    world: &World,
    mut ray: Ray,
    max_depth: u32,
    rr_depth: u32,
    sampler: &mut Sampler,
    counters: &mut RayCounters,
) -> Radiance {
    let mut l = Vec3::ZERO;
    let mut beta = Vec3::ONE;
    let mut alpha = 0.0;
    let mut specular_bounce = true;
    // The sample's colour when it left the primary vertex by its specular reflection.
    let mut reflection_from: Option<Vec3> = None;
    // The primary hit's transmitted chain while the path follows it (docs/sidecar.md).
    let mut chain = crate::transmission_layers::PathChain::default();
    let mut eta_scale = 1.0f32;
    // The previous vertex (for MIS of emitters hit by BSDF sampling).
    let mut prev: Option<(glam::DVec3, f32, rib_parser::scene::AttributesId)> = None;
    let mut depth = 0u32;
    loop {
        let mut rays = 0;
        let found = find_surface_or_escape_inlined(world, ray, sampler, &mut rays);
        if depth == 0 {
            counters.camera += rays;
        } else {
            counters.bounce += rays;
        }
        let (si, weight) = match found {
            Ok(found) => found,
            Err(through) => {
                l += escaped_with_mis(world, ray.direction, beta * through, depth, specular_bounce, prev);
                break;
            }
        };
        beta *= weight;
        let material = world.material(si.attributes);
        if material.holdout {
            break;
        }
        if depth == 0 {
            alpha = 1.0;
        }
        if let Some(e) = si.emitter {
            let light = &world.lights[e as usize];
            let le = light.emitted(si.ng, si.wo);
            if le != Vec3::ZERO {
                match prev {
                    None => l += beta * le,
                    Some(_) if specular_bounce => l += beta * le,
                    Some((p_prev, pdf_bsdf, attrs)) => {
                        let set = world.light_set(attrs);
                        let pick = set.pmf(e);
                        if pick > 0.0 {
                            let light_pdf = pick * light.pdf_li(p_prev, -si.wo, si.p64, si.ng);
                            let c = beta * le * power_heuristic(pdf_bsdf, light_pdf);
                            l += c;
                            if depth == 1 {
                                crate::light_layers::direct_via_bsdf(e, c);
                            }
                        }
                    }
                }
            }
        }
        l += beta * surface_terms(world, &si, material);
        let bsdf = material.bsdf_inlined(si.wo, si.ng, si.ns, si.n_outward, si.dpdu, si.st, si.st_width);
        if depth == 0 {
            crate::light_layers::primary_vertex(world, &si, material, &bsdf, beta);
        }
        crate::transmission_layers::path_reached(&mut chain, depth, si.p, si.wo, &bsdf);
        if bsdf.is_black() || depth >= max_depth {
            break;
        }
        if bsdf.has_non_specular() {
            l += beta * sample_one_light(world, &si, &bsdf, LobeFlags::ALL, sampler, counters);
            crate::light_layers::end_primary();
        }
        let Some(bs) = bsdf.sample(
            si.wo,
            sampler.uniform(),
            sampler.uniform2(),
            TransportMode::Radiance,
            LobeFlags::ALL,
        ) else {
            break;
        };
        let cos = bs.wi.dot(bsdf.frame.z).abs();
        beta *= bs.f * (cos / bs.pdf);
        if !beta.is_finite() || beta == Vec3::ZERO {
            break;
        }
        specular_bounce = bs.is_specular();
        if depth == 0 && specular_bounce && bs.flags.intersects(LobeFlags::REFLECTION) {
            reflection_from = Some(l);
        }
        if bs.flags.intersects(LobeFlags::TRANSMISSION) {
            eta_scale *= bs.eta * bs.eta;
        }
        prev = Some((si.p64, bs.pdf, si.attributes));
        ray = si.spawn_ray(bs.wi);
        depth += 1;
        if depth > rr_depth {
            let rr_beta = (beta * eta_scale).max_element();
            if rr_beta < 1.0 {
                let q = (1.0 - rr_beta).max(0.0);
                if sampler.uniform() < q {
                    break;
                }
                beta /= 1.0 - q;
            }
        }
        crate::transmission_layers::path_sampled(&mut chain, si.p, bs.wi, bs.flags, beta, l);
    }
    if let Some(before) = reflection_from {
        crate::light_layers::primary_reflection_weighted(l - before);
    }
    crate::transmission_layers::path_end(&chain, l);
    Radiance { rgb: sanitize(l), alpha }
}
