//! Eight-lane (AVX2) kernels of the wavefront's stages, chosen at run time
//! ([`X86_64V3::detect`]). Each lane does the IEEE operations of the scalar code it replaces in
//! the same order (no fused multiply-add), so its results are the same bits; the tests below
//! compare them with the scalar code's.

use crate::accel::X86_64V3;
use crate::bsdf::{Bsdf, BsdfSample, Lobe, LobeFlags};
use glam::{Vec2, Vec3};

/// Lanes of one group.
pub(super) const LANES: usize = 8;

/// The inputs of eight Lambert BSDF samples, structure of arrays: the world directions
/// toward the viewer, the shading frames, the geometric normals, the reflectances and the
/// two sampled numbers of the direction.
#[derive(Clone, Copy, Debug, Default)]
pub(super) struct LambertGroup {
    wo: [[f32; LANES]; 3],
    frame: [[[f32; LANES]; 3]; 3],
    ng: [[f32; LANES]; 3],
    r: [[f32; LANES]; 3],
    u: [[f32; LANES]; 2],
}

/// What [`lambert_samples`] returns for a group: the world direction, the BSDF value and the
/// density of each lane, and a bit per lane whose sample exists.
#[derive(Clone, Copy, Debug, Default)]
pub(super) struct LambertSamples {
    wi: [[f32; LANES]; 3],
    f: [[f32; LANES]; 3],
    pdf: [f32; LANES],
    valid: u32,
}

/// The reflectance of a BSDF that is one Lambert lobe: the BSDFs whose samples the lanes
/// take.
pub(super) fn single_lambert(bsdf: &Bsdf) -> Option<Vec3> {
    match bsdf.lobes() {
        [Lobe::Lambert { r }] => Some(*r),
        _ => None,
    }
}

impl LambertGroup {
    /// Puts lane `k`'s sample into the group: `wo` toward the viewer, the BSDF's frame, normal
    /// and reflectance `r`, and the sample's two numbers.
    pub(super) fn set(&mut self, k: usize, wo: Vec3, bsdf: &Bsdf, r: Vec3, u: Vec2) {
        let f = &bsdf.frame;
        for (c, axis) in [f.x, f.y, f.z].into_iter().enumerate() {
            self.frame[c][0][k] = axis.x;
            self.frame[c][1][k] = axis.y;
            self.frame[c][2][k] = axis.z;
        }
        for (dst, v) in [(&mut self.wo, wo), (&mut self.ng, bsdf.ng), (&mut self.r, r)] {
            dst[0][k] = v.x;
            dst[1][k] = v.y;
            dst[2][k] = v.z;
        }
        self.u[0][k] = u.x;
        self.u[1][k] = u.y;
    }
}

impl LambertSamples {
    /// Lane `k`'s sample, as [`Bsdf::sample`] returns it.
    pub(super) fn get(&self, k: usize) -> Option<BsdfSample> {
        (self.valid >> k & 1 == 1).then(|| BsdfSample {
            f: Vec3::new(self.f[0][k], self.f[1][k], self.f[2][k]),
            wi: Vec3::new(self.wi[0][k], self.wi[1][k], self.wi[2][k]),
            pdf: self.pdf[k],
            flags: LobeFlags::DIFFUSE | LobeFlags::REFLECTION,
            eta: 1.0,
        })
    }
}

/// [`Bsdf::sample`] of eight one-lobe Lambert BSDFs (mode radiance, every lobe allowed), the
/// same bits lane by lane.
pub(super) fn lambert_samples(_v3: X86_64V3, group: &LambertGroup) -> LambertSamples {
    #[cfg(target_arch = "x86_64")]
    {
        // SAFETY: a value of `X86_64V3` exists only when the CPU has AVX2.
        unsafe { lambert_samples_avx2(group) }
    }
    #[cfg(not(target_arch = "x86_64"))]
    {
        unreachable!("X86_64V3 is detected on x86-64 only: {group:?}")
    }
}

#[cfg(target_arch = "x86_64")]
#[target_feature(enable = "avx2,fma,bmi1,bmi2,lzcnt,popcnt")]
unsafe fn lambert_samples_avx2(g: &LambertGroup) -> LambertSamples {
    use std::arch::x86_64::*;
    use std::f32::consts::{FRAC_1_PI, FRAC_PI_4};
    // Macros, not closures: a closure would not inherit the target features.
    macro_rules! load {
        ($a:expr) => {
            unsafe { _mm256_loadu_ps($a.as_ptr()) }
        };
    }
    macro_rules! store {
        ($dst:expr, $v:expr) => {
            unsafe { _mm256_storeu_ps($dst.as_mut_ptr(), $v) }
        };
    }
    macro_rules! dot {
        ($a:expr, $b:expr) => {
            _mm256_add_ps(
                _mm256_add_ps(_mm256_mul_ps($a[0], $b[0]), _mm256_mul_ps($a[1], $b[1])),
                _mm256_mul_ps($a[2], $b[2]),
            )
        };
    }
    macro_rules! splat {
        ($v:expr) => {
            _mm256_set1_ps($v)
        };
    }
    let zero = _mm256_setzero_ps();
    let sign = _mm256_set1_ps(-0.0);
    macro_rules! abs {
        ($v:expr) => {
            _mm256_andnot_ps(sign, $v)
        };
    }
    macro_rules! finite {
        ($v:expr) => {
            _mm256_cmp_ps::<_CMP_LT_OQ>(abs!($v), splat!(f32::INFINITY))
        };
    }
    let wo = [load!(g.wo[0]), load!(g.wo[1]), load!(g.wo[2])];
    let fx = [load!(g.frame[0][0]), load!(g.frame[0][1]), load!(g.frame[0][2])];
    let fy = [load!(g.frame[1][0]), load!(g.frame[1][1]), load!(g.frame[1][2])];
    let fz = [load!(g.frame[2][0]), load!(g.frame[2][1]), load!(g.frame[2][2])];
    let ng = [load!(g.ng[0]), load!(g.ng[1]), load!(g.ng[2])];
    let r = [load!(g.r[0]), load!(g.r[1]), load!(g.r[2])];
    // `Frame::to_local`.
    let wol = [dot!(wo, fx), dot!(wo, fy), dot!(wo, fz)];
    let mut ok = _mm256_and_ps(
        _mm256_cmp_ps::<_CMP_NEQ_OQ>(wol[2], zero),
        _mm256_and_ps(finite!(wol[0]), _mm256_and_ps(finite!(wol[1]), finite!(wol[2]))),
    );
    // The lobe's weight (`Vec3::max_element`, then `max(0)` when finite) and the total.
    // glam's `if a > b { a } else { b }`.
    let yz = _mm256_blendv_ps(r[2], r[1], _mm256_cmp_ps::<_CMP_GT_OQ>(r[1], r[2]));
    let w = _mm256_blendv_ps(yz, r[0], _mm256_cmp_ps::<_CMP_GT_OQ>(r[0], yz));
    let w = _mm256_and_ps(_mm256_max_ps(w, zero), finite!(w));
    let total = _mm256_add_ps(zero, w);
    ok = _mm256_and_ps(ok, _mm256_cmp_ps::<_CMP_GT_OQ>(total, zero));
    // `sample_concentric_disk`.
    let ox = _mm256_sub_ps(_mm256_mul_ps(load!(g.u[0]), splat!(2.0)), splat!(1.0));
    let oy = _mm256_sub_ps(_mm256_mul_ps(load!(g.u[1]), splat!(2.0)), splat!(1.0));
    let centre = _mm256_and_ps(_mm256_cmp_ps::<_CMP_EQ_OQ>(ox, zero), _mm256_cmp_ps::<_CMP_EQ_OQ>(oy, zero));
    let x_major = _mm256_cmp_ps::<_CMP_GT_OQ>(abs!(ox), abs!(oy));
    let num = _mm256_blendv_ps(ox, oy, x_major);
    let den = _mm256_blendv_ps(oy, ox, x_major);
    let a = _mm256_mul_ps(splat!(FRAC_PI_4), _mm256_div_ps(num, den));
    // `sin_cos_quarter`.
    use crate::sampling::{COS_C0, COS_C1, COS_C2, SIN_C0, SIN_C1, SIN_C2};
    let z2 = _mm256_mul_ps(a, a);
    let sin_poly = _mm256_add_ps(
        splat!(SIN_C0),
        _mm256_mul_ps(z2, _mm256_add_ps(splat!(SIN_C1), _mm256_mul_ps(z2, splat!(SIN_C2)))),
    );
    let sin = _mm256_add_ps(a, _mm256_mul_ps(_mm256_mul_ps(a, z2), sin_poly));
    let cos_poly = _mm256_add_ps(
        splat!(COS_C0),
        _mm256_mul_ps(z2, _mm256_add_ps(splat!(COS_C1), _mm256_mul_ps(z2, splat!(COS_C2)))),
    );
    let cos = _mm256_add_ps(
        _mm256_sub_ps(splat!(1.0), _mm256_mul_ps(splat!(0.5), z2)),
        _mm256_mul_ps(_mm256_mul_ps(z2, z2), cos_poly),
    );
    let radius = _mm256_blendv_ps(oy, ox, x_major);
    let dx = _mm256_mul_ps(_mm256_blendv_ps(sin, cos, x_major), radius);
    let dy = _mm256_mul_ps(_mm256_blendv_ps(cos, sin, x_major), radius);
    let dx = _mm256_blendv_ps(dx, zero, centre);
    let dy = _mm256_blendv_ps(dy, zero, centre);
    // `sample_cosine_hemisphere`, flipped to `wo`'s side.
    let zz = _mm256_sub_ps(_mm256_sub_ps(splat!(1.0), _mm256_mul_ps(dx, dx)), _mm256_mul_ps(dy, dy));
    let z = _mm256_sqrt_ps(_mm256_max_ps(zz, zero));
    let below = _mm256_cmp_ps::<_CMP_LT_OQ>(wol[2], zero);
    let z = _mm256_blendv_ps(z, _mm256_xor_ps(z, sign), below);
    ok = _mm256_and_ps(ok, _mm256_cmp_ps::<_CMP_GT_OQ>(_mm256_mul_ps(wol[2], z), zero));
    // `Frame::from_local`, then reflection by the geometric normal.
    macro_rules! from_local {
        ($c:expr) => {
            _mm256_add_ps(
                _mm256_add_ps(_mm256_mul_ps(fx[$c], dx), _mm256_mul_ps(fy[$c], dy)),
                _mm256_mul_ps(fz[$c], z),
            )
        };
    }
    let wi = [from_local!(0), from_local!(1), from_local!(2)];
    let reflect = _mm256_cmp_ps::<_CMP_GT_OQ>(_mm256_mul_ps(dot!(wi, ng), dot!(wo, ng)), zero);
    // The one lobe's value and density (`f_pdf_local`).
    let density = _mm256_mul_ps(_mm256_max_ps(abs!(z), zero), splat!(FRAC_1_PI));
    let pdf = _mm256_add_ps(zero, _mm256_mul_ps(_mm256_div_ps(w, total), density));
    ok = _mm256_and_ps(ok, _mm256_cmp_ps::<_CMP_GT_OQ>(pdf, zero));
    let mut out = LambertSamples { valid: _mm256_movemask_ps(ok) as u32, ..LambertSamples::default() };
    for c in 0..3 {
        let f = _mm256_and_ps(_mm256_add_ps(zero, _mm256_mul_ps(r[c], splat!(FRAC_1_PI))), reflect);
        store!(out.f[c], f);
        store!(out.wi[c], wi[c]);
    }
    store!(out.pdf, pdf);
    out
}

/// The inputs of eight evaluations of one-lobe Lambert BSDFs toward light samples: the
/// directions toward the viewer and the light, the shading normals (the frames' z; a Lambert
/// lobe reads nothing else of the frame), the geometric normals and the reflectances.
#[derive(Clone, Copy, Debug, Default)]
pub(super) struct LambertEvalGroup {
    wo: [[f32; LANES]; 3],
    wi: [[f32; LANES]; 3],
    n: [[f32; LANES]; 3],
    ng: [[f32; LANES]; 3],
    r: [[f32; LANES]; 3],
}

impl LambertEvalGroup {
    pub(super) fn set(&mut self, k: usize, wo: Vec3, wi: Vec3, bsdf: &Bsdf, r: Vec3) {
        let fields = [
            (&mut self.wo, wo),
            (&mut self.wi, wi),
            (&mut self.n, bsdf.frame.z),
            (&mut self.ng, bsdf.ng),
            (&mut self.r, r),
        ];
        for (dst, v) in fields {
            dst[0][k] = v.x;
            dst[1][k] = v.y;
            dst[2][k] = v.z;
        }
    }
}

/// [`lambert_f_pdf`]'s results: `f |cos|` and the density of each lane.
#[derive(Clone, Copy, Debug, Default)]
pub(super) struct LambertValues {
    f_cos: [[f32; LANES]; 3],
    pdf: [f32; LANES],
}

impl LambertValues {
    pub(super) fn get(&self, k: usize) -> (Vec3, f32) {
        (Vec3::new(self.f_cos[0][k], self.f_cos[1][k], self.f_cos[2][k]), self.pdf[k])
    }
}

/// [`Bsdf::f_and_pdf`] of eight one-lobe Lambert BSDFs (every lobe allowed) with the value
/// multiplied by `|wi . n|` as direct lighting does, the same bits lane by lane.
pub(super) fn lambert_f_pdf(_v3: X86_64V3, group: &LambertEvalGroup) -> LambertValues {
    #[cfg(target_arch = "x86_64")]
    {
        // SAFETY: a value of `X86_64V3` exists only when the CPU has AVX2.
        unsafe { lambert_f_pdf_avx2(group) }
    }
    #[cfg(not(target_arch = "x86_64"))]
    {
        unreachable!("X86_64V3 is detected on x86-64 only: {group:?}")
    }
}

#[cfg(target_arch = "x86_64")]
#[target_feature(enable = "avx2,fma,bmi1,bmi2,lzcnt,popcnt")]
unsafe fn lambert_f_pdf_avx2(g: &LambertEvalGroup) -> LambertValues {
    use std::arch::x86_64::*;
    use std::f32::consts::FRAC_1_PI;
    macro_rules! load {
        ($a:expr) => {
            unsafe { _mm256_loadu_ps($a.as_ptr()) }
        };
    }
    macro_rules! dot {
        ($a:expr, $b:expr) => {
            _mm256_add_ps(
                _mm256_add_ps(_mm256_mul_ps($a[0], $b[0]), _mm256_mul_ps($a[1], $b[1])),
                _mm256_mul_ps($a[2], $b[2]),
            )
        };
    }
    let zero = _mm256_setzero_ps();
    let sign = _mm256_set1_ps(-0.0);
    let wo = [load!(g.wo[0]), load!(g.wo[1]), load!(g.wo[2])];
    let wi = [load!(g.wi[0]), load!(g.wi[1]), load!(g.wi[2])];
    let fz = [load!(g.n[0]), load!(g.n[1]), load!(g.n[2])];
    let ng = [load!(g.ng[0]), load!(g.ng[1]), load!(g.ng[2])];
    let r = [load!(g.r[0]), load!(g.r[1]), load!(g.r[2])];
    // The local directions' z (`Frame::to_local`): all the lobe reads of them.
    let wo_z = dot!(wo, fz);
    let wi_z = dot!(wi, fz);
    let reflect = _mm256_cmp_ps::<_CMP_GT_OQ>(_mm256_mul_ps(dot!(wi, ng), dot!(wo, ng)), zero);
    // `f_pdf_local` of one lobe: nothing when `wo` lies in the surface; the lobe's value and
    // density in the same hemisphere; the value only for reflection.
    let some = _mm256_cmp_ps::<_CMP_NEQ_UQ>(wo_z, zero);
    let same = _mm256_and_ps(some, _mm256_cmp_ps::<_CMP_GT_OQ>(_mm256_mul_ps(wo_z, wi_z), zero));
    let yz = _mm256_blendv_ps(r[2], r[1], _mm256_cmp_ps::<_CMP_GT_OQ>(r[1], r[2]));
    let w = _mm256_blendv_ps(yz, r[0], _mm256_cmp_ps::<_CMP_GT_OQ>(r[0], yz));
    let w = _mm256_and_ps(
        _mm256_max_ps(w, zero),
        _mm256_cmp_ps::<_CMP_LT_OQ>(_mm256_andnot_ps(sign, w), _mm256_set1_ps(f32::INFINITY)),
    );
    let total = _mm256_add_ps(zero, w);
    let with_pdf = _mm256_cmp_ps::<_CMP_GT_OQ>(total, zero);
    let abs_wi_z = _mm256_andnot_ps(sign, wi_z);
    let density =
        _mm256_and_ps(_mm256_mul_ps(_mm256_max_ps(abs_wi_z, zero), _mm256_set1_ps(FRAC_1_PI)), same);
    let pdf = _mm256_and_ps(_mm256_add_ps(zero, _mm256_mul_ps(_mm256_div_ps(w, total), density)), with_pdf);
    let pdf = _mm256_and_ps(pdf, some);
    let mut out = LambertValues::default();
    for (f_cos, &rc) in out.f_cos.iter_mut().zip(&r) {
        let value = _mm256_and_ps(_mm256_mul_ps(rc, _mm256_set1_ps(FRAC_1_PI)), same);
        let f = _mm256_and_ps(_mm256_add_ps(zero, value), _mm256_and_ps(reflect, some));
        // `f * wi.dot(frame.z).abs()`: the dot product is the local z computed above.
        unsafe { _mm256_storeu_ps(f_cos.as_mut_ptr(), _mm256_mul_ps(f, abs_wi_z)) };
    }
    unsafe { _mm256_storeu_ps(out.pdf.as_mut_ptr(), pdf) };
    out
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::bsdf::TransportMode;
    use crate::math::Frame;
    use crate::sampling::Rng;

    fn direction(rng: &mut Rng) -> Vec3 {
        crate::sampling::sample_uniform_sphere(rng.uniform2())
    }

    /// The lanes give [`Bsdf::sample`]'s bits for random frames, normals, reflectances, views
    /// and numbers, the disc's centre and axes included.
    #[test]
    fn lambert_lanes_match_the_scalar_sample() {
        let Some(v3) = X86_64V3::detect() else {
            eprintln!("skipped: this CPU lacks x86-64-v3");
            return;
        };
        let mut rng = Rng::new(11, 3);
        let special = [Vec2::new(0.5, 0.5), Vec2::new(0.5, 0.9), Vec2::new(0.1, 0.5), Vec2::new(0.0, 0.0)];
        let mut compared = 0;
        for round in 0..4000 {
            let mut group = LambertGroup::default();
            let mut cases = Vec::new();
            for k in 0..LANES {
                let n = direction(&mut rng);
                let frame = Frame::from_z_and_tangent(n, direction(&mut rng));
                // The geometric normal near the shading one, sometimes on the other side.
                let ng = (n + direction(&mut rng) * 0.3).normalize();
                let mut bsdf = Bsdf::new(frame, if rng.uniform() < 0.1 { -ng } else { ng });
                let r = Vec3::new(rng.uniform(), rng.uniform(), rng.uniform());
                bsdf.add(Lobe::Lambert { r });
                let wo = if k == 3 { frame.x } else { direction(&mut rng) };
                let u = if round % 5 == 0 { special[k % 4] } else { rng.uniform2() };
                let u_lobe = rng.uniform();
                group.set(k, wo, &bsdf, r, u);
                cases.push((bsdf, wo, u_lobe, u));
            }
            let lanes = lambert_samples(v3, &group);
            for (k, (bsdf, wo, u_lobe, u)) in cases.iter().enumerate() {
                let scalar = bsdf.sample(*wo, *u_lobe, *u, TransportMode::Radiance, LobeFlags::ALL);
                let bits = |s: Option<BsdfSample>| {
                    s.map(|s| {
                        (s.f.to_array().map(f32::to_bits), s.wi.to_array().map(f32::to_bits), s.pdf.to_bits())
                    })
                };
                assert_eq!(bits(lanes.get(k)), bits(scalar), "lane {k}, wo {wo}, u {u}");
                compared += usize::from(scalar.is_some());
            }
        }
        assert!(compared > 20_000, "{compared} samples compared");
    }

    /// [`lambert_f_pdf`] gives [`Bsdf::f_and_pdf`]'s bits times `|wi . n|` for random frames,
    /// normals, reflectances and directions, on both sides and in the surface.
    #[test]
    fn lambert_evaluation_lanes_match_the_scalar_one() {
        let Some(v3) = X86_64V3::detect() else {
            eprintln!("skipped: this CPU lacks x86-64-v3");
            return;
        };
        let mut rng = Rng::new(12, 4);
        for _ in 0..4000 {
            let mut group = LambertEvalGroup::default();
            let mut cases = Vec::new();
            for k in 0..LANES {
                let n = direction(&mut rng);
                let frame = Frame::from_z_and_tangent(n, direction(&mut rng));
                let ng = (n + direction(&mut rng) * 0.3).normalize();
                let mut bsdf = Bsdf::new(frame, ng);
                let r = Vec3::new(rng.uniform(), rng.uniform(), rng.uniform());
                bsdf.add(Lobe::Lambert { r });
                let wo = if k == 2 { frame.x } else { direction(&mut rng) };
                let wi = if k == 5 { frame.y } else { direction(&mut rng) };
                group.set(k, wo, wi, &bsdf, r);
                cases.push((bsdf, wo, wi));
            }
            let lanes = lambert_f_pdf(v3, &group);
            for (k, (bsdf, wo, wi)) in cases.iter().enumerate() {
                let (f, pdf) = bsdf.f_and_pdf(*wo, *wi, LobeFlags::ALL);
                let f = f * wi.dot(bsdf.frame.z).abs();
                let (lane_f, lane_pdf) = lanes.get(k);
                assert_eq!(lane_f.to_array().map(f32::to_bits), f.to_array().map(f32::to_bits), "lane {k}");
                assert_eq!(lane_pdf.to_bits(), pdf.to_bits(), "lane {k}");
            }
        }
    }
}
