//! Deforming shapes: the keys of a `MotionBegin` block (one shape per key time, the same
//! request and topology) tessellated alike, so that vertex `i` of one key's mesh is vertex `i`
//! of every other key's and a renderer can interpolate the vertices linearly between keys.
//!
//! Adaptive tessellation chooses its rates from the positions, so keys tessellated on their
//! own may come out with other triangles. Here the key that needs the most triangles decides
//! for all of them:
//! - `Patch`, `PatchMesh` and `NuPatch`: that key is diced at the largest of all the keys'
//!   rates (span by span and side by side, so each key is as fine as it needs and shared
//!   sides still agree), and every key is evaluated at its vertex parameters `(u, v)` (its
//!   grid, stitched sides and trim crossings alike);
//! - `SubdivisionMesh`: every key is subdivided to that key's level, with the same faces
//!   refined adaptively and the same quad diagonals (subdivision is linear in the control
//!   points, so each key's vertices are the same stencils applied to its own points).
//!
//! - `Blobby`: an isosurface has no parameters to carry, so every vertex of the deciding key's
//!   mesh is moved onto each other key's isosurface by Newton steps along the field's
//!   gradient. That holds while the blobs keep their topology; where they split or merge
//!   (a triangle bridging two blobs ends far from the surface, or turns over) the keys are
//!   refused with the reason.
//!
//! Zero-area triangles are kept in the keyed meshes (another key may give them area), and the
//! keys' texture coordinates are the deciding key's. Other shapes are tessellated key by key.

use super::blobby::{BLOBBY_THRESHOLD, BlobbyField};
use super::grid::{RatePlanning, Rates};
use super::nurbs::Surface;
use super::nurbs::tessellate_nupatch;
use super::patch::PatchSurface;
use super::patch::tessellate_patches;
use super::placed::{spectral_norm, transform_mesh};
use super::subdiv::{Planning, SubdivPlan, tessellate_subdivision_planned};
use super::{ShapeOptions, TessellateError, Tolerance, TriangleMesh, shape_kind, tessellate_scaled};
use glam::{DMat3, DMat4, DVec3, Vec2};
use rib_parser::scene::{PatchMesh, Shape, SubdivisionMesh};

/// Tessellates the keys of a deforming shape and places them with `world_from_object` (as
/// [`tessellate_placed`](super::tessellate_placed) does one shape): the meshes have the same
/// triangles (indices, face indices, texture coordinates), with each key's own vertex positions
/// and normals. See the [module notes](self). Keys that are not one request are refused.
pub fn tessellate_placed_keys(
    keys: &[&Shape],
    world_from_object: &DMat4,
    reverse_orientation: bool,
    tol: &Tolerance,
) -> Result<Vec<TriangleMesh>, TessellateError> {
    let Some(first) = keys.first() else { return Ok(Vec::new()) };
    let kind = shape_kind(first);
    if keys.iter().any(|k| shape_kind(k) != kind) {
        return Err(TessellateError::InvalidShape { kind, reason: "its keys are other requests".into() });
    }
    if !world_from_object.is_finite() {
        return Err(TessellateError::NonFinite { kind, reason: "the transform is not finite".into() });
    }
    tol.validate()?;
    let scale = spectral_norm(&DMat3::from_mat4(*world_from_object));
    let mut meshes = match keys {
        [Shape::SubdivisionMesh(_), ..] => subdivision_keys(keys, tol, scale)?,
        [Shape::Patches(_) | Shape::NuPatch(_), ..] => parametric_keys(keys, tol, scale)?,
        [Shape::Blobby(_), ..] => blobby_keys(keys, tol, scale)?,
        _ => keys
            .iter()
            .map(|k| tessellate_scaled(k, tol, scale, ShapeOptions::default()))
            .collect::<Result<_, _>>()?,
    };
    for mesh in &mut meshes {
        transform_mesh(mesh, world_from_object, reverse_orientation);
        mesh.check_finite(kind)?;
    }
    Ok(meshes)
}

/// The index of the mesh with the most triangles (the first of equals).
fn finest(meshes: &[TriangleMesh]) -> usize {
    let most = meshes.iter().map(TriangleMesh::triangle_count).max().unwrap_or(0);
    meshes.iter().position(|m| m.triangle_count() == most).unwrap_or(0)
}

fn subdivision_keys(
    keys: &[&Shape],
    tol: &Tolerance,
    scale: f64,
) -> Result<Vec<TriangleMesh>, TessellateError> {
    let meshes: Vec<&SubdivisionMesh> =
        keys.iter().filter_map(|k| if let Shape::SubdivisionMesh(m) = k { Some(m) } else { None }).collect();
    let mut recorded = Vec::with_capacity(meshes.len());
    let mut plans = Vec::with_capacity(meshes.len());
    for mesh in &meshes {
        let mut planning = Planning::Record(SubdivPlan::default());
        recorded.push(tessellate_subdivision_planned(mesh, tol, scale, &mut planning)?);
        plans.push(if let Planning::Record(plan) = planning { plan } else { SubdivPlan::default() });
    }
    let decider = finest(&recorded);
    let mut out = Vec::with_capacity(meshes.len());
    for (k, mesh) in meshes.iter().enumerate() {
        if k == decider {
            out.push(recorded[k].clone());
            continue;
        }
        // This key's points with the deciding key's everything else (its st in particular, which
        // decides where vertices split).
        let key = SubdivisionMesh { positions: mesh.positions.clone(), ..meshes[decider].clone() };
        let mut planning = Planning::Replay(plans[decider].clone());
        out.push(tessellate_subdivision_planned(&key, tol, scale, &mut planning)?);
    }
    same_triangles(&out)?;
    Ok(out)
}

/// A parametric key to evaluate at another key's vertex parameters.
enum Parametric {
    Patches(Box<PatchSurface>),
    NuPatch(Surface),
}

impl Parametric {
    fn new(shape: &Shape) -> Result<Parametric, TessellateError> {
        match shape {
            Shape::Patches(pm) => Ok(Parametric::Patches(Box::new(PatchSurface::new(pm)?))),
            Shape::NuPatch(np) => Ok(Parametric::NuPatch(Surface::new(np)?)),
            other => Err(TessellateError::InvalidShape {
                kind: shape_kind(other),
                reason: "not parametric".into(),
            }),
        }
    }

    /// The position and `S_u x S_v` at the vertex whose default texture coordinates are `st`
    /// (`(u / patches u, v / patches v)` for patch meshes, the knot values for NuPatch).
    fn eval(&self, st: Vec2) -> (DVec3, DVec3) {
        let st = st.as_dvec2();
        match self {
            Parametric::Patches(s) => {
                let (pu, pv) = s.patches();
                s.eval(st.x * pu as f64, st.y * pv as f64)
            }
            Parametric::NuPatch(s) => s.eval(st.x, st.y),
        }
    }

    fn weight_vanished(&self) -> bool {
        match self {
            Parametric::Patches(s) => s.bad_weight.get(),
            Parametric::NuPatch(s) => s.bad_weight.get(),
        }
    }
}

/// The shape with no `st`, `s` or `t`, so its texture coordinates are its parameters.
fn without_texture_coordinates(shape: &Shape) -> Option<Shape> {
    let Shape::Patches(pm) = shape else { return None };
    let named = |name: &str| matches!(name, "st" | "s" | "t");
    if !pm.primvars.0.iter().any(|p| named(&p.name)) {
        return None;
    }
    let mut plain: PatchMesh = pm.clone();
    plain.primvars.0.retain(|p| !named(&p.name));
    Some(Shape::Patches(plain))
}

fn parametric_keys(
    keys: &[&Shape],
    tol: &Tolerance,
    scale: f64,
) -> Result<Vec<TriangleMesh>, TessellateError> {
    let kind = shape_kind(keys[0]);
    let mut own = Vec::with_capacity(keys.len());
    let mut rates = Vec::with_capacity(keys.len());
    for key in keys {
        let mut planning = RatePlanning::Record(None);
        own.push(tessellate_parametric(key, tol, scale, &mut planning)?);
        rates.push(if let RatePlanning::Record(r) = planning { r } else { None });
    }
    let decider = finest(&own);
    // Every key is diced at the largest of the keys' rates, span by span and side by side, so
    // each is at least as fine as it needs (a key curved where the decider is flat included).
    let largest = Rates::largest(&rates).filter(|r| Some(r) != rates[decider].as_ref());
    if let Some(largest) = largest {
        own[decider] =
            tessellate_parametric(keys[decider], tol, scale, &mut RatePlanning::Given(largest.clone()))?;
        rates[decider] = Some(largest);
    }
    let params = match without_texture_coordinates(keys[decider]) {
        Some(plain) => {
            let mut planning = rates[decider].clone().map_or(RatePlanning::Free, RatePlanning::Given);
            tessellate_parametric(&plain, tol, scale, &mut planning)?
        }
        None => own[decider].clone(),
    };
    let Some(params_st) = params.st.as_ref().filter(|_| params.indices == own[decider].indices) else {
        return Err(TessellateError::InvalidShape {
            kind,
            reason: "its vertex parameters are unknown".into(),
        });
    };
    let template = &own[decider];
    let mut out = Vec::with_capacity(keys.len());
    for (k, key) in keys.iter().enumerate() {
        if k == decider {
            out.push(template.clone());
            continue;
        }
        let surface = Parametric::new(key)?;
        let samples: Vec<(DVec3, DVec3)> = params_st.iter().map(|&st| surface.eval(st)).collect();
        if surface.weight_vanished() {
            return Err(TessellateError::NonFinite {
                kind,
                reason: "a homogeneous weight vanishes on the surface".into(),
            });
        }
        let mut mesh = TriangleMesh {
            positions: samples.iter().map(|s| s.0.as_vec3()).collect(),
            normals: None,
            ..template.clone()
        };
        mesh.normals = Some(key_normals(&mesh, samples.iter().map(|s| s.1)));
        out.push(mesh);
    }
    same_triangles(&out)?;
    Ok(out)
}

/// One parametric key (`Patch`, `PatchMesh`, `NuPatch`) with its rates planned.
fn tessellate_parametric(
    shape: &Shape,
    tol: &Tolerance,
    scale: f64,
    planning: &mut RatePlanning,
) -> Result<TriangleMesh, TessellateError> {
    match shape {
        Shape::Patches(pm) => tessellate_patches(pm, tol, scale, planning),
        Shape::NuPatch(np) => tessellate_nupatch(np, tol, scale, ShapeOptions::default(), planning),
        other => tessellate_scaled(other, tol, scale, ShapeOptions::default()),
    }
}

/// Unit normals from the surface's `S_u x S_v`, and where that vanishes (a pole, a collapsed
/// edge) from the key's own triangles around the vertex.
fn key_normals(mesh: &TriangleMesh, surface: impl Iterator<Item = DVec3>) -> Vec<glam::Vec3> {
    let mut around: Option<Vec<DVec3>> = None;
    surface
        .enumerate()
        .map(|(i, n)| {
            let n = if n.is_finite() && n.length_squared() > 0.0 {
                n
            } else {
                let sums = around.get_or_insert_with(|| {
                    let mut sums = vec![DVec3::ZERO; mesh.positions.len()];
                    for t in 0..mesh.indices.len() {
                        let cross = mesh.face_cross(t);
                        for &v in &mesh.indices[t] {
                            sums[v as usize] += cross;
                        }
                    }
                    sums
                });
                sums[i]
            };
            n.normalize_or(DVec3::Z).as_vec3()
        })
        .collect()
}

/// Checks that every key's mesh has the first one's triangles.
fn same_triangles(meshes: &[TriangleMesh]) -> Result<(), TessellateError> {
    let Some(first) = meshes.first() else { return Ok(()) };
    if meshes.iter().any(|m| m.indices != first.indices || m.positions.len() != first.positions.len()) {
        return Err(TessellateError::InvalidShape {
            kind: "deforming shape",
            reason: "its keys tessellate to different triangles".into(),
        });
    }
    Ok(())
}

fn blobby_keys(keys: &[&Shape], tol: &Tolerance, scale: f64) -> Result<Vec<TriangleMesh>, TessellateError> {
    let own: Vec<TriangleMesh> = keys
        .iter()
        .map(|k| tessellate_scaled(k, tol, scale, ShapeOptions::default()))
        .collect::<Result<_, _>>()?;
    // Keys that tessellate alike (a blob that only scales, its grid scaling with it) need nothing more.
    if same_triangles(&own).is_ok() {
        return Ok(own);
    }
    let decider = finest(&own);
    let template = &own[decider];
    let refuse = |why: &str| TessellateError::InvalidShape {
        kind: "Blobby",
        reason: format!("its keys' isosurfaces cannot be mapped onto one another ({why})"),
    };
    let field_of = |shape: &Shape| match shape {
        Shape::Blobby(b) => BlobbyField::new(b),
        other => {
            Err(TessellateError::InvalidShape { kind: shape_kind(other), reason: "not a Blobby".into() })
        }
    };
    let eps_of = |field: &BlobbyField| -> Result<f64, TessellateError> {
        tol.effective(field.bounds.map_or(1.0, |(lo, hi)| (hi - lo).length()), scale)
    };
    let eps_decider = eps_of(&field_of(keys[decider])?)?;
    let mut scratch = Vec::new();
    let mut out = Vec::with_capacity(keys.len());
    for (k, key) in keys.iter().enumerate() {
        if k == decider {
            out.push(template.clone());
            continue;
        }
        let field = field_of(key)?;
        let eps = eps_of(&field)?;
        let mut positions = Vec::with_capacity(template.positions.len());
        let mut normals = Vec::with_capacity(template.positions.len());
        for p in &template.positions {
            let (x, g) = onto_isosurface(&field, p.as_dvec3(), eps, &mut scratch)
                .ok_or_else(|| refuse("a vertex finds no surface nearby"))?;
            positions.push(x.as_vec3());
            normals.push((-g).normalize_or(DVec3::Z).as_vec3());
        }
        let mesh = TriangleMesh { positions, normals: Some(normals), ..template.clone() };
        // Triangles that bridge blobs that came apart end far from the surface, or turn over.
        let limit = 4.0 * eps.max(eps_decider);
        let vertex_normals = mesh.normals.as_deref().unwrap_or(&[]);
        for t in 0..mesh.indices.len() {
            let [a, b, c] = mesh.triangle(t).map(|p| p.as_dvec3());
            let (v, g) = field.eval((a + b + c) / 3.0, &mut scratch);
            let smooth = mesh.indices[t]
                .map(|i| vertex_normals.get(i as usize).copied().unwrap_or(glam::Vec3::Z).as_dvec3());
            let creased =
                smooth[0].dot(smooth[1]).min(smooth[1].dot(smooth[2])).min(smooth[0].dot(smooth[2])) < 0.9;
            if !creased && g.length() > 0.0 && (v - BLOBBY_THRESHOLD).abs() / g.length() > limit {
                return Err(refuse("the blobs split, merge or move too far"));
            }
            let cross = mesh.face_cross(t);
            if cross != DVec3::ZERO && smooth.iter().any(|n| n.dot(cross) < 0.0) && !creased {
                return Err(refuse("a triangle turns over"));
            }
        }
        out.push(mesh);
    }
    same_triangles(&out)?;
    Ok(out)
}

/// The point of the field's level set reached from `p` by Newton steps along the gradient, with
/// the gradient there, or `None` when the steps do not converge (no surface nearby).
fn onto_isosurface(
    field: &BlobbyField,
    p: DVec3,
    eps: f64,
    scratch: &mut Vec<(f64, DVec3)>,
) -> Option<(DVec3, DVec3)> {
    let mut x = p;
    for _ in 0..64 {
        let (v, g) = field.eval(x, scratch);
        let g2 = g.length_squared();
        if !(g2 > 0.0 && v.is_finite()) {
            return None;
        }
        let step = (v - BLOBBY_THRESHOLD) / g2;
        if (step * g2.sqrt()).abs() <= 1e-6 * eps {
            return Some((x, g));
        }
        x -= g * step;
    }
    None
}
