//! The RenderMan camera: image resolution, screen window, projection and the ray through a
//! raster position.
//!
//! Conventions (CONTRACTS.md §3, RISpec 3.2 §4.1.1):
//! - Camera space is left-handed: +x right, +y up, +z forward into the screen. The eye point is
//!   the camera-space origin.
//! - `Projection "perspective" "fov" [a]`: `a` is the full angle across the **shorter** axis of
//!   the default screen window, so screen coordinates are `(x / (z tan(a/2)), y / (z tan(a/2)))`.
//! - Default screen window: `[-r, r] x [-1, 1]` for frame aspect `r >= 1`, else
//!   `[-1, 1] x [-1/r, 1/r]`.
//! - Raster space has its origin at the top-left corner of the image, x right, y **down**, one
//!   unit per pixel; the centre of pixel `(i, j)` is raster `(i + 0.5, j + 0.5)`.
//!
//! All camera arithmetic is done in `f64`; consumers round once, at the end.

use glam::{DMat3, DMat4, DVec2, DVec3, DVec4};
use std::fmt;

/// The projection named by `Projection`.
#[derive(Clone, Copy, Debug, PartialEq)]
pub enum Projection {
    /// `Projection "perspective" "fov" [fov_degrees]` (RenderMan's default fov is 90 degrees).
    Perspective { fov_degrees: f64 },
    /// `Projection "orthographic"`: screen coordinates are camera-space x and y.
    Orthographic,
}

impl Default for Projection {
    /// RenderMan's default projection is orthographic.
    fn default() -> Self {
        Projection::Orthographic
    }
}

/// `ScreenWindow left right bottom top`, in screen coordinates.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct ScreenWindow {
    pub left: f64,
    pub right: f64,
    pub bottom: f64,
    pub top: f64,
}

/// `CropWindow xmin xmax ymin ymax`, in NDC (0 at the left/top edge, 1 at the right/bottom).
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct CropWindow {
    pub xmin: f64,
    pub xmax: f64,
    pub ymin: f64,
    pub ymax: f64,
}

impl Default for CropWindow {
    fn default() -> Self {
        CropWindow { xmin: 0.0, xmax: 1.0, ymin: 0.0, ymax: 1.0 }
    }
}

impl CropWindow {
    /// RenderMan's rule for a crop window: every edge finite and in `[0, 1]`, `min < max` on
    /// both axes.
    pub fn is_valid(&self) -> bool {
        [self.xmin, self.xmax, self.ymin, self.ymax].iter().all(|v| v.is_finite() && (0.0..=1.0).contains(v))
            && self.xmin < self.xmax
            && self.ymin < self.ymax
    }
}

/// `Clipping near far`: camera-space z of the clipping planes.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct Clipping {
    pub near: f64,
    pub far: f64,
}

impl Default for Clipping {
    /// RenderMan's defaults: `RI_EPSILON` and `RI_INFINITY`.
    fn default() -> Self {
        Clipping { near: 1e-10, far: 1e38 }
    }
}

/// Everything the RIB says about the camera, as given (before defaults that depend on other
/// options are resolved). `rib-parser` fills this in; [`Camera::new`] checks and resolves it.
#[derive(Clone, Debug, PartialEq)]
pub struct CameraSettings {
    /// `Format` x resolution in pixels.
    pub x_resolution: u32,
    /// `Format` y resolution in pixels.
    pub y_resolution: u32,
    /// `Format` pixel aspect ratio (width / height of one pixel).
    pub pixel_aspect_ratio: f64,
    /// `FrameAspectRatio`, when given.
    pub frame_aspect_ratio: Option<f64>,
    /// `ScreenWindow`, when given.
    pub screen_window: Option<ScreenWindow>,
    pub projection: Projection,
    pub clipping: Clipping,
    pub crop_window: CropWindow,
    /// The current transformation at `WorldBegin`: maps world space to (left-handed) camera space.
    pub camera_from_world: DMat4,
}

impl Default for CameraSettings {
    /// RenderMan's defaults: `Format 640 480 1`, orthographic, identity camera transform.
    fn default() -> Self {
        CameraSettings {
            x_resolution: 640,
            y_resolution: 480,
            pixel_aspect_ratio: 1.0,
            frame_aspect_ratio: None,
            screen_window: None,
            projection: Projection::default(),
            clipping: Clipping::default(),
            crop_window: CropWindow::default(),
            camera_from_world: DMat4::IDENTITY,
        }
    }
}

/// Why a [`CameraSettings`] cannot make a camera.
#[derive(Clone, Debug, PartialEq)]
#[non_exhaustive]
pub enum CameraError {
    /// Zero width or height.
    EmptyImage { x_resolution: u32, y_resolution: u32 },
    /// A value that must be finite and positive is not.
    BadValue { what: &'static str, value: f64 },
    /// A screen window with zero or non-finite extent.
    BadScreenWindow(ScreenWindow),
    /// The camera transform cannot be inverted or is not finite.
    SingularTransform,
}

impl fmt::Display for CameraError {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        match self {
            CameraError::EmptyImage { x_resolution, y_resolution } => {
                write!(f, "image size {x_resolution}x{y_resolution} has no pixels")
            }
            CameraError::BadValue { what, value } => {
                write!(f, "{what} must be finite and positive, got {value}")
            }
            CameraError::BadScreenWindow(w) => {
                write!(f, "screen window [{} {} {} {}] has no extent", w.left, w.right, w.bottom, w.top)
            }
            CameraError::SingularTransform => write!(f, "the camera transform is singular or not finite"),
        }
    }
}

impl std::error::Error for CameraError {}

/// A ray in camera space. `direction` has unit length in camera space.
///
/// When the camera transform has no scale (the usual case: rotations, translations and mirrors
/// such as `Scale 1 1 -1`) a distance along this ray is also a distance in world units; in
/// general use [`Camera::pixel_centre_world_ray`], whose direction has unit length in world
/// space, because the depth table holds world-space distances.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct CameraRay {
    pub origin: DVec3,
    pub direction: DVec3,
}

/// A ray in world space with a direction of unit length in world units: a hit at parameter `t`
/// is `t` scene units from `origin`, which is what a depth table stores (CONTRACTS.md §2).
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct WorldRay {
    pub origin: DVec3,
    pub direction: DVec3,
}

impl WorldRay {
    /// The point at distance `t` along the ray.
    pub fn at(&self, t: f64) -> DVec3 {
        self.origin + self.direction * t
    }
}

/// The viewing volume of a camera in camera space, as the eye-space projection matrices need it.
///
/// For a perspective camera the four values are slopes: the left edge of the image is the
/// plane `x = left * z` (camera space, `z` forward), and so on; they are the screen window
/// scaled by `tan(fov / 2)`. For an orthographic camera they are camera-space extents (the
/// screen window itself). Raster y grows downward, so `top` is the edge of raster row 0.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct Frustum {
    pub left: f64,
    pub right: f64,
    pub bottom: f64,
    pub top: f64,
    /// Whether the camera is perspective (slopes) or orthographic (extents).
    pub perspective: bool,
}

/// A checked camera with every default resolved.
#[derive(Clone, Debug, PartialEq)]
pub struct Camera {
    settings: CameraSettings,
    frame_aspect_ratio: f64,
    screen_window: ScreenWindow,
    /// `tan(fov / 2)` for a perspective camera, `None` for an orthographic one.
    tan_half_fov: Option<f64>,
    world_from_camera: DMat4,
    /// The Gram matrix `Lᵀ L` of the linear part `L` of `world_from_camera`: the squared world
    /// length of a camera-space vector `v` is `vᵀ G v`. It is the identity for a rigid camera.
    world_gram: DMat3,
}

impl Camera {
    /// Checks `settings` and resolves the frame aspect ratio and screen window defaults.
    pub fn new(settings: CameraSettings) -> Result<Camera, CameraError> {
        let (w, h) = (settings.x_resolution, settings.y_resolution);
        if w == 0 || h == 0 {
            return Err(CameraError::EmptyImage { x_resolution: w, y_resolution: h });
        }
        let positive = |what, value: f64| {
            if value.is_finite() && value > 0.0 {
                Ok(value)
            } else {
                Err(CameraError::BadValue { what, value })
            }
        };
        let pixel_aspect = positive("pixel aspect ratio", settings.pixel_aspect_ratio)?;
        let frame_aspect_ratio = match settings.frame_aspect_ratio {
            Some(r) => positive("frame aspect ratio", r)?,
            None => f64::from(w) * pixel_aspect / f64::from(h),
        };
        let screen_window = match settings.screen_window {
            Some(sw) => {
                let ok = [sw.left, sw.right, sw.bottom, sw.top].iter().all(|v| v.is_finite())
                    && sw.left != sw.right
                    && sw.bottom != sw.top;
                if !ok {
                    return Err(CameraError::BadScreenWindow(sw));
                }
                sw
            }
            None if frame_aspect_ratio >= 1.0 => {
                ScreenWindow { left: -frame_aspect_ratio, right: frame_aspect_ratio, bottom: -1.0, top: 1.0 }
            }
            None => ScreenWindow {
                left: -1.0,
                right: 1.0,
                bottom: -1.0 / frame_aspect_ratio,
                top: 1.0 / frame_aspect_ratio,
            },
        };
        let tan_half_fov = match settings.projection {
            Projection::Perspective { fov_degrees } => {
                if !(fov_degrees.is_finite() && fov_degrees > 0.0 && fov_degrees < 180.0) {
                    return Err(CameraError::BadValue {
                        what: "perspective fov (degrees, below 180)",
                        value: fov_degrees,
                    });
                }
                Some((fov_degrees.to_radians() * 0.5).tan())
            }
            Projection::Orthographic => None,
        };
        let c = settings.camera_from_world;
        if !c.is_finite() || c.determinant() == 0.0 {
            return Err(CameraError::SingularTransform);
        }
        // A camera transform must be affine: a projective bottom row would make "distance along
        // the ray" meaningless.
        if c.row(3) != DVec4::new(0.0, 0.0, 0.0, 1.0) {
            return Err(CameraError::SingularTransform);
        }
        let world_from_camera = c.inverse();
        if !world_from_camera.is_finite() {
            return Err(CameraError::SingularTransform);
        }
        let linear = DMat3::from_mat4(world_from_camera);
        let world_gram = linear.transpose() * linear;
        Ok(Camera {
            settings,
            frame_aspect_ratio,
            screen_window,
            tan_half_fov,
            world_from_camera,
            world_gram,
        })
    }

    /// The settings this camera was made from.
    pub fn settings(&self) -> &CameraSettings {
        &self.settings
    }

    /// Full image size in pixels (the crop window does not change raster coordinates).
    pub fn resolution(&self) -> (u32, u32) {
        (self.settings.x_resolution, self.settings.y_resolution)
    }

    pub fn frame_aspect_ratio(&self) -> f64 {
        self.frame_aspect_ratio
    }

    /// The screen window with RenderMan's defaults resolved.
    pub fn screen_window(&self) -> ScreenWindow {
        self.screen_window
    }

    /// `tan(fov / 2)` of a perspective camera.
    pub fn tan_half_fov(&self) -> Option<f64> {
        self.tan_half_fov
    }

    /// Whether the projection is perspective (as opposed to orthographic).
    pub fn is_perspective(&self) -> bool {
        self.tan_half_fov.is_some()
    }

    /// `Clipping near far` as given (camera-space z of the clipping planes).
    pub fn clipping(&self) -> Clipping {
        self.settings.clipping
    }

    pub fn camera_from_world(&self) -> DMat4 {
        self.settings.camera_from_world
    }

    pub fn world_from_camera(&self) -> DMat4 {
        self.world_from_camera
    }

    /// The eye point (the camera-space origin) in world space.
    pub fn eye_position(&self) -> DVec3 {
        self.world_from_camera.w_axis.truncate()
    }

    /// The view matrix: world space to the right-handed eye space of OpenGL and wgpu (x right,
    /// y up, looking down `-z`). RenderMan's camera space is left-handed with `+z` forward, so
    /// this is `camera_from_world` followed by a flip of z. Eye-space `-z` equals camera-space
    /// `z`: the planar eye depth of a point is `-z_eye`.
    pub fn eye_from_world(&self) -> DMat4 {
        DMat4::from_scale(DVec3::new(1.0, 1.0, -1.0)) * self.settings.camera_from_world
    }

    /// The pixels the crop window selects: `[x0, x1) x [y0, y1)` in full-image pixel indices,
    /// with pbrt's rounding (`ceil(res * edge)`) so that abutting crop windows tile the image.
    pub fn crop_pixel_bounds(&self) -> (u32, u32, u32, u32) {
        let (w, h) = self.resolution();
        let cw = self.settings.crop_window;
        let edge = |res: u32, t: f64| ((f64::from(res) * t.clamp(0.0, 1.0)).ceil() as u32).min(res);
        (edge(w, cw.xmin), edge(w, cw.xmax), edge(h, cw.ymin), edge(h, cw.ymax))
    }

    /// Raster position (origin top-left, y down, pixel units) to screen position.
    #[inline]
    pub fn raster_to_screen(&self, raster: DVec2) -> DVec2 {
        let (w, h) = self.resolution();
        let sw = self.screen_window;
        let ndc_x = raster.x / f64::from(w);
        let ndc_y = raster.y / f64::from(h);
        DVec2::new(sw.left + ndc_x * (sw.right - sw.left), sw.top - ndc_y * (sw.top - sw.bottom))
    }

    /// Screen position to raster position: the inverse of [`Camera::raster_to_screen`].
    pub fn screen_to_raster(&self, screen: DVec2) -> DVec2 {
        let (w, h) = self.resolution();
        let sw = self.screen_window;
        DVec2::new(
            (screen.x - sw.left) / (sw.right - sw.left) * f64::from(w),
            (sw.top - screen.y) / (sw.top - sw.bottom) * f64::from(h),
        )
    }

    /// For a perspective camera, the camera-space point at `z = 1` on the ray through a screen
    /// position; for an orthographic camera the ray direction `(0, 0, 1)`. Every depth
    /// conversion below is written in terms of this vector, so they all agree with
    /// [`Camera::ray_through_raster`].
    fn unit_depth_direction(&self, screen: DVec2) -> DVec3 {
        match self.tan_half_fov {
            Some(t) => DVec3::new(screen.x * t, screen.y * t, 1.0),
            None => DVec3::Z,
        }
    }

    /// The camera-space ray through a raster position. For a perspective camera it starts at
    /// the eye point and points through the screen position `s` at `(s.x tan(fov/2),
    /// s.y tan(fov/2), 1)`, normalised; for an orthographic camera it starts at `(s.x, s.y, 0)`
    /// and points along `+z`.
    pub fn ray_through_raster(&self, raster: DVec2) -> CameraRay {
        let s = self.raster_to_screen(raster);
        let direction = self.unit_depth_direction(s).normalize();
        let origin = if self.is_perspective() { DVec3::ZERO } else { DVec3::new(s.x, s.y, 0.0) };
        CameraRay { origin, direction }
    }

    /// *The* ray through the centre of pixel `(i, j)` (column `i` from the left, row `j` from
    /// the top): raster position `(i + 0.5, j + 0.5)`, in camera space.
    ///
    /// This is the single definition the ray tracer and the depth conversion share. It is
    /// evaluated in `f64` (a few `f64` ulps from the real-number ray); a consumer that works in
    /// `f32` rounds origin and direction once. Prefer [`Camera::pixel_centre_world_ray`] for
    /// tracing: its parameter is a world-space distance even when the camera transform scales.
    pub fn pixel_centre_ray(&self, i: u32, j: u32) -> CameraRay {
        self.ray_through_raster(pixel_centre(i, j))
    }

    /// The ray through the centre of pixel `(i, j)` in world space, with a direction of unit
    /// world length: the depth table value of the pixel is the `t` of the nearest hit along it.
    ///
    /// The ray tracer shoots this ray. When it rounds the direction to `f32`, the rounded
    /// direction's length differs from 1 by up to about `2^-24`, so `t` along it differs from
    /// the distance by at most about one `f32` ulp; computing the depth as
    /// `(hit - origin).length()` in `f64` avoids even that.
    pub fn pixel_centre_world_ray(&self, i: u32, j: u32) -> WorldRay {
        self.world_ray_through_raster(pixel_centre(i, j))
    }

    /// The world-space ray through a raster position (see [`Camera::pixel_centre_world_ray`]).
    pub fn world_ray_through_raster(&self, raster: DVec2) -> WorldRay {
        let s = self.raster_to_screen(raster);
        let origin_camera = if self.is_perspective() { DVec3::ZERO } else { DVec3::new(s.x, s.y, 0.0) };
        WorldRay {
            origin: self.world_from_camera.transform_point3(origin_camera),
            direction: self.world_direction_at_screen(s),
        }
    }

    /// The direction of [`Camera::world_ray_through_raster`] at a screen position, unit length
    /// in world units. For a perspective camera, whose rays all start at
    /// [`Camera::eye_position`], this and the screen position are all a ray needs; a caller
    /// that also wants [`Camera::eye_depth_per_radial_at_screen`] converts the raster position
    /// once.
    #[inline]
    pub fn world_direction_at_screen(&self, screen: DVec2) -> DVec3 {
        self.world_from_camera.transform_vector3(self.unit_depth_direction(screen)).normalize()
    }

    /// The planar eye depth (camera-space z) per unit of radial world distance along the ray
    /// through screen position `(screen_x, screen_y)`: `1 / |L u|`, with `u` the camera-space
    /// point at `z = 1` on the ray and `L` the linear part of `world_from_camera`. For a rigid
    /// camera this is the cosine of the angle between the ray and the view axis.
    #[inline]
    pub fn eye_depth_per_radial_at_screen(&self, screen_x: f64, screen_y: f64) -> f64 {
        let u = self.unit_depth_direction(DVec2::new(screen_x, screen_y));
        let g = &self.world_gram;
        // uᵀ G u, written out so the per-pixel loop in `remap` evaluates exactly this.
        let x = u.x;
        let y = u.y;
        let z = u.z;
        let q = g.x_axis.x * x * x
            + g.y_axis.y * y * y
            + g.z_axis.z * z * z
            + 2.0 * (g.y_axis.x * x * y + g.z_axis.x * x * z + g.z_axis.y * y * z);
        1.0 / q.sqrt()
    }

    /// Planar eye depth per unit radial distance for pixel `(i, j)`; see
    /// [`Camera::eye_depth_per_radial_at_screen`].
    pub fn eye_depth_per_radial(&self, i: u32, j: u32) -> f64 {
        let s = self.raster_to_screen(pixel_centre(i, j));
        self.eye_depth_per_radial_at_screen(s.x, s.y)
    }

    /// Planar eye depth (camera-space z, the distance in front of the eye plane in camera
    /// units) of the point at `radial` world distance along the pixel-centre ray of pixel
    /// `(i, j)`. This is what a perspective depth buffer is a function of; using the radial
    /// distance instead is wrong by `1/cos` of the angle off the view axis (12% at the corner
    /// of a 40-degree square image). `inf` stays `inf`.
    pub fn radial_to_eye_depth(&self, i: u32, j: u32, radial: f64) -> f64 {
        radial * self.eye_depth_per_radial(i, j)
    }

    /// Inverse of [`Camera::radial_to_eye_depth`].
    pub fn eye_depth_to_radial(&self, i: u32, j: u32, eye_depth: f64) -> f64 {
        eye_depth / self.eye_depth_per_radial(i, j)
    }

    /// Projects a world-space point: its raster position and planar eye depth (camera-space
    /// z). `None` when the point is on or behind the eye plane of a perspective camera.
    pub fn world_to_raster(&self, world: DVec3) -> Option<(DVec2, f64)> {
        let p = self.settings.camera_from_world.transform_point3(world);
        let screen = match self.tan_half_fov {
            Some(t) => {
                if p.z <= 0.0 {
                    return None;
                }
                DVec2::new(p.x / (p.z * t), p.y / (p.z * t))
            }
            None => DVec2::new(p.x, p.y),
        };
        Some((self.screen_to_raster(screen), p.z))
    }

    /// The frustum of the whole image.
    pub fn frustum(&self) -> Frustum {
        let (w, h) = self.resolution();
        self.frustum_for_pixels(0, w, 0, h)
    }

    /// The frustum of the crop window's pixels: what a viewer showing a cropped render uses.
    pub fn crop_frustum(&self) -> Frustum {
        let (x0, x1, y0, y1) = self.crop_pixel_bounds();
        self.frustum_for_pixels(x0, x1, y0, y1)
    }

    /// The frustum of the pixel rectangle `[x0, x1) x [y0, y1)` (raster edges, not centres).
    pub fn frustum_for_pixels(&self, x0: u32, x1: u32, y0: u32, y1: u32) -> Frustum {
        let top_left = self.raster_to_screen(DVec2::new(f64::from(x0), f64::from(y0)));
        let bottom_right = self.raster_to_screen(DVec2::new(f64::from(x1), f64::from(y1)));
        let scale = self.tan_half_fov.unwrap_or(1.0);
        Frustum {
            left: top_left.x * scale,
            right: bottom_right.x * scale,
            bottom: bottom_right.y * scale,
            top: top_left.y * scale,
            perspective: self.is_perspective(),
        }
    }
}

/// Raster position of the centre of pixel `(i, j)`.
#[inline]
pub fn pixel_centre(i: u32, j: u32) -> DVec2 {
    DVec2::new(f64::from(i) + 0.5, f64::from(j) + 0.5)
}

#[cfg(test)]
mod tests {
    use super::*;

    fn perspective(w: u32, h: u32, fov: f64) -> Camera {
        Camera::new(CameraSettings {
            x_resolution: w,
            y_resolution: h,
            projection: Projection::Perspective { fov_degrees: fov },
            ..CameraSettings::default()
        })
        .unwrap()
    }

    fn angle_degrees(a: DVec3, b: DVec3) -> f64 {
        a.angle_between(b).to_degrees()
    }

    #[test]
    fn fov_spans_the_shorter_axis_in_landscape_and_portrait() {
        // Landscape: the vertical edges of the image are 45 degrees off the axis.
        let landscape = perspective(640, 480, 90.0);
        let top = landscape.ray_through_raster(DVec2::new(320.0, 0.0)).direction;
        let bottom = landscape.ray_through_raster(DVec2::new(320.0, 480.0)).direction;
        assert!((angle_degrees(top, bottom) - 90.0).abs() < 1e-12);
        assert!(top.y > 0.0, "raster row 0 is the top of the image");
        let left = landscape.ray_through_raster(DVec2::new(0.0, 240.0)).direction;
        assert!(left.x < 0.0);
        assert!((left.x / left.z + 4.0 / 3.0).abs() < 1e-12, "wider axis extends by the aspect ratio");
        // Portrait: the horizontal edges are.
        let portrait = perspective(480, 640, 90.0);
        let left = portrait.ray_through_raster(DVec2::new(0.0, 320.0)).direction;
        let right = portrait.ray_through_raster(DVec2::new(480.0, 320.0)).direction;
        assert!((angle_degrees(left, right) - 90.0).abs() < 1e-12);
        let sw = portrait.screen_window();
        assert_eq!((sw.left, sw.right), (-1.0, 1.0));
        assert!((sw.top - 4.0 / 3.0).abs() < 1e-15);
    }

    #[test]
    fn pixel_aspect_ratio_widens_the_default_screen_window() {
        let camera = Camera::new(CameraSettings {
            x_resolution: 100,
            y_resolution: 100,
            pixel_aspect_ratio: 2.0,
            projection: Projection::Perspective { fov_degrees: 60.0 },
            ..CameraSettings::default()
        })
        .unwrap();
        assert_eq!(camera.frame_aspect_ratio(), 2.0);
        assert_eq!(camera.screen_window(), ScreenWindow { left: -2.0, right: 2.0, bottom: -1.0, top: 1.0 });
    }

    #[test]
    fn pixel_centre_ray_goes_through_the_pixel_centre() {
        let camera = perspective(4, 2, 40.0);
        // The image centre lies between pixels; the centre ray of a 1x1 image is the axis.
        let centre = camera.ray_through_raster(DVec2::new(2.0, 1.0));
        assert!((centre.direction - DVec3::Z).length() < 1e-15);
        let one = perspective(1, 1, 40.0).pixel_centre_ray(0, 0);
        assert_eq!(one.direction, DVec3::Z);
        // Pixel (0, 0) is up and to the left.
        let d = camera.pixel_centre_ray(0, 0).direction;
        assert!(d.x < 0.0 && d.y > 0.0);
        let (raster, depth) = camera.world_to_raster(d * 3.0).unwrap();
        assert!((raster - DVec2::new(0.5, 0.5)).length() < 1e-12);
        assert!((depth - 3.0 * d.z).abs() < 1e-12);
    }

    #[test]
    fn radial_and_eye_depth_differ_by_the_cosine_at_the_corner() {
        // The example: at the corner of a 40-degree square image radial and planar
        // depth differ by about 12% (1 / cos of the corner angle, tan = tan(20) * sqrt(2)).
        let camera = perspective(1000, 1000, 40.0);
        let ratio = camera.radial_to_eye_depth(0, 0, 1.0);
        let t = (20f64).to_radians().tan() * 2f64.sqrt() * 999.0 / 1000.0;
        assert!((ratio - 1.0 / (1.0 + t * t).sqrt()).abs() < 1e-12);
        assert!(ratio < 0.89 && ratio > 0.88);
        let r = camera.eye_depth_to_radial(0, 0, camera.radial_to_eye_depth(0, 0, 7.25));
        assert!((r - 7.25).abs() < 1e-14);
    }

    #[test]
    fn world_ray_distances_are_world_units_even_with_a_scaled_camera() {
        // A camera transform with scale and shear: camera space is not world-metric.
        let camera_from_world = DMat4::from_cols_array(&[
            2.0, 0.1, 0.0, 0.0, //
            0.0, 1.5, 0.2, 0.0, //
            0.3, 0.0, -0.5, 0.0, //
            10.0, -3.0, 7.0, 1.0,
        ]);
        let camera = Camera::new(CameraSettings {
            x_resolution: 32,
            y_resolution: 24,
            projection: Projection::Perspective { fov_degrees: 55.0 },
            camera_from_world,
            ..CameraSettings::default()
        })
        .unwrap();
        for (i, j) in [(0, 0), (31, 0), (5, 17), (31, 23)] {
            let ray = camera.pixel_centre_world_ray(i, j);
            assert!((ray.direction.length() - 1.0).abs() < 1e-15);
            assert!((ray.origin - camera.eye_position()).length() < 1e-12);
            let point = ray.at(4.0);
            let (raster, eye_depth) = camera.world_to_raster(point).unwrap();
            assert!((raster - pixel_centre(i, j)).length() < 1e-9, "{raster}");
            let converted = camera.radial_to_eye_depth(i, j, 4.0);
            assert!((converted - eye_depth).abs() < 1e-12 * eye_depth, "{converted} vs {eye_depth}");
            // The camera-space ray goes the same way.
            let c = camera.pixel_centre_ray(i, j);
            let along = camera_from_world.transform_point3(point);
            assert!((along.normalize() - c.direction).length() < 1e-12);
        }
    }

    #[test]
    fn orthographic_rays_are_parallel() {
        let camera = Camera::new(CameraSettings {
            x_resolution: 20,
            y_resolution: 10,
            screen_window: Some(ScreenWindow { left: -4.0, right: 4.0, bottom: -2.0, top: 2.0 }),
            ..CameraSettings::default()
        })
        .unwrap();
        let ray = camera.pixel_centre_ray(0, 0);
        assert_eq!(ray.direction, DVec3::Z);
        assert_eq!(ray.origin, DVec3::new(-3.8, 1.8, 0.0));
        assert_eq!(camera.radial_to_eye_depth(3, 4, 2.5), 2.5);
        let (raster, depth) = camera.world_to_raster(DVec3::new(-3.8, 1.8, 2.0)).unwrap();
        assert!((raster - DVec2::new(0.5, 0.5)).length() < 1e-12);
        assert_eq!(depth, 2.0);
    }

    #[test]
    fn view_matrix_looks_down_negative_z() {
        let camera = Camera::new(CameraSettings {
            projection: Projection::Perspective { fov_degrees: 30.0 },
            camera_from_world: DMat4::from_translation(DVec3::new(0.0, 0.0, 5.0)),
            ..CameraSettings::default()
        })
        .unwrap();
        // World origin is 5 units in front of the eye: eye space z = -5.
        let eye = camera.eye_from_world().transform_point3(DVec3::ZERO);
        assert_eq!(eye, DVec3::new(0.0, 0.0, -5.0));
        assert_eq!(camera.eye_position(), DVec3::new(0.0, 0.0, -5.0));
        // A point up and to the right stays up and to the right.
        let p = camera.eye_from_world().transform_point3(DVec3::new(1.0, 2.0, 0.0));
        assert!(p.x > 0.0 && p.y > 0.0);
    }

    #[test]
    fn bad_settings_are_errors() {
        let bad = |settings: CameraSettings| Camera::new(settings).unwrap_err();
        assert!(matches!(
            bad(CameraSettings { x_resolution: 0, ..Default::default() }),
            CameraError::EmptyImage { .. }
        ));
        assert!(matches!(
            bad(CameraSettings {
                projection: Projection::Perspective { fov_degrees: 180.0 },
                ..Default::default()
            }),
            CameraError::BadValue { .. }
        ));
        assert!(matches!(
            bad(CameraSettings { camera_from_world: DMat4::ZERO, ..Default::default() }),
            CameraError::SingularTransform
        ));
        let mut projective = DMat4::IDENTITY;
        projective.x_axis.w = 0.5;
        assert!(matches!(
            bad(CameraSettings { camera_from_world: projective, ..Default::default() }),
            CameraError::SingularTransform
        ));
        assert!(matches!(
            bad(CameraSettings {
                screen_window: Some(ScreenWindow { left: 1.0, right: 1.0, bottom: 0.0, top: 1.0 }),
                ..Default::default()
            }),
            CameraError::BadScreenWindow(_)
        ));
    }

    #[test]
    fn crop_frustum_is_the_sub_rectangle() {
        let camera = Camera::new(CameraSettings {
            x_resolution: 100,
            y_resolution: 100,
            projection: Projection::Perspective { fov_degrees: 90.0 },
            crop_window: CropWindow { xmin: 0.5, xmax: 1.0, ymin: 0.0, ymax: 0.25 },
            ..CameraSettings::default()
        })
        .unwrap();
        assert_eq!(camera.crop_pixel_bounds(), (50, 100, 0, 25));
        let f = camera.crop_frustum();
        assert!((f.left - 0.0).abs() < 1e-15 && (f.right - 1.0).abs() < 1e-15);
        assert!((f.top - 1.0).abs() < 1e-15 && (f.bottom - 0.5).abs() < 1e-15);
    }
}
