//! The default search radius (`maxdist`), from where the photons are.
//!
//! A `k`-nearest query whose surface holds fewer than `k` photons within the search radius
//! visits every photon within it, so the radius bounds the cost of the sparse queries. It used
//! to be a tenth of the scene's bounding radius, which one far object (a ground plane, a sky
//! sphere, a stray sphere thousands of units away) made as large as the whole lit region:
//! the caustics example took 20 s instead of 2 s to prepare with a unit sphere 300 units
//! away (docs/photon-mapping.md, "The default `maxdist`").
//!
//! The default is now measured on the stored photons themselves: the distance to the `k`-th
//! nearest photon (of any surface) at a deterministic spread of photons of each map, its
//! [`QUANTILE`] over those photons, times [`SAFETY_FACTOR`], the largest over the maps. A far
//! object changes it only if it holds photons enough to move that quantile, and then only to
//! the radius its photons need. A search within it around a photon whose own radius is
//! below the quantile meets about `SAFETY_FACTOR^2 k` photons of a surface of that density.
//! The caller keeps it at most a tenth of the scene's bounding radius (the old default).

use super::Photon;
use super::kdtree::{KdTree, KnnHeap};
use rayon::prelude::*;

/// Photons of each map at which the `k`-nearest radius is measured (spread evenly over the
/// map's tree order, which is deterministic).
pub const SAMPLES_PER_MAP: usize = 2048;
/// The quantile of the measured radii: most photons lie where the light is, so a high one
/// reaches the dim regions too.
pub const QUANTILE: f32 = 0.9;
/// The default over the quantile's radius: dim regions, corners (where the measured radius
/// counts the photons of both walls, the estimate only those of one) and the surfaces between
/// the sampled photons get a radius several times their measured one. With 2 the room example's
/// default fell from 0.93 to 0.54 and its error against a path-traced reference grew by 4% to
/// 8% (docs/photon-mapping.md, "The default `maxdist`").
pub const SAFETY_FACTOR: f32 = 3.0;

/// What the default was measured from, for `--stats`.
#[derive(Clone, Copy, Debug, Default, PartialEq)]
pub struct Measured {
    /// Photons whose `k`-nearest radius was measured, over all maps.
    pub samples: usize,
    /// The largest of the maps' [`QUANTILE`] radii.
    pub quantile_radius: f32,
    /// The largest of the maps' median radii.
    pub median_radius: f32,
}

impl Measured {
    /// The default search radius: `SAFETY_FACTOR` times the quantile's radius; `None` where
    /// it is not a positive finite distance (no photons, or all of them at one point).
    pub fn max_dist(&self) -> Option<f32> {
        let d = SAFETY_FACTOR * self.quantile_radius;
        (d > 0.0 && d.is_finite()).then_some(d)
    }
}

/// The search radius: `maxdist` where the RIB gives it; otherwise the one measured on the
/// photons, at most a tenth of the scene's bounding radius (the old default, which a far object
/// only raises), or that tenth where there were no photons to measure (nothing is searched).
pub fn chosen(explicit: Option<f32>, measured: &Measured, scene_radius: f32) -> f32 {
    let scene_tenth = 0.1 * scene_radius;
    explicit.unwrap_or(measured.max_dist().map_or(scene_tenth, |d| d.min(scene_tenth)))
}

/// Where the search radius `max_dist` came from, for `--stats` (`None`: the RIB gave it).
pub fn describe(measured: Option<&Measured>, max_dist: f32) -> String {
    match measured {
        None => "maxdist given".to_string(),
        Some(m) if m.max_dist().is_none() => "no photons to measure: a tenth of the scene's radius".into(),
        Some(m) if m.max_dist().is_some_and(|d| d > max_dist) => {
            "a tenth of the scene's radius, less than what the photons ask for".into()
        }
        Some(m) => format!(
            "{SAFETY_FACTOR} x the {:.0}th percentile of the nused-nearest radius at {} photons; median {:.4}",
            100.0 * QUANTILE,
            m.samples,
            m.median_radius
        ),
    }
}

/// Measures the `k`-nearest radii of the photons of `maps` (empty maps count for nothing).
pub fn measure(maps: &[Option<&KdTree<Photon>>], k: usize) -> Measured {
    let mut out = Measured::default();
    for map in maps.iter().copied().flatten().filter(|m| !m.is_empty()) {
        let mut radii = nearest_radii(map, k);
        radii.retain(|d| d.is_finite());
        if radii.is_empty() {
            continue;
        }
        radii.sort_by(f32::total_cmp);
        let at = |q: f32| radii[((radii.len() - 1) as f32 * q) as usize];
        out.samples += radii.len();
        out.quantile_radius = out.quantile_radius.max(at(QUANTILE));
        out.median_radius = out.median_radius.max(at(0.5));
    }
    out
}

/// The distance to the `k`-th nearest photon (the photon itself counted, as at a query on
/// it) at up to [`SAMPLES_PER_MAP`] photons of `map`. The search has no normal test, so its
/// heap fills after about `k` photons and its cost is bounded wherever the photon is.
fn nearest_radii(map: &KdTree<Photon>, k: usize) -> Vec<f32> {
    let k = k.clamp(1, map.len());
    let step = map.len().div_ceil(SAMPLES_PER_MAP).max(1);
    map.items()
        .par_iter()
        .step_by(step)
        .map_init(
            || KnnHeap::new(k),
            |heap, ph| {
                map.knn(ph.p, f32::INFINITY, heap, |_| true);
                if heap.is_full() { heap.max_d2().sqrt() } else { f32::NAN }
            },
        )
        .collect()
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::photon::pack_unit;
    use crate::sampling::Rng;
    use glam::Vec3;

    fn photon(p: Vec3) -> Photon {
        Photon { p, power: Vec3::splat(1e-3), wi: pack_unit(Vec3::Z), n: pack_unit(Vec3::Z) }
    }

    /// `n` photons uniform on the unit square of the plane `z = 0`.
    fn floor(n: usize, seed: u64) -> Vec<Photon> {
        let mut rng = Rng::new(seed, 1);
        (0..n).map(|_| photon(Vec3::new(rng.uniform(), rng.uniform(), 0.0))).collect()
    }

    /// On a uniform plane the measured radius is the one that holds `k` photons of its density,
    /// and a few photons far away (a stray sphere 3000 units off) do not change it.
    #[test]
    fn far_photons_leave_the_default_as_it_is() {
        let (n, k) = (100_000usize, 50usize);
        let near = KdTree::build(floor(n, 3));
        let plain = measure(&[Some(&near)], k);
        // pi r^2 n = k on the unit square.
        let expected = (k as f32 / (std::f32::consts::PI * n as f32)).sqrt();
        assert!((plain.median_radius / expected - 1.0).abs() < 0.15, "{plain:?} vs {expected}");
        let d = plain.max_dist().unwrap();
        assert!(d > expected && d < 2.0 * SAFETY_FACTOR * expected, "{d} vs {expected}");
        let mut photons = floor(n, 3);
        photons.extend((0..40).map(|i| photon(Vec3::new(3000.0, i as f32 * 0.01, 0.0))));
        photons.push(photon(Vec3::splat(2.0f32.powi(31))));
        let far = KdTree::build(photons);
        let with_far = measure(&[Some(&far)], k).max_dist().unwrap();
        assert!((with_far / d - 1.0).abs() < 0.05, "{with_far} vs {d}");
    }

    /// The largest of the maps' radii counts: a sparse caustic map beside a dense global one
    /// gets a radius that reaches its own photons.
    #[test]
    fn the_sparsest_map_sets_the_default() {
        let dense = KdTree::build(floor(100_000, 4));
        let sparse = KdTree::build(floor(1_000, 5));
        let both = measure(&[Some(&dense), None, Some(&sparse)], 50);
        let alone = measure(&[Some(&sparse)], 50);
        assert_eq!(both.max_dist(), alone.max_dist());
        assert!(both.samples > SAMPLES_PER_MAP);
    }

    /// No photons, one photon, all photons at one point: no default (the caller keeps its
    /// fallback), and no panic or NaN.
    #[test]
    fn degenerate_maps_give_no_default() {
        let empty: KdTree<Photon> = KdTree::build(Vec::new());
        assert_eq!(measure(&[Some(&empty), None], 50).max_dist(), None);
        assert_eq!(measure(&[], 50).max_dist(), None);
        let one = KdTree::build(vec![photon(Vec3::ONE)]);
        assert_eq!(measure(&[Some(&one)], 50).max_dist(), None);
        let same = KdTree::build(vec![photon(Vec3::new(0.5, -2.0, 7.0)); 500]);
        assert_eq!(measure(&[Some(&same)], 50).max_dist(), None);
        // Two points: the radius is their distance, with fewer photons than `k`.
        let two = KdTree::build(vec![photon(Vec3::ZERO), photon(Vec3::X)]);
        assert_eq!(measure(&[Some(&two)], 50).max_dist(), Some(SAFETY_FACTOR));
        // Photons so far apart that their squared distance overflows: no default.
        let huge = KdTree::build(vec![photon(Vec3::splat(-1e30)), photon(Vec3::splat(1e30))]);
        assert_eq!(measure(&[Some(&huge)], 50).max_dist(), None);
    }
}
