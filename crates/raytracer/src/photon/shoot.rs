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

/// At most this many aiming spheres; more specular shapes share one sphere around them all
/// (aiming costs a cone per sphere for every photon).
const MAX_AIM_SPHERES: usize = 32;

/// Bounding spheres of the specular shapes, at which caustic photons are aimed (Jensen's
/// projection maps, with exact cones instead of a grid of directions): a caustic path starts
/// with a specular hit, so emission toward anything else is wasted.
#[derive(Clone, Debug, Default)]
pub(crate) struct Aim {
    pub spheres: Vec<(Vec3, f32)>,
}

/// The cone of directions from a point toward one sphere.
#[derive(Clone, Copy, Debug)]
struct Cone {
    axis: Vec3,
    /// Cosine of the half-angle; -1 when the point is inside the sphere (all directions).
    cos_max: f32,
    /// `1 - cos_max`, accurate for small cones.
    one_minus_cos: f32,
}

impl Cone {
    fn solid_angle(&self) -> f32 {
        2.0 * std::f32::consts::PI * self.one_minus_cos
    }

    fn contains(&self, dir: Vec3) -> bool {
        self.cos_max <= -1.0 || dir.dot(self.axis) >= self.cos_max
    }
}

impl Aim {
    /// Spheres around the given render-space boxes (boxes that are not finite are skipped).
    pub fn from_boxes(boxes: &[(Vec3, Vec3)]) -> Aim {
        let sphere = |lo: Vec3, hi: Vec3| {
            // Rounding of the centre is covered by a margin relative to the coordinates' size.
            let margin = 1e-6 * lo.abs().max(hi.abs()).max_element();
            let r = (hi - lo).length() * 0.5 * (1.0 + 1e-5) + margin;
            ((lo + hi) * 0.5, r.max(f32::MIN_POSITIVE))
        };
        let finite: Vec<(Vec3, Vec3)> = boxes
            .iter()
            .copied()
            .filter(|(lo, hi)| lo.is_finite() && hi.is_finite() && lo.cmple(*hi).all())
            .collect();
        let spheres = if finite.len() > MAX_AIM_SPHERES {
            let lo = finite.iter().fold(Vec3::INFINITY, |a, b| a.min(b.0));
            let hi = finite.iter().fold(Vec3::NEG_INFINITY, |a, b| a.max(b.1));
            vec![sphere(lo, hi)]
        } else {
            finite.iter().map(|&(lo, hi)| sphere(lo, hi)).collect()
        };
        Aim { spheres }
    }

    /// The cone of directions from `p` toward sphere `(c, r)`; all directions when `p` is inside.
    fn cone(c: Vec3, r: f32, p: Vec3) -> Cone {
        let d = c - p;
        let dist2 = d.length_squared();
        if !(dist2 > r * r) {
            return Cone { axis: Vec3::Z, cos_max: -1.0, one_minus_cos: 2.0 };
        }
        let sin2 = r * r / dist2;
        let cos_max = (1.0 - sin2).max(0.0).sqrt();
        // 1 - sqrt(1 - s) = s / (1 + sqrt(1 - s)), without cancellation for small cones.
        let one_minus_cos = sin2 / (1.0 + cos_max);
        Cone { axis: d / dist2.sqrt(), cos_max, one_minus_cos }
    }

    /// Total solid angle of the cones from `p` (overlaps counted twice): what aiming samples.
    fn solid_angle(&self, p: Vec3) -> f32 {
        self.spheres.iter().take(MAX_AIM_SPHERES).map(|&(c, r)| Self::cone(c, r, p).solid_angle()).sum()
    }

    /// A direction from `p` toward a sphere chosen in proportion to its solid angle, uniform in
    /// that sphere's cone, and its density (per solid angle) over the union of all the cones.
    fn sample(&self, p: Vec3, u_pick: f32, u: Vec2) -> Option<(Vec3, f32)> {
        let n = self.spheres.len().min(MAX_AIM_SPHERES);
        if n == 0 {
            return None;
        }
        let mut cones = [Cone { axis: Vec3::Z, cos_max: -1.0, one_minus_cos: 2.0 }; MAX_AIM_SPHERES];
        let mut total = 0.0f32;
        for (cone, &(c, r)) in cones.iter_mut().zip(&self.spheres[..n]) {
            *cone = Self::cone(c, r, p);
            total += cone.solid_angle();
        }
        let cones = &cones[..n];
        if !(total > 0.0) || !total.is_finite() {
            return None;
        }
        let mut target = u_pick * total;
        let mut chosen = cones[n - 1];
        for cone in cones {
            let w = cone.solid_angle();
            if target < w {
                chosen = *cone;
                break;
            }
            target -= w;
        }
        // Uniform in the cone: 1 - cos(theta) uniform in [0, 1 - cos_max].
        let one_minus = u.x * chosen.one_minus_cos;
        let cos_theta = 1.0 - one_minus;
        let sin_theta = (one_minus * (2.0 - one_minus)).max(0.0).sqrt();
        let phi = 2.0 * std::f32::consts::PI * u.y;
        let local = Vec3::new(phi.cos() * sin_theta, phi.sin() * sin_theta, cos_theta);
        let dir = crate::math::Frame::from_z(chosen.axis).from_local(local).normalize();
        // Each cone is chosen with probability `solid angle / total` and sampled with density
        // `1 / solid angle`, so every cone that contains `dir` adds `1 / total`. The chosen cone
        // contains it (rounding aside).
        let inside = cones.iter().filter(|c| c.contains(dir)).count().max(1);
        Some((dir, inside as f32 / total))
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

/// A photon's first ray and power, from the light's own emission distribution.
fn emission(
    light: &Light,
    u_pos: Vec2,
    u_dir: Vec2,
    u_side: f32,
    scene: (Vec3, f32),
    pick: f32,
) -> Option<(Vec3, Vec3, Vec3)> {
    let le = light.sample_le(u_pos, u_dir, u_side, scene)?;
    let cos = if le.n == Vec3::ZERO { 1.0 } else { le.n.dot(le.direction).abs() };
    let denominator = pick * le.pdf_pos * le.pdf_dir;
    let alpha = le.le * (cos / denominator);
    let ok = denominator > 0.0 && alpha.is_finite() && alpha != Vec3::ZERO && le.direction.is_finite();
    ok.then_some((le.origin, le.direction, alpha))
}

/// A photon aimed at the specular shapes: the light's position as it samples it, a direction
/// from [`Aim::sample`], and the power `Le cos / (pick pdf_pos pdf_aim)`. Where the cones cover
/// no less solid angle than the light emits into (a narrow spot light, a point inside a bounding
/// sphere), the photon keeps the light's own direction distribution instead; the choice depends
/// on the position only, so each is unbiased given the position. Lights at infinity (distant and
/// environment lights) keep their direction distribution and aim the origin instead
/// ([`aimed_from_infinity`]).
#[allow(clippy::too_many_arguments)]
fn aimed_emission(
    light: &Light,
    aim: &Aim,
    u_pos: Vec2,
    u_dir: Vec2,
    u_side: f32,
    u_aim: f32,
    scene: (Vec3, f32),
    pick: f32,
) -> Option<(Vec3, Vec3, Vec3)> {
    use std::f32::consts::PI;
    let (origin, n, pdf_pos, two_sided, emitted_solid_angle) = match light {
        Light::Point { position, .. } => (*position, Vec3::ZERO, 1.0, false, 4.0 * PI),
        Light::Spot { position, cos_outside, .. } => {
            (*position, Vec3::ZERO, 1.0, false, 2.0 * PI * (1.0 - cos_outside))
        }
        Light::Area { two_sided, .. } => {
            // The position (and, for two-sided lights, the side) as the light samples them;
            // its origin is already pushed off the surface to that side.
            let le = light.sample_le(u_pos, u_dir, u_side, scene)?;
            (le.origin, le.n, le.pdf_pos, *two_sided, 2.0 * PI)
        }
        Light::Distant { .. } | Light::Environment(_) => {
            return aimed_from_infinity(light, aim, u_pos, u_dir, u_aim, scene, pick);
        }
        _ => return emission(light, u_pos, u_dir, u_side, scene, pick),
    };
    if aim.solid_angle(origin) >= emitted_solid_angle {
        return emission(light, u_pos, u_dir, u_side, scene, pick);
    }
    let (direction, pdf_dir) = aim.sample(origin, u_aim, u_dir)?;
    let intensity = match light {
        Light::Point { intensity, .. } => *intensity,
        Light::Spot { position, .. } => {
            // Spot intensity toward `direction`: the radiance arriving one unit away.
            let ctx = crate::lights::LightSampleContext {
                p: *position + direction,
                p_error: Vec3::ZERO,
                n: Vec3::ZERO,
                p64: (*position + direction).as_dvec3(),
            };
            light.sample_li(&ctx, Vec2::ZERO)?.li * (*position - ctx.p).length_squared()
        }
        _ => {
            // Emission leaves the sampled side only.
            let cos = n.dot(direction);
            if !(cos > 0.0) {
                return None;
            }
            let side = if two_sided { 0.5 } else { 1.0 };
            light.emitted(n, direction) * (cos / side)
        }
    };
    let denominator = pick * pdf_pos * pdf_dir;
    let alpha = intensity / denominator;
    let ok = denominator > 0.0 && alpha.is_finite() && alpha != Vec3::ZERO;
    ok.then_some((origin, direction, alpha))
}

/// A photon from a light at infinity aimed at the specular shapes: the direction from the
/// light's own distribution, the origin uniform on the silhouette (a disc of its radius) of an
/// aiming sphere chosen by area, seen along that direction, instead of on the disc of the whole
/// scene. The area density counts every silhouette that contains the origin. Where the
/// silhouettes cover no less area than the scene's disc, the photon is not aimed.
fn aimed_from_infinity(
    light: &Light,
    aim: &Aim,
    u_pos: Vec2,
    u_dir: Vec2,
    u_aim: f32,
    scene: (Vec3, f32),
    pick: f32,
) -> Option<(Vec3, Vec3, Vec3)> {
    use std::f32::consts::PI;
    let spheres = &aim.spheres[..aim.spheres.len().min(MAX_AIM_SPHERES)];
    let total_r2: f32 = spheres.iter().map(|&(_, r)| r * r).sum();
    let (centre, radius) = scene;
    if spheres.is_empty() || !(total_r2 > 0.0) || total_r2 >= radius * radius {
        return emission(light, u_pos, u_dir, 0.0, scene, pick);
    }
    // The direction (and radiance) as the light samples them; its origin is replaced.
    let le = light.sample_le(u_pos, u_dir, 0.0, scene)?;
    let wi = -le.direction;
    let mut target = u_aim * total_r2;
    let mut chosen = spheres[spheres.len() - 1];
    for &(c, r) in spheres {
        if target < r * r {
            chosen = (c, r);
            break;
        }
        target -= r * r;
    }
    let (c, r) = chosen;
    let frame = crate::math::Frame::from_z(wi);
    let d = crate::sampling::sample_concentric_disk(u_pos) * r;
    let on_plane = c + frame.x * d.x + frame.y * d.y;
    let covering = spheres
        .iter()
        .filter(|&&(c, r)| {
            let v = on_plane - c;
            (v - wi * v.dot(wi)).length_squared() <= r * r
        })
        .count()
        .max(1);
    let pdf_pos = covering as f32 / (PI * total_r2);
    // Moved back along the direction until it is outside the scene's bounding sphere.
    let origin = on_plane + wi * (radius + (c - centre).length());
    let denominator = pick * pdf_pos * le.pdf_dir;
    let alpha = le.le / denominator;
    let ok = denominator > 0.0 && alpha.is_finite() && alpha != Vec3::ZERO && origin.is_finite();
    ok.then_some((origin, le.direction, alpha))
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

    /// Photons from lights at infinity aimed at two overlapping spheres carry, on average over
    /// the photons whose ray meets a sphere, the same power as unaimed photons: the flux through
    /// the spheres' silhouettes.
    #[test]
    fn aimed_photons_from_infinity_carry_the_flux_through_the_silhouettes() {
        use crate::environment_light::EnvironmentLight;
        let map = crate::texture::Texture::from_rgb(
            16,
            8,
            (0..128).map(|i| Vec3::splat(0.2 + (i % 5) as f32)).collect(),
        )
        .unwrap();
        let env = Light::Environment(std::sync::Arc::new(
            EnvironmentLight::new(Vec3::ONE, Some(std::sync::Arc::new(map)), glam::DMat3::IDENTITY).unwrap(),
        ));
        let distant =
            Light::Distant { direction: Vec3::new(0.3, -1.0, 0.2).normalize(), irradiance: Vec3::ONE };
        let spheres = vec![(Vec3::new(0.5, 0.0, 0.0), 0.6), (Vec3::new(1.0, 0.3, 0.2), 0.4)];
        let aim = Aim { spheres: spheres.clone() };
        let scene = (Vec3::ZERO, 3.0);
        let hits = |o: Vec3, d: Vec3| {
            spheres.iter().any(|&(c, r)| {
                let v = c - o;
                let t = v.dot(d);
                t > 0.0 && (v - d * t).length_squared() <= r * r
            })
        };
        for light in [&env, &distant] {
            let n = 200_000;
            let mut rng = Rng::new(3, 3);
            let (mut aimed, mut plain) = (Vec3::ZERO, Vec3::ZERO);
            for _ in 0..n {
                let (u_pos, u_dir, u_aim) = (rng.uniform2(), rng.uniform2(), rng.uniform());
                if let Some((o, d, a)) = aimed_from_infinity(light, &aim, u_pos, u_dir, u_aim, scene, 1.0) {
                    assert!(hits(o, d), "an aimed photon misses");
                    assert!((o - scene.0).length() >= scene.1 * 0.999);
                    aimed += a;
                }
                if let Some((o, d, a)) = emission(light, u_pos, u_dir, 0.0, scene, 1.0)
                    && hits(o, d)
                {
                    plain += a;
                }
            }
            let (aimed, plain) = (aimed / n as f32, plain / n as f32);
            assert!((aimed - plain).abs().max_element() < 0.03 * plain.max_element(), "{aimed} vs {plain}");
        }
    }

    /// With two overlapping spheres, one apart and one around the point, the mean of
    /// `1 / pdf` over aimed directions is the solid angle of the union of the cones (counted by
    /// uniform directions), which holds only if the density accounts for the overlaps.
    #[test]
    fn aim_density_covers_the_union_of_the_cones() {
        let p = Vec3::new(0.1, -0.2, 0.3);
        let cases = [
            vec![
                (Vec3::new(2.0, 0.0, 0.0), 0.8),
                (Vec3::new(2.2, 0.5, 0.0), 0.7),
                (Vec3::new(-1.0, -3.0, 1.0), 0.5),
            ],
            vec![(Vec3::new(3.0, 1.0, 0.0), 0.01), (Vec3::new(0.0, 0.0, 0.0), 1.0)],
        ];
        for spheres in cases {
            let aim = Aim { spheres: spheres.clone() };
            let n = 200_000;
            let mut rng = Rng::new(7, 1);
            let mut sum_inverse = 0.0f64;
            for _ in 0..n {
                let (dir, pdf) =
                    aim.sample(p, rng.uniform(), Vec2::new(rng.uniform(), rng.uniform())).unwrap();
                assert!((dir.length() - 1.0).abs() < 1e-4);
                sum_inverse += 1.0 / f64::from(pdf);
            }
            let mut inside = 0u32;
            for _ in 0..n {
                let dir = crate::sampling::sample_uniform_sphere(Vec2::new(rng.uniform(), rng.uniform()));
                if spheres.iter().any(|&(c, r)| Aim::cone(c, r, p).contains(dir)) {
                    inside += 1;
                }
            }
            let union = 4.0 * std::f64::consts::PI * f64::from(inside) / f64::from(n);
            let estimate = sum_inverse / f64::from(n);
            assert!((estimate - union).abs() < 0.02 * union, "{estimate} vs {union}");
        }
    }
}
