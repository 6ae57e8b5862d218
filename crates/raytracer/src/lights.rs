//! Light sources in render space: RenderMan's standard lights and area lights on any shape.
//!
//! Units. `AreaLightSource "arealight"` emits radiance `intensity * lightcolor` (CONTRACTS.md §3).
//! RenderMan's `pointlight`, `spotlight` and `distantlight` set `Cl = intensity * lightcolor`
//! (over `d^2` for the first two), which `diffuse()` multiplies by the cosine *without* a `1/pi`;
//! since our `matte` is a true Lambertian BRDF `Kd Cs / pi`, these lights carry a factor `pi`
//! ([`RENDERMAN_LIGHT_SCALE`]) so that a matte surface under a point light is exactly as bright as
//! RenderMan renders it. `ambientlight` adds `Ka Cs intensity lightcolor` where a shader has `Ka`.
//!
//! Every light can be sampled from a reference point (`sample_li`, for next-event estimation),
//! evaluated for a direction found by BSDF sampling (`pdf_li`, for multiple importance
//! sampling), and sampled as an emitter of rays (`sample_le`, for photon tracing), with its total
//! power (`power`) for choosing among lights.

use crate::accel::X86_64V3;
use crate::environment_light::EnvironmentLight;
use crate::math::{Frame, offset_ray_origin, positive_and_finite, round_point, transform_normal};
use crate::sampling::{
    Distribution1D, UNIFORM_SPHERE_PDF, sample_concentric_disk, sample_cosine_hemisphere,
    sample_uniform_cone, sample_uniform_sphere, sample_uniform_triangle, uniform_cone_pdf,
};
use crate::shapes::Quadric;
use glam::{DMat4, DVec3, Vec2, Vec3};
use std::f32::consts::PI;
use std::sync::Arc;

/// The factor between RenderMan's `Cl` of the standard point, spot and distant lights and
/// physical radiant intensity or irradiance (see the module documentation), defined once with
/// the scene's lights so the viewer's live objects use the same.
pub const RENDERMAN_LIGHT_SCALE: f32 = rib_parser::scene::RENDERMAN_DELTA_LIGHT_SCALE;

/// Emitting geometry of an area light, in render space.
#[derive(Clone, Debug)]
#[allow(clippy::large_enum_variant)]
pub enum EmitterShape {
    /// Triangles with their front-side unit normals, chosen by area.
    Triangles { triangles: Vec<[Vec3; 3]>, normals: Vec<Vec3>, by_area: Distribution1D, area: f32 },
    /// A quadric and its transforms. `flip` reverses its parametric normal (orientation).
    Quadric {
        quadric: Quadric,
        render_from_object: DMat4,
        object_from_render: DMat4,
        det: f64,
        flip: bool,
        /// A full sphere under a similarity transform: centre and radius, for cone sampling.
        sphere: Option<(DVec3, f64)>,
        area: f64,
    },
}

/// A light source.
#[derive(Clone, Debug)]
#[allow(clippy::large_enum_variant)]
pub enum Light {
    Point {
        position: Vec3,
        intensity: Vec3,
    },
    Spot {
        position: Vec3,
        frame: Frame,
        intensity: Vec3,
        cos_outside: f32,
        cos_inside: f32,
        beam: f32,
        cone_integral: f32,
    },
    /// Light travelling along `direction` with irradiance `irradiance` on a surface facing it.
    Distant {
        direction: Vec3,
        irradiance: Vec3,
    },
    Area {
        shape: EmitterShape,
        radiance: Vec3,
        two_sided: bool,
    },
    Ambient {
        color: Vec3,
    },
    /// Light from every direction at infinity (see [`EnvironmentLight`]); rays that leave the
    /// scene see it.
    Environment(Arc<EnvironmentLight>),
}

/// The point lights are sampled from.
#[derive(Clone, Copy, Debug)]
pub struct LightSampleContext {
    pub p: Vec3,
    pub p_error: Vec3,
    /// Geometric normal (zero when the point is not on a surface).
    pub n: Vec3,
    pub p64: DVec3,
}

/// A sample toward a light from a reference point.
#[derive(Clone, Copy, Debug)]
pub struct LightLiSample {
    /// Radiance arriving from the light (for delta lights: the quantity that multiplies
    /// `f |cos|`, i.e. irradiance at normal incidence).
    pub li: Vec3,
    pub wi: Vec3,
    /// Solid-angle density (1 for delta lights).
    pub pdf: f32,
    pub is_delta: bool,
    /// The sampled point on the light (for the shadow ray) and its error bound; `None` for
    /// distant lights (shadow ray to infinity).
    pub p_light: Option<(Vec3, Vec3, Vec3)>,
}

/// A ray leaving a light (photon emission).
#[derive(Clone, Copy, Debug)]
pub struct LightLeSample {
    pub origin: Vec3,
    pub origin_error: Vec3,
    /// Surface normal at the origin (zero for point-like lights).
    pub n: Vec3,
    pub direction: Vec3,
    pub le: Vec3,
    pub pdf_pos: f32,
    pub pdf_dir: f32,
}

#[inline]
fn smoothstep(a: f32, b: f32, x: f32) -> f32 {
    if a == b {
        return if x < a { 0.0 } else { 1.0 };
    }
    let t = ((x - a) / (b - a)).clamp(0.0, 1.0);
    t * t * (3.0 - 2.0 * t)
}

impl Light {
    /// A spot light as RenderMan's standard `spotlight` computes it.
    pub fn spot(
        position: Vec3,
        axis: Vec3,
        intensity: Vec3,
        cone_angle: f32,
        cone_delta: f32,
        beam: f32,
    ) -> Light {
        let cos_outside = cone_angle.clamp(0.0, PI).cos();
        let cos_inside = (cone_angle - cone_delta).clamp(0.0, PI).cos();
        let beam = if beam.is_finite() { beam.max(0.0) } else { 0.0 };
        // Integral over the cosine of the falloff, numerically (midpoint rule on 4096 steps).
        let n = 4096;
        let mut integral = 0.0f64;
        let lo = cos_outside;
        for i in 0..n {
            let c = lo + (1.0 - lo) * (i as f32 + 0.5) / n as f32;
            integral += f64::from(c.max(0.0).powf(beam) * smoothstep(cos_outside, cos_inside, c));
        }
        let cone_integral = (integral * f64::from(1.0 - lo) / f64::from(n)) as f32;
        Light::Spot {
            position,
            frame: Frame::from_z(axis.normalize_or(Vec3::Z)),
            intensity,
            cos_outside,
            cos_inside,
            beam,
            cone_integral,
        }
    }

    fn spot_falloff(cos: f32, cos_outside: f32, cos_inside: f32, beam: f32) -> f32 {
        if cos < cos_outside {
            return 0.0;
        }
        cos.max(0.0).powf(beam) * smoothstep(cos_outside, cos_inside, cos)
    }

    /// True for lights that cannot be hit by a ray (point, spot, distant, ambient).
    pub fn is_delta(&self) -> bool {
        !matches!(self, Light::Area { .. } | Light::Environment(_))
    }

    /// Radiance an environment light sends along a ray leaving the scene in direction `dir`
    /// (zero for other lights).
    #[inline]
    pub fn escaped(&self, dir: Vec3) -> Vec3 {
        match self {
            Light::Environment(env) => env.radiance(dir),
            _ => Vec3::ZERO,
        }
    }

    /// Solid-angle density with which [`Light::sample_li`] of an environment light returns
    /// direction `dir` (zero for other lights).
    pub fn pdf_escaped(&self, dir: Vec3) -> f32 {
        match self {
            Light::Environment(env) => env.pdf(dir),
            _ => 0.0,
        }
    }

    /// Total emitted power (per channel). `scene_radius` bounds the scene for distant lights.
    pub fn power(&self, scene_radius: f32) -> Vec3 {
        match self {
            Light::Point { intensity, .. } => *intensity * (4.0 * PI),
            Light::Spot { intensity, cone_integral, .. } => *intensity * (2.0 * PI * cone_integral),
            Light::Distant { irradiance, .. } => *irradiance * (PI * scene_radius * scene_radius),
            Light::Area { shape, radiance, two_sided } => {
                let area = match shape {
                    EmitterShape::Triangles { area, .. } => *area,
                    EmitterShape::Quadric { area, .. } => *area as f32,
                };
                *radiance * (PI * area * if *two_sided { 2.0 } else { 1.0 })
            }
            Light::Ambient { .. } => Vec3::ZERO,
            Light::Environment(env) => env.power(scene_radius),
        }
    }

    /// Radiance emitted by an area light at a point with front normal `n` toward `w`.
    #[inline]
    pub fn emitted(&self, n: Vec3, w: Vec3) -> Vec3 {
        match self {
            Light::Area { radiance, two_sided, .. } => {
                if *two_sided || n.dot(w) > 0.0 {
                    *radiance
                } else {
                    Vec3::ZERO
                }
            }
            _ => Vec3::ZERO,
        }
    }

    /// Samples incident light at `ctx`.
    pub fn sample_li(&self, ctx: &LightSampleContext, u: Vec2) -> Option<LightLiSample> {
        self.sample_li_inlined(None, ctx, u)
    }

    /// [`Light::sample_li`], inlined where it is called: the wavefront's x86-64-v3 copy
    /// compiles it with its own features, and rounds an area light's point in lanes where `v3`
    /// says it may ([`barycentric_point_rounded_v3`](crate::shapes::barycentric_point_rounded_v3)).
    #[inline(always)]
    pub(crate) fn sample_li_inlined(
        &self,
        v3: Option<X86_64V3>,
        ctx: &LightSampleContext,
        u: Vec2,
    ) -> Option<LightLiSample> {
        match self {
            Light::Point { position, intensity } => {
                let d = *position - ctx.p;
                let d2 = d.length_squared();
                if !(d2 > 0.0) {
                    return None;
                }
                Some(LightLiSample {
                    li: *intensity / d2,
                    wi: d / d2.sqrt(),
                    pdf: 1.0,
                    is_delta: true,
                    p_light: Some((*position, Vec3::ZERO, Vec3::ZERO)),
                })
            }
            Light::Spot { position, frame, intensity, cos_outside, cos_inside, beam, .. } => {
                let d = *position - ctx.p;
                let d2 = d.length_squared();
                if !(d2 > 0.0) {
                    return None;
                }
                let wi = d / d2.sqrt();
                let falloff = Self::spot_falloff((-wi).dot(frame.z), *cos_outside, *cos_inside, *beam);
                if falloff <= 0.0 {
                    return None;
                }
                Some(LightLiSample {
                    li: *intensity * (falloff / d2),
                    wi,
                    pdf: 1.0,
                    is_delta: true,
                    p_light: Some((*position, Vec3::ZERO, Vec3::ZERO)),
                })
            }
            Light::Distant { direction, irradiance } => Some(LightLiSample {
                li: *irradiance,
                wi: -*direction,
                pdf: 1.0,
                is_delta: true,
                p_light: None,
            }),
            Light::Ambient { .. } => None,
            Light::Environment(env) => {
                let (wi, pdf, li) = env.sample(u)?;
                Some(LightLiSample { li, wi, pdf, is_delta: false, p_light: None })
            }
            Light::Area { shape, .. } => {
                let (p, p_err, n, pdf) = match shape {
                    EmitterShape::Quadric { sphere: Some((centre, radius)), flip, .. }
                        if ctx.p64.distance_squared(*centre) > radius * radius * (1.0 + 1e-6) =>
                    {
                        // A context of its own for the call, made of the two fields it reads:
                        // a reference to `ctx` would let the call read all of it, and the
                        // inlined callers would then store every field of every context they
                        // build, whatever the light (the wavefront's light stage, once per
                        // light sample).
                        let cone =
                            LightSampleContext { p: ctx.p, p_error: Vec3::ZERO, n: Vec3::ZERO, p64: ctx.p64 };
                        return self.sample_sphere_cone(&cone, *centre, *radius, *flip, u);
                    }
                    _ => self.sample_area(v3, u)?,
                };
                let d = p - ctx.p;
                let d2 = d.length_squared();
                if !(d2 > 0.0) {
                    return None;
                }
                let wi = d / d2.sqrt();
                let cos_l = n.dot(-wi).abs();
                if cos_l == 0.0 {
                    return None;
                }
                let le = self.emitted(n, -wi);
                if le == Vec3::ZERO {
                    return None;
                }
                let pdf_solid = pdf * d2 / cos_l;
                if !positive_and_finite(pdf_solid) {
                    return None;
                }
                Some(LightLiSample {
                    li: le,
                    wi,
                    pdf: pdf_solid,
                    is_delta: false,
                    p_light: Some((p, p_err, n)),
                })
            }
        }
    }

    /// A point on an area light chosen with an area density: (point, error, front normal, pdf).
    /// Always inlined, into [`Light::sample_li_inlined`] among others.
    #[inline(always)]
    fn sample_area(&self, v3: Option<X86_64V3>, u: Vec2) -> Option<(Vec3, Vec3, Vec3, f32)> {
        let Light::Area { shape, .. } = self else { return None };
        match shape {
            EmitterShape::Triangles { triangles, normals, by_area, area } => {
                let (i, _, u0) = by_area.sample(u.x)?;
                let tp = &triangles[i];
                let b = sample_uniform_triangle(Vec2::new(u0, u.y));
                let b = [f64::from(b[0]), f64::from(b[1]), f64::from(b[2])];
                let (_, p, p_err) = crate::shapes::barycentric_point_rounded_v3(v3, b, tp);
                Some((p, p_err, normals[i], 1.0 / area))
            }
            EmitterShape::Quadric { quadric, render_from_object, object_from_render, det, flip, .. } => {
                let (po, no) = quadric.sample_point(f64::from(u.x), f64::from(u.y));
                let pw = render_from_object.transform_point3(po);
                let err = crate::math::transform_point_error(render_from_object, po)
                    + DVec3::splat(1e-9 * quadric_scale(quadric, render_from_object));
                let (p, p_err) = round_point(pw, err);
                let mut n = transform_normal(object_from_render, no).normalize_or_zero().as_vec3();
                if *flip {
                    n = -n;
                }
                let density = quadric_area_density(quadric, object_from_render, *det, po)?;
                Some((p, p_err, n, (1.0 / density) as f32))
            }
        }
    }

    fn sample_sphere_cone(
        &self,
        ctx: &LightSampleContext,
        centre: DVec3,
        radius: f64,
        flip: bool,
        u: Vec2,
    ) -> Option<LightLiSample> {
        let to_centre = centre - ctx.p64;
        let dc = to_centre.length();
        let sin_max = radius / dc;
        let sin2_max = sin_max * sin_max;
        let cos_max = (1.0 - sin2_max).max(0.0).sqrt();
        let mut one_minus_cos_max = 1.0 - cos_max;
        let (u0, u1) = (f64::from(u.x), f64::from(u.y));
        let mut cos_theta = (cos_max - 1.0) * u0 + 1.0;
        let mut sin2_theta = 1.0 - cos_theta * cos_theta;
        if sin2_max < 0.000_685_23 {
            // Small cones: Taylor expansion keeps precision.
            sin2_theta = sin2_max * u0;
            cos_theta = (1.0 - sin2_theta).sqrt();
            one_minus_cos_max = sin2_max / 2.0;
        }
        let cos_alpha = sin2_theta / sin_max + cos_theta * (1.0 - sin2_theta / sin2_max).max(0.0).sqrt();
        let sin_alpha = (1.0 - cos_alpha * cos_alpha).max(0.0).sqrt();
        let phi = u1 * std::f64::consts::TAU;
        let axis = to_centre / dc;
        let frame = Frame::from_z(axis.as_vec3());
        let local = DVec3::new(sin_alpha * phi.cos(), sin_alpha * phi.sin(), cos_alpha);
        // Normal at the sampled point, pointing back toward the reference point's side.
        let w = frame.from_local(local.as_vec3()).as_dvec3();
        let n_out = -w;
        let p64 = centre + n_out * radius;
        let (p, p_err) = round_point(p64, p64.abs() * 1e-12 + DVec3::splat(radius * 1e-12));
        let n = if flip { -n_out.as_vec3() } else { n_out.as_vec3() };
        let d = p - ctx.p;
        let d2 = d.length_squared();
        if !(d2 > 0.0) {
            return None;
        }
        let wi = d / d2.sqrt();
        let le = self.emitted(n, -wi);
        if le == Vec3::ZERO {
            return None;
        }
        let pdf = (1.0 / (std::f64::consts::TAU * one_minus_cos_max)) as f32;
        Some(LightLiSample { li: le, wi, pdf, is_delta: false, p_light: Some((p, p_err, n)) })
    }

    /// Solid-angle density with which [`Light::sample_li`] from `ref_p64` produces direction `wi`
    /// reaching the light at `hit_p64` with front normal `hit_n`.
    pub fn pdf_li(&self, ref_p64: DVec3, wi: Vec3, hit_p64: DVec3, hit_n: Vec3) -> f32 {
        let Light::Area { shape, .. } = self else { return 0.0 };
        if let EmitterShape::Quadric { sphere: Some((centre, radius)), .. } = shape
            && ref_p64.distance_squared(*centre) > radius * radius * (1.0 + 1e-6)
        {
            let sin2_max = radius * radius / ref_p64.distance_squared(*centre);
            let cos_max = (1.0 - sin2_max).max(0.0).sqrt();
            let one_minus = if sin2_max < 0.000_685_23 { sin2_max / 2.0 } else { 1.0 - cos_max };
            return (1.0 / (std::f64::consts::TAU * one_minus)) as f32;
        }
        let pdf_area = match shape {
            EmitterShape::Triangles { area, .. } => 1.0 / *area,
            EmitterShape::Quadric { quadric, object_from_render, det, .. } => {
                let po = object_from_render.transform_point3(hit_p64);
                match quadric_area_density(quadric, object_from_render, *det, po) {
                    Some(d) => (1.0 / d) as f32,
                    None => return 0.0,
                }
            }
        };
        let d2 = hit_p64.distance_squared(ref_p64) as f32;
        let cos_l = hit_n.dot(-wi).abs();
        if cos_l == 0.0 {
            return 0.0;
        }
        pdf_area * d2 / cos_l
    }

    /// Samples a ray leaving the light. `scene` is the render-space bounding sphere.
    pub fn sample_le(
        &self,
        u_pos: Vec2,
        u_dir: Vec2,
        u_side: f32,
        scene: (Vec3, f32),
    ) -> Option<LightLeSample> {
        match self {
            Light::Point { position, intensity } => Some(LightLeSample {
                origin: *position,
                origin_error: Vec3::ZERO,
                n: Vec3::ZERO,
                direction: sample_uniform_sphere(u_dir),
                le: *intensity,
                pdf_pos: 1.0,
                pdf_dir: UNIFORM_SPHERE_PDF,
            }),
            Light::Spot { position, frame, intensity, cos_outside, cos_inside, beam, .. } => {
                let local = sample_uniform_cone(u_dir, *cos_outside);
                let falloff = Self::spot_falloff(local.z, *cos_outside, *cos_inside, *beam);
                Some(LightLeSample {
                    origin: *position,
                    origin_error: Vec3::ZERO,
                    n: Vec3::ZERO,
                    direction: frame.from_local(local),
                    le: *intensity * falloff,
                    pdf_pos: 1.0,
                    pdf_dir: uniform_cone_pdf(*cos_outside),
                })
            }
            Light::Distant { direction, irradiance } => {
                let (centre, radius) = scene;
                let frame = Frame::from_z(*direction);
                let d = sample_concentric_disk(u_pos) * radius;
                let origin = centre - *direction * radius + frame.x * d.x + frame.y * d.y;
                Some(LightLeSample {
                    origin,
                    origin_error: Vec3::ZERO,
                    n: Vec3::ZERO,
                    direction: *direction,
                    le: *irradiance,
                    pdf_pos: 1.0 / (PI * radius * radius),
                    pdf_dir: 1.0,
                })
            }
            Light::Ambient { .. } => None,
            Light::Environment(env) => {
                let (origin, direction, le, pdf_pos, pdf_dir) = env.sample_emission(u_pos, u_dir, scene)?;
                Some(LightLeSample {
                    origin,
                    origin_error: Vec3::ZERO,
                    n: Vec3::ZERO,
                    direction,
                    le,
                    pdf_pos,
                    pdf_dir,
                })
            }
            Light::Area { two_sided, .. } => {
                let (p, p_err, n, pdf_pos) = self.sample_area(None, u_pos)?;
                let mut local = sample_cosine_hemisphere(u_dir);
                let mut pdf_dir = local.z / PI;
                let mut n_side = n;
                if *two_sided {
                    pdf_dir *= 0.5;
                    if u_side < 0.5 {
                        local.z = -local.z;
                        n_side = -n;
                    }
                }
                let direction = Frame::from_z(n).from_local(local);
                if !(pdf_dir > 0.0) {
                    return None;
                }
                let origin = offset_ray_origin(p, p_err, n_side, direction);
                Some(LightLeSample {
                    origin,
                    origin_error: p_err,
                    n: n_side,
                    direction,
                    le: self.emitted(n, direction),
                    pdf_pos,
                    pdf_dir,
                })
            }
        }
    }
}

/// A conservative length scale of a quadric in render space (for absolute error bounds).
fn quadric_scale(q: &Quadric, render_from_object: &DMat4) -> f64 {
    let extent = (q.bounds_max - q.bounds_min).length();
    let l = render_from_object;
    let s = l.x_axis.truncate().length().max(l.y_axis.truncate().length()).max(l.z_axis.truncate().length());
    extent * s
}

/// Render-space area per unit of the quadric's sampling parameters at object point `po`.
fn quadric_area_density(q: &Quadric, object_from_render: &DMat4, det: f64, po: DVec3) -> Option<f64> {
    let v = q.sample_density_vector(po);
    // (L a) x (L b) = det(L) L^-T (a x b); L^-T is the normal transform of object_from_render.
    let density = det.abs() * transform_normal(object_from_render, v).length();
    (density.is_finite() && density > 0.0).then_some(density)
}

/// Render-space area of a quadric under a transform, by a midpoint rule over its sampling
/// parameters (exact for the shapes whose density is constant).
pub fn quadric_area(q: &Quadric, object_from_render: &DMat4, det: f64) -> f64 {
    let n = 32;
    let mut sum = 0.0;
    for i in 0..n {
        for j in 0..n {
            let (a, b) = ((i as f64 + 0.5) / n as f64, (j as f64 + 0.5) / n as f64);
            let (p, _) = q.sample_point(a, b);
            sum += quadric_area_density(q, object_from_render, det, p).unwrap_or(0.0);
        }
    }
    sum / (n * n) as f64
}

/// The lights that illuminate a set of surfaces: a distribution by power over them and the sum
/// of their ambient lights.
#[derive(Clone, Debug, Default)]
pub struct LightSet {
    /// Indices into the world's lights.
    pub lights: Vec<u32>,
    pub distribution: Distribution1D,
    pub ambient: Vec3,
    /// Whether each light of the world is in the set (for emitters found by BSDF sampling).
    pub member: Vec<bool>,
}

impl LightSet {
    pub fn new(all: &[Light], members: &[u32], scene_radius: f32) -> LightSet {
        let mut lights = Vec::new();
        let mut weights = Vec::new();
        let mut ambient = Vec3::ZERO;
        let mut member = vec![false; all.len()];
        for &i in members {
            let Some(light) = all.get(i as usize) else { continue };
            member[i as usize] = true;
            match light {
                Light::Ambient { color } => ambient += *color,
                _ => {
                    let p = light.power(scene_radius);
                    let w = (p.x + p.y + p.z) / 3.0;
                    if w > 0.0 && w.is_finite() {
                        lights.push(i);
                        weights.push(w);
                    }
                }
            }
        }
        LightSet { lights, distribution: Distribution1D::new(&weights), ambient, member }
    }

    /// Picks a light: (world light index, probability, remapped u). Always inlined: out of
    /// line it was a call per light sample, and baseline code in the wavefront's x86-64-v3 batch.
    #[inline(always)]
    pub fn pick(&self, u: f32) -> Option<(u32, f32)> {
        let (i, p, _) = self.distribution.sample(u)?;
        Some((self.lights[i], p))
    }

    /// Probability that [`LightSet::pick`] returns world light `light`.
    pub fn pmf(&self, light: u32) -> f32 {
        if !self.member.get(light as usize).copied().unwrap_or(false) {
            return 0.0;
        }
        match self.lights.iter().position(|&l| l == light) {
            Some(i) => self.distribution.pmf(i),
            None => 0.0,
        }
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::sampling::Rng;

    fn quad_light(two_sided: bool) -> Light {
        // A unit square at z = 1 facing down (-z).
        let t = vec![
            [Vec3::new(0.0, 0.0, 1.0), Vec3::new(0.0, 1.0, 1.0), Vec3::new(1.0, 0.0, 1.0)],
            [Vec3::new(1.0, 0.0, 1.0), Vec3::new(0.0, 1.0, 1.0), Vec3::new(1.0, 1.0, 1.0)],
        ];
        let normals = vec![-Vec3::Z, -Vec3::Z];
        Light::Area {
            shape: EmitterShape::Triangles {
                triangles: t,
                normals,
                by_area: Distribution1D::new(&[0.5, 0.5]),
                area: 1.0,
            },
            radiance: Vec3::ONE,
            two_sided,
        }
    }

    #[test]
    fn area_light_irradiance_matches_form_factor() {
        // Irradiance at the origin from a unit square at height 1 over one of its corners:
        // E = L pi F with the form factor of a corner-aligned a x b rectangle at distance 1:
        // pi F = (1/2)[A/sqrt(1+A^2) atan(B/sqrt(1+A^2)) + B/sqrt(1+B^2) atan(A/sqrt(1+B^2))].
        let light = quad_light(false);
        let ctx = LightSampleContext { p: Vec3::ZERO, p_error: Vec3::ZERO, n: Vec3::Z, p64: DVec3::ZERO };
        let mut rng = Rng::new(2, 2);
        let n = 200_000;
        let mut e = 0.0f64;
        for _ in 0..n {
            if let Some(s) = light.sample_li(&ctx, rng.uniform2()) {
                e += f64::from(s.li.x * s.wi.z.max(0.0) / s.pdf);
            }
        }
        e /= f64::from(n);
        let a: f64 = 1.0;
        let s = (a * a + 1.0).sqrt();
        let exact = 0.5 * (a / s * (a / s).atan() + a / s * (a / s).atan());
        assert!((e - exact).abs() < 0.01 * exact, "{e} vs {exact}");
        // From above the light (its back side) nothing arrives.
        let above = LightSampleContext { p: Vec3::new(0.5, 0.5, 2.0), ..ctx };
        assert!(light.sample_li(&above, Vec2::splat(0.3)).is_none());
        assert!(quad_light(true).sample_li(&above, Vec2::splat(0.3)).is_some());
    }

    #[test]
    fn spot_matches_renderman() {
        let s = Light::spot(Vec3::ZERO, Vec3::Z, Vec3::ONE, 30f32.to_radians(), 5f32.to_radians(), 2.0);
        let ctx = |p: Vec3| LightSampleContext { p, p_error: Vec3::ZERO, n: Vec3::ZERO, p64: p.as_dvec3() };
        // On the axis at distance 2: Cl = 1 / 4.
        let on_axis = s.sample_li(&ctx(Vec3::new(0.0, 0.0, 2.0)), Vec2::ZERO).unwrap();
        assert!((on_axis.li.x - 0.25).abs() < 1e-6);
        // Outside the cone: nothing.
        assert!(s.sample_li(&ctx(Vec3::new(2.0, 0.0, 1.0)), Vec2::ZERO).is_none());
        // Power: 2 pi * integral of cos^2 over [cos 30, 1] with a smooth edge: between the
        // hard cone at 25 and at 30 degrees.
        let p = s.power(1.0).x;
        let hard = |deg: f32| 2.0 * PI * (1.0 - deg.to_radians().cos().powi(3)) / 3.0;
        assert!(p > hard(25.0) && p < hard(30.0), "{p}");
    }

    #[test]
    fn pdf_li_matches_sampling_density() {
        let light = quad_light(false);
        let ctx = LightSampleContext { p: Vec3::ZERO, p_error: Vec3::ZERO, n: Vec3::Z, p64: DVec3::ZERO };
        let s = light.sample_li(&ctx, Vec2::new(0.3, 0.6)).unwrap();
        let (p, _, n) = s.p_light.unwrap();
        let pdf = light.pdf_li(DVec3::ZERO, s.wi, p.as_dvec3(), n);
        assert!((pdf - s.pdf).abs() < 1e-4 * s.pdf);
    }

    /// A whole sphere of radius 0.5 about its object-space origin.
    fn sphere_of_radius_half() -> crate::shapes::Quadric {
        crate::shapes::Quadric::new(&rib_parser::scene::Shape::Sphere {
            radius: 0.5,
            z_min: -0.5,
            z_max: 0.5,
            theta_max_degrees: 360.0,
        })
        .unwrap()
    }

    /// Photons carry `Le |cos| / (pdf_pos pdf_dir)`: their mean over many emissions must be the
    /// light's power, for every kind of light (what a photon mapper relies on).
    #[test]
    fn emission_sampling_carries_the_power() {
        let spot =
            Light::spot(Vec3::ZERO, Vec3::new(0.0, -1.0, 0.2), Vec3::new(2.0, 1.0, 0.5), 0.5, 0.1, 1.5);
        let q = sphere_of_radius_half();
        let m = DMat4::from_scale_rotation_translation(
            DVec3::new(1.0, 2.0, 0.5),
            glam::DQuat::from_rotation_x(0.3),
            DVec3::ONE,
        );
        let inv = m.inverse();
        let det = glam::DMat3::from_mat4(m).determinant();
        let ellipsoid = Light::Area {
            shape: EmitterShape::Quadric {
                quadric: q,
                render_from_object: m,
                object_from_render: inv,
                det,
                flip: false,
                sphere: None,
                area: quadric_area(&q, &inv, det),
            },
            radiance: Vec3::splat(3.0),
            two_sided: false,
        };
        let lights = [
            Light::Point { position: Vec3::ONE, intensity: Vec3::new(1.0, 2.0, 3.0) },
            spot,
            Light::Distant { direction: Vec3::new(0.0, -1.0, 0.0), irradiance: Vec3::ONE },
            quad_light(false),
            quad_light(true),
            ellipsoid,
            Light::Environment(Arc::new(
                EnvironmentLight::new(Vec3::new(0.5, 1.0, 2.0), None, glam::DMat3::IDENTITY).unwrap(),
            )),
            Light::Environment(Arc::new(
                EnvironmentLight::new(
                    Vec3::ONE,
                    Some(Arc::new(
                        crate::texture::Texture::from_rgb(
                            32,
                            16,
                            (0..512).map(|i| Vec3::new((i % 7) as f32, 1.0, 0.1 * (i % 3) as f32)).collect(),
                        )
                        .unwrap(),
                    )),
                    glam::DMat3::from_rotation_y(0.7),
                )
                .unwrap(),
            )),
        ];
        let mut rng = Rng::new(8, 8);
        for light in &lights {
            let n = 100_000;
            let mut sum = Vec3::ZERO;
            for _ in 0..n {
                if let Some(s) =
                    light.sample_le(rng.uniform2(), rng.uniform2(), rng.uniform(), (Vec3::ZERO, 2.0))
                {
                    let cos = if s.n == Vec3::ZERO { 1.0 } else { s.n.dot(s.direction).abs() };
                    sum += s.le * cos / (s.pdf_pos * s.pdf_dir);
                }
            }
            let mc = sum / n as f32;
            let power = light.power(2.0);
            assert!(
                (mc - power).abs().max_element() < 0.02 * power.max_element(),
                "{light:?}: {mc} vs {power}"
            );
        }
    }

    /// A sphere light seen from outside is sampled by its cone, which [`Light::sample_li`]
    /// calls with a context of the reference point alone: the samples are those of the full
    /// context, bit for bit, whatever its error bounds and normal (zero, random, infinite or
    /// NaN). Fails if the cone ever reads more of the context than the points it is given.
    #[test]
    fn sphere_cone_gets_all_it_reads_of_the_context() {
        let q = sphere_of_radius_half();
        let centre = DVec3::new(0.3, 1.0, -0.2);
        let m = DMat4::from_translation(centre);
        let inv = m.inverse();
        let mut rng = Rng::new(17, 5);
        let mut sampled = 0;
        for flip in [false, true] {
            let light = Light::Area {
                shape: EmitterShape::Quadric {
                    quadric: q,
                    render_from_object: m,
                    object_from_render: inv,
                    det: 1.0,
                    flip,
                    sphere: Some((centre, 0.5)),
                    area: quadric_area(&q, &inv, 1.0),
                },
                radiance: Vec3::new(1.0, 2.0, 0.5),
                two_sided: flip,
            };
            let odd = [Vec3::ZERO, Vec3::INFINITY, Vec3::NAN, Vec3::new(-0.0, f32::MIN_POSITIVE, 1e30)];
            for k in 0..20_000 {
                let p = (crate::sampling::sample_uniform_sphere(rng.uniform2())
                    * (0.6 + 4.0 * rng.uniform()))
                .as_dvec3()
                    + centre;
                let random = || crate::sampling::sample_uniform_sphere(Rng::new(k, 1).uniform2());
                let (p_error, n) = if k % 5 == 0 {
                    (odd[k as usize % 4], odd[(k as usize / 5) % 4])
                } else {
                    (random() * 1e-3, random())
                };
                let ctx = LightSampleContext { p: p.as_vec3(), p_error, n, p64: p };
                let u = rng.uniform2();
                let Light::Area { shape: EmitterShape::Quadric { sphere: Some((c, r)), flip, .. }, .. } =
                    &light
                else {
                    unreachable!()
                };
                let bits = |s: Option<LightLiSample>| {
                    s.map(|s| {
                        let (pl, err, n) = s.p_light.unwrap();
                        [s.li, s.wi, pl, err, n]
                            .map(|v| v.to_array().map(f32::to_bits))
                            .concat()
                            .into_iter()
                            .chain([s.pdf.to_bits(), u32::from(s.is_delta)])
                            .collect::<Vec<_>>()
                    })
                };
                let through_sample_li = light.sample_li(&ctx, u);
                if ctx.p64.distance_squared(*c) > r * r * (1.0 + 1e-6) {
                    let direct = light.sample_sphere_cone(&ctx, *c, *r, *flip, u);
                    assert_eq!(bits(through_sample_li), bits(direct), "{ctx:?} {u}");
                    sampled += usize::from(direct.is_some());
                }
            }
        }
        assert!(sampled > 20_000, "{sampled} samples compared");
    }

    #[test]
    fn light_set_picks_by_power() {
        let lights = vec![
            Light::Point { position: Vec3::ZERO, intensity: Vec3::ONE },
            Light::Point { position: Vec3::ZERO, intensity: Vec3::splat(3.0) },
            Light::Ambient { color: Vec3::splat(0.1) },
        ];
        let set = LightSet::new(&lights, &[0, 1, 2], 1.0);
        assert!((set.pmf(1) - 0.75).abs() < 1e-6);
        assert_eq!(set.pmf(2), 0.0);
        assert_eq!(set.ambient, Vec3::splat(0.1));
        let only_first = LightSet::new(&lights, &[0], 1.0);
        assert_eq!(only_first.pmf(1), 0.0);
        assert_eq!(only_first.pick(0.99).unwrap().0, 0);
    }
}
