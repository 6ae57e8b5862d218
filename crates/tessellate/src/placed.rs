//! Placing tessellations in the world: transforms in `f64`, RenderMan orientation, and the
//! scene-level walk over shapes and object instances.

use super::dice::DicingRule;
use super::displace::{Displaced, DisplacementShader, tessellate_displaced_with};
use super::seam::SeamWelder;
use super::{ShapeOptions, TessellateError, Tolerance, TriangleMesh, blobby, tessellate_scaled};
use glam::{DMat3, DMat4, DVec3, DVec4, Vec3};
use rib_parser::scene::{Attributes, AttributesId, FileLoc, ObjectId, Scene, Shape, ShapeEntity};

/// Where a world-space mesh came from.
#[derive(Clone, Copy, Debug, PartialEq, Eq, Hash)]
pub enum MeshOrigin {
    /// `scene.shapes[index]`.
    Shape { index: usize },
    /// Shape `shape` of `scene.objects[object]`, placed by `scene.instances[instance]`.
    Instance { instance: usize, object: ObjectId, shape: usize },
}

/// One shape's triangles in world space.
#[derive(Clone, Debug, PartialEq)]
pub struct WorldMesh {
    /// Positions and normals in world space; winding and normals follow the orientation rules
    /// of the [module docs](super).
    pub mesh: TriangleMesh,
    pub origin: MeshOrigin,
    /// The attribute state to shade and orient the shape with: the one it was made under, or
    /// for an instanced shape its state in that instance
    /// ([`ObjectInstanceEntity::shape_attributes`](rib_parser::scene::ObjectInstanceEntity::shape_attributes)).
    pub attributes: AttributesId,
    /// For an instanced shape, the attribute state current at its `ObjectInstance`.
    pub instance_attributes: Option<AttributesId>,
    /// The full transform applied (`world_from_instance * world_from_object` for instances).
    pub world_from_object: DMat4,
    /// Whether the normals were flipped from `world_from_object^-T * n_object`: the
    /// `reverse_orientation` of [`WorldMesh::attributes`].
    pub reverse_orientation: bool,
    pub loc: FileLoc,
}

/// A shape that gave no triangles, and why.
#[derive(Clone, Debug, PartialEq)]
pub struct SkippedShape {
    pub origin: MeshOrigin,
    pub attributes: AttributesId,
    pub loc: FileLoc,
    pub error: TessellateError,
}

/// Everything [`tessellate_scene`] produced.
#[derive(Clone, Debug, Default, PartialEq)]
pub struct SceneMeshes {
    pub meshes: Vec<WorldMesh>,
    /// Shapes left out: `Points` and `Curves` ([`TessellateError::is_not_a_surface`]), invalid
    /// shapes, shapes over the triangle budget, shapes the filter excluded are not listed.
    pub skipped: Vec<SkippedShape>,
    /// Textures `bumpy` names that could not be read (each once; they read 0).
    pub unreadable_textures: Vec<String>,
}

impl SceneMeshes {
    pub fn triangle_count(&self) -> u64 {
        self.meshes.iter().map(|m| m.mesh.triangle_count() as u64).sum()
    }
}

/// Tessellates `shape` and places it with `world_from_object` (in `f64`). The absolute
/// tolerance is in world units: the shape is tessellated in object space with
/// `max_deviation / s`, where `s` is the largest stretch (spectral norm) of the transform's
/// linear part. Normals become `world_from_object^-T * n`, flipped when
/// `reverse_orientation`; triangles are re-wound to stay counter-clockwise around them.
///
/// A singular transform (zero scale) gives flattened triangles and no normals. A projective
/// transform (a `Perspective` in the object's transform, as RenderMan allows) is applied
/// exactly to positions and through its Jacobian to normals; its tolerance scale is a bound of
/// the Jacobian's stretch over the shape's bounds ([`largest_stretch`]).
pub fn tessellate_placed(
    shape: &Shape,
    world_from_object: &DMat4,
    reverse_orientation: bool,
    tol: &Tolerance,
) -> Result<TriangleMesh, TessellateError> {
    place(shape, world_from_object, reverse_orientation, tol, ShapeOptions::default())
}

pub(crate) fn place(
    shape: &Shape,
    world_from_object: &DMat4,
    reverse_orientation: bool,
    tol: &Tolerance,
    options: ShapeOptions,
) -> Result<TriangleMesh, TessellateError> {
    let kind = super::shape_kind(shape);
    if !world_from_object.is_finite() {
        return Err(TessellateError::NonFinite { kind, reason: "the transform is not finite".into() });
    }
    let scale = largest_stretch(world_from_object, shape);
    let mut mesh = tessellate_scaled(shape, tol, scale, options)?;
    transform_mesh(&mut mesh, world_from_object, reverse_orientation);
    mesh.check_finite(kind)?;
    Ok(mesh)
}

/// The most `m` stretches any short object-space segment of `shape`: the spectral norm of
/// its linear part when it is affine. A projective `m` maps `p` to `p' = (A p + t) / h(p)`
/// with `h` linear, whose Jacobian `(A - p' w^T) / h` (`w` the bottom row's first three
/// entries) is bounded over the shape's bounding box by `(|A| + max |p'| |w|) / min |h|`;
/// both extremes lie at the box's corners while `h` keeps one sign there (`h` is linear, and
/// the image of the box is the hull of its corners' images). Where `h` changes sign in the
/// box the surface reaches infinity and no bound exists: the linear part's norm is used.
pub(crate) fn largest_stretch(m: &DMat4, shape: &Shape) -> f64 {
    let linear_norm = spectral_norm(&DMat3::from_mat4(*m));
    let row3 = m.row(3);
    if row3 == DVec4::W {
        return linear_norm;
    }
    let Some((lo, hi)) = shape_bounds(shape) else { return linear_norm };
    let (mut min_h, mut max_h, mut max_projected) = (f64::INFINITY, f64::NEG_INFINITY, 0f64);
    for i in 0..8 {
        let corner = DVec3::new(
            if i & 1 == 0 { lo.x } else { hi.x },
            if i & 2 == 0 { lo.y } else { hi.y },
            if i & 4 == 0 { lo.z } else { hi.z },
        );
        let h = row3.truncate().dot(corner) + row3.w;
        min_h = min_h.min(h);
        max_h = max_h.max(h);
        max_projected = max_projected.max(m.project_point3(corner).length());
    }
    let nearest_h = if min_h > 0.0 { min_h } else { -max_h };
    let bound = (linear_norm + max_projected * row3.truncate().length()) / nearest_h;
    if nearest_h > 0.0 && bound.is_finite() { bound } else { linear_norm }
}

/// Applies `m` to positions and normals and fixes winding and normal sides.
pub(crate) fn transform_mesh(mesh: &mut TriangleMesh, m: &DMat4, reverse_orientation: bool) {
    let linear = DMat3::from_mat4(*m);
    let row3 = m.row(3);
    let affine = row3 == DVec4::new(0.0, 0.0, 0.0, 1.0);
    // The Jacobian of the (projective) transform at an object-space point.
    let jacobian = |p: DVec3| -> DMat3 {
        let h = row3.truncate().dot(p) + row3.w;
        let projected = m.project_point3(p);
        let w = row3.truncate();
        // d/dp of (A p + t) / h = (A - p' w^T) / h.
        let outer = DMat3::from_cols(projected * w.x, projected * w.y, projected * w.z);
        (linear - outer) * (1.0 / h)
    };
    let singular = |j: &DMat3| !(j.determinant().abs() > 1e-300);
    if affine {
        // One Jacobian for the whole mesh: its cofactor, sign and winding decision are computed
        // once instead of per vertex and per triangle (the same operations, so the same bits).
        transform_mesh_affine(mesh, m, &linear, reverse_orientation, singular(&linear));
        return;
    }

    let object_positions: Vec<DVec3> = mesh.positions.iter().map(|p| p.as_dvec3()).collect();
    for (out, &p) in mesh.positions.iter_mut().zip(&object_positions) {
        *out = m.project_point3(p).as_vec3();
    }
    let mut any_singular = false;
    if let Some(normals) = mesh.normals.as_mut() {
        for (n, &p) in normals.iter_mut().zip(&object_positions) {
            let j = jacobian(p);
            if singular(&j) {
                any_singular = true;
                break;
            }
            if !place_normal(n, &cofactor(&j), j.determinant().signum(), reverse_orientation) {
                any_singular = true;
                break;
            }
        }
    }
    if any_singular {
        mesh.normals = None;
    }
    for tri in &mut mesh.indices {
        let det = jacobian(object_positions[tri[0] as usize]).determinant();
        if (det < 0.0) != reverse_orientation {
            tri.swap(1, 2);
        }
    }
}

/// [`transform_mesh`] for an affine `m` whose linear part is `linear`.
fn transform_mesh_affine(
    mesh: &mut TriangleMesh,
    m: &DMat4,
    linear: &DMat3,
    reverse_orientation: bool,
    linear_singular: bool,
) {
    for p in mesh.positions.iter_mut() {
        *p = m.transform_point3(p.as_dvec3()).as_vec3();
    }
    let det = linear.determinant();
    let mut any_singular = linear_singular;
    if let Some(normals) = mesh.normals.as_mut()
        && !linear_singular
    {
        let (cof, sign) = (cofactor(linear), det.signum());
        for n in normals.iter_mut() {
            if !place_normal(n, &cof, sign, reverse_orientation) {
                any_singular = true;
                break;
            }
        }
    }
    if any_singular {
        mesh.normals = None;
    }
    if (det < 0.0) != reverse_orientation {
        for tri in &mut mesh.indices {
            tri.swap(1, 2);
        }
    }
}

/// Maps an object-space normal by the Jacobian's `cofactor` and determinant `sign`, flipped for
/// reversed orientation; false when it degenerates to zero.
fn place_normal(n: &mut Vec3, cofactor: &DMat3, sign: f64, reverse_orientation: bool) -> bool {
    let world = *cofactor * n.as_dvec3() * sign;
    let world = if reverse_orientation { -world } else { world };
    *n = world.normalize_or_zero().as_vec3();
    *n != Vec3::ZERO
}

/// `det(a) * a^-T`, defined for singular matrices too.
fn cofactor(a: &DMat3) -> DMat3 {
    DMat3::from_cols(a.y_axis.cross(a.z_axis), a.z_axis.cross(a.x_axis), a.x_axis.cross(a.y_axis))
}

/// The largest singular value of `a`: the most it stretches any vector.
pub(crate) fn spectral_norm(a: &DMat3) -> f64 {
    // Largest eigenvalue of the symmetric a^T a, in closed form (trigonometric method).
    let s = a.transpose() * *a;
    let (a00, a11, a22) = (s.x_axis.x, s.y_axis.y, s.z_axis.z);
    let (a01, a02, a12) = (s.y_axis.x, s.z_axis.x, s.z_axis.y);
    let p1 = a01 * a01 + a02 * a02 + a12 * a12;
    let q = (a00 + a11 + a22) / 3.0;
    let largest = if p1 == 0.0 {
        a00.max(a11).max(a22)
    } else {
        let p2 = (a00 - q).powi(2) + (a11 - q).powi(2) + (a22 - q).powi(2) + 2.0 * p1;
        let p = (p2 / 6.0).sqrt();
        let b = (s - DMat3::from_diagonal(DVec3::splat(q))) * (1.0 / p);
        let r = (b.determinant() / 2.0).clamp(-1.0, 1.0);
        q + 2.0 * p * (r.acos() / 3.0).cos()
    };
    largest.max(0.0).sqrt()
}

/// How finely [`tessellate_scene`] dices displaced shapes, where no camera is known: edges of
/// at most 1/128 of the shape's bounding-box diagonal.
pub const SCENE_DICING: DicingRule = DicingRule::RelativeToSize(1.0 / 128.0);

/// Tessellates every [`ShapeEntity`] of the scene and every shape of every object instance,
/// in world space (see [`tessellate_placed`] for the transform and tolerance rules). Surfaces
/// with a standard displacement shader are displaced (see [`crate::tessellate_displaced`]),
/// diced by [`SCENE_DICING`]; `bumpy` reads its texture as the ray tracer does
/// ([`crate::DisplacementTextures`]), so the haptics touch the surface that is drawn.
pub fn tessellate_scene(scene: &Scene, tol: &Tolerance) -> SceneMeshes {
    tessellate_scene_filtered(scene, tol, |_| true)
}

/// [`tessellate_scene`] for the shapes `keep` accepts; e.g. a ray tracer that intersects
/// quadrics exactly passes `|s| !tessellate::is_quadric(s)`.
pub fn tessellate_scene_filtered(
    scene: &Scene,
    tol: &Tolerance,
    keep: impl Fn(&Shape) -> bool,
) -> SceneMeshes {
    let mut out = SceneMeshes::default();
    let mut total: u64 = 0;
    // Separate patches that share an edge get bitwise-equal vertices along it.
    let mut seams = scene_bounds(scene).map(|(lo, hi)| SeamWelder::new(lo, hi));
    let attributes = |id: AttributesId| scene.attributes.get(id.0 as usize);
    let textures = crate::DisplacementTextures::new(scene);
    let texture = |name: &str, st: glam::Vec2| textures.value(name, st);
    let mut unreadable_textures: Vec<String> = Vec::new();
    let mut visit = |origin: MeshOrigin,
                     entity: &ShapeEntity,
                     world_from_object: DMat4,
                     shape_attributes: AttributesId,
                     instance_attributes: Option<AttributesId>,
                     world_from_definition: DMat4| {
        if !keep(&entity.shape) {
            return;
        }
        let own = attributes(shape_attributes);
        let reverse = own.is_some_and(|a| a.reverse_orientation);
        let options = ShapeOptions { trim_keeps_outside: own.is_some_and(trim_keeps_outside) };
        let skip =
            |error| SkippedShape { origin, attributes: shape_attributes, loc: entity.loc.clone(), error };
        if total >= tol.max_scene_triangles {
            out.skipped.push(skip(TessellateError::TooManyTriangles {
                kind: super::shape_kind(&entity.shape),
                estimated: total,
                limit: tol.max_scene_triangles,
            }));
            return;
        }
        // Leave the scene budget's remainder as this shape's limit.
        let local = tol.with_max_triangles(tol.max_triangles.min(tol.max_scene_triangles - total));
        let placed = match own.map(DisplacementShader::from_attributes) {
            Some(Ok(Some(shader))) if !shader.is_identity() && super::is_surface(&entity.shape) => {
                // The shader space of a shape in an object definition is the definition's.
                let shader = match shader {
                    DisplacementShader::Dented { km, world_from_shader } => DisplacementShader::Dented {
                        km,
                        world_from_shader: world_from_definition * world_from_shader,
                    },
                    other => other,
                };
                let displaced = Displaced {
                    shader: &shader,
                    world_from_placed: DMat4::IDENTITY,
                    texture: &texture,
                    dicing: SCENE_DICING,
                };
                tessellate_displaced_with(
                    &entity.shape,
                    &world_from_object,
                    reverse,
                    &local,
                    &displaced,
                    options,
                )
                .map(|d| {
                    for name in d.unreadable_textures {
                        if !unreadable_textures.contains(&name) {
                            unreadable_textures.push(name);
                        }
                    }
                    d.mesh
                })
            }
            _ => place(&entity.shape, &world_from_object, reverse, &local, options),
        };
        match placed {
            Ok(mut mesh) => {
                if let Some(seams) = seams.as_mut().filter(|_| SeamWelder::applies_to(&entity.shape)) {
                    seams.weld(&mut mesh);
                }
                total += mesh.triangle_count() as u64;
                out.meshes.push(WorldMesh {
                    mesh,
                    origin,
                    attributes: shape_attributes,
                    instance_attributes,
                    world_from_object,
                    reverse_orientation: reverse,
                    loc: entity.loc.clone(),
                });
            }
            Err(error) => out.skipped.push(skip(error)),
        }
    };
    for (index, entity) in scene.shapes.iter().enumerate() {
        visit(
            MeshOrigin::Shape { index },
            entity,
            entity.world_from_object,
            entity.attributes,
            None,
            DMat4::IDENTITY,
        );
    }
    for (instance, inst) in scene.instances.iter().enumerate() {
        let Some(def) = scene.objects.get(inst.object.0 as usize) else { continue };
        for (shape, entity) in def.shapes.iter().enumerate() {
            let m = inst.world_from_instance * entity.world_from_object;
            // The state resolved for this shape in this instance (the builder replays the
            // definition's attribute requests over the instance's state).
            let resolved = inst.shape_attributes.get(shape).copied().unwrap_or(entity.attributes);
            let origin = MeshOrigin::Instance { instance, object: inst.object, shape };
            visit(origin, entity, m, resolved, Some(inst.attributes), inst.world_from_instance);
        }
    }
    out.unreadable_textures = unreadable_textures;
    out
}

/// `Attribute "trimcurve" "sense" "outside"` in effect.
fn trim_keeps_outside(a: &Attributes) -> bool {
    a.user
        .iter()
        .rev()
        .filter(|call| call.namespace == "trimcurve")
        .find_map(|call| call.params.string("sense"))
        .is_some_and(|s| s.eq_ignore_ascii_case("outside"))
}

/// Object-space bounds of a surface shape: of its control points for polygons, patches, NURBS
/// and subdivision meshes (the surface lies within them for B-spline and Bezier bases, near
/// them for others), of the full revolution for quadrics, of the primitives' supports for
/// `Blobby`, of the positions grown by half the widest width for `Points` and `Curves` (the
/// control points of a cubic curve hold it for B-spline and Bezier bases). `None` for empty or
/// non-finite shapes.
pub fn shape_bounds(shape: &Shape) -> Option<(DVec3, DVec3)> {
    let from_points = |points: &mut dyn Iterator<Item = DVec3>| {
        let mut lo = DVec3::splat(f64::INFINITY);
        let mut hi = DVec3::splat(f64::NEG_INFINITY);
        for p in points {
            lo = lo.min(p);
            hi = hi.max(p);
        }
        (lo.is_finite() && hi.is_finite()).then_some((lo, hi))
    };
    let ring = |rho: f64, z0: f64, z1: f64| {
        let rho = rho.abs();
        from_points(&mut [DVec3::new(-rho, -rho, z0), DVec3::new(rho, rho, z1)].into_iter())
    };
    let homogeneous = |p: &glam::Vec4| (p.w != 0.0).then(|| p.truncate().as_dvec3() / p.w as f64);
    match shape {
        Shape::Sphere { radius, z_min, z_max, .. } => {
            let r = radius.abs() as f64;
            // A NaN radius has no bounds (and would make `clamp` panic).
            if !r.is_finite() {
                return None;
            }
            ring(r, (*z_min as f64).clamp(-r, r), (*z_max as f64).clamp(-r, r))
        }
        Shape::Cylinder { radius, z_min, z_max, .. } => ring(*radius as f64, *z_min as f64, *z_max as f64),
        Shape::Cone { height, radius, .. } => ring(*radius as f64, 0.0, *height as f64),
        Shape::Disk { height, radius, .. } => ring(*radius as f64, *height as f64, *height as f64),
        Shape::Paraboloid { r_max, z_min, z_max, .. } => ring(*r_max as f64, *z_min as f64, *z_max as f64),
        Shape::Hyperboloid { point1, point2, .. } => {
            let rho = point1.truncate().length().max(point2.truncate().length()) as f64;
            ring(rho, point1.z as f64, point2.z as f64)
        }
        Shape::Torus { major_radius, minor_radius, .. } => {
            let (big, small) = (major_radius.abs() as f64, minor_radius.abs() as f64);
            ring(big + small, -small, small)
        }
        Shape::Polygons(p) => from_points(
            &mut p.vertex_indices.iter().filter_map(|&i| p.positions.get(i as usize)).map(|p| p.as_dvec3()),
        ),
        Shape::Patches(p) => from_points(&mut p.positions.iter().filter_map(homogeneous)),
        Shape::NuPatch(p) => from_points(&mut p.positions.iter().filter_map(homogeneous)),
        Shape::SubdivisionMesh(s) => from_points(&mut s.positions.iter().map(|p| p.as_dvec3())),
        Shape::Blobby(b) => blobby::BlobbyField::new(b).ok().and_then(|f| f.bounds),
        Shape::Points(p) => {
            let half =
                p.positions.iter().zip(super::point_widths(p)).map(|(&q, w)| (q.as_dvec3(), 0.5 * w.abs()));
            let mut lo = DVec3::splat(f64::INFINITY);
            let mut hi = DVec3::splat(f64::NEG_INFINITY);
            for (q, r) in half {
                lo = lo.min(q - DVec3::splat(r));
                hi = hi.max(q + DVec3::splat(r));
            }
            (lo.x <= hi.x && lo.is_finite() && hi.is_finite()).then_some((lo, hi))
        }
        Shape::Curves(c) => {
            let w = c.primvars.float("constantwidth").map(f64::from).unwrap_or_else(|| {
                c.primvars
                    .floats("width")
                    .map_or(1.0, |v| v.iter().fold(0.0f64, |m, &x| m.max(f64::from(x).abs())))
            });
            from_points(&mut c.positions.iter().map(|p| p.as_dvec3()))
                .map(|(lo, hi)| (lo - DVec3::splat(0.5 * w), hi + DVec3::splat(0.5 * w)))
        }
    }
}

/// World-space bounds of every surface of the scene, object instances included (the corners
/// of each shape's [`shape_bounds`] transformed). A scene-wide absolute tolerance is then, for
/// example, `Tolerance::absolute(1e-4 * (hi - lo).length())`: unlike the per-shape relative
/// bound it does not spend as many triangles on a small patch as on a large one.
pub fn scene_bounds(scene: &Scene) -> Option<(DVec3, DVec3)> {
    let mut lo = DVec3::splat(f64::INFINITY);
    let mut hi = DVec3::splat(f64::NEG_INFINITY);
    let mut add = |shape: &Shape, m: &DMat4| {
        let Some((a, b)) = shape_bounds(shape) else { return };
        for k in 0..8 {
            let corner = DVec3::new(
                if k & 1 == 0 { a.x } else { b.x },
                if k & 2 == 0 { a.y } else { b.y },
                if k & 4 == 0 { a.z } else { b.z },
            );
            let p = m.project_point3(corner);
            if p.is_finite() {
                lo = lo.min(p);
                hi = hi.max(p);
            }
        }
    };
    for e in &scene.shapes {
        add(&e.shape, &e.world_from_object);
    }
    for inst in &scene.instances {
        if let Some(def) = scene.objects.get(inst.object.0 as usize) {
            for e in &def.shapes {
                add(&e.shape, &(inst.world_from_instance * e.world_from_object));
            }
        }
    }
    (lo.x <= hi.x).then_some((lo, hi))
}
