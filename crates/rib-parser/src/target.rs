//! The target trait the parser drives: one method per RIB request (pbrt-v4's `ParserTarget`).
//!
//! The parser never builds a scene. It tokenizes, checks each request's arguments and
//! parameter lists (types, value counts against the primitive, index ranges), follows
//! `ReadArchive` and inline archives, and calls one method of a [`RibTarget`] per request with
//! typed, validated arguments and a [`Cx`] holding the request's location and the diagnostics
//! sink. [`crate::builder::SceneBuilder`] is one target; tests use recording targets.
//!
//! Requests that most targets ignore have default methods that warn (`ClippingPlane`,
//! `Blobby`, texture making, ...), so a target only writes what it supports.

use crate::diagnostics::{DiagnosticKind, Diagnostics};
pub use crate::scene::NuPatchBasis;
use crate::scene::{
    Basis, FileLoc, Handle, MadeTexture, MadeTextureKind, ParamDecl, ParamList, PatchKind, ShaderCall,
    SubdivisionTag, TrimCurves, Wrap,
};
use glam::{DMat4, DVec3, Vec3};

/// The context of one request: where it is and where diagnostics go.
#[derive(Debug)]
pub struct Cx<'a> {
    pub loc: FileLoc,
    pub diagnostics: &'a mut Diagnostics,
}

impl Cx<'_> {
    pub fn warn(&mut self, kind: DiagnosticKind, message: impl Into<String>) {
        self.diagnostics.warn(kind, &self.loc, message);
    }

    pub fn error(&mut self, kind: DiagnosticKind, message: impl Into<String>) {
        self.diagnostics.error(kind, &self.loc, message);
    }

    /// An error at another location (e.g. a parameter's).
    pub fn error_at(&mut self, loc: &FileLoc, kind: DiagnosticKind, message: impl Into<String>) {
        self.diagnostics.error(kind, loc, message);
    }
}

/// Which shader slot a shader request fills.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum ShaderSlot {
    Surface,
    Displacement,
    Atmosphere,
    Interior,
    Exterior,
    Deformation,
}

impl ShaderSlot {
    pub fn request_name(self) -> &'static str {
        match self {
            ShaderSlot::Surface => "Surface",
            ShaderSlot::Displacement => "Displacement",
            ShaderSlot::Atmosphere => "Atmosphere",
            ShaderSlot::Interior => "Interior",
            ShaderSlot::Exterior => "Exterior",
            ShaderSlot::Deformation => "Deformation",
        }
    }
}

/// The quadric surfaces, with their RIB arguments (angles in degrees).
#[derive(Clone, Copy, Debug, PartialEq)]
pub enum Quadric {
    Sphere { radius: f32, z_min: f32, z_max: f32, theta_max: f32 },
    Cylinder { radius: f32, z_min: f32, z_max: f32, theta_max: f32 },
    Cone { height: f32, radius: f32, theta_max: f32 },
    Disk { height: f32, radius: f32, theta_max: f32 },
    Paraboloid { r_max: f32, z_min: f32, z_max: f32, theta_max: f32 },
    Hyperboloid { point1: Vec3, point2: Vec3, theta_max: f32 },
    Torus { major_radius: f32, minor_radius: f32, phi_min: f32, phi_max: f32, theta_max: f32 },
}

/// One method per RIB request. Arguments are validated by the parser: counts and indices fit,
/// every parameter has a declaration and the number of values its class and the primitive ask
/// for. Matrices are converted from RIB's row-vector layout to column-vector [`DMat4`]s.
#[allow(unused_variables)]
pub trait RibTarget {
    // Structure.
    fn version(&mut self, version: f64, cx: &mut Cx<'_>) {}
    /// A `Declare` (the parser has already recorded it for parsing what follows).
    fn declare(&mut self, name: &str, decl: ParamDecl, cx: &mut Cx<'_>) {}
    fn frame_begin(&mut self, frame: i32, cx: &mut Cx<'_>);
    fn frame_end(&mut self, cx: &mut Cx<'_>);
    fn world_begin(&mut self, cx: &mut Cx<'_>);
    fn world_end(&mut self, cx: &mut Cx<'_>);
    fn attribute_begin(&mut self, cx: &mut Cx<'_>);
    fn attribute_end(&mut self, cx: &mut Cx<'_>);
    fn transform_begin(&mut self, cx: &mut Cx<'_>);
    fn transform_end(&mut self, cx: &mut Cx<'_>);
    fn solid_begin(&mut self, operation: &str, cx: &mut Cx<'_>);
    fn solid_end(&mut self, cx: &mut Cx<'_>);
    fn object_begin(&mut self, handle: Handle, cx: &mut Cx<'_>);
    fn object_end(&mut self, cx: &mut Cx<'_>);
    fn object_instance(&mut self, handle: Handle, cx: &mut Cx<'_>);
    fn motion_begin(&mut self, times: &[f32], cx: &mut Cx<'_>);
    fn motion_end(&mut self, cx: &mut Cx<'_>);

    // Options.
    fn format(&mut self, x_resolution: i32, y_resolution: i32, pixel_aspect_ratio: f64, cx: &mut Cx<'_>);
    fn frame_aspect_ratio(&mut self, ratio: f64, cx: &mut Cx<'_>);
    fn screen_window(&mut self, left: f64, right: f64, bottom: f64, top: f64, cx: &mut Cx<'_>);
    fn crop_window(&mut self, x_min: f64, x_max: f64, y_min: f64, y_max: f64, cx: &mut Cx<'_>);
    /// `Projection name params`. `fov_degrees` is the `"fov"` parameter read at `f64` precision
    /// (the value in `params` is rounded to `f32` like every parameter), so the camera gets the
    /// field of view exactly as written.
    fn projection(&mut self, name: &str, params: ParamList, fov_degrees: Option<f64>, cx: &mut Cx<'_>);
    fn clipping(&mut self, near: f64, far: f64, cx: &mut Cx<'_>);
    fn clipping_plane(&mut self, point: DVec3, normal: DVec3, cx: &mut Cx<'_>) {
        cx.warn(DiagnosticKind::Unsupported, "ClippingPlane is not supported; ignored");
    }
    /// `DepthOfField fstop focallength focaldistance`, or `None` for `DepthOfField` without
    /// arguments (a pinhole camera).
    fn depth_of_field(&mut self, settings: Option<[f32; 3]>, cx: &mut Cx<'_>) {
        if settings.is_some() {
            cx.warn(DiagnosticKind::Unsupported, "DepthOfField is not supported; the camera stays a pinhole");
        }
    }
    fn shutter(&mut self, open: f32, close: f32, cx: &mut Cx<'_>);
    fn pixel_variance(&mut self, variance: f32, cx: &mut Cx<'_>) {}
    fn pixel_samples(&mut self, x: f32, y: f32, cx: &mut Cx<'_>);
    fn pixel_filter(&mut self, name: &str, x_width: f32, y_width: f32, cx: &mut Cx<'_>);
    fn exposure(&mut self, gain: f32, gamma: f32, cx: &mut Cx<'_>);
    fn imager(&mut self, call: ShaderCall, cx: &mut Cx<'_>) {
        cx.warn(DiagnosticKind::Unsupported, format!("Imager \"{}\" is not supported; ignored", call.name));
    }
    fn quantize(&mut self, kind: &str, one: i32, min: i32, max: i32, dither: f32, cx: &mut Cx<'_>);
    fn display(&mut self, name: &str, driver: &str, mode: &str, params: ParamList, cx: &mut Cx<'_>);
    fn hider(&mut self, name: &str, params: ParamList, cx: &mut Cx<'_>);
    /// `ColorSamples`: the matrices are `n x 3` and `3 x n`, row-major.
    fn color_samples(&mut self, n_to_rgb: Vec<f32>, rgb_to_n: Vec<f32>, cx: &mut Cx<'_>);
    fn relative_detail(&mut self, value: f32, cx: &mut Cx<'_>) {}
    fn option(&mut self, namespace: &str, params: ParamList, cx: &mut Cx<'_>);
    /// LRT / pbrt-v1 style `SurfaceIntegrator "name" params`.
    fn surface_integrator(&mut self, call: ShaderCall, cx: &mut Cx<'_>);

    // Attributes.
    /// `Color`: one value per colour sample (3 unless `ColorSamples` says otherwise).
    fn color(&mut self, color: &[f32], cx: &mut Cx<'_>);
    fn opacity(&mut self, opacity: &[f32], cx: &mut Cx<'_>);
    fn texture_coordinates(&mut self, st: [f32; 8], cx: &mut Cx<'_>) {}
    fn light_source(&mut self, call: ShaderCall, handle: Handle, cx: &mut Cx<'_>);
    fn area_light_source(&mut self, call: ShaderCall, handle: Handle, cx: &mut Cx<'_>);
    fn illuminate(&mut self, handle: Handle, on: bool, cx: &mut Cx<'_>);
    fn shader(&mut self, slot: ShaderSlot, call: ShaderCall, cx: &mut Cx<'_>);
    fn shading_rate(&mut self, rate: f32, cx: &mut Cx<'_>);
    fn shading_interpolation(&mut self, kind: &str, cx: &mut Cx<'_>) {}
    fn matte(&mut self, on: bool, cx: &mut Cx<'_>);
    fn bound(&mut self, bound: [f32; 6], cx: &mut Cx<'_>) {}
    fn detail(&mut self, bound: [f32; 6], cx: &mut Cx<'_>) {}
    fn detail_range(&mut self, range: [f32; 4], cx: &mut Cx<'_>) {}
    fn geometric_approximation(&mut self, kind: &str, value: f32, cx: &mut Cx<'_>) {}
    fn geometric_representation(&mut self, kind: &str, cx: &mut Cx<'_>) {}
    fn orientation(&mut self, orientation: &str, cx: &mut Cx<'_>);
    fn reverse_orientation(&mut self, cx: &mut Cx<'_>);
    fn sides(&mut self, sides: i32, cx: &mut Cx<'_>);
    fn attribute(&mut self, namespace: &str, params: ParamList, cx: &mut Cx<'_>);
    /// `Basis`: named bases are already resolved to their matrices.
    fn basis(&mut self, u: Basis, v: Basis, cx: &mut Cx<'_>);
    fn trim_curve(&mut self, trim: TrimCurves, cx: &mut Cx<'_>);

    // Transformations.
    fn identity(&mut self, cx: &mut Cx<'_>);
    fn transform(&mut self, matrix: DMat4, cx: &mut Cx<'_>);
    fn concat_transform(&mut self, matrix: DMat4, cx: &mut Cx<'_>);
    fn perspective(&mut self, fov_degrees: f64, cx: &mut Cx<'_>);
    fn translate(&mut self, delta: DVec3, cx: &mut Cx<'_>);
    fn rotate(&mut self, angle_degrees: f64, axis: DVec3, cx: &mut Cx<'_>);
    fn scale(&mut self, scale: DVec3, cx: &mut Cx<'_>);
    fn skew(&mut self, angle_degrees: f64, from: DVec3, to: DVec3, cx: &mut Cx<'_>);
    fn coordinate_system(&mut self, name: &str, cx: &mut Cx<'_>);
    fn scoped_coordinate_system(&mut self, name: &str, cx: &mut Cx<'_>) {
        self.coordinate_system(name, cx);
    }
    fn coord_sys_transform(&mut self, name: &str, cx: &mut Cx<'_>);

    // Geometry.
    /// `Polygon` with `vertex_count` vertices.
    fn polygon(&mut self, vertex_count: u32, params: ParamList, cx: &mut Cx<'_>);
    fn general_polygon(&mut self, vertices_per_loop: Vec<u32>, params: ParamList, cx: &mut Cx<'_>);
    fn points_polygons(
        &mut self,
        vertices_per_face: Vec<u32>,
        vertex_indices: Vec<u32>,
        params: ParamList,
        cx: &mut Cx<'_>,
    );
    fn points_general_polygons(
        &mut self,
        loops_per_face: Vec<u32>,
        vertices_per_loop: Vec<u32>,
        vertex_indices: Vec<u32>,
        params: ParamList,
        cx: &mut Cx<'_>,
    );
    fn patch(&mut self, kind: PatchKind, params: ParamList, cx: &mut Cx<'_>);
    #[allow(clippy::too_many_arguments)]
    fn patch_mesh(
        &mut self,
        kind: PatchKind,
        nu: u32,
        u_wrap: Wrap,
        nv: u32,
        v_wrap: Wrap,
        params: ParamList,
        cx: &mut Cx<'_>,
    );
    fn nu_patch(&mut self, patch: NuPatchBasis, params: ParamList, cx: &mut Cx<'_>);
    fn subdivision_mesh(
        &mut self,
        scheme: &str,
        vertices_per_face: Vec<u32>,
        vertex_indices: Vec<u32>,
        tags: Vec<SubdivisionTag>,
        params: ParamList,
        cx: &mut Cx<'_>,
    );
    fn quadric(&mut self, quadric: Quadric, params: ParamList, cx: &mut Cx<'_>);
    fn points(&mut self, params: ParamList, cx: &mut Cx<'_>);
    fn curves(
        &mut self,
        cubic: bool,
        vertices_per_curve: Vec<u32>,
        wrap: Wrap,
        params: ParamList,
        cx: &mut Cx<'_>,
    );
    /// `Blobby`, its program checked ([`crate::blobby::decode_blobby`]).
    fn blobby(&mut self, blobby: crate::scene::Blobby, cx: &mut Cx<'_>) {
        cx.warn(DiagnosticKind::Unsupported, "Blobby is not supported; skipped");
    }
    /// `Geometry "type"` (e.g. `"teapot"`).
    fn geometry(&mut self, kind: &str, params: ParamList, cx: &mut Cx<'_>) {
        cx.warn(DiagnosticKind::Unsupported, format!("Geometry \"{kind}\" is not supported; skipped"));
    }
    /// A `Procedural` other than `DelayedReadArchive` (which the parser reads like
    /// `ReadArchive`) and `RunProgram`/`DynamicLoad` (which the parser refuses).
    fn procedural(&mut self, kind: &str, args: Vec<String>, bound: [f32; 6], cx: &mut Cx<'_>) {
        cx.warn(DiagnosticKind::Unsupported, format!("Procedural \"{kind}\" is not supported; skipped"));
    }
    /// `MakeTexture`, `MakeShadow`, `MakeLatLongEnvironment`, ... : texture files are never made.
    fn make_texture(&mut self, request: &str, cx: &mut Cx<'_>) {
        cx.warn(
            DiagnosticKind::Unsupported,
            format!("{request} is not supported (no texture files are made); skipped"),
        );
    }
    /// `MakeTexture`, `MakeLatLongEnvironment`, `MakeCubeFaceEnvironment`, with their arguments.
    fn made_texture(&mut self, made: MadeTexture, cx: &mut Cx<'_>) {
        let request = match made.kind {
            MadeTextureKind::Texture { .. } => "MakeTexture",
            MadeTextureKind::LatLong { .. } => "MakeLatLongEnvironment",
            MadeTextureKind::CubeFaces { .. } => "MakeCubeFaceEnvironment",
        };
        self.make_texture(request, cx);
    }
    /// `MakeShadow`: a shadow map from a depth image.
    fn make_shadow(&mut self, cx: &mut Cx<'_>) {
        self.make_texture("MakeShadow", cx);
    }
    /// The value of a variable a conditional expression (`IfBegin`, `ElseIf`) refers to:
    /// `Frame`, `Option:ns:name`, `Attribute:ns:name`, `ns:name` or a bare `name` (see
    /// [`crate::conditional`]); `None` when it is not defined.
    fn variable(&self, name: &str) -> Option<crate::conditional::Value> {
        None
    }
    /// `Resource handle type params`: saves or restores part of the graphics state.
    fn resource(&mut self, handle: &str, kind: &str, params: ParamList, cx: &mut Cx<'_>) {
        cx.warn(
            DiagnosticKind::Unsupported,
            format!("Resource \"{handle}\" \"{kind}\" is not supported; ignored"),
        );
    }
    /// `ResourceBegin`: resources made until the matching `ResourceEnd` are forgotten there.
    fn resource_begin(&mut self, cx: &mut Cx<'_>) {}
    fn resource_end(&mut self, cx: &mut Cx<'_>) {}
}
