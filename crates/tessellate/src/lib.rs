//! Tessellation: every surface [`Shape`] as triangles, with a stated tolerance.
//!
//! Consumers: the ray tracer (patches, NURBS, subdivision surfaces and polygons become triangles
//! for its BVH; it may intersect quadrics exactly instead), the haptics (every surface, in world
//! space, for collision) and the viewer / `lrt-depth --check` (triangle counts).
//!
//! - [`tessellate`] turns one shape into a [`TriangleMesh`] in its **object space**.
//! - [`tessellate_placed`] does the same and places the result with a `world_from_object`
//!   transform (applied in `f64`), orienting it as the RenderMan Interface says.
//! - [`tessellate_placed_keys`] tessellates the keys of a deforming shape (`MotionBegin`) so
//!   that every key has the same triangles, each with its own vertex positions.
//! - [`tessellate_displaced`] places a shape, dices it into micropolygons and runs a standard
//!   RenderMan displacement shader on it (`null`, `dented`, `bumpy`).
//! - [`tessellate_scene`] yields a world-space mesh for every
//!   [`ShapeEntity`](rib_parser::scene::ShapeEntity) and every shape of every object instance of a
//!   [`Scene`](rib_parser::scene::Scene), with its [`AttributesId`](rib_parser::scene::AttributesId).
//!
//! # Tolerance
//! [`Tolerance`] states the largest distance between the triangles and the true surface: a
//! chord (sagitta) bound for curved surfaces, in object units for [`tessellate`] and in world
//! units for [`tessellate_placed`] / [`tessellate_scene`], optionally relative to the shape's
//! size, and capped by a triangle budget that is checked *before* anything big is allocated.
//! Polygons are exact whatever the tolerance.
//!
//! # Orientation and winding (an invariant every consumer may rely on)
//! Every triangle `[a, b, c]` is wound counter-clockwise around its surface normal: the
//! right-handed cross product `(b - a) x (c - a)` points the way the surface normal points, in
//! object space for [`tessellate`] and in world space for the placed and scene functions.
//! - In object space the normal is RenderMan's geometric normal from the parametrisation:
//!   `dPdu x dPdv` for quadrics, patches, NURBS; the polygon's Newell normal (the direction of
//!   `(P1 - P0) x (P2 - P0)` for a convex polygon) for polygons; the face winding for
//!   subdivision meshes. A full `Sphere 1 -1 1 360` has outward normals.
//! - In world space the normal is `world_from_object^-T * n_object`, flipped iff
//!   [`Attributes::reverse_orientation`](rib_parser::scene::Attributes::reverse_orientation) (see
//!   `scene.rs`). The triangle order is reversed whenever needed so the cross product still
//!   follows that normal, so a mirror transform never turns a sphere inside out.
//! - Vertex normals ([`TriangleMesh::normals`]), where present, are unit vectors on the same side
//!   (they are the smooth surface normals; user-supplied `N` are kept as given and transformed
//!   and flipped the same way).
//!
//! # Example
//! ```
//! use rib_parser::scene::Shape;
//! use tessellate::{tessellate, Tolerance};
//!
//! let sphere = Shape::Sphere { radius: 1.0, z_min: -1.0, z_max: 1.0, theta_max_degrees: 360.0 };
//! let mesh = tessellate(&sphere, &Tolerance::absolute(1e-3)).unwrap();
//! assert!(mesh.is_closed());
//! // An inscribed mesh: its area is below 4 pi by about 2 eps / r relative.
//! let exact = 4.0 * std::f64::consts::PI;
//! assert!(mesh.area() < exact && mesh.area() > exact * (1.0 - 2.5e-3));
//! ```

// Negated comparisons (`!(x > 0.0)`) are deliberate here: they also reject NaN.
#![allow(clippy::neg_cmp_op_on_partial_ord)]
// Numeric kernels index several arrays with one loop variable.
#![allow(clippy::needless_range_loop)]

mod blobby;
mod curves;
mod dice;
mod displace;
mod grid;
mod keys;
mod mesh;
mod noise;
mod nurbs;
mod patch;
mod placed;
mod polygon;
mod primvar;
mod quadric;
mod seam;
mod stitch;
mod subdiv;
pub mod texture;
mod texture_scene;
mod trim;

pub use blobby::{BLOBBY_THRESHOLD, BlobbyField};
pub use curves::{
    CurvePolyline, RibbonFacing, curve_polylines, curve_ribbons, curve_ribbons_keys, point_widths,
};
pub use dice::{DiceReport, DicingRule};
pub use displace::{
    DENTED_MAX_MAGNITUDE_CUBED, Displaced, DisplacedKeys, DisplacedMesh, DisplacementShader,
    dented_magnitude_cubed, displace_keys, displacement_bound, tessellate_displaced,
};
pub use keys::tessellate_placed_keys;
pub use mesh::TriangleMesh;
pub use noise::{perlin_noise, renderman_noise};
pub use placed::{
    MeshOrigin, SCENE_DICING, SceneMeshes, SkippedShape, WorldMesh, scene_bounds, shape_bounds,
    tessellate_placed, tessellate_scene, tessellate_scene_filtered,
};
pub use seam::SeamWelder;
pub use texture_scene::{DisplacementTextures, load_scene_texture};

use glam::DVec3;
use rib_parser::scene::Shape;

/// How finely to tessellate.
///
/// The effective deviation bound `eps` of a shape is the smaller of [`max_deviation`] and
/// [`max_relative_deviation`] times the diagonal of the shape's bounding box (the bounding box of
/// its control points for patches, NURBS and subdivision meshes). Curved surfaces are sampled
/// so that no point of a triangle lies farther than `eps` from the true surface (a chord or
/// sagitta bound: analytic for quadrics; for patches and NURBS checked at every triangle's edge
/// midpoints and centroid, and refined until it holds; for subdivision surfaces estimated from
/// the measured displacement of each level, which shrinks about fourfold per level). `eps` is
/// never taken below `2^-20` of the shape's size, the resolution of `f32` output.
///
/// [`max_deviation`]: Tolerance::max_deviation
/// [`max_relative_deviation`]: Tolerance::max_relative_deviation
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct Tolerance {
    /// Largest distance from the triangles to the surface, in object units for [`tessellate`]
    /// and world units for [`tessellate_placed`] / [`tessellate_scene`]. `None`: no absolute
    /// bound.
    pub max_deviation: Option<f64>,
    /// Largest distance as a fraction of the shape's bounding-box diagonal. `None`: no relative
    /// bound.
    pub max_relative_deviation: Option<f64>,
    /// Most triangles one shape may produce. A shape that would need more is refused with
    /// [`TessellateError::TooManyTriangles`] before its triangles are allocated.
    pub max_triangles: u64,
    /// Most triangles [`tessellate_scene`] produces in all; shapes past it are skipped with
    /// [`TessellateError::TooManyTriangles`].
    pub max_scene_triangles: u64,
}

impl Default for Tolerance {
    /// 0.1 % of each shape's size, at most 4 million triangles per shape and 64 million per
    /// scene.
    fn default() -> Self {
        Tolerance {
            max_deviation: None,
            max_relative_deviation: Some(1e-3),
            max_triangles: 4_000_000,
            max_scene_triangles: 64_000_000,
        }
    }
}

impl Tolerance {
    /// An absolute bound (object or world units, see [`Tolerance::max_deviation`]) with the
    /// default caps.
    pub fn absolute(max_deviation: f64) -> Tolerance {
        Tolerance { max_deviation: Some(max_deviation), max_relative_deviation: None, ..Default::default() }
    }

    /// A bound relative to each shape's bounding-box diagonal, with the default caps.
    pub fn relative(fraction_of_size: f64) -> Tolerance {
        Tolerance {
            max_deviation: None,
            max_relative_deviation: Some(fraction_of_size),
            ..Default::default()
        }
    }

    /// The same tolerance with another per-shape triangle cap.
    pub fn with_max_triangles(self, max_triangles: u64) -> Tolerance {
        Tolerance { max_triangles, ..self }
    }

    /// Checks the fields: bounds must be finite and positive, at least one must be given.
    pub fn validate(&self) -> Result<(), TessellateError> {
        let check = |name: &str, value: Option<f64>| match value {
            Some(v) if !(v.is_finite() && v > 0.0) => {
                Err(TessellateError::InvalidTolerance(format!("{name} must be finite and > 0, got {v}")))
            }
            _ => Ok(()),
        };
        check("max_deviation", self.max_deviation)?;
        check("max_relative_deviation", self.max_relative_deviation)?;
        if self.max_deviation.is_none() && self.max_relative_deviation.is_none() {
            return Err(TessellateError::InvalidTolerance(
                "give max_deviation, max_relative_deviation or both".into(),
            ));
        }
        Ok(())
    }

    /// The deviation bound for a shape of bounding-box diagonal `size` (object units), with
    /// the absolute bound divided by `scale` (the largest stretch of the object-to-world
    /// transform; 1 in object space).
    pub(crate) fn effective(&self, size: f64, scale: f64) -> Result<f64, TessellateError> {
        self.validate()?;
        let size = if size.is_finite() && size > 0.0 { size } else { 1.0 };
        let mut eps = f64::INFINITY;
        if let Some(d) = self.max_deviation {
            let scale = if scale.is_finite() && scale > 0.0 { scale } else { 1.0 };
            eps = eps.min(d / scale);
        }
        if let Some(r) = self.max_relative_deviation {
            eps = eps.min(r * size);
        }
        // Below this the f32 output cannot represent the difference anyway.
        Ok(eps.max(size * (-20f64).exp2()))
    }
}

/// Why a shape gave no triangles.
#[derive(Clone, Debug, PartialEq, thiserror::Error)]
#[non_exhaustive]
pub enum TessellateError {
    /// A shape that is not a surface and has no triangles (no tessellator returns it today;
    /// `Points` and `Curves` become spheres and tubes).
    #[error("{kind} is not a surface and has no triangles")]
    NotASurface { kind: &'static str },
    /// The shape's data is inconsistent (counts, indices, knots).
    #[error("invalid {kind}: {reason}")]
    InvalidShape { kind: &'static str, reason: String },
    /// A position, parameter or weight is not finite, or a rational surface has a zero weight.
    #[error("{kind} has non-finite or degenerate numbers: {reason}")]
    NonFinite { kind: &'static str, reason: String },
    /// Meeting the tolerance would take more triangles than [`Tolerance::max_triangles`] allows.
    #[error(
        "{kind} would need about {estimated} triangles at this tolerance, more than the limit of {limit}"
    )]
    TooManyTriangles { kind: &'static str, estimated: u64, limit: u64 },
    /// A `SubdivisionMesh` scheme other than `"catmull-clark"`.
    #[error("unsupported subdivision scheme {0:?} (only \"catmull-clark\" is supported)")]
    UnsupportedScheme(String),
    /// The [`Tolerance`] itself is unusable.
    #[error("invalid tolerance: {0}")]
    InvalidTolerance(String),
}

impl TessellateError {
    /// True for [`TessellateError::NotASurface`]: a warning, not an error, for most consumers.
    pub fn is_not_a_surface(&self) -> bool {
        matches!(self, TessellateError::NotASurface { .. })
    }
}

/// Options that come from a shape's attributes rather than from the shape itself.
#[derive(Clone, Copy, Debug, Default, PartialEq, Eq)]
pub(crate) struct ShapeOptions {
    /// `Attribute "trimcurve" "sense" "outside"`: keep the outside of the trim loops.
    pub trim_keeps_outside: bool,
}

/// The RIB request name of a shape, for messages: the parser's name
/// (`rib_parser::summary::shape_kind`), but "polygon mesh" for all four polygon requests, which
/// the tessellator's messages name alike.
pub fn shape_kind(shape: &Shape) -> &'static str {
    match shape {
        Shape::Polygons(_) => "polygon mesh",
        other => rib_parser::summary::shape_kind(other),
    }
}

/// True for the quadrics (sphere, cylinder, cone, disk, paraboloid, hyperboloid, torus), which a
/// ray tracer may intersect exactly instead of tessellating.
pub fn is_quadric(shape: &Shape) -> bool {
    matches!(
        shape,
        Shape::Sphere { .. }
            | Shape::Cylinder { .. }
            | Shape::Cone { .. }
            | Shape::Disk { .. }
            | Shape::Paraboloid { .. }
            | Shape::Hyperboloid { .. }
            | Shape::Torus { .. }
    )
}

/// True for shapes that are surfaces in the RenderMan sense (everything but `Points` and
/// `Curves`, which [`tessellate`] still turns into spheres and tubes of their width).
pub fn is_surface(shape: &Shape) -> bool {
    !matches!(shape, Shape::Points(_) | Shape::Curves(_))
}

/// Tessellates one shape in its object space. See the [module docs](self) for the tolerance
/// and winding conventions.
///
/// `Points` become spheres and `Curves` round tubes (closed by flat caps) of their width, so
/// the haptics can touch them; the ray tracer renders curves as ribbons facing the eye
/// ([`curve_ribbons`]) and points as exact spheres. Returns an empty mesh for shapes that are
/// degenerate but valid (zero radius, zero sweep, a polygon with no area).
pub fn tessellate(shape: &Shape, tol: &Tolerance) -> Result<TriangleMesh, TessellateError> {
    tessellate_scaled(shape, tol, 1.0, ShapeOptions::default())
}

/// [`tessellate`] with the absolute bound divided by `scale` (the largest stretch of the
/// transform that will place the mesh) and attribute-derived options.
pub(crate) fn tessellate_scaled(
    shape: &Shape,
    tol: &Tolerance,
    scale: f64,
    options: ShapeOptions,
) -> Result<TriangleMesh, TessellateError> {
    tol.validate()?;
    let mesh = match shape {
        Shape::Points(points) => curves::tessellate_points(points, tol, scale)?,
        Shape::Curves(c) => curves::tessellate_curves(c, tol, scale)?,
        Shape::Polygons(polygons) => polygon::tessellate_polygons(polygons, tol)?,
        Shape::Patches(patches) => {
            patch::tessellate_patches(patches, tol, scale, &mut grid::RatePlanning::Free)?
        }
        Shape::NuPatch(nupatch) => {
            nurbs::tessellate_nupatch(nupatch, tol, scale, options, &mut grid::RatePlanning::Free)?
        }
        Shape::SubdivisionMesh(subdiv) => subdiv::tessellate_subdivision(subdiv, tol, scale)?,
        Shape::Blobby(blobby) => blobby::tessellate_blobby(blobby, tol, scale)?,
        quadric => quadric::tessellate_quadric(quadric, tol, scale)?,
    };
    mesh.check_finite(shape_kind(shape))?;
    Ok(mesh)
}

/// Checks a triangle estimate against the cap before allocating.
pub(crate) fn check_budget(
    kind: &'static str,
    estimated: f64,
    tol: &Tolerance,
) -> Result<(), TessellateError> {
    if !(estimated <= tol.max_triangles as f64) {
        let estimated = if estimated.is_finite() { estimated as u64 } else { u64::MAX };
        return Err(TessellateError::TooManyTriangles { kind, estimated, limit: tol.max_triangles });
    }
    Ok(())
}

/// Bounding-box diagonal of a set of points (0 for none); non-finite points are reported.
pub(crate) fn diagonal_of(
    kind: &'static str,
    points: impl Iterator<Item = DVec3>,
) -> Result<f64, TessellateError> {
    let mut lo = DVec3::splat(f64::INFINITY);
    let mut hi = DVec3::splat(f64::NEG_INFINITY);
    for p in points {
        if !p.is_finite() {
            return Err(TessellateError::NonFinite { kind, reason: format!("point {p}") });
        }
        lo = lo.min(p);
        hi = hi.max(p);
    }
    Ok(if lo.x <= hi.x { (hi - lo).length() } else { 0.0 })
}

#[cfg(test)]
mod tests;
