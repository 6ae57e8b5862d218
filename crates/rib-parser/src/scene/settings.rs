//! Render settings (options): camera, display, filters, exposure, depth requests.

use super::*;
use glam::DVec3;
use std::path::PathBuf;
use std::sync::Arc;

// ---------------------------------------------------------------------------------------------
// Render settings

/// `PixelFilter "name" xwidth ywidth`. The name is kept as given (`"box"`, `"triangle"`,
/// `"gaussian"`, `"catmull-rom"`, `"sinc"`, or anything else for the consumer to reject).
#[derive(Clone, Debug, PartialEq)]
pub struct PixelFilter {
    pub name: String,
    pub x_width: f32,
    pub y_width: f32,
}

impl Default for PixelFilter {
    /// RenderMan's default: `PixelFilter "gaussian" 2 2`.
    fn default() -> Self {
        PixelFilter { name: "gaussian".into(), x_width: 2.0, y_width: 2.0 }
    }
}

/// `Exposure gain gamma`: `out = (gain * in) ^ (1 / gamma)`.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct Exposure {
    pub gain: f32,
    pub gamma: f32,
}

impl Default for Exposure {
    fn default() -> Self {
        Exposure { gain: 1.0, gamma: 1.0 }
    }
}

/// `Quantize "rgba" one min max dither`. `one == 0` asks for floating-point output.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct Quantize {
    pub one: i32,
    pub min: i32,
    pub max: i32,
    pub dither: f32,
}

impl Default for Quantize {
    /// RenderMan's default: 8-bit with dither amplitude 0.5.
    fn default() -> Self {
        Quantize { one: 255, min: 0, max: 255, dither: 0.5 }
    }
}

/// `DepthOfField fstop focallength focaldistance`: a thin lens whose aperture radius is
/// `focal_length / (2 fstop)`, every length in camera-space units (RenderMan spec §4.1.2).
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct DepthOfField {
    pub fstop: f32,
    pub focal_length: f32,
    /// Camera-space z of the plane in sharp focus.
    pub focal_distance: f32,
}

impl DepthOfField {
    /// The radius of the lens aperture in camera-space units.
    pub fn lens_radius(&self) -> f64 {
        f64::from(self.focal_length) / (2.0 * f64::from(self.fstop))
    }
}

/// Image-forming options other than the camera geometry.
#[derive(Clone, Debug, PartialEq)]
pub struct RenderSettings {
    /// `PixelSamples xsamples ysamples`.
    pub pixel_samples: (f32, f32),
    pub pixel_filter: PixelFilter,
    pub exposure: Exposure,
    /// `Quantize "rgba" ...`.
    pub quantize: Quantize,
    /// `Quantize "z" ...` when given.
    pub quantize_depth: Option<Quantize>,
    /// `Hider "name" params`.
    pub hider: Option<ShaderCall>,
    /// LRT / pbrt-v1 style `SurfaceIntegrator "name" params`.
    pub surface_integrator: Option<ShaderCall>,
    /// `Shutter open close`.
    pub shutter: Option<(f32, f32)>,
    /// `camera_from_world` at each key time (scene times) of a `MotionBegin` block around the
    /// camera transformation; `None` when the camera does not move. `CameraSettings`'
    /// `camera_from_world` is its value at shutter open.
    pub camera_motion: Option<Arc<crate::motion::TransformMotion>>,
    /// `ClippingPlane` requests (RenderMan 3.2), in camera space: everything on the side of a
    /// plane its normal points to is removed from the scene.
    pub clipping_planes: Vec<ClippingPlane>,
    /// `DepthOfField fstop focallength focaldistance`; `None` is a pinhole camera.
    pub depth_of_field: Option<DepthOfField>,
    /// `Imager "name" params` (`"background"` sets the colour where rays miss).
    pub imager: Option<ShaderCall>,
    /// `MakeTexture`, `MakeLatLongEnvironment` and `MakeCubeFaceEnvironment` requests, in order:
    /// renderers that read images directly resolve a texture name through them.
    pub textures: Vec<MadeTexture>,
}

/// A user clipping plane through `point` with `normal` (camera space): geometry on the side
/// `normal` points to (`(p - point) . normal > 0`) is clipped away.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct ClippingPlane {
    pub point: DVec3,
    pub normal: DVec3,
}

/// What a `Make...` request makes.
#[derive(Clone, Debug, PartialEq)]
pub enum MadeTextureKind {
    /// `MakeTexture picture name swrap twrap filter swidth twidth`.
    Texture { picture: String, swrap: String, twrap: String },
    /// `MakeLatLongEnvironment picture name filter swidth twidth`.
    LatLong { picture: String },
    /// `MakeCubeFaceEnvironment px nx py ny pz nz name fov filter swidth twidth`.
    CubeFaces { faces: [String; 6], fov: f32 },
}

/// A texture file that a RIB asks to make from pictures: `name` is what shaders refer to.
#[derive(Clone, Debug, PartialEq)]
pub struct MadeTexture {
    pub name: String,
    pub kind: MadeTextureKind,
    pub filter: String,
    pub filter_width: (f32, f32),
    pub params: ParamList,
    pub loc: FileLoc,
}

impl Default for RenderSettings {
    fn default() -> Self {
        RenderSettings {
            pixel_samples: (2.0, 2.0),
            pixel_filter: PixelFilter::default(),
            exposure: Exposure::default(),
            quantize: Quantize::default(),
            quantize_depth: None,
            hider: None,
            surface_integrator: None,
            shutter: None,
            camera_motion: None,
            clipping_planes: Vec::new(),
            depth_of_field: None,
            imager: None,
            textures: Vec::new(),
        }
    }
}

/// A `Display` request. A name starting with `+` is a secondary display; `name` keeps the `+`
/// stripped and `secondary` says it was there.
#[derive(Clone, Debug, PartialEq)]
pub struct Display {
    pub name: String,
    pub secondary: bool,
    /// The display type (`"file"`, `"tiff"`, `"framebuffer"`, `"openexr"`, `"depthtable"`, ...).
    pub driver: String,
    /// The display mode (`"rgb"`, `"rgba"`, `"z"`, ...).
    pub mode: String,
    pub params: ParamList,
    pub loc: FileLoc,
}

/// How the depth table was requested (CONTRACTS.md §1).
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum DepthRequestSource {
    /// `Option "lrt" "string depthfile" ["name.depth"]`.
    Option,
    /// `Display "+name.depth" "depthtable" "z"`.
    Display,
    /// `lrt-depth --depth PATH` (set by the CLI, never by the parser).
    CommandLine,
}

/// A request for a depth table. `path` is as given; relative paths resolve against the
/// current working directory, like `Display` names.
#[derive(Clone, Debug, PartialEq)]
pub struct DepthRequest {
    pub path: PathBuf,
    pub source: DepthRequestSource,
    /// `None` for a command-line request.
    pub loc: Option<FileLoc>,
}

/// Any `Option "namespace" params` call, kept whole.
#[derive(Clone, Debug, PartialEq)]
pub struct OptionCall {
    pub namespace: String,
    pub params: ParamList,
    pub loc: FileLoc,
}
