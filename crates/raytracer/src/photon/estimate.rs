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

/// Photons of any surface, per photon of an estimate, that its search may meet within its
/// radius. Beyond that, the query's surface holds few of the photons around it (a small
/// object beside a bright wall, a sparse surface under a large `maxdist`), and the search
/// would read every photon within `maxdist`: it is redone within the distance of the
/// `SEARCH_BUDGET_PER_K * k`-th nearest photon of any surface instead, so that no estimate
/// costs more than that many photons. A search in the open meets about `3 k` (a plane's disc
/// that shrinks as the heap fills), in a corner about `6 k`.
pub const SEARCH_BUDGET_PER_K: usize = 16;

/// A `k`-nearest search's scratch: the heap of the photons found, the photons of other
/// surfaces (position, normal, squared distance) the normal test rejected on the way, and the
/// heap of the nearest photons of any surface for a search over its budget.
#[derive(Clone, Debug)]
pub struct Nearest {
    pub heap: KnnHeap,
    rejected: Vec<(Vec3, Vec3, f32)>,
    any: KnnHeap,
    /// Searches redone within a smaller radius for being over their budget.
    pub capped: u64,
}

impl Nearest {
    /// Scratch for estimates of `k` photons.
    pub fn new(k: usize) -> Nearest {
        let any = KnnHeap::new(k.saturating_mul(SEARCH_BUDGET_PER_K));
        Nearest { heap: KnnHeap::new(k), rejected: Vec::new(), any, capped: 0 }
    }

    /// The part of the disc of squared radius `r2` around `q` that lies on `q`'s surface, read
    /// from the rejected photons within it ([`Boundaries`]). The search only ever meets photons
    /// within its current radius, which shrinks to `r2`, so every photon within `r2` was met.
    fn area_fraction(&self, q: &Query, r2: f32) -> f32 {
        if self.rejected.is_empty() {
            return 1.0;
        }
        let mut edges = Boundaries::new(q.p, q.n, r2);
        for &(x, m, d2) in &self.rejected {
            if d2 < r2 {
                edges.add(x, m);
            }
        }
        edges.area_fraction()
    }
}

/// Finds the photons of `map` for `q` into `nearest`; returns the squared radius the estimate
/// divides by (the farthest photon's when the heap filled, the search radius otherwise) and the
/// part of that disc on the surface. A disc that reaches past an edge (a wall meeting the floor,
/// a box's side meeting its top) holds fewer photons than its area says: it grows to find its
/// `k` photons, and the estimate would be dark along every edge without the cut.
pub(crate) fn gather_photons(map: &KdTree<Photon>, q: &Query, nearest: &mut Nearest) -> (f32, f32) {
    let r2 = nearest_on_surface(map, q, nearest);
    (r2, nearest.area_fraction(q, r2))
}

/// The `k` nearest photons of `map` on `q`'s surface (normal within [`NORMAL_COSINE`]) into
/// `nearest.heap`, and those of other surfaces met on the way into its rejected list. Returns
/// the squared radius an estimate divides by: the farthest photon's when the heap filled,
/// otherwise the search radius, `q.max_d2` or, for a search that met more than its budget of
/// photons, the distance of the budget's nearest photon of any surface.
pub fn nearest_on_surface(map: &KdTree<Photon>, q: &Query, nearest: &mut Nearest) -> f32 {
    let Nearest { heap, rejected, any, capped } = nearest;
    let on_surface = |rejected: &mut Vec<(Vec3, Vec3, f32)>, ph: &Photon| {
        let m = unpack_unit(ph.n);
        let aligned = m.dot(q.n) > NORMAL_COSINE;
        if !aligned {
            rejected.push((ph.p, m, (ph.p - q.p).length_squared()));
        }
        aligned
    };
    rejected.clear();
    let budget = any.capacity();
    let mut radius2 = q.max_d2;
    if !map.knn_within_budget(q.p, q.max_d2, budget, heap, |ph| on_surface(rejected, ph)) {
        // Fewer than `budget` photons lie within the distance of the `budget`-th nearest one,
        // so the search within it stays within budget (ties on the rim aside).
        map.knn(q.p, q.max_d2, any, |_| true);
        if any.is_full() {
            radius2 = any.max_d2();
        }
        *capped += 1;
        rejected.clear();
        map.knn(q.p, radius2, heap, |ph| on_surface(rejected, ph));
    }
    if heap.is_full() { heap.max_d2() } else { radius2 }
}

/// The photons an estimate sums: all those found within a fixed radius, but of a full heap
/// only the `k - 1` inside the radius. The `k`-th photon sits on the rim by construction; given
/// the radius, the others are spread uniformly over the disc, so `(k - 1) / (pi r^2)` is an
/// unbiased density where `k / (pi r^2)` is `k / (k - 1)` too high (2% at 50 photons, in
/// every estimate, where the edges' darkness used to hide it).
fn inside(heap: &KnnHeap) -> &[(f32, u32)] {
    // A full max-heap holds its farthest entry first.
    if heap.is_full() { &heap.entries()[1..] } else { heap.entries() }
}

/// Irradiance at `q` (incident flux per area, from the photons' side), per path-normalised
/// photon power.
pub fn irradiance(map: &KdTree<Photon>, q: &Query, filter: PhotonFilter, nearest: &mut Nearest) -> Vec3 {
    let (r2, fraction) = gather_photons(map, q, nearest);
    let heap = &nearest.heap;
    if heap.is_empty() || !(r2 > 0.0) {
        return Vec3::ZERO;
    }
    let mut sum = Vec3::ZERO;
    for &(d2, i) in inside(heap) {
        sum += map.get(i).power * filter.weight(d2, r2);
    }
    sum / (filter.normalisation() * PI * r2 * fraction)
}

/// Radiance reflected toward `wo` by the non-specular part of `bsdf` at `q`.
pub fn radiance(
    map: &KdTree<Photon>,
    q: &Query,
    bsdf: &Bsdf,
    wo: Vec3,
    filter: PhotonFilter,
    nearest: &mut Nearest,
) -> Vec3 {
    let (r2, fraction) = gather_photons(map, q, nearest);
    let heap = &nearest.heap;
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
        for &(d2, i) in inside(heap) {
            let ph = map.get(i);
            if unpack_unit(ph.wi).dot(bsdf.ng) * wo.dot(bsdf.ng) > 0.0 {
                sum += ph.power * filter.weight(d2, r2);
            }
        }
        sum *= bsdf.diffuse_reflectance() * std::f32::consts::FRAC_1_PI;
    } else {
        for &(d2, i) in inside(heap) {
            let ph = map.get(i);
            let f = bsdf.f(wo, unpack_unit(ph.wi), LobeFlags::NON_SPECULAR);
            sum += f * ph.power * filter.weight(d2, r2);
        }
    }
    sum / (filter.normalisation() * PI * r2 * fraction)
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

    /// The `k`-nearest estimate of the default mode (radiance photons' irradiance, visible
    /// caustics) beside a wall: photons on a jittered grid of the same density on a floor
    /// (`z = 0`, normal `+z`) and a wall (`x = 1`, normal `-x`). Within a radius of the wall the
    /// disc that finds `k` floor photons reaches past the wall, so dividing by `pi r^2` is dark
    /// (by a fifth at a quarter of a radius); the cut keeps the floor's irradiance.
    #[test]
    fn nearest_estimate_next_to_a_wall_is_not_dark() {
        let mut rng = Rng::new(5, 3);
        let (spacing, power) = (0.005f32, 1e-3f32);
        let per_area = 1.0 / (spacing * spacing);
        let cells = (2.0 / spacing) as u32;
        let mut photons = Vec::new();
        for i in 0..cells {
            for j in 0..cells {
                let u = -1.0 + (i as f32 + rng.uniform()) * spacing;
                let v = -1.0 + (j as f32 + rng.uniform()) * spacing;
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
        }
        let map = KdTree::build(photons);
        let k = 50;
        let mut nearest = Nearest::new(k);
        // The radius that holds `k` photons of the floor's density.
        let r = (k as f32 / (PI * per_area)).sqrt();
        let expected = per_area * power;
        for distance in [0.0, 0.25, 0.5, 1.0, 3.0] {
            let (mut sum, mut uncut) = (0.0, 0.0);
            let points = 100;
            for i in 0..points {
                let p = Vec3::new(1.0 - distance * r, -0.8 + 1.6 * i as f32 / points as f32, 0.0);
                let q = Query { p, n: Vec3::Z, max_d2: 0.01 };
                let e = irradiance(&map, &q, PhotonFilter::Box, &mut nearest).x;
                sum += e;
                uncut += e * gather_photons(&map, &q, &mut nearest).1;
            }
            let (mean, uncut) = (sum / points as f32, uncut / points as f32);
            assert!((mean / expected - 1.0).abs() < 0.03, "{distance} radii: {mean} vs {expected}");
            if distance == 0.25 {
                assert!(uncut / expected < 0.85, "without the cut: {uncut} vs {expected}");
            }
        }
    }

    /// On a plane of uniformly random photons, the mean of many `k`-nearest estimates is the
    /// density: the `k - 1` photons inside the radius count, not the `k`-th on its rim, with
    /// which the mean is `k / (k - 1)` of it (2% high at 50 photons).
    #[test]
    fn nearest_estimate_is_unbiased_on_a_plane() {
        let mut rng = Rng::new(9, 4);
        let (count, power) = (100_000u32, 1e-5f32);
        let photons = (0..count)
            .map(|_| Photon {
                p: Vec3::new(rng.uniform(), rng.uniform(), 0.0),
                power: Vec3::splat(power),
                wi: pack_unit(Vec3::Z),
                n: pack_unit(Vec3::Z),
            })
            .collect();
        let map = KdTree::build(photons);
        let mut nearest = Nearest::new(50);
        // Queries 0.025 apart, about one disc's width, away from the square's sides.
        let (mut sum, mut n) = (0.0f64, 0u32);
        for i in 0..36 {
            for j in 0..36 {
                let p = Vec3::new(0.05 + 0.025 * i as f32, 0.05 + 0.025 * j as f32, 0.0);
                let q = Query { p, n: Vec3::Z, max_d2: 0.01 };
                sum += f64::from(irradiance(&map, &q, PhotonFilter::Box, &mut nearest).x);
                n += 1;
            }
        }
        let expected = f64::from(count as f32 * power);
        let mean = sum / f64::from(n);
        assert!((mean / expected - 1.0).abs() < 0.01, "{mean} vs {expected}");
    }

    /// A small patch (a wall's strip, normal `+x`, 20 photons) standing on a densely lit floor
    /// (normal `+z`), searched with a huge `maxdist`: the search meets the floor's photons, not
    /// its own, so it is redone within the distance of the budget's nearest photon of any
    /// surface and meets no more than the budget; the estimate is the one an explicit radius of
    /// that distance gives, and a search in the floor's open is not touched.
    #[test]
    fn a_sparse_surface_among_dense_photons_reads_a_bounded_number_of_them() {
        let mut rng = Rng::new(3, 9);
        let flat =
            |p: Vec3, n: Vec3| Photon { p, power: Vec3::splat(1e-3), wi: pack_unit(n), n: pack_unit(n) };
        let mut photons: Vec<Photon> = (0..100_000)
            .map(|_| flat(Vec3::new(rng.uniform() * 2.0 - 1.0, rng.uniform() * 2.0 - 1.0, 0.0), Vec3::Z))
            .collect();
        photons.extend((0..20).map(|i| flat(Vec3::new(0.0, 0.001 * i as f32, 0.01), Vec3::X)));
        let map = KdTree::build(photons);
        let k = 50;
        let budget = SEARCH_BUDGET_PER_K * k;
        let mut nearest = Nearest::new(k);
        let q = Query { p: Vec3::new(0.0, 0.01, 0.01), n: Vec3::X, max_d2: 1e6 };
        let r2 = nearest_on_surface(&map, &q, &mut nearest);
        assert_eq!(nearest.capped, 1);
        assert!(nearest.heap.met() <= budget, "{}", nearest.heap.met());
        assert_eq!(nearest.heap.len(), 20);
        // The budget's nearest photon: about sqrt(800 / (pi 25000)) = 0.1 away on the floor.
        assert!(r2 > 0.05f32.powi(2) && r2 < 0.2f32.powi(2), "{}", r2.sqrt());
        let capped = irradiance(&map, &q, PhotonFilter::Box, &mut nearest);
        let explicit = irradiance(&map, &Query { max_d2: r2, ..q }, PhotonFilter::Box, &mut nearest);
        assert_eq!(capped, explicit);
        assert!(capped.is_finite() && capped.x > 0.0);
        // On the floor the heap fills long before the budget: no second search.
        let (open, capped) = (Query { p: Vec3::new(0.5, 0.5, 0.0), n: Vec3::Z, max_d2: 1e6 }, nearest.capped);
        nearest_on_surface(&map, &open, &mut nearest);
        assert_eq!(nearest.capped, capped);
        assert!(nearest.heap.met() < budget / 2, "{}", nearest.heap.met());
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
