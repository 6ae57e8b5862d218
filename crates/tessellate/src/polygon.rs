//! Polygons: convex and concave, non-planar, with holes.
//!
//! Each face is projected onto the plane of its outer loop's Newell normal (the area-weighted
//! normal, robust for non-planar and concave loops). Triangles and convex quads are split
//! directly; everything else, holes included, goes through ear clipping with hole bridging
//! (the `earcut` crate, a port of Mapbox's earcut). Triangles are wound counter-clockwise
//! around the Newell normal; triangles of zero area are dropped, and faces with no area count
//! as [`TriangleMesh::degenerate_faces`].

use super::primvar::{Var, st_var, vec3_var};
use super::{TessellateError, Tolerance, TriangleMesh, check_budget};
use glam::{DVec2, DVec3, Vec2, Vec3};
use rib_parser::scene::PolygonMesh;

const KIND: &str = "polygon mesh";

fn invalid(reason: String) -> TessellateError {
    TessellateError::InvalidShape { kind: KIND, reason }
}

pub(crate) fn tessellate_polygons(
    pm: &PolygonMesh,
    tol: &Tolerance,
) -> Result<TriangleMesh, TessellateError> {
    // Check the counts before indexing anything.
    let loops_total: u64 = pm.loops_per_face.iter().map(|&n| n as u64).sum();
    if loops_total != pm.vertices_per_loop.len() as u64 {
        return Err(invalid(format!(
            "the faces have {loops_total} loops in all but {} loop sizes are given",
            pm.vertices_per_loop.len()
        )));
    }
    let corners_total: u64 = pm.vertices_per_loop.iter().map(|&n| n as u64).sum();
    if corners_total != pm.vertex_indices.len() as u64 {
        return Err(invalid(format!(
            "the loops have {corners_total} vertices in all but {} vertex indices are given",
            pm.vertex_indices.len()
        )));
    }
    if let Some(&bad) = pm.vertex_indices.iter().find(|&&i| i as usize >= pm.positions.len()) {
        return Err(invalid(format!("vertex index {bad} but only {} positions", pm.positions.len())));
    }
    if let Some(p) = pm.positions.iter().find(|p| !p.is_finite()) {
        return Err(TessellateError::NonFinite { kind: KIND, reason: format!("position {p}") });
    }
    // A face with c corners and h holes gives at most c + 2h - 2 triangles.
    let mut estimate = 0.0f64;
    let mut next_loop = 0usize;
    for &nloops in &pm.loops_per_face {
        let loops = &pm.vertices_per_loop[next_loop..next_loop + nloops as usize];
        let corners: f64 = loops.iter().map(|&n| n as f64).sum();
        estimate += (corners + 2.0 * (nloops as f64 - 1.0) - 2.0).max(0.0);
        next_loop += nloops as usize;
    }
    check_budget(KIND, estimate, tol)?;

    let faces = pm.loops_per_face.len();
    let corners = pm.vertex_indices.len();
    let nvar = vec3_var(&pm.primvars, "N").filter(|v| v.fits(faces, pm.positions.len(), corners));
    let stvar = st_var(&pm.primvars).filter(|v| v.fits(faces, pm.positions.len(), corners));
    let split =
        nvar.as_ref().is_some_and(Var::splits_vertices) || stvar.as_ref().is_some_and(Var::splits_vertices);

    let mut mesh = TriangleMesh::default();
    // Output vertex of each corner: the corner itself when vertices are split, else its vertex.
    if split {
        mesh.positions = pm.vertex_indices.iter().map(|&v| pm.positions[v as usize]).collect();
    } else {
        mesh.positions = pm.positions.clone();
    }
    let vertex_count = mesh.positions.len();
    let mut normals: Option<Vec<Vec3>> = nvar.as_ref().map(|_| vec![Vec3::ZERO; vertex_count]);
    let mut st: Option<Vec<Vec2>> = stvar.as_ref().map(|_| vec![Vec2::ZERO; vertex_count]);

    let mut triangulator = Triangulator::default();
    // Scratch space reused by every face: a mesh has hundreds of thousands of small faces, and
    // per-face vectors made the allocator a tenth of `lrt-depth --check`'s time.
    let mut points: Vec<DVec3> = Vec::new();
    let mut loop_lens: Vec<usize> = Vec::new();
    let mut tris: Vec<[usize; 3]> = Vec::new();
    mesh.indices.reserve(estimate.min(tol.max_triangles as f64) as usize);
    mesh.face_index.reserve(estimate.min(tol.max_triangles as f64) as usize);
    let mut loop_start = 0usize; // index into vertices_per_loop
    let mut corner_start = 0usize; // index into vertex_indices
    for face in 0..faces {
        let nloops = pm.loops_per_face[face] as usize;
        let loops = &pm.vertices_per_loop[loop_start..loop_start + nloops];
        let face_corners: usize = loops.iter().map(|&n| n as usize).sum();
        let corner_ids = corner_start..corner_start + face_corners;
        let out_vertex = |c: usize| if split { c } else { pm.vertex_indices[c] as usize };

        points.clear();
        points.extend(corner_ids.clone().map(|c| pm.positions[pm.vertex_indices[c] as usize].as_dvec3()));
        loop_lens.clear();
        loop_lens.extend(loops.iter().map(|&n| n as usize));
        let normal = triangulator.triangulate(&points, &loop_lens, &mut tris);
        if tris.is_empty() {
            mesh.degenerate_faces += 1;
        }
        for t in &tris {
            mesh.indices.push(t.map(|k| out_vertex(corner_start + k) as u32));
            mesh.face_index.push(face as u32);
        }
        // Carry N and st to the vertices this face uses.
        for c in corner_ids {
            let vertex = pm.vertex_indices[c] as usize;
            let o = out_vertex(c);
            if let (Some(n), Some(var)) = (normals.as_mut(), nvar.as_ref()) {
                let value = var.at(face, vertex, c).unwrap_or(Vec3::ZERO);
                n[o] = if value.is_finite() && value.length_squared() > 0.0 {
                    value.normalize()
                } else if n[o] == Vec3::ZERO {
                    normal.as_vec3()
                } else {
                    n[o]
                };
            }
            if let (Some(s), Some(var)) = (st.as_mut(), stvar.as_ref()) {
                s[o] = var.at(face, vertex, c).filter(|v| v.is_finite()).unwrap_or(Vec2::ZERO);
            }
        }
        loop_start += nloops;
        corner_start += face_corners;
    }
    if let Some(n) = normals.as_mut() {
        for v in n.iter_mut().filter(|v| **v == Vec3::ZERO) {
            *v = Vec3::Z;
        }
    }
    mesh.normals = normals;
    mesh.st = st;
    super::grid::compact(&mut mesh);
    Ok(mesh)
}

/// Reusable scratch space for triangulating faces.
#[derive(Default)]
pub(crate) struct Triangulator {
    earcut: earcut::Earcut<f64>,
    flat: Vec<[f64; 2]>,
    holes: Vec<u32>,
    out: Vec<u32>,
}

impl std::fmt::Debug for Triangulator {
    fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
        f.debug_struct("Triangulator").finish_non_exhaustive()
    }
}

impl Triangulator {
    /// Triangulates one face given as consecutive loops of `points` (the first loop outer, the
    /// rest holes). Replaces `tris` with triangles as indices into `points`, counter-clockwise
    /// around the outer loop's Newell normal, and returns that unit normal (zero for a face
    /// with no area).
    pub fn triangulate(
        &mut self,
        points: &[DVec3],
        loop_lens: &[usize],
        tris: &mut Vec<[usize; 3]>,
    ) -> DVec3 {
        tris.clear();
        let Some(&outer_len) = loop_lens.first() else { return DVec3::ZERO };
        let outer = &points[..outer_len.min(points.len())];
        if outer.len() < 3 {
            return DVec3::ZERO;
        }
        let newell = newell_normal(outer);
        let extent = bbox_diagonal(outer);
        // Twice the area against the square of the size: a sliver this thin has no area.
        if !(newell.length() > 1e-12 * extent * extent) {
            return DVec3::ZERO;
        }
        let normal = newell.normalize();
        let (t_axis, b_axis) = plane_axes(normal);
        let flat = |p: DVec3| DVec2::new(p.dot(t_axis), p.dot(b_axis));
        let area2 = |a: DVec2, b: DVec2, c: DVec2| (b - a).perp_dot(c - a);
        let has_holes = loop_lens.len() > 1 && loop_lens[1..].iter().any(|&n| n >= 3);

        // Fast paths: a triangle, and a convex quad split along its shorter diagonal.
        if !has_holes && outer_len == 3 {
            tris.push([0, 1, 2]);
            return normal;
        }
        if !has_holes && outer_len == 4 {
            let q: [DVec2; 4] = std::array::from_fn(|i| flat(outer[i]));
            let turns: [f64; 4] = std::array::from_fn(|i| area2(q[i], q[(i + 1) % 4], q[(i + 2) % 4]));
            if turns.iter().all(|&t| t > 0.0) {
                let d02 = outer[0].distance_squared(outer[2]);
                let d13 = outer[1].distance_squared(outer[3]);
                let pair = if d02 <= d13 { [[0, 1, 2], [0, 2, 3]] } else { [[0, 1, 3], [1, 2, 3]] };
                tris.extend_from_slice(&pair);
                return normal;
            }
        }

        self.flat.clear();
        self.holes.clear();
        let mut index_of_flat: Vec<usize> = Vec::with_capacity(points.len());
        let mut start = 0usize;
        for (l, &len) in loop_lens.iter().enumerate() {
            let end = (start + len).min(points.len());
            if l > 0 {
                if len < 3 {
                    start = end;
                    continue;
                }
                self.holes.push(self.flat.len() as u32);
            }
            for (k, p) in points[start..end].iter().enumerate() {
                self.flat.push(flat(*p).to_array());
                index_of_flat.push(start + k);
            }
            start = end;
        }
        self.earcut.earcut(self.flat.iter().copied(), &self.holes, &mut self.out);
        for t in self.out.chunks_exact(3) {
            let [a, b, c] = [t[0], t[1], t[2]].map(|i| i as usize);
            let (pa, pb, pc) = (self.flat[a], self.flat[b], self.flat[c]);
            let s = area2(DVec2::from(pa), DVec2::from(pb), DVec2::from(pc));
            let [a, b, c] = [a, b, c].map(|i| index_of_flat[i]);
            if s > 0.0 {
                tris.push([a, b, c]);
            } else if s < 0.0 {
                tris.push([a, c, b]);
            }
        }
        normal
    }
}

/// Newell's normal of a closed loop: twice its area along its normal.
pub(crate) fn newell_normal(points: &[DVec3]) -> DVec3 {
    // Relative to the first point, for precision far from the origin.
    let o = points[0];
    let mut n = DVec3::ZERO;
    for i in 0..points.len() {
        let (a, b) = (points[i] - o, points[(i + 1) % points.len()] - o);
        n += a.cross(b);
    }
    n
}

fn bbox_diagonal(points: &[DVec3]) -> f64 {
    let (lo, hi) =
        points.iter().fold((DVec3::splat(f64::INFINITY), DVec3::splat(f64::NEG_INFINITY)), |(l, h), &p| {
            (l.min(p), h.max(p))
        });
    (hi - lo).length()
}

/// Two unit axes spanning the plane perpendicular to `normal`, with `t x b = normal`.
fn plane_axes(normal: DVec3) -> (DVec3, DVec3) {
    let helper = if normal.x.abs() > 0.9 { DVec3::Y } else { DVec3::X };
    let t = helper.cross(normal).normalize();
    let b = normal.cross(t);
    (t, b)
}
