//! The graphics state an entity carries (attributes) and the lights it declares.

use super::*;
use glam::{DMat4, DVec3, Vec3};

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
