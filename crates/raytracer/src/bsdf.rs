//! Scattering functions: a BSDF is a small sum of lobes in a shading frame.
//!
//! Lobes: Lambertian reflection, a glossy Blinn microfacet lobe (pbrt-v1's `Blinn` distribution
//! with the Torrance-Sparrow V-cavity shadowing, exponent `1 / roughness` as RenderMan's
//! `specular()` uses it), perfect specular reflection, and a smooth dielectric interface with
//! exact unpolarised Fresnel. Every lobe is flagged diffuse, glossy or specular so that an
//! integrator can evaluate or sample a part of the BSDF only (a photon map stores photons on
//! the non-specular part and follows the specular part).
//!
//! Directions point away from the surface (`wo` toward the viewer, `wi` toward the light).

use crate::math::Frame;
use crate::sampling::{cosine_hemisphere_pdf, sample_cosine_hemisphere};
use glam::{Vec2, Vec3};
use std::f32::consts::{FRAC_1_PI, PI};

/// Which quantity is carried along a path: radiance from the camera, or importance (photons)
/// from the lights. Refraction scales radiance by `1 / eta^2` but not importance.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum TransportMode {
    Radiance,
    Importance,
}

/// Lobe categories, combinable as a mask.
#[derive(Clone, Copy, Debug, PartialEq, Eq, Hash)]
pub struct LobeFlags(u8);

impl LobeFlags {
    pub const DIFFUSE: LobeFlags = LobeFlags(1);
    pub const GLOSSY: LobeFlags = LobeFlags(2);
    pub const SPECULAR: LobeFlags = LobeFlags(4);
    pub const REFLECTION: LobeFlags = LobeFlags(8);
    pub const TRANSMISSION: LobeFlags = LobeFlags(16);
    pub const NONE: LobeFlags = LobeFlags(0);
    /// Every category.
    pub const ALL: LobeFlags = LobeFlags(31);
    /// Diffuse and glossy (everything with a density), both directions.
    pub const NON_SPECULAR: LobeFlags = LobeFlags(1 | 2 | 8 | 16);
    /// Specular lobes, both directions.
    pub const SPECULAR_ALL: LobeFlags = LobeFlags(4 | 8 | 16);

    #[inline]
    pub fn contains(self, other: LobeFlags) -> bool {
        self.0 & other.0 == other.0
    }

    #[inline]
    pub fn intersects(self, other: LobeFlags) -> bool {
        self.0 & other.0 != 0
    }

    /// A lobe of type `self` passes the mask `mask` when its category (diffuse, glossy or
    /// specular) and its direction (reflection or transmission) are both allowed.
    #[inline]
    pub fn allowed_by(self, mask: LobeFlags) -> bool {
        let category = LobeFlags(self.0 & 7);
        let direction = LobeFlags(self.0 & 24);
        mask.intersects(category) && mask.intersects(direction)
    }

    #[inline]
    pub fn is_specular(self) -> bool {
        self.intersects(LobeFlags::SPECULAR)
    }
}

impl std::ops::BitAnd for LobeFlags {
    type Output = LobeFlags;
    fn bitand(self, rhs: LobeFlags) -> LobeFlags {
        LobeFlags(self.0 & rhs.0)
    }
}

impl std::ops::BitOr for LobeFlags {
    type Output = LobeFlags;
    fn bitor(self, rhs: LobeFlags) -> LobeFlags {
        LobeFlags(self.0 | rhs.0)
    }
}

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
    fn sampling_weight(&self) -> f32 {
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
fn same_hemisphere(a: Vec3, b: Vec3) -> bool {
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
fn refract(wi: Vec3, n: Vec3, eta: f32) -> Option<Vec3> {
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
fn reflect(wo: Vec3, n: Vec3) -> Vec3 {
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

/// A sampled direction.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct BsdfSample {
    /// BSDF value (for specular lobes: the delta's weight divided by `|cos wi|`).
    pub f: Vec3,
    /// World-space direction.
    pub wi: Vec3,
    /// Density (solid angle) for non-specular samples; the discrete probability for specular ones.
    pub pdf: f32,
    pub flags: LobeFlags,
    /// Relative index crossed (1 for reflection), for Russian roulette's eta scaling.
    pub eta: f32,
}

impl BsdfSample {
    pub fn is_specular(&self) -> bool {
        self.flags.is_specular()
    }
}

/// Up to four lobes in a shading frame, plus the geometric normal used to tell reflection from
/// transmission.
#[derive(Clone, Debug, PartialEq)]
pub struct Bsdf {
    pub frame: Frame,
    /// Geometric normal, on the same side as `frame.z`.
    pub ng: Vec3,
    lobes: [Lobe; 4],
    /// Each lobe's flags and sampling weight, computed once when it is added: every
    /// evaluation and sample reads them, several times per path vertex.
    lobe_flags: [LobeFlags; 4],
    lobe_weights: [f32; 4],
    count: usize,
}

impl Bsdf {
    /// An empty BSDF (black) with the given frame.
    pub fn new(frame: Frame, ng: Vec3) -> Bsdf {
        Bsdf {
            frame,
            ng,
            lobes: [Lobe::Lambert { r: Vec3::ZERO }; 4],
            lobe_flags: [LobeFlags::NONE; 4],
            lobe_weights: [0.0; 4],
            count: 0,
        }
    }

    /// Adds a lobe (lobes beyond four, and lobes that cannot scatter, are dropped).
    pub fn add(&mut self, lobe: Lobe) {
        let weight = lobe.sampling_weight();
        if self.count < self.lobes.len() && weight > 0.0 {
            self.lobes[self.count] = lobe;
            self.lobe_flags[self.count] = lobe.flags();
            self.lobe_weights[self.count] = weight;
            self.count += 1;
        }
    }

    pub fn lobes(&self) -> &[Lobe] {
        &self.lobes[..self.count]
    }

    pub fn is_black(&self) -> bool {
        self.count == 0
    }

    /// The flags of the lobes, one per lobe.
    fn flags_of_lobes(&self) -> &[LobeFlags] {
        &self.lobe_flags[..self.count]
    }

    /// The union of the lobes' flags.
    pub fn flags(&self) -> LobeFlags {
        self.flags_of_lobes().iter().fold(LobeFlags::NONE, |acc, &l| acc | l)
    }

    /// True when some lobe has a density (diffuse or glossy): light sampling can help.
    pub fn has_non_specular(&self) -> bool {
        self.flags_of_lobes().iter().any(|l| !l.is_specular())
    }

    /// Number of lobes passing `mask`.
    pub fn count_matching(&self, mask: LobeFlags) -> usize {
        self.flags_of_lobes().iter().filter(|l| l.allowed_by(mask)).count()
    }

    /// Evaluates the non-specular lobes allowed by `mask` for world directions `wo`, `wi`.
    pub fn f(&self, wo_world: Vec3, wi_world: Vec3, mask: LobeFlags) -> Vec3 {
        let wo = self.frame.to_local(wo_world);
        let wi = self.frame.to_local(wi_world);
        self.f_local(wo, wi, self.reflects(wo_world, wi_world), mask)
    }

    /// Density of sampling `wi` with [`Bsdf::sample`] restricted to `mask` (non-specular lobes).
    pub fn pdf(&self, wo_world: Vec3, wi_world: Vec3, mask: LobeFlags) -> f32 {
        let wo = self.frame.to_local(wo_world);
        let wi = self.frame.to_local(wi_world);
        self.pdf_local(wo, wi, self.total_weight(mask), mask)
    }

    /// [`Bsdf::f`] and [`Bsdf::pdf`] together, as direct lighting with MIS needs them: the
    /// directions go into the shading frame once and each lobe is evaluated once (a glossy
    /// lobe's half vector and power serve both). Bit for bit the values of the two calls.
    pub fn f_and_pdf(&self, wo_world: Vec3, wi_world: Vec3, mask: LobeFlags) -> (Vec3, f32) {
        let wo = self.frame.to_local(wo_world);
        let wi = self.frame.to_local(wi_world);
        self.f_pdf_local(wo, wi, self.reflects(wo_world, wi_world), self.total_weight(mask), mask)
    }

    /// Reflection or transmission is decided by the geometric normal (no light leaks through
    /// interpolated shading normals).
    #[inline]
    fn reflects(&self, wo_world: Vec3, wi_world: Vec3) -> bool {
        wi_world.dot(self.ng) * wo_world.dot(self.ng) > 0.0
    }

    fn f_local(&self, wo: Vec3, wi: Vec3, reflect: bool, mask: LobeFlags) -> Vec3 {
        if wo.z == 0.0 {
            return Vec3::ZERO;
        }
        let wants = if reflect { LobeFlags::REFLECTION } else { LobeFlags::TRANSMISSION };
        let mut f = Vec3::ZERO;
        for (lobe, &flags) in self.lobes().iter().zip(self.flags_of_lobes()) {
            if flags.is_specular() || !flags.allowed_by(mask) || !flags.intersects(wants) {
                continue;
            }
            f += lobe_f(lobe, wo, wi);
        }
        f
    }

    fn pdf_local(&self, wo: Vec3, wi: Vec3, total_weight: f32, mask: LobeFlags) -> f32 {
        if wo.z == 0.0 || total_weight <= 0.0 {
            return 0.0;
        }
        let mut pdf = 0.0;
        for ((lobe, &flags), &weight) in self.lobes().iter().zip(&self.lobe_flags).zip(&self.lobe_weights) {
            if !flags.allowed_by(mask) || flags.is_specular() {
                continue;
            }
            pdf += weight / total_weight * lobe_pdf(lobe, wo, wi);
        }
        pdf
    }

    /// `f_local` and `pdf_local` in one pass over the lobes, summing in the same order (so the
    /// results are bit-identical to the two separate calls). A BSDF of one lobe (matte, metal:
    /// the commonest) evaluates that lobe directly.
    fn f_pdf_local(
        &self,
        wo: Vec3,
        wi: Vec3,
        reflect: bool,
        total_weight: f32,
        mask: LobeFlags,
    ) -> (Vec3, f32) {
        if wo.z == 0.0 {
            return (Vec3::ZERO, 0.0);
        }
        let with_pdf = total_weight > 0.0;
        let wants = if reflect { LobeFlags::REFLECTION } else { LobeFlags::TRANSMISSION };
        if self.count == 1 {
            let flags = self.lobe_flags[0];
            if flags.is_specular() || !flags.allowed_by(mask) {
                return (Vec3::ZERO, 0.0);
            }
            let (lobe_value, lobe_density) = lobe_f_pdf(&self.lobes[0], wo, wi);
            // The sums of the general loop below, from zero, so that the bits are the same.
            let f = if flags.intersects(wants) { Vec3::ZERO + lobe_value } else { Vec3::ZERO };
            let pdf = if with_pdf { 0.0 + self.lobe_weights[0] / total_weight * lobe_density } else { 0.0 };
            return (f, pdf);
        }
        let mut f = Vec3::ZERO;
        let mut pdf = 0.0;
        for ((lobe, &flags), &weight) in self.lobes().iter().zip(&self.lobe_flags).zip(&self.lobe_weights) {
            if flags.is_specular() || !flags.allowed_by(mask) {
                continue;
            }
            let (lobe_value, lobe_density) = lobe_f_pdf(lobe, wo, wi);
            if flags.intersects(wants) {
                f += lobe_value;
            }
            if with_pdf {
                pdf += weight / total_weight * lobe_density;
            }
        }
        (f, pdf)
    }

    /// The summed sampling weight of the lobes allowed by `mask`.
    fn total_weight(&self, mask: LobeFlags) -> f32 {
        let mut total = 0.0;
        for (&flags, &weight) in self.flags_of_lobes().iter().zip(&self.lobe_weights) {
            if flags.allowed_by(mask) {
                total += weight;
            }
        }
        total
    }

    /// Samples a direction from the lobes allowed by `mask`: a lobe is picked in proportion to
    /// its albedo, then a direction from it. For a non-specular pick the returned `f` and `pdf`
    /// sum over all allowed non-specular lobes (so MIS sees the full BSDF).
    pub fn sample(
        &self,
        wo_world: Vec3,
        u_lobe: f32,
        u: Vec2,
        mode: TransportMode,
        mask: LobeFlags,
    ) -> Option<BsdfSample> {
        let wo = self.frame.to_local(wo_world);
        if wo.z == 0.0 || !wo.is_finite() {
            return None;
        }
        let total = self.total_weight(mask);
        if !(total > 0.0) {
            return None;
        }
        // Pick a lobe in proportion to its weight (every stored weight is positive).
        let mut target = u_lobe * total;
        let mut chosen = None;
        for (i, (&flags, &w)) in self.flags_of_lobes().iter().zip(&self.lobe_weights).enumerate() {
            if !flags.allowed_by(mask) {
                continue;
            }
            chosen = Some(i);
            if target < w {
                break;
            }
            target -= w;
        }
        let chosen = chosen?;
        let lobe = &self.lobes[chosen];
        let p_lobe = self.lobe_weights[chosen] / total;
        match *lobe {
            Lobe::SpecularReflection { r } => {
                let wi = Vec3::new(-wo.x, -wo.y, wo.z);
                let cos = wi.z.abs();
                if cos == 0.0 {
                    return None;
                }
                Some(BsdfSample {
                    f: r / cos,
                    wi: self.frame.from_local(wi),
                    pdf: p_lobe,
                    flags: self.lobe_flags[chosen],
                    eta: 1.0,
                })
            }
            Lobe::Dielectric { eta, r, t } => {
                let fr = fresnel_dielectric(wo.z, eta);
                let ft = 1.0 - fr;
                // Choose reflection or transmission in proportion to their weights.
                let pr = fr * r.max_element();
                let pt = ft * t.max_element();
                if pr + pt <= 0.0 {
                    return None;
                }
                // Reuse the lobe-choice number for the reflect/transmit decision.
                let u_rt = u.x;
                if u_rt < pr / (pr + pt) {
                    let wi = Vec3::new(-wo.x, -wo.y, wo.z);
                    let cos = wi.z.abs();
                    if cos == 0.0 {
                        return None;
                    }
                    Some(BsdfSample {
                        f: r * fr / cos,
                        wi: self.frame.from_local(wi),
                        pdf: p_lobe * pr / (pr + pt),
                        flags: LobeFlags::SPECULAR | LobeFlags::REFLECTION,
                        eta: 1.0,
                    })
                } else {
                    let entering = wo.z > 0.0;
                    let n = if entering { Vec3::Z } else { -Vec3::Z };
                    let rel = if entering { eta } else { 1.0 / eta };
                    let wi = refract(wo, n, rel)?;
                    let cos = wi.z.abs();
                    if cos == 0.0 || !wi.is_finite() {
                        return None;
                    }
                    let mut f = t * ft / cos;
                    if mode == TransportMode::Radiance {
                        f /= rel * rel;
                    }
                    Some(BsdfSample {
                        f,
                        wi: self.frame.from_local(wi),
                        pdf: p_lobe * pt / (pr + pt),
                        flags: LobeFlags::SPECULAR | LobeFlags::TRANSMISSION,
                        eta: rel,
                    })
                }
            }
            Lobe::Lambert { .. } | Lobe::Blinn { .. } => {
                let wi = if let Lobe::Blinn { exponent, .. } = *lobe {
                    let cos_h = u.x.powf(1.0 / (exponent + 1.0));
                    let sin_h = (1.0 - cos_h * cos_h).max(0.0).sqrt();
                    let phi = 2.0 * PI * u.y;
                    let mut wh = Vec3::new(sin_h * phi.cos(), sin_h * phi.sin(), cos_h);
                    if wo.z < 0.0 {
                        wh = -wh;
                    }
                    reflect(wo, wh)
                } else {
                    let mut w = sample_cosine_hemisphere(u);
                    if wo.z < 0.0 {
                        w.z = -w.z;
                    }
                    w
                };
                if !same_hemisphere(wo, wi) {
                    return None;
                }
                let wi_world = self.frame.from_local(wi);
                // The value and density of the whole allowed non-specular part (what MIS
                // needs), in one pass: the lobe choice above also counted the specular lobes'
                // weights.
                let reflect = self.reflects(wo_world, wi_world);
                let (f, pdf) = self.f_pdf_local(wo, wi, reflect, total, non_specular(mask));
                if !(pdf > 0.0) {
                    return None;
                }
                Some(BsdfSample { f, wi: wi_world, pdf, flags: self.lobe_flags[chosen], eta: 1.0 })
            }
        }
    }

    /// Every specular direction of the BSDF with its weight (`f |cos| / pdf` of a deterministic
    /// choice): a mirror gives one, a dielectric its reflection and its refraction. Whitted-style
    /// integrators follow all of them.
    pub fn specular_directions(&self, wo_world: Vec3, mode: TransportMode) -> SpecularDirections {
        let wo = self.frame.to_local(wo_world);
        let mut out = SpecularDirections::default();
        if wo.z == 0.0 || !wo.is_finite() {
            return out;
        }
        let mirror = Vec3::new(-wo.x, -wo.y, wo.z);
        for lobe in self.lobes() {
            match *lobe {
                Lobe::SpecularReflection { r } => {
                    out.push((self.frame.from_local(mirror), r, LobeFlags::SPECULAR | LobeFlags::REFLECTION))
                }
                Lobe::Dielectric { eta, r, t } => {
                    let fr = fresnel_dielectric(wo.z, eta);
                    if fr > 0.0 {
                        out.push((
                            self.frame.from_local(mirror),
                            r * fr,
                            LobeFlags::SPECULAR | LobeFlags::REFLECTION,
                        ));
                    }
                    let entering = wo.z > 0.0;
                    let n = if entering { Vec3::Z } else { -Vec3::Z };
                    let rel = if entering { eta } else { 1.0 / eta };
                    if fr < 1.0
                        && let Some(wi) = refract(wo, n, rel)
                    {
                        let mut w = t * (1.0 - fr);
                        if mode == TransportMode::Radiance {
                            w /= rel * rel;
                        }
                        out.push((
                            self.frame.from_local(wi),
                            w,
                            LobeFlags::SPECULAR | LobeFlags::TRANSMISSION,
                        ));
                    }
                }
                _ => {}
            }
        }
        out
    }

    /// Hemispherical reflectance estimate of the non-specular part for direction `wo` (used by
    /// photon maps to decide where photons are worth storing and for irradiance estimates).
    pub fn diffuse_reflectance(&self) -> Vec3 {
        self.lobes()
            .iter()
            .map(|l| match l {
                Lobe::Lambert { r } => *r,
                _ => Vec3::ZERO,
            })
            .sum()
    }
}

#[inline]
fn non_specular(mask: LobeFlags) -> LobeFlags {
    LobeFlags(mask.0 & !LobeFlags::SPECULAR.0)
}

fn lobe_f(lobe: &Lobe, wo: Vec3, wi: Vec3) -> Vec3 {
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
fn lobe_f_pdf(lobe: &Lobe, wo: Vec3, wi: Vec3) -> (Vec3, f32) {
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

fn lobe_pdf(lobe: &Lobe, wo: Vec3, wi: Vec3) -> f32 {
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

/// The specular directions of one BSDF, `(direction, weight, lobe)`: at most two per lobe, kept
/// inline so that a Whitted-style bounce allocates nothing.
#[derive(Clone, Copy, Debug)]
pub struct SpecularDirections {
    items: [(Vec3, Vec3, LobeFlags); 8],
    len: usize,
}

impl Default for SpecularDirections {
    fn default() -> Self {
        SpecularDirections { items: [(Vec3::ZERO, Vec3::ZERO, LobeFlags::SPECULAR); 8], len: 0 }
    }
}

impl SpecularDirections {
    /// Four lobes with two directions each fill it exactly, so nothing is ever dropped.
    fn push(&mut self, item: (Vec3, Vec3, LobeFlags)) {
        if let Some(slot) = self.items.get_mut(self.len) {
            *slot = item;
            self.len += 1;
        }
    }
}

impl IntoIterator for SpecularDirections {
    type Item = (Vec3, Vec3, LobeFlags);
    type IntoIter = std::iter::Take<std::array::IntoIter<(Vec3, Vec3, LobeFlags), 8>>;

    fn into_iter(self) -> Self::IntoIter {
        self.items.into_iter().take(self.len)
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::sampling::Rng;

    fn frame() -> Frame {
        Frame::from_z(Vec3::Z)
    }

    /// Monte Carlo estimate of the albedo `∫ f cos` by sampling, and a check that f/pdf agree
    /// with f() and pdf() evaluated separately.
    fn albedo(bsdf: &Bsdf, wo: Vec3, n: usize) -> Vec3 {
        let mut rng = Rng::new(11, 3);
        let mut sum = Vec3::ZERO;
        for _ in 0..n {
            if let Some(s) =
                bsdf.sample(wo, rng.uniform(), rng.uniform2(), TransportMode::Radiance, LobeFlags::ALL)
            {
                sum += s.f * s.wi.dot(bsdf.ng).abs() / s.pdf;
                if !s.is_specular() {
                    let f = bsdf.f(wo, s.wi, LobeFlags::ALL);
                    let p = bsdf.pdf(wo, s.wi, LobeFlags::ALL);
                    assert!((f - s.f).length() <= 1e-4 * (1.0 + f.length()));
                    assert!((p - s.pdf).abs() <= 1e-4 * (1.0 + p));
                }
            }
        }
        sum / n as f32
    }

    /// The lobe sets the materials build: matte, plastic, metal, shinymetal, mirror, glass,
    /// and a diffuse lobe under a mirror.
    fn material_like_bsdfs(frame: Frame, ng: Vec3) -> Vec<Bsdf> {
        let sets: [&[Lobe]; 7] = [
            &[Lobe::Lambert { r: Vec3::new(0.7, 0.5, 0.2) }],
            &[Lobe::Lambert { r: Vec3::splat(0.45) }, Lobe::Blinn { ks: Vec3::splat(0.5), exponent: 10.0 }],
            &[Lobe::Blinn { ks: Vec3::new(0.9, 0.6, 0.3), exponent: 250.0 }],
            &[
                Lobe::Blinn { ks: Vec3::splat(0.3), exponent: 1.0 },
                Lobe::SpecularReflection { r: Vec3::splat(0.6) },
            ],
            &[Lobe::SpecularReflection { r: Vec3::ONE }],
            &[Lobe::Dielectric { eta: 1.5, r: Vec3::ONE, t: Vec3::ONE }],
            &[Lobe::Lambert { r: Vec3::splat(0.3) }, Lobe::SpecularReflection { r: Vec3::splat(0.6) }],
        ];
        sets.iter()
            .map(|lobes| {
                let mut b = Bsdf::new(frame, ng);
                for &l in *lobes {
                    b.add(l);
                }
                b
            })
            .collect()
    }

    fn bits(f: Vec3, pdf: f32) -> [u32; 4] {
        [f.x.to_bits(), f.y.to_bits(), f.z.to_bits(), pdf.to_bits()]
    }

    /// The one-pass evaluation (`f_and_pdf`, and the pass `sample` makes after choosing a
    /// direction) gives exactly the bits of the separate `f` and `pdf` evaluations, for every
    /// material's lobes, over directions on both sides, with a shading normal tilted off the
    /// geometric one, under every mask.
    #[test]
    fn one_pass_evaluation_is_bit_identical_to_separate_f_and_pdf() {
        use crate::sampling::sample_uniform_sphere;
        let ns = Vec3::new(0.2, -0.1, 1.0).normalize();
        let frame = Frame::from_z_and_tangent(ns, Vec3::X);
        let masks = [LobeFlags::ALL, LobeFlags::NON_SPECULAR, LobeFlags::DIFFUSE | LobeFlags::REFLECTION];
        let mut rng = Rng::new(5, 9);
        let mut nonzero = 0;
        for bsdf in material_like_bsdfs(frame, Vec3::Z) {
            for _ in 0..4000 {
                let wo = sample_uniform_sphere(rng.uniform2());
                let wi = sample_uniform_sphere(rng.uniform2());
                for mask in masks {
                    let (f, pdf) = bsdf.f_and_pdf(wo, wi, mask);
                    assert_eq!(bits(f, pdf), bits(bsdf.f(wo, wi, mask), bsdf.pdf(wo, wi, mask)), "{bsdf:?}");
                    let (lo, li) = (frame.to_local(wo), frame.to_local(wi));
                    for reflect in [false, true] {
                        let total = bsdf.total_weight(mask);
                        let (f, pdf) = bsdf.f_pdf_local(lo, li, reflect, total, non_specular(mask));
                        let separate = (
                            bsdf.f_local(lo, li, reflect, non_specular(mask)),
                            bsdf.pdf_local(lo, li, total, non_specular(mask)),
                        );
                        assert_eq!(bits(f, pdf), bits(separate.0, separate.1));
                    }
                    nonzero += usize::from(pdf > 0.0);
                }
                for lobe in bsdf.lobes() {
                    let (f, pdf) = lobe_f_pdf(lobe, frame.to_local(wo), frame.to_local(wi));
                    let (lo, li) = (frame.to_local(wo), frame.to_local(wi));
                    assert_eq!(bits(f, pdf), bits(lobe_f(lobe, lo, li), lobe_pdf(lobe, lo, li)));
                }
            }
        }
        // The directions exercised the lobes, not only their zero branches.
        assert!(nonzero > 10_000, "{nonzero}");
    }

    /// A sampled non-specular direction carries the value and density that `f` and `pdf` give
    /// for it.
    #[test]
    fn samples_carry_f_and_pdf_of_the_whole_bsdf() {
        let mut rng = Rng::new(2, 8);
        for bsdf in material_like_bsdfs(frame(), Vec3::Z) {
            for _ in 0..2000 {
                let wo = crate::sampling::sample_uniform_sphere(rng.uniform2());
                let Some(s) =
                    bsdf.sample(wo, rng.uniform(), rng.uniform2(), TransportMode::Radiance, LobeFlags::ALL)
                else {
                    continue;
                };
                if !s.is_specular() {
                    assert_eq!(
                        bits(s.f, s.pdf),
                        bits(bsdf.f(wo, s.wi, LobeFlags::ALL), bsdf.pdf(wo, s.wi, LobeFlags::ALL))
                    );
                }
            }
        }
    }

    #[test]
    fn lambert_albedo_is_r() {
        let mut b = Bsdf::new(frame(), Vec3::Z);
        b.add(Lobe::Lambert { r: Vec3::new(0.2, 0.5, 0.8) });
        let a = albedo(&b, Vec3::new(0.3, 0.1, 0.9).normalize(), 20_000);
        assert!((a - Vec3::new(0.2, 0.5, 0.8)).abs().max_element() < 1e-3, "{a}");
    }

    #[test]
    fn blinn_is_energy_bounded_and_consistent() {
        for e in [1.0, 10.0, 100.0] {
            let mut b = Bsdf::new(frame(), Vec3::Z);
            b.add(Lobe::Blinn { ks: Vec3::ONE, exponent: e });
            let a = albedo(&b, Vec3::new(0.3, 0.0, 0.95).normalize(), 40_000);
            assert!(a.x > 0.3 && a.x <= 1.05, "exponent {e}: albedo {a}");
        }
    }

    #[test]
    fn mixed_lobes_sum_their_albedos() {
        // A diffuse and a mirror lobe: the sampled estimate of the albedo must be their sum
        // (the non-specular density must count the chance of picking the mirror).
        let mut b = Bsdf::new(frame(), Vec3::Z);
        b.add(Lobe::Lambert { r: Vec3::splat(0.3) });
        b.add(Lobe::SpecularReflection { r: Vec3::splat(0.6) });
        let a = albedo(&b, Vec3::new(0.2, 0.1, 0.95).normalize(), 40_000);
        assert!((a.x - 0.9).abs() < 0.01, "{a}");
    }

    #[test]
    fn fresnel_limits() {
        assert!((fresnel_dielectric(1.0, 1.5) - 0.04).abs() < 1e-6);
        assert_eq!(fresnel_dielectric(0.0, 1.5), 1.0);
        // Total internal reflection from inside beyond the critical angle.
        assert_eq!(fresnel_dielectric(-0.3, 1.5), 1.0);
        assert!((fresnel_dielectric(-1.0, 1.5) - 0.04).abs() < 1e-6);
    }

    #[test]
    fn glass_conserves_energy_in_importance_mode() {
        let mut b = Bsdf::new(frame(), Vec3::Z);
        b.add(Lobe::Dielectric { eta: 1.5, r: Vec3::ONE, t: Vec3::ONE });
        let mut rng = Rng::new(1, 2);
        let wo = Vec3::new(0.5, 0.0, 0.8).normalize();
        let mut sum = 0.0;
        let n = 20_000;
        for _ in 0..n {
            let s = b
                .sample(wo, rng.uniform(), rng.uniform2(), TransportMode::Importance, LobeFlags::ALL)
                .unwrap();
            sum += s.f.x * s.wi.z.abs() / s.pdf;
            if s.flags.intersects(LobeFlags::TRANSMISSION) {
                // Snell's law.
                let sin_o = (1.0 - wo.z * wo.z).sqrt();
                let sin_i = (1.0 - s.wi.z * s.wi.z).sqrt();
                assert!((sin_o - 1.5 * sin_i).abs() < 1e-5);
            }
        }
        assert!((sum / n as f32 - 1.0).abs() < 1e-4);
    }

    #[test]
    fn masks_select_parts() {
        let mut b = Bsdf::new(frame(), Vec3::Z);
        b.add(Lobe::Lambert { r: Vec3::splat(0.5) });
        b.add(Lobe::SpecularReflection { r: Vec3::splat(0.5) });
        let wo = Vec3::new(0.0, 0.6, 0.8);
        let mut rng = Rng::new(4, 4);
        for _ in 0..100 {
            let s = b
                .sample(wo, rng.uniform(), rng.uniform2(), TransportMode::Radiance, LobeFlags::SPECULAR_ALL)
                .unwrap();
            assert!(s.is_specular());
            let s = b
                .sample(wo, rng.uniform(), rng.uniform2(), TransportMode::Radiance, LobeFlags::NON_SPECULAR)
                .unwrap();
            assert!(!s.is_specular());
        }
        assert_eq!(b.count_matching(LobeFlags::DIFFUSE | LobeFlags::REFLECTION), 1);
    }
}
