//! The world-space scene description that comes out of a RIB file.
//!
//! This is plain data, built by the scene builder (one implementation of the parser's target
//! trait) and read by the ray tracer, the viewer and the haptics. It says what the RIB means,
//! not how any consumer renders it: shader names and parameters are kept as given, and each
//! consumer interprets them (e.g. the ray tracer maps `"plastic"` to its material).
//!
//! Conventions:
//! - Transforms are `f64` ([`DMat4`], column vectors, `p_world = world_from_object * p`), composed
//!   as the RenderMan Interface says: the transform given last applies to the object first. A RIB
//!   matrix in row-vector layout converts with `DMat4::from_cols_array(&rib16)`.
//! - Geometry is stored in its own object space, as given (`f32`, like `RtFloat`), so a consumer
//!   can choose its own render space (e.g. camera-relative) and keep precision far from the origin.
//! - Angles are kept in the RIB's units (degrees) where the RIB gives them, and named `_degrees`.
//! - Every entity carries the [`FileLoc`] of the request that made it.

use depth_remap::CameraSettings;
use glam::{DMat4, DVec3, Vec3, Vec4};
use std::fmt;
use std::path::PathBuf;
use std::sync::Arc;

// ---------------------------------------------------------------------------------------------
// Locations

/// Where something came from: `file:line:col`, 1-based. `file` is the path as the user or the
/// including file named it (so messages read like the command line).
#[derive(Clone, Debug, PartialEq, Eq, Hash)]
pub struct FileLoc {
    pub file: Arc<str>,
    pub line: u32,
    pub column: u32,
}

impl FileLoc {
    pub fn new(file: impl Into<Arc<str>>, line: u32, column: u32) -> FileLoc {
        FileLoc { file: file.into(), line, column }
    }
}

impl fmt::Display for FileLoc {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        write!(f, "{}:{}:{}", self.file, self.line, self.column)
    }
}

// ---------------------------------------------------------------------------------------------
// Parameters

/// Storage class of a parameter or primitive variable (RISpec §2.3, plus `facevertex`).
#[derive(Clone, Copy, Debug, PartialEq, Eq, Hash)]
pub enum StorageClass {
    Constant,
    Uniform,
    Varying,
    Vertex,
    FaceVarying,
    FaceVertex,
}

/// Base type of a parameter.
#[derive(Clone, Copy, Debug, PartialEq, Eq, Hash)]
pub enum ParamType {
    Float,
    Integer,
    String,
    Point,
    Vector,
    Normal,
    Color,
    HPoint,
    Matrix,
}

impl ParamType {
    /// Number of scalar components of one element (`color` assumes 3 colour samples).
    pub fn components(self) -> usize {
        match self {
            ParamType::Float | ParamType::Integer | ParamType::String => 1,
            ParamType::Point | ParamType::Vector | ParamType::Normal | ParamType::Color => 3,
            ParamType::HPoint => 4,
            ParamType::Matrix => 16,
        }
    }
}

/// A parameter's declared type: `"vertex point"`, `"uniform float[2]"`, ...
#[derive(Clone, Copy, Debug, PartialEq, Eq, Hash)]
pub struct ParamDecl {
    pub class: StorageClass,
    pub ty: ParamType,
    /// `n` of `type[n]`; 1 when not an array.
    pub array_len: u32,
}

impl ParamDecl {
    /// Scalars per element: `components * array_len`.
    pub fn scalars_per_element(&self) -> usize {
        self.ty.components() * self.array_len as usize
    }
}

/// The values of a parameter, as given.
#[derive(Clone, Debug, PartialEq)]
pub enum ParamValues {
    Floats(Vec<f32>),
    Ints(Vec<i32>),
    Strings(Vec<String>),
}

impl ParamValues {
    pub fn len(&self) -> usize {
        match self {
            ParamValues::Floats(v) => v.len(),
            ParamValues::Ints(v) => v.len(),
            ParamValues::Strings(v) => v.len(),
        }
    }

    pub fn is_empty(&self) -> bool {
        self.len() == 0
    }
}

/// One `"name" [values]` pair with its resolved declaration.
#[derive(Clone, Debug, PartialEq)]
pub struct Param {
    /// The bare name, without any inline type (`"uniform float Kd"` gives `Kd`).
    pub name: String,
    pub decl: ParamDecl,
    pub values: ParamValues,
    pub loc: FileLoc,
}

/// A parameter list, in the order given.
#[derive(Clone, Debug, Default, PartialEq)]
pub struct ParamList(pub Vec<Param>);

impl ParamList {
    pub fn get(&self, name: &str) -> Option<&Param> {
        self.0.iter().find(|p| p.name == name)
    }

    /// The floats of parameter `name`, when it has float values.
    pub fn floats(&self, name: &str) -> Option<&[f32]> {
        match &self.get(name)?.values {
            ParamValues::Floats(v) => Some(v),
            _ => None,
        }
    }

    /// The first float of parameter `name`.
    pub fn float(&self, name: &str) -> Option<f32> {
        self.floats(name)?.first().copied()
    }

    pub fn ints(&self, name: &str) -> Option<&[i32]> {
        match &self.get(name)?.values {
            ParamValues::Ints(v) => Some(v),
            _ => None,
        }
    }

    pub fn strings(&self, name: &str) -> Option<&[String]> {
        match &self.get(name)?.values {
            ParamValues::Strings(v) => Some(v),
            _ => None,
        }
    }

    /// The first string of parameter `name`.
    pub fn string(&self, name: &str) -> Option<&str> {
        self.strings(name)?.first().map(String::as_str)
    }

    /// Three floats of parameter `name` as a vector (a `color`, `point`, `vector` or `normal`).
    pub fn vec3(&self, name: &str) -> Option<Vec3> {
        let f = self.floats(name)?;
        (f.len() >= 3).then(|| Vec3::new(f[0], f[1], f[2]))
    }
}

/// The displacement shaders of the RenderMan standard library that consumers evaluate (the
/// RenderMan Companion's `dented`, RISpec's `bumpy`, and `null`); any other name is a custom
/// shader written in the RenderMan Shading Language.
pub const STANDARD_DISPLACEMENT_SHADERS: [&str; 3] = ["null", "dented", "bumpy"];

/// A shader-like call as given: `Surface "plastic" "Ks" [0.5]`, `LightSource ...`,
/// `SurfaceIntegrator "photonmap" ...`, `PixelFilter`-style calls are typed elsewhere.
#[derive(Clone, Debug, PartialEq)]
pub struct ShaderCall {
    pub name: String,
    pub params: ParamList,
    pub loc: FileLoc,
}

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

// ---------------------------------------------------------------------------------------------
// Attributes

/// Index into [`Scene::attributes`].
#[derive(Clone, Copy, Debug, PartialEq, Eq, Hash, PartialOrd, Ord)]
pub struct AttributesId(pub u32);

/// Index into [`Scene::lights`].
#[derive(Clone, Copy, Debug, PartialEq, Eq, Hash, PartialOrd, Ord)]
pub struct LightId(pub u32);

/// Any `Attribute "namespace" params` call, kept whole.
#[derive(Clone, Debug, PartialEq)]
pub struct AttributeCall {
    pub namespace: String,
    pub params: ParamList,
    pub loc: FileLoc,
}

/// Haptic material from `Attribute "haptic" ...` (our namespace). `None` means "not given":
/// the haptics crate picks defaults relative to the device.
#[derive(Clone, Copy, Debug, Default, PartialEq)]
pub struct HapticMaterial {
    /// `"float stiffness"`: newtons per metre of device travel.
    pub stiffness: Option<f32>,
    /// `"float friction"`: one coefficient for both static and dynamic friction.
    pub friction: Option<f32>,
    /// `"float staticfriction"`, overriding `friction` for the static cone.
    pub static_friction: Option<f32>,
    /// `"float dynamicfriction"`, overriding `friction` for the dynamic cone.
    pub dynamic_friction: Option<f32>,
}

/// One attribute state, shared by every shape made while it was current.
#[derive(Clone, Debug, PartialEq)]
pub struct Attributes {
    /// `Color` (Cs), linear RGB.
    pub color: Vec3,
    /// `Opacity` (Os).
    pub opacity: Vec3,
    /// `Surface`; `None` means RenderMan's default surface (`"defaultsurface"`).
    pub surface: Option<ShaderCall>,
    /// `Displacement`. The standard shaders (`null`, `dented`, `bumpy`, see
    /// [`STANDARD_DISPLACEMENT_SHADERS`]) are evaluated by `tessellate::displace`; the builder
    /// warns once about any other (a custom shader in the RenderMan Shading Language).
    pub displacement: Option<ShaderCall>,
    /// The shader space of [`Attributes::displacement`]: the transformation current at the
    /// `Displacement` request (`world_from_shader`; relative to the definition inside
    /// `ObjectBegin`), where `dented` evaluates its noise. Identity without a displacement.
    pub displacement_space: DMat4,
    /// `Atmosphere`, `Interior`, `Exterior`: kept as given.
    pub atmosphere: Option<ShaderCall>,
    pub interior: Option<ShaderCall>,
    pub exterior: Option<ShaderCall>,
    /// `Sides 1` or `Sides 2`.
    pub sides: u8,
    /// True when the geometric normal of the shapes is the opposite of the one computed from
    /// their parametrisation (RenderMan's `Orientation`/`ReverseOrientation` against the
    /// handedness of the current coordinate system). The geometric normal of a shape is
    /// `world_from_object^-T * n_object`, where `n_object` is computed in object space
    /// (`(P1 - P0) x (P2 - P0)` for a polygon, `dP/du x dP/dv` for a parametric surface),
    /// negated when this flag is set. See [`crate::builder`] for the rule. It never changes
    /// which side of a closed quadric is inside.
    pub reverse_orientation: bool,
    /// `AreaLightSource` current when the shapes were made: they emit as that light.
    pub area_light: Option<LightId>,
    /// The lights that illuminate these shapes (light linking by `Illuminate`), sorted.
    pub illuminated_by: Vec<LightId>,
    /// `Matte 1`.
    pub matte: bool,
    /// `Attribute "identifier" "name"`, when given.
    pub name: Option<String>,
    /// Our `Attribute "haptic"` namespace, decoded.
    pub haptic: HapticMaterial,
    /// Every `Attribute` call in effect, in order (including `"identifier"` and `"haptic"`).
    /// A parameter set again in the same namespace replaces its earlier value (the earlier
    /// call keeps its other parameters; a call left without parameters is dropped).
    pub user: Vec<AttributeCall>,
    /// `ShadingRate`.
    pub shading_rate: f32,
}

impl Default for Attributes {
    fn default() -> Self {
        Attributes {
            color: Vec3::ONE,
            opacity: Vec3::ONE,
            surface: None,
            displacement: None,
            displacement_space: DMat4::IDENTITY,
            atmosphere: None,
            interior: None,
            exterior: None,
            sides: 2,
            reverse_orientation: false,
            area_light: None,
            illuminated_by: Vec::new(),
            matte: false,
            name: None,
            haptic: HapticMaterial::default(),
            user: Vec::new(),
            shading_rate: 1.0,
        }
    }
}

// ---------------------------------------------------------------------------------------------
// Lights

/// A handle of a light or object: an integer (`LightSource "pointlight" 1`) or a name (`"key"`).
#[derive(Clone, Debug, PartialEq, Eq, Hash)]
pub enum Handle {
    Int(i32),
    Name(String),
}

/// The factor between the `Cl` of RenderMan's standard point, spot and distant lights and
/// physical radiant intensity or irradiance: their shaders' `diffuse()` multiplies `Cl` by the
/// cosine with no `1/pi`, so on a true Lambertian surface (`Kd Cs / pi`) these lights carry a
/// factor `pi` to be as bright as RenderMan renders them. Every consumer of [`LightKind`] that
/// shades physically (the ray tracer, the viewer's live objects) applies it.
pub const RENDERMAN_DELTA_LIGHT_SCALE: f32 = std::f32::consts::PI;

/// A light resolved to world space with RenderMan's standard defaults filled in.
/// Intensities follow the standard shaders: point and spot lights fall off as `1 / d^2`
/// (see [`RENDERMAN_DELTA_LIGHT_SCALE`] for their units).
#[derive(Clone, Debug, PartialEq)]
pub enum LightKind {
    /// `ambientlight`: `intensity`, `lightcolor`.
    Ambient { intensity: f32, color: Vec3 },
    /// `distantlight`: light travels along `direction` (unit, world space, from `from` to `to`).
    Distant { direction: DVec3, intensity: f32, color: Vec3 },
    /// `pointlight` at `position` (world space).
    Point { position: DVec3, intensity: f32, color: Vec3 },
    /// `spotlight`: apex `position`, unit axis `direction`, `cone_angle` and
    /// `cone_delta_angle` in radians as the standard shader takes them, `beam_distribution`.
    Spot {
        position: DVec3,
        direction: DVec3,
        intensity: f32,
        color: Vec3,
        cone_angle: f32,
        cone_delta_angle: f32,
        beam_distribution: f32,
    },
    /// `AreaLightSource "arealight" ... "intensity" "lightcolor"`: the shapes whose
    /// [`Attributes::area_light`] is this light emit radiance `intensity * color` from their
    /// front side (both sides when their attributes say `Sides 2`).
    Area { intensity: f32, color: Vec3 },
    /// Any other light shader: kept as given, consumers warn and skip it. The environment
    /// lights (`envlight`, `environmentlight`, `infinite`) are kept so too; a consumer that
    /// renders them reads them with [`crate::builder::environment_light`].
    Other,
}

#[derive(Clone, Debug, PartialEq)]
pub struct Light {
    pub handle: Handle,
    /// The call as given (shader name and parameters).
    pub shader: ShaderCall,
    pub kind: LightKind,
    /// The current transformation when the light was declared.
    pub world_from_light: DMat4,
}

// ---------------------------------------------------------------------------------------------
// Shapes

/// A primitive variable other than the positions: `N`, `Cs`, `st`, user data...
pub type PrimVars = ParamList;

/// `Polygon`, `GeneralPolygon`, `PointsPolygons` and `PointsGeneralPolygons` as one type.
/// Face `f` has `loops_per_face[f]` loops (the first is the outer boundary, the rest holes);
/// loop `l` has `vertices_per_loop[l]` entries of `vertex_indices`.
#[derive(Clone, Debug, PartialEq)]
pub struct PolygonMesh {
    pub loops_per_face: Vec<u32>,
    pub vertices_per_loop: Vec<u32>,
    pub vertex_indices: Vec<u32>,
    pub positions: Vec<Vec3>,
    pub primvars: PrimVars,
}

/// A patch basis matrix and its step (RISpec `Basis`).
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct Basis {
    /// Row-vector layout as in the RIB: the 16 numbers in order.
    pub matrix: [f32; 16],
    pub step: u32,
}

#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum PatchKind {
    Bilinear,
    Bicubic,
}

#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum Wrap {
    Periodic,
    NonPeriodic,
}

/// `Patch` (a 1x1 `PatchMesh`) and `PatchMesh`. Positions are homogeneous: `P` gives `w = 1`,
/// `Pz` gives a height field over the unit square, `Pw` is taken as is.
#[derive(Clone, Debug, PartialEq)]
pub struct PatchMesh {
    pub kind: PatchKind,
    pub nu: u32,
    pub nv: u32,
    pub u_wrap: Wrap,
    pub v_wrap: Wrap,
    pub u_basis: Basis,
    pub v_basis: Basis,
    /// `nu * nv` control points, u varying fastest.
    pub positions: Vec<Vec4>,
    pub primvars: PrimVars,
}

/// One trim loop set from `TrimCurve` (applies to every following `NuPatch` in the block).
#[derive(Clone, Debug, PartialEq)]
pub struct TrimCurves {
    pub curves_per_loop: Vec<u32>,
    pub order: Vec<u32>,
    pub knots: Vec<f32>,
    pub min: Vec<f32>,
    pub max: Vec<f32>,
    pub n: Vec<u32>,
    pub u: Vec<f32>,
    pub v: Vec<f32>,
    pub w: Vec<f32>,
}

/// `NuPatch`: a non-uniform rational B-spline surface. Positions are homogeneous (`Pw`;
/// `P` gives `w = 1`), `nu * nv` of them, u varying fastest.
#[derive(Clone, Debug, PartialEq)]
pub struct NuPatch {
    pub nu: u32,
    pub u_order: u32,
    pub u_knots: Vec<f32>,
    pub u_min: f32,
    pub u_max: f32,
    pub nv: u32,
    pub v_order: u32,
    pub v_knots: Vec<f32>,
    pub v_min: f32,
    pub v_max: f32,
    pub positions: Vec<Vec4>,
    pub trim: Option<Arc<TrimCurves>>,
    pub primvars: PrimVars,
}

/// One tag of a `SubdivisionMesh` (`"crease"`, `"corner"`, `"hole"`, `"interpolateboundary"`, ...).
#[derive(Clone, Debug, PartialEq)]
pub struct SubdivisionTag {
    pub name: String,
    pub int_args: Vec<i32>,
    pub float_args: Vec<f32>,
    pub string_args: Vec<String>,
}

/// `SubdivisionMesh` (scheme `"catmull-clark"`; others are kept for the consumer to reject).
#[derive(Clone, Debug, PartialEq)]
pub struct SubdivisionMesh {
    pub scheme: String,
    pub vertices_per_face: Vec<u32>,
    pub vertex_indices: Vec<u32>,
    pub tags: Vec<SubdivisionTag>,
    pub positions: Vec<Vec3>,
    pub primvars: PrimVars,
}

/// `Points`: particles of diameter `width` (vertex) or `constantwidth` (constant), default 1.
#[derive(Clone, Debug, PartialEq)]
pub struct Points {
    pub positions: Vec<Vec3>,
    pub primvars: PrimVars,
}

/// `Curves`: linear or cubic (with `v_basis`) curves of width `width` (varying) or
/// `constantwidth` (constant), default 1.
#[derive(Clone, Debug, PartialEq)]
pub struct Curves {
    pub cubic: bool,
    pub vertices_per_curve: Vec<u32>,
    pub wrap: Wrap,
    pub v_basis: Basis,
    pub positions: Vec<Vec3>,
    pub primvars: PrimVars,
}

/// `Blobby`: an implicit surface, the level set of a field built from primitive fields
/// (opcodes 1000 constant, 1001 ellipsoid, 1002 segment, 1003 plane, 1004 plugin) combined by
/// the operators of RISpec 3.2 Table 5.3 (0 add, 1 multiply, 2 maximum, 3 minimum, 4 subtract,
/// 5 divide, 6 negate, 7 identity). The parser has checked the program: every opcode is known,
/// every operand indexes `floats`, `strings` or an earlier instruction's result, and the number
/// of primitive fields is `leaf_count`. The field is the last instruction's result.
#[derive(Clone, Debug, PartialEq)]
pub struct Blobby {
    pub leaf_count: u32,
    pub code: Vec<i32>,
    pub floats: Vec<f32>,
    pub strings: Vec<String>,
    pub primvars: PrimVars,
}

/// A geometric primitive in its object space. Quadric parameters are as in the RIB; the sweep
/// angles (`theta_max_degrees` etc.) are in degrees.
#[derive(Clone, Debug, PartialEq)]
pub enum Shape {
    Sphere {
        radius: f32,
        z_min: f32,
        z_max: f32,
        theta_max_degrees: f32,
    },
    Cylinder {
        radius: f32,
        z_min: f32,
        z_max: f32,
        theta_max_degrees: f32,
    },
    Cone {
        height: f32,
        radius: f32,
        theta_max_degrees: f32,
    },
    Disk {
        height: f32,
        radius: f32,
        theta_max_degrees: f32,
    },
    Paraboloid {
        r_max: f32,
        z_min: f32,
        z_max: f32,
        theta_max_degrees: f32,
    },
    Hyperboloid {
        point1: Vec3,
        point2: Vec3,
        theta_max_degrees: f32,
    },
    Torus {
        major_radius: f32,
        minor_radius: f32,
        phi_min_degrees: f32,
        phi_max_degrees: f32,
        theta_max_degrees: f32,
    },
    Polygons(PolygonMesh),
    Patches(PatchMesh),
    NuPatch(NuPatch),
    SubdivisionMesh(SubdivisionMesh),
    Points(Points),
    Curves(Curves),
    Blobby(Blobby),
}

impl Scene {
    /// Whether something moves while the shutter is open (`Shutter open close` with
    /// `close > open` and a shape or instance with transformation or deformation motion): the image then has
    /// motion blur.
    pub fn has_motion_blur(&self) -> bool {
        let open = self.render.shutter.is_some_and(|(open, close)| close > open);
        open && (self.render.camera_motion.is_some()
            || self.shapes.iter().any(|s| s.motion.is_some() || s.deformation.is_some())
            || self.instances.iter().any(|i| i.motion.is_some()))
    }
}

/// A shape placed in the world with the attribute state it was made under.
#[derive(Clone, Debug, PartialEq)]
pub struct ShapeEntity {
    pub shape: Arc<Shape>,
    /// The transformation at shutter open (the whole of it for a shape that does not move).
    pub world_from_object: DMat4,
    /// `world_from_object` at each key time of a `MotionBegin` block around its
    /// transformations (scene times, as `Shutter` gives them); `None` when it does not move.
    pub motion: Option<Arc<crate::motion::TransformMotion>>,
    /// The shape at each key time of a `MotionBegin` block around one geometry request per
    /// time (scene times); `shape` is then its value at shutter open. `None` when it keeps its
    /// shape.
    pub deformation: Option<Arc<crate::deformation::Deformation>>,
    pub attributes: AttributesId,
    /// True when the shape was given inside `SolidBegin`/`SolidEnd`; for world shapes the
    /// operations are in [`Scene::solids`].
    pub in_solid: bool,
    pub loc: FileLoc,
}

/// A `SolidBegin` operation.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum SolidOp {
    /// One closed solid bounded by all the surfaces inside the block.
    Primitive,
    Union,
    Intersection,
    /// The first operand minus all the others.
    Difference,
}

/// What a solid block contains, in the order of the file.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum SolidPart {
    /// A nested block: an index into [`Scene::solids`].
    Solid(u32),
    /// A shape: an index into [`Scene::shapes`].
    Shape(u32),
}

/// A `SolidBegin` ... `SolidEnd` block of the world (constructive solid geometry). Outside a
/// `"primitive"` block each shape is a primitive solid of its own, as the RenderMan
/// specification has it; solids nest up to `Limits::max_nesting` deep.
#[derive(Clone, Debug, PartialEq)]
pub struct Solid {
    pub op: SolidOp,
    /// The enclosing block, `None` for an outermost one.
    pub parent: Option<u32>,
    pub parts: Vec<SolidPart>,
    pub loc: FileLoc,
}

/// Index into [`Scene::objects`].
#[derive(Clone, Copy, Debug, PartialEq, Eq, Hash)]
pub struct ObjectId(pub u32);

/// An `ObjectBegin` ... `ObjectEnd` definition. Its shapes' `world_from_object` transforms are
/// relative to the object's own space (the instance transform applies on top), and their
/// `attributes` are the state while the definition was read. An instance's own attributes are
/// in [`ObjectInstanceEntity::shape_attributes`].
#[derive(Clone, Debug, PartialEq)]
pub struct ObjectDefinition {
    pub handle: Handle,
    pub shapes: Vec<ShapeEntity>,
    pub loc: FileLoc,
}

/// An `ObjectInstance`: the definition's shapes placed with `world_from_instance * their own
/// transform`, without copying their geometry.
///
/// Attributes follow the RenderMan Interface: an instance inherits the graphics state current
/// at `ObjectInstance` (surface, colour, lights, orientation, ...), and attribute requests made
/// inside the definition apply on top of it, as if the definition's requests were replayed
/// there. `attributes` is the state at `ObjectInstance`; `shape_attributes[i]` is the resolved
/// state of the definition's shape `i` in this instance: use it to shade and orient the shapes.
#[derive(Clone, Debug, PartialEq)]
pub struct ObjectInstanceEntity {
    pub object: ObjectId,
    /// The instance's transformation at shutter open.
    pub world_from_instance: DMat4,
    /// `world_from_instance` at each key time when the instance moves (see
    /// [`ShapeEntity::motion`]).
    pub motion: Option<Arc<crate::motion::TransformMotion>>,
    pub attributes: AttributesId,
    /// One entry per shape of the definition, in the definition's order.
    pub shape_attributes: Vec<AttributesId>,
    pub loc: FileLoc,
}

// ---------------------------------------------------------------------------------------------
// The scene

/// One frame of a RIB file, in world space.
#[derive(Clone, Debug, PartialEq)]
pub struct Scene {
    /// The file the scene was read from (`-` for standard input).
    pub source: Arc<str>,
    /// `FrameBegin n` of the frame this scene is, when the file has frames.
    pub frame: Option<i32>,
    /// The camera as the RIB describes it; `depth_remap::Camera::new` checks it.
    pub camera: CameraSettings,
    pub render: RenderSettings,
    pub displays: Vec<Display>,
    pub depth_request: Option<DepthRequest>,
    /// Every `Option` call, in order.
    pub options: Vec<OptionCall>,
    pub lights: Vec<Light>,
    pub attributes: Vec<Attributes>,
    pub shapes: Vec<ShapeEntity>,
    /// The world's `SolidBegin` blocks, outer blocks before the blocks they contain.
    pub solids: Vec<Solid>,
    pub objects: Vec<ObjectDefinition>,
    pub instances: Vec<ObjectInstanceEntity>,
    /// `CoordinateSystem "name"`: world-from-named-space, in the order declared.
    pub coordinate_systems: Vec<(String, DMat4)>,
}

impl Scene {
    pub fn attributes_of(&self, id: AttributesId) -> &Attributes {
        &self.attributes[id.0 as usize]
    }

    pub fn light(&self, id: LightId) -> &Light {
        &self.lights[id.0 as usize]
    }
}
