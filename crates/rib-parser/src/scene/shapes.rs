//! Shapes, shape entities, solids and object definitions.

use super::*;
use glam::{DMat4, Vec3, Vec4};
use std::sync::Arc;

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

/// The arguments of `NuPatch` before its parameter list: in each direction the vertex count,
/// the order, the knot vector and the parameter range drawn.
#[derive(Clone, Debug, PartialEq)]
pub struct NuPatchBasis {
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
}

/// `NuPatch`: a non-uniform rational B-spline surface. Positions are homogeneous (`Pw`;
/// `P` gives `w = 1`), `nu * nv` of them, u varying fastest.
#[derive(Clone, Debug, PartialEq)]
pub struct NuPatch {
    pub basis: NuPatchBasis,
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
