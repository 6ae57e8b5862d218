//! Morris & Joshi's formulas and matrices exactly as printed, the OpenGL functions they name,
//! and a numerical check of what the printed pieces do together (`docs/depth-mapping.md`).
//!
//! The paper gives
//!
//! ```text
//! z_transformed = z_eye (zFar + zNear) / (zFar - zNear) - 2 zNear zFar / (zFar - zNear)
//! ```
//!
//! as the value "passed on to the viewport transformation", and draws the pre-rendered points
//! with `gluOrtho2D`'s matrix modified so that its depth row is `[0 0 1 1]`. With OpenGL's own
//! `gluPerspective`, the printed formula is the **clip-space** z (before the perspective divide)
//! of a point at eye-space `z = -z_eye`, i.e. `z_eye` must be the positive planar distance in
//! front of the eye. A perspective-drawn polygon then reaches the viewport with
//! `z_ndc = z_transformed / z_eye`, while a point drawn with the modified matrix reaches it
//! with `z_ndc = z_in + 1` (`w = 1`). The two agree only if the point's vertex z is
//! `z_transformed / z_eye - 1`: the printed recipe (feed `z_transformed`) misses both the
//! divide and the `- 1`, and would put almost every point outside the clip volume. This crate
//! feeds NDC depth through [`crate::point_cloud_matrix`], whose depth row is `[0 0 1 0]`.

use crate::mapping::from_rows;
use glam::{DMat4, DVec4};

/// The paper's `z_transformed`, exactly as printed.
pub fn paper_z_transformed(z_eye: f64, z_near: f64, z_far: f64) -> f64 {
    z_eye * (z_far + z_near) / (z_far - z_near) - 2.0 * (z_near * z_far) / (z_far - z_near)
}

/// `gluPerspective(fovy, aspect, zNear, zFar)` as GLU defines it (`fovy` in degrees, the full
/// vertical angle).
pub fn glu_perspective(fovy_degrees: f64, aspect: f64, z_near: f64, z_far: f64) -> DMat4 {
    let f = 1.0 / (fovy_degrees.to_radians() / 2.0).tan();
    from_rows([
        [f / aspect, 0.0, 0.0, 0.0],
        [0.0, f, 0.0, 0.0],
        [0.0, 0.0, (z_far + z_near) / (z_near - z_far), 2.0 * z_far * z_near / (z_near - z_far)],
        [0.0, 0.0, -1.0, 0.0],
    ])
}

/// `glOrtho(left, right, bottom, top, zNear, zFar)`: the matrix the paper prints as "the
/// immediate output of `gluOrtho2D()`" (with its `zNear`/`zFar`).
pub fn gl_ortho(left: f64, right: f64, bottom: f64, top: f64, z_near: f64, z_far: f64) -> DMat4 {
    from_rows([
        [2.0 / (right - left), 0.0, 0.0, -(right + left) / (right - left)],
        [0.0, 2.0 / (top - bottom), 0.0, -(top + bottom) / (top - bottom)],
        [0.0, 0.0, -2.0 / (z_far - z_near), -(z_far + z_near) / (z_far - z_near)],
        [0.0, 0.0, 0.0, 1.0],
    ])
}

/// `gluOrtho2D(left, right, bottom, top)` = `glOrtho(left, right, bottom, top, -1, 1)`.
pub fn glu_ortho_2d(left: f64, right: f64, bottom: f64, top: f64) -> DMat4 {
    gl_ortho(left, right, bottom, top, -1.0, 1.0)
}

/// The paper's modified `gluOrtho2D` matrix, exactly as printed: depth row `[0 0 1 1]`.
pub fn paper_modified_ortho(left: f64, right: f64, bottom: f64, top: f64) -> DMat4 {
    from_rows([
        [2.0 / (right - left), 0.0, 0.0, -(right + left) / (right - left)],
        [0.0, 2.0 / (top - bottom), 0.0, -(top + bottom) / (top - bottom)],
        [0.0, 0.0, 1.0, 1.0],
        [0.0, 0.0, 0.0, 1.0],
    ])
}

/// OpenGL's viewport depth transform with `glDepthRange(0, 1)`.
pub fn gl_window_from_ndc(ndc: f64) -> f64 {
    0.5 * ndc + 0.5
}

/// What each path delivers for a surface at planar eye depth `d` (all in `f64`).
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct PaperColocation {
    pub eye_depth: f64,
    /// The printed formula with `z_eye = +d`.
    pub z_transformed: f64,
    /// Clip-space z of `gluPerspective` applied to the eye point `(0, 0, -d, 1)`.
    pub polygon_clip_z: f64,
    /// Its `w` (= d).
    pub polygon_clip_w: f64,
    /// What the polygon gives the viewport transform (after the divide).
    pub polygon_ndc: f64,
    /// The polygon's window depth.
    pub polygon_window: f64,
    /// NDC z of a point whose vertex z is `z_transformed`, through the printed matrix.
    pub printed_point_ndc: f64,
    /// Whether that point survives clipping (`-1 <= ndc <= 1`).
    pub printed_point_visible: bool,
    /// NDC z of a point fed the printed formula with OpenGL's negative eye z (`z_eye = -d`).
    pub printed_negative_eye_ndc: f64,
    /// The vertex z that makes the printed matrix co-locate: `z_transformed / d - 1`.
    pub vertex_z_for_printed_matrix: f64,
    /// NDC z of a point fed `z_transformed / d` through the corrected `[0 0 1 0]` row.
    pub corrected_point_ndc: f64,
}

/// Runs the printed recipe and the perspective path for one surface (`fovy`/`aspect` only
/// affect x and y).
pub fn paper_colocation(d: f64, z_near: f64, z_far: f64) -> PaperColocation {
    let perspective = glu_perspective(60.0, 1.0, z_near, z_far);
    let clip = perspective * DVec4::new(0.0, 0.0, -d, 1.0);
    let z_transformed = paper_z_transformed(d, z_near, z_far);
    let modified = paper_modified_ortho(0.0, 1.0, 0.0, 1.0);
    let printed = modified * DVec4::new(0.5, 0.5, z_transformed, 1.0);
    let negative = modified * DVec4::new(0.5, 0.5, paper_z_transformed(-d, z_near, z_far), 1.0);
    let vertex_z = z_transformed / d - 1.0;
    let corrected = crate::mapping::point_cloud_matrix(1, 1) * DVec4::new(0.5, 0.5, z_transformed / d, 1.0);
    let polygon_ndc = clip.z / clip.w;
    PaperColocation {
        eye_depth: d,
        z_transformed,
        polygon_clip_z: clip.z,
        polygon_clip_w: clip.w,
        polygon_ndc,
        polygon_window: gl_window_from_ndc(polygon_ndc),
        printed_point_ndc: printed.z / printed.w,
        printed_point_visible: (-1.0..=1.0).contains(&(printed.z / printed.w)),
        printed_negative_eye_ndc: negative.z / negative.w,
        vertex_z_for_printed_matrix: vertex_z,
        corrected_point_ndc: corrected.z / corrected.w,
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    fn close(a: f64, b: f64) -> bool {
        (a - b).abs() <= 1e-12 * (1.0 + a.abs().max(b.abs()))
    }

    #[test]
    fn printed_formula_is_glu_perspective_clip_z_for_positive_eye_depth() {
        for (n, f) in [(1.0, 100.0), (0.1, 1e4), (2.0, 3.0)] {
            for d in [n, 1.5 * n, 0.5 * (n + f), f] {
                let c = paper_colocation(d, n, f);
                assert!(close(c.z_transformed, c.polygon_clip_z), "{c:?}");
                assert!(close(c.polygon_clip_w, d));
            }
            // Clip z runs from -n at the near plane to f at the far plane.
            assert!(close(paper_z_transformed(n, n, f), -n));
            assert!(close(paper_z_transformed(f, n, f), f));
        }
    }

    #[test]
    fn printed_matrix_adds_one_and_needs_the_divided_value_minus_one() {
        let (n, f) = (1.0, 100.0);
        let c = paper_colocation(10.0, n, f);
        // z_t = (10 * 101 - 200) / 99 = 8.1818...; the polygon's NDC is z_t / 10.
        assert!(close(c.z_transformed, 810.0 / 99.0));
        assert!(close(c.polygon_ndc, 81.0 / 99.0));
        // As printed, the point gets z_t + 1 = 9.18 and is clipped away.
        assert!(close(c.printed_point_ndc, c.z_transformed + 1.0));
        assert!(!c.printed_point_visible);
        // Fed z_t / d - 1 it co-locates; the corrected matrix takes z_t / d.
        let fixed = paper_modified_ortho(0.0, 1.0, 0.0, 1.0)
            * DVec4::new(0.5, 0.5, c.vertex_z_for_printed_matrix, 1.0);
        assert!(close(fixed.z, c.polygon_ndc));
        assert!(close(c.corrected_point_ndc, c.polygon_ndc));
        // OpenGL's negative eye z in the printed formula is no better.
        assert!(c.printed_negative_eye_ndc < -1.0);
    }

    #[test]
    fn printed_gluortho2d_depth_row_is_minus_one() {
        let m = glu_ortho_2d(0.0, 640.0, 0.0, 480.0);
        assert_eq!(m.row(2), DVec4::new(0.0, 0.0, -1.0, 0.0));
        let p = paper_modified_ortho(0.0, 640.0, 0.0, 480.0);
        assert_eq!(p.row(2), DVec4::new(0.0, 0.0, 1.0, 1.0));
        assert_eq!(p.row(0), m.row(0));
        assert_eq!(p.row(1), m.row(1));
    }
}
