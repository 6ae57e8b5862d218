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

mod lobe;
#[cfg(test)]
mod tests;

pub use lobe::{Lobe, fresnel_dielectric};

use crate::math::Frame;
use crate::sampling::sample_cosine_hemisphere;
use glam::{Vec2, Vec3};
use lobe::{lobe_f, lobe_f_pdf, lobe_pdf, reflect, refract, same_hemisphere};
use std::f32::consts::PI;

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
/// The lobes past `count` are left over from an earlier BSDF written in the same place
/// ([`Bsdf::reset`]) and never read; equality compares the frame, the normal and the lobes in
/// use.
#[derive(Clone, Debug)]
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

impl PartialEq for Bsdf {
    fn eq(&self, other: &Bsdf) -> bool {
        self.frame == other.frame
            && self.ng == other.ng
            && self.lobes() == other.lobes()
            && self.flags_of_lobes() == other.flags_of_lobes()
            && self.lobe_weights[..self.count] == other.lobe_weights[..other.count]
    }
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

    /// Makes this the BSDF of no lobes in `frame` with geometric normal `ng`, as
    /// [`Bsdf::new`] would, without writing the lobes' storage: every read stops at the lobes
    /// in use. Where a record is written in place once per path vertex (the wavefront's), the
    /// new BSDF zeroed four lobes only for the first [`Bsdf::add`] to write over one.
    #[inline]
    pub fn reset(&mut self, frame: Frame, ng: Vec3) {
        self.frame = frame;
        self.ng = ng;
        self.count = 0;
    }

    /// Adds a lobe (lobes beyond four, and lobes that cannot scatter, are dropped). Inline:
    /// the wavefront's x86-64-v3 batch (`wavefront::render_batch`) compiles it with its own
    /// features rather than calling baseline code.
    #[inline]
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
