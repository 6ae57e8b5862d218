//! The lobes a BSDF sums: each lobe's value and density in the shading frame, and the
//! geometry they share (Fresnel, reflection and refraction, the Blinn distribution and its
//! shadowing). [`super::Bsdf`] chooses among them and turns world directions into this frame.

use super::LobeFlags;
use crate::sampling::cosine_hemisphere_pdf;
use glam::Vec3;
use std::f32::consts::{FRAC_1_PI, PI};

/// One lobe, in the shading frame (+z is the shading normal on the viewer's side for opaque
/// materials, the outward normal for dielectrics).
#[derive(Clone, Copy, Debug, PartialEq)]
pub enum Lobe {
    /// `f = r / pi`.
    Lambert { r: Vec3 },
    /// Blinn microfacet reflection scaled by `ks` (which plays Fresnel's part).
    Blinn { ks: Vec3, exponent: f32 },
    /// Perfect mirror reflection with reflectance `r`.
    SpecularReflection { r: Vec3 },
    /// Smooth dielectric: index `eta` on the -z side, 1 on the +z side; both the reflected and
    /// the transmitted parts are multiplied by `r` and `t`.
    Dielectric { eta: f32, r: Vec3, t: Vec3 },
}

impl Lobe {
    pub fn flags(&self) -> LobeFlags {
        match self {
            Lobe::Lambert { .. } => LobeFlags::DIFFUSE | LobeFlags::REFLECTION,
            Lobe::Blinn { .. } => LobeFlags::GLOSSY | LobeFlags::REFLECTION,
            Lobe::SpecularReflection { .. } => LobeFlags::SPECULAR | LobeFlags::REFLECTION,
            Lobe::Dielectric { .. } => LobeFlags::SPECULAR | LobeFlags::REFLECTION | LobeFlags::TRANSMISSION,
        }
    }

    /// A weight for choosing this lobe when sampling: its rough albedo.
    pub(super) fn sampling_weight(&self) -> f32 {
        let w = match self {
            Lobe::Lambert { r } => r.max_element(),
            Lobe::Blinn { ks, .. } => ks.max_element(),
            Lobe::SpecularReflection { r } => r.max_element(),
            Lobe::Dielectric { r, t, .. } => r.max_element().max(t.max_element()),
        };
        if w.is_finite() { w.max(0.0) } else { 0.0 }
    }
}

#[inline]
fn cos_theta(w: Vec3) -> f32 {
    w.z
}

#[inline]
pub(super) fn same_hemisphere(a: Vec3, b: Vec3) -> bool {
    a.z * b.z > 0.0
}

/// Exact unpolarised Fresnel reflectance of a dielectric interface for light arriving at cosine
/// `cos_i` (positive on the side with index 1), relative index `eta` (inside / outside).
pub fn fresnel_dielectric(cos_i: f32, eta: f32) -> f32 {
    let mut cos_i = cos_i.clamp(-1.0, 1.0);
    let mut eta = eta;
    if cos_i < 0.0 {
        eta = 1.0 / eta;
        cos_i = -cos_i;
    }
    let sin2_i = 1.0 - cos_i * cos_i;
    let sin2_t = sin2_i / (eta * eta);
    if sin2_t >= 1.0 {
        return 1.0;
    }
    let cos_t = (1.0 - sin2_t).max(0.0).sqrt();
    let r_parl = (eta * cos_i - cos_t) / (eta * cos_i + cos_t);
    let r_perp = (cos_i - eta * cos_t) / (cos_i + eta * cos_t);
    0.5 * (r_parl * r_parl + r_perp * r_perp)
}

/// Refracts `wi` (pointing away from the surface on the side of `n`) through an interface of
/// relative index `eta`; `None` on total internal reflection.
pub(super) fn refract(wi: Vec3, n: Vec3, eta: f32) -> Option<Vec3> {
    let cos_i = n.dot(wi);
    let sin2_i = (1.0 - cos_i * cos_i).max(0.0);
    let sin2_t = sin2_i / (eta * eta);
    if sin2_t >= 1.0 {
        return None;
    }
    let cos_t = (1.0 - sin2_t).sqrt();
    Some(-wi / eta + n * (cos_i / eta - cos_t))
}

#[inline]
pub(super) fn reflect(wo: Vec3, n: Vec3) -> Vec3 {
    -wo + n * (2.0 * wo.dot(n))
}

/// The Blinn distribution `D(h) = (e + 2) / (2 pi) cos^e(theta_h)`.
#[inline]
fn blinn_d(cos_h: f32, e: f32) -> f32 {
    if cos_h <= 0.0 { 0.0 } else { (e + 2.0) * (0.5 * FRAC_1_PI) * cos_h.powf(e) }
}

/// V-cavity shadowing-masking (Torrance and Sparrow; pbrt-v1).
#[inline]
fn v_cavity_g(wo: Vec3, wi: Vec3, wh: Vec3) -> f32 {
    let n_dot_h = cos_theta(wh).abs();
    let n_dot_o = cos_theta(wo).abs();
    let n_dot_i = cos_theta(wi).abs();
    let o_dot_h = wo.dot(wh).abs();
    if o_dot_h == 0.0 {
        return 0.0;
    }
    (2.0 * n_dot_h * n_dot_o / o_dot_h).min(2.0 * n_dot_h * n_dot_i / o_dot_h).min(1.0)
}

pub(super) fn lobe_f(lobe: &Lobe, wo: Vec3, wi: Vec3) -> Vec3 {
    match *lobe {
        Lobe::Lambert { r } => {
            if same_hemisphere(wo, wi) {
                r * FRAC_1_PI
            } else {
                Vec3::ZERO
            }
        }
        Lobe::Blinn { ks, exponent } => {
            if !same_hemisphere(wo, wi) {
                return Vec3::ZERO;
            }
            let cos_o = cos_theta(wo).abs();
            let cos_i = cos_theta(wi).abs();
            if cos_o == 0.0 || cos_i == 0.0 {
                return Vec3::ZERO;
            }
            let wh = (wo + wi).normalize_or_zero();
            if wh == Vec3::ZERO {
                return Vec3::ZERO;
            }
            let wh = if wh.z < 0.0 { -wh } else { wh };
            ks * (blinn_d(wh.z, exponent) * v_cavity_g(wo, wi, wh) / (4.0 * cos_o * cos_i))
        }
        Lobe::SpecularReflection { .. } | Lobe::Dielectric { .. } => Vec3::ZERO,
    }
}

/// [`lobe_f`] and [`lobe_pdf`] of one lobe together: the glossy lobe's half vector and
/// `cos^e` are computed once. Bit for bit the values of the two functions.
pub(super) fn lobe_f_pdf(lobe: &Lobe, wo: Vec3, wi: Vec3) -> (Vec3, f32) {
    match *lobe {
        Lobe::Lambert { r } => {
            if same_hemisphere(wo, wi) {
                (r * FRAC_1_PI, cosine_hemisphere_pdf(wi.z.abs()))
            } else {
                (Vec3::ZERO, 0.0)
            }
        }
        Lobe::Blinn { ks, exponent } => blinn_f_pdf(ks, exponent, wo, wi),
        Lobe::SpecularReflection { .. } | Lobe::Dielectric { .. } => (Vec3::ZERO, 0.0),
    }
}

/// The glossy lobe's value and density. Kept out of line: inlined into the loop over lobes,
/// the compiler hoisted the half vector's normalisation above the loop, so a matte surface
/// paid for it on every evaluation.
#[inline(never)]
fn blinn_f_pdf(ks: Vec3, exponent: f32, wo: Vec3, wi: Vec3) -> (Vec3, f32) {
    // Both nonzero when in the same hemisphere.
    if !same_hemisphere(wo, wi) {
        return (Vec3::ZERO, 0.0);
    }
    let wh = (wo + wi).normalize_or_zero();
    if wh == Vec3::ZERO {
        return (Vec3::ZERO, 0.0);
    }
    let cos_h = wh.z.abs();
    let power = cos_h.powf(exponent);
    let o_dot_h = wo.dot(wh).abs();
    let pdf = if o_dot_h == 0.0 { 0.0 } else { (exponent + 1.0) * power / (2.0 * PI * 4.0 * o_dot_h) };
    // `lobe_f` flips the half vector to +z; its cosine is then `cos_h` unless it is zero.
    let wh_up = if wh.z < 0.0 { -wh } else { wh };
    let d = if wh_up.z <= 0.0 { 0.0 } else { (exponent + 2.0) * (0.5 * FRAC_1_PI) * power };
    let (cos_o, cos_i) = (cos_theta(wo).abs(), cos_theta(wi).abs());
    let f = ks * (d * v_cavity_g(wo, wi, wh_up) / (4.0 * cos_o * cos_i));
    (f, pdf)
}

pub(super) fn lobe_pdf(lobe: &Lobe, wo: Vec3, wi: Vec3) -> f32 {
    match *lobe {
        Lobe::Lambert { .. } => {
            if same_hemisphere(wo, wi) {
                cosine_hemisphere_pdf(wi.z.abs())
            } else {
                0.0
            }
        }
        Lobe::Blinn { exponent, .. } => {
            if !same_hemisphere(wo, wi) {
                return 0.0;
            }
            let wh = (wo + wi).normalize_or_zero();
            if wh == Vec3::ZERO {
                return 0.0;
            }
            let cos_h = wh.z.abs();
            let o_dot_h = wo.dot(wh).abs();
            if o_dot_h == 0.0 {
                return 0.0;
            }
            (exponent + 1.0) * cos_h.powf(exponent) / (2.0 * PI * 4.0 * o_dot_h)
        }
        Lobe::SpecularReflection { .. } | Lobe::Dielectric { .. } => 0.0,
    }
}
