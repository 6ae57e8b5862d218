//! Rendering with the photon maps: the radiance along a camera ray.

use super::estimate::{self, NORMAL_COSINE, Query};
use super::kdtree::KnnHeap;
use super::{GatherSampling, Photon, PhotonMapper, unpack_unit};
use crate::bsdf::{Bsdf, Lobe, LobeFlags, TransportMode};
use crate::integrators::{
    DirectStrategy, Radiance, RayCounters, camera_escaped, direct_from_light, escaped, find_surface,
    find_surface_or_escape, sanitize, surface_terms,
};
use crate::math::Frame;
use crate::sampler::Sampler;
use crate::sampling::{power_heuristic, sample_uniform_cone, uniform_cone_pdf};
use crate::world::{Ray, SurfaceInteraction, World};
use glam::{Vec2, Vec3};
use std::f32::consts::FRAC_1_PI;
use std::sync::atomic::Ordering;

/// Indirect photons whose directions guide photon-guided gathering (pbrt-v2's choice).
const GUIDE_PHOTONS: usize = 50;

/// Secondary gathers a chain of short gather rays may start (issue 12): with 1 the Cornell box's
/// corner at the short box's base came out 15% dark (the chain's end brings no light), with 3 it
/// is within 1%; with 5 no closer, and the 0.01 gap above the light 18% brighter than with 3.
const SECONDARY_GATHER_LEVELS: u32 = 3;

/// The generator `g` of a Korobov rank-1 lattice of `n` points `(j / n, {j g / n})`: the integer
/// nearest to `n / phi` that is coprime with `n` (a Fibonacci lattice when `n` is a Fibonacci
/// number).
fn lattice_generator(n: u32) -> u32 {
    if n <= 2 {
        return 1;
    }
    let gcd = |mut a: u32, mut b: u32| {
        while b != 0 {
            (a, b) = (b, a % b);
        }
        a
    };
    let g0 = (f64::from(n) * 0.618_033_988_749_895).round() as u32;
    (0..n)
        .flat_map(|d| [g0 + d, g0.saturating_sub(d)])
        .find(|&g| g > 0 && g < n && gcd(g, n) == 1)
        .unwrap_or(1)
}

/// Point `j` of the lattice, shifted by `offset` modulo 1.
#[inline]
fn lattice_point(j: u32, n: u32, generator: u32, offset: Vec2) -> Vec2 {
    let x = (j as f32 + 0.5) / n as f32 + offset.x;
    let y = ((u64::from(j) * u64::from(generator) % u64::from(n)) as f32 + 0.5) / n as f32 + offset.y;
    Vec2::new(x.fract(), y.fract()).min(Vec2::splat(1.0 - f32::EPSILON / 2.0))
}

/// The photon maps read where a camera path meets a non-specular surface.
#[derive(Clone, Copy)]
enum VisibleMap {
    /// Caustic photons (always read directly).
    Caustic,
    /// Indirect photons, read directly when there is no final gathering.
    Indirect,
}

/// Radiance photons a final-gather ray's lookup may meet within its shrinking radius. One
/// in an open surface meets a handful; one on a surface that holds few of the photons around
/// it (the far side of a thin wall under a large `maxdist`) would read every photon within
/// `maxdist`, and stops here with the nearest of its own surface met so far, or none (dark
/// rather than light from the other side).
const RADIANCE_SEARCH_BUDGET: usize = 512;

/// Per-camera-ray scratch space and counts.
struct Scratch {
    nearest: estimate::Nearest,
    guide_heap: KnnHeap,
    guide_dirs: Vec<Vec3>,
    gather_rays: u64,
    lookups: u64,
    /// Radiance-photon lookups cut at their budget (density estimates count theirs in
    /// `nearest.capped`).
    capped_radiance: u64,
    culled: [u64; 3],
    /// While an irradiance-cache record gathers: the sum of the inverse lengths of its gather
    /// rays' first segments and their count (misses count with length infinity).
    hit_distances: Option<(f32, u32)>,
    /// Camera samples whose indirect light the irradiance cache gave, and those it could not.
    cache_interpolated: u64,
    cache_gathered: u64,
}

impl Scratch {
    fn new(n_used: u32) -> Scratch {
        Scratch {
            nearest: estimate::Nearest::new(n_used as usize),
            guide_heap: KnnHeap::new(GUIDE_PHOTONS),
            guide_dirs: Vec::new(),
            gather_rays: 0,
            lookups: 0,
            capped_radiance: 0,
            culled: [0; 3],
            hit_distances: None,
            cache_interpolated: 0,
            cache_gathered: 0,
        }
    }
}

/// The normal of `si` on the side its ray arrived from.
#[inline]
pub(super) fn facing_normal(si: &SurfaceInteraction) -> Vec3 {
    if si.ng.dot(si.wo) < 0.0 { -si.ng } else { si.ng }
}

/// Hemispherical reflectance of the non-specular lobes, as a radiance photon's irradiance is
/// turned into exitant radiance (`rho / pi * E`): exact for matte surfaces, the lobe's scale for
/// glossy ones (pbrt-v2 does the same with a sampled albedo).
pub(super) fn non_specular_albedo(bsdf: &Bsdf) -> Vec3 {
    bsdf.lobes()
        .iter()
        .map(|l| match l {
            Lobe::Lambert { r } => *r,
            Lobe::Blinn { ks, .. } => *ks,
            _ => Vec3::ZERO,
        })
        .sum()
}

impl PhotonMapper {
    /// Radiance along a camera ray.
    pub fn radiance(
        &self,
        world: &World,
        ray: Ray,
        sampler: &mut Sampler,
        counters: &mut RayCounters,
    ) -> Radiance {
        let mut scratch = Scratch::new(self.settings.n_used);
        let r = self.li_depth(world, ray, 0, sampler, counters, &mut scratch);
        self.add_counts(&scratch);
        r
    }

    /// Adds a scratch's counts to the shared counters.
    fn add_counts(&self, scratch: &Scratch) {
        if let Some(cache) = &self.irradiance_cache {
            cache.count(scratch.cache_interpolated, scratch.cache_gathered);
        }
        let c = &self.counters;
        if scratch.gather_rays > 0 {
            c.gather_rays.fetch_add(scratch.gather_rays, Ordering::Relaxed);
        }
        if scratch.lookups > 0 {
            c.lookups.fetch_add(scratch.lookups, Ordering::Relaxed);
        }
        if scratch.nearest.capped > 0 {
            c.capped_estimates.fetch_add(scratch.nearest.capped, Ordering::Relaxed);
        }
        if scratch.capped_radiance > 0 {
            c.capped_radiance_lookups.fetch_add(scratch.capped_radiance, Ordering::Relaxed);
        }
        for (a, n) in c.culled.iter().zip(scratch.culled) {
            if n > 0 {
                a.fetch_add(n, Ordering::Relaxed);
            }
        }
    }

    /// One irradiance-cache record's gather at the camera-visible surface `si` (a surface
    /// whose non-specular lobes are all Lambertian): the final gather of today's path with
    /// `n` rays through a white Lambertian BSDF in the surface's frame, so that the result is
    /// the indirect irradiance over pi (a matte surface reflects its albedo times it). Also the
    /// harmonic mean length of the gather rays' first segments (Ward's record radius), infinite
    /// when every ray left the scene.
    pub(super) fn record_gather(
        &self,
        world: &World,
        si: &SurfaceInteraction,
        bsdf: &Bsdf,
        n: u32,
        sampler: &mut Sampler,
        counters: &mut RayCounters,
    ) -> (Vec3, f32) {
        let mut white = Bsdf::new(bsdf.frame, bsdf.ng);
        white.add(Lobe::Lambert { r: Vec3::ONE });
        let mut scratch = Scratch::new(self.settings.n_used);
        scratch.hit_distances = Some((0.0, 0));
        let e = self.gather(world, si, &white, n, sampler, counters, &mut scratch);
        self.add_counts(&scratch);
        let (inverse_sum, count) = scratch.hit_distances.unwrap_or((0.0, 0));
        let harmonic = if inverse_sum > 0.0 { count as f32 / inverse_sum } else { f32::INFINITY };
        (e, harmonic)
    }

    fn li_depth(
        &self,
        world: &World,
        ray: Ray,
        depth: u32,
        sampler: &mut Sampler,
        counters: &mut RayCounters,
        scratch: &mut Scratch,
    ) -> Radiance {
        let mut rays = 0;
        let found = find_surface_or_escape(world, ray, sampler, &mut rays);
        if depth == 0 {
            counters.camera += rays;
        } else {
            counters.bounce += rays;
        }
        let (si, weight) = match found {
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
                l += self.direct(world, &si, &bsdf, sampler, counters, scratch);
                crate::light_layers::end_primary();
                let n = facing_normal(&si);
                if let Some(caustic) = self.visible_photons(VisibleMap::Caustic, &si, n, &bsdf, scratch) {
                    l += caustic;
                }
                if self.gather {
                    l += match self.cached_indirect(&si, &bsdf, scratch) {
                        Some(cached) => cached,
                        None => {
                            let n = self.settings.final_gather_samples;
                            self.gather(world, &si, &bsdf, n, sampler, counters, scratch)
                        }
                    };
                } else if let Some(indirect) =
                    self.visible_photons(VisibleMap::Indirect, &si, n, &bsdf, scratch)
                {
                    l += indirect;
                }
            }
            if depth < self.settings.max_depth {
                for (k, (wi, w, flags)) in directions.into_iter().enumerate() {
                    if w == Vec3::ZERO {
                        continue;
                    }
                    let link = crate::transmission_layers::branch(chain == Some(k), si.p, wi, w, weight);
                    let r = self.li_depth(world, si.spawn_ray(wi), depth + 1, sampler, counters, scratch);
                    crate::transmission_layers::after_branch(link, r.rgb);
                    l += w * r.rgb;
                    if depth == 0 && flags.intersects(LobeFlags::REFLECTION) {
                        crate::light_layers::primary_reflection(w * r.rgb);
                    }
                }
            }
        }
        Radiance { rgb: sanitize(l * weight), alpha: 1.0 }
    }

    /// Indirect light at a matte surface from the irradiance cache: its albedo times the
    /// interpolated irradiance over pi; `None` without a cache, at other surfaces and where no
    /// record covers the point.
    fn cached_indirect(&self, si: &SurfaceInteraction, bsdf: &Bsdf, scratch: &mut Scratch) -> Option<Vec3> {
        let cache = self.irradiance_cache.as_ref()?;
        if !super::irradiance_cache::cacheable(bsdf) {
            return None;
        }
        match cache.interpolate(si.p, facing_normal(si)) {
            Some(e) => {
                scratch.cache_interpolated += 1;
                Some(bsdf.diffuse_reflectance() * e)
            }
            None => {
                scratch.cache_gathered += 1;
                None
            }
        }
    }

    /// Direct light from every light of the surface's set that can reach it: light sampling
    /// alone for matte surfaces, combined with BSDF sampling (MIS) where a glossy lobe is.
    fn direct(
        &self,
        world: &World,
        si: &SurfaceInteraction,
        bsdf: &Bsdf,
        sampler: &mut Sampler,
        counters: &mut RayCounters,
        scratch: &mut Scratch,
    ) -> Vec3 {
        let set = world.light_set(si.attributes);
        let glossy = bsdf.lobes().iter().any(|l| l.flags().intersects(LobeFlags::GLOSSY));
        let strategy = if glossy { DirectStrategy::Both } else { DirectStrategy::LightOnly };
        let reflect_only = bsdf
            .lobes()
            .iter()
            .filter(|l| !l.flags().is_specular())
            .all(|l| !l.flags().intersects(LobeFlags::TRANSMISSION));
        let mut l = Vec3::ZERO;
        for &light in &set.lights {
            if self.cull_lights
                && let Some(bounds) = self.light_bounds.get(light as usize)
                && let Some(reason) = bounds.cull(si.p, si.p_error, bsdf.ng, reflect_only)
            {
                scratch.culled[reason as usize] += 1;
                continue;
            }
            l += direct_from_light(world, si, bsdf, light, 1.0, LobeFlags::ALL, sampler, counters, strategy);
        }
        l
    }

    /// Indirect light reflected at `si` by final gathering with `n` gather rays.
    #[allow(clippy::too_many_arguments)]
    fn gather(
        &self,
        world: &World,
        si: &SurfaceInteraction,
        bsdf: &Bsdf,
        n: u32,
        sampler: &mut Sampler,
        counters: &mut RayCounters,
        scratch: &mut Scratch,
    ) -> Vec3 {
        let n = n.max(1);
        if self.settings.gather_sampling == GatherSampling::Photons && n >= 2 {
            self.collect_guide_directions(si, scratch);
            if !scratch.guide_dirs.is_empty() {
                return self.gather_guided(world, si, bsdf, n, sampler, counters, scratch);
            }
        }
        // The directions of one gather are a rank-1 lattice (well spread for any count),
        // rotated by one stratified pair of the pixel's sampler (Cranley-Patterson).
        let offset = sampler.uniform2();
        let generator = lattice_generator(n);
        let mut sum = Vec3::ZERO;
        for j in 0..n {
            let u = lattice_point(j, n, generator, offset);
            let u_lobe = sampler.rng().uniform();
            let Some(bs) = bsdf.sample(si.wo, u_lobe, u, TransportMode::Radiance, LobeFlags::NON_SPECULAR)
            else {
                continue;
            };
            let f = bs.f * (bs.wi.dot(bsdf.frame.z).abs() / bs.pdf);
            if f == Vec3::ZERO || !f.is_finite() {
                continue;
            }
            sum += f * self.gathered(world, si.spawn_ray(bs.wi), sampler, counters, scratch);
        }
        sum / n as f32
    }

    /// Directions the nearest indirect photons arrived from, widening the search until enough
    /// are found (at most a few doublings).
    fn collect_guide_directions(&self, si: &SurfaceInteraction, scratch: &mut Scratch) {
        scratch.guide_dirs.clear();
        let Some(map) = &self.indirect else { return };
        let n = facing_normal(si);
        let mut r2 = self.max_d2;
        // The budget of a density estimate's search bounds each try (a surface with few
        // photons among many of others' keeps what the first try found).
        let budget = estimate::SEARCH_BUDGET_PER_K * scratch.guide_heap.capacity();
        for _ in 0..4 {
            let accept = |ph: &Photon| unpack_unit(ph.n).dot(n) > NORMAL_COSINE;
            let within_budget = map.knn_within_budget(si.p, r2, budget, &mut scratch.guide_heap, accept);
            if scratch.guide_heap.is_full() || !within_budget {
                break;
            }
            r2 *= 2.0;
        }
        scratch.lookups += 1;
        scratch
            .guide_dirs
            .extend(scratch.guide_heap.entries().iter().map(|&(_, i)| unpack_unit(map.get(i).wi)));
    }

    /// Half the gather rays from the BSDF, half in cones around photon directions (pbrt-v2's
    /// final gathering), each weighted by the power heuristic.
    #[allow(clippy::too_many_arguments)]
    fn gather_guided(
        &self,
        world: &World,
        si: &SurfaceInteraction,
        bsdf: &Bsdf,
        n: u32,
        sampler: &mut Sampler,
        counters: &mut RayCounters,
        scratch: &mut Scratch,
    ) -> Vec3 {
        let n_bsdf = n / 2;
        let n_photon = n - n_bsdf;
        let cos_gather = self.settings.gather_angle_degrees.to_radians().cos();
        let cone_pdf = uniform_cone_pdf(cos_gather);
        let dirs = std::mem::take(&mut scratch.guide_dirs);
        let photon_pdf = |wi: Vec3| -> f32 {
            let hits = dirs.iter().filter(|d| d.dot(wi) > 0.999 * cos_gather).count();
            cone_pdf * hits as f32 / dirs.len() as f32
        };
        let mut from_bsdf = Vec3::ZERO;
        for _ in 0..n_bsdf {
            let Some(bs) = bsdf.sample(
                si.wo,
                sampler.uniform(),
                sampler.uniform2(),
                TransportMode::Radiance,
                LobeFlags::NON_SPECULAR,
            ) else {
                continue;
            };
            let f = bs.f * bs.wi.dot(bsdf.frame.z).abs();
            if f == Vec3::ZERO || !(bs.pdf > 0.0) {
                continue;
            }
            let w = power_heuristic(n_bsdf as f32 * bs.pdf, n_photon as f32 * photon_pdf(bs.wi));
            from_bsdf +=
                f * self.gathered(world, si.spawn_ray(bs.wi), sampler, counters, scratch) * (w / bs.pdf);
        }
        let mut from_photons = Vec3::ZERO;
        for _ in 0..n_photon {
            let d = dirs[sampler.rng().below(dirs.len() as u32) as usize];
            let wi = Frame::from_z(d).from_local(sample_uniform_cone(sampler.uniform2(), cos_gather));
            let f = bsdf.f(si.wo, wi, LobeFlags::NON_SPECULAR) * wi.dot(bsdf.frame.z).abs();
            if f == Vec3::ZERO {
                continue;
            }
            let pdf = photon_pdf(wi);
            if !(pdf > 0.0) {
                continue;
            }
            let w = power_heuristic(
                n_photon as f32 * pdf,
                n_bsdf as f32 * bsdf.pdf(si.wo, wi, LobeFlags::NON_SPECULAR),
            );
            from_photons +=
                f * self.gathered(world, si.spawn_ray(wi), sampler, counters, scratch) * (w / pdf);
        }
        scratch.guide_dirs = dirs;
        let mut l = from_photons / n_photon as f32;
        if n_bsdf > 0 {
            l += from_bsdf / n_bsdf as f32;
        }
        l
    }

    /// Radiance arriving along a gather ray, without emission and direct light (sampled at the
    /// gather's origin) and without caustics there (the caustic map has them): the photon
    /// estimate at the first non-specular surface, following specular surfaces on the way.
    /// Outside progressive passes, a gather ray shorter than the photon search radius
    /// (`maxdist`) gathers once more at its hit instead of reading the photons there
    /// ([`Self::secondary_gather`]).
    fn gathered(
        &self,
        world: &World,
        ray: Ray,
        sampler: &mut Sampler,
        counters: &mut RayCounters,
        scratch: &mut Scratch,
    ) -> Vec3 {
        self.gathered_at_depth(world, ray, SECONDARY_GATHER_LEVELS, sampler, counters, scratch)
    }

    /// [`Self::gathered`], with `levels` the secondary gathers a short ray may still start; a
    /// short ray with none left brings no light.
    fn gathered_at_depth(
        &self,
        world: &World,
        mut ray: Ray,
        levels: u32,
        sampler: &mut Sampler,
        counters: &mut RayCounters,
        scratch: &mut Scratch,
    ) -> Vec3 {
        let mut beta = Vec3::ONE;
        let mut l = Vec3::ZERO;
        let mut first_segment = true;
        for _ in 0..=self.settings.max_depth {
            let mut rays = 0;
            let found = find_surface(world, ray, sampler, &mut rays);
            counters.bounce += rays;
            scratch.gather_rays += rays;
            if first_segment
                && levels == SECONDARY_GATHER_LEVELS
                && let Some((inverse_sum, count)) = &mut scratch.hit_distances
            {
                *count += 1;
                if let Some((si, _)) = &found {
                    let d = (si.p - ray.origin).length();
                    if d > 0.0 {
                        *inverse_sum += 1.0 / d;
                    }
                }
            }
            let Some((si, weight)) = found else { break };
            beta *= weight;
            let material = world.material(si.attributes);
            // Self-emitting shaders and ambient light are not in the photons.
            l += beta * surface_terms(world, &si, material);
            let bsdf = material.bsdf(si.wo, si.ng, si.ns, si.n_outward, si.dpdu, si.st, si.st_width);
            if bsdf.has_non_specular() {
                // A photon estimate is the light averaged over up to `maxdist` around the hit;
                // seen from a gather origin closer than that, the average spans a wide angle,
                // so a corner's fall-off (at the short box's base, lit only by other surfaces)
                // read as the brighter light around it. A short ray gathers once more instead;
                // in a gap thinner than `maxdist` the chain ends dark after a few levels rather
                // than reading light that leaks in from outside the gap. Progressive passes
                // (`fixed`) do not: their radius shrinks below the corner's scale, and secondary
                // gathers measured only noisier there (docs/photon-mapping.md).
                let short = first_segment
                    && self.fixed.is_none()
                    && (si.p - ray.origin).length_squared() < self.max_d2;
                if !short {
                    l += beta * self.exitant(&si, &bsdf, scratch);
                } else if levels > 0 {
                    l += beta
                        * self.secondary_gather(world, &si, &bsdf, levels - 1, sampler, counters, scratch);
                }
            }
            first_segment = false;
            if !bsdf.flags().is_specular() {
                break;
            }
            let Some(bs) = bsdf.sample(
                si.wo,
                sampler.uniform(),
                sampler.uniform2(),
                TransportMode::Radiance,
                LobeFlags::SPECULAR_ALL,
            ) else {
                break;
            };
            beta *= bs.f * (bs.wi.dot(bsdf.frame.z).abs() / bs.pdf);
            if beta == Vec3::ZERO || !beta.is_finite() {
                break;
            }
            ray = si.spawn_ray(bs.wi);
        }
        l
    }

    /// Radiance leaving a short gather ray's surface `si` toward its origin: direct light
    /// sampled there, the caustic map's estimate, and one gather ray (which, if short too,
    /// gathers again while `levels` lasts).
    #[allow(clippy::too_many_arguments)]
    fn secondary_gather(
        &self,
        world: &World,
        si: &SurfaceInteraction,
        bsdf: &Bsdf,
        levels: u32,
        sampler: &mut Sampler,
        counters: &mut RayCounters,
        scratch: &mut Scratch,
    ) -> Vec3 {
        let mut l = self.direct(world, si, bsdf, sampler, counters, scratch);
        if let Some(caustic) = self.visible_photons(VisibleMap::Caustic, si, facing_normal(si), bsdf, scratch)
        {
            l += caustic;
        }
        let u_lobe = sampler.uniform();
        let u = sampler.uniform2();
        if let Some(bs) = bsdf.sample(si.wo, u_lobe, u, TransportMode::Radiance, LobeFlags::NON_SPECULAR) {
            let f = bs.f * (bs.wi.dot(bsdf.frame.z).abs() / bs.pdf);
            if f != Vec3::ZERO && f.is_finite() {
                l += f * self.gathered_at_depth(
                    world,
                    si.spawn_ray(bs.wi),
                    levels,
                    sampler,
                    counters,
                    scratch,
                );
            }
        }
        l
    }

    /// The estimate of `which` map at a camera path's vertex `si` (normal `n`), or `None` when
    /// the render has no such map. A progressive pass keeps its photons in grids only (no
    /// kd-trees) and reads them within the pass's radius there; otherwise the kd-tree is read
    /// within `max_d2`.
    fn visible_photons(
        &self,
        which: VisibleMap,
        si: &SurfaceInteraction,
        n: Vec3,
        bsdf: &Bsdf,
        scratch: &mut Scratch,
    ) -> Option<Vec3> {
        let filter = self.settings.filter;
        if let Some(f) = &self.fixed {
            let grid = match which {
                VisibleMap::Caustic => f.caustic.as_ref()?,
                VisibleMap::Indirect => f.global.as_ref()?,
            };
            scratch.lookups += 1;
            let max_d2 = match which {
                VisibleMap::Caustic => f.radii.caustic_d2(si.p),
                VisibleMap::Indirect => f.radii.global_d2(si.p),
            };
            return Some(estimate::radiance_within(grid, &Query { p: si.p, n, max_d2 }, bsdf, si.wo, filter));
        }
        let map = match which {
            VisibleMap::Caustic => self.caustic.as_ref()?,
            VisibleMap::Indirect => self.indirect.as_ref()?,
        };
        scratch.lookups += 1;
        let q = Query { p: si.p, n, max_d2: self.max_d2 };
        Some(estimate::radiance(map, &q, bsdf, si.wo, filter, &mut scratch.nearest))
    }

    /// Radiance leaving a gather ray's surface toward its origin, from the photons.
    fn exitant(&self, si: &SurfaceInteraction, bsdf: &Bsdf, scratch: &mut Scratch) -> Vec3 {
        let n = facing_normal(si);
        scratch.lookups += 1;
        if let Some(f) = &self.fixed {
            // In progressive mode the grid holds every stored photon (the mode builds no
            // radiance photons).
            let Some(grid) = &f.global else { return Vec3::ZERO };
            let q = Query { p: si.p, n, max_d2: f.radii.global_d2(si.p) };
            return estimate::radiance_within(grid, &q, bsdf, si.wo, self.settings.filter);
        }
        if let Some(rp) = &self.radiance {
            let (found, within) = rp.nearest_within_budget(si.p, self.max_d2, RADIANCE_SEARCH_BUDGET, |r| {
                unpack_unit(r.n).dot(n) > NORMAL_COSINE
            });
            scratch.capped_radiance += u64::from(!within);
            return match found {
                Some(r) => non_specular_albedo(bsdf) * FRAC_1_PI * r.irradiance,
                None => Vec3::ZERO,
            };
        }
        let q = Query { p: si.p, n, max_d2: self.max_d2 };
        let mut l = Vec3::ZERO;
        for map in [&self.direct, &self.indirect, &self.caustic].into_iter().flatten() {
            l += estimate::radiance(map, &q, bsdf, si.wo, self.settings.filter, &mut scratch.nearest);
        }
        l
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    /// Every lattice has one point per row and per column of an `n x n` grid, and its points
    /// stay in the unit square whatever the shift.
    #[test]
    fn gather_lattice_is_stratified() {
        for n in [1u32, 2, 3, 4, 5, 8, 13, 16, 32, 100] {
            let g = lattice_generator(n);
            let mut rows = vec![0; n as usize];
            let mut cols = vec![0; n as usize];
            for j in 0..n {
                let p = lattice_point(j, n, g, Vec2::ZERO);
                cols[(p.x * n as f32) as usize] += 1;
                rows[(p.y * n as f32) as usize] += 1;
                let q = lattice_point(j, n, g, Vec2::new(0.999, 0.73));
                assert!(q.x >= 0.0 && q.x < 1.0 && q.y >= 0.0 && q.y < 1.0);
            }
            assert!(rows.iter().all(|&c| c == 1) && cols.iter().all(|&c| c == 1), "n {n} g {g}");
        }
    }
}
