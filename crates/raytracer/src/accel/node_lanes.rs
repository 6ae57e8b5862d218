//! The slab tests of a node's eight children, in two instruction sets with the same results.
//!
//! [`Baseline`] runs them as two groups of four lanes (SSE2 on x86-64, glam's `Vec4`);
//! [`X86_64V3`] as one group of eight (AVX2), for callers compiled for x86-64-v3. Each lane
//! does the same `f32` operations in the same order (`maxps` and `minps` keep their operand
//! order; Rust never fuses a multiply and an add), so both give the same mask bit for bit.

use super::{EXIT_PAD, NodeTest};
use glam::{Vec3A, Vec4};

/// One way of running the slab tests of a node's children.
pub(crate) trait NodeLanes: Copy {
    /// Bit `k` set when child `k`'s widened box, `(plane +- CHILD_PAD) * scale + offset` per
    /// axis, overlaps `[t_min, t_limit]` (the far distances widened by `EXIT_PAD`). `planes`
    /// are the node's quantised planes `[min_x, max_x, min_y, max_y, min_z, max_z]`.
    fn child_mask(
        self,
        planes: &[[u8; 8]; 6],
        test: &NodeTest,
        scale: Vec3A,
        offset: Vec3A,
        range: (f32, f32),
    ) -> u32;
}

/// Two groups of four lanes: SSE2 on x86-64, where it is the baseline.
#[derive(Clone, Copy, Debug)]
pub(crate) struct Baseline;

impl NodeLanes for Baseline {
    #[inline(always)]
    fn child_mask(
        self,
        planes: &[[u8; 8]; 6],
        test: &NodeTest,
        scale: Vec3A,
        offset: Vec3A,
        (t_min, t_limit): (f32, f32),
    ) -> u32 {
        // Entry and exit distances of the eight children along one axis, as two groups of four.
        let axis = |a: usize, scale: f32, offset: f32| {
            let near = child_planes(&planes[2 * a + (test.near[a] & 1)]);
            let far = child_planes(&planes[2 * a + ((test.near[a] & 1) ^ 1)]);
            let (scale, offset) = (Vec4::splat(scale), Vec4::splat(offset));
            [0, 1].map(|g| {
                ((near[g] + test.near_pad[a]) * scale + offset, (far[g] + test.far_pad[a]) * scale + offset)
            })
        };
        let x = axis(0, scale.x, offset.x);
        let y = axis(1, scale.y, offset.y);
        let z = axis(2, scale.z, offset.z);
        let mut mask = 0u32;
        for g in 0..2 {
            let t_near = x[g].0.max(y[g].0).max(z[g].0).max(Vec4::splat(t_min));
            let t_far = (x[g].1.min(y[g].1).min(z[g].1) * Vec4::splat(EXIT_PAD)).min(Vec4::splat(t_limit));
            mask |= t_near.cmple(t_far).bitmask() << (4 * g);
        }
        mask
    }
}

/// One quantised plane of a node's eight children (`child_min_x` and so on) as two groups of
/// four floats. Exact: every byte is a small integer. On x86-64 the bytes are widened with
/// SSE2 unpacks (six instructions instead of eight scalar conversions and inserts).
#[inline(always)]
pub(super) fn child_planes(q: &[u8; 8]) -> [Vec4; 2] {
    #[cfg(target_arch = "x86_64")]
    {
        use std::arch::x86_64::{
            _mm_cvtepi32_ps, _mm_cvtsi64_si128, _mm_setzero_si128, _mm_unpackhi_epi16, _mm_unpacklo_epi8,
            _mm_unpacklo_epi16,
        };
        // SAFETY: SSE2 is part of the x86-64 baseline, and these intrinsics touch no memory.
        unsafe {
            let zero = _mm_setzero_si128();
            let words = _mm_unpacklo_epi8(_mm_cvtsi64_si128(i64::from_le_bytes(*q)), zero);
            [
                Vec4::from(_mm_cvtepi32_ps(_mm_unpacklo_epi16(words, zero))),
                Vec4::from(_mm_cvtepi32_ps(_mm_unpackhi_epi16(words, zero))),
            ]
        }
    }
    #[cfg(not(target_arch = "x86_64"))]
    {
        let group = |i: usize| {
            Vec4::new(f32::from(q[i]), f32::from(q[i + 1]), f32::from(q[i + 2]), f32::from(q[i + 3]))
        };
        [group(0), group(4)]
    }
}

/// One group of eight lanes (AVX2). A value exists only on a CPU with x86-64-v3's instruction
/// set ([`X86_64V3::detect`]), which makes calling its AVX2 code sound; code that takes it
/// should be compiled with those features (`#[target_feature(enable =
/// "avx2,fma,bmi1,bmi2,lzcnt,popcnt")]`), or the intrinsics are calls.
#[derive(Clone, Copy, Debug)]
pub(crate) struct X86_64V3 {
    _detected: (),
}

impl X86_64V3 {
    /// `Some` when this CPU has x86-64-v3's instruction set.
    pub fn detect() -> Option<X86_64V3> {
        #[cfg(target_arch = "x86_64")]
        {
            let has = std::arch::is_x86_feature_detected!("avx2")
                && std::arch::is_x86_feature_detected!("fma")
                && std::arch::is_x86_feature_detected!("bmi1")
                && std::arch::is_x86_feature_detected!("bmi2")
                && std::arch::is_x86_feature_detected!("lzcnt")
                && std::arch::is_x86_feature_detected!("popcnt");
            has.then_some(X86_64V3 { _detected: () })
        }
        #[cfg(not(target_arch = "x86_64"))]
        {
            None
        }
    }
}

impl NodeLanes for X86_64V3 {
    #[inline(always)]
    fn child_mask(
        self,
        planes: &[[u8; 8]; 6],
        test: &NodeTest,
        scale: Vec3A,
        offset: Vec3A,
        range: (f32, f32),
    ) -> u32 {
        #[cfg(target_arch = "x86_64")]
        {
            // SAFETY: a value of this type exists only when the CPU has AVX2 (`detect`).
            unsafe { child_mask_avx2(planes, test, scale, offset, range) }
        }
        #[cfg(not(target_arch = "x86_64"))]
        {
            Baseline.child_mask(planes, test, scale, offset, range)
        }
    }
}

/// [`Baseline::child_mask`] on eight lanes at once: the same operations lane by lane.
///
/// # Safety
/// The CPU must have AVX2.
#[cfg(target_arch = "x86_64")]
#[inline(always)]
unsafe fn child_mask_avx2(
    planes: &[[u8; 8]; 6],
    test: &NodeTest,
    scale: Vec3A,
    offset: Vec3A,
    (t_min, t_limit): (f32, f32),
) -> u32 {
    use std::arch::x86_64::*;
    // No closures here: a closure does not inherit the target features of the function it is
    // inlined into, so its intrinsics would stay calls.
    // SAFETY: the caller guarantees AVX2; each load reads the eight bytes of one plane.
    unsafe {
        // Eight bytes widened to eight exact floats.
        macro_rules! plane {
            ($q:expr) => {
                _mm256_cvtepi32_ps(_mm256_cvtepu8_epi32(_mm_loadl_epi64($q.as_ptr().cast())))
            };
        }
        // Entry and exit distances of the eight children along axis `a`.
        macro_rules! axis {
            ($a:expr, $scale:expr, $offset:expr) => {{
                let near = plane!(&planes[2 * $a + (test.near[$a] & 1)]);
                let far = plane!(&planes[2 * $a + ((test.near[$a] & 1) ^ 1)]);
                let (scale, offset) = (_mm256_set1_ps($scale), _mm256_set1_ps($offset));
                let near_pad = _mm256_set1_ps(test.near_pad[$a].x);
                let far_pad = _mm256_set1_ps(test.far_pad[$a].x);
                (
                    _mm256_add_ps(_mm256_mul_ps(_mm256_add_ps(near, near_pad), scale), offset),
                    _mm256_add_ps(_mm256_mul_ps(_mm256_add_ps(far, far_pad), scale), offset),
                )
            }};
        }
        let x = axis!(0, scale.x, offset.x);
        let y = axis!(1, scale.y, offset.y);
        let z = axis!(2, scale.z, offset.z);
        let t_near = _mm256_max_ps(_mm256_max_ps(_mm256_max_ps(x.0, y.0), z.0), _mm256_set1_ps(t_min));
        let t_far = _mm256_min_ps(
            _mm256_mul_ps(_mm256_min_ps(_mm256_min_ps(x.1, y.1), z.1), _mm256_set1_ps(EXIT_PAD)),
            _mm256_set1_ps(t_limit),
        );
        // `_CMP_LE_OS` is SSE's `cmpleps`: false when either side is NaN.
        _mm256_movemask_ps(_mm256_cmp_ps::<_CMP_LE_OS>(t_near, t_far)) as u32
    }
}

// The tests index the planes by child and axis, as the node stores them.
#[allow(clippy::needless_range_loop)]
#[cfg(test)]
mod tests {
    use super::*;
    use crate::accel::TraversalRay;
    use crate::sampling::{Rng, sample_uniform_sphere};

    /// The slab test of one child with one `f32` operation at a time, `maxps` and `minps` written
    /// out (`a > b ? a : b`, `a < b ? a : b`): the reference both lane versions must match.
    fn scalar_mask(
        planes: &[[u8; 8]; 6],
        test: &NodeTest,
        scale: Vec3A,
        offset: Vec3A,
        (t_min, t_limit): (f32, f32),
    ) -> u32 {
        let max = |a: f32, b: f32| if a > b { a } else { b };
        let min = |a: f32, b: f32| if a < b { a } else { b };
        let mut mask = 0;
        for child in 0..8 {
            let mut entry = [0.0; 3];
            let mut exit = [0.0; 3];
            for a in 0..3 {
                let near = f32::from(planes[2 * a + test.near[a]][child]);
                let far = f32::from(planes[2 * a + (test.near[a] ^ 1)][child]);
                entry[a] = (near + test.near_pad[a].x) * scale[a] + offset[a];
                exit[a] = (far + test.far_pad[a].x) * scale[a] + offset[a];
            }
            let t_near = max(max(max(entry[0], entry[1]), entry[2]), t_min);
            let t_far = min(min(min(exit[0], exit[1]), exit[2]) * EXIT_PAD, t_limit);
            if t_near <= t_far {
                mask |= 1 << child;
            }
        }
        mask
    }

    /// Both lane versions give the scalar reference's mask on random planes and rays, including
    /// axis-aligned rays (reciprocals of `1e20`), rays starting on a plane or running along it,
    /// empty and flat children, infinite and zero `t_limit`, and the extreme exponents of a
    /// node's scale.
    #[test]
    fn node_lanes_match_the_scalar_test() {
        let mut rng = Rng::new(9, 14);
        let v3 = X86_64V3::detect();
        if v3.is_none() {
            eprintln!("this CPU lacks x86-64-v3: only the baseline lanes are compared");
        }
        let mut hits = [0usize; 2];
        for k in 0..20_000 {
            let mut planes = [[0u8; 8]; 6];
            for a in 0..3 {
                for child in 0..8 {
                    let (lo, hi) = match (k + child) % 5 {
                        // An empty child (obvhs stores min > max), a flat one, the whole node.
                        0 => (255, 0),
                        1 => (100, 100),
                        2 => (0, 255),
                        _ => {
                            let p = (rng.uniform() * 256.0) as u8;
                            let q = (rng.uniform() * 256.0) as u8;
                            (p.min(q), p.max(q))
                        }
                    };
                    planes[2 * a][child] = lo;
                    planes[2 * a + 1][child] = hi;
                }
            }
            let mut d = sample_uniform_sphere(rng.uniform2());
            if k % 3 == 0 {
                d[(k / 3) % 3] = [0.0, -0.0, 1e-25][(k / 9) % 3];
            }
            // The origin inside, outside or on a plane of the node's [0, 256) box.
            let mut o = glam::Vec3::new(rng.uniform(), rng.uniform(), rng.uniform()) * 400.0 - 72.0;
            if k % 4 == 1 {
                o[k % 3] = f32::from(planes[2 * (k % 3)][k % 8]);
            }
            let t_max = [f32::INFINITY, 0.0, 50.0, 1e30][k % 4];
            let Some(ray) = TraversalRay::new(o, d, 0.0, t_max) else { continue };
            let test = NodeTest::new(&ray);
            // `intersect_node`'s scale and offset for a node at the origin with extent `2^e`.
            let e = [-20.0f32, 0.0, 3.0, 30.0][(k / 4) % 4];
            let extent = Vec3A::splat(e.exp2());
            let scale = extent * ray.inv_direction();
            let offset = (Vec3A::ZERO - ray.origin) * ray.inv_direction();
            let range = (ray.t_min, ray.t_max * EXIT_PAD);
            let expected = scalar_mask(&planes, &test, scale, offset, range);
            assert_eq!(Baseline.child_mask(&planes, &test, scale, offset, range), expected, "case {k}");
            if let Some(v3) = v3 {
                assert_eq!(v3.child_mask(&planes, &test, scale, offset, range), expected, "case {k}");
            }
            hits[usize::from(expected != 0)] += 1;
        }
        assert!(hits[0] > 1000 && hits[1] > 1000, "{hits:?} nodes missed and hit");
    }
}
