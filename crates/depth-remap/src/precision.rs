//! Simulation of what a GPU stores in its depth buffer, to measure how far apart two surfaces
//! must be to be ordered correctly (the precision study in `docs/depth-mapping.md`).
//!
//! The pipeline is modelled as a GPU runs it, in `f32`: the eye-space z of the vertex is an
//! `f32`; clip z is one fused multiply-add of the matrix's `f32` depth row; `w = -z_eye`
//! exactly; the perspective divide is correctly rounded; OpenGL's viewport transform is one
//! fused multiply-add (`0.5 z + 0.5`); the result is clamped to `[0, 1]` and stored either as
//! an `f32` or as a 24-bit unsigned normalised integer (`round(z * (2^24 - 1))`).

use crate::mapping::DepthMapping;

/// How the depth buffer stores a window depth.
#[derive(Clone, Copy, Debug, PartialEq, Eq, Hash)]
pub enum DepthBufferFormat {
    /// 24-bit unsigned normalised (`Depth24Plus` where it is really 24 bits, `GL_DEPTH_COMPONENT24`).
    Unorm24,
    /// 32-bit float (`Depth32Float`, `GL_DEPTH_COMPONENT32F`).
    Float32,
}

/// The stored depth of a surface at planar eye depth `d`, as a key that grows with distance
/// (so a nearer surface wins a depth test exactly when its key is smaller).
pub fn stored_key(mapping: &DepthMapping, format: DepthBufferFormat, d: f64) -> i64 {
    let (z_scale, z_offset) = mapping.z_row();
    let (z_scale, z_offset) = (z_scale as f32, z_offset as f32);
    let z_eye = -(d as f32);
    let convention = mapping.convention();
    let ndc = if mapping.is_perspective() {
        let z_clip = z_scale.mul_add(z_eye, z_offset);
        z_clip / -z_eye
    } else {
        z_scale.mul_add(z_eye, z_offset)
    };
    let window = if convention.is_gl() { ndc.mul_add(0.5, 0.5) } else { ndc };
    let window = window.clamp(0.0, 1.0);
    let key = match format {
        DepthBufferFormat::Float32 => i64::from(window.to_bits()),
        DepthBufferFormat::Unorm24 => (f64::from(window) * f64::from((1u32 << 24) - 1)).round() as i64,
    };
    if convention.is_reversed() { -key } else { key }
}

/// Deterministic jitter in `[0, 1)`.
fn jitter(k: u64) -> f64 {
    let mut x = k.wrapping_mul(0x9E37_79B9_7F4A_7C15) ^ 0xD1B5_4A32_D192_ED03;
    x ^= x >> 31;
    x = x.wrapping_mul(0xBF58_476D_1CE4_E5B9);
    x ^= x >> 29;
    (x >> 11) as f64 / (1u64 << 53) as f64
}

/// The smallest separation `delta` such that a surface at any depth `x` near `d` (sampled over
/// several quantisation steps around `d`) is stored strictly nearer than one at `x + delta`.
/// `None` when no separation up to a quarter of `min(d, far - d)` suffices.
pub fn min_separation(
    mapping: &DepthMapping,
    format: DepthBufferFormat,
    d: f64,
    samples: usize,
) -> Option<f64> {
    let key = |x: f64| stored_key(mapping, format, x);
    let limit = match mapping.far() {
        crate::mapping::FarPlane::Finite(f) => (f - d).min(d),
        crate::mapping::FarPlane::Infinite => d,
    };
    if limit <= 0.0 {
        return None;
    }
    // The width of the step that contains d, roughly: the smallest step up that changes the key.
    let base = key(d);
    let mut step = d * 1e-9;
    while step < limit && key(d + step) == base {
        step *= 2.0;
    }
    if step >= limit {
        return None;
    }
    // Samples spread over several quantisation steps, jittered so they fall at every phase of
    // the quantisation. The first guess of the step can be too small (d may sit just below a
    // step boundary), so the span grows until it covers at least eight times the answer.
    // Samples and their partners stay within `limit / 2` of d, so inside the near and far planes.
    let max_span = limit / 2.0;
    let mut span = (8.0 * step).max(d * 1e-6).min(max_span);
    for _ in 0..8 {
        let delta = separation_over(&key, d, span, samples, step, max_span / 2.0)?;
        if span >= 8.0 * delta || span >= max_span {
            return Some(delta);
        }
        span = (16.0 * delta).min(max_span);
    }
    None
}

/// The smallest separation that orders every sample in `d ± span / 2` against the surface
/// `delta` behind it, by bisection in log space; `None` past `limit`.
fn separation_over(
    key: &impl Fn(f64) -> i64,
    d: f64,
    span: f64,
    samples: usize,
    first_guess: f64,
    limit: f64,
) -> Option<f64> {
    let points: Vec<(f64, i64)> = (0..samples)
        .map(|k| {
            let x = d + span * ((k as f64 + jitter(k as u64)) / samples as f64 - 0.5);
            (x, key(x))
        })
        .collect();
    let ordered = |delta: f64| points.iter().all(|&(x, kx)| kx < key(x + delta));
    let mut high = first_guess;
    while !ordered(high) {
        high *= 2.0;
        if high > limit {
            return None;
        }
    }
    let mut low = high / 2.0;
    while low > d * 1e-12 && ordered(low) {
        high = low;
        low /= 2.0;
    }
    for _ in 0..40 {
        let mid = (low * high).sqrt();
        if ordered(mid) {
            high = mid;
        } else {
            low = mid;
        }
        if high / low < 1.0 + 1e-4 {
            break;
        }
    }
    Some(high)
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::mapping::{DepthConvention, FarPlane};

    #[test]
    fn unorm24_standard_matches_the_analytic_step() {
        // Window depth f (d - n) / ((f - n) d) has slope f n / ((f - n) d^2); one 24-bit step is
        // 1 / (2^24 - 1), so surfaces need about (f - n) d^2 / (f n (2^24 - 1)) between them.
        // The f32 arithmetic before the quantisation (ulp 2^-24 near 1, the size of one step)
        // adds up to about one more step.
        let (n, f) = (1.0, 1e4);
        let mapping = DepthMapping::perspective(DepthConvention::Gl, n, FarPlane::Finite(f)).unwrap();
        for d in [10.0, 100.0, 1000.0, 5000.0] {
            let analytic = (f - n) * d * d / (f * n * f64::from((1u32 << 24) - 1));
            let measured = min_separation(&mapping, DepthBufferFormat::Unorm24, d, 512).unwrap();
            assert!(
                measured > 0.8 * analytic && measured < 2.5 * analytic,
                "d {d}: measured {measured}, analytic {analytic}"
            );
        }
    }

    #[test]
    fn reversed_float_infinite_is_near_f32_resolution_everywhere() {
        let mapping =
            DepthMapping::perspective(DepthConvention::WgpuReversed, 1.0, FarPlane::Infinite).unwrap();
        for d in [2.0, 1e2, 1e4, 1e6] {
            let measured = min_separation(&mapping, DepthBufferFormat::Float32, d, 512).unwrap();
            // The vertex's own f32 rounding (2^-24 relative) plus one step of n / d: a few 1e-7.
            assert!(measured / d < 4.0 * f64::from(f32::EPSILON), "d {d}: relative {}", measured / d);
        }
    }

    #[test]
    fn standard_float_loses_to_reversed_far_away() {
        let standard = DepthMapping::perspective(DepthConvention::Wgpu, 1.0, FarPlane::Finite(1e5)).unwrap();
        let reversed =
            DepthMapping::perspective(DepthConvention::WgpuReversed, 1.0, FarPlane::Finite(1e5)).unwrap();
        let d = 5e4;
        let s = min_separation(&standard, DepthBufferFormat::Float32, d, 512).unwrap();
        let r = min_separation(&reversed, DepthBufferFormat::Float32, d, 512).unwrap();
        assert!(s > 100.0 * r, "standard {s}, reversed {r}");
    }
}
