//! Baking the sidecar's reflection probes (docs/sidecar.md) from the render's own integrator:
//! a coarse grid of probes at the cell centres of the scene's bounds, each an octahedral map of
//! the radiance the integrator returns through every texel (jittered rays, averaged) less the
//! area lights' emission seen directly (a viewer adds the lights' glossy reflection itself), the
//! distance to the first surface through each texel's centre (and whether that surface is a
//! mirror or glass, whose radiance there is an image that changes with the viewpoint), and the
//! map prefiltered into the roughness levels `sidecar::reflection_levels` defines.

use crate::integrators::{Integrator, RayCounters};
use crate::probe_bake::{emitter_seen, grid_layout};
use crate::sampler::PixelSampler;
use crate::world::{Ray, World};
use glam::Vec3;
use rayon::prelude::*;
use sidecar::{
    REFLECTION_LEVELS, REFLECTION_TEXELS, ReflectionProbes, octahedral_direction, reflection_levels,
};

/// Bounds on the bake's work: at most `max_probes * 1024 * rays_per_texel` integrator
/// estimates and `max_probes * 1024` distance rays.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub struct ReflectionLimits {
    /// Probes along the scene's longest axis (fewer along the others, in proportion).
    pub probes_along_longest: u32,
    /// Radiance rays per level-0 texel (each one the integrator's full estimate).
    pub rays_per_texel: u32,
    /// Most probes in all.
    pub max_probes: u32,
}

impl Default for ReflectionLimits {
    /// 6 probes along the longest axis (at most 216, under the viewer's 256), 1 ray per texel:
    /// about 1000 integrator estimates a probe. With 3 (until 2026-11-27) the room example had
    /// one layer of probes, 3 units above its floor and 4 apart, and a glossy sphere on the floor
    /// reflected its neighbours and the floor blurred and too dark; 5 (an odd count, a probe at
    /// the centre) did worse than 6 in the Cornell box (docs/sidecar.md, "Reflection probes").
    fn default() -> Self {
        ReflectionLimits { probes_along_longest: 6, rays_per_texel: 1, max_probes: 216 }
    }
}

/// One probe's row of texels as one task bakes it.
struct TexelRow {
    radiance: Vec<[f32; 3]>,
    distance: Vec<f32>,
    /// Whether each texel's first surface is a mirror or glass.
    specular: Vec<bool>,
    counters: RayCounters,
}

/// The reflection probes over `world`'s bounds (world space), or `None` for an empty or
/// unbounded scene. Deterministic for a seed, whatever the thread count: every ray has its own
/// sampler, keyed by probe, texel and ray.
pub fn bake_reflections(
    world: &World,
    integrator: &dyn Integrator,
    seed: u64,
    limits: ReflectionLimits,
) -> Option<(ReflectionProbes, RayCounters)> {
    let layout = grid_layout(world, limits.probes_along_longest, limits.max_probes.min(4096))?;
    let n = layout.counts.iter().map(|&c| c as usize).product::<usize>();
    let side = REFLECTION_TEXELS;
    let rays = limits.rays_per_texel.clamp(1, 1024);
    // One task per probe and texel row: even work for two threads or twenty.
    let rows: Vec<TexelRow> = (0..n * side)
        .into_par_iter()
        .map(|task| {
            let (probe, j) = (task / side, task % side);
            let p = layout.position(probe);
            let mut counters = RayCounters::default();
            let mut radiance = Vec::with_capacity(side);
            let mut distance = Vec::with_capacity(side);
            let mut specular = Vec::with_capacity(side);
            for i in 0..side {
                let texel = j * side + i;
                let mut sum = Vec3::ZERO;
                let pixel_sampler = PixelSampler::new(seed ^ 0x7ef1_ec75, probe as i64, texel as i64);
                for k in 0..rays {
                    let mut sampler = pixel_sampler.sample(k);
                    let jitter = sampler.uniform2();
                    let d = octahedral_direction([
                        (i as f32 + jitter.x) / side as f32,
                        (j as f32 + jitter.y) / side as f32,
                    ]);
                    let ray = Ray::new(p, Vec3::from_array(d));
                    let r = integrator.li(world, ray, &mut sampler, &mut counters);
                    if r.rgb.is_finite() {
                        sum += (r.rgb - emitter_seen(world, &ray, &mut counters)).max(Vec3::ZERO);
                    }
                }
                radiance.push((sum / rays as f32).to_array());
                let centre =
                    octahedral_direction([(i as f32 + 0.5) / side as f32, (j as f32 + 0.5) / side as f32]);
                counters.shadow += 1;
                let ray = Ray::new(p, Vec3::from_array(centre));
                let hit = world.intersect(&ray);
                distance.push(hit.map_or(layout.miss_distance, |h| h.t.min(layout.miss_distance)));
                // Mirror and glass: the materials whose light reaches a point only along
                // specular paths.
                specular.push(hit.is_some_and(|h| {
                    world.material(world.interaction(&ray, &h).attributes).blocks_shadows()
                }));
            }
            TexelRow { radiance, distance, specular, counters }
        })
        .collect();
    let mut counters = RayCounters::default();
    let mut base = Vec::with_capacity(n * side * side);
    let mut distance = Vec::with_capacity(n * side * side);
    let mut specular = Vec::with_capacity(n * side * side);
    for row in rows {
        counters.add(&row.counters);
        base.extend(row.radiance);
        distance.extend(row.distance);
        specular.extend(row.specular);
    }
    // None marked: the sidecar's form for a scene without mirrors or glass in the probes' view.
    if !specular.contains(&true) {
        specular.clear();
    }
    let levels: Vec<Vec<Vec<[f32; 3]>>> = base.par_chunks(side * side).map(reflection_levels).collect();
    let radiance = (0..REFLECTION_LEVELS)
        .map(|k| levels.iter().flat_map(|probe| probe[k].iter().copied()).collect())
        .collect();
    let probes = ReflectionProbes {
        depth_fingerprint: 0,
        origin: layout.origin_world,
        spacing: layout.spacing,
        counts: layout.counts,
        radiance,
        distance,
        specular,
    };
    Some((probes, counters))
}
