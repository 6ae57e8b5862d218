//! Density estimation: radiance and irradiance from the `k` nearest photons, weighted by a
//! filter kernel (Jensen 2001, ch. 7).

use super::{Photon, unpack_unit};
use crate::bsdf::{Bsdf, LobeFlags};
use crate::photon::clip::Boundaries;
use crate::photon::grid::{GridPhoton, PhotonGrid};
use crate::photon::kdtree::{KdTree, KnnHeap};
use glam::Vec3;
use std::f32::consts::PI;

/// The kernel that weights photons by their distance `d` from the query point, relative to the
/// search radius `r`.
#[derive(Clone, Copy, Debug, PartialEq)]
pub enum PhotonFilter {
    /// Every photon counts fully.
    Box,
    /// `w = 1 - d / (k r)`, normalised by `1 - 2 / (3 k)` (Jensen's cone filter, `k >= 1`).
    Cone { k: f32 },
    /// Jensen's Gaussian (after Pavicic): `w = alpha (1 - (1 - exp(-beta d^2 / (2 r^2))) /
    /// (1 - exp(-beta)))` with `alpha = 0.918`, `beta = 1.953`, normalised by its exact integral.
    Gaussian,
}

const GAUSS_ALPHA: f32 = 0.918;
const GAUSS_BETA: f32 = 1.953;

impl PhotonFilter {
    /// Weight of a photon at squared distance `d2` when the radius is `sqrt(r2)`.
    #[inline]
    pub fn weight(&self, d2: f32, r2: f32) -> f32 {
        match *self {
            PhotonFilter::Box => 1.0,
            PhotonFilter::Cone { k } => (1.0 - (d2 / r2).sqrt() / k).max(0.0),
            PhotonFilter::Gaussian => {
                let e = (1.0 - (-GAUSS_BETA * d2 / (2.0 * r2)).exp()) / (1.0 - (-GAUSS_BETA).exp());
                (GAUSS_ALPHA * (1.0 - e)).max(0.0)
            }
        }
    }

    /// The integral of the weight over the disc, divided by its area (so that an estimate
    /// divides by `normalisation * pi r^2`).
    #[inline]
    pub fn normalisation(&self) -> f32 {
        match *self {
            PhotonFilter::Box => 1.0,
            PhotonFilter::Cone { k } => 1.0 - 2.0 / (3.0 * k),
            // (1 / pi) * integral of w over the unit disc, in closed form.
            PhotonFilter::Gaussian => {
                let inner = 0.5 - (1.0 - (-GAUSS_BETA / 2.0).exp()) / GAUSS_BETA;
                GAUSS_ALPHA * (1.0 - 2.0 * inner / (1.0 - (-GAUSS_BETA).exp()))
            }
        }
    }

    pub fn name(&self) -> &'static str {
        match self {
            PhotonFilter::Box => "box",
            PhotonFilter::Cone { .. } => "cone",
            PhotonFilter::Gaussian => "gaussian",
        }
    }
}

/// Photons whose surface normal is closer than this (cosine) to the query's count: photons of
/// the other side of a thin sheet and of a perpendicular wall in a corner are left out.
pub const NORMAL_COSINE: f32 = 0.5;

/// A density estimate's query: the point, its normal on the side it is seen from, the search
/// radius and the photon count.
#[derive(Clone, Copy, Debug)]
pub struct Query {
    pub p: Vec3,
    pub n: Vec3,
    pub max_d2: f32,
}

/// Finds the photons of `map` for `q` into `heap`; returns the squared radius the estimate
/// divides by (the farthest photon's when `heap` filled, the search radius otherwise).
fn gather_photons(map: &KdTree<Photon>, q: &Query, heap: &mut KnnHeap) -> f32 {
    map.knn(q.p, q.max_d2, heap, |ph| unpack_unit(ph.n).dot(q.n) > NORMAL_COSINE);
    if heap.is_full() { heap.max_d2() } else { q.max_d2 }
}

/// Irradiance at `q` (incident flux per area, from the photons' side), per path-normalised
/// photon power.
pub fn irradiance(map: &KdTree<Photon>, q: &Query, filter: PhotonFilter, heap: &mut KnnHeap) -> Vec3 {
    let r2 = gather_photons(map, q, heap);
    if heap.is_empty() || !(r2 > 0.0) {
        return Vec3::ZERO;
    }
    let mut sum = Vec3::ZERO;
    for &(d2, i) in heap.entries() {
        sum += map.get(i).power * filter.weight(d2, r2);
    }
    sum / (filter.normalisation() * PI * r2)
}

/// Radiance reflected toward `wo` by the non-specular part of `bsdf` at `q`.
pub fn radiance(
    map: &KdTree<Photon>,
    q: &Query,
    bsdf: &Bsdf,
    wo: Vec3,
    filter: PhotonFilter,
    heap: &mut KnnHeap,
) -> Vec3 {
    let r2 = gather_photons(map, q, heap);
    if heap.is_empty() || !(r2 > 0.0) {
        return Vec3::ZERO;
    }
    let lambertian = bsdf
        .lobes()
        .iter()
        .all(|l| matches!(l, crate::bsdf::Lobe::Lambert { .. }) || l.flags().is_specular());
    let mut sum = Vec3::ZERO;
    if lambertian {
        // `f` is the same for every photon on the viewer's side.
        for &(d2, i) in heap.entries() {
            let ph = map.get(i);
            if unpack_unit(ph.wi).dot(bsdf.ng) * wo.dot(bsdf.ng) > 0.0 {
                sum += ph.power * filter.weight(d2, r2);
            }
        }
        sum *= bsdf.diffuse_reflectance() * std::f32::consts::FRAC_1_PI;
    } else {
        for &(d2, i) in heap.entries() {
            let ph = map.get(i);
            let f = bsdf.f(wo, unpack_unit(ph.wi), LobeFlags::NON_SPECULAR);
            sum += f * ph.power * filter.weight(d2, r2);
        }
    }
    sum / (filter.normalisation() * PI * r2)
}

/// Radiance reflected toward `wo` by the non-specular part of `bsdf` from every photon of `grid`
/// within `sqrt(q.max_d2)` of `q.p`: the fixed-radius estimate of progressive photon mapping,
/// summed during the search (no photon is kept, so a dense region costs time, never memory).
/// The sum is divided by the part of the disc that lies on the surface: the photons the normal
/// test rejects mark where an adjacent surface cuts it ([`Boundaries`]).
pub fn radiance_within(grid: &PhotonGrid, q: &Query, bsdf: &Bsdf, wo: Vec3, filter: PhotonFilter) -> Vec3 {
    let r2 = q.max_d2;
    if !(r2 > 0.0) || !r2.is_finite() {
        return Vec3::ZERO;
    }
    let mut edges = Boundaries::new(q.p, q.n, r2);
    let mut accept = |ph: &GridPhoton| {
        let aligned = ph.n.dot(q.n) > NORMAL_COSINE;
        if !aligned {
            edges.add(ph.p, ph.n);
        }
        aligned
    };
    let lambertian = bsdf
        .lobes()
        .iter()
        .all(|l| matches!(l, crate::bsdf::Lobe::Lambert { .. }) || l.flags().is_specular());
    let mut sum = Vec3::ZERO;
    if lambertian && filter == PhotonFilter::Box {
        // Every photon on the viewer's side weighs the same: a plain sum, without branches.
        sum = grid.sum_power_within(q.p, r2, q.n, bsdf.ng, wo.dot(bsdf.ng), |x, m| edges.add(x, m));
        sum *= bsdf.diffuse_reflectance() * std::f32::consts::FRAC_1_PI;
    } else if lambertian {
        // `f` is the same for every photon on the viewer's side.
        let wo_side = wo.dot(bsdf.ng);
        grid.for_each_within(q.p, r2, &mut accept, |d2, ph| {
            if ph.wi.dot(bsdf.ng) * wo_side > 0.0 {
                sum += ph.power * filter.weight(d2, r2);
            }
        });
        sum *= bsdf.diffuse_reflectance() * std::f32::consts::FRAC_1_PI;
    } else {
        grid.for_each_within(q.p, r2, &mut accept, |d2, ph| {
            let f = bsdf.f(wo, ph.wi, LobeFlags::NON_SPECULAR);
            sum += f * ph.power * filter.weight(d2, r2);
        });
    }
    // The kernels other than the box weigh the disc's rim less, and the part cut off is at the
    // rim: dividing by the cut area is then a slight overcorrection that vanishes with the radius.
    sum / (filter.normalisation() * PI * r2 * edges.area_fraction())
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::bsdf::Lobe;
    use crate::math::Frame;
    use crate::photon::pack_unit;
    use crate::sampling::Rng;

    /// A floor (`z = 0`, normal `+z`) meeting a wall (`x = 1`, normal `-x`), each with photons
    /// of the same density: the fixed-radius estimate on the floor is the floor's irradiance
    /// times `albedo / pi` everywhere, next to the wall too, where the disc without the cut
    /// (the estimate before 2026-11-26) was a quarter too dark at half a radius from it.
    #[test]
    fn estimate_next_to_a_wall_is_not_dark() {
        let mut rng = Rng::new(11, 2);
        let (per_area, power) = (40_000.0f32, 1e-3f32);
        let mut photons = Vec::new();
        // The floor over [-1, 1] x [-1, 1], the wall over y in [-1, 1], z in [0, 2].
        for _ in 0..(per_area * 4.0) as u32 {
            let (u, v) = (rng.uniform() * 2.0 - 1.0, rng.uniform() * 2.0 - 1.0);
            let wi = pack_unit(Vec3::new(0.1, 0.2, 1.0).normalize());
            photons.push(Photon {
                p: Vec3::new(u, v, 0.0),
                power: Vec3::splat(power),
                wi,
                n: pack_unit(Vec3::Z),
            });
            let wi = pack_unit(Vec3::new(-1.0, 0.2, 0.1).normalize());
            photons.push(Photon {
                p: Vec3::new(1.0, v, u + 1.0),
                power: Vec3::splat(power),
                wi,
                n: pack_unit(-Vec3::X),
            });
        }
        let grid = PhotonGrid::build(&photons, 0.1);
        let mut bsdf = Bsdf::new(Frame::from_z(Vec3::Z), Vec3::Z);
        bsdf.add(Lobe::Lambert { r: Vec3::splat(0.5) });
        let wo = Vec3::new(0.0, 0.3, 1.0).normalize();
        let expected = 0.5 * std::f32::consts::FRAC_1_PI * per_area * power;
        let r = 0.1f32;
        // Several points per distance from the wall, so that photon noise averages out.
        for distance in [0.0, 0.02, 0.05, 0.08, 0.3] {
            let (mut sum, mut uncut) = (0.0, 0.0);
            let points = 40;
            for i in 0..points {
                let p = Vec3::new(1.0 - distance, -0.8 + 1.6 * i as f32 / points as f32, 0.0);
                let q = Query { p, n: Vec3::Z, max_d2: r * r };
                let l = radiance_within(&grid, &q, &bsdf, wo, PhotonFilter::Box).x;
                sum += l;
                let mut edges = Boundaries::new(p, Vec3::Z, r * r);
                grid.sum_power_within(p, r * r, Vec3::Z, Vec3::Z, 1.0, |x, m| edges.add(x, m));
                uncut += l * edges.area_fraction();
            }
            let (mean, uncut) = (sum / points as f32, uncut / points as f32);
            assert!((mean / expected - 1.0).abs() < 0.03, "{distance}: {mean} vs {expected}");
            if distance == 0.05 {
                assert!(uncut / expected < 0.85, "without the cut: {uncut} vs {expected}");
            }
        }
    }

    /// Each kernel integrates to `normalisation * pi` over the unit disc.
    #[test]
    fn kernels_are_normalised() {
        for f in [
            PhotonFilter::Box,
            PhotonFilter::Cone { k: 1.1 },
            PhotonFilter::Cone { k: 1.0 },
            PhotonFilter::Gaussian,
        ] {
            let n = 2000;
            let mut integral = 0.0f64;
            for i in 0..n {
                let r = (i as f64 + 0.5) / n as f64;
                integral +=
                    f64::from(f.weight((r * r) as f32, 1.0)) * 2.0 * std::f64::consts::PI * r / n as f64;
            }
            let expected = f64::from(f.normalisation()) * std::f64::consts::PI;
            assert!((integral - expected).abs() < 1e-4 * expected, "{}: {integral} vs {expected}", f.name());
        }
    }
}
