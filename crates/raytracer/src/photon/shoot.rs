//! Photon tracing: paths leave the lights in proportion to their power and deposit photons on
//! every non-specular surface they reach.
//!
//! Each path is classified by what it did before the hit (Jensen's notation):
//! - `L D`: a *direct* photon (kept only when final gathering needs it for radiance photons);
//! - `L S+ D`: a *caustic* photon (only specular bounces so far);
//! - `L (S|D|G)* (D|G) (S|D|G)* D`: an *indirect* photon (at least one non-specular bounce).
//!
//! Determinism. Path `i` draws its light, position and direction from scrambled Halton points
//! `i` and everything after from a generator seeded by `(seed, i)`, so a path does not depend on
//! which thread traces it. Paths are traced in fixed-size chunks, a round of chunks at a time in
//! parallel; the chunks' photons are merged in path order, and a map stops after the path in
//! which it reached its target. The maps are therefore identical for any thread count.

use super::emission::{Aim, aimed_emission, emission};
use super::{Photon, pack_unit};
use crate::bsdf::{LobeFlags, TransportMode};
use crate::integrators::find_surface;
use crate::lights::Light;
use crate::math::luminance;
use crate::sampler::Sampler;
use crate::sampling::{Distribution1D, Rng, mix64};
use crate::world::{Ray, World};
use glam::{Vec2, Vec3};
use rayon::prelude::*;

/// Which map a photon belongs to.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub(crate) enum PhotonKind {
    Direct,
    Caustic,
    Indirect,
}

/// A point where a radiance photon (precomputed irradiance) will be placed: a photon hit on a
/// non-specular surface, with the normal on the side the photon arrived from.
#[derive(Clone, Copy, Debug, PartialEq)]
pub(crate) struct RadianceSite {
    pub p: Vec3,
    pub n: Vec3,
}

/// What to shoot.
#[derive(Clone, Copy, Debug)]
pub(crate) struct ShootRequest {
    /// Target photon counts; `None` for a map that is not built.
    pub caustic: Option<usize>,
    pub indirect: Option<usize>,
    /// Keep direct photons (during the indirect map's paths).
    pub direct: bool,
    /// Probability that an indirect-timeline hit becomes a radiance site (0: none).
    pub radiance_fraction: f32,
    pub max_depth: u32,
    pub seed: u64,
    /// A map still empty after this many paths is abandoned.
    pub pilot_paths: u64,
    /// No more paths than this, whatever the targets.
    pub max_paths: u64,
    /// Keep each caustic photon's path vertices (for the sidecar's caustics file).
    pub caustic_paths: bool,
}

/// The photons shot, with the number of paths each map's photons are normalised by.
#[derive(Clone, Debug, Default)]
pub(crate) struct ShootResult {
    pub caustic: Vec<Photon>,
    /// With `ShootRequest::caustic_paths`, each caustic photon's path from the light: the
    /// emission point and every specular vertex, in render space (the photon's own position
    /// ends it).
    pub caustic_vertices: Vec<Vec<Vec3>>,
    pub caustic_paths: u64,
    pub direct: Vec<Photon>,
    pub indirect: Vec<Photon>,
    /// Paths of the indirect (and direct) map.
    pub indirect_paths: u64,
    pub sites: Vec<RadianceSite>,
    /// Paths traced in all (including those past a map's cut).
    pub paths_traced: u64,
    pub rays: u64,
    /// Maps abandoned because the pilot found no photon for them.
    pub caustic_abandoned: bool,
    pub indirect_abandoned: bool,
    /// The path limit stopped shooting before a target was reached.
    pub hit_path_limit: bool,
}

/// Paths per chunk (the unit of parallel work).
const CHUNK: u64 = 1024;

/// One chunk's output, in path order.
#[derive(Default)]
struct ChunkOut {
    photons: Vec<(u64, PhotonKind, Photon)>,
    /// The path vertices of the chunk's caustic photons, in order, when requested.
    caustic_vertices: Vec<Vec<Vec3>>,
    sites: Vec<(u64, RadianceSite)>,
    rays: u64,
}

/// The lights that emit photons, chosen by power.
pub(crate) struct Emitters {
    pub lights: Vec<u32>,
    pub distribution: Distribution1D,
}

impl Emitters {
    /// Every light that illuminates something and has power (ambient lights do not emit
    /// photons: they are added as a constant term).
    pub fn new(world: &World) -> Emitters {
        let (_, radius) = world.bounding_sphere();
        let mut lights = Vec::new();
        let mut weights = Vec::new();
        for (i, light) in world.lights.iter().enumerate() {
            if matches!(light, Light::Ambient { .. }) {
                continue;
            }
            let used = !light.is_delta()
                || world.light_sets.iter().any(|s| s.member.get(i).copied().unwrap_or(false));
            let power = light.power(radius);
            let w = (power.x + power.y + power.z) / 3.0;
            if used && w.is_finite() && w > 0.0 {
                lights.push(i as u32);
                weights.push(w);
            }
        }
        Emitters { lights, distribution: Distribution1D::new(&weights) }
    }
}

/// Shoots photons until every requested map has its photons (or is abandoned). With `aim`, the
/// caustic map gets its own pass of photons aimed at the specular shapes.
pub(crate) fn shoot(
    world: &World,
    emitters: &Emitters,
    request: &ShootRequest,
    aim: Option<&Aim>,
) -> ShootResult {
    let aim = aim.filter(|a| !a.spheres.is_empty());
    match aim {
        Some(aim) if request.caustic.is_some_and(|n| n > 0) => {
            let global = shoot_pass(world, emitters, &ShootRequest { caustic: None, ..*request }, None);
            let caustic = shoot_pass(
                world,
                emitters,
                &ShootRequest { indirect: None, seed: mix64(request.seed ^ 0x63_6175_7374_6963), ..*request },
                Some(aim),
            );
            ShootResult {
                caustic: caustic.caustic,
                caustic_vertices: caustic.caustic_vertices,
                caustic_paths: caustic.caustic_paths,
                caustic_abandoned: caustic.caustic_abandoned,
                paths_traced: global.paths_traced + caustic.paths_traced,
                rays: global.rays + caustic.rays,
                hit_path_limit: global.hit_path_limit || caustic.hit_path_limit,
                ..global
            }
        }
        _ => shoot_pass(world, emitters, request, None),
    }
}

fn shoot_pass(world: &World, emitters: &Emitters, request: &ShootRequest, aim: Option<&Aim>) -> ShootResult {
    let mut result = ShootResult::default();
    let caustic_target = request.caustic.unwrap_or(0);
    let indirect_target = request.indirect.unwrap_or(0);
    let mut caustic_open = caustic_target > 0;
    let mut indirect_open = indirect_target > 0;
    if emitters.distribution.total() <= 0.0 {
        result.caustic_abandoned = caustic_open;
        result.indirect_abandoned = indirect_open;
        return result;
    }
    let scene = world.bounding_sphere();
    let threads = rayon::current_num_threads().max(1) as u64;
    let mut next_path = 0u64;
    while caustic_open || indirect_open {
        if next_path >= request.max_paths {
            result.hit_path_limit = true;
            break;
        }
        // A round: enough chunks to keep every thread busy.
        let chunks = threads * 4;
        let starts: Vec<u64> =
            (0..chunks).map(|c| next_path + c * CHUNK).filter(|&s| s < request.max_paths).collect();
        let outs: Vec<ChunkOut> = starts
            .par_iter()
            .map(|&start| {
                let end = (start + CHUNK).min(request.max_paths);
                trace_chunk(world, emitters, scene, request, aim, caustic_open, indirect_open, start, end)
            })
            .collect();
        let round_end = starts.last().map(|&s| (s + CHUNK).min(request.max_paths)).unwrap_or(next_path);
        // Merge in path order; a map closes after the path that fills it.
        let mut caustic_cut: Option<u64> = None;
        let mut indirect_cut: Option<u64> = None;
        for out in &outs {
            result.rays += out.rays;
            let mut vertices = out.caustic_vertices.iter();
            for &(path, kind, photon) in &out.photons {
                let path_vertices = if kind == PhotonKind::Caustic { vertices.next() } else { None };
                match kind {
                    PhotonKind::Caustic if caustic_open && caustic_cut.is_none_or(|c| path <= c) => {
                        result.caustic.push(photon);
                        if let Some(v) = path_vertices {
                            result.caustic_vertices.push(v.clone());
                        }
                        if caustic_cut.is_none() && result.caustic.len() >= caustic_target {
                            caustic_cut = Some(path);
                        }
                    }
                    PhotonKind::Indirect | PhotonKind::Direct
                        if indirect_open && indirect_cut.is_none_or(|c| path <= c) =>
                    {
                        if kind == PhotonKind::Direct {
                            result.direct.push(photon);
                        } else {
                            result.indirect.push(photon);
                            if indirect_cut.is_none() && result.indirect.len() >= indirect_target {
                                indirect_cut = Some(path);
                            }
                        }
                    }
                    _ => {}
                }
            }
            if indirect_open {
                for &(path, site) in &out.sites {
                    if indirect_cut.is_none_or(|c| path <= c) {
                        result.sites.push(site);
                    }
                }
            }
        }
        result.paths_traced = round_end;
        if caustic_open {
            match caustic_cut {
                Some(c) => {
                    result.caustic_paths = c + 1;
                    caustic_open = false;
                }
                None => result.caustic_paths = round_end,
            }
        }
        if indirect_open {
            match indirect_cut {
                Some(c) => {
                    result.indirect_paths = c + 1;
                    indirect_open = false;
                }
                None => result.indirect_paths = round_end,
            }
        }
        // Abandon maps the pilot found nothing for: no light path reaches them.
        if round_end >= request.pilot_paths {
            if caustic_open && result.caustic.is_empty() {
                caustic_open = false;
                result.caustic_abandoned = true;
            }
            if indirect_open && result.indirect.is_empty() {
                indirect_open = false;
                result.indirect_abandoned = true;
            }
        }
        next_path = round_end;
    }
    // Photons of a map are estimates per emitted path: divide by the paths of its timeline.
    let scale = |photons: &mut Vec<Photon>, paths: u64| {
        let s = if paths > 0 { 1.0 / paths as f64 } else { 0.0 };
        for p in photons.iter_mut() {
            p.power = (p.power.as_dvec3() * s).as_vec3();
        }
    };
    scale(&mut result.caustic, result.caustic_paths);
    scale(&mut result.direct, result.indirect_paths);
    scale(&mut result.indirect, result.indirect_paths);
    if result.caustic_abandoned {
        result.caustic.clear();
        result.caustic_vertices.clear();
    }
    if result.indirect_abandoned {
        result.direct.clear();
        result.indirect.clear();
        result.sites.clear();
    }
    result
}

/// The first primes, for the Halton dimensions of a path's emission.
const PRIMES: [u32; 7] = [2, 3, 5, 7, 11, 13, 17];

/// The radical inverse of `i` in base `base`, in `[0, 1)`.
fn radical_inverse(base: u32, mut i: u64) -> f64 {
    let b = u64::from(base);
    let inv = 1.0 / f64::from(base);
    let mut v = 0.0;
    let mut weight = inv;
    while i > 0 {
        v += (i % b) as f64 * weight;
        weight *= inv;
        i /= b;
    }
    v.min(1.0 - f64::EPSILON)
}

/// Dimension `d` of Halton point `i`, rotated by a per-seed offset (Cranley-Patterson).
fn halton(d: usize, i: u64, seed: u64) -> f32 {
    let offset =
        (mix64(seed ^ (d as u64 + 1).wrapping_mul(0x9e37_79b9_7f4a_7c15)) >> 11) as f64 / (1u64 << 53) as f64;
    let v = radical_inverse(PRIMES[d], i) + offset;
    let v = if v >= 1.0 { v - 1.0 } else { v };
    (v as f32).min(1.0 - f32::EPSILON / 2.0)
}

#[allow(clippy::too_many_arguments)]
fn trace_chunk(
    world: &World,
    emitters: &Emitters,
    scene: (Vec3, f32),
    request: &ShootRequest,
    aim: Option<&Aim>,
    want_caustic: bool,
    want_indirect: bool,
    start: u64,
    end: u64,
) -> ChunkOut {
    let mut out = ChunkOut::default();
    for path in start..end {
        trace_path(world, emitters, scene, request, aim, want_caustic, want_indirect, path, &mut out);
    }
    out
}

#[allow(clippy::too_many_arguments)]
fn trace_path(
    world: &World,
    emitters: &Emitters,
    scene: (Vec3, f32),
    request: &ShootRequest,
    aim: Option<&Aim>,
    want_caustic: bool,
    want_indirect: bool,
    path: u64,
    out: &mut ChunkOut,
) {
    let seed = request.seed;
    let Some((which, pick, _)) = emitters.distribution.sample(halton(0, path, seed)) else { return };
    let light_index = emitters.lights[which];
    let light = &world.lights[light_index as usize];
    let u_pos = Vec2::new(halton(1, path, seed), halton(2, path, seed));
    let u_dir = Vec2::new(halton(3, path, seed), halton(4, path, seed));
    let u_side = halton(5, path, seed);
    let Some((origin, direction, mut alpha)) = (match aim {
        Some(aim) => aimed_emission(light, aim, u_pos, u_dir, u_side, halton(6, path, seed), scene, pick),
        None => emission(light, u_pos, u_dir, u_side, scene, pick),
    }) else {
        return;
    };
    let mut rng = Sampler::from_rng(Rng::new(mix64(seed ^ 0x7068_6f74_6f6e), path));
    let mut ray = Ray::new(origin, direction);
    let mut specular_path = true;
    // The caustic path's vertices so far, kept only for the sidecar's caustics file.
    let mut vertices = if request.caustic_paths && want_caustic { vec![origin] } else { Vec::new() };
    for depth in 0..request.max_depth {
        let mut rays = 0;
        let found = find_surface(world, ray, &mut rng, &mut rays);
        out.rays += rays;
        let Some((si, weight)) = found else { break };
        alpha *= weight;
        let material = world.material(si.attributes);
        let bsdf = material.bsdf(si.wo, si.ng, si.ns, si.n_outward, si.dpdu, si.st, si.st_width);
        if bsdf.is_black() {
            break;
        }
        if bsdf.has_non_specular() {
            // A light linked away from this surface (RenderMan's Illuminate) does not light it.
            if depth == 0
                && !matches!(light, Light::Area { .. })
                && !world.light_set(si.attributes).member[light_index as usize]
            {
                break;
            }
            let n = if si.ng.dot(si.wo) < 0.0 { -si.ng } else { si.ng };
            let photon = Photon { p: si.p, power: alpha, wi: pack_unit(si.wo), n: pack_unit(n) };
            let kind = if depth == 0 {
                PhotonKind::Direct
            } else if specular_path {
                PhotonKind::Caustic
            } else {
                PhotonKind::Indirect
            };
            let keep = match kind {
                PhotonKind::Direct => want_indirect && request.direct,
                PhotonKind::Caustic => want_caustic,
                PhotonKind::Indirect => want_indirect,
            };
            if keep {
                out.photons.push((path, kind, photon));
                if kind == PhotonKind::Caustic && request.caustic_paths {
                    out.caustic_vertices.push(vertices.clone());
                }
            }
            if want_indirect && request.radiance_fraction > 0.0 && rng.uniform() < request.radiance_fraction {
                out.sites.push((path, RadianceSite { p: si.p, n }));
            }
        }
        // Scatter, with the adjoint shading-normal correction (Veach 1997, 5.3).
        let Some(bs) =
            bsdf.sample(si.wo, rng.uniform(), rng.uniform2(), TransportMode::Importance, LobeFlags::ALL)
        else {
            break;
        };
        let wo_ng = si.wo.dot(bsdf.ng).abs();
        if wo_ng == 0.0 || !(bs.pdf > 0.0) {
            break;
        }
        let factor = si.wo.dot(bsdf.frame.z).abs() * bs.wi.dot(bsdf.ng).abs() / (wo_ng * bs.pdf);
        let next = alpha * bs.f * factor;
        // Russian roulette keeps the photon's power roughly constant (pbrt's rule).
        let continue_probability = (luminance(next) / luminance(alpha)).min(1.0);
        if !(continue_probability > 0.0) || !next.is_finite() {
            break;
        }
        if continue_probability < 1.0 {
            if rng.uniform() >= continue_probability {
                break;
            }
            alpha = next / continue_probability;
        } else {
            alpha = next;
        }
        specular_path &= bs.is_specular();
        if specular_path && request.caustic_paths && want_caustic {
            vertices.push(si.p);
        }
        if !specular_path && !want_indirect {
            // Only the caustic map is still filling: this path can add nothing more to it.
            break;
        }
        ray = si.spawn_ray(bs.wi);
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn halton_points_are_stratified() {
        // The first 2^k points of base 2 fall one per interval of width 2^-k.
        let mut seen = [false; 64];
        for i in 0..64 {
            let v = radical_inverse(2, i);
            seen[(v * 64.0) as usize] = true;
        }
        assert!(seen.iter().all(|&s| s));
        assert_eq!(radical_inverse(3, 1), 1.0 / 3.0);
        for d in 0..PRIMES.len() {
            for i in [0, 1, 17, u64::MAX / 3] {
                let v = halton(d, i, 42);
                assert!((0.0..1.0).contains(&v));
            }
        }
    }
}
