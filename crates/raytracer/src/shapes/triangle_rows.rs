//! The watertight triangle test on a triangle stored for it, three vertices to a vector.
//!
//! [`intersect_triangle`](super::intersect_triangle) loads nine scalar coordinates per test and
//! permutes them with a three-way branch on the ray's axis. Here a triangle is stored as three
//! rows, the x, y and z coordinates of its three vertices ([`TriangleRows`]), so the ray's
//! permutation becomes the choice of which row to load ([`RowShear`], once per ray), and the
//! translation, the shear and the three `f64` edge functions are a few AVX2 instructions over the
//! three vertices at once. Each lane does the scalar test's IEEE operations in the same order
//! (Rust never fuses a multiply and an add), and the sums and the error bound take their terms in
//! the scalar order, so the result is [`intersect_triangle`](super::intersect_triangle)'s bit for
//! bit: the same hits, `t` and barycentrics, the same rejections.

use super::triangle::{RayShear, TriangleHit, t_error_bound};
#[cfg(target_arch = "x86_64")]
use crate::accel::TraversalRay;
use glam::Vec3;

/// A triangle's vertices as rows: `rows[axis] = [p0[axis], p1[axis], p2[axis], p2[axis]]`. The
/// fourth lane repeats the third, so every lane-wise value of the test is one of the three
/// vertices' (or edges') and a maximum or a sign over four lanes is the one over three.
#[derive(Clone, Copy, Debug, PartialEq)]
#[repr(C, align(16))]
pub struct TriangleRows {
    rows: [[f32; 4]; 3],
}

impl TriangleRows {
    pub fn new(p: [Vec3; 3]) -> TriangleRows {
        TriangleRows { rows: [0, 1, 2].map(|a| [p[0][a], p[1][a], p[2][a], p[2][a]]) }
    }
}

/// What the row test needs of a ray, made once per ray from its [`RayShear`]: which row becomes
/// each sheared axis (as its byte offset in [`TriangleRows`], so that a load needs no scaling of
/// the index per triangle), the origin's coordinates negated in that order (`p + -o` is `p - o` in
/// IEEE arithmetic, and lets the load be an operand of the addition), and the shear.
#[derive(Clone, Copy, Debug)]
pub struct RowShear {
    row_offsets: [usize; 3],
    minus_origin: [f32; 3],
    sx: f32,
    sy: f32,
    sz: f64,
}

impl RowShear {
    #[inline(always)]
    pub fn new(shear: &RayShear) -> RowShear {
        let kz = usize::from(shear.kz);
        let kx = (kz + 1) % 3;
        let ky = (kx + 1) % 3;
        RowShear {
            row_offsets: [kx, ky, kz].map(|k| k * std::mem::size_of::<[f32; 4]>()),
            minus_origin: shear.origin_permuted.map(|o| -o),
            sx: shear.sx,
            sy: shear.sy,
            sz: f64::from(shear.sz),
        }
    }

    /// `RowShear::new(&RayShear::for_traversal(ray))` bit for bit, without branches: the axis
    /// that becomes z comes from two lane comparisons of the direction's magnitudes, and the
    /// permutation is one `vpermilps` of the direction, the origin and the reciprocals. Which
    /// component of a bounce ray's direction is largest is a random choice, so the scalar
    /// code's two branches on it were mispredicted for about one ray in two.
    ///
    /// # Safety
    /// The CPU must have AVX (an [`X86_64V3`](crate::accel::X86_64V3) exists); the caller should
    /// be compiled with it, or the intrinsics are calls.
    #[cfg(target_arch = "x86_64")]
    #[inline(always)]
    pub unsafe fn for_traversal_avx(ray: &TraversalRay) -> RowShear {
        use std::arch::x86_64::*;
        /// Per index `(x > y) | (y > z) << 1 | (x > z) << 2` of the magnitudes, the axis that
        /// [`RayShear::for_traversal`] makes z: the first of the largest, so x on a tie with y or
        /// z only where it is the larger of the two others, and y before z.
        const KZ: [usize; 8] = {
            let mut kz = [0; 8];
            let mut i = 0;
            while i < 8 {
                let (x_gt_y, y_gt_z, x_gt_z) = (i & 1 != 0, i & 2 != 0, i & 4 != 0);
                kz[i] = if x_gt_y {
                    if x_gt_z { 0 } else { 2 }
                } else if y_gt_z {
                    1
                } else {
                    2
                };
                i += 1;
            }
            kz
        };
        /// Per axis z, the lanes `(kx, ky, kz, 3)` for `vpermilps` and the rows' byte offsets.
        const PERMUTE: [[i32; 4]; 3] = [[1, 2, 0, 3], [2, 0, 1, 3], [0, 1, 2, 3]];
        const ROW: usize = std::mem::size_of::<[f32; 4]>();
        const OFFSETS: [[usize; 3]; 3] = [[ROW, 2 * ROW, 0], [2 * ROW, 0, ROW], [0, ROW, 2 * ROW]];
        // SAFETY: the caller guarantees AVX; the loads read the constant tables above.
        unsafe {
            let d = __m128::from(ray.direction);
            // The traversal ray's direction and origin are finite (`TraversalRay::new`), so the
            // comparisons are the scalar code's: lanes 0 to 2 of `a > a.yzx` are x > y, y > z and
            // z > x, of `a < a.yzx` x < y, y < z and z < x (which is x > z).
            let a = _mm_andnot_ps(_mm_set1_ps(-0.0), d);
            let a_yzx = _mm_permute_ps::<0b11_00_10_01>(a);
            let greater = _mm_movemask_ps(_mm_cmpgt_ps(a, a_yzx));
            let less = _mm_movemask_ps(_mm_cmplt_ps(a, a_yzx));
            let kz = KZ[((greater & 3) | (less & 4)) as usize];
            let lanes = _mm_loadu_si128(PERMUTE[kz].as_ptr().cast());
            // `-x` flips the sign bit, as the `xor` does.
            let minus = _mm_set1_ps(-0.0);
            let dp = _mm_permutevar_ps(d, lanes);
            let minus_origin = _mm_xor_ps(_mm_permutevar_ps(__m128::from(ray.origin), lanes), minus);
            // Lanes 0 and 1: `-d_x / d_z` and `-d_y / d_z`, the scalar divisions.
            let shear = _mm_div_ps(_mm_xor_ps(dp, minus), _mm_permute_ps::<0b10_10_10_10>(dp));
            // The largest component is never flushed (as in `RayShear::for_traversal`).
            let inv_dz = _mm_permutevar_ps(__m128::from(ray.inv_direction()), lanes);
            let mut origin = [0.0f32; 4];
            _mm_storeu_ps(origin.as_mut_ptr(), minus_origin);
            RowShear {
                row_offsets: OFFSETS[kz],
                minus_origin: [origin[0], origin[1], origin[2]],
                sx: _mm_cvtss_f32(shear),
                sy: _mm_cvtss_f32(_mm_movehdup_ps(shear)),
                sz: f64::from(_mm_cvtss_f32(_mm_movehl_ps(inv_dz, inv_dz))),
            }
        }
    }
}

/// [`intersect_triangle`](super::intersect_triangle) of the triangle `tri` for parameters in
/// `(0, t_max)`, the same result bit for bit, with AVX2.
///
/// # Safety
/// The CPU must have AVX2 (an [`X86_64V3`](crate::accel::X86_64V3) exists); the caller should
/// be compiled with it, or the intrinsics are calls.
#[cfg(target_arch = "x86_64")]
#[inline(always)]
pub unsafe fn intersect_rows_avx2(shear: &RowShear, tri: &TriangleRows, t_max: f32) -> Option<TriangleHit> {
    use std::arch::x86_64::*;
    // No closures here: a closure does not inherit its caller's target features.
    // SAFETY: the caller guarantees AVX2; the loads read rows of `tri` (aligned to 16 bytes),
    // at the offsets of rows 0 to 2 (`RowShear::new`).
    unsafe {
        // Translated, permuted and sheared vertices: lane i is vertex i (lane 3 repeats 2).
        macro_rules! translated {
            ($axis:expr) => {
                _mm_add_ps(
                    _mm_set1_ps(shear.minus_origin[$axis]),
                    _mm_load_ps(tri.rows.as_ptr().byte_add(shear.row_offsets[$axis]).cast()),
                )
            };
        }
        let (x, y, z) = (translated!(0), translated!(1), translated!(2));
        let xs = _mm_add_ps(x, _mm_mul_ps(_mm_set1_ps(shear.sx), z));
        let ys = _mm_add_ps(y, _mm_mul_ps(_mm_set1_ps(shear.sy), z));

        // Edge functions in f64: lane 0 is `bx cy - by cx`, 1 `cx ay - cy ax`, 2 and 3 `ax by -
        // ay bx`. The products of f32 values are exact, the difference rounds once.
        let (xd, yd) = (_mm256_cvtps_pd(xs), _mm256_cvtps_pd(ys));
        // Lanes (1, 2, 0, 0) and (2, 0, 1, 1) of a vector.
        const NEXT: i32 = 0b00_00_10_01;
        const AFTER: i32 = 0b01_01_00_10;
        let e = _mm256_sub_pd(
            _mm256_mul_pd(_mm256_permute4x64_pd::<NEXT>(xd), _mm256_permute4x64_pd::<AFTER>(yd)),
            _mm256_mul_pd(_mm256_permute4x64_pd::<NEXT>(yd), _mm256_permute4x64_pd::<AFTER>(xd)),
        );
        // Ordered comparisons: a NaN is neither, as in the scalar test.
        let zero = _mm256_setzero_pd();
        let negative = _mm256_movemask_pd(_mm256_cmp_pd::<_CMP_LT_OQ>(e, zero));
        let positive = _mm256_movemask_pd(_mm256_cmp_pd::<_CMP_GT_OQ>(e, zero));
        if negative != 0 && positive != 0 {
            return None;
        }
        let (e01, e23) = (_mm256_castpd256_pd128(e), _mm256_extractf128_pd::<1>(e));
        let (e0, e1, e2) = (_mm_cvtsd_f64(e01), _mm_cvtsd_f64(_mm_unpackhi_pd(e01, e01)), _mm_cvtsd_f64(e23));
        let det = e0 + e1 + e2;
        // `det == 0 || !det.is_finite()` as one comparison of the magnitude's bits (LLVM turns
        // the float comparisons into a longer classification): zero wraps to the largest value,
        // and infinity and NaN are at or above infinity's bits.
        const INFINITY_BITS: u64 = 0x7ff0_0000_0000_0000;
        if (det.to_bits() & !(1 << 63)).wrapping_sub(1) >= INFINITY_BITS - 1 {
            return None;
        }

        // Scaled hit distance and the interval test against (0, t_max).
        let zt = _mm256_mul_pd(_mm256_cvtps_pd(z), _mm256_set1_pd(shear.sz));
        let terms = _mm256_mul_pd(e, zt);
        let (t01, t23) = (_mm256_castpd256_pd128(terms), _mm256_extractf128_pd::<1>(terms));
        let t_scaled = _mm_cvtsd_f64(t01) + _mm_cvtsd_f64(_mm_unpackhi_pd(t01, t01)) + _mm_cvtsd_f64(t23);
        let t_max64 = f64::from(t_max);
        if det < 0.0 && (t_scaled >= 0.0 || t_scaled < t_max64 * det) {
            return None;
        }
        if det > 0.0 && (t_scaled <= 0.0 || t_scaled > t_max64 * det) {
            return None;
        }
        let inv_det = 1.0 / det;
        let t = t_scaled * inv_det;

        // The maxima of the error bound over the lanes. Every value is finite here (a
        // non-finite coordinate makes `det` non-finite), so `max` is the scalar test's
        // `greater` in any order; an f32 converted to f64 and back is itself.
        macro_rules! max_pd {
            ($v:expr) => {{
                let v = _mm256_andnot_pd(_mm256_set1_pd(-0.0), $v);
                let m = _mm_max_pd(_mm256_castpd256_pd128(v), _mm256_extractf128_pd::<1>(v));
                _mm_cvtsd_f64(_mm_max_sd(m, _mm_unpackhi_pd(m, m)))
            }};
        }
        macro_rules! max_ps {
            ($v:expr) => {{
                let v = _mm_andnot_ps(_mm_set1_ps(-0.0), $v);
                let m = _mm_max_ps(v, _mm_movehl_ps(v, v));
                _mm_cvtss_f32(_mm_max_ss(m, _mm_movehdup_ps(m)))
            }};
        }
        let max_zt = max_pd!(zt) as f32;
        let max_z_unscaled = max_ps!(z);
        let max_xt = max_ps!(xs);
        let max_yt = max_ps!(ys);
        let max_e = max_pd!(e) as f32;
        let delta_t = t_error_bound(max_xt, max_yt, max_zt, max_z_unscaled, max_e, inv_det);
        let t32 = t as f32;
        if !(t32 > delta_t) || !(t32 < t_max || t_max.is_infinite()) {
            return None;
        }
        Some(TriangleHit { t: t32, b: [e0 * inv_det, e1 * inv_det, e2 * inv_det] })
    }
}

#[cfg(all(test, target_arch = "x86_64"))]
mod tests {
    use super::*;
    use crate::accel::X86_64V3;
    use crate::sampling::{Rng, sample_uniform_sphere};
    use crate::shapes::intersect_triangle;

    /// Both tests on one ray and triangle, compared bit for bit. Returns whether it hit.
    fn compare(_v3: X86_64V3, ray: &TraversalRay, p: [Vec3; 3], t_max: f32) -> bool {
        let shear = RayShear::for_traversal(ray);
        let expected = intersect_triangle(&shear, p[0], p[1], p[2], t_max);
        // SAFETY: an `X86_64V3` exists only on a CPU with AVX2.
        let got = unsafe { intersect_rows_avx2(&RowShear::new(&shear), &TriangleRows::new(p), t_max) };
        let bits = |h: Option<TriangleHit>| h.map(|h| (h.t.to_bits(), h.b.map(f64::to_bits)));
        assert_eq!(bits(got), bits(expected), "ray {ray:?}, triangle {p:?}, t_max {t_max}");
        expected.is_some()
    }

    fn point(rng: &mut Rng, scale: f32) -> Vec3 {
        (Vec3::new(rng.uniform(), rng.uniform(), rng.uniform()) * 2.0 - 1.0) * scale
    }

    /// The row test gives the scalar test's result bit for bit, so it never rejects a hit the
    /// scalar test accepts nor accepts one it rejects: rays aimed at random triangles, at their
    /// vertices, at points of their edges (where rounding decides) and just beside them, along
    /// each axis and with tiny components; triangles large and small, degenerate, far from the
    /// origin; segments that end just before, at and after the hit; short and long directions.
    #[test]
    fn rows_match_the_scalar_test() {
        let Some(v3) = X86_64V3::detect() else {
            eprintln!("this CPU has no x86-64-v3: the row test cannot run here");
            return;
        };
        let mut rng = Rng::new(77, 5);
        let (mut hits, mut misses, mut edge_hits) = (0, 0, 0);
        for k in 0..200_000 {
            let scale = [1.0, 1e-3, 1e3, 0.02][k % 4];
            let centre = if k % 11 == 0 { Vec3::new(1e4, -3e3, 2e2) } else { Vec3::ZERO };
            let mut p = [0; 3].map(|_| centre + point(&mut rng, scale));
            match k % 13 {
                // Degenerate: a repeated vertex, or three collinear ones.
                0 => p[2] = p[1],
                1 => p[2] = p[0] + (p[1] - p[0]) * 0.5,
                // Axis-aligned, as the Cornell box's walls.
                2 | 3 => p.iter_mut().for_each(|v| v[k % 3] = centre[k % 3] + 0.25 * scale),
                _ => {}
            }
            let origin = centre + point(&mut rng, 3.0 * scale);
            // Aim at a vertex, at a point of an edge, inside, or anywhere near.
            let (i, j) = (k % 3, (k + 1) % 3);
            let s = rng.uniform();
            let target = match (k / 13) % 5 {
                0 => p[i],
                1 => p[i] + (p[j] - p[i]) * s,
                2 => (p[0] + p[1] + p[2]) / 3.0,
                3 => p[i] + (p[j] - p[i]) * s + point(&mut rng, 1e-6 * scale),
                _ => centre + point(&mut rng, scale),
            };
            let length = [1.0, 1e-4, 1e4, 0.37][(k / 7) % 4];
            let mut direction = (target - origin).normalize_or(Vec3::Z) * length;
            if k % 17 == 0 {
                direction = sample_uniform_sphere(rng.uniform2());
            }
            if k % 19 == 0 {
                direction[(k / 19) % 3] = [0.0, -0.0, 1e-25, -1e-30][(k / 57) % 4];
            }
            let Some(ray) = TraversalRay::new(origin, direction, 0.0, f32::INFINITY) else { continue };
            let hit = compare(v3, &ray, p, f32::INFINITY);
            if hit {
                // The segment ends just before, at and just after the hit, and far beyond.
                let shear = RayShear::for_traversal(&ray);
                let t = intersect_triangle(&shear, p[0], p[1], p[2], f32::INFINITY).map_or(1.0, |h| h.t);
                for t_max in [t.next_down(), t, t.next_up(), t * 2.0, f32::MAX] {
                    compare(v3, &ray, p, t_max);
                }
                edge_hits += usize::from(matches!((k / 13) % 5, 0 | 1));
                hits += 1;
            } else {
                misses += 1;
            }
            compare(v3, &ray, p, [0.0, 1.0, 1e-3, 1e30][k % 4]);
        }
        assert!(hits > 40_000 && misses > 40_000 && edge_hits > 10_000, "{hits} {misses} {edge_hits}");
    }

    /// `RowShear::for_traversal_avx` gives `RowShear::new(&RayShear::for_traversal(ray))` bit for
    /// bit: directions whose components are zeros of both signs, subnormals, the smallest normal,
    /// values that the traversal ray flushes, huge ones and ties of equal magnitude and either
    /// sign (where the scalar code's order of comparisons decides the axis), with origins as
    /// awkward; infinities and NaNs, which have no traversal ray, are tried too.
    #[test]
    fn shear_without_branches_matches_the_scalar_one() {
        let Some(_v3) = X86_64V3::detect() else {
            eprintln!("this CPU has no x86-64-v3: the lane shear cannot run here");
            return;
        };
        let special = [
            0.0,
            -0.0,
            1e-45,
            -1e-45,
            1e-40,
            -3e-39,
            f32::MIN_POSITIVE,
            -f32::MIN_POSITIVE,
            1e-20,
            -1e-20,
            0.5,
            -0.5,
            1.0,
            -1.0,
            3e38,
            -f32::MAX,
            f32::INFINITY,
            f32::NEG_INFINITY,
            f32::NAN,
            -f32::NAN,
        ];
        let mut rng = Rng::new(15, 3);
        let mut pick = |k: usize| -> f32 {
            match k % 3 {
                0 => special[(rng.uniform() * special.len() as f32) as usize % special.len()],
                // A magnitude that ties with another component's, of either sign.
                1 => [1.0, -1.0, 0.5, -0.5][(rng.uniform() * 4.0) as usize % 4],
                _ => (rng.uniform() * 2.0 - 1.0) * 10f32.powf(rng.uniform() * 60.0 - 30.0),
            }
        };
        let (mut rays, mut axes) = (0, [0; 3]);
        for k in 0..200_000 {
            let d = Vec3::new(pick(k), pick(k / 3), pick(k / 9));
            let o =
                if k % 5 == 0 { Vec3::new(pick(k + 1), pick(k / 3 + 2), pick(k / 9)) } else { Vec3::ZERO };
            let Some(ray) = TraversalRay::new(o, d, 0.0, f32::INFINITY) else { continue };
            let shear = RayShear::for_traversal(&ray);
            let expected = RowShear::new(&shear);
            // SAFETY: an `X86_64V3` exists only on a CPU with AVX.
            let got = unsafe { RowShear::for_traversal_avx(&ray) };
            let bits = |s: RowShear| {
                (
                    s.row_offsets,
                    s.minus_origin.map(f32::to_bits),
                    s.sx.to_bits(),
                    s.sy.to_bits(),
                    s.sz.to_bits(),
                )
            };
            assert_eq!(bits(got), bits(expected), "origin {o:?}, direction {d:?}");
            rays += 1;
            axes[usize::from(shear.kz)] += 1;
        }
        assert!(rays > 50_000 && axes.iter().all(|&n| n > 10_000), "{rays} {axes:?}");
    }
}
