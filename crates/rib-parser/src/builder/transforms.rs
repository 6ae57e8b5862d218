//! The transformation requests (`Identity`, `Transform`, `ConcatTransform`, `Perspective`,
//! `Translate`, `Rotate`, `Scale`, `Skew`) and named coordinate systems (`CoordinateSystem`,
//! `CoordSysTransform`), composed in `f64`.

use super::{MotionStep, SceneBuilder};
use crate::diagnostics::DiagnosticKind;
use crate::target::Cx;
use glam::{DMat4, DVec3, DVec4};
use std::sync::Arc;

impl SceneBuilder {
    /// The handedness of the current coordinate system: left-handed (RenderMan's camera
    /// space) when `det(camera_from_current) > 0`.
    pub(super) fn coordsys_left_handed(&self) -> bool {
        let camera_from_current =
            if self.in_world() { self.camera_from_world * self.gs.ctm } else { self.gs.ctm };
        camera_from_current.determinant() > 0.0
    }

    /// Applies `m` to the current transformation (`ctm = ctm * m`), refusing non-finite results.
    /// Inside a motion block the request is the next key (see `motion_end`).
    pub(super) fn concat(&mut self, m: DMat4, request: &str, cx: &mut Cx<'_>) {
        if self.record_motion_step(MotionStep::Concat(m)) {
            return;
        }
        let next = self.gs.ctm * m;
        let next_motion = self.gs.motion.as_ref().and_then(|motion| motion.map(|k| k * m));
        if !next.is_finite()
            || next_motion.as_ref().is_some_and(|n| !n.matrices().iter().all(|k| k.is_finite()))
        {
            cx.error(
                DiagnosticKind::BadValue,
                format!("{request} makes the transformation non-finite; ignored"),
            );
            return;
        }
        self.gs.ctm = next;
        self.gs.motion = next_motion.map(Arc::new);
    }

    /// Sets the current transformation (outside a motion block; inside, `m` is the next key).
    pub(super) fn set_transform(&mut self, m: DMat4) {
        if self.record_motion_step(MotionStep::Set(m)) {
            return;
        }
        self.gs.ctm = m;
        self.gs.motion = None;
    }

    pub(super) fn identity(&mut self, _cx: &mut Cx<'_>) {
        self.set_transform(DMat4::IDENTITY);
    }

    pub(super) fn transform(&mut self, matrix: DMat4, cx: &mut Cx<'_>) {
        if !matrix.is_finite() {
            cx.error(DiagnosticKind::BadValue, "Transform: the matrix is not finite; ignored");
            return;
        }
        self.set_transform(matrix);
    }

    pub(super) fn concat_transform(&mut self, matrix: DMat4, cx: &mut Cx<'_>) {
        self.concat(matrix, "ConcatTransform", cx);
    }

    pub(super) fn perspective(&mut self, fov_degrees: f64, cx: &mut Cx<'_>) {
        if !(fov_degrees > 0.0 && fov_degrees < 180.0) {
            cx.error(
                DiagnosticKind::BadValue,
                format!("Perspective: fov {fov_degrees} must be in (0, 180) degrees"),
            );
            return;
        }
        self.concat(perspective_matrix(fov_degrees), "Perspective", cx);
    }

    pub(super) fn translate(&mut self, delta: DVec3, cx: &mut Cx<'_>) {
        self.concat(DMat4::from_translation(delta), "Translate", cx);
    }

    pub(super) fn rotate(&mut self, angle_degrees: f64, axis: DVec3, cx: &mut Cx<'_>) {
        let len = axis.length();
        if !(len > 0.0 && len.is_finite()) {
            if angle_degrees == 0.0 {
                // `Rotate 0 0 0 0` is a no-op some writers emit.
                return;
            }
            cx.error(DiagnosticKind::BadValue, "Rotate: the axis has zero length; ignored");
            return;
        }
        self.concat(rotation_matrix(angle_degrees, axis / len), "Rotate", cx);
    }

    pub(super) fn scale(&mut self, scale: DVec3, cx: &mut Cx<'_>) {
        self.concat(DMat4::from_scale(scale), "Scale", cx);
    }

    pub(super) fn skew(&mut self, angle_degrees: f64, from: DVec3, to: DVec3, cx: &mut Cx<'_>) {
        match skew_matrix(angle_degrees, from, to) {
            Ok(m) => self.concat(m, "Skew", cx),
            Err(msg) => cx.error(DiagnosticKind::BadValue, format!("Skew: {msg}; ignored")),
        }
    }

    pub(super) fn coordinate_system(&mut self, name: &str, _cx: &mut Cx<'_>) {
        let m = self.gs.ctm;
        match self.named_spaces.iter_mut().find(|(n, _)| n == name) {
            Some(entry) => entry.1 = m,
            None => self.named_spaces.push((name.to_string(), m)),
        }
        if let Some(world) = self.world_mut() {
            match world.coordinate_systems.iter_mut().find(|(n, _)| n == name) {
                Some(entry) => entry.1 = m,
                None => world.coordinate_systems.push((name.to_string(), m)),
            }
        }
    }

    pub(super) fn coord_sys_transform(&mut self, name: &str, cx: &mut Cx<'_>) {
        let in_world = self.in_world();
        let m = match name {
            "world" if in_world => Some(DMat4::IDENTITY),
            "camera" if in_world => Some(self.camera_from_world.inverse()),
            "camera" => Some(DMat4::IDENTITY),
            "object" | "current" | "shader" => Some(self.gs.ctm),
            other => self.named_spaces.iter().find(|(n, _)| n == other).map(|(_, m)| *m),
        };
        match m {
            Some(m) => self.set_transform(m),
            None => cx.error(
                DiagnosticKind::UnknownHandle,
                format!("CoordSysTransform: no coordinate system named \"{name}\""),
            ),
        }
    }
}

/// Exporters write camera and object matrices whose projective row holds float noise
/// (`2.7e-12` instead of 0, as in the corpus's `complexnurbs1.rib`); below `f32` precision it
/// is taken as the exact affine row `(0 0 0 1)`.
pub(super) fn snap_affine(mut m: DMat4) -> DMat4 {
    let r = m.row(3);
    let noise = f64::from(f32::EPSILON);
    if r.x.abs() < noise
        && r.y.abs() < noise
        && r.z.abs() < noise
        && (r.w - 1.0).abs() < noise
        && r != DVec4::W
    {
        m.x_axis.w = 0.0;
        m.y_axis.w = 0.0;
        m.z_axis.w = 0.0;
        m.w_axis.w = 1.0;
    }
    m
}

/// `Perspective fov`: the projection of PRMan (and Aqsis, which matched it in testing), in the
/// row-vector layout `[1 0 0 0; 0 1 0 0; 0 0 f f; 0 0 -f 0]` with `f = tan(fov / 2)`:
/// screen `x = x / (z f)`, `y = y / (z f)`.
pub fn perspective_matrix(fov_degrees: f64) -> DMat4 {
    let f = (fov_degrees.to_radians() * 0.5).tan();
    DMat4::from_cols_array(&[1.0, 0.0, 0.0, 0.0, 0.0, 1.0, 0.0, 0.0, 0.0, 0.0, f, f, 0.0, 0.0, -f, 0.0])
}

/// `Rotate angle x y z`: the right-hand-rule rotation about the unit axis (numerically the
/// matrix pbrt and Aqsis build).
pub fn rotation_matrix(angle_degrees: f64, unit_axis: DVec3) -> DMat4 {
    DMat4::from_axis_angle(unit_axis, angle_degrees.to_radians())
}

/// `Skew angle d1 d2` (RISpec §4.3): shears along `d2` so that `d1` turns by `angle` towards
/// `d2`, leaving the plane of `d1` and `d2` (and every plane parallel to it) in place.
/// With `d1 = cos(a) d2 + sin(a) o` (`o` the unit vector in the plane, perpendicular to `d2`),
/// points move by `s (p . o) d2` with `s = cot(a - angle) - cot(a)`.
pub fn skew_matrix(angle_degrees: f64, d1: DVec3, d2: DVec3) -> Result<DMat4, String> {
    let (l1, l2) = (d1.length(), d2.length());
    if !(l1 > 0.0 && l2 > 0.0 && l1.is_finite() && l2.is_finite()) {
        return Err("both vectors need a non-zero length".into());
    }
    let (d1, d2) = (d1 / l1, d2 / l2);
    let par = d1.dot(d2).clamp(-1.0, 1.0);
    let a = par.acos();
    let o = d1 - par * d2;
    let perp = o.length();
    if perp < 1e-12 {
        return Err("the two vectors are parallel".into());
    }
    let o = o / perp;
    let angle = angle_degrees.to_radians();
    let b = a - angle;
    if !(b > 0.0 && b < std::f64::consts::PI) {
        return Err(format!(
            "angle {angle_degrees} skews past the axis (must be between {} and {})",
            (a - std::f64::consts::PI).to_degrees(),
            a.to_degrees()
        ));
    }
    let s = 1.0 / b.tan() - par / perp;
    // p' = p + s (o . p) d2, i.e. I + s d2 o^T.
    let shear = glam::DMat3::from_cols(d2 * (s * o.x), d2 * (s * o.y), d2 * (s * o.z));
    Ok(DMat4::from_mat3(glam::DMat3::IDENTITY + shear))
}
