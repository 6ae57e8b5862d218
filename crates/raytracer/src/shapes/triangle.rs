//! Watertight ray-triangle intersection (Woop, Benthin and Wald 2013, as in pbrt-v4).
//!
//! The ray is translated to the origin and sheared so that it runs along +z; the triangle's
//! vertices go through the same `f32` steps, so a vertex shared by two triangles is transformed
//! identically for both. The 2D edge functions are then evaluated in `f64`, where the products of
//! two `f32` values are exact and the single rounded difference keeps its exact sign: a ray
//! through a shared edge or vertex is reported by at least one of the triangles that share it.

use crate::accel::TraversalRay;
use crate::math::gamma;
use glam::{DVec3, Vec3};

/// A ray-triangle hit: the ray parameter and the barycentric coordinates of the hit point
/// (`b0 + b1 + b2 = 1` in `f64`). Which side was hit is [`hits_front`], asked only for
/// one-sided shapes.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct TriangleHit {
    pub t: f32,
    pub b: [f64; 3],
}

/// True when a ray along `direction` hits the side the normal `(p1 - p0) x (p2 - p0)` of the
/// triangle `(p0, p1, p2)` points to (from the geometric normal, as `f32`).
#[inline]
pub fn hits_front(p0: Vec3, p1: Vec3, p2: Vec3, direction: Vec3) -> bool {
    (p1 - p0).cross(p2 - p0).dot(direction) < 0.0
}

/// Precomputed per-ray values of the watertight test (the permutation and shear).
#[derive(Clone, Copy, Debug)]
pub struct RayShear {
    pub origin: Vec3,
    pub direction: Vec3,
    /// The axis that becomes z (the largest direction component); x and y follow cyclically.
    pub(super) kz: u8,
    /// The origin's coordinates in the permuted order.
    pub(super) origin_permuted: [f32; 3],
    pub(super) sx: f32,
    pub(super) sy: f32,
    pub(super) sz: f32,
}

impl RayShear {
    /// `None` for a zero or non-finite direction.
    pub fn new(origin: Vec3, direction: Vec3) -> Option<RayShear> {
        if !(direction.is_finite() && origin.is_finite()) || direction == Vec3::ZERO {
            return None;
        }
        let a = direction.abs();
        let kz = if a.x > a.y {
            if a.x > a.z { 0 } else { 2 }
        } else if a.y > a.z {
            1
        } else {
            2
        };
        let kx = (kz + 1) % 3;
        let ky = (kx + 1) % 3;
        let d = [direction[kx], direction[ky], direction[kz]];
        let origin_permuted = [origin[kx], origin[ky], origin[kz]];
        Some(RayShear {
            origin,
            direction,
            kz: kz as u8,
            origin_permuted,
            sx: -d[0] / d[2],
            sy: -d[1] / d[2],
            sz: 1.0 / d[2],
        })
    }

    /// The shear of a ray already prepared for traversal, reusing its reciprocal direction for
    /// `sz`; the same values as [`RayShear::new`] bit for bit. `Sx` and `Sy` stay divisions:
    /// `-d_x * (1 / d_z)` can differ from `-d_x / d_z` in the last bit, which would move every
    /// sheared vertex and so change hits on edges and the last bits of `t`.
    #[inline]
    pub fn for_traversal(ray: &TraversalRay) -> RayShear {
        let d = Vec3::from(ray.direction);
        let o = Vec3::from(ray.origin);
        let a = d.abs();
        // The permutation written out per case (indexing a vector by a variable axis compiles
        // to a chain of selects per component).
        let (kz, d, origin_permuted) = if a.x > a.y {
            if a.x > a.z {
                (0, [d.y, d.z, d.x], [o.y, o.z, o.x])
            } else {
                (2, [d.x, d.y, d.z], [o.x, o.y, o.z])
            }
        } else if a.y > a.z {
            (1, [d.z, d.x, d.y], [o.z, o.x, o.y])
        } else {
            (2, [d.x, d.y, d.z], [o.x, o.y, o.z])
        };
        // The largest component is never flushed to zero by the traversal ray (a ray whose
        // components are all flushed has no traversal ray), so its reciprocal is `1 / d_z`.
        let inv_dz = ray.inv_direction()[kz];
        RayShear {
            origin: o,
            direction: Vec3::from(ray.direction),
            kz: kz as u8,
            origin_permuted,
            sx: -d[0] / d[2],
            sy: -d[1] / d[2],
            sz: inv_dz,
        }
    }

    /// Translated, permuted and sheared vertex (z not yet scaled).
    #[inline(always)]
    fn transform(&self, p: Vec3) -> [f32; 3] {
        // The permutation is one of three rotations, the same for every triangle of a ray, so
        // this branch predicts well; the differences are the same f32 operations as
        // `p - origin` followed by the permutation.
        let o = &self.origin_permuted;
        let (x, y, z) = match self.kz {
            0 => (p.y - o[0], p.z - o[1], p.x - o[2]),
            1 => (p.z - o[0], p.x - o[1], p.y - o[2]),
            _ => (p.x - o[0], p.y - o[1], p.z - o[2]),
        };
        [x + self.sx * z, y + self.sy * z, z]
    }
}

/// Intersects the triangle `(p0, p1, p2)` with the ray described by `shear` for parameters in
/// `(0, t_max)`. Degenerate (zero-area) triangles are never hit.
#[inline(always)]
pub fn intersect_triangle(shear: &RayShear, p0: Vec3, p1: Vec3, p2: Vec3, t_max: f32) -> Option<TriangleHit> {
    let a = shear.transform(p0);
    let b = shear.transform(p1);
    let c = shear.transform(p2);

    // Edge functions in f64: exact products, one rounding, so signs are exact.
    let (ax, ay) = (f64::from(a[0]), f64::from(a[1]));
    let (bx, by) = (f64::from(b[0]), f64::from(b[1]));
    let (cx, cy) = (f64::from(c[0]), f64::from(c[1]));
    let e0 = bx * cy - by * cx;
    let e1 = cx * ay - cy * ax;
    let e2 = ax * by - ay * bx;
    if (e0 < 0.0 || e1 < 0.0 || e2 < 0.0) && (e0 > 0.0 || e1 > 0.0 || e2 > 0.0) {
        return None;
    }
    let det = e0 + e1 + e2;
    if det == 0.0 || !det.is_finite() {
        return None;
    }

    // Scaled hit distance and the interval test against (0, t_max).
    let sz = f64::from(shear.sz);
    let (az, bz, cz) = (f64::from(a[2]) * sz, f64::from(b[2]) * sz, f64::from(c[2]) * sz);
    let t_scaled = e0 * az + e1 * bz + e2 * cz;
    let t_max = f64::from(t_max);
    if det < 0.0 && (t_scaled >= 0.0 || t_scaled < t_max * det) {
        return None;
    }
    if det > 0.0 && (t_scaled <= 0.0 || t_scaled > t_max * det) {
        return None;
    }
    let inv_det = 1.0 / det;
    let t = t_scaled * inv_det;

    // Make sure t is conservatively greater than zero: pbrt-v4's bound on the f32 steps above
    // (translation, shear, z scaling; the f64 edge functions add only a tiny relative error),
    // with one correction. The error of the sheared x and y is bounded by their size plus the
    // size of the *unscaled* z (|Sx|, |Sy| <= 1); pbrt uses the z already scaled by 1/d_z, which
    // is only an upper bound for directions of length about one and rejects valid hits of short
    // ray directions (a shadow ray `p_light - p` in a scene a millimetre across).
    // The bounds below take maxima of finite, non-negative values: a non-finite coordinate
    // would have made an edge function, so `det`, non-finite. `greater` is then the same as
    // `max`, without `max`'s NaN handling (four more instructions per maximum on x86-64).
    let max_zt = greater(greater(az.abs(), bz.abs()), cz.abs()) as f32;
    let max_z_unscaled = greater(greater(a[2].abs(), b[2].abs()), c[2].abs());
    let max_xt = greater(greater(ax.abs(), bx.abs()), cx.abs()) as f32;
    let max_yt = greater(greater(ay.abs(), by.abs()), cy.abs()) as f32;
    let max_e = greater(greater(e0.abs(), e1.abs()), e2.abs()) as f32;
    let delta_t = t_error_bound(max_xt, max_yt, max_zt, max_z_unscaled, max_e, inv_det);
    let t32 = t as f32;
    if !(t32 > delta_t) || !(t32 < t_max as f32 || t_max.is_infinite()) {
        return None;
    }
    Some(TriangleHit { t: t32, b: [e0 * inv_det, e1 * inv_det, e2 * inv_det] })
}

/// The bound on the error of `t` from the largest magnitudes of the sheared `x`, `y`, the
/// scaled and the unscaled `z` of the three vertices, of the edge functions, and `1 / det`
/// (see [`intersect_triangle`]). Shared with the row test, which must compute it identically.
#[inline(always)]
pub(super) fn t_error_bound(
    max_xt: f32,
    max_yt: f32,
    max_zt: f32,
    max_z_unscaled: f32,
    max_e: f32,
    inv_det: f64,
) -> f32 {
    let delta_z = gamma(3) * max_zt;
    let delta_x = gamma(5) * (max_xt + max_z_unscaled);
    let delta_y = gamma(5) * (max_yt + max_z_unscaled);
    let delta_e = 2.0 * (gamma(2) * max_xt * max_yt + delta_y * max_xt + delta_x * max_yt);
    3.0 * (gamma(3) * max_e * max_zt + delta_e * max_zt + delta_z * max_e) * (inv_det.abs() as f32)
}

/// The larger of `a` and `b` (`b` when they compare equal or either is NaN: one `maxss` or
/// `maxsd`).
#[inline(always)]
fn greater<T: PartialOrd>(a: T, b: T) -> T {
    if a > b { a } else { b }
}

/// The hit point `b0 p0 + b1 p1 + b2 p2` in `f64`, with an absolute bound on its `f64` error.
#[inline]
pub fn barycentric_point(b: [f64; 3], p0: Vec3, p1: Vec3, p2: Vec3) -> (DVec3, DVec3) {
    let (q0, q1, q2) = (p0.as_dvec3(), p1.as_dvec3(), p2.as_dvec3());
    let p = q0 * b[0] + q1 * b[1] + q2 * b[2];
    let abs_sum = (q0 * b[0]).abs() + (q1 * b[1]).abs() + (q2 * b[2]).abs();
    // The barycentrics sum to one within a few f64 ulps; the combination adds a few more.
    (p, abs_sum * (8.0 * f64::EPSILON))
}

/// [`barycentric_point`] of a triangle's vertices `tp`, rounded to `f32` with its error bound
/// ([`round_point`](crate::math::round_point)): the point in `f64`, the rounded point and the
/// bound, the same bits. Where `v3` says the CPU has x86-64-v3, the three components are the
/// lanes of AVX registers from the vertices to the bound
/// ([`round_point_lanes`](crate::math::round_point_lanes)), the same IEEE operations in the
/// same order per lane.
/// Always inlined, for the wavefront's x86-64-v3 batch; a caller without those target
/// features passes `None` (the intrinsics would be calls).
#[inline(always)]
pub(crate) fn barycentric_point_rounded_v3(
    v3: Option<crate::accel::X86_64V3>,
    b: [f64; 3],
    tp: &[Vec3; 3],
) -> (DVec3, Vec3, Vec3) {
    #[cfg(target_arch = "x86_64")]
    if let Some(v3) = v3 {
        use std::arch::x86_64::*;
        // SAFETY: `v3` exists only on a CPU with AVX2. The loads read 16 bytes at byte offsets
        // 0, 12 and 20 of the 36 of `tp` (`Vec3` is three `f32`, `repr(C)`).
        let (p, err) = unsafe {
            let base = tp.as_ptr().cast::<f32>();
            // Each vertex in lanes 0 to 2; lane 3 holds a neighbour's component, and its
            // results are never read.
            let q0 = _mm_loadu_ps(base);
            let q1 = _mm_loadu_ps(base.add(3));
            let q2 = _mm_permute_ps::<0b00_11_10_01>(_mm_loadu_ps(base.add(5)));
            let term = |q: __m128, b: f64| _mm256_mul_pd(_mm256_cvtps_pd(q), _mm256_set1_pd(b));
            let (t0, t1, t2) = (term(q0, b[0]), term(q1, b[1]), term(q2, b[2]));
            let p = _mm256_add_pd(_mm256_add_pd(t0, t1), t2);
            let magnitude = _mm256_castsi256_pd(_mm256_set1_epi64x(i64::MAX));
            let abs_sum = _mm256_add_pd(
                _mm256_add_pd(_mm256_and_pd(t0, magnitude), _mm256_and_pd(t1, magnitude)),
                _mm256_and_pd(t2, magnitude),
            );
            (p, _mm256_mul_pd(abs_sum, _mm256_set1_pd(8.0 * f64::EPSILON)))
        };
        // SAFETY: an `__m256d` is four `f64`.
        let [x, y, z, _] = unsafe { std::mem::transmute::<__m256d, [f64; 4]>(p) };
        let (pf, bound) = crate::math::round_point_lanes(v3, p, err);
        return (DVec3::new(x, y, z), pf, bound);
    }
    #[cfg(not(target_arch = "x86_64"))]
    let _ = v3;
    let (p, err) = barycentric_point(b, tp[0], tp[1], tp[2]);
    let (pf, bound) = crate::math::round_point(p, err);
    (p, pf, bound)
}

#[cfg(test)]
mod tests {
    use super::*;

    fn hit(o: Vec3, d: Vec3, p: [Vec3; 3]) -> Option<TriangleHit> {
        intersect_triangle(&RayShear::new(o, d).unwrap(), p[0], p[1], p[2], f32::INFINITY)
    }

    #[test]
    fn hits_and_misses() {
        let tri = [Vec3::new(0.0, 0.0, 0.0), Vec3::new(1.0, 0.0, 0.0), Vec3::new(0.0, 1.0, 0.0)];
        let h = hit(Vec3::new(0.25, 0.25, 2.0), -Vec3::Z, tri).unwrap();
        assert!((h.t - 2.0).abs() < 1e-6);
        let p = barycentric_point(h.b, tri[0], tri[1], tri[2]).0;
        assert!((p - DVec3::new(0.25, 0.25, 0.0)).length() < 1e-7);
        // Normal is +z; a ray coming from +z hits the front.
        assert!(hits_front(tri[0], tri[1], tri[2], -Vec3::Z));
        assert!(hit(Vec3::new(0.25, 0.25, -2.0), Vec3::Z, tri).is_some());
        assert!(!hits_front(tri[0], tri[1], tri[2], Vec3::Z));
        assert!(hit(Vec3::new(0.75, 0.75, 2.0), -Vec3::Z, tri).is_none());
        // Behind the origin.
        assert!(hit(Vec3::new(0.25, 0.25, -2.0), -Vec3::Z, tri).is_none());
        // Degenerate triangle.
        let degenerate = [Vec3::ZERO, Vec3::X, Vec3::X * 2.0];
        assert!(hit(Vec3::new(0.5, 0.0, 1.0), -Vec3::Z, degenerate).is_none());
    }

    #[test]
    fn shared_edge_is_watertight() {
        // Two triangles sharing the diagonal of a square; rays aimed exactly at the diagonal.
        let a = [Vec3::new(0.0, 0.0, 0.0), Vec3::new(1.0, 0.0, 0.0), Vec3::new(1.0, 1.0, 0.0)];
        let b = [Vec3::new(0.0, 0.0, 0.0), Vec3::new(1.0, 1.0, 0.0), Vec3::new(0.0, 1.0, 0.0)];
        let o = Vec3::new(0.1234, -0.771, 3.3);
        // Interior points of the diagonal (its ends are corners of the open square, where a ray
        // rounded to f32 may pass just outside).
        for i in 1..1000 {
            let s = i as f32 / 1000.0;
            let target = Vec3::new(s, s, 0.0);
            let d = target - o;
            assert!(hit(o, d, a).is_some() || hit(o, d, b).is_some(), "leak at {s}");
        }
    }

    use crate::accel::TraversalRay;
    use crate::sampling::{Rng, sample_uniform_sphere};

    /// The shear made from a traversal ray is the one `RayShear::new` makes, bit for bit.
    #[test]
    fn shear_for_traversal_is_the_same() {
        let mut rng = Rng::new(12, 3);
        for k in 0..5000 {
            let o = Vec3::new(rng.uniform(), rng.uniform(), rng.uniform()) * 10.0 - 5.0;
            let mut d = sample_uniform_sphere(rng.uniform2()) * 10f32.powf(rng.uniform() * 8.0 - 4.0);
            // Axis-aligned and tiny components too.
            d[k % 3] = [0.0, -0.0, 1e-25, d[k % 3]][(k / 3) % 4];
            let (Some(a), Some(ray)) = (RayShear::new(o, d), TraversalRay::new(o, d, 0.0, 1.0)) else {
                continue;
            };
            let b = RayShear::for_traversal(&ray);
            assert_eq!(
                (a.kz, a.origin_permuted, a.sx.to_bits(), a.sy.to_bits(), a.sz.to_bits()),
                (b.kz, b.origin_permuted, b.sx.to_bits(), b.sy.to_bits(), b.sz.to_bits())
            );
        }
    }

    /// [`barycentric_point_rounded_v3`] is [`barycentric_point`] then
    /// [`round_point`](crate::math::round_point) bit for bit, with and without x86-64-v3: on
    /// vertices of every scale and sign, zeros of both signs, subnormals, `±f32::MAX`,
    /// infinities and NaNs, with barycentrics that sum to one and others (negative, huge,
    /// subnormal, infinite, NaN). A NaN compares equal to any NaN: the lanes and the scalar code
    /// may carry different NaN payloads, as Rust does not specify them.
    #[test]
    fn rounded_barycentric_point_in_lanes_matches() {
        let v3 = crate::accel::X86_64V3::detect();
        if v3.is_none() {
            eprintln!("barycentric_point_rounded_v3's lanes are not tested: this CPU lacks x86-64-v3");
        }
        let special = [
            0.0,
            -0.0,
            1e-40,
            -1e-40,
            1.0,
            -1.0,
            f32::MAX,
            -f32::MAX,
            f32::INFINITY,
            f32::NEG_INFINITY,
            f32::NAN,
        ];
        let special_b = [0.0, -0.0, 1e-310, -0.5, 1.5, 1e300, f64::INFINITY, f64::NAN];
        let mut rng = crate::sampling::Rng::new(3, 9);
        let mut value = |k: usize| {
            if k.is_multiple_of(5) {
                special[(k / 5) % special.len()]
            } else {
                (rng.uniform() - 0.5) * 10f32.powi((rng.uniform() * 70.0) as i32 - 35)
            }
        };
        let f32_bits = |x: f32| if x.is_nan() { u32::MAX } else { x.to_bits() };
        let f64_bits = |x: f64| if x.is_nan() { u64::MAX } else { x.to_bits() };
        let bits = |(p, pf, e): (DVec3, Vec3, Vec3)| {
            (p.to_array().map(f64_bits), pf.to_array().map(f32_bits), e.to_array().map(f32_bits))
        };
        for k in 0..30_000 {
            let tp = [0, 3, 6].map(|j| Vec3::new(value(k + j), value(k + j + 1), value(k + j + 2)));
            let (b1, b2) = (f64::from(value(k + 9)).abs().min(1.0), f64::from(value(k + 10)).abs().min(1.0));
            let mut b = [1.0 - b1 - b2, b1, b2];
            if k.is_multiple_of(7) {
                b[k % 3] = special_b[(k / 7) % special_b.len()];
            }
            let (p, err) = barycentric_point(b, tp[0], tp[1], tp[2]);
            let (pf, bound) = crate::math::round_point(p, err);
            for lanes in [v3, None] {
                assert_eq!(
                    bits(barycentric_point_rounded_v3(lanes, b, &tp)),
                    bits((p, pf, bound)),
                    "{tp:?} {b:?}"
                );
            }
        }
    }
}
