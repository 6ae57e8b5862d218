//! Floating-point helpers: rounding-error bounds, robust ray spawning, orthonormal frames.
//!
//! The renderer has no fixed epsilons. A ray leaving a surface starts at the hit point pushed
//! along the geometric normal by a conservative bound on the point's rounding error
//! ([`offset_ray_origin`], as in pbrt-v4), so it can neither re-hit the surface it left nor
//! tunnel through a neighbour, at any scale.

use glam::{DMat4, DVec3, Vec3};

/// Half an ulp of 1.0 in `f32`: the unit roundoff of one correctly rounded operation.
pub const MACHINE_EPSILON: f32 = f32::EPSILON * 0.5;

/// `gamma(n) = n u / (1 - n u)`: the bound on the relative error of `n` chained operations.
#[inline]
pub fn gamma(n: i32) -> f32 {
    let nu = n as f32 * MACHINE_EPSILON;
    nu / (1.0 - nu)
}

/// The smallest `f32` greater than `v` (infinity stays infinity).
///
/// On the bits, with one well-predicted branch for the usual case (a positive finite value or
/// +0, as error bounds are): +inf stays, -0 goes to the smallest subnormal, everything else
/// (negative values and NaNs) steps its bits down.
#[inline]
pub fn next_float_up(v: f32) -> f32 {
    let bits = v.to_bits();
    f32::from_bits(if bits < 0x7f80_0000 {
        bits + 1
    } else if bits == 0x7f80_0000 {
        bits
    } else if bits == 0x8000_0000 {
        1
    } else {
        bits - 1
    })
}

/// The largest `f32` smaller than `v` (negative infinity stays).
///
/// On the bits: a positive value (+inf included) steps down, either zero goes to the negative
/// subnormal closest to it, -inf stays, everything else (negative values and NaNs) steps up.
#[inline]
pub fn next_float_down(v: f32) -> f32 {
    let bits = v.to_bits();
    f32::from_bits(if bits.wrapping_sub(1) < 0x7f80_0000 {
        bits - 1
    } else if bits & 0x7fff_ffff == 0 {
        0x8000_0001
    } else if bits == 0xff80_0000 {
        bits
    } else {
        // Wrapping, as release builds of the float-level definition did for the NaN 0xffffffff.
        bits.wrapping_add(1)
    })
}

/// `x.is_finite() && x > 0.0` as one unsigned comparison of the bits: the positive finite
/// numbers are exactly the bit patterns 1 (the smallest subnormal) to `0x7f7f_ffff`
/// (`f32::MAX`); zeros, negatives, infinities and NaNs fall outside. The two float
/// comparisons `x > 0.0 && x < f32::INFINITY`, where `x` was in an integer register, became a
/// dozen integer instructions. `positive_and_finite_matches_the_test_it_replaces` tests it.
#[inline(always)]
pub fn positive_and_finite(x: f32) -> bool {
    x.to_bits().wrapping_sub(1) < 0x7f7f_ffff
}

/// Rounds an `f64` point to `f32` and returns it with a per-component bound on the error of the
/// rounded point relative to the exact surface point: the rounding itself plus `extra_error`
/// (the error of the `f64` computation, already bounded by the caller).
#[inline]
pub fn round_point(p: DVec3, extra_error: DVec3) -> (Vec3, Vec3) {
    let pf = p.as_vec3();
    // |p - round(p)| <= ulp/2; the f64 -> f32 subtraction below is exact enough to measure it, and
    // a generous relative margin covers the f64 error of the caller's arithmetic.
    let rounding = (p - pf.as_dvec3()).abs();
    let err = rounding + extra_error + p.abs() * (4.0 * f64::EPSILON);
    // Round the bound itself up so that it is never an underestimate once in f32.
    let err32 =
        Vec3::new(next_float_up(err.x as f32), next_float_up(err.y as f32), next_float_up(err.z as f32));
    (pf, err32 + Vec3::splat(f32::MIN_POSITIVE))
}

/// [`round_point`], the same bits, with its three components in the lanes of AVX registers
/// (the `f64` arithmetic and both conversions one instruction for all three, the bound's step
/// up without a branch per component): the point `pd` and the error bound `extra_error` in
/// lanes 0 to 2 (lane 3 is ignored), the rounded point and its bound out as `round_point` gives
/// them. `_v3` says the CPU has x86-64-v3. Always inlined, for the wavefront's x86-64-v3 batch
/// (through [`barycentric_point_rounded_v3`](crate::shapes::barycentric_point_rounded_v3)); a
/// caller without those target features would make the intrinsics calls.
#[cfg(target_arch = "x86_64")]
#[inline(always)]
pub(crate) fn round_point_lanes(
    _v3: crate::accel::X86_64V3,
    pd: std::arch::x86_64::__m256d,
    extra_error: std::arch::x86_64::__m256d,
) -> (Vec3, Vec3) {
    use std::arch::x86_64::*;
    // SAFETY: `_v3` exists only on a CPU with AVX2; no memory is touched.
    unsafe {
        let magnitude = _mm256_castsi256_pd(_mm256_set1_epi64x(i64::MAX));
        let pf = _mm256_cvtpd_ps(pd);
        let rounding = _mm256_and_pd(_mm256_sub_pd(pd, _mm256_cvtps_pd(pf)), magnitude);
        let err = _mm256_add_pd(
            _mm256_add_pd(rounding, extra_error),
            _mm256_mul_pd(_mm256_and_pd(pd, magnitude), _mm256_set1_pd(4.0 * f64::EPSILON)),
        );
        // `next_float_up` of each lane's bits: +1 below infinity, infinity kept, -0 to the
        // smallest subnormal, -1 for the rest (negative values and NaNs).
        let bits = _mm_castps_si128(_mm256_cvtpd_ps(err));
        let infinity = _mm_set1_epi32(0x7f80_0000);
        let below = _mm_cmpeq_epi32(_mm_min_epu32(bits, _mm_set1_epi32(0x7f7f_ffff)), bits);
        let at_infinity = _mm_cmpeq_epi32(bits, infinity);
        // -1, plus 2 below infinity (each mask is -1 where it holds), plus 1 at infinity.
        let step = _mm_sub_epi32(_mm_sub_epi32(_mm_set1_epi32(-1), _mm_add_epi32(below, below)), at_infinity);
        let negative_zero = _mm_cmpeq_epi32(bits, _mm_set1_epi32(i32::MIN));
        let up = _mm_blendv_epi8(_mm_add_epi32(bits, step), _mm_set1_epi32(1), negative_zero);
        let bound = _mm_add_ps(_mm_castsi128_ps(up), _mm_set1_ps(f32::MIN_POSITIVE));
        let [x, y, z, _] = std::mem::transmute::<__m128, [f32; 4]>(pf);
        let [ex, ey, ez, _] = std::mem::transmute::<__m128, [f32; 4]>(bound);
        (Vec3::new(x, y, z), Vec3::new(ex, ey, ez))
    }
}

/// Pushes `p` (with per-component error bound `p_error`) along the geometric normal `n` to the
/// side `w` points to, far enough that the result is strictly on that side of the true surface,
/// and rounds each component away from the surface (pbrt-v4 `OffsetRayOrigin`). Always inlined:
/// out of line it was a call per ray end, and baseline code in the wavefront's x86-64-v3 batch.
#[inline(always)]
pub fn offset_ray_origin(p: Vec3, p_error: Vec3, n: Vec3, w: Vec3) -> Vec3 {
    let d = n.abs().dot(p_error);
    let mut offset = n * d;
    if w.dot(n) < 0.0 {
        offset = -offset;
    }
    let mut po = p + offset;
    for i in 0..3 {
        if offset[i] > 0.0 {
            po[i] = next_float_up(po[i]);
        } else if offset[i] < 0.0 {
            po[i] = next_float_down(po[i]);
        }
    }
    po
}

/// [`offset_ray_origin`], the same bits, with the three components in the lanes of one SSE
/// register where `v3` says the CPU has x86-64-v3: both dot products as two horizontal adds
/// (in the scalar order, `(x + y) + z`), the side's sign flip as one mask, and each
/// component's step up or down as integer lane operations instead of two branches per
/// component on the offset's sign. Always inlined, for the wavefront's x86-64-v3 batch; a
/// caller without those target features passes `None`. A NaN result may differ from the
/// scalar one in sign and payload, which Rust leaves open for NaN arithmetic anyway.
#[inline(always)]
pub(crate) fn offset_ray_origin_v3(
    v3: Option<crate::accel::X86_64V3>,
    p: Vec3,
    p_error: Vec3,
    n: Vec3,
    w: Vec3,
) -> Vec3 {
    #[cfg(target_arch = "x86_64")]
    if v3.is_some() {
        use std::arch::x86_64::*;
        // SAFETY: `v3` exists only on a CPU with AVX2 (and so SSE4.1); no memory is touched.
        unsafe {
            let nv = _mm_setr_ps(n.x, n.y, n.z, 0.0);
            // Lane 3 of both products is -0 (0 times -0), which the horizontal add adds to the
            // z product without changing it: `(x + y) + (z + -0)` is `(x + y) + z`, bit for bit.
            let magnitude = _mm_castsi128_ps(_mm_set1_epi32(i32::MAX));
            let err_products =
                _mm_mul_ps(_mm_and_ps(nv, magnitude), _mm_setr_ps(p_error.x, p_error.y, p_error.z, -0.0));
            let side_products = _mm_mul_ps(_mm_setr_ps(w.x, w.y, w.z, -0.0), nv);
            // Lane 0: `|n| . p_error`; lane 1: `w . n`.
            let pairs = _mm_hadd_ps(err_products, side_products);
            let dots = _mm_hadd_ps(pairs, pairs);
            let zero = _mm_setzero_ps();
            let negative = _mm_cmplt_ps(dots, zero);
            let flip = _mm_and_ps(_mm_shuffle_ps::<0b01_01_01_01>(negative, negative), _mm_set1_ps(-0.0));
            let offset = _mm_xor_ps(_mm_mul_ps(nv, _mm_shuffle_ps::<0>(dots, dots)), flip);
            let po = _mm_add_ps(_mm_setr_ps(p.x, p.y, p.z, 0.0), offset);
            // The step away from the surface: on the bits, `next_float_up` where the offset is
            // positive and `next_float_down` where it is negative are +1 where the point has the
            // offset's sign and -1 where not, but 0 at the infinity on the offset's side, and a
            // zero steps to the smallest subnormal with the offset's sign (as if it had that
            // sign). A NaN point stays NaN either way. Neither step where the offset is zero
            // or NaN.
            let moves = _mm_cmp_ps::<_CMP_NEQ_OQ>(offset, zero);
            let sign = _mm_and_ps(offset, _mm_set1_ps(-0.0));
            let from = _mm_blendv_ps(po, sign, _mm_and_ps(_mm_cmpeq_ps(po, zero), moves));
            let other_side = _mm_srai_epi32::<31>(_mm_castps_si128(_mm_xor_ps(from, offset)));
            let at_infinity = _mm_cmpeq_ps(po, _mm_or_ps(sign, _mm_set1_ps(f32::INFINITY)));
            let step =
                _mm_add_epi32(_mm_or_si128(other_side, _mm_set1_epi32(1)), _mm_castps_si128(at_infinity));
            let step = _mm_and_si128(step, _mm_castps_si128(moves));
            let moved = _mm_add_epi32(_mm_castps_si128(from), step);
            let [x, y, z, _] = std::mem::transmute::<__m128i, [f32; 4]>(moved);
            return Vec3::new(x, y, z);
        }
    }
    #[cfg(not(target_arch = "x86_64"))]
    let _ = v3;
    offset_ray_origin(p, p_error, n, w)
}

/// An orthonormal frame around a unit vector `z`.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct Frame {
    pub x: Vec3,
    pub y: Vec3,
    pub z: Vec3,
}

impl Frame {
    /// A frame whose `z` is `n` (unit length), with a tangent chosen continuously
    /// (Duff et al. 2017, "Building an Orthonormal Basis, Revisited").
    pub fn from_z(n: Vec3) -> Frame {
        let sign = 1.0f32.copysign(n.z);
        let a = -1.0 / (sign + n.z);
        let b = n.x * n.y * a;
        let x = Vec3::new(1.0 + sign * n.x * n.x * a, sign * b, -sign * n.x);
        let y = Vec3::new(b, sign + n.y * n.y * a, -n.y);
        Frame { x, y, z: n }
    }

    /// A frame with `z = n` and `x` as close as possible to `tangent`.
    pub fn from_z_and_tangent(n: Vec3, tangent: Vec3) -> Frame {
        let t = tangent - n * n.dot(tangent);
        let len = t.length();
        if !(len > 1e-12) || !len.is_finite() {
            return Frame::from_z(n);
        }
        let x = t / len;
        Frame { x, y: n.cross(x), z: n }
    }

    #[inline]
    pub fn to_local(&self, v: Vec3) -> Vec3 {
        Vec3::new(v.dot(self.x), v.dot(self.y), v.dot(self.z))
    }

    #[inline]
    pub fn from_local(&self, v: Vec3) -> Vec3 {
        self.x * v.x + self.y * v.y + self.z * v.z
    }
}

/// Transforms a point by an affine `f64` matrix.
#[inline]
pub fn transform_point(m: &DMat4, p: DVec3) -> DVec3 {
    m.transform_point3(p)
}

/// Transforms a direction by the linear part of an affine `f64` matrix.
#[inline]
pub fn transform_vector(m: &DMat4, v: DVec3) -> DVec3 {
    m.transform_vector3(v)
}

/// Transforms a normal given the inverse of the point transform (normals transform by the
/// inverse transpose, which keeps them on the same side of the surface under mirroring).
#[inline]
pub fn transform_normal(inverse: &DMat4, n: DVec3) -> DVec3 {
    let m = inverse;
    DVec3::new(
        m.x_axis.x * n.x + m.x_axis.y * n.y + m.x_axis.z * n.z,
        m.y_axis.x * n.x + m.y_axis.y * n.y + m.y_axis.z * n.z,
        m.z_axis.x * n.x + m.z_axis.y * n.y + m.z_axis.z * n.z,
    )
}

/// Per-component absolute bound of the rounding error of `m * p` computed in `f64`.
#[inline]
pub fn transform_point_error(m: &DMat4, p: DVec3) -> DVec3 {
    let a = |row: usize| {
        let r = m.row(row);
        (r.x * p.x).abs() + (r.y * p.y).abs() + (r.z * p.z).abs() + r.w.abs()
    };
    DVec3::new(a(0), a(1), a(2)) * (4.0 * f64::EPSILON)
}

/// True when every element of the matrix is finite and the bottom row is `(0, 0, 0, 1)`.
pub fn is_finite_affine(m: &DMat4) -> bool {
    m.is_finite() && m.row(3) == glam::DVec4::new(0.0, 0.0, 0.0, 1.0)
}

/// `x * x`.
#[inline]
pub fn sqr<T: std::ops::Mul<Output = T> + Copy>(x: T) -> T {
    x * x
}

/// Largest component of the absolute value.
#[inline]
pub fn max_abs_component(v: Vec3) -> f32 {
    v.abs().max_element()
}

/// Average of the three channels of an RGB value.
#[inline]
pub fn average(c: Vec3) -> f32 {
    (c.x + c.y + c.z) / 3.0
}

/// Relative luminance of linear RGB (Rec. 709 weights).
#[inline]
pub fn luminance(c: Vec3) -> f32 {
    0.2126 * c.x + 0.7152 * c.y + 0.0722 * c.z
}

/// True when all three channels are zero.
#[inline]
pub fn is_black(c: Vec3) -> bool {
    c.x == 0.0 && c.y == 0.0 && c.z == 0.0
}

#[cfg(test)]
mod tests {
    use super::*;

    /// The bit-level next-float functions agree with the float-level definitions on the
    /// special values and on every 251st bit pattern (NaNs of both signs included).
    #[test]
    fn next_float_matches_the_float_definition() {
        let up = |v: f32| {
            if v.is_infinite() && v > 0.0 {
                return v;
            }
            let v = if v == -0.0 { 0.0 } else { v };
            let bits = v.to_bits();
            f32::from_bits(if v >= 0.0 { bits.wrapping_add(1) } else { bits.wrapping_sub(1) })
        };
        let down = |v: f32| {
            if v.is_infinite() && v < 0.0 {
                return v;
            }
            let v = if v == 0.0 { -0.0 } else { v };
            let bits = v.to_bits();
            f32::from_bits(if v > 0.0 { bits.wrapping_sub(1) } else { bits.wrapping_add(1) })
        };
        let specials = [0u32, 1, 0x7f7f_ffff, 0x7f80_0000, 0x7f80_0001, 0x7fc0_0000, 0x7fff_ffff];
        let specials = specials.iter().flat_map(|&b| [b, b | 0x8000_0000]);
        for bits in (0..=u32::MAX).step_by(251).chain(specials) {
            let v = f32::from_bits(bits);
            assert_eq!(next_float_up(v).to_bits(), up(v).to_bits(), "up {bits:#x}");
            assert_eq!(next_float_down(v).to_bits(), down(v).to_bits(), "down {bits:#x}");
        }
    }

    #[test]
    fn next_float_steps_one_ulp() {
        assert_eq!(next_float_up(1.0), 1.0 + f32::EPSILON);
        assert_eq!(next_float_down(1.0), 1.0 - f32::EPSILON / 2.0);
        assert!(next_float_up(0.0) > 0.0);
        assert!(next_float_down(0.0) < 0.0);
        assert!(next_float_up(-1.0) > -1.0);
        assert_eq!(next_float_up(f32::INFINITY), f32::INFINITY);
    }

    #[test]
    fn frame_is_orthonormal() {
        for n in
            [Vec3::Z, -Vec3::Z, Vec3::X, Vec3::new(0.3, -0.5, 0.81).normalize(), Vec3::new(0.0, 0.0, -1.0)]
        {
            let f = Frame::from_z(n);
            assert!((f.x.length() - 1.0).abs() < 1e-6);
            assert!((f.y.length() - 1.0).abs() < 1e-6);
            assert!(f.x.dot(f.y).abs() < 1e-6 && f.x.dot(f.z).abs() < 1e-6 && f.y.dot(f.z).abs() < 1e-6);
            let v = Vec3::new(0.2, 0.7, -0.4);
            assert!((f.from_local(f.to_local(v)) - v).length() < 1e-6);
        }
    }

    /// [`round_point_lanes`] is [`round_point`] bit for bit: on
    /// points of every scale and sign, zeros of both signs, subnormals, infinities and NaNs,
    /// with error bounds that overflow `f32`, are NaN or are negative (which the bound's step
    /// up treats as the bits say).
    #[test]
    fn round_point_in_lanes_matches() {
        let v3 = crate::accel::X86_64V3::detect();
        if v3.is_none() {
            eprintln!("round_point_lanes is not tested: this CPU lacks x86-64-v3");
        }
        let special = [
            0.0,
            -0.0,
            1e-310,
            -1e-310,
            1e-40,
            f64::from(f32::MAX),
            1e39,
            -1e39,
            f64::INFINITY,
            f64::NEG_INFINITY,
            f64::NAN,
            -f64::NAN,
            3.4028235677973366e38,
        ];
        let mut rng = crate::sampling::Rng::new(2, 7);
        let mut value = |k: usize| {
            if k.is_multiple_of(4) {
                special[(k / 4) % special.len()]
            } else {
                let magnitude = 10f64.powi((rng.uniform() * 80.0) as i32 - 40);
                (f64::from(rng.uniform()) - 0.5) * magnitude
            }
        };
        for k in 0..20_000 {
            let p = DVec3::new(value(k), value(k + 1), value(k + 2));
            let extra = DVec3::new(value(k + 3), value(k + 5), value(k + 6)).abs()
                * if k.is_multiple_of(9) { -1.0 } else { 1.0 };
            let expected = round_point(p, extra);
            let bits =
                |(a, b): (Vec3, Vec3)| (a.to_array().map(f32::to_bits), b.to_array().map(f32::to_bits));
            #[cfg(target_arch = "x86_64")]
            if let Some(v3) = v3 {
                use std::arch::x86_64::_mm256_setr_pd;
                // SAFETY: `v3` exists only on a CPU with AVX2.
                let (pd, extra) = unsafe {
                    (_mm256_setr_pd(p.x, p.y, p.z, 0.0), _mm256_setr_pd(extra.x, extra.y, extra.z, 0.0))
                };
                assert_eq!(bits(round_point_lanes(v3, pd, extra)), bits(expected), "{p:?} {extra:?}");
            }
        }
    }

    /// `offset_ray_origin_v3`'s lanes give `offset_ray_origin`'s bits (NaNs as NaNs), on points, bounds,
    /// normals and directions with zeros of both signs, subnormals, huge and infinite values
    /// and NaNs of both signs, and bounds that are zero or negative (which the steps up and
    /// down treat as the bits say); every fourth component is one of those, the rest random
    /// over 80 decades.
    #[test]
    fn offset_ray_origin_in_lanes_matches() {
        let v3 = crate::accel::X86_64V3::detect();
        if v3.is_none() {
            eprintln!("offset_ray_origin_v3's lanes are not tested: this CPU lacks x86-64-v3");
        }
        let special = [
            0.0,
            -0.0,
            1e-45,
            -1e-45,
            1e-40,
            f32::MIN_POSITIVE,
            f32::MAX,
            -f32::MAX,
            3e38,
            f32::INFINITY,
            f32::NEG_INFINITY,
            f32::NAN,
            -f32::NAN,
            1.0,
            -1.0,
        ];
        let mut rng = crate::sampling::Rng::new(3, 11);
        let mut value = |k: usize| {
            if k.is_multiple_of(4) {
                special[(k / 4) % special.len()]
            } else {
                let magnitude = 10f32.powi((rng.uniform() * 80.0) as i32 - 40);
                (rng.uniform() - 0.5) * magnitude
            }
        };
        // A NaN's sign and payload are left open by Rust (LLVM may swap an addition's
        // operands, which picks the NaN that propagates), so a NaN matches any NaN.
        let bits = |v: Vec3| v.to_array().map(|c| (!c.is_nan()).then_some(c.to_bits()));
        for k in 0..40_000 {
            let mut v = |j: usize| value(k * 3 + j);
            let p = Vec3::new(v(0), v(1), v(2));
            let err = Vec3::new(v(3), v(5), v(7)).abs() * if k.is_multiple_of(9) { -1.0 } else { 1.0 };
            let n = Vec3::new(v(11), v(13), v(17));
            let w = Vec3::new(v(19), v(23), v(29));
            let expected = offset_ray_origin(p, err, n, w);
            for lanes in [v3, None] {
                assert_eq!(
                    bits(offset_ray_origin_v3(lanes, p, err, n, w)),
                    bits(expected),
                    "{p:?} {err:?} {n:?} {w:?}"
                );
            }
            // A unit normal and a small bound, as surfaces give them, on the same point.
            let (n, err) = (n.normalize_or(Vec3::Z), err.abs() * 1e-6);
            let expected = offset_ray_origin(p, err, n, w);
            if let Some(v3) = v3 {
                assert_eq!(
                    bits(offset_ray_origin_v3(Some(v3), p, err, n, w)),
                    bits(expected),
                    "{p:?} {err:?} {n:?} {w:?}"
                );
            }
        }
    }

    #[test]
    fn offset_moves_to_the_requested_side() {
        let p = Vec3::new(1e5, 2.0, -3.0);
        let (pf, err) = round_point(p.as_dvec3(), DVec3::ZERO);
        let n = Vec3::X;
        let above = offset_ray_origin(pf, err, n, Vec3::X);
        let below = offset_ray_origin(pf, err, n, -Vec3::X);
        assert!(above.x > 1e5 && below.x < 1e5);
    }

    /// `positive_and_finite` answers as the test it replaces, on zeros of both signs,
    /// subnormals, the extremes, infinities and NaNs of both signs and payloads, and on random
    /// bits.
    #[test]
    fn positive_and_finite_matches_the_test_it_replaces() {
        let special = [
            0.0,
            -0.0,
            1e-45,
            -1e-45,
            1e-40,
            f32::MIN_POSITIVE,
            -f32::MIN_POSITIVE,
            1.0,
            -1.0,
            f32::MAX,
            -f32::MAX,
            f32::INFINITY,
            f32::NEG_INFINITY,
            f32::NAN,
            -f32::NAN,
            f32::from_bits(0x7f80_0001),
            f32::from_bits(0xffc0_1234),
        ];
        let mut rng = crate::sampling::Rng::new(21, 4);
        let mut values: Vec<f32> = special.to_vec();
        values.extend((0..2000).map(|_| f32::from_bits(rng.next_u32())));
        for &x in &values {
            assert_eq!(positive_and_finite(x), x.is_finite() && x > 0.0, "{x:e} ({:#x})", x.to_bits());
        }
    }
}
