//! The option requests, fixed at `WorldBegin` and saved by `FrameBegin`: camera (`Format`,
//! `FrameAspectRatio`, `ScreenWindow`, `CropWindow`, `Projection`, `Clipping`, `Shutter`),
//! display (`Display`, `Quantize`, `Exposure`, `ColorSamples`) and rendering (`PixelSamples`,
//! `PixelFilter`, `Hider`, `SurfaceIntegrator`, `Option`).

use super::SceneBuilder;
use crate::diagnostics::DiagnosticKind;
use crate::scene::*;
use crate::target::Cx;
use depth_remap::{Clipping, CropWindow, Projection, ScreenWindow};
use glam::DVec3;

/// At most this many `ClippingPlane`s: each costs every ray a test.
pub const MAX_CLIPPING_PLANES: usize = 64;

impl SceneBuilder {
    /// Options may only change outside the world block.
    pub(super) fn option_allowed(&mut self, request: &str, cx: &mut Cx<'_>) -> bool {
        if self.in_world() {
            cx.warn(
                DiagnosticKind::Nesting,
                format!("{request} inside WorldBegin/WorldEnd is ignored (options are fixed at WorldBegin)"),
            );
            return false;
        }
        true
    }

    pub(super) fn format(&mut self, x: i32, y: i32, pixel_aspect: f64, cx: &mut Cx<'_>) {
        if !self.option_allowed("Format", cx) {
            return;
        }
        let limits = &self.options.limits;
        let side = i64::from(limits.max_image_side);
        if x < 1 || y < 1 || i64::from(x) > side || i64::from(y) > side {
            cx.error(
                DiagnosticKind::BadValue,
                format!("Format: resolution {x}x{y} must be between 1 and {side} pixels per side"),
            );
            return;
        }
        let pixels = x as u64 * y as u64;
        if pixels > limits.max_image_pixels {
            cx.error(
                DiagnosticKind::Limit,
                format!(
                    "Format: {x}x{y} = {pixels} pixels exceeds the limit of {} pixels",
                    limits.max_image_pixels
                ),
            );
            return;
        }
        let aspect = if pixel_aspect.is_finite() && pixel_aspect > 0.0 {
            pixel_aspect
        } else {
            cx.warn(
                DiagnosticKind::BadValue,
                format!("Format: pixel aspect ratio {pixel_aspect} is not positive; using 1"),
            );
            1.0
        };
        let c = &mut self.opts.camera;
        c.x_resolution = x as u32;
        c.y_resolution = y as u32;
        c.pixel_aspect_ratio = aspect;
    }

    pub(super) fn frame_aspect_ratio(&mut self, ratio: f64, cx: &mut Cx<'_>) {
        if !self.option_allowed("FrameAspectRatio", cx) {
            return;
        }
        if !(ratio.is_finite() && ratio > 0.0) {
            cx.error(DiagnosticKind::BadValue, format!("FrameAspectRatio must be positive, got {ratio}"));
            return;
        }
        self.opts.camera.frame_aspect_ratio = Some(ratio);
    }

    pub(super) fn screen_window(&mut self, left: f64, right: f64, bottom: f64, top: f64, cx: &mut Cx<'_>) {
        if !self.option_allowed("ScreenWindow", cx) {
            return;
        }
        let finite = [left, right, bottom, top].iter().all(|v| v.is_finite());
        if !finite || left == right || bottom == top {
            cx.error(
                DiagnosticKind::BadValue,
                format!("ScreenWindow [{left} {right} {bottom} {top}] has no extent"),
            );
            return;
        }
        self.opts.camera.screen_window = Some(ScreenWindow { left, right, bottom, top });
    }

    pub(super) fn crop_window(&mut self, x_min: f64, x_max: f64, y_min: f64, y_max: f64, cx: &mut Cx<'_>) {
        if !self.option_allowed("CropWindow", cx) {
            return;
        }
        let crop = CropWindow { xmin: x_min, xmax: x_max, ymin: y_min, ymax: y_max };
        if !crop.is_valid() {
            cx.error(
                DiagnosticKind::BadValue,
                format!("CropWindow [{x_min} {x_max} {y_min} {y_max}] must satisfy 0 <= min < max <= 1"),
            );
            return;
        }
        self.opts.camera.crop_window = crop;
    }

    pub(super) fn projection(
        &mut self,
        name: &str,
        params: ParamList,
        fov_degrees: Option<f64>,
        cx: &mut Cx<'_>,
    ) {
        if !self.option_allowed("Projection", cx) {
            return;
        }
        match name {
            "perspective" => {
                let fov = fov_degrees.or(params.float("fov").map(f64::from)).unwrap_or(90.0);
                if !(fov.is_finite() && fov > 0.0 && fov < 180.0) {
                    cx.error(
                        DiagnosticKind::BadValue,
                        format!("Projection \"perspective\": fov {fov} must be in (0, 180) degrees"),
                    );
                    return;
                }
                self.opts.camera.projection = Projection::Perspective { fov_degrees: fov };
            }
            "orthographic" => self.opts.camera.projection = Projection::Orthographic,
            // `Projection "NULL"` or `""` leaves the camera transformation as the whole projection.
            "null" | "NULL" | "" => self.opts.camera.projection = Projection::Orthographic,
            other => cx.error(
                DiagnosticKind::Unsupported,
                format!("Projection \"{other}\" is not supported (perspective or orthographic)"),
            ),
        }
    }

    pub(super) fn clipping(&mut self, near: f64, far: f64, cx: &mut Cx<'_>) {
        if !self.option_allowed("Clipping", cx) {
            return;
        }
        if !(near > 0.0 && far > near) || near.is_nan() {
            cx.error(DiagnosticKind::BadValue, format!("Clipping {near} {far}: needs 0 < near < far"));
            return;
        }
        self.opts.camera.clipping = Clipping { near, far };
    }

    /// `ClippingPlane x y z nx ny nz`: the point and normal are in the current coordinate
    /// system (before `WorldBegin`, where options are given, the current transformation maps it
    /// to camera space), kept in camera space.
    pub(super) fn clipping_plane(&mut self, point: DVec3, normal: DVec3, cx: &mut Cx<'_>) {
        if !self.option_allowed("ClippingPlane", cx) {
            return;
        }
        if self.opts.render.clipping_planes.len() >= MAX_CLIPPING_PLANES {
            cx.warn(
                DiagnosticKind::BadValue,
                format!(
                    "ClippingPlane: more than {MAX_CLIPPING_PLANES} clipping planes; this one is ignored"
                ),
            );
            return;
        }
        let camera_from_current = self.gs.ctm;
        let camera_point = camera_from_current.transform_point3(point);
        let camera_normal = camera_from_current.inverse().transpose().transform_vector3(normal);
        if !(camera_point.is_finite() && camera_normal.is_finite() && camera_normal != DVec3::ZERO) {
            cx.error(
                DiagnosticKind::BadValue,
                "ClippingPlane: the point must be finite and the normal finite and not zero (in camera space)",
            );
            return;
        }
        self.opts.render.clipping_planes.push(ClippingPlane { point: camera_point, normal: camera_normal });
    }

    pub(super) fn shutter(&mut self, open: f32, close: f32, cx: &mut Cx<'_>) {
        if !self.option_allowed("Shutter", cx) {
            return;
        }
        self.opts.render.shutter = Some((open, close));
    }

    pub(super) fn depth_of_field(&mut self, settings: Option<[f32; 3]>, cx: &mut Cx<'_>) {
        if !self.option_allowed("DepthOfField", cx) {
            return;
        }
        let Some([fstop, focal_length, focal_distance]) = settings else {
            self.opts.render.depth_of_field = None;
            return;
        };
        // RI_INFINITY (1e38 in RIB files) as the f-stop is RenderMan's pinhole camera.
        if fstop.is_infinite() || fstop >= 1e30 {
            self.opts.render.depth_of_field = None;
            return;
        }
        let positive = |v: f32| v.is_finite() && v > 0.0;
        if !(positive(fstop) && positive(focal_length) && positive(focal_distance)) {
            cx.error(
                DiagnosticKind::BadValue,
                format!(
                    "DepthOfField {fstop} {focal_length} {focal_distance}: fstop, focallength and \
                     focaldistance must be finite and positive"
                ),
            );
            return;
        }
        self.opts.render.depth_of_field = Some(DepthOfField { fstop, focal_length, focal_distance });
    }

    pub(super) fn pixel_samples(&mut self, x: f32, y: f32, cx: &mut Cx<'_>) {
        if !self.option_allowed("PixelSamples", cx) {
            return;
        }
        if !(x.is_finite() && y.is_finite() && x > 0.0 && y > 0.0) {
            cx.error(DiagnosticKind::BadValue, format!("PixelSamples {x} {y} must be positive"));
            return;
        }
        self.opts.render.pixel_samples = (x, y);
    }

    pub(super) fn pixel_filter(&mut self, name: &str, x_width: f32, y_width: f32, cx: &mut Cx<'_>) {
        if !self.option_allowed("PixelFilter", cx) {
            return;
        }
        if !(x_width.is_finite() && y_width.is_finite() && x_width > 0.0 && y_width > 0.0) {
            cx.error(
                DiagnosticKind::BadValue,
                format!("PixelFilter widths {x_width} {y_width} must be positive"),
            );
            return;
        }
        self.opts.render.pixel_filter = PixelFilter { name: name.to_string(), x_width, y_width };
    }

    pub(super) fn exposure(&mut self, gain: f32, gamma: f32, cx: &mut Cx<'_>) {
        if !self.option_allowed("Exposure", cx) {
            return;
        }
        if !(gain.is_finite() && gain >= 0.0 && gamma.is_finite() && gamma > 0.0) {
            cx.error(
                DiagnosticKind::BadValue,
                format!("Exposure {gain} {gamma}: needs gain >= 0 and gamma > 0"),
            );
            return;
        }
        self.opts.render.exposure = Exposure { gain, gamma };
    }

    pub(super) fn quantize(
        &mut self,
        kind: &str,
        one: i32,
        min: i32,
        max: i32,
        dither: f32,
        cx: &mut Cx<'_>,
    ) {
        if !self.option_allowed("Quantize", cx) {
            return;
        }
        let q = Quantize { one, min, max, dither };
        match kind {
            "rgba" => self.opts.render.quantize = q,
            "z" => self.opts.render.quantize_depth = Some(q),
            other => cx
                .warn(DiagnosticKind::Unsupported, format!("Quantize \"{other}\" is not supported; ignored")),
        }
    }

    pub(super) fn display(
        &mut self,
        name: &str,
        driver: &str,
        mode: &str,
        params: ParamList,
        cx: &mut Cx<'_>,
    ) {
        if !self.option_allowed("Display", cx) {
            return;
        }
        let (secondary, bare) = match name.strip_prefix('+') {
            Some(rest) => (true, rest),
            None => (false, name),
        };
        if bare.is_empty() {
            cx.error(DiagnosticKind::BadValue, "Display: empty name");
            return;
        }
        if !secondary {
            // A primary display replaces the display list (RISpec §4.1.3).
            self.opts.displays.clear();
        }
        if driver == "depthtable" {
            if let Some(prev) = &self.opts.depth_request
                && prev.path.as_os_str() != bare
            {
                cx.warn(
                    DiagnosticKind::BadValue,
                    format!(
                        "a depth table was already requested ({}); this Display replaces it",
                        prev.path.display()
                    ),
                );
            }
            self.opts.depth_request = Some(DepthRequest {
                path: bare.into(),
                source: DepthRequestSource::Display,
                loc: Some(cx.loc.clone()),
            });
        }
        self.opts.displays.push(Display {
            name: bare.to_string(),
            secondary,
            driver: driver.to_string(),
            mode: mode.to_string(),
            params,
            loc: cx.loc.clone(),
        });
    }

    pub(super) fn hider(&mut self, name: &str, params: ParamList, cx: &mut Cx<'_>) {
        if !self.option_allowed("Hider", cx) {
            return;
        }
        self.opts.render.hider = Some(ShaderCall { name: name.to_string(), params, loc: cx.loc.clone() });
    }

    pub(super) fn color_samples(&mut self, n_to_rgb: Vec<f32>, _rgb_to_n: Vec<f32>, cx: &mut Cx<'_>) {
        if !self.option_allowed("ColorSamples", cx) {
            return;
        }
        self.opts.color_to_rgb =
            if n_to_rgb.len() == 9 && is_identity3(&n_to_rgb) { None } else { Some(n_to_rgb) };
    }

    pub(super) fn option(&mut self, namespace: &str, params: ParamList, cx: &mut Cx<'_>) {
        if namespace == "lrt" {
            if let Some(path) = params.string("depthfile") {
                if path.is_empty() {
                    cx.error(DiagnosticKind::BadValue, "Option \"lrt\" \"depthfile\": empty file name");
                } else {
                    let loc = params.get("depthfile").map_or_else(|| cx.loc.clone(), |p| p.loc.clone());
                    self.opts.depth_request = Some(DepthRequest {
                        path: path.into(),
                        source: DepthRequestSource::Option,
                        loc: Some(loc),
                    });
                }
            } else if params.get("depthfile").is_some() {
                cx.error(DiagnosticKind::ParameterValues, "Option \"lrt\" \"depthfile\" needs a string");
            }
        }
        self.opts.options.push(OptionCall { namespace: namespace.to_string(), params, loc: cx.loc.clone() });
    }

    /// `Imager`: kept in the render settings; `"background"` is the colour where rays miss
    /// (RenderMan's `Ci += (1 - alpha) * background`), the others are shader programs.
    ///
    /// Unlike other options it is taken inside the world block too, as Aqsis takes it (scenes
    /// such as its `hand.rib` set it there): the imager runs on the finished image, so nothing
    /// in the world depends on it.
    pub(super) fn imager(&mut self, call: ShaderCall, cx: &mut Cx<'_>) {
        if call.name == "background" {
            if background_color(&call.params).is_none() {
                cx.warn(
                    DiagnosticKind::ParameterValues,
                    "Imager \"background\" has no colour (\"background\", \"bgcolor\" or \"color\"); the background stays black",
                );
            }
        } else {
            cx.warn(
                DiagnosticKind::Unsupported,
                format!("Imager \"{}\" is a shader program, which is not run; ignored", call.name),
            );
        }
        self.opts.render.imager = Some(call);
    }

    pub(super) fn surface_integrator(&mut self, call: ShaderCall, cx: &mut Cx<'_>) {
        if !self.option_allowed("SurfaceIntegrator", cx) {
            return;
        }
        self.opts.render.surface_integrator = Some(call);
    }
}

fn is_identity3(m: &[f32]) -> bool {
    m.iter().enumerate().all(|(i, &v)| v == if i % 4 == 0 { 1.0 } else { 0.0 })
}

/// The colour of `Imager "background"`: its `"background"` parameter, or the `"bgcolor"` and
/// `"color"` spellings scenes also use.
pub fn background_color(params: &ParamList) -> Option<glam::Vec3> {
    ["background", "bgcolor", "color"].into_iter().find_map(|name| params.vec3(name))
}
