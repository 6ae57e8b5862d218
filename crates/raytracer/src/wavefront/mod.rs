//! The path tracer over a batch of paths at once ("paths in lanes", docs/performance.md).
//!
//! A tile's camera samples are one batch (in chunks of [`BATCH`]); each bounce runs as
//! stages over the list of live paths, every stage over all of them before the next: closest
//! hits, emission and the BSDF, the light sample with its shadow ray, the BSDF sample with
//! Russian roulette. The state lives in arrays indexed by path. Each path keeps its own
//! [`Sampler`] and does the scalar integrator's operations in the same order, so every pixel
//! is bit for bit what [`crate::integrators::PathTracer`] renders (`tests/wavefront.rs`).
//! Where the CPU has x86-64-v3, a batch runs as a copy compiled for it, its stages and their
//! hot callees inlined ([`render_batch`]).
//!
//! Only some renders qualify ([`supports`]): the path integrator over a flat world whose
//! materials are all opaque `matte` and whose lights are points, spots, distant lights or
//! area triangles; no motion, no light or transmission layers, no probe bakes. Everything else
//! takes the scalar integrator.

mod lanes;

use crate::accel::X86_64V3;
use crate::bsdf::{Bsdf, BsdfSample, LobeFlags, TransportMode};
use crate::integrators::{
    IntegratorKind, Radiance, RayCounters, escaped_with_mis, light_context, surface_terms,
    visible_light_estimate,
};
use crate::lights::{EmitterShape, Light, LightLiSample};
use crate::materials::Surface;
use crate::sampler::Sampler;
use crate::sampling::power_heuristic;
use crate::world::{Ray, SurfaceInteraction, World};
use glam::{DVec3, Vec3};
use rib_parser::scene::AttributesId;

/// Paths traced together: a tile's samples are split into batches this large, which keeps a
/// batch's state (about 600 bytes a path) in the second-level cache.
pub const BATCH: usize = 1024;

/// The path integrator's settings, for a render the wavefront can run.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub struct PathSettings {
    pub max_depth: u32,
    pub rr_depth: u32,
}

/// The path integrator's settings when the wavefront can render `world` with `kind`, else why
/// not (the scalar integrator renders it). Sidecar layers and probe bakes are the caller's to
/// rule out: their hooks are per primary vertex on the scalar path.
pub fn supports(world: &World, kind: &IntegratorKind) -> Result<PathSettings, &'static str> {
    let IntegratorKind::Path { max_depth, rr_depth } = *kind else {
        return Err("not the path integrator");
    };
    if !world.flat_queries() {
        return Err("not a flat world");
    }
    if world.motion_blur || world.camera_motion.is_some() {
        return Err("motion");
    }
    if !world.environment_lights.is_empty() {
        return Err("an environment light");
    }
    let matte = |m: &crate::materials::Material| {
        matches!(m.surface, Surface::Matte { .. }) && m.opacity == Vec3::ONE && !m.holdout
    };
    if !world.materials.iter().all(matte) {
        return Err("a material other than opaque matte");
    }
    let simple_light = |l: &Light| match l {
        Light::Point { .. } | Light::Spot { .. } | Light::Distant { .. } | Light::Ambient { .. } => true,
        Light::Area { shape, .. } => matches!(shape, EmitterShape::Triangles { .. }),
        Light::Environment(_) => false,
    };
    if !world.lights.iter().all(simple_light) {
        return Err("a light other than points, spots, distant lights and area triangles");
    }
    Ok(PathSettings { max_depth, rr_depth })
}

/// A path's previous vertex, for the MIS weight of an emitter its BSDF sample hits.
type PreviousVertex = Option<(DVec3, f32, AttributesId)>;

/// The state of a batch's paths, one entry per path. The samplers are the caller's: moved
/// in, each (about 130 bytes) was copied with `memcpy` twice per camera sample.
struct Paths<'s> {
    ray: Vec<Ray>,
    sampler: &'s mut [Sampler],
    beta: Vec<Vec3>,
    l: Vec<Vec3>,
    alpha: Vec<f32>,
    specular_bounce: Vec<bool>,
    eta_scale: Vec<f32>,
    prev: Vec<PreviousVertex>,
    depth: Vec<u32>,
    /// The surface the path's ray found and its BSDF, during a bounce: stage 1 writes the
    /// surface of every path it keeps, stage 2 the BSDF of every path it keeps, so a live path's
    /// are always its own bounce's. Plain records, not `Option`s: a record made in place of an
    /// `Option` was built on the stack and copied in (two `memcpy`s per vertex).
    si: Vec<SurfaceInteraction>,
    bsdf: Vec<Bsdf>,
}

/// What [`Paths::si`] holds before a path's first hit (never read).
fn no_surface() -> SurfaceInteraction {
    SurfaceInteraction {
        p: Vec3::ZERO,
        p_error: Vec3::ZERO,
        p64: DVec3::ZERO,
        t: 0.0,
        ng: Vec3::Z,
        ns: Vec3::Z,
        n_outward: Vec3::Z,
        dpdu: Vec3::X,
        st: glam::Vec2::ZERO,
        st_width: 0.0,
        wo: Vec3::Z,
        front: true,
        attributes: AttributesId(0),
        emitter: None,
        time: 0.0,
    }
}

/// Renders a batch of camera rays, each with its sampler (the state after the camera's
/// dimensions; `rays` and `samplers` are as long as each other): the radiance and coverage of
/// each, as [`crate::integrators::PathTracer`] returns them. The batch runs as its x86-64-v3
/// copy where the world found that instruction set on this CPU (`World::x86_64_v3`).
pub fn render_batch(
    world: &World,
    settings: PathSettings,
    rays: &[Ray],
    samplers: &mut [Sampler],
    counters: &mut RayCounters,
) -> Vec<Radiance> {
    #[cfg(target_arch = "x86_64")]
    if let Some(v3) = world.x86_64_v3 {
        // SAFETY: the token exists only on a CPU with these features.
        return unsafe { render_batch_v3(v3, world, settings, rays, samplers, counters) };
    }
    render_batch_inlined(None, world, settings, rays, samplers, counters)
}

/// [`render_batch`] compiled for x86-64-v3: the four stages are inlined into it, so their
/// scalar arithmetic (the surface interaction, the BSDF, the light sample's moves, the MIS
/// weights) gets the VEX encodings' three operands instead of SSE2's register copies, and the
/// samplers take their Sobol pairs with SIMD ([`Sampler::uniform2_v3`]). The results are the
/// same bits: Rust never fuses a multiply and an add by itself.
#[cfg(target_arch = "x86_64")]
#[target_feature(enable = "avx2,fma,bmi1,bmi2,lzcnt,popcnt")]
fn render_batch_v3(
    v3: X86_64V3,
    world: &World,
    settings: PathSettings,
    rays: &[Ray],
    samplers: &mut [Sampler],
    counters: &mut RayCounters,
) -> Vec<Radiance> {
    render_batch_inlined(Some(v3), world, settings, rays, samplers, counters)
}

/// The body of [`render_batch`] and its x86-64-v3 copy. The stages, and the closures they
/// pass, are inlined into it: a closure is compiled with the features of the function it is
/// written in, and one left out of line would be a baseline call from the copy.
#[inline(always)]
fn render_batch_inlined(
    v3: Option<X86_64V3>,
    world: &World,
    settings: PathSettings,
    rays: &[Ray],
    samplers: &mut [Sampler],
    counters: &mut RayCounters,
) -> Vec<Radiance> {
    let n = rays.len();
    assert_eq!(samplers.len(), n, "one sampler per camera ray");
    let mut paths = Paths {
        ray: rays.to_vec(),
        sampler: samplers,
        beta: vec![Vec3::ONE; n],
        l: vec![Vec3::ZERO; n],
        alpha: vec![0.0; n],
        specular_bounce: vec![true; n],
        eta_scale: vec![1.0; n],
        prev: vec![None; n],
        depth: vec![0; n],
        si: vec![no_surface(); n],
        bsdf: vec![Bsdf::new(crate::math::Frame::from_z(Vec3::Z), Vec3::Z); n],
    };
    let mut live: Vec<u32> = (0..n as u32).collect();
    // Whether every light set's ambient light is finite: a surface without emission, ambient
    // or environment terms then adds `+0` ([`crate::integrators::no_surface_terms`]).
    let ambient_finite = world.light_sets.iter().all(|set| set.ambient.is_finite());
    while !live.is_empty() {
        closest_hits(v3, world, &mut paths, &mut live, counters);
        emission_and_bsdf(world, settings, ambient_finite, &mut paths, &mut live);
        light_samples(v3, world, &mut paths, &live, counters);
        bsdf_samples(v3, settings, &mut paths, &mut live);
    }
    let mut radiance = Vec::with_capacity(n);
    for i in 0..n {
        radiance.push(Radiance { rgb: crate::integrators::sanitize(paths.l[i]), alpha: paths.alpha[i] });
    }
    radiance
}

/// Keeps the live paths for which `keep` holds, in their order, each asked once (what
/// `Vec::retain` does; its loop is std's, compiled without the stages' features, and would
/// call `keep` out of line).
#[inline(always)]
fn retain_live(live: &mut Vec<u32>, mut keep: impl FnMut(usize) -> bool) {
    // A slice, whose length stays in a register: the stages' stores kept the compiler from
    // knowing that the vector's length did not change, so each read and write was checked.
    let paths = live.as_mut_slice();
    let mut kept = 0;
    for k in 0..paths.len() {
        let i = paths[k];
        if keep(i as usize) {
            // `kept <= k`: the slot has been read.
            paths[kept.min(k)] = i;
            kept += 1;
        }
    }
    live.truncate(kept);
}

/// Stage 1: each live path's closest hit and its surface interaction; paths that leave the
/// scene take what the environment gives them and end.
#[inline(always)]
fn closest_hits(
    v3: Option<X86_64V3>,
    world: &World,
    paths: &mut Paths<'_>,
    live: &mut Vec<u32>,
    counters: &mut RayCounters,
) {
    retain_live(
        live,
        #[inline(always)]
        |i| {
            let depth = paths.depth[i];
            if depth == 0 {
                counters.camera += 1;
            } else {
                counters.bounce += 1;
            }
            let ray = paths.ray[i];
            match world.intersect(&ray) {
                Some(hit) => {
                    world.write_interaction(v3, &ray, &hit, &mut paths.si[i]);
                    // An opaque surface stops the ray with weight one (the scalar path's product).
                    paths.beta[i] *= Vec3::ONE;
                    true
                }
                None => {
                    let through = paths.beta[i] * Vec3::ONE;
                    paths.l[i] += escaped_with_mis(
                        world,
                        ray.direction,
                        through,
                        depth,
                        paths.specular_bounce[i],
                        paths.prev[i],
                    );
                    false
                }
            }
        },
    );
}

/// Stage 2: coverage, the emission of a light hit (weighted for MIS against the previous
/// vertex's light sample), the surface's own terms, and its BSDF; paths whose BSDF is black or
/// whose depth is at the limit end.
#[inline(always)]
fn emission_and_bsdf(
    world: &World,
    settings: PathSettings,
    ambient_finite: bool,
    paths: &mut Paths<'_>,
    live: &mut Vec<u32>,
) {
    retain_live(
        live,
        #[inline(always)]
        |i| {
            let si = &paths.si[i];
            let depth = paths.depth[i];
            let beta = paths.beta[i];
            let material = world.material(si.attributes);
            if depth == 0 {
                paths.alpha[i] = 1.0;
            }
            let l = &mut paths.l[i];
            if let Some(e) = si.emitter {
                let light = &world.lights[e as usize];
                let le = light.emitted(si.ng, si.wo);
                if le != Vec3::ZERO {
                    match paths.prev[i] {
                        None => *l += beta * le,
                        Some(_) if paths.specular_bounce[i] => *l += beta * le,
                        Some((p_prev, pdf_bsdf, attrs)) => {
                            let pick = world.light_set(attrs).pmf(e);
                            if pick > 0.0 {
                                let light_pdf = pick * light.pdf_li(p_prev, -si.wo, si.p64, si.ng);
                                *l += beta * le * power_heuristic(pdf_bsdf, light_pdf);
                            }
                        }
                    }
                }
            }
            // Without the light set's lookup where the terms are known to be `+0`.
            let terms = if ambient_finite && !material.has_surface_terms() {
                Vec3::ZERO
            } else {
                surface_terms(world, si, material)
            };
            *l += beta * terms;
            let bsdf = &mut paths.bsdf[i];
            material.write_bsdf(bsdf, si.wo, si.ng, si.ns, si.n_outward, si.dpdu, si.st, si.st_width);
            !(bsdf.is_black() || depth >= settings.max_depth)
        },
    );
}

/// Stage 3: next-event estimation, one light chosen by power with its shadow ray, weighted
/// for MIS against the BSDF sample that follows ([`crate::integrators::sample_one_light`]
/// path by path). One pass over the live paths: a path whose BSDF is one Lambert lobe waits,
/// where the CPU has AVX2, for seven others, and the eight take the BSDF's value and density
/// toward their light samples in lanes and then trace their shadow rays; any other path is
/// estimated at once. Each path does the scalar integrator's operations in its order, so the
/// order among paths changes nothing.
#[inline(always)]
fn light_samples(
    v3: Option<X86_64V3>,
    world: &World,
    paths: &mut Paths<'_>,
    live: &[u32],
    counters: &mut RayCounters,
) {
    // The paths waiting for their group's lanes: each path and its light sample, with the
    // probability of its light's choice and whether MIS weights it.
    let mut group = lanes::LambertEvalGroup::default();
    let no_sample =
        LightLiSample { li: Vec3::ZERO, wi: Vec3::ZERO, pdf: 0.0, is_delta: false, p_light: None };
    let mut waiting = [(0usize, Picked { pick: 0.0, mis: false, ls: no_sample }); lanes::LANES];
    let mut filled = 0;
    for &i in live {
        let i = i as usize;
        let (si, bsdf) = (&paths.si[i], &paths.bsdf[i]);
        if !bsdf.has_non_specular() {
            continue;
        }
        let sampler = &mut paths.sampler[i];
        let Some((light, pick)) = world.light_set(si.attributes).pick(sampler.uniform_v3(v3)) else {
            // Zero too when no light was sampled: the scalar integrator's sum, bit for bit.
            paths.l[i] += paths.beta[i] * Vec3::ZERO;
            continue;
        };
        let light = &world.lights[light as usize];
        let Some(ls) = light.sample_li_inlined(v3, &light_context(si), sampler.uniform2_v3(v3)) else {
            paths.l[i] += paths.beta[i] * Vec3::ZERO;
            continue;
        };
        let picked = Picked { pick, mis: !light.is_delta(), ls };
        match (v3, lanes::single_lambert(bsdf)) {
            (Some(v3), Some(r)) => {
                group.set(filled, si.wo, ls.wi, bsdf, r);
                waiting[filled] = (i, picked);
                filled += 1;
                if filled == lanes::LANES {
                    let out = lanes::lambert_f_pdf(v3, &group);
                    for (lane, (i, picked)) in waiting.iter().enumerate() {
                        estimate_direct(Some(v3), world, paths, *i, picked, out.get(lane), counters);
                    }
                    filled = 0;
                }
            }
            _ => {
                // `f |cos|` and the BSDF's density toward the light sample.
                let (f, pdf) = if picked.mis && !ls.is_delta {
                    bsdf.f_and_pdf(si.wo, ls.wi, LobeFlags::ALL)
                } else {
                    (bsdf.f(si.wo, ls.wi, LobeFlags::ALL), 0.0)
                };
                let value = (f * ls.wi.dot(bsdf.frame.z).abs(), pdf);
                estimate_direct(v3, world, paths, i, &picked, value, counters);
            }
        }
    }
    if let (Some(v3), true) = (v3, filled > 0) {
        let out = lanes::lambert_f_pdf(v3, &group);
        for (lane, (i, picked)) in waiting[..filled].iter().enumerate() {
            estimate_direct(Some(v3), world, paths, *i, picked, out.get(lane), counters);
        }
    }
}

/// A light sample with the probability of its light's choice, and whether MIS weights it.
#[derive(Clone, Copy)]
struct Picked {
    pick: f32,
    mis: bool,
    ls: LightLiSample,
}

/// Path `i`'s direct light from its light sample, given the BSDF's `f |cos|` and density
/// toward it (`value`): its shadow ray and `direct_from_light`'s arithmetic, added to `L`.
#[inline(always)]
fn estimate_direct(
    v3: Option<X86_64V3>,
    world: &World,
    paths: &mut Paths<'_>,
    i: usize,
    picked: &Picked,
    value: (Vec3, f32),
    counters: &mut RayCounters,
) {
    let mut total = Vec3::ZERO;
    if value.0 != Vec3::ZERO && picked.ls.li != Vec3::ZERO {
        total += visible_light_estimate(
            v3,
            world,
            &paths.si[i],
            &picked.ls,
            value,
            picked.pick,
            picked.mis,
            counters,
        );
    }
    paths.l[i] += paths.beta[i] * total;
}

/// Stage 4: the BSDF sample that continues each path, its throughput, the next ray, and
/// Russian roulette, in one pass over the live paths that keeps those that go on. A path
/// whose BSDF is one Lambert lobe waits, where the CPU has AVX2, for seven others, and the
/// eight directions are sampled in lanes; any other path is sampled at once. Each path draws
/// its numbers in the scalar integrator's order.
#[inline(always)]
fn bsdf_samples(v3: Option<X86_64V3>, settings: PathSettings, paths: &mut Paths<'_>, live: &mut Vec<u32>) {
    let mut group = lanes::LambertGroup::default();
    let mut members = [0u32; lanes::LANES];
    let mut filled = 0;
    // The paths kept so far are written over the front of `live`, never past the one read.
    let mut next = 0;
    for k in 0..live.len() {
        let i = live[k];
        let (si, bsdf) = (&paths.si[i as usize], &paths.bsdf[i as usize]);
        let sampler = &mut paths.sampler[i as usize];
        let u_lobe = sampler.uniform_v3(v3);
        let u = sampler.uniform2_v3(v3);
        match (v3, lanes::single_lambert(bsdf)) {
            (Some(v3), Some(r)) => {
                group.set(filled, si.wo, bsdf, r, u);
                members[filled] = i;
                filled += 1;
                if filled == lanes::LANES {
                    let out = lanes::lambert_samples(v3, &group);
                    for (lane, &m) in members.iter().enumerate() {
                        if continue_path(Some(v3), settings, paths, m as usize, out.get(lane)) {
                            live[next] = m;
                            next += 1;
                        }
                    }
                    filled = 0;
                }
            }
            _ => {
                let bs = bsdf.sample(si.wo, u_lobe, u, TransportMode::Radiance, LobeFlags::ALL);
                if continue_path(v3, settings, paths, i as usize, bs) {
                    live[next] = i;
                    next += 1;
                }
            }
        }
    }
    if let (Some(v3), true) = (v3, filled > 0) {
        let out = lanes::lambert_samples(v3, &group);
        for (lane, &m) in members[..filled].iter().enumerate() {
            if continue_path(Some(v3), settings, paths, m as usize, out.get(lane)) {
                live[next] = m;
                next += 1;
            }
        }
    }
    live.truncate(next);
}

/// A path's throughput, next ray and Russian roulette after its BSDF sample `bs`: false when
/// the path ends.
#[inline(always)]
fn continue_path(
    v3: Option<X86_64V3>,
    settings: PathSettings,
    paths: &mut Paths<'_>,
    i: usize,
    bs: Option<BsdfSample>,
) -> bool {
    let Some(bs) = bs else { return false };
    let (si, bsdf) = (&paths.si[i], &paths.bsdf[i]);
    let cos = bs.wi.dot(bsdf.frame.z).abs();
    let beta = &mut paths.beta[i];
    *beta *= bs.f * (cos / bs.pdf);
    if !beta.is_finite() || *beta == Vec3::ZERO {
        return false;
    }
    paths.specular_bounce[i] = bs.is_specular();
    if bs.flags.intersects(LobeFlags::TRANSMISSION) {
        paths.eta_scale[i] *= bs.eta * bs.eta;
    }
    paths.prev[i] = Some((si.p64, bs.pdf, si.attributes));
    paths.ray[i] = si.spawn_ray_inlined(v3, bs.wi);
    paths.depth[i] += 1;
    if paths.depth[i] > settings.rr_depth {
        let rr_beta = (*beta * paths.eta_scale[i]).max_element();
        if rr_beta < 1.0 {
            let q = (1.0 - rr_beta).max(0.0);
            if paths.sampler[i].uniform_v3(v3) < q {
                return false;
            }
            *beta /= 1.0 - q;
        }
    }
    true
}

#[cfg(test)]
mod tests {
    use super::{render_batch, supports};
    use crate::diagnostics::Diagnostics;
    use crate::integrators::{IntegratorKind, RayCounters};
    use crate::sampler::PixelSampler;
    use crate::world::{PixelFootprint, Ray, World};
    use glam::{DVec3, Vec3};

    /// The stand-in for the surface terms of a material without them under finite ambient
    /// light, `+0`, is [`crate::integrators::no_surface_terms`]'s sum bit for bit: ambient
    /// lights of every sign and scale, zeros of both signs, subnormals and `±f32::MAX`. Under
    /// an infinite or NaN one the sum is NaN, and the batch takes it.
    #[test]
    fn surface_terms_are_zero_under_a_finite_ambient_light() {
        use crate::integrators::no_surface_terms;
        let mut rng = crate::sampling::Rng::new(5, 13);
        let special = [0.0, -0.0, f32::MIN_POSITIVE, -1e-45, 1e-45, f32::MAX, f32::MIN, 1.0, -3.5];
        for k in 0..30_000 {
            let mut c = || {
                if k % 3 == 0 {
                    special[(rng.uniform() * special.len() as f32) as usize % special.len()]
                } else {
                    (rng.uniform() - 0.5) * 10f32.powi((rng.uniform() * 76.0) as i32 - 38)
                }
            };
            let ambient = Vec3::new(c(), c(), c());
            assert!(ambient.is_finite());
            assert_eq!(no_surface_terms(ambient).to_array().map(f32::to_bits), [0; 3], "{ambient}");
        }
        for odd in [f32::INFINITY, f32::NEG_INFINITY, f32::NAN] {
            assert!(no_surface_terms(Vec3::new(0.5, odd, 0.0)).y.is_nan());
        }
    }

    /// The batch's x86-64-v3 copy (its stages inlined, the Lambert lanes on) gives the baseline
    /// copy's radiance, coverage, ray counts and sampler states bit for bit, in a box of matte
    /// walls lit by an area quad and a point light, where some camera rays leave the box.
    #[test]
    fn x86_64_v3_batch_matches_the_baseline() {
        if crate::accel::X86_64V3::detect().is_none() {
            eprintln!("skipped: this CPU lacks x86-64-v3");
            return;
        }
        let rib = "WorldBegin\nSurface \"matte\"\n\
                   LightSource \"pointlight\" 1 \"from\" [0.4 0.7 0.3] \"intensity\" [0.3]\n\
                   AttributeBegin\nAreaLightSource \"arealight\" 2 \"intensity\" [6]\n\
                   Polygon \"P\" [-0.3 0.99 0.2 0.3 0.99 0.2 0.3 0.99 0.7 -0.3 0.99 0.7]\nAttributeEnd\n\
                   AttributeBegin\nColor [0.7 0.7 0.7]\nSurface \"matte\"\n\
                   Polygon \"P\" [-1 -1 -1 1 -1 -1 1 -1 1 -1 -1 1]\n\
                   Polygon \"P\" [-1 1 -1 1 1 -1 1 1 1 -1 1 1]\n\
                   Polygon \"P\" [-1 -1 1 1 -1 1 1 1 1 -1 1 1]\nAttributeEnd\n\
                   AttributeBegin\nColor [0.7 0.2 0.2]\nSurface \"matte\"\n\
                   Polygon \"P\" [-1 -1 -1 -1 1 -1 -1 1 1 -1 -1 1]\nAttributeEnd\n\
                   AttributeBegin\nColor [0.2 0.6 0.3]\nSurface \"matte\" \"Kd\" [0.8]\n\
                   Polygon \"P\" [1 -1 -1 1 1 -1 1 1 1 1 -1 1]\nAttributeEnd\nWorldEnd\n";
        let scene = rib_parser::load_bytes("batch.rib", rib.as_bytes().to_vec(), &Default::default())
            .unwrap_or_else(|e| panic!("{}", e.render()))
            .scene;
        // The eye outside the open front of the box, so the rays toward the corners escape.
        let eye = DVec3::new(0.1, 0.05, -1.6);
        let mut world = World::build(&scene, eye, PixelFootprint::Unknown, &mut Diagnostics::default())
            .expect("the world builds");
        let settings = supports(&world, &IntegratorKind::Path { max_depth: 6, rr_depth: 3 })
            .expect("the wavefront renders a box of matte polygons");
        // Camera rays from the eye (render space's origin) over a 24x24 grid, 3 samples each,
        // each with the sampler the tile loop would give it after its pixel jitter.
        let (mut rays, mut samplers) = (Vec::new(), Vec::new());
        for y in 0..24 {
            for x in 0..24 {
                let pixel = PixelSampler::new(11, x, y);
                for s in 0..3 {
                    let mut sampler = pixel.sample(s);
                    let jitter = sampler.uniform2();
                    let ndc = (glam::Vec2::new(x as f32, y as f32) + jitter) / 12.0 - 1.0;
                    rays.push(Ray::new(Vec3::ZERO, Vec3::new(ndc.x * 2.0, -ndc.y * 2.0, 1.0)));
                    samplers.push(sampler);
                }
            }
        }
        let results = [true, false].map(|v3| {
            world.x86_64_v3 = if v3 { crate::accel::X86_64V3::detect() } else { None };
            let mut samplers = samplers.clone();
            let mut counters = RayCounters::default();
            let radiance = render_batch(&world, settings, &rays, &mut samplers, &mut counters);
            let bits: Vec<_> =
                radiance.iter().map(|r| (r.rgb.to_array().map(f32::to_bits), r.alpha.to_bits())).collect();
            (bits, counters, format!("{samplers:?}"))
        });
        assert!(results[0].0 == results[1].0, "the radiance differs");
        assert_eq!(results[0].1, results[1].1, "the ray counts differ");
        assert!(results[0].2 == results[1].2, "the samplers' states differ");
        let lit = results[0].0.iter().filter(|(rgb, _)| rgb.iter().any(|&c| f32::from_bits(c) > 0.0)).count();
        let escaped = results[0].0.iter().filter(|&&(_, alpha)| alpha == 0).count();
        let counters = results[0].1;
        assert!(
            lit > 800 && escaped > 100 && counters.bounce > counters.camera,
            "{lit} lit, {escaped} escaped, {counters:?}"
        );
    }
}
