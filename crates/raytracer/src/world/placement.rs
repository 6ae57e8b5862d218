//! Placing a scene's shapes: tessellation at the camera's resolution (half a pixel of chord
//! error where the shape is), exact quadrics and spheres for `Points`, and the bottom-level BVH
//! builder they go into.

use super::*;
use glam::DVec4;
use rib_parser::scene::{AttributesId, Scene, Shape, ShapeEntity};
use tessellate::{
    RibbonFacing, SeamWelder, Tolerance, TriangleMesh, curve_ribbons, is_quadric, point_widths,
    tessellate_placed,
};

pub(super) struct BlasBuilder {
    pub(super) triangles: Vec<TrianglePrim>,
    pub(super) quadrics: Vec<QuadricPrim>,
    shapes: Vec<BlasShape>,
    meshes: Vec<MeshShading>,
    /// Triangles left out because a corner lies beyond `accel::MAX_BOX_COORD`.
    pub(super) far_triangles: usize,
}

/// A placed shape: triangles already in BLAS space, or a quadric in its object space.
pub(super) enum Geometry {
    Mesh(TriangleMesh),
    Quadric(Quadric),
    /// `Points`: exact spheres of their width, each with its object-from-sphere translation.
    Spheres(Vec<(Quadric, DMat4)>),
}

/// How large a pixel is at a distance from the eye: the tessellation of curved surfaces aims
/// at a chord error of half a pixel where the surface is (like RenderMan's shading rate).
#[derive(Clone, Copy, Debug, PartialEq)]
pub enum PixelFootprint {
    /// A perspective camera: one pixel spans this angle (radians, the smaller of x and y).
    Perspective { radians_per_pixel: f64 },
    /// An orthographic camera: one pixel spans this size in world units; every ray goes along
    /// `view_direction` (world space; ribbons face against it).
    Orthographic { size: f64, view_direction: DVec3 },
    /// No camera: tessellate relative to each shape's size only.
    Unknown,
}

impl PixelFootprint {
    /// The footprint at `distance` from the eye, 0 when the camera is not known.
    pub(super) fn width_at(&self, distance: f64) -> f64 {
        self.at(distance).unwrap_or(0.0)
    }

    fn at(&self, distance: f64) -> Option<f64> {
        let s = match *self {
            PixelFootprint::Perspective { radians_per_pixel } => radians_per_pixel * distance,
            PixelFootprint::Orthographic { size, .. } => size,
            PixelFootprint::Unknown => return None,
        };
        (s.is_finite() && s > 0.0).then_some(s)
    }
}

/// Chord error bounds of the tessellation relative to a shape's size: never coarser than 1%,
/// never finer than 1e-4 (and 2e-4 where the camera distance is not known: object definitions).
pub const TESSELLATION_COARSEST: f64 = 1e-2;
pub const TESSELLATION_FINEST: f64 = 1e-4;
pub const TESSELLATION_DEFAULT: f64 = 2e-4;

/// At most this many triangles in a world; shapes beyond it are skipped with a warning.
pub const MAX_WORLD_TRIANGLES: usize = 64_000_000;

/// Bounds of a shape's control points (object space), when it has any.
fn control_bounds(shape: &Shape) -> Option<(DVec3, DVec3)> {
    let points: Box<dyn Iterator<Item = DVec3> + '_> = match shape {
        Shape::Polygons(m) => Box::new(m.positions.iter().map(|p| p.as_dvec3())),
        Shape::SubdivisionMesh(m) => Box::new(m.positions.iter().map(|p| p.as_dvec3())),
        Shape::Patches(m) => {
            Box::new(m.positions.iter().filter(|p| p.w != 0.0).map(|p| (p.truncate() / p.w).as_dvec3()))
        }
        Shape::NuPatch(m) => {
            Box::new(m.positions.iter().filter(|p| p.w != 0.0).map(|p| (p.truncate() / p.w).as_dvec3()))
        }
        Shape::Blobby(_) => return tessellate::shape_bounds(shape),
        Shape::Curves(c) => Box::new(c.positions.iter().map(|p| p.as_dvec3())),
        _ => return None,
    };
    let mut lo = DVec3::splat(f64::INFINITY);
    let mut hi = DVec3::splat(f64::NEG_INFINITY);
    for p in points {
        if p.is_finite() {
            lo = lo.min(p);
            hi = hi.max(p);
        }
    }
    (lo.x <= hi.x).then_some((lo, hi))
}

/// The tessellation tolerance of a shape placed with `blas_from_object`: half a pixel at the
/// shape's nearest point to the eye (`eye_distance` from its bounds, when known), clamped to
/// [`TESSELLATION_FINEST`, `TESSELLATION_COARSEST`] of the shape's size.
pub(super) fn tolerance_for(
    shape: &Shape,
    blas_from_object: &DMat4,
    footprint: Option<&PixelFootprint>,
) -> Tolerance {
    let relative = Tolerance::relative(TESSELLATION_DEFAULT);
    let (Some(footprint), Some((lo, hi))) = (footprint, control_bounds(shape)) else { return relative };
    let (lo, hi) = transformed_box(blas_from_object, lo, hi);
    let (lo, hi) = (lo.as_dvec3(), hi.as_dvec3());
    let size = (hi - lo).length();
    if !(size > 0.0) || !size.is_finite() {
        return relative;
    }
    // Distance from the eye (the render-space origin) to the box.
    let distance = (DVec3::ZERO.clamp(lo, hi)).length();
    let Some(pixel) = footprint.at(distance) else { return relative };
    let eps = (0.5 * pixel).clamp(TESSELLATION_FINEST * size, TESSELLATION_COARSEST * size);
    Tolerance::absolute(eps)
}

/// One tolerance for every key of a deforming shape: the finest any key asks for, as an
/// absolute bound (a relative one would differ between keys of other sizes).
pub(super) fn common_tolerance(
    keys: &[Arc<Shape>],
    blas_from_object: &DMat4,
    footprint: Option<&PixelFootprint>,
) -> Tolerance {
    let mut eps = f64::INFINITY;
    for shape in keys {
        let t = tolerance_for(shape, blas_from_object, footprint);
        let size = control_bounds(shape).map(|(lo, hi)| {
            let (lo, hi) = transformed_box(blas_from_object, lo, hi);
            (hi - lo).length() as f64
        });
        let key_eps = match (t.max_deviation, t.max_relative_deviation, size) {
            (Some(d), _, _) => d,
            (None, Some(r), Some(size)) if size > 0.0 && size.is_finite() => r * size,
            _ => continue,
        };
        eps = eps.min(key_eps);
    }
    if eps.is_finite() && eps > 0.0 {
        Tolerance::absolute(eps)
    } else {
        Tolerance::relative(TESSELLATION_DEFAULT)
    }
}

/// Turns a scene shape into renderable geometry placed with `blas_from_object`, or says why it
/// is skipped. Quadrics are kept exact; everything else goes through rib-parser's tessellator.
pub(super) fn place_geometry(
    shape: &Shape,
    blas_from_object: &DMat4,
    footprint: Option<&PixelFootprint>,
) -> Result<Geometry, String> {
    place_geometry_with(shape, blas_from_object, footprint, tolerance_for(shape, blas_from_object, footprint))
}

/// [`place_geometry`] with the tessellation's tolerance given.
pub(super) fn place_geometry_with(
    shape: &Shape,
    blas_from_object: &DMat4,
    footprint: Option<&PixelFootprint>,
    tolerance: Tolerance,
) -> Result<Geometry, String> {
    // Under a projective transform (`Perspective` in the object's transform) a quadric is no
    // longer one the exact intersector knows, and a ray maps to a line whose parameter is not
    // preserved: such shapes are tessellated, which applies the transform exactly at every
    // vertex (`tessellate_placed`).
    let affine = blas_from_object.row(3) == DVec4::W;
    if is_quadric(shape) && affine {
        return Quadric::new(shape).map(Geometry::Quadric).map_err(|e| e.0.to_string());
    }
    if let Shape::Points(points) = shape
        && affine
    {
        return points_as_spheres(points);
    }
    let mesh = match shape {
        // Seen from the eye (the render-space origin), curves are ribbons facing it; in an
        // object definition, where no eye is known, round tubes.
        Shape::Curves(curves) if let Some(footprint) = footprint => {
            curve_ribbons(curves, blas_from_object, ribbon_facing(footprint), &tolerance)
                .map_err(|e| e.to_string())?
        }
        _ => tessellate_placed(shape, blas_from_object, false, &tolerance).map_err(|e| e.to_string())?,
    };
    if mesh.is_empty() {
        return Err("it has no area".into());
    }
    Ok(Geometry::Mesh(mesh))
}

/// Which way curve ribbons face for a camera: toward the eye (the render-space origin), or
/// against an orthographic camera's view direction.
pub(super) fn ribbon_facing(footprint: &PixelFootprint) -> RibbonFacing {
    match footprint {
        PixelFootprint::Orthographic { view_direction, .. } => RibbonFacing::Direction(-*view_direction),
        _ => RibbonFacing::Eye(DVec3::ZERO),
    }
}

/// `Points` as exact spheres of diameter `width` (RenderMan's default 1) around each point.
fn points_as_spheres(points: &rib_parser::scene::Points) -> Result<Geometry, String> {
    let mut spheres = Vec::with_capacity(points.positions.len());
    for (p, width) in points.positions.iter().zip(point_widths(points)) {
        let radius = (0.5 * width.abs()) as f32;
        if !(radius > 0.0 && radius.is_finite() && p.is_finite()) {
            continue;
        }
        let sphere = Shape::Sphere { radius, z_min: -radius, z_max: radius, theta_max_degrees: 360.0 };
        let q = Quadric::new(&sphere).map_err(|e| e.0.to_string())?;
        spheres.push((q, DMat4::from_translation(p.as_dvec3())));
    }
    if spheres.is_empty() {
        return Err("no point has a positive width".into());
    }
    Ok(Geometry::Spheres(spheres))
}

impl BlasBuilder {
    pub(super) fn new() -> BlasBuilder {
        BlasBuilder {
            triangles: Vec::new(),
            quadrics: Vec::new(),
            shapes: Vec::new(),
            meshes: Vec::new(),
            far_triangles: 0,
        }
    }

    /// Adds a placed shape (`blas_from_object` places quadrics; meshes are placed already);
    /// returns the BLAS shape index.
    pub(super) fn add(
        &mut self,
        geometry: &Geometry,
        blas_from_object: &DMat4,
        attributes: AttributesId,
        scene: &Scene,
    ) -> Option<u32> {
        let attrs = scene.attributes_of(attributes);
        let shape_index = self.shapes.len() as u32;
        match geometry {
            Geometry::Mesh(mesh) => {
                let first = self.triangles.len();
                for (i, t) in mesh.indices.iter().enumerate() {
                    let p = [
                        mesh.positions[t[0] as usize],
                        mesh.positions[t[1] as usize],
                        mesh.positions[t[2] as usize],
                    ];
                    // Zero-area and non-finite triangles can never be hit: leave them out.
                    if !(p[0].is_finite() && p[1].is_finite() && p[2].is_finite())
                        || (p[1] - p[0]).cross(p[2] - p[0]) == Vec3::ZERO
                    {
                        continue;
                    }
                    // A corner past the BVH's coordinate range (a control point at 1e30, say)
                    // would degrade the build; such a triangle is out of any f32 view anyway.
                    if p.iter().any(|v| v.abs().max_element() > crate::accel::MAX_BOX_COORD) {
                        self.far_triangles += 1;
                        continue;
                    }
                    self.triangles.push(TrianglePrim { p, shape: shape_index, index: i as u32 });
                }
                if self.triangles.len() == first {
                    return None;
                }
                self.meshes.push(MeshShading {
                    triangles: mesh.indices.clone(),
                    normals: mesh.normals.clone(),
                    st: mesh.st.clone(),
                });
                self.shapes.push(BlasShape {
                    attributes,
                    one_sided: attrs.sides == 1,
                    reverse: attrs.reverse_orientation,
                    mesh: Some(self.meshes.len() as u32 - 1),
                });
            }
            Geometry::Spheres(spheres) => {
                for (q, object_from_sphere) in spheres {
                    let blas_from_sphere = *blas_from_object * *object_from_sphere;
                    let sphere_from_blas = blas_from_sphere.inverse();
                    if !sphere_from_blas.is_finite() {
                        return None;
                    }
                    self.quadrics.push(QuadricPrim {
                        quadric: *q,
                        object_from_blas: sphere_from_blas,
                        blas_from_object: blas_from_sphere,
                        shape: shape_index,
                    });
                }
                self.shapes.push(BlasShape {
                    attributes,
                    one_sided: attrs.sides == 1,
                    reverse: attrs.reverse_orientation,
                    mesh: None,
                });
            }
            Geometry::Quadric(q) => {
                let object_from_blas = blas_from_object.inverse();
                if !object_from_blas.is_finite() {
                    return None;
                }
                self.quadrics.push(QuadricPrim {
                    quadric: *q,
                    object_from_blas,
                    blas_from_object: *blas_from_object,
                    shape: shape_index,
                });
                self.shapes.push(BlasShape {
                    attributes,
                    one_sided: attrs.sides == 1,
                    reverse: attrs.reverse_orientation,
                    mesh: None,
                });
            }
        }
        Some(shape_index)
    }

    /// Adds the BLAS shape of primitives pushed directly (a deforming shape's).
    pub(super) fn push_shape(&mut self, attributes: AttributesId, mesh: Option<MeshShading>, scene: &Scene) {
        let attrs = scene.attributes_of(attributes);
        let mesh = mesh.map(|m| {
            self.meshes.push(m);
            self.meshes.len() as u32 - 1
        });
        self.shapes.push(BlasShape {
            attributes,
            one_sided: attrs.sides == 1,
            reverse: attrs.reverse_orientation,
            mesh,
        });
    }

    pub(super) fn finish(self) -> Blas {
        self.finish_with(None)
    }

    /// The BLAS of a deforming shape: every primitive's box holds it at every key.
    pub(super) fn finish_deforming(self, deforming: deformation::Deforming) -> Blas {
        self.finish_with(Some(Box::new(deforming)))
    }

    fn finish_with(self, deforming: Option<Box<deformation::Deforming>>) -> Blas {
        let mut boxes = Vec::with_capacity(self.triangles.len() + self.quadrics.len());
        let mut refs = Vec::with_capacity(boxes.capacity());
        for (i, t) in self.triangles.iter().enumerate() {
            let keyed = deforming.as_ref().and_then(|d| d.triangle_box(t.index));
            boxes.push(keyed.unwrap_or((t.p[0].min(t.p[1]).min(t.p[2]), t.p[0].max(t.p[1]).max(t.p[2]))));
            refs.push(Prim::Triangle(i as u32));
        }
        for (i, q) in self.quadrics.iter().enumerate() {
            let keyed = deforming.as_ref().and_then(|d| d.quadric_box(i));
            boxes.push(keyed.unwrap_or_else(|| {
                transformed_box(&q.blas_from_object, q.quadric.bounds_min, q.quadric.bounds_max)
            }));
            refs.push(Prim::Quadric(i as u32));
        }
        let mut bounds = (Vec3::splat(f32::INFINITY), Vec3::splat(f32::NEG_INFINITY));
        for b in &boxes {
            bounds.0 = bounds.0.min(b.0);
            bounds.1 = bounds.1.max(b.1);
        }
        let bvh = Bvh::build(&boxes);
        // Store triangles in BVH order for locality; quadrics stay indexed.
        let mut triangles = Vec::with_capacity(self.triangles.len());
        let mut prims = Vec::with_capacity(bvh.order().len());
        for &i in bvh.order() {
            match refs[i as usize] {
                Prim::Triangle(t) => {
                    prims.push(Prim::Triangle(triangles.len() as u32));
                    triangles.push(self.triangles[t as usize]);
                }
                q @ Prim::Quadric(_) => prims.push(q),
            }
        }
        Blas {
            bvh,
            prims,
            triangles,
            rows: Vec::new(),
            quadrics: self.quadrics,
            shapes: self.shapes,
            meshes: self.meshes,
            bounds,
            csg: None,
            deforming,
        }
    }
}

/// A seam welder for the shapes of an object definition, in their BLAS space (the
/// definition's), over their bounds; `None` when no shape has bounds.
pub(super) fn definition_seams(shapes: &[ShapeEntity]) -> Option<SeamWelder> {
    let mut bounds: Option<(DVec3, DVec3)> = None;
    for entity in shapes {
        let Some((lo, hi)) = tessellate::shape_bounds(&entity.shape) else { continue };
        let (lo, hi) = transformed_box(&entity.world_from_object, lo, hi);
        let (lo, hi) = (lo.as_dvec3(), hi.as_dvec3());
        bounds = Some(bounds.map_or((lo, hi), |(a, b)| (a.min(lo), b.max(hi))));
    }
    bounds.filter(|(lo, hi)| lo.is_finite() && hi.is_finite()).map(|(lo, hi)| SeamWelder::new(lo, hi))
}

/// Bounds of the transformed box (all eight corners in `f64`, rounded outward).
pub(super) fn transformed_box(m: &DMat4, lo: DVec3, hi: DVec3) -> (Vec3, Vec3) {
    let mut bmin = DVec3::splat(f64::INFINITY);
    let mut bmax = DVec3::splat(f64::NEG_INFINITY);
    for i in 0..8 {
        let c = DVec3::new(
            if i & 1 == 0 { lo.x } else { hi.x },
            if i & 2 == 0 { lo.y } else { hi.y },
            if i & 4 == 0 { lo.z } else { hi.z },
        );
        // A projective `m` (whose denominator keeps one sign over the box, else the shape
        // reaches infinity) maps the box into the hull of its corners' images.
        let p = if m.row(3) == DVec4::W { m.transform_point3(c) } else { m.project_point3(c) };
        bmin = bmin.min(p);
        bmax = bmax.max(p);
    }
    let pad = (bmax - bmin).abs() * 1e-9 + bmin.abs().max(bmax.abs()) * 1e-12;
    let lo = (bmin - pad).as_vec3();
    let hi = (bmax + pad).as_vec3();
    (
        Vec3::new(
            crate::math::next_float_down(lo.x),
            crate::math::next_float_down(lo.y),
            crate::math::next_float_down(lo.z),
        ),
        Vec3::new(
            crate::math::next_float_up(hi.x),
            crate::math::next_float_up(hi.y),
            crate::math::next_float_up(hi.z),
        ),
    )
}

#[cfg(test)]
mod tests {
    use crate::diagnostics::Diagnostics;
    use crate::world::{PixelFootprint, Prim, World};
    use glam::DVec3;

    /// The traversal's shortcut for BLASes of triangles alone relies on this: there, BVH slot
    /// `k` holds triangle `k` (for the world's BLAS, a one-triangle definition with its
    /// duplicate slot, and a definition mixing a quadric and triangles, which keeps `prims`).
    #[test]
    fn triangle_only_blases_hold_triangle_k_in_slot_k() {
        let mut rib = String::from("WorldBegin\n");
        for i in 0..40 {
            let (x, z) = ((i % 7) as f32, (i / 7) as f32);
            rib += &format!("Polygon \"P\" [{x} 0 {z} {} 0 {z} {x} 1 {}]\n", x + 1.5, z + 0.5);
        }
        rib += "ObjectBegin 1\nSphere 1 -1 1 360\nPolygon \"P\" [0 0 0 1 0 0 0 1 0]\n\
                Polygon \"P\" [0 0 1 1 0 1 0 1 1]\nObjectEnd\n\
                ObjectBegin 2\nPolygon \"P\" [0 0 0 1 0 0 0 1 0]\nObjectEnd\n\
                ObjectInstance 1\nObjectInstance 2\nWorldEnd\n";
        let scene = rib_parser::load_bytes("slots.rib", rib.into_bytes(), &Default::default())
            .unwrap_or_else(|e| panic!("{}", e.render()))
            .scene;
        let world = World::build(
            &scene,
            DVec3::new(0.0, 0.0, -5.0),
            PixelFootprint::Unknown,
            &mut Diagnostics::default(),
        )
        .expect("the world builds");
        let (mut triangles_only, mut mixed) = (0, 0);
        for blas in &world.blases {
            if blas.quadrics.is_empty() {
                triangles_only += 1;
                for (k, prim) in blas.prims.iter().enumerate() {
                    assert_eq!(*prim, Prim::Triangle(k as u32));
                }
                assert_eq!(blas.prims.len(), blas.triangles.len());
            } else {
                mixed += 1;
            }
        }
        assert_eq!((triangles_only, mixed), (2, 1));
    }
}
