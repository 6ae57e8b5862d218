//! Progressive photon mapping without a bias floor: `SurfaceIntegrator "photonmap"
//! "integer progressive" [1]`.
//!
//! A fixed photon map leaves a bias that no number of pixel samples removes: every density
//! estimate averages the light over a disc. The progressive mode follows Knaus and Zwicker's
//! *probabilistic* progressive photon mapping (2011), the memory-free form of Hachisuka and
//! Jensen's stochastic progressive photon mapping (2009): the image is the average of passes,
//! each with its own photons (seeded by the pass number) and with density estimates over a
//! fixed radius that shrinks from pass to pass as
//!
//! `r_{i+1}^2 = r_i^2 (i + alpha) / (i + 1)`  (passes numbered from 1),
//!
//! so the bias of pass `i` falls like `r_i^2` while the variance of the average still falls:
//! the render converges to the right image with no floor, and every pass is independent (no
//! per-pixel photon statistics to keep, nothing shared between threads).
//!
//! What uses the shrinking radius: the caustic estimate at the first non-specular surface a
//! camera path meets, and the photon estimate where a final-gather ray lands (one map of all
//! stored photons, read with a fixed radius instead of the radiance photons, whose nearest-site
//! lookup would keep a blur that does not shrink). Direct light is sampled as before.
//!
//! The initial radii come from the photons of the first pass ([`RadiusField`]): the distance to
//! the `nused`-th nearest photon at a spread subset of them (separately for the caustic map),
//! read at the nearest of those sites. Later passes keep that field, scaled, so that the radius
//! at a point depends only on the seed and the pass.

use super::estimate::{Nearest, Query, nearest_on_surface};
use super::grid::PhotonGrid;
use super::kdtree::{KdTree, Positioned};
use super::search_radius::{self, Measured};
use super::{GatherSampling, Photon, PhotonMapSettings, unpack_unit};
use crate::sampling::mix64;
use glam::Vec3;
use std::sync::Arc;

/// Knaus and Zwicker's `alpha` (and Hachisuka's): 2/3 to 0.7 balances the falling bias against
/// the growing variance per pass.
pub const DEFAULT_ALPHA: f32 = 0.7;
/// Passes of a progressive render when neither `--time` nor `--target-error` decide.
pub const DEFAULT_PASSES: u32 = 16;
/// The most passes one render may ask for.
pub const MAX_PASSES: u32 = 1 << 16;
/// Photons of the first pass that carry a radius ([`RadiusField`]).
const RADIUS_SITES: usize = 4096;

/// A search radius for every point: the `k`-nearest-photon radius of the first pass at the
/// nearest of a spread subset of its photons. Bright regions get small radii and dim ones large
/// radii, as a `k`-nearest estimate would, but the radius is a fixed function of the position
/// for every later pass (scaled by the reduction), so each pass is a fixed-radius estimate
/// whose bias goes to zero.
#[derive(Debug)]
pub struct RadiusField {
    sites: KdTree<RadiusSite>,
    fallback_d2: f32,
    median_d2: f32,
}

#[derive(Clone, Copy, Debug)]
struct RadiusSite {
    p: Vec3,
    d2: f32,
}

impl Positioned for RadiusSite {
    #[inline]
    fn position(&self) -> Vec3 {
        self.p
    }
}

impl RadiusField {
    /// The field of `map`'s photons with `k` photons per estimate, radii at most
    /// `sqrt(max_d2)`; `None` for an empty map.
    pub fn new(map: Option<&KdTree<Photon>>, k: usize, max_d2: f32) -> Option<RadiusField> {
        let map = map.filter(|m| !m.is_empty())?;
        let k = k.clamp(1, map.len());
        let step = map.len().div_ceil(RADIUS_SITES).max(1);
        let mut nearest = Nearest::new(k);
        let sites: Vec<RadiusSite> = map
            .items()
            .iter()
            .step_by(step)
            .map(|ph| {
                let q = Query { p: ph.p, n: unpack_unit(ph.n), max_d2 };
                let d2 = nearest_on_surface(map, &q, &mut nearest);
                RadiusSite { p: ph.p, d2: if d2 > 0.0 && d2.is_finite() { d2 } else { max_d2 } }
            })
            .collect();
        let mut d2: Vec<f32> = sites.iter().map(|s| s.d2).collect();
        let median_d2 = if d2.is_empty() {
            max_d2
        } else {
            let m = d2.len() / 2;
            *d2.select_nth_unstable_by(m, f32::total_cmp).1
        };
        Some(RadiusField { sites: KdTree::build(sites), fallback_d2: max_d2, median_d2 })
    }

    /// The squared radius of the first pass at `p`.
    #[inline]
    pub fn d2_at(&self, p: Vec3) -> f32 {
        self.sites.nearest(p, f32::INFINITY, |_| true).map_or(self.fallback_d2, |s| s.d2)
    }

    /// Sites and their median radius, for `--stats`.
    pub fn summary(&self) -> (usize, f32) {
        (self.sites.len(), self.median_d2.sqrt())
    }
}

/// Cell width of a pass's photon grid over the pass's median search radius: a query of the
/// median radius reads at most 2x2x2 cells. Measured on the Cornell box (256x256, 8 passes,
/// one thread): 1, 1.5, 2, 3 and 4 took 2.61, 2.18, 2.02, 1.98 and 2.23 CPU s; narrower cells
/// test fewer photons but probe more cells, most of them empty.
const CELL_PER_MEDIAN_RADIUS: f32 = 2.0;

/// The fixed-radius estimates of one pass: its radii and its photons sorted into grids for them.
#[derive(Debug)]
pub struct FixedRadius {
    pub radii: Radii,
    /// All stored photons where final-gather rays land, or the indirect map without final
    /// gathering (read with [`Radii::global_d2`]).
    pub global: Option<PhotonGrid>,
    /// The caustic map (read with [`Radii::caustic_d2`]).
    pub caustic: Option<PhotonGrid>,
}

impl FixedRadius {
    pub fn new(radii: Radii, global: Option<&[Photon]>, caustic: Option<&[Photon]>) -> FixedRadius {
        let grid = |photons: Option<&[Photon]>, field: &Option<Arc<RadiusField>>| {
            let photons = photons.filter(|p| !p.is_empty())?;
            let median = field.as_ref().map_or(0.0, |f| (f.median_d2 * radii.scale).sqrt());
            Some(PhotonGrid::build(photons, median * CELL_PER_MEDIAN_RADIUS))
        };
        let global = grid(global, &radii.global);
        let caustic = grid(caustic, &radii.caustic);
        FixedRadius { radii, global, caustic }
    }
}

/// The photons of one progressive pass, as it reads them.
pub(super) struct PassMaps {
    /// The grids and radii of the pass's estimates.
    pub fixed: FixedRadius,
    /// The first pass's radii (this pass's, unscaled).
    pub first: Radii,
    /// The indirect map as a kd-tree, kept only where photon-guided gathering searches it for
    /// its `k` nearest photons.
    pub indirect: Option<KdTree<Photon>>,
}

/// Sorts one pass's photons (caustic, direct, indirect) into what its estimates read, building
/// nothing else: no kd-tree of the direct map (the global grid holds its photons), none of the
/// indirect map unless photon-guided gathering searches it or, without final gathering, its
/// grid is filled in the tree's order. The caustic map is put in tree order for its grid (as
/// before, so that sums run in the same order and images stay bit-identical), then dropped.
/// `first` is the first pass's radii; `None` in the first pass, which computes them from its
/// photons with `nused` nearest neighbours within `max_dist_of` of what
/// [`search_radius::measure`] measured on them (the search radius, kept for later passes).
pub(super) fn build_pass_maps(
    [caustic, direct, indirect]: [Vec<Photon>; 3],
    gather: bool,
    settings: &PhotonMapSettings,
    first: Option<Radii>,
    max_dist_of: &dyn Fn(&Measured) -> f32,
    pass: u32,
) -> PassMaps {
    let keep_indirect_tree =
        gather && settings.gather_sampling == GatherSampling::Photons && settings.final_gather_samples >= 2;
    let k = settings.n_used as usize;
    let tree_of = |photons: Vec<Photon>| (!photons.is_empty()).then(|| KdTree::build(photons));
    // Final gathering reads every stored photon with one estimate, in the order they were shot.
    let global: Option<Vec<Photon>> = gather.then(|| {
        let mut all = direct;
        all.reserve_exact(indirect.len() + caustic.len());
        all.extend_from_slice(&indirect);
        all.extend_from_slice(&caustic);
        all
    });
    let caustic = tree_of(caustic);
    let indirect = if !gather || keep_indirect_tree { tree_of(indirect) } else { None };
    let first = first.unwrap_or_else(|| {
        // The first pass's radii: k-nearest searches, which a kd-tree serves (built here once).
        let global_tree = global.clone().map(KdTree::build);
        let global_tree = global_tree.as_ref().or(indirect.as_ref());
        let measured =
            settings.max_dist.is_none().then(|| search_radius::measure(&[global_tree, caustic.as_ref()], k));
        let max_dist = max_dist_of(&measured.unwrap_or_default());
        let max_d2 = max_dist * max_dist;
        Radii {
            global: RadiusField::new(global_tree, k, max_d2).map(Arc::new),
            caustic: RadiusField::new(caustic.as_ref(), k, max_d2).map(Arc::new),
            scale: 1.0,
            max_dist,
            measured,
        }
    });
    let global_or_indirect = global.as_deref().or(indirect.as_ref().map(|t| t.items()));
    let fixed = FixedRadius::new(
        first.at_pass(pass, settings.alpha),
        global_or_indirect,
        caustic.as_ref().map(|t| t.items()),
    );
    PassMaps { fixed, first, indirect: indirect.filter(|_| keep_indirect_tree) }
}

/// The search radii of one pass: the first pass's fields, scaled.
#[derive(Clone, Debug)]
pub struct Radii {
    /// Where final-gather rays land (all stored photons), or the indirect map without final
    /// gathering.
    pub global: Option<Arc<RadiusField>>,
    /// The caustic map.
    pub caustic: Option<Arc<RadiusField>>,
    /// `r_pass^2 / r_0^2`.
    pub scale: f32,
    /// The search radius of the first pass's `k`-nearest searches (`maxdist`), kept for the
    /// photon-guided gathering of every pass, and what its default was measured from.
    pub max_dist: f32,
    pub measured: Option<Measured>,
}

impl Radii {
    /// The radii of pass `pass` (0-based) when the first pass used `self`.
    pub fn at_pass(&self, pass: u32, alpha: f32) -> Radii {
        Radii { scale: reduction(pass, alpha), ..self.clone() }
    }

    #[inline]
    pub fn global_d2(&self, p: Vec3) -> f32 {
        self.global.as_ref().map_or(0.0, |f| f.d2_at(p) * self.scale)
    }

    #[inline]
    pub fn caustic_d2(&self, p: Vec3) -> f32 {
        self.caustic.as_ref().map_or(0.0, |f| f.d2_at(p) * self.scale)
    }
}

/// `r_pass^2 / r_0^2`: the product of `(i + alpha) / (i + 1)` for `i` in `1..=pass`.
pub fn reduction(pass: u32, alpha: f32) -> f32 {
    let alpha = f64::from(alpha);
    (1..=pass).fold(1.0f64, |s, i| s * (f64::from(i) + alpha) / (f64::from(i) + 1.0)) as f32
}

/// The seed of the photons of pass `pass`: the render's seed for the first pass (so a
/// one-pass progressive render shoots the photons a plain render would).
pub fn pass_seed(seed: u64, pass: u32) -> u64 {
    if pass == 0 { seed } else { mix64(seed ^ mix64(u64::from(pass) ^ 0x7f4a_7c15_9e37_79b9)) }
}

#[cfg(test)]
mod tests {
    use super::*;

    /// The radius schedule is Knaus and Zwicker's: `r_2^2 = r_1^2 (1 + alpha) / 2`, ...; the
    /// sum of `1 / r_i^2` grows slower than `i^2` (variance falls) while `r_i^2` goes to zero
    /// (bias falls).
    #[test]
    fn radius_shrinks_as_knaus_zwicker() {
        assert_eq!(reduction(0, 0.7), 1.0);
        assert!((reduction(1, 0.7) - 0.85).abs() < 1e-6);
        assert!((reduction(2, 0.7) - 0.85 * 2.7 / 3.0).abs() < 1e-6);
        let late = reduction(10_000, 0.7);
        // r_i^2 ~ C i^(alpha - 1).
        let expected_ratio = (10_001f64 / 5_001f64).powf(-0.3) as f32;
        assert!((late / reduction(5_000, 0.7) - expected_ratio).abs() < 1e-3);
        assert_ne!(pass_seed(1, 1), pass_seed(1, 2));
        assert_eq!(pass_seed(5, 0), 5);
    }
}
