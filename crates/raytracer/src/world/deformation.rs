//! Deformation motion blur in the world: a shape whose keys (`MotionBegin` around one geometry
//! request per time) differ while the shutter is open gets a BLAS of its own holding every key,
//! and each ray meets the shape interpolated at its time, as PRMan and pbrt render it.
//!
//! - Meshes (polygons, patches, NURBS, subdivision surfaces, curves): every key is tessellated
//!   with one tolerance; when the keys' meshes have the same triangles (vertex `i` of one is
//!   vertex `i` of the others) the triangle at a ray's time has the keys' vertices interpolated
//!   linearly and is tested watertight like any other (shared vertices interpolate to the same
//!   bits, so the deforming mesh stays closed). Patches, NURBS, subdivision surfaces and
//!   Blobby, whose tessellations adapt to their positions, are tessellated by
//!   `tessellate_placed_keys`: the key that needs the most triangles chooses the rates
//!   (parameters, refined faces) of every key, or, for a Blobby, its vertices are carried
//!   onto the other keys' isosurfaces.
//!   Keys whose tessellations still differ are drawn at shutter open, with a warning.
//! - Quadrics and `Points` spheres: their parameters (radius, heights, sweep, centre) are
//!   interpolated and the quadric at the ray's time is solved exactly.
//! - Bounds: a triangle's box holds every key's vertices (a vertex moves on a segment between
//!   keys, inside that box); a quadric's box holds every key's full-sweep box built from the
//!   largest radius and the extreme heights of the keys, which holds every interpolated quadric.
//!
//! The BLAS stores the shape at shutter open in its ordinary triangles and quadrics (read by
//! the code that needs no time), so the depth table (the pinhole ray at shutter open) sees that
//! shape, as the haptics do.

use super::placement::{
    BlasBuilder, Geometry, PixelFootprint, common_tolerance, place_geometry_with, ribbon_facing,
    transformed_box,
};
use super::*;
use rib_parser::deformation::{Deformation, key_segment, lerp_shape};
use rib_parser::scene::{Scene, Shape};
use tessellate::{curve_ribbons_keys, is_quadric, tessellate_placed_keys};

/// The keys of a deforming BLAS (one shape), aligned with its triangles (by their mesh index)
/// and quadrics (by index).
#[derive(Debug)]
pub(super) struct Deforming {
    /// Key times as shutter fractions, non-decreasing.
    times: Vec<f64>,
    mesh: Option<KeyedMesh>,
    quadrics: Vec<KeyedQuadric>,
}

#[derive(Debug)]
struct KeyedMesh {
    triangles: Vec<[u32; 3]>,
    /// Each key's vertex positions (BLAS space).
    positions: Vec<Vec<Vec3>>,
    /// Each key's vertex normals, when the mesh has them.
    normals: Option<Vec<Vec<Vec3>>>,
}

#[derive(Debug)]
struct KeyedQuadric {
    /// Each key's quadric (object space) and its placement in the BLAS.
    shapes: Vec<Shape>,
    blas_from_object: Vec<DMat4>,
    shape: u32,
}

#[inline]
fn lerp3(a: Vec3, b: Vec3, f: f64) -> Vec3 {
    (a.as_dvec3() * (1.0 - f) + b.as_dvec3() * f).as_vec3()
}

impl Deforming {
    /// The vertices of the mesh's triangle `index` at shutter fraction `time`.
    #[inline]
    pub(super) fn triangle(&self, index: u32, time: f32) -> Option<[Vec3; 3]> {
        let mesh = self.mesh.as_ref()?;
        let v = mesh.triangles[index as usize];
        let (i, j, f) = key_segment(&self.times, f64::from(time));
        let (a, b) = (&mesh.positions[i], &mesh.positions[j]);
        Some(v.map(|k| if f == 0.0 { a[k as usize] } else { lerp3(a[k as usize], b[k as usize], f) }))
    }

    /// The interpolated vertex normal of the mesh's triangle `index` at barycentric `bw` and
    /// shutter fraction `time`.
    pub(super) fn normal(&self, index: u32, bw: [f32; 3], time: f32) -> Option<Vec3> {
        let mesh = self.mesh.as_ref()?;
        let normals = mesh.normals.as_ref()?;
        let v = mesh.triangles[index as usize];
        let (i, j, f) = key_segment(&self.times, f64::from(time));
        let at = |k: usize| lerp3(normals[i][v[k] as usize], normals[j][v[k] as usize], f);
        let n = at(0) * bw[0] + at(1) * bw[1] + at(2) * bw[2];
        (n.length_squared() > 0.0 && n.is_finite()).then_some(n)
    }

    /// Quadric `i` at shutter fraction `time`, or `None` where it is degenerate then (a radius
    /// passing through zero).
    pub(super) fn quadric(&self, i: u32, time: f32) -> Option<QuadricPrim> {
        let q = self.quadrics.get(i as usize)?;
        let (a, b, f) = key_segment(&self.times, f64::from(time));
        let shape = if f == 0.0 { q.shapes[a].clone() } else { lerp_shape(&q.shapes[a], &q.shapes[b], f) };
        let quadric = Quadric::new(&shape).ok()?;
        let (ma, mb) = (q.blas_from_object[a], q.blas_from_object[b]);
        let blas_from_object = if f == 0.0 || ma == mb { ma } else { ma * (1.0 - f) + mb * f };
        let object_from_blas = blas_from_object.inverse();
        object_from_blas.is_finite().then_some(QuadricPrim {
            quadric,
            object_from_blas,
            blas_from_object,
            shape: q.shape,
        })
    }

    /// A box holding triangle `index` (mesh index) at every time.
    pub(super) fn triangle_box(&self, index: u32) -> Option<(Vec3, Vec3)> {
        let mesh = self.mesh.as_ref()?;
        let v = mesh.triangles[index as usize];
        let mut b = (Vec3::splat(f32::INFINITY), Vec3::splat(f32::NEG_INFINITY));
        for key in &mesh.positions {
            for k in v {
                b = (b.0.min(key[k as usize]), b.1.max(key[k as usize]));
            }
        }
        Some(b)
    }

    /// A box holding quadric `i` at every time (see the module notes).
    pub(super) fn quadric_box(&self, i: usize) -> Option<(Vec3, Vec3)> {
        let q = self.quadrics.get(i)?;
        let mut b = (Vec3::splat(f32::INFINITY), Vec3::splat(f32::NEG_INFINITY));
        let (lo, hi) = sweep_box(&q.shapes);
        for m in &q.blas_from_object {
            let (l, h) = transformed_box(m, lo, hi);
            b = (b.0.min(l), b.1.max(h));
        }
        Some(b)
    }
}

/// An object-space box holding every quadric whose parameters lie between those of `keys`
/// (same kind): the whole sweep, with the largest radius and the extreme heights of the keys.
fn sweep_box(keys: &[Shape]) -> (DVec3, DVec3) {
    let f = |v: f32| f64::from(v);
    let (mut r, mut z0, mut z1) = (0.0f64, f64::INFINITY, f64::NEG_INFINITY);
    let mut grow = |radius: f64, za: f64, zb: f64| {
        r = r.max(radius.abs());
        z0 = z0.min(za.min(zb));
        z1 = z1.max(za.max(zb));
    };
    for key in keys {
        match *key {
            Shape::Sphere { radius, .. } => grow(f(radius), -f(radius), f(radius)),
            Shape::Cylinder { radius, z_min, z_max, .. } => grow(f(radius), f(z_min), f(z_max)),
            Shape::Cone { height, radius, .. } => grow(f(radius), 0.0, f(height)),
            Shape::Disk { height, radius, .. } => grow(f(radius), f(height), f(height)),
            Shape::Paraboloid { r_max, z_min, z_max, .. } => {
                // Radius r_max sqrt(z / z_max) for z up to max(|z_min|, |z_max|).
                let k = if z_max != 0.0 {
                    (f(z_min).abs().max(f(z_max).abs()) / f(z_max).abs()).max(1.0)
                } else {
                    1.0
                };
                grow(f(r_max) * k.sqrt(), f(z_min), f(z_max))
            }
            Shape::Hyperboloid { point1, point2, .. } => {
                let rr = point1.truncate().length().max(point2.truncate().length());
                grow(f64::from(rr), f(point1.z), f(point2.z))
            }
            Shape::Torus { major_radius, minor_radius, .. } => {
                let m = f(minor_radius).abs();
                grow(f(major_radius).abs() + m, -m, m)
            }
            _ => {}
        }
    }
    // The paraboloid's radius bound mixes keys: take the largest ratio with the largest r_max.
    if let Some(Shape::Paraboloid { .. }) = keys.first() {
        let (mut rmax, mut kmax) = (0.0f64, 1.0f64);
        for key in keys {
            if let Shape::Paraboloid { r_max, z_min, z_max, .. } = *key {
                rmax = rmax.max(f(r_max).abs());
                if z_max != 0.0 {
                    kmax = kmax.max(f(z_min).abs().max(f(z_max).abs()) / f(z_max).abs());
                }
            }
        }
        r = r.max(rmax * kmax.sqrt());
    }
    (DVec3::new(-r, -r, z0), DVec3::new(r, r, z1))
}

/// The render-space box of a deforming BLAS's one shape at every time.
pub(super) fn instance_box(inst: &Instance, blas: &Blas) -> (Vec3, Vec3) {
    let (lo, hi) = blas.bounds;
    match &inst.motion {
        Some(motion) => super::motion::motion_box(motion, lo.as_dvec3(), hi.as_dvec3()),
        None if inst.identity => (lo, hi),
        None => transformed_box(&inst.render_from_blas, lo.as_dvec3(), hi.as_dvec3()),
    }
}

/// The deformation over the shutter interval (key times mapped to shutter fractions as
/// [`Ray::time`] uses them), or `None` when the shape keeps its shape while the shutter is open
/// (no keys, a closed shutter, or every key inside it and the shapes at open and close equal).
pub(super) fn shutter_deformation(
    scene: &Scene,
    deformation: &Option<Arc<Deformation>>,
) -> Option<Deformation> {
    let deformation = deformation.as_ref()?;
    let (open, close) = scene.render.shutter?;
    let (open, close) = (f64::from(open), f64::from(close));
    if !(close > open) {
        return None;
    }
    let keyed = deformation.retimed(|t| (t - open) / (close - open))?;
    let first = keyed.at(0.0);
    let inner = keyed.times().iter().zip(keyed.shapes()).filter(|(t, _)| **t > 0.0 && **t < 1.0);
    let moves = inner.map(|(_, s)| (**s).clone()).chain(std::iter::once(keyed.at(1.0))).any(|s| s != first);
    moves.then_some(keyed)
}

/// A BLAS holding the deforming shape placed with `blas_from_object`, tessellated for
/// `footprint` when given, and the number of triangles of all its keys (at most `budget`), or
/// why its keys cannot be interpolated.
pub(super) fn deforming_blas(
    deformation: &Deformation,
    attributes: AttributesId,
    blas_from_object: &DMat4,
    footprint: Option<&PixelFootprint>,
    budget: usize,
    scene: &Scene,
    displace: Option<KeyDisplacement<'_>>,
) -> Result<(Blas, usize), String> {
    let shapes = deformation.shapes();
    let times = deformation.times().to_vec();
    let mut builder = BlasBuilder::new();
    if is_quadric(&shapes[0]) || matches!(*shapes[0], Shape::Points(_)) {
        if displace.is_some() {
            return Err(
                "the keys of a displaced quadric are not displaced (it is a mesh at shutter open)".into()
            );
        }
        // Each key's quadrics (a Points key: one sphere per point).
        let mut per_key = Vec::with_capacity(shapes.len());
        for shape in shapes {
            per_key.push(quadric_keys(shape)?);
        }
        let count = per_key[0].len();
        if per_key.iter().any(|k| k.len() != count) {
            return Err("its keys have other numbers of points with a positive width".into());
        }
        let mut quadrics = Vec::with_capacity(count);
        for i in 0..count {
            quadrics.push(KeyedQuadric {
                shapes: per_key.iter().map(|k| k[i].0.clone()).collect(),
                blas_from_object: per_key.iter().map(|k| *blas_from_object * k[i].1).collect(),
                shape: 0,
            });
        }
        let deforming = Deforming { times, mesh: None, quadrics };
        // The quadrics at shutter open stand for the shape where no time is known; a quadric
        // that is degenerate then takes its first usable key.
        for i in 0..count as u32 {
            let q = deforming
                .quadric(i, 0.0)
                .or_else(|| {
                    (0..deforming.times.len()).find_map(|k| deforming.quadric(i, deforming.times[k] as f32))
                })
                .ok_or("its quadric is degenerate at every key")?;
            builder.quadrics.push(q);
        }
        builder.push_shape(attributes, None, scene);
        return Ok((builder.finish_deforming(deforming), 0));
    }
    // Meshes: every key with one tolerance, the finest any key asks for.
    let tolerance = common_tolerance(shapes, blas_from_object, footprint);
    // Every key's triangles count against the world's budget: a hostile file with many keys
    // cannot make more than that.
    let mut left = budget;
    let mut meshes = Vec::with_capacity(shapes.len());
    let curves: Vec<&rib_parser::scene::Curves> =
        shapes.iter().filter_map(|s| if let Shape::Curves(c) = &**s { Some(c) } else { None }).collect();
    if let (Some(footprint), true) = (footprint, curves.len() == shapes.len()) {
        // Ribbons facing the eye, every key sampled alike (tessellate::curve_ribbons_keys).
        let cap = tolerance.max_triangles.min(left as u64);
        let keyed = curve_ribbons_keys(
            &curves,
            blas_from_object,
            ribbon_facing(footprint),
            &tolerance.with_max_triangles(cap),
        )
        .map_err(|e| e.to_string())?;
        for m in keyed {
            left = left.checked_sub(m.indices.len()).ok_or_else(|| {
                format!("its keys would make more than the world's {MAX_WORLD_TRIANGLES} triangles")
            })?;
            meshes.push(m);
        }
    }
    if meshes.is_empty()
        && matches!(
            *shapes[0],
            Shape::Patches(_) | Shape::NuPatch(_) | Shape::SubdivisionMesh(_) | Shape::Blobby(_)
        )
    {
        // Adaptive surfaces: the key that needs the most triangles decides the rates of all
        // (a Blobby's vertices are carried onto the other keys' isosurfaces).
        let cap = tolerance.max_triangles.min((left / shapes.len()) as u64);
        if cap == 0 {
            return Err(format!("its keys would make more than the world's {MAX_WORLD_TRIANGLES} triangles"));
        }
        let keys: Vec<&Shape> = shapes.iter().map(|s| &**s).collect();
        for m in tessellate_placed_keys(&keys, blas_from_object, false, &tolerance.with_max_triangles(cap))
            .map_err(|e| e.to_string())?
        {
            left = left.saturating_sub(m.indices.len());
            meshes.push(m);
        }
    }
    let tessellate_each = meshes.is_empty();
    for shape in shapes.iter().filter(|_| tessellate_each) {
        let cap = tolerance.max_triangles.min(left as u64);
        if cap == 0 {
            return Err(format!("its keys would make more than the world's {MAX_WORLD_TRIANGLES} triangles"));
        }
        match place_geometry_with(shape, blas_from_object, footprint, tolerance.with_max_triangles(cap))? {
            Geometry::Mesh(m) => {
                left = left.saturating_sub(m.indices.len());
                meshes.push(m);
            }
            _ => return Err("its keys are not meshes".into()),
        }
    }
    let first = &meshes[0];
    if meshes.iter().any(|m| m.indices != first.indices || m.positions.len() != first.positions.len()) {
        return Err(
            "its keys tessellate to different meshes (the surface is refined differently at each key)".into(),
        );
    }
    if let Some(displace) = displace {
        // Every key diced alike and displaced at its own vertices; the displaced keys replace
        // the plain ones in the budget, shared by the keys.
        meshes = displace(&meshes, (budget / meshes.len()) as u64)?;
        let keyed: usize = meshes.iter().map(|m| m.indices.len()).sum();
        left = budget.checked_sub(keyed).ok_or_else(|| {
            format!("its displaced keys would make more than the world's {MAX_WORLD_TRIANGLES} triangles")
        })?;
    }
    let normals: Option<Vec<Vec<Vec3>>> = meshes.iter().map(|m| m.normals.clone()).collect();
    let positions: Vec<Vec<Vec3>> = meshes.iter().map(|m| m.positions.clone()).collect();
    // The mesh at shutter open stands for the shape where no time is known.
    let mut open = meshes.swap_remove(0);
    let (i, j, f) = key_segment(&times, 0.0);
    open.positions = lerp_keys(&positions, (i, j, f));
    open.normals = normals.as_deref().map(|n| lerp_keys(n, (i, j, f)));
    // Every triangle that has an area at some key.
    for (index, t) in open.indices.iter().enumerate() {
        let has_area = positions.iter().any(|key| {
            let p = t.map(|k| key[k as usize]);
            p.iter().all(|v| v.is_finite()) && (p[1] - p[0]).cross(p[2] - p[0]) != Vec3::ZERO
        });
        if has_area {
            let p = t.map(|k| open.positions[k as usize]);
            builder.triangles.push(TrianglePrim { p, shape: 0, index: index as u32 });
        }
    }
    if builder.triangles.is_empty() {
        return Err("it has no area at any key".into());
    }
    let mesh = KeyedMesh { triangles: open.indices.clone(), positions, normals };
    let deforming = Deforming { times, mesh: Some(mesh), quadrics: Vec::new() };
    let keyed_triangles = budget - left;
    builder.push_shape(
        attributes,
        Some(MeshShading { triangles: open.indices, normals: open.normals, st: open.st }),
        scene,
    );
    Ok((builder.finish_deforming(deforming), keyed_triangles))
}

/// Displaces the keys of a deforming mesh (the same triangles at every key) within a number
/// of triangles per key, keeping them alike.
pub(super) type KeyDisplacement<'a> =
    &'a mut dyn FnMut(&[tessellate::TriangleMesh], u64) -> Result<Vec<tessellate::TriangleMesh>, String>;

/// Every vertex of the keys `(i, j)` interpolated `f` of the way.
fn lerp_keys(keys: &[Vec<Vec3>], (i, j, f): (usize, usize, f64)) -> Vec<Vec3> {
    keys[i].iter().zip(&keys[j]).map(|(a, b)| if f == 0.0 { *a } else { lerp3(*a, *b, f) }).collect()
}

/// A quadric shape's one quadric, or a `Points` key's spheres, each with its placement in the
/// shape's object space.
fn quadric_keys(shape: &Shape) -> Result<Vec<(Shape, DMat4)>, String> {
    if let Shape::Points(points) = shape {
        return Ok(points
            .positions
            .iter()
            .zip(tessellate::point_widths(points))
            .map(|(p, width)| {
                let radius = (0.5 * width.abs()) as f32;
                let sphere =
                    Shape::Sphere { radius, z_min: -radius, z_max: radius, theta_max_degrees: 360.0 };
                (sphere, DMat4::from_translation(p.as_dvec3()))
            })
            .collect());
    }
    Ok(vec![(shape.clone(), DMat4::IDENTITY)])
}

impl World {
    /// [`World::intersect_instance`] for a deforming BLAS: its triangles and quadrics at the
    /// ray's time.
    pub(super) fn intersect_deforming(
        &self,
        instance: u32,
        inst: &Instance,
        query: &mut RayQuery,
        t_max: &mut f32,
        best: &mut Option<Hit>,
    ) {
        let blas = &self.blases[inst.blas as usize];
        let Some(deforming) = &blas.deforming else { return };
        let ray = query.ray;
        let (t_min, time) = (ray.t_min, ray.time);
        let Some((mut tray, shear)) = Self::blas_ray(inst, query, *t_max) else { return };
        let (origin, direction) = (Vec3::from(tray.origin), Vec3::from(tray.direction));
        let mut test = |t_max: f32, slot: u32| match blas.prims[slot as usize] {
            Prim::Triangle(i) => {
                let tri = &blas.triangles[i as usize];
                let p = deforming.triangle(tri.index, time)?;
                let h = intersect_triangle(&shear, p[0], p[1], p[2], t_max)?;
                if h.t <= t_min {
                    return None;
                }
                let (one_sided, reverse) = self.sidedness(inst, blas, tri.shape);
                if one_sided && (hits_front(p[0], p[1], p[2], direction) == reverse) {
                    return None;
                }
                *best =
                    Some(Hit { t: h.t, instance, detail: HitDetail::Triangle(i, h.b), csg_entering: None });
                Some(h.t)
            }
            Prim::Quadric(i) => {
                let q = deforming.quadric(i, time)?;
                let h = self.quadric_hit(inst, blas, &q, (origin, direction), (t_min, t_max))?;
                let t = h.t as f32;
                *best = Some(Hit { t, instance, detail: HitDetail::Quadric(i, h), csg_entering: None });
                Some(t)
            }
        };
        blas.bvh.closest(&mut tray, |r, slot| test(r.t_max, slot));
        *t_max = tray.t_max;
    }

    /// [`World::transmittance_instance`] for a deforming BLAS.
    pub(super) fn transmittance_deforming(
        &self,
        inst: &Instance,
        blas: &Blas,
        deforming: &Deforming,
        query: &mut RayQuery,
        tr: &mut Vec3,
    ) {
        let ray = query.ray;
        let (t_min, t_max, time) = (ray.t_min, ray.t_max, ray.time);
        let Some((tray, shear)) = Self::blas_ray(inst, query, t_max) else { return };
        let (origin, direction) = (Vec3::from(tray.origin), Vec3::from(tray.direction));
        let mut blocks = |slot: u32| {
            let crossing = |shape: u32, tr: &mut Vec3| {
                let attributes = inst.attributes.unwrap_or(blas.shapes[shape as usize].attributes);
                match self.attenuation(attributes) {
                    None => *tr = Vec3::ZERO,
                    Some(a) => *tr *= a,
                }
            };
            match blas.prims[slot as usize] {
                Prim::Triangle(i) => {
                    let tri = &blas.triangles[i as usize];
                    let Some(p) = deforming.triangle(tri.index, time) else { return false };
                    let Some(h) = intersect_triangle(&shear, p[0], p[1], p[2], t_max) else { return false };
                    let (one_sided, reverse) = self.sidedness(inst, blas, tri.shape);
                    if h.t <= t_min || (one_sided && (hits_front(p[0], p[1], p[2], direction) == reverse)) {
                        return false;
                    }
                    crossing(tri.shape, tr);
                }
                Prim::Quadric(i) => {
                    let Some(q) = deforming.quadric(i, time) else { return false };
                    return self.quadric_blocks(inst, blas, &q, (origin, direction), (t_min, t_max), tr);
                }
            }
            *tr == Vec3::ZERO
        };
        blas.bvh.any(&tray, |_, slot| blocks(slot));
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use glam::Vec3 as V;

    /// Every quadric between two keys lies in the keys' sweep box, even where the largest
    /// radius and the widest sweep come from different keys.
    #[test]
    fn sweep_boxes_hold_every_interpolated_quadric() {
        let pairs = [
            (
                Shape::Sphere { radius: 1.0, z_min: -1.0, z_max: 1.0, theta_max_degrees: 90.0 },
                Shape::Sphere { radius: 0.5, z_min: -0.2, z_max: 0.5, theta_max_degrees: 360.0 },
            ),
            (
                Shape::Cylinder { radius: 0.5, z_min: -0.5, z_max: 0.5, theta_max_degrees: 360.0 },
                Shape::Cylinder { radius: 0.4, z_min: -0.2, z_max: 0.9, theta_max_degrees: 270.0 },
            ),
            (
                Shape::Cone { height: 1.0, radius: 0.5, theta_max_degrees: 360.0 },
                Shape::Cone { height: -0.5, radius: 0.4, theta_max_degrees: 270.0 },
            ),
            (
                Shape::Disk { height: 0.0, radius: 0.5, theta_max_degrees: 360.0 },
                Shape::Disk { height: 2.0, radius: 0.25, theta_max_degrees: 270.0 },
            ),
            (
                Shape::Paraboloid { r_max: 0.25, z_min: 0.0, z_max: 0.5, theta_max_degrees: 360.0 },
                Shape::Paraboloid { r_max: 0.35, z_min: 0.3, z_max: 0.4, theta_max_degrees: 230.0 },
            ),
            (
                Shape::Hyperboloid {
                    point1: V::new(0.0, 0.5, -0.25),
                    point2: V::new(0.5, 0.0, 0.25),
                    theta_max_degrees: 360.0,
                },
                Shape::Hyperboloid {
                    point1: V::new(0.3, 0.3, -0.5),
                    point2: V::new(0.0, 0.3, 0.25),
                    theta_max_degrees: 260.0,
                },
            ),
            (
                Shape::Torus {
                    major_radius: 1.0,
                    minor_radius: 0.25,
                    phi_min_degrees: 0.0,
                    phi_max_degrees: 360.0,
                    theta_max_degrees: 360.0,
                },
                Shape::Torus {
                    major_radius: 0.5,
                    minor_radius: 0.5,
                    phi_min_degrees: 90.0,
                    phi_max_degrees: 180.0,
                    theta_max_degrees: 90.0,
                },
            ),
        ];
        for (a, b) in pairs {
            let (lo, hi) = sweep_box(&[a.clone(), b.clone()]);
            for k in 0..=16 {
                let shape = lerp_shape(&a, &b, f64::from(k) / 16.0);
                let Ok(q) = Quadric::new(&shape) else { continue };
                // Points on the surface, not only its own box (which ignores the sweep).
                for i in 0..=8 {
                    for j in 0..=8 {
                        let p = q.point_at(f64::from(i) / 8.0, f64::from(j) / 8.0);
                        let inside = p.cmpge(lo - 1e-12).all() && p.cmple(hi + 1e-12).all();
                        assert!(inside, "{shape:?}: {p} outside {lo} {hi}");
                    }
                }
            }
        }
    }
}
