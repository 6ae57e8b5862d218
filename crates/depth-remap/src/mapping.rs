//! Depth conventions: from planar eye depth to the value a depth buffer stores, and the
//! projection matrices that produce it.
//!
//! Every function takes the **planar eye depth** `d > 0` (camera-space z, the distance in front
//! of the eye plane; `-z` in right-handed eye space) and returns a value computed in `f64`, to
//! be rounded once by the caller. Names follow glam: `_gl` is OpenGL's `[-1, 1]` NDC depth with
//! `glDepthRange(0, 1)`, `_wgpu` is the `[0, 1]` NDC depth of wgpu, Vulkan, Direct3D and Metal,
//! `reversed` maps the near plane to 1 and the far plane to 0.
//!
//! | convention | NDC depth at near .. far | window depth at near .. far | window depth at `d` (finite far) | infinite far | depth test | clear |
//! |---|---|---|---|---|---|---|
//! | [`DepthConvention::Gl`] | -1 .. 1 | 0 .. 1 | `f (d - n) / ((f - n) d)` | `1 - n / d` | `LESS` | 1 |
//! | [`DepthConvention::GlReversed`] | 1 .. -1 | 1 .. 0 | `n (f - d) / ((f - n) d)` | `n / d` | `GREATER` | 0 |
//! | [`DepthConvention::Wgpu`] | 0 .. 1 | 0 .. 1 | `f (d - n) / ((f - n) d)` | `1 - n / d` | `LESS` | 1 |
//! | [`DepthConvention::WgpuReversed`] | 1 .. 0 | 1 .. 0 | `n (f - d) / ((f - n) d)` | `n / d` | `GREATER` | 0 |
//!
//! In exact arithmetic OpenGL's window depth (`(z_ndc + 1) / 2`) equals wgpu's NDC depth, and
//! reversing either gives the same window depth, so [`window_depth_gl`] and
//! [`window_depth_wgpu`] are the same function. What differs is what the GPU computes in `f32`
//! on the way: OpenGL's `[-1, 1]` range throws away the extra precision a float has near 0,
//! which is why a reversed depth buffer only helps with `[0, 1]` NDC (see
//! `docs/depth-mapping.md`).
//!
//! For an orthographic camera the depth is linear in `d` (`(d - n) / (f - n)` in window terms).

use crate::camera::Frustum;
use glam::{DMat4, DVec4};
use std::fmt;

/// Which NDC depth range and direction a depth buffer uses.
#[derive(Clone, Copy, Debug, PartialEq, Eq, Hash)]
pub enum DepthConvention {
    /// OpenGL: NDC depth in `[-1, 1]`, near at -1, window depth `(z + 1) / 2`.
    Gl,
    /// OpenGL with the near plane at NDC +1 (as `glDepthRange(1, 0)` would give).
    GlReversed,
    /// wgpu / Vulkan / Direct3D / Metal: NDC depth in `[0, 1]`, near at 0; window = NDC.
    Wgpu,
    /// Reversed-Z for wgpu: near at 1, far at 0 (with `Depth32Float` and `GREATER`).
    WgpuReversed,
}

impl DepthConvention {
    pub const ALL: [DepthConvention; 4] = [
        DepthConvention::Gl,
        DepthConvention::GlReversed,
        DepthConvention::Wgpu,
        DepthConvention::WgpuReversed,
    ];

    /// Whether NDC depth runs over `[-1, 1]` (OpenGL) rather than `[0, 1]`.
    pub fn is_gl(self) -> bool {
        matches!(self, DepthConvention::Gl | DepthConvention::GlReversed)
    }

    /// Whether the near plane maps to the larger depth value.
    pub fn is_reversed(self) -> bool {
        matches!(self, DepthConvention::GlReversed | DepthConvention::WgpuReversed)
    }

    /// The depth test that keeps the nearer fragment.
    pub fn compare(self) -> DepthCompare {
        if self.is_reversed() { DepthCompare::Greater } else { DepthCompare::Less }
    }

    /// The window depth of the far plane, of a miss and of the depth-buffer clear value.
    pub fn far_window_depth(self) -> f32 {
        if self.is_reversed() { 0.0 } else { 1.0 }
    }

    /// The window depth of the near plane.
    pub fn near_window_depth(self) -> f32 {
        if self.is_reversed() { 1.0 } else { 0.0 }
    }

    /// NDC depth of the far plane.
    pub fn far_ndc_depth(self) -> f32 {
        match self {
            DepthConvention::Gl => 1.0,
            DepthConvention::GlReversed => -1.0,
            DepthConvention::Wgpu => 1.0,
            DepthConvention::WgpuReversed => 0.0,
        }
    }

    /// NDC depth of the near plane.
    pub fn near_ndc_depth(self) -> f32 {
        match self {
            DepthConvention::Gl => -1.0,
            DepthConvention::GlReversed => 1.0,
            DepthConvention::Wgpu => 0.0,
            DepthConvention::WgpuReversed => 1.0,
        }
    }

    /// The viewport transform of depth with the default depth range: NDC to window depth.
    pub fn ndc_to_window(self, ndc: f64) -> f64 {
        if self.is_gl() { 0.5 * ndc + 0.5 } else { ndc }
    }

    /// Inverse of [`DepthConvention::ndc_to_window`].
    pub fn window_to_ndc(self, window: f64) -> f64 {
        if self.is_gl() { 2.0 * window - 1.0 } else { window }
    }

    pub fn name(self) -> &'static str {
        match self {
            DepthConvention::Gl => "gl",
            DepthConvention::GlReversed => "gl-reversed",
            DepthConvention::Wgpu => "wgpu",
            DepthConvention::WgpuReversed => "wgpu-reversed",
        }
    }
}

impl fmt::Display for DepthConvention {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        f.write_str(self.name())
    }
}

/// The depth comparison that keeps the nearer of two fragments.
#[derive(Clone, Copy, Debug, PartialEq, Eq, Hash)]
pub enum DepthCompare {
    Less,
    Greater,
}

/// Where the far clipping plane is.
#[derive(Clone, Copy, Debug, PartialEq)]
pub enum FarPlane {
    /// A far plane at this planar eye depth.
    Finite(f64),
    /// No far plane: the limit `f -> inf` of the perspective matrix (perspective only).
    Infinite,
}

/// Why a [`DepthMapping`] cannot be built.
#[derive(Clone, Debug, PartialEq)]
#[non_exhaustive]
pub enum MappingError {
    /// Near must be finite and positive (perspective) or finite (orthographic), and below far.
    BadPlanes { near: f64, far: FarPlane },
    /// An orthographic projection has no infinite-far limit.
    InfiniteOrthographic,
}

impl fmt::Display for MappingError {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        match self {
            MappingError::BadPlanes { near, far } => match far {
                FarPlane::Finite(far) => write!(f, "bad clipping planes: near {near}, far {far}"),
                FarPlane::Infinite => write!(f, "bad near plane {near} (infinite far)"),
            },
            MappingError::InfiniteOrthographic => {
                write!(f, "an orthographic camera needs a finite far plane")
            }
        }
    }
}

impl std::error::Error for MappingError {}

/// One complete depth mapping: a convention, near and far planes and the kind of projection.
///
/// It holds the depth row of the clip matrix, `z_clip = z_scale * z_eye + z_offset` (with
/// `w_clip = -z_eye` for perspective and 1 for orthographic), **rounded to `f32`**, because
/// that is what a GPU is given. [`DepthMapping::window_depth`] evaluates exactly those
/// coefficients in `f64`, so a pre-rendered pixel's depth is the real-number value of the very
/// matrix the live polygons are drawn with; the only difference left is the GPU's own `f32`
/// arithmetic.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct DepthMapping {
    convention: DepthConvention,
    near: f64,
    far: FarPlane,
    perspective: bool,
    z_scale: f64,
    z_offset: f64,
}

impl DepthMapping {
    /// A perspective depth mapping. `near` must be finite and positive and below a finite far.
    pub fn perspective(convention: DepthConvention, near: f64, far: FarPlane) -> Result<Self, MappingError> {
        let bad = || MappingError::BadPlanes { near, far };
        if !(near.is_finite() && near > 0.0) {
            return Err(bad());
        }
        let (z_scale, z_offset) = match far {
            FarPlane::Finite(f) => {
                if !(f.is_finite() && f > near) {
                    return Err(bad());
                }
                let n = near;
                let r = f - n;
                match convention {
                    DepthConvention::Gl => (-(f + n) / r, -2.0 * f * n / r),
                    DepthConvention::GlReversed => ((f + n) / r, 2.0 * f * n / r),
                    DepthConvention::Wgpu => (-f / r, -f * n / r),
                    DepthConvention::WgpuReversed => (n / r, n * f / r),
                }
            }
            FarPlane::Infinite => match convention {
                DepthConvention::Gl => (-1.0, -2.0 * near),
                DepthConvention::GlReversed => (1.0, 2.0 * near),
                DepthConvention::Wgpu => (-1.0, -near),
                DepthConvention::WgpuReversed => (0.0, near),
            },
        };
        Self::from_row(convention, near, far, true, z_scale, z_offset)
    }

    /// An orthographic depth mapping (linear in eye depth); `far` must be finite.
    pub fn orthographic(convention: DepthConvention, near: f64, far: FarPlane) -> Result<Self, MappingError> {
        let FarPlane::Finite(f) = far else {
            return Err(MappingError::InfiniteOrthographic);
        };
        if !(near.is_finite() && f.is_finite() && f > near) {
            return Err(MappingError::BadPlanes { near, far });
        }
        let n = near;
        let r = f - n;
        let (z_scale, z_offset) = match convention {
            DepthConvention::Gl => (-2.0 / r, -(f + n) / r),
            DepthConvention::GlReversed => (2.0 / r, (f + n) / r),
            DepthConvention::Wgpu => (-1.0 / r, -n / r),
            DepthConvention::WgpuReversed => (1.0 / r, f / r),
        };
        Self::from_row(convention, near, far, false, z_scale, z_offset)
    }

    fn from_row(
        convention: DepthConvention,
        near: f64,
        far: FarPlane,
        perspective: bool,
        z_scale: f64,
        z_offset: f64,
    ) -> Result<Self, MappingError> {
        // What the GPU gets: the coefficients as f32.
        let z_scale = f64::from(z_scale as f32);
        let z_offset = f64::from(z_offset as f32);
        if !(z_scale.is_finite() && z_offset.is_finite()) || (z_offset == 0.0 && perspective) {
            return Err(MappingError::BadPlanes { near, far });
        }
        Ok(DepthMapping { convention, near, far, perspective, z_scale, z_offset })
    }

    pub fn convention(&self) -> DepthConvention {
        self.convention
    }

    pub fn near(&self) -> f64 {
        self.near
    }

    pub fn far(&self) -> FarPlane {
        self.far
    }

    pub fn is_perspective(&self) -> bool {
        self.perspective
    }

    /// The depth row of the clip matrix as the GPU gets it: `(z_scale, z_offset)` with
    /// `z_clip = z_scale * z_eye + z_offset`. Both are exactly representable as `f32`.
    pub fn z_row(&self) -> (f64, f64) {
        (self.z_scale, self.z_offset)
    }

    /// NDC depth of a point at planar eye depth `eye_depth` (`-z_eye`), unclamped, in `f64`.
    #[inline]
    pub fn ndc_depth(&self, eye_depth: f64) -> f64 {
        // z_clip = z_offset - z_scale * d without cancellation error (it cancels at the zero of
        // NDC depth), then one division.
        let z_clip = (-self.z_scale).mul_add(eye_depth, self.z_offset);
        if self.perspective { z_clip / eye_depth } else { z_clip }
    }

    /// Window depth (what the depth buffer stores, before quantisation) of a point at planar
    /// eye depth `eye_depth`, unclamped, in `f64`.
    #[inline]
    pub fn window_depth(&self, eye_depth: f64) -> f64 {
        self.convention.ndc_to_window(self.ndc_depth(eye_depth))
    }

    /// The same projection applied to RenderMan's left-handed camera space (`+z` forward):
    /// `projection(frustum) * diag(1, 1, -1, 1)`, so `clip_from_camera * camera_from_world`
    /// equals `projection * Camera::eye_from_world`.
    pub fn clip_from_camera(&self, frustum: &Frustum) -> DMat4 {
        self.projection(frustum) * DMat4::from_scale(glam::DVec3::new(1.0, 1.0, -1.0))
    }

    /// The projection matrix (right-handed eye space to clip space) for `frustum` with this
    /// depth mapping. Its depth row is [`DepthMapping::z_row`]. Round it with `as_mat4()`.
    pub fn projection(&self, frustum: &Frustum) -> DMat4 {
        let (l, r, b, t) = (frustum.left, frustum.right, frustum.bottom, frustum.top);
        let rows = if self.perspective {
            [
                [2.0 / (r - l), 0.0, (r + l) / (r - l), 0.0],
                [0.0, 2.0 / (t - b), (t + b) / (t - b), 0.0],
                [0.0, 0.0, self.z_scale, self.z_offset],
                [0.0, 0.0, -1.0, 0.0],
            ]
        } else {
            [
                [2.0 / (r - l), 0.0, 0.0, -(r + l) / (r - l)],
                [0.0, 2.0 / (t - b), 0.0, -(t + b) / (t - b)],
                [0.0, 0.0, self.z_scale, self.z_offset],
                [0.0, 0.0, 0.0, 1.0],
            ]
        };
        from_rows(rows)
    }
}

/// Builds a matrix from rows as printed (glam stores columns).
pub(crate) fn from_rows(rows: [[f64; 4]; 4]) -> DMat4 {
    DMat4::from_cols(
        DVec4::new(rows[0][0], rows[1][0], rows[2][0], rows[3][0]),
        DVec4::new(rows[0][1], rows[1][1], rows[2][1], rows[3][1]),
        DVec4::new(rows[0][2], rows[1][2], rows[2][2], rows[3][2]),
        DVec4::new(rows[0][3], rows[1][3], rows[2][3], rows[3][3]),
    )
}

// ---------------------------------------------------------------------------------------------
// Named window-depth functions (real-number formulas evaluated in f64 without cancellation).

/// OpenGL window depth (`glDepthRange(0, 1)`) of planar eye depth `d`: `f (d - n) / ((f - n) d)`.
/// Equal to [`window_depth_wgpu`] in exact arithmetic.
pub fn window_depth_gl(d: f64, near: f64, far: f64) -> f64 {
    far / (far - near) * ((d - near) / d)
}

/// OpenGL NDC depth (`[-1, 1]`): `((f + n) d - 2 f n) / ((f - n) d)`.
pub fn ndc_depth_gl(d: f64, near: f64, far: f64) -> f64 {
    // (f (d - n) + n (d - f)) / ((f - n) d): both products are exact-ish and the sum is the
    // only cancellation, at the NDC zero crossing, where f32 has the finest resolution anyway.
    (far * (d - near) + near * (d - far)) / ((far - near) * d)
}

/// wgpu window (= NDC) depth, `[0, 1]`, near at 0: `f (d - n) / ((f - n) d)`.
pub fn window_depth_wgpu(d: f64, near: f64, far: f64) -> f64 {
    far / (far - near) * ((d - near) / d)
}

/// Reversed-Z window depth, near at 1, far at 0: `n (f - d) / ((f - n) d)`. This is the window
/// depth of both [`DepthConvention::WgpuReversed`] and [`DepthConvention::GlReversed`].
pub fn window_depth_reversed(d: f64, near: f64, far: f64) -> f64 {
    near / (far - near) * ((far - d) / d)
}

/// OpenGL NDC depth with the near plane at +1: the negation of [`ndc_depth_gl`].
pub fn ndc_depth_reversed_gl(d: f64, near: f64, far: f64) -> f64 {
    -ndc_depth_gl(d, near, far)
}

/// OpenGL window depth with an infinite far plane: `1 - n / d`.
pub fn window_depth_infinite_gl(d: f64, near: f64) -> f64 {
    (d - near) / d
}

/// OpenGL NDC depth with an infinite far plane: `1 - 2 n / d`.
pub fn ndc_depth_infinite_gl(d: f64, near: f64) -> f64 {
    (d - 2.0 * near) / d
}

/// wgpu window depth with an infinite far plane: `1 - n / d`.
pub fn window_depth_infinite_wgpu(d: f64, near: f64) -> f64 {
    (d - near) / d
}

/// Reversed-Z window depth with an infinite far plane: `n / d`. One division: the best-
/// conditioned of all mappings (relative error 1/2 ulp whatever the distance).
pub fn window_depth_infinite_reversed(d: f64, near: f64) -> f64 {
    near / d
}

// ---------------------------------------------------------------------------------------------
// Named projection matrices (glam-style names, real-number coefficients in f64).

impl Frustum {
    fn perspective_xy_rows(&self) -> [[f64; 4]; 2] {
        let (l, r, b, t) = (self.left, self.right, self.bottom, self.top);
        [[2.0 / (r - l), 0.0, (r + l) / (r - l), 0.0], [0.0, 2.0 / (t - b), (t + b) / (t - b), 0.0]]
    }

    fn perspective_with_z_row(&self, z_scale: f64, z_offset: f64) -> DMat4 {
        let [x, y] = self.perspective_xy_rows();
        from_rows([x, y, [0.0, 0.0, z_scale, z_offset], [0.0, 0.0, -1.0, 0.0]])
    }

    /// `glFrustum`: right-handed eye space to OpenGL clip space, NDC depth `[-1, 1]`.
    pub fn perspective_rh_gl(&self, near: f64, far: f64) -> DMat4 {
        self.perspective_with_z_row(-(far + near) / (far - near), -2.0 * far * near / (far - near))
    }

    /// OpenGL clip space with the near plane at NDC +1.
    pub fn perspective_reversed_rh_gl(&self, near: f64, far: f64) -> DMat4 {
        self.perspective_with_z_row((far + near) / (far - near), 2.0 * far * near / (far - near))
    }

    /// wgpu clip space, NDC depth `[0, 1]` (glam's `perspective_rh`, off-centre).
    pub fn perspective_rh_wgpu(&self, near: f64, far: f64) -> DMat4 {
        self.perspective_with_z_row(-far / (far - near), -far * near / (far - near))
    }

    /// wgpu clip space, reversed: near at NDC 1, far at 0.
    pub fn perspective_reversed_rh_wgpu(&self, near: f64, far: f64) -> DMat4 {
        self.perspective_with_z_row(near / (far - near), near * far / (far - near))
    }

    /// OpenGL clip space, infinite far plane.
    pub fn perspective_infinite_rh_gl(&self, near: f64) -> DMat4 {
        self.perspective_with_z_row(-1.0, -2.0 * near)
    }

    /// OpenGL clip space, near at NDC +1, infinite far plane.
    pub fn perspective_infinite_reversed_rh_gl(&self, near: f64) -> DMat4 {
        self.perspective_with_z_row(1.0, 2.0 * near)
    }

    /// wgpu clip space, infinite far plane (glam's `perspective_infinite_rh`, off-centre).
    pub fn perspective_infinite_rh_wgpu(&self, near: f64) -> DMat4 {
        self.perspective_with_z_row(-1.0, -near)
    }

    /// wgpu clip space, reversed, infinite far plane (glam's `perspective_infinite_reverse_rh`,
    /// off-centre): `z_clip = near`, `w_clip = -z_eye`. The viewer's default.
    pub fn perspective_infinite_reversed_rh_wgpu(&self, near: f64) -> DMat4 {
        self.perspective_with_z_row(0.0, near)
    }
}

/// The matrix that draws the pre-rendered pixels as points, passing their depth through.
///
/// Input vertex: `(x, y, z, 1)` with `(x, y)` the raster position of the pixel centre
/// (`i + 0.5`, `j + 0.5`; origin top-left, y down) and `z` the pixel's **NDC** depth for the
/// chosen convention ([`DepthMapping::ndc_depth`]; equal to the window depth for wgpu). Output:
/// NDC `x = 2x/W - 1`, `y = 1 - 2y/H`, `z` unchanged, `w = 1`. The depth row is `[0 0 1 0]`;
/// this is the paper's modified `gluOrtho2D` with its printed `[0 0 1 1]` corrected (see
/// `docs/depth-mapping.md`). After the viewport transform the pixel centre lands exactly on
/// the framebuffer pixel centre in both OpenGL (window y up) and wgpu (framebuffer y down).
pub fn point_cloud_matrix(width: u32, height: u32) -> DMat4 {
    let (w, h) = (f64::from(width), f64::from(height));
    from_rows([
        [2.0 / w, 0.0, 0.0, -1.0],
        [0.0, -2.0 / h, 0.0, 1.0],
        [0.0, 0.0, 1.0, 0.0],
        [0.0, 0.0, 0.0, 1.0],
    ])
}
