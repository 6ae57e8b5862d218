//! Baking the sidecar's irradiance probes (docs/sidecar.md) from the render's own integrator:
//! a grid of probes at the cell centres of the scene's bounds, each with the SH projection of
//! the radiance the integrator returns along a spherical Fibonacci set of rays (less what an
//! emitter sends straight to the probe: a viewer adds the lights' direct light itself), and the
//! distance to the first surface through each octahedral visibility texel.

use crate::integrators::{Integrator, RayCounters};
use crate::sampler::PixelSampler;
use crate::world::{Ray, World};
use glam::{DVec3, Vec3};
use rayon::prelude::*;
use sidecar::sh::{ShProjector, fibonacci_sphere};
use sidecar::{ProbeGrid, VISIBILITY_TEXELS, octahedral_texel_direction};

/// One probe's radiance SH, visibility texels and the rays it traced.
type BakedProbe = ([[f32; 3]; 9], Vec<[f32; 2]>, RayCounters);

/// The radiance an area light's emitter sends straight along `ray` (zero when the ray's first
/// hit is not an emitter): both kinds of probe leave it out, because a viewer lights and
/// reflects with the lights itself, from their emitter samples (exactly, where the probes would
/// blur a close, bright emitter with the probe's view of it). Delta lights never reach a probe.
pub(crate) fn emitter_seen(world: &World, ray: &Ray, counters: &mut RayCounters) -> Vec3 {
    counters.shadow += 1;
    let Some(hit) = world.intersect(ray) else { return Vec3::ZERO };
    let si = world.interaction(ray, &hit);
    match si.emitter {
        Some(e) => world.lights[e as usize].emitted(si.ng, si.wo),
        None => Vec3::ZERO,
    }
}

/// Bounds on the bake's work.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub struct ProbeLimits {
    /// Probes along the scene's longest axis (fewer along the others, in proportion).
    pub probes_along_longest: u32,
    /// Radiance rays per probe (each one the integrator's full estimate).
    pub radiance_rays: u32,
    /// Most probes in all.
    pub max_probes: u32,
}

impl Default for ProbeLimits {
    /// 16 probes along the longest axis, 64 radiance rays each, at most 4096 probes. With 8,
    /// the lowest layer of a room-sized scene sat half a 1.5-unit cell above its floor, so a
    /// live object resting there read probes from above its own height (docs/sidecar.md,
    /// "Probes"); 16 costs about a second more of a 256x256, 64-sample render.
    fn default() -> Self {
        ProbeLimits { probes_along_longest: 16, radiance_rays: 64, max_probes: 4096 }
    }
}

/// Where a grid of probes goes: at the centres of the cells of a grid over `world`'s bounds.
#[derive(Clone, Copy, Debug)]
pub(crate) struct GridLayout {
    pub counts: [u32; 3],
    pub spacing: [f32; 3],
    /// Probe (0, 0, 0) in render space (what rays start from) and in world space (what the
    /// sidecar stores).
    pub origin_render: [f32; 3],
    pub origin_world: [f32; 3],
    /// The distance recorded for a ray that leaves the scene: twice the bounds' diagonal.
    pub miss_distance: f32,
}

impl GridLayout {
    /// Render-space position of probe number `index` (x fastest, then y, then z).
    pub fn position(&self, index: usize) -> Vec3 {
        let (nx, ny) = (self.counts[0] as usize, self.counts[1] as usize);
        let cell = [index % nx, (index / nx) % ny, index / (nx * ny)];
        Vec3::from_array(std::array::from_fn(|a| self.origin_render[a] + cell[a] as f32 * self.spacing[a]))
    }
}

/// `along` cells (clamped to 1..=64) along the bounds' longest axis and proportionally fewer
/// along the others (at least 1), at most `max_probes` in all; `None` for an empty or
/// unbounded scene.
pub(crate) fn grid_layout(world: &World, along: u32, max_probes: u32) -> Option<GridLayout> {
    let (lo, hi) = world.bounds;
    let extent = hi - lo;
    if !lo.is_finite() || !hi.is_finite() || extent.max_element() <= 0.0 {
        return None;
    }
    let along = along.clamp(1, 64);
    let cell = extent.max_element() / along as f32;
    let mut counts = [0u32; 3];
    for a in 0..3 {
        counts[a] = ((extent[a] / cell).round() as u32).clamp(1, along);
    }
    while counts.iter().map(|&c| u64::from(c)).product::<u64>() > u64::from(max_probes.max(1)) {
        let largest = (0..3).max_by_key(|&a| counts[a]).unwrap_or(0);
        counts[largest] = (counts[largest] - 1).max(1);
    }
    // Probes at cell centres, so none sits on the bounding walls.
    let spacing: [f32; 3] = std::array::from_fn(|a| (extent[a] / counts[a] as f32).max(cell * 1e-3));
    let eye = world.render_from_world.inverse().transform_point3(DVec3::ZERO);
    let origin_render: [f32; 3] = std::array::from_fn(|a| lo[a] + spacing[a] * 0.5);
    let origin_world: [f32; 3] = std::array::from_fn(|a| (f64::from(origin_render[a]) + eye[a]) as f32);
    Some(GridLayout { counts, spacing, origin_render, origin_world, miss_distance: 2.0 * extent.length() })
}

/// The probe grid over `world`'s bounds (world space), or `None` for an empty or unbounded
/// scene. Deterministic for a seed (every probe has its own sampler streams).
pub fn bake_probes(
    world: &World,
    integrator: &dyn Integrator,
    seed: u64,
    limits: ProbeLimits,
) -> Option<(ProbeGrid, RayCounters)> {
    let layout = grid_layout(world, limits.probes_along_longest, limits.max_probes)?;
    let GridLayout { counts, spacing, origin_world, miss_distance, .. } = layout;
    let n = counts.iter().map(|&c| c as usize).product::<usize>();
    let texels = VISIBILITY_TEXELS * VISIBILITY_TEXELS;
    let results: Vec<BakedProbe> = (0..n)
        .into_par_iter()
        .map(|index| {
            let p = layout.position(index);
            let mut counters = RayCounters::default();
            let mut projector = ShProjector::default();
            // A different rotation of the direction set per probe avoids aliasing across the grid.
            let twist = index as f32 * 2.399_963;
            let pixel_sampler = PixelSampler::new(seed ^ 0x70b3_5eed, index as i64, -1);
            for (k, d) in
                fibonacci_sphere(limits.radiance_rays.max(1) as usize, twist).into_iter().enumerate()
            {
                let mut sampler = pixel_sampler.sample(k as u32);
                let r = integrator.li(world, Ray::new(p, Vec3::from_array(d)), &mut sampler, &mut counters);
                let rgb = if r.rgb.is_finite() {
                    (r.rgb - emitter_seen(world, &Ray::new(p, Vec3::from_array(d)), &mut counters))
                        .max(Vec3::ZERO)
                } else {
                    Vec3::ZERO
                };
                projector.add(d, rgb.to_array());
            }
            let visibility = (0..texels)
                .map(|t| {
                    let d = Vec3::from_array(octahedral_texel_direction(t));
                    counters.shadow += 1;
                    let distance =
                        world.intersect(&Ray::new(p, d)).map_or(miss_distance, |h| h.t.min(miss_distance));
                    [distance, distance * distance]
                })
                .collect();
            (projector.finish(), visibility, counters)
        })
        .collect();
    let mut counters = RayCounters::default();
    let mut radiance_sh = Vec::with_capacity(n);
    let mut visibility = Vec::with_capacity(n * texels);
    for (sh, vis, c) in results {
        counters.add(&c);
        radiance_sh.push(sh);
        visibility.extend(vis);
    }
    let grid = ProbeGrid {
        depth_fingerprint: 0,
        origin: origin_world,
        spacing,
        counts,
        radiance_sh,
        visibility,
        emitters_seen: false,
    };
    Some((grid, counters))
}
