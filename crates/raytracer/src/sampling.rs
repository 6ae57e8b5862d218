//! Random numbers, sample warping and discrete distributions.
//!
//! Every pixel sample owns a [`Rng`] seeded by a hash of (seed, pixel, sample index), so an
//! image is the same whatever the tiling, the thread count or the crop window.

use glam::{Vec2, Vec3};
use std::f32::consts::{FRAC_1_PI, FRAC_PI_4, PI};

/// PCG32 (O'Neill 2014): small, fast and statistically sound.
#[derive(Clone, Debug)]
pub struct Rng {
    state: u64,
    inc: u64,
}

const PCG_MULT: u64 = 0x5851_f42d_4c95_7f2d;

impl Rng {
    /// A generator for stream `stream` started at `seed`.
    pub fn new(seed: u64, stream: u64) -> Rng {
        let mut rng = Rng { state: 0, inc: (stream << 1) | 1 };
        rng.next_u32();
        rng.state = rng.state.wrapping_add(seed);
        rng.next_u32();
        rng
    }

    /// A generator for one pixel sample: independent of every other (pixel, sample) pair.
    pub fn for_pixel_sample(seed: u64, x: u32, y: u32, sample: u32) -> Rng {
        Rng::for_pixel_key_sample(Rng::pixel_key(seed, x, y), sample)
    }

    /// The part of [`Rng::for_pixel_sample`] that depends only on the pixel.
    pub fn pixel_key(seed: u64, x: u32, y: u32) -> u64 {
        mix64(seed ^ mix64((u64::from(x) << 32) | u64::from(y)))
    }

    /// [`Rng::for_pixel_sample`] from the pixel's [`Rng::pixel_key`].
    #[inline]
    pub fn for_pixel_key_sample(key: u64, sample: u32) -> Rng {
        Rng::new(mix64(key ^ u64::from(sample).wrapping_mul(0x9e37_79b9_7f4a_7c15)), key)
    }

    #[inline]
    pub fn next_u32(&mut self) -> u32 {
        let old = self.state;
        self.state = old.wrapping_mul(PCG_MULT).wrapping_add(self.inc);
        let xorshifted = (((old >> 18) ^ old) >> 27) as u32;
        let rot = (old >> 59) as u32;
        xorshifted.rotate_right(rot)
    }

    /// A uniform float in `[0, 1)`.
    #[inline]
    pub fn uniform(&mut self) -> f32 {
        // 24 random bits: every value is exactly representable and strictly below 1.
        (self.next_u32() >> 8) as f32 * (1.0 / 16_777_216.0)
    }

    #[inline]
    pub fn uniform2(&mut self) -> Vec2 {
        Vec2::new(self.uniform(), self.uniform())
    }

    /// A uniform integer in `[0, n)` (`n > 0`), without modulo bias worth noticing for small `n`.
    #[inline]
    pub fn below(&mut self, n: u32) -> u32 {
        ((u64::from(self.next_u32()) * u64::from(n)) >> 32) as u32
    }
}

/// SplitMix64's finaliser: a good 64-bit mixing function.
#[inline]
pub fn mix64(mut z: u64) -> u64 {
    z = (z ^ (z >> 30)).wrapping_mul(0xbf58_476d_1ce4_e5b9);
    z = (z ^ (z >> 27)).wrapping_mul(0x94d0_49bb_1331_11eb);
    z ^ (z >> 31)
}

/// Uniform point on the unit disk, concentric mapping (Shirley and Chiu).
pub fn sample_concentric_disk(u: Vec2) -> Vec2 {
    let o = u * 2.0 - Vec2::ONE;
    if o.x == 0.0 && o.y == 0.0 {
        return Vec2::ZERO;
    }
    // The angle is `a` in [-pi/4, pi/4] on the x-major wedges and `pi/2 - a` on the others,
    // whose cosine and sine are `a`'s sine and cosine: no range reduction is needed.
    if o.x.abs() > o.y.abs() {
        let (sin, cos) = sin_cos_quarter(FRAC_PI_4 * (o.y / o.x));
        Vec2::new(cos, sin) * o.x
    } else {
        let (sin, cos) = sin_cos_quarter(FRAC_PI_4 * (o.x / o.y));
        Vec2::new(sin, cos) * o.y
    }
}

/// Sine and cosine of `x` in `[-pi/4, pi/4]` (Cephes' `sinf` and `cosf` polynomials, within
/// about one unit in the last place there). Plain `f32` products and sums in a fixed order, no
/// fused multiply-add and no libm, so that a lane kernel doing the same operations computes
/// the same bits (`wavefront` relies on it). Outside the interval the error grows quickly.
#[inline]
pub fn sin_cos_quarter(x: f32) -> (f32, f32) {
    let z = x * x;
    let sin = x + x * z * (SIN_C0 + z * (SIN_C1 + z * SIN_C2));
    let cos = 1.0 - 0.5 * z + z * z * (COS_C0 + z * (COS_C1 + z * COS_C2));
    (sin, cos)
}

/// [`sin_cos_quarter`]'s coefficients.
pub const SIN_C0: f32 = -1.666_665_5e-1;
pub const SIN_C1: f32 = 8.332_161e-3;
pub const SIN_C2: f32 = -1.951_529_6e-4;
pub const COS_C0: f32 = 4.166_664_6e-2;
pub const COS_C1: f32 = -1.388_731_6e-3;
pub const COS_C2: f32 = 2.443_315_7e-5;

/// Cosine-weighted direction on the hemisphere around +z.
pub fn sample_cosine_hemisphere(u: Vec2) -> Vec3 {
    let d = sample_concentric_disk(u);
    let z = (1.0 - d.x * d.x - d.y * d.y).max(0.0).sqrt();
    Vec3::new(d.x, d.y, z)
}

#[inline]
pub fn cosine_hemisphere_pdf(cos_theta: f32) -> f32 {
    cos_theta.max(0.0) * FRAC_1_PI
}

/// Uniform direction on the unit sphere.
pub fn sample_uniform_sphere(u: Vec2) -> Vec3 {
    let z = 1.0 - 2.0 * u.x;
    let r = (1.0 - z * z).max(0.0).sqrt();
    let phi = 2.0 * PI * u.y;
    Vec3::new(r * phi.cos(), r * phi.sin(), z)
}

pub const UNIFORM_SPHERE_PDF: f32 = 1.0 / (4.0 * PI);

/// Uniform direction in the cone of directions within `acos(cos_max)` of +z.
pub fn sample_uniform_cone(u: Vec2, cos_max: f32) -> Vec3 {
    let cos_theta = (1.0 - u.x) + u.x * cos_max;
    let sin_theta = (1.0 - cos_theta * cos_theta).max(0.0).sqrt();
    let phi = u.y * 2.0 * PI;
    Vec3::new(phi.cos() * sin_theta, phi.sin() * sin_theta, cos_theta)
}

#[inline]
pub fn uniform_cone_pdf(cos_max: f32) -> f32 {
    1.0 / (2.0 * PI * (1.0 - cos_max))
}

/// Uniform barycentric coordinates on a triangle (Heitz 2019 low-distortion map):
/// returns `(b0, b1, b2)`.
pub fn sample_uniform_triangle(u: Vec2) -> [f32; 3] {
    let (b0, b1);
    if u.x < u.y {
        b0 = u.x / 2.0;
        b1 = u.y - b0;
    } else {
        b1 = u.y / 2.0;
        b0 = u.x - b1;
    }
    [b0, b1, 1.0 - b0 - b1]
}

/// The power heuristic with exponent 2 (Veach), for one sample of each strategy.
#[inline]
pub fn power_heuristic(pdf_f: f32, pdf_g: f32) -> f32 {
    let f = pdf_f * pdf_f;
    let g = pdf_g * pdf_g;
    if f.is_infinite() {
        return 1.0;
    }
    if f + g == 0.0 { 0.0 } else { f / (f + g) }
}

/// A piecewise-constant distribution over `n` items (by weight): sampling in `O(log n)`.
#[derive(Clone, Debug, Default)]
pub struct Distribution1D {
    /// Normalised cumulative weights, `cdf[0] = 0`, `cdf[n] = 1`.
    cdf: Vec<f64>,
    weights: Vec<f32>,
    /// `weights[i] / total`.
    pmf: Vec<f32>,
    /// Per index `i` that the binary search can find, what [`Distribution1D::sample`] returns
    /// for it, read in one place: see [`Pick`].
    picks: Vec<Pick>,
    total: f64,
}

/// The item that the binary search's index `i` stands for, with what the pick needs of it: the
/// nearest item of non-zero weight, below `i` first (what the search's two loops over zero
/// weights found per sample before, always the same for the same `i`), its probability and its
/// cdf interval.
#[derive(Clone, Copy, Debug, Default)]
struct Pick {
    c0: f64,
    c1: f64,
    index: usize,
    p: f32,
}

impl Distribution1D {
    /// Builds from non-negative weights (negative or non-finite weights count as zero). An
    /// all-zero distribution samples nothing ([`Distribution1D::sample`] returns `None`).
    pub fn new(weights: &[f32]) -> Distribution1D {
        let weights: Vec<f32> =
            weights.iter().map(|&w| if w.is_finite() && w > 0.0 { w } else { 0.0 }).collect();
        let mut cdf = Vec::with_capacity(weights.len() + 1);
        cdf.push(0.0);
        let mut total = 0.0f64;
        for &w in &weights {
            total += f64::from(w);
            cdf.push(total);
        }
        if total > 0.0 {
            for c in &mut cdf {
                *c /= total;
            }
        }
        let pmf: Vec<f32> =
            weights.iter().map(|&w| if total > 0.0 { (f64::from(w) / total) as f32 } else { 0.0 }).collect();
        let n = weights.len();
        let picks = (0..n)
            .map(|mut i| {
                // Never return a zero-weight item (possible at the ends through rounding).
                while weights[i] == 0.0 && i > 0 {
                    i -= 1;
                }
                while weights[i] == 0.0 && i + 1 < n {
                    i += 1;
                }
                Pick { c0: cdf[i], c1: cdf[i + 1], index: i, p: pmf[i] }
            })
            .collect();
        Distribution1D { cdf, weights, pmf, picks, total }
    }

    pub fn len(&self) -> usize {
        self.weights.len()
    }

    pub fn is_empty(&self) -> bool {
        self.weights.is_empty()
    }

    /// Sum of the weights.
    pub fn total(&self) -> f64 {
        self.total
    }

    /// Picks an item with probability proportional to its weight; returns the index, its
    /// probability and `u` remapped to `[0, 1)` within the item. Always inlined: the light
    /// sample of the wavefront's x86-64-v3 batch picks with it twice per path vertex.
    #[inline(always)]
    pub fn sample(&self, u: f32) -> Option<(usize, f32, f32)> {
        if self.total <= 0.0 {
            return None;
        }
        let n = self.weights.len();
        if n == 1 {
            return Some((0, 1.0, u));
        }
        let u = f64::from(u);
        // One less than the first index whose cdf is > u, at most n - 1 (the cdf does not
        // decrease, so any binary search finds the same index).
        let i = self.cdf[1..n].partition_point(|&c| c <= u);
        // The item of non-zero weight that `i` stands for, its probability and its interval.
        let Pick { c0, c1, index, p } = self.picks[i];
        let width = c1 - c0;
        let remapped = if width > 0.0 { ((u - c0) / width).clamp(0.0, 1.0) } else { 0.5 };
        Some((index, p, (remapped as f32).min(1.0 - f32::EPSILON / 2.0)))
    }

    /// Probability of item `i`.
    pub fn pmf(&self, i: usize) -> f32 {
        self.pmf.get(i).copied().unwrap_or(0.0)
    }
}

/// A piecewise-constant density over `[0, 1)^2` on a `width x height` grid of cells (pbrt's
/// `PiecewiseConstant2D`): a marginal distribution over rows and one conditional distribution
/// per row, built on [`Distribution1D`].
#[derive(Clone, Debug, Default)]
pub struct Distribution2D {
    conditional: Vec<Distribution1D>,
    marginal: Distribution1D,
    width: usize,
    height: usize,
}

impl Distribution2D {
    /// Builds from row-major cell weights (`width * height` of them; negative or non-finite
    /// weights count as zero). `None` when the sizes do not match.
    pub fn new(weights: &[f32], width: usize, height: usize) -> Option<Distribution2D> {
        if width == 0 || height == 0 || weights.len() != width * height {
            return None;
        }
        let conditional: Vec<Distribution1D> = weights.chunks_exact(width).map(Distribution1D::new).collect();
        let row_totals: Vec<f32> = conditional.iter().map(|d| d.total() as f32).collect();
        Some(Distribution2D { marginal: Distribution1D::new(&row_totals), conditional, width, height })
    }

    /// Sum of the weights.
    pub fn total(&self) -> f64 {
        self.conditional.iter().map(Distribution1D::total).sum()
    }

    /// A point of `[0, 1)^2` with its density (with respect to area in `[0, 1)^2`); `None` when
    /// every weight is zero.
    pub fn sample(&self, u: Vec2) -> Option<(Vec2, f32)> {
        let (row, p_row, v) = self.marginal.sample(u.y)?;
        let (col, p_col, w) = self.conditional[row].sample(u.x)?;
        let point = Vec2::new((col as f32 + w) / self.width as f32, (row as f32 + v) / self.height as f32);
        let pdf = p_row * self.height as f32 * p_col * self.width as f32;
        Some((point.min(Vec2::splat(1.0 - f32::EPSILON / 2.0)), pdf))
    }

    /// The density [`Distribution2D::sample`] has at `point`.
    pub fn pdf(&self, point: Vec2) -> f32 {
        if !point.is_finite() {
            return 0.0;
        }
        let col = ((point.x * self.width as f32) as usize).min(self.width - 1);
        let row = ((point.y * self.height as f32) as usize).min(self.height - 1);
        self.marginal.pmf(row) * self.height as f32 * self.conditional[row].pmf(col) * self.width as f32
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn rng_streams_differ_and_repeat() {
        let mut a = Rng::for_pixel_sample(1, 3, 4, 0);
        let mut b = Rng::for_pixel_sample(1, 3, 4, 1);
        let mut c = Rng::for_pixel_sample(1, 3, 4, 0);
        let va: Vec<u32> = (0..8).map(|_| a.next_u32()).collect();
        let vb: Vec<u32> = (0..8).map(|_| b.next_u32()).collect();
        let vc: Vec<u32> = (0..8).map(|_| c.next_u32()).collect();
        assert_ne!(va, vb);
        assert_eq!(va, vc);
        let mut r = Rng::new(7, 0);
        let mean: f32 = (0..100_000).map(|_| r.uniform()).sum::<f32>() / 100_000.0;
        assert!((mean - 0.5).abs() < 0.01, "mean {mean}");
    }

    /// Sampling picks the item and remaps `u` exactly as the textbook binary search over the
    /// cdf followed by the two loops over zero weights does (what `sample` ran before the
    /// picks were made once, in `new`), bit for bit: zero weights (also at the ends, and all
    /// but one), weights that are negative, subnormal, huge, infinite or NaN, and `u` a zero of
    /// either sign, subnormal, negative, 1 or above, infinite or NaN.
    #[test]
    fn distribution_sampling_matches_a_plain_binary_search() {
        let reference = |d: &Distribution1D, u: f32| {
            let (u, n) = (f64::from(u), d.weights.len());
            let (mut lo, mut hi) = (0usize, n);
            while lo < hi {
                let mid = (lo + hi) / 2;
                if d.cdf[mid + 1] <= u { lo = mid + 1 } else { hi = mid }
            }
            let mut i = lo.min(n - 1);
            while d.weights[i] == 0.0 && i > 0 {
                i -= 1;
            }
            while d.weights[i] == 0.0 && i + 1 < n {
                i += 1;
            }
            let width = d.cdf[i + 1] - d.cdf[i];
            let r = if width > 0.0 { ((u - d.cdf[i]) / width).clamp(0.0, 1.0) } else { 0.5 };
            (i, d.pmf(i), (r as f32).min(1.0 - f32::EPSILON / 2.0))
        };
        let awkward_weights =
            [0.0, -0.0, -1.0, 1e-45, 1e-40, f32::MIN_POSITIVE, 3e38, f32::INFINITY, f32::NAN];
        let awkward_u = [
            0.0,
            -0.0,
            1e-45,
            -1e-45,
            f32::MIN_POSITIVE,
            -0.25,
            1.0 - f32::EPSILON / 2.0,
            1.0,
            1.5,
            f32::INFINITY,
            f32::NEG_INFINITY,
            f32::NAN,
            -f32::NAN,
        ];
        let bits = |s: Option<(usize, f32, f32)>| s.map(|(i, p, u)| (i, p.to_bits(), u.to_bits()));
        let mut rng = Rng::new(3, 1);
        for n in 1..12 {
            for k in 0..200 {
                let w: Vec<f32> = (0..n)
                    .map(|_| match rng.uniform() {
                        x if x < 0.3 => 0.0,
                        x if k % 2 == 1 && x < 0.45 => {
                            awkward_weights[(rng.uniform() * 9.0) as usize % awkward_weights.len()]
                        }
                        _ => rng.uniform() * 10.0,
                    })
                    .collect();
                let d = Distribution1D::new(&w);
                for u in (0..64).map(|_| rng.uniform()).chain(awkward_u) {
                    match d.sample(u) {
                        Some(s) if n > 1 => {
                            assert_eq!(bits(Some(s)), bits(Some(reference(&d, u))), "weights {w:?}, u {u}")
                        }
                        Some(s) => assert_eq!(bits(Some(s)), bits(Some((0, 1.0, u)))),
                        None => assert!(d.total() <= 0.0),
                    }
                }
            }
        }
    }

    #[test]
    fn distribution_matches_weights() {
        let d = Distribution1D::new(&[1.0, 0.0, 3.0]);
        assert_eq!(d.pmf(0), 0.25);
        assert_eq!(d.pmf(1), 0.0);
        let mut counts = [0u32; 3];
        let mut r = Rng::new(1, 1);
        for _ in 0..40_000 {
            let (i, p, rem) = d.sample(r.uniform()).unwrap();
            assert!(p > 0.0 && (0.0..1.0).contains(&rem));
            counts[i] += 1;
        }
        assert_eq!(counts[1], 0);
        assert!((f64::from(counts[2]) / 40_000.0 - 0.75).abs() < 0.02);
        assert!(Distribution1D::new(&[0.0, f32::NAN]).sample(0.3).is_none());
    }

    /// The 2D density integrates to 1, is proportional to the weights, and samples land where
    /// the weight is.
    #[test]
    fn distribution_2d_density_matches_weights() {
        let weights = [0.0, 1.0, 2.0, 0.0, 0.0, 5.0];
        let d = Distribution2D::new(&weights, 3, 2).unwrap();
        let area = 1.0 / 6.0;
        let integral: f32 = (0..6)
            .map(|i| d.pdf(Vec2::new(((i % 3) as f32 + 0.5) / 3.0, ((i / 3) as f32 + 0.5) / 2.0)) * area)
            .sum();
        assert!((integral - 1.0).abs() < 1e-5, "{integral}");
        assert!((d.pdf(Vec2::new(0.9, 0.9)) - 5.0 / 8.0 * 6.0).abs() < 1e-5);
        let mut r = Rng::new(4, 4);
        let mut hits = [0u32; 6];
        for _ in 0..20_000 {
            let (p, pdf) = d.sample(r.uniform2()).unwrap();
            assert!((pdf - d.pdf(p)).abs() < 1e-4 * pdf, "{p} {pdf}");
            hits[((p.y * 2.0) as usize) * 3 + (p.x * 3.0) as usize] += 1;
        }
        assert_eq!(hits[0] + hits[3] + hits[4], 0);
        assert!((f64::from(hits[5]) / 20_000.0 - 5.0 / 8.0).abs() < 0.02);
        assert!(Distribution2D::new(&weights, 4, 2).is_none());
        assert!(Distribution2D::new(&[0.0; 4], 2, 2).unwrap().sample(Vec2::splat(0.5)).is_none());
    }

    /// The polynomial sine and cosine stay within two units in the last place of libm's on
    /// their interval, and the concentric disc keeps its points on the disc.
    #[test]
    fn polynomial_sin_cos_matches_libm_on_its_interval() {
        use std::f32::consts::FRAC_PI_2;
        let n = 200_000;
        for i in 0..=n {
            let x = -FRAC_PI_4 + FRAC_PI_2 * (i as f32 / n as f32);
            let (s, c) = sin_cos_quarter(x);
            let (es, ec) = (f64::from(x).sin(), f64::from(x).cos());
            assert!(
                (f64::from(s) - es).abs() <= 2.0 * f64::from(f32::EPSILON) * es.abs().max(1e-30),
                "sin {x}"
            );
            assert!((f64::from(c) - ec).abs() <= 2.0 * f64::from(f32::EPSILON), "cos {x}");
        }
        let mut r = Rng::new(5, 2);
        for _ in 0..100_000 {
            let d = sample_concentric_disk(r.uniform2());
            assert!(d.length() <= 1.0 + 1e-6, "{d}");
        }
        assert_eq!(sample_concentric_disk(Vec2::new(1.0, 0.5)), Vec2::new(1.0, 0.0));
    }

    #[test]
    fn warps_stay_in_domain() {
        let mut r = Rng::new(3, 9);
        for _ in 0..10_000 {
            let u = r.uniform2();
            let d = sample_cosine_hemisphere(u);
            assert!(d.z >= 0.0 && (d.length() - 1.0).abs() < 1e-4);
            let s = sample_uniform_sphere(u);
            assert!((s.length() - 1.0).abs() < 1e-4);
            let c = sample_uniform_cone(u, 0.9);
            assert!(c.z >= 0.9 - 1e-6);
            let b = sample_uniform_triangle(u);
            assert!(b.iter().all(|&x| x >= -1e-6) && (b[0] + b[1] + b[2] - 1.0).abs() < 1e-6);
        }
    }
}
