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

use glam::{DMat4, DVec2, DVec3};
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

/// A ray in camera space. `direction` has unit length, so a distance along it is a distance in
/// camera-space units.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct CameraRay {
    pub origin: DVec3,
    pub direction: DVec3,
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
        let world_from_camera = c.inverse();
        if !world_from_camera.is_finite() {
            return Err(CameraError::SingularTransform);
        }
        Ok(Camera { settings, frame_aspect_ratio, screen_window, tan_half_fov, world_from_camera })
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

    pub fn camera_from_world(&self) -> DMat4 {
        self.settings.camera_from_world
    }

    pub fn world_from_camera(&self) -> DMat4 {
        self.world_from_camera
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
    pub fn raster_to_screen(&self, raster: DVec2) -> DVec2 {
        let (w, h) = self.resolution();
        let sw = self.screen_window;
        let ndc_x = raster.x / f64::from(w);
        let ndc_y = raster.y / f64::from(h);
        DVec2::new(sw.left + ndc_x * (sw.right - sw.left), sw.top - ndc_y * (sw.top - sw.bottom))
    }

    /// The camera-space ray through a raster position.
    pub fn ray_through_raster(&self, raster: DVec2) -> CameraRay {
        let s = self.raster_to_screen(raster);
        match self.tan_half_fov {
            Some(t) => {
                CameraRay { origin: DVec3::ZERO, direction: DVec3::new(s.x * t, s.y * t, 1.0).normalize() }
            }
            None => CameraRay { origin: DVec3::new(s.x, s.y, 0.0), direction: DVec3::Z },
        }
    }

    /// *The* ray through the centre of pixel `(i, j)` (column `i` from the left, row `j` from
    /// the top): raster position `(i + 0.5, j + 0.5)`. The depth table holds distances along it.
    pub fn pixel_centre_ray(&self, i: u32, j: u32) -> CameraRay {
        self.ray_through_raster(DVec2::new(f64::from(i) + 0.5, f64::from(j) + 0.5))
    }

    /// Planar eye depth (camera-space z) of the point at `radial` distance along the pixel-centre
    /// ray of pixel `(i, j)`. For an orthographic camera the two are equal.
    pub fn radial_to_eye_depth(&self, i: u32, j: u32, radial: f64) -> f64 {
        radial * self.pixel_centre_ray(i, j).direction.z
    }

    /// Inverse of [`Camera::radial_to_eye_depth`].
    pub fn eye_depth_to_radial(&self, i: u32, j: u32, eye_depth: f64) -> f64 {
        eye_depth / self.pixel_centre_ray(i, j).direction.z
    }
}
