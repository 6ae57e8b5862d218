//! The viewer's projection: the RIB camera's clip-from-camera matrix in wgpu's clip space, the
//! depth convention of the depth buffer, and the per-pixel conversion of the depth table.
//!
//! PROVISIONAL: the depth arithmetic here (`clip_from_camera`, `window_depth`,
//! `DepthRange::from_radial_depths`) belongs to `depth_remap`, which is adding the same
//! functions (view/projection matrices for wgpu conventions incl. reversed-Z, radial to window
//! depth, near/far from the data). Replace these with `depth_remap`'s as soon as they land; the
//! viewer's tests then check the two agree bit for bit.
//!
//! Conventions (wgpu clip space): `x_ndc, y_ndc` in `[-1, 1]` with `+y` up, window depth
//! `z_ndc` in `[0, 1]`. Camera space is RenderMan's (left-handed, `+z` forward).
//!
//! | convention | window depth of eye depth `z` | near -> far | compare (nearer wins) | clear |
//! |---|---|---|---|---|
//! | [`DepthConvention::Reversed`] | `n (f - z) / (z (f - n))`, `n / z` for `f = inf` | 1 -> 0 | `Greater` | 0 |
//! | [`DepthConvention::Standard`] | `f (z - n) / (z (f - n))` | 0 -> 1 | `Less` | 1 |
//!
//! Orthographic cameras use the linear versions (`(f - z) / (f - n)`, `(z - n) / (f - n)`).

use depth_remap::Camera;
use glam::{DMat4, DVec4};

/// Which way the depth buffer runs.
#[derive(Clone, Copy, Debug, PartialEq, Eq, Hash)]
pub enum DepthConvention {
    /// Reversed-Z: the near plane maps to 1 and the far plane (or infinity) to 0. With a float
    /// depth buffer this spends the float exponent range where perspective compresses depth,
    /// giving nearly constant relative precision in eye depth.
    Reversed,
    /// wgpu's conventional `[0, 1]`: near maps to 0 and far to 1.
    Standard,
}

impl DepthConvention {
    /// The window depth of a point at infinity or with no surface (the far end of the range).
    pub fn far_value(self) -> f32 {
        match self {
            DepthConvention::Reversed => 0.0,
            DepthConvention::Standard => 1.0,
        }
    }

    /// The comparison under which a nearer fragment passes.
    pub fn nearer(self) -> wgpu::CompareFunction {
        match self {
            DepthConvention::Reversed => wgpu::CompareFunction::Greater,
            DepthConvention::Standard => wgpu::CompareFunction::Less,
        }
    }
}

/// Near and far planes (camera-space z) of the live projection. `far = None` is an infinite far
/// plane (only meaningful with [`DepthConvention::Reversed`] and a perspective camera).
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct DepthRange {
    pub near: f64,
    pub far: Option<f64>,
}

impl DepthRange {
    /// Near/far from the data (PROVISIONAL, to be replaced by `depth_remap`'s): the near plane
    /// sits at 1/64 of the nearest surface's eye depth, so a live object can come well in front
    /// of every pre-rendered surface before it is clipped; with reversed-Z the near plane's
    /// position barely changes precision, so this costs nothing. The far plane is infinite for
    /// reversed-Z and twice the farthest surface otherwise. A table with no finite depth falls
    /// back to the camera's `Clipping`.
    pub fn from_radial_depths(camera: &Camera, radial: &[f32], convention: DepthConvention) -> DepthRange {
        let (w, h) = camera.resolution();
        let mut z_min = f64::INFINITY;
        let mut z_max = 0.0f64;
        for j in 0..h {
            for i in 0..w {
                let r = radial[(j * w + i) as usize];
                if r.is_finite() && r > 0.0 {
                    let z = camera.radial_to_eye_depth(i, j, f64::from(r));
                    z_min = z_min.min(z);
                    z_max = z_max.max(z);
                }
            }
        }
        let clipping = camera.settings().clipping;
        if !z_min.is_finite() || z_min <= 0.0 {
            let far = match convention {
                DepthConvention::Reversed if camera.tan_half_fov().is_some() => None,
                _ => Some(clipping.far.min(1e30)),
            };
            return DepthRange { near: clipping.near.max(1e-6), far };
        }
        let near = z_min / 64.0;
        let far = match convention {
            DepthConvention::Reversed if camera.tan_half_fov().is_some() => None,
            _ => Some(z_max * 2.0),
        };
        DepthRange { near, far }
    }
}

/// The live projection: everything needed to map camera space to wgpu clip space and window
/// depth, for one camera, range and convention.
#[derive(Clone, Debug, PartialEq)]
pub struct Projection {
    camera: Camera,
    range: DepthRange,
    convention: DepthConvention,
}

impl Projection {
    pub fn new(camera: Camera, range: DepthRange, convention: DepthConvention) -> Projection {
        Projection { camera, range, convention }
    }

    pub fn camera(&self) -> &Camera {
        &self.camera
    }

    pub fn range(&self) -> DepthRange {
        self.range
    }

    pub fn convention(&self) -> DepthConvention {
        self.convention
    }

    /// Clip-from-camera (PROVISIONAL, `depth_remap` will own it): `x, y` through the RIB's screen
    /// window (fov across the shorter axis), `z` by the depth convention, `w = z` for a
    /// perspective camera. The raster positions of a camera-space point agree with
    /// `Camera::ray_through_raster`.
    pub fn clip_from_camera(&self) -> DMat4 {
        let sw = self.camera.screen_window();
        let sx = 2.0 / (sw.right - sw.left);
        let sy = 2.0 / (sw.top - sw.bottom);
        let ox = -(sw.right + sw.left) / (sw.right - sw.left);
        let oy = -(sw.top + sw.bottom) / (sw.top - sw.bottom);
        let n = self.range.near;
        match self.camera.tan_half_fov() {
            Some(t) => {
                // x_clip = sx * x / t + ox * z, w = z, so x_ndc = sx * (x / (z t)) + ox.
                let (a, b) = match (self.convention, self.range.far) {
                    (DepthConvention::Reversed, None) => (0.0, n),
                    (DepthConvention::Reversed, Some(f)) => (-n / (f - n), n * f / (f - n)),
                    (DepthConvention::Standard, Some(f)) => (f / (f - n), -n * f / (f - n)),
                    // An infinite far plane with standard depth: the limit f -> inf.
                    (DepthConvention::Standard, None) => (1.0, -n),
                };
                DMat4::from_cols(
                    DVec4::new(sx / t, 0.0, 0.0, 0.0),
                    DVec4::new(0.0, sy / t, 0.0, 0.0),
                    DVec4::new(ox, oy, a, 1.0),
                    DVec4::new(0.0, 0.0, b, 0.0),
                )
            }
            None => {
                let f = self.range.far.unwrap_or(n + 1e30);
                let (a, b) = match self.convention {
                    DepthConvention::Reversed => (-1.0 / (f - n), f / (f - n)),
                    DepthConvention::Standard => (1.0 / (f - n), -n / (f - n)),
                };
                DMat4::from_cols(
                    DVec4::new(sx, 0.0, 0.0, 0.0),
                    DVec4::new(0.0, sy, 0.0, 0.0),
                    DVec4::new(0.0, 0.0, a, 0.0),
                    DVec4::new(ox, oy, b, 1.0),
                )
            }
        }
    }

    /// Window depth of a point at eye depth `z` (PROVISIONAL, `depth_remap` will own it),
    /// computed in `f64` and rounded once; clamped to `[0, 1]` so points outside the range land
    /// on its ends instead of being lost.
    pub fn window_depth_of_eye_depth(&self, z: f64) -> f32 {
        if !z.is_finite() {
            return self.convention.far_value();
        }
        let m = self.clip_from_camera();
        let clip = m * DVec4::new(0.0, 0.0, z, 1.0);
        let d = clip.z / clip.w;
        if d.is_nan() { self.convention.far_value() } else { d.clamp(0.0, 1.0) as f32 }
    }

    /// Window depth of the depth-table value `radial` of pixel `(i, j)`: the eye depth along
    /// the pixel-centre ray (`Camera::radial_to_eye_depth`, the one camera model) mapped by the
    /// convention. A miss (`inf`) maps to the far end.
    pub fn window_depth(&self, i: u32, j: u32, radial: f32) -> f32 {
        if !radial.is_finite() {
            return self.convention.far_value();
        }
        self.window_depth_of_eye_depth(self.camera.radial_to_eye_depth(i, j, f64::from(radial)))
    }

    /// Window depths of a whole table, row-major, top row first.
    pub fn window_depths(&self, radial: &[f32]) -> Vec<f32> {
        let (w, _) = self.camera.resolution();
        radial.iter().enumerate().map(|(k, &r)| self.window_depth(k as u32 % w, k as u32 / w, r)).collect()
    }

    /// The paper's point-cloud matrix in wgpu form: `gluOrtho2D` over raster space (origin
    /// top-left, `y` down, one unit per pixel) with the `z` row replaced so that `z` passes
    /// through untouched. The paper's printed row `(0 0 1 1)` adds `w` to `z` (fine for its
    /// pre-shifted GL values); passing `z` through exactly (`(0 0 1 0)`) keeps the window depth
    /// bit-identical to the table's converted value, which the full-screen path writes directly.
    pub fn clip_from_raster(&self) -> DMat4 {
        let (w, h) = self.camera.resolution();
        let (w, h) = (f64::from(w), f64::from(h));
        DMat4::from_cols(
            DVec4::new(2.0 / w, 0.0, 0.0, 0.0),
            DVec4::new(0.0, -2.0 / h, 0.0, 0.0),
            DVec4::new(0.0, 0.0, 1.0, 0.0),
            DVec4::new(-1.0, 1.0, 0.0, 1.0),
        )
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use depth_remap::{CameraSettings, Projection as RibProjection};
    use glam::{DVec2, DVec3};

    fn camera(w: u32, h: u32, fov: f64) -> Camera {
        Camera::new(CameraSettings {
            x_resolution: w,
            y_resolution: h,
            projection: RibProjection::Perspective { fov_degrees: fov },
            ..CameraSettings::default()
        })
        .unwrap()
    }

    /// A camera-space point on the ray through a raster position projects back onto that raster
    /// position: the live projection and the depth table's rays agree.
    #[test]
    fn projection_matches_the_camera_rays() {
        for (w, h) in [(64, 48), (48, 64), (50, 50)] {
            let cam = camera(w, h, 39.3);
            let p =
                Projection::new(cam.clone(), DepthRange { near: 0.01, far: None }, DepthConvention::Reversed);
            let m = p.clip_from_camera();
            for raster in [DVec2::new(0.5, 0.5), DVec2::new(17.25, 3.5), DVec2::new(f64::from(w) - 0.5, 9.0)]
            {
                let ray = cam.ray_through_raster(raster);
                let point = ray.origin + ray.direction * 3.7;
                let clip = m * point.extend(1.0);
                let ndc = DVec3::new(clip.x / clip.w, clip.y / clip.w, clip.z / clip.w);
                let back = DVec2::new((ndc.x + 1.0) * 0.5 * f64::from(w), (1.0 - ndc.y) * 0.5 * f64::from(h));
                assert!((back - raster).length() < 1e-9, "{raster} -> {back}");
            }
        }
    }

    #[test]
    fn conventions_map_near_and_far_to_their_ends() {
        let cam = camera(32, 32, 60.0);
        let r = Projection::new(
            cam.clone(),
            DepthRange { near: 0.5, far: Some(100.0) },
            DepthConvention::Reversed,
        );
        assert_eq!(r.window_depth_of_eye_depth(0.5), 1.0);
        assert_eq!(r.window_depth_of_eye_depth(100.0), 0.0);
        let s = Projection::new(
            cam.clone(),
            DepthRange { near: 0.5, far: Some(100.0) },
            DepthConvention::Standard,
        );
        assert_eq!(s.window_depth_of_eye_depth(0.5), 0.0);
        assert_eq!(s.window_depth_of_eye_depth(100.0), 1.0);
        let inf = Projection::new(cam, DepthRange { near: 0.5, far: None }, DepthConvention::Reversed);
        assert_eq!(inf.window_depth_of_eye_depth(1.0), 0.5);
        assert_eq!(inf.window_depth(0, 0, f32::INFINITY), 0.0);
    }

    #[test]
    fn raster_matrix_maps_pixel_centres_and_passes_depth_through() {
        let p = Projection::new(
            camera(8, 4, 45.0),
            DepthRange { near: 0.1, far: None },
            DepthConvention::Reversed,
        );
        let m = p.clip_from_raster();
        let c = m * DVec4::new(0.5, 0.5, 0.123, 1.0);
        assert_eq!((c.x, c.y, c.z, c.w), (-0.875, 0.75, 0.123, 1.0));
    }
}
