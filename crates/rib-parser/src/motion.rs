//! Transformation motion (`MotionBegin [t0 t1 ...]` around transformation requests): the
//! transformation at each key time, and the transformation between keys as pbrt's
//! `AnimatedTransform` interpolates it.
//!
//! Each key is decomposed into a translation `T`, a rotation `R` (the polar decomposition of
//! the upper 3x3) and a symmetric stretch `S` (scale and shear), `M = T R S`. Between two keys
//! `T` and `S` are interpolated linearly and `R` by quaternion slerp, so a rotating object
//! keeps its size (a matrix lerp would shrink it). Like pbrt, a rotation turns along the
//! shorter arc between two keys: a half turn or more needs more keys.

use glam::{DMat3, DMat4, DQuat, DVec3};

/// A transformation given at increasing key times.
#[derive(Clone, Debug, PartialEq)]
pub struct TransformMotion {
    times: Vec<f64>,
    matrices: Vec<DMat4>,
    keys: Vec<Option<Decomposed>>,
}

/// `M = T R S` of an affine matrix.
#[derive(Clone, Copy, Debug, PartialEq)]
struct Decomposed {
    translation: DVec3,
    rotation: DQuat,
    stretch: DMat3,
}

impl TransformMotion {
    /// The motion through `matrices` at `times` (same length, at least one, times
    /// non-decreasing), or `None` when they do not fit that.
    pub fn new(times: Vec<f64>, matrices: Vec<DMat4>) -> Option<TransformMotion> {
        if times.is_empty()
            || times.len() != matrices.len()
            || !times.iter().all(|t| t.is_finite())
            || times.windows(2).any(|w| w[0] > w[1])
        {
            return None;
        }
        let keys = matrices.iter().map(decompose).collect();
        Some(TransformMotion { times, matrices, keys })
    }

    pub fn times(&self) -> &[f64] {
        &self.times
    }

    pub fn matrices(&self) -> &[DMat4] {
        &self.matrices
    }

    /// Whether every key is the same matrix (no motion at all).
    pub fn is_static(&self) -> bool {
        self.matrices.iter().all(|m| *m == self.matrices[0])
    }

    /// The same keys with every matrix `m` replaced by `f(m)` (e.g. `before * m * after`).
    pub fn map(&self, f: impl Fn(DMat4) -> DMat4) -> Option<TransformMotion> {
        TransformMotion::new(self.times.clone(), self.matrices.iter().map(|m| f(*m)).collect())
    }

    /// The same matrices at times `f(t)` (e.g. scene time to shutter fraction).
    pub fn retimed(&self, f: impl Fn(f64) -> f64) -> Option<TransformMotion> {
        TransformMotion::new(self.times.iter().map(|t| f(*t)).collect(), self.matrices.clone())
    }

    /// The transformation at `time`: the first key before the first time, the last after the
    /// last, a key's own matrix at its time (bit for bit), interpolated in between.
    pub fn at(&self, time: f64) -> DMat4 {
        let n = self.times.len();
        if time.is_nan() || time <= self.times[0] {
            return self.matrices[0];
        }
        if time >= self.times[n - 1] {
            return self.matrices[n - 1];
        }
        // The segment [t_i, t_i+1) holding `time`; zero-length segments are never chosen.
        let i = self.times.partition_point(|&t| t <= time) - 1;
        let (t0, t1) = (self.times[i], self.times[i + 1]);
        if time == t0 {
            return self.matrices[i];
        }
        let f = (time - t0) / (t1 - t0);
        match (&self.keys[i], &self.keys[i + 1]) {
            (Some(a), Some(b)) => a.lerp(b, f).matrix(),
            // A projective key: element-wise interpolation is all that is defined.
            _ => self.matrices[i] * (1.0 - f) + self.matrices[i + 1] * f,
        }
    }
}

impl Decomposed {
    fn lerp(&self, other: &Decomposed, f: f64) -> Decomposed {
        Decomposed {
            translation: self.translation.lerp(other.translation, f),
            rotation: self.rotation.slerp(other.rotation, f),
            stretch: self.stretch * (1.0 - f) + other.stretch * f,
        }
    }

    fn matrix(&self) -> DMat4 {
        let linear = DMat3::from_quat(self.rotation) * self.stretch;
        let mut m = DMat4::from_mat3(linear);
        m.w_axis = self.translation.extend(1.0);
        m
    }
}

/// `M = T R S` (pbrt's `AnimatedTransform::Decompose`), `None` for a projective or singular
/// matrix. A reflection is kept in the stretch so that `R` is a proper rotation.
fn decompose(m: &DMat4) -> Option<Decomposed> {
    if m.x_axis.w != 0.0 || m.y_axis.w != 0.0 || m.z_axis.w != 0.0 || m.w_axis.w != 1.0 {
        return None;
    }
    let linear = DMat3::from_mat4(*m);
    if !linear.is_finite() || linear.determinant() == 0.0 {
        return None;
    }
    // Polar decomposition: average the matrix with its inverse transpose until it is a
    // rotation (quadratic convergence; 100 rounds is pbrt's bound).
    let mut r = linear;
    for _ in 0..100 {
        let next = (r + r.transpose().inverse()) * 0.5;
        let change = (0..3).map(|c| (next.col(c) - r.col(c)).abs().max_element()).fold(0.0, f64::max);
        r = next;
        if change < 1e-14 {
            break;
        }
    }
    if r.determinant() < 0.0 {
        r = -r;
    }
    let stretch = r.transpose() * linear;
    let rotation = DQuat::from_mat3(&r).normalize();
    if !rotation.is_finite() || !stretch.is_finite() {
        return None;
    }
    Some(Decomposed { translation: m.w_axis.truncate(), rotation, stretch })
}

#[cfg(test)]
mod tests {
    use super::*;

    fn close(a: DMat4, b: DMat4) -> bool {
        a.abs_diff_eq(b, 1e-12)
    }

    #[test]
    fn keys_are_exact_and_translation_is_linear() {
        let a = DMat4::from_translation(DVec3::new(-1.0, 0.0, 5.0));
        let b = DMat4::from_translation(DVec3::new(1.0, 2.0, 5.0));
        let m = TransformMotion::new(vec![0.0, 1.0], vec![a, b]).unwrap();
        assert_eq!(m.at(0.0), a);
        assert_eq!(m.at(-3.0), a);
        assert_eq!(m.at(1.0), b);
        assert!(close(m.at(0.25), DMat4::from_translation(DVec3::new(-0.5, 0.5, 5.0))));
    }

    #[test]
    fn rotation_keeps_its_length_and_turns_at_constant_speed() {
        let a = DMat4::from_rotation_z(0.0);
        let b = DMat4::from_rotation_z(std::f64::consts::FRAC_PI_2);
        let m = TransformMotion::new(vec![0.0, 2.0], vec![a, b]).unwrap();
        // A matrix lerp would give length cos(45 deg) here.
        assert!(close(m.at(1.0), DMat4::from_rotation_z(std::f64::consts::FRAC_PI_4)));
        assert!(close(m.at(0.5), DMat4::from_rotation_z(std::f64::consts::FRAC_PI_8)));
    }

    #[test]
    fn scale_rotation_and_translation_together() {
        let key = |s: f64, angle: f64, x: f64| {
            DMat4::from_translation(DVec3::new(x, 0.0, 0.0))
                * DMat4::from_rotation_y(angle)
                * DMat4::from_scale(DVec3::new(s, 2.0 * s, 1.0))
        };
        let m = TransformMotion::new(
            vec![1.0, 3.0, 4.0],
            vec![key(1.0, 0.0, 0.0), key(2.0, 1.0, 4.0), key(2.0, 1.0, 5.0)],
        )
        .unwrap();
        assert!(close(m.at(2.0), key(1.5, 0.5, 2.0)));
        assert!(close(m.at(3.5), key(2.0, 1.0, 4.5)));
        // A mirror image stays mirrored between its keys.
        let mirror = DMat4::from_scale(DVec3::new(-1.0, 1.0, 1.0));
        let m =
            TransformMotion::new(vec![0.0, 1.0], vec![mirror, DMat4::from_rotation_z(0.5) * mirror]).unwrap();
        assert!(close(m.at(0.5), DMat4::from_rotation_z(0.25) * mirror));
    }

    #[test]
    fn bad_keys_are_refused() {
        let i = DMat4::IDENTITY;
        assert!(TransformMotion::new(vec![], vec![]).is_none());
        assert!(TransformMotion::new(vec![0.0], vec![i, i]).is_none());
        assert!(TransformMotion::new(vec![1.0, 0.0], vec![i, i]).is_none());
        assert!(TransformMotion::new(vec![0.0, f64::NAN], vec![i, i]).is_none());
    }
}
