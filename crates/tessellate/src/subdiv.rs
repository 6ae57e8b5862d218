//! `SubdivisionMesh "catmull-clark"`: arbitrary polygons, boundaries, and the tags
//! `interpolateboundary`, `crease`, `corner` and `hole`.
//!
//! Rules (DeRose, Kass and Truong, "Subdivision surfaces in character animation", 1998, as
//! OpenSubdiv implements them with its default uniform sharpness decrement):
//! - Face points are face centroids; smooth edge points average the edge's ends and the two
//!   face points; edges with sharpness >= 1, boundary and non-manifold edges take the midpoint;
//!   sharpness in (0, 1) blends the two.
//! - A vertex with no or one sharp edge takes the smooth rule `(F + 2R + (n - 3) v) / n`, with
//!   two the crease rule `(a + 6v + b) / 8`, with three or more (or a sharp vertex) stays put.
//!   When the rule changes between a level and the next because sharpness runs out, the two
//!   rules are blended by the fractional sharpness of the edges that run out.
//! - Every level lowers every sharpness by one; `sharpness >= 10` is infinite.
//! - Without `interpolateboundary` the faces around boundary vertices are not drawn (as in
//!   RenderMan and OpenSubdiv's "boundary none"); with it, boundary edges are sharp creases and
//!   (for `interpolateboundary [1]`, the default) corners with one face are sharp vertices.
//! - `hole` faces (and their children) are subdivided but not drawn.
//!
//! The level comes from the tolerance, measured: a level's deviation is the distance of the
//! next level's edge and face points, pushed to the limit surface, from the level's flat
//! triangles (times 4/3, the most a quadratic error inside a triangle exceeds its
//! edge-midpoint values). Uniform levels are built until the regular faces (those away from
//! extraordinary vertices, darts and sharp corners) meet the tolerance or at most a tenth of
//! all faces miss it; once the regular faces' decay is steady and near-quadratic the remaining
//! uniform levels are predicted instead of measured, and semi-sharp creases are given levels
//! enough to run out where affordable. Then the faces that still miss the tolerance (or, after
//! a prediction, the faces around special vertices, where Catmull-Clark converges slowly) are
//! refined on their own, one level at a time, each time with the one-ring their limit depends
//! on, until they meet it; a drawn face next to refined ones is fanned from its centre through
//! the vertices they add on the shared edge, so closed meshes stay closed. Faces at sharp
//! corners (cone points, where refinement converges only linearly) take no part in the
//! measure. The drawn vertices are on the limit surface: the smooth limit stencil
//! `(n^2 v + 4 sum e + sum f) / (n (n + 5))` with the exact limit normal from Halstead et
//! al.'s tangent stencils at smooth vertices, the cubic B-spline limit `(a + 4v + b) / 6` on
//! creases, the vertex itself at corners; normals elsewhere are averaged from the limit
//! faces. Edges still semi-sharp at the drawn level are taken as sharp there.
//!
//! `st` of any class is carried per face corner and interpolated bilinearly (face-varying
//! linear); vertices are split only where the values differ.

use super::primvar::st_var;
use super::{TessellateError, Tolerance, TriangleMesh, check_budget, diagonal_of};
use glam::{DVec2, DVec3, Vec2};
use rib_parser::scene::SubdivisionMesh;
use std::collections::HashMap;
use std::f64::consts::PI;

const KIND: &str = "SubdivisionMesh";
/// OpenSubdiv's infinite sharpness.
const INFINITE_SHARPNESS: f64 = 10.0;
const MAX_LEVEL: u32 = 12;

fn invalid(reason: String) -> TessellateError {
    TessellateError::InvalidShape { kind: KIND, reason }
}

#[derive(Clone, Copy, Debug, PartialEq, Eq)]
enum Boundary {
    /// No `interpolateboundary`: faces around boundary vertices are not drawn.
    None,
    /// `interpolateboundary [1]`: boundary edges and one-face corners are sharp.
    EdgeAndCorner,
    /// `interpolateboundary [2]`: boundary edges are sharp, corners follow the crease rule.
    EdgeOnly,
}

#[derive(Clone, Debug)]
struct Edge {
    v: [u32; 2],
    /// Incident faces (two for an interior manifold edge).
    faces: u32,
    /// First two incident faces.
    face: [u32; 2],
    sharpness: f64,
}

/// One level of the mesh: polygons at level 0, quads after.
#[derive(Clone, Debug, Default)]
struct Level {
    positions: Vec<DVec3>,
    face_start: Vec<u32>,
    face_verts: Vec<u32>,
    /// The edge from each face corner to the next corner.
    face_edges: Vec<u32>,
    /// The control-mesh face every face descends from.
    face_origin: Vec<u32>,
    face_hidden: Vec<bool>,
    /// A marker every face passes to its children (the adaptive refinement's special faces).
    face_tag: Vec<u32>,
    edges: Vec<Edge>,
    vertex_sharpness: Vec<f64>,
    /// Edges of each vertex (CSR).
    vertex_edge_start: Vec<u32>,
    vertex_edges: Vec<u32>,
    /// Faces of each vertex with the corner index in that face (CSR).
    vertex_face_start: Vec<u32>,
    vertex_faces: Vec<(u32, u32)>,
    /// `st` per face corner.
    st: Option<Vec<DVec2>>,
}

impl Level {
    fn face_count(&self) -> usize {
        self.face_start.len() - 1
    }

    fn face(&self, f: usize) -> std::ops::Range<usize> {
        self.face_start[f] as usize..self.face_start[f + 1] as usize
    }

    /// Finds the edges of the faces (control mesh only: finer levels know theirs), with the
    /// sharpness of `sharp` edges, then the adjacency.
    fn build_topology(&mut self, sharp: &HashMap<(u32, u32), f64>) {
        let mut ids: HashMap<(u32, u32), u32> = HashMap::with_capacity(self.face_verts.len());
        self.edges.clear();
        self.face_edges = vec![0; self.face_verts.len()];
        for f in 0..self.face_count() {
            let r = self.face(f);
            let n = r.len();
            for k in 0..n {
                let (a, b) = (self.face_verts[r.start + k], self.face_verts[r.start + (k + 1) % n]);
                let key = (a.min(b), a.max(b));
                let edges = &mut self.edges;
                let id = *ids.entry(key).or_insert_with(|| {
                    edges.push(Edge {
                        v: [key.0, key.1],
                        faces: 0,
                        face: [u32::MAX; 2],
                        sharpness: sharp.get(&key).copied().unwrap_or(0.0),
                    });
                    (edges.len() - 1) as u32
                });
                self.face_edges[r.start + k] = id;
            }
        }
        self.build_adjacency();
    }

    /// Faces of every edge and the vertex-to-edge and vertex-to-face tables, from `edges` and
    /// `face_edges`.
    fn build_adjacency(&mut self) {
        for e in &mut self.edges {
            e.faces = 0;
            e.face = [u32::MAX; 2];
        }
        for f in 0..self.face_count() {
            for c in self.face(f) {
                let e = &mut self.edges[self.face_edges[c] as usize];
                if (e.faces as usize) < 2 {
                    e.face[e.faces as usize] = f as u32;
                }
                e.faces += 1;
            }
        }
        let nv = self.positions.len();
        let mut count = vec![0u32; nv + 1];
        for e in &self.edges {
            count[e.v[0] as usize + 1] += 1;
            count[e.v[1] as usize + 1] += 1;
        }
        for i in 0..nv {
            count[i + 1] += count[i];
        }
        let mut fill = count.clone();
        self.vertex_edges = vec![0; 2 * self.edges.len()];
        for (id, e) in self.edges.iter().enumerate() {
            for &v in &e.v {
                self.vertex_edges[fill[v as usize] as usize] = id as u32;
                fill[v as usize] += 1;
            }
        }
        self.vertex_edge_start = count;
        let mut count = vec![0u32; nv + 1];
        for &v in &self.face_verts {
            count[v as usize + 1] += 1;
        }
        for i in 0..nv {
            count[i + 1] += count[i];
        }
        let mut fill = count.clone();
        self.vertex_faces = vec![(0, 0); self.face_verts.len()];
        for f in 0..self.face_count() {
            for (k, c) in self.face(f).enumerate() {
                let v = self.face_verts[c] as usize;
                self.vertex_faces[fill[v] as usize] = (f as u32, k as u32);
                fill[v] += 1;
            }
        }
        self.vertex_face_start = count;
    }

    fn edges_of(&self, v: usize) -> &[u32] {
        &self.vertex_edges[self.vertex_edge_start[v] as usize..self.vertex_edge_start[v + 1] as usize]
    }

    fn faces_of(&self, v: usize) -> &[(u32, u32)] {
        &self.vertex_faces[self.vertex_face_start[v] as usize..self.vertex_face_start[v + 1] as usize]
    }

    fn other_end(&self, e: u32, v: usize) -> usize {
        let e = &self.edges[e as usize];
        if e.v[0] as usize == v { e.v[1] as usize } else { e.v[0] as usize }
    }

    fn is_boundary_vertex(&self, v: usize) -> bool {
        self.edges_of(v).iter().any(|&e| self.edges[e as usize].faces != 2)
    }
}

/// How a vertex moves: its rule and the ends of its sharp edges.
#[derive(Clone, Copy, Debug, PartialEq)]
enum Rule {
    Smooth,
    Crease(usize, usize),
    Corner,
}

/// The rule of vertex `v` with edge sharpness lowered by `lowered` (0: this level, 1: next).
fn vertex_rule(level: &Level, v: usize, lowered: f64, boundary: Boundary) -> Rule {
    let mut ends = [0usize; 2];
    let mut sharp = 0usize;
    let mut faces_boundary = 0usize;
    for &e in level.edges_of(v) {
        let edge = &level.edges[e as usize];
        let is_sharp = edge.faces != 2 || edge.sharpness - lowered > 0.0;
        if edge.faces != 2 {
            faces_boundary += 1;
        }
        if is_sharp {
            if sharp < 2 {
                ends[sharp] = level.other_end(e, v);
            }
            sharp += 1;
        }
    }
    let corner_vertex =
        boundary == Boundary::EdgeAndCorner && faces_boundary == 2 && level.faces_of(v).len() == 1;
    if level.vertex_sharpness[v] - lowered > 0.0 || sharp > 2 || corner_vertex {
        Rule::Corner
    } else if sharp == 2 {
        Rule::Crease(ends[0], ends[1])
    } else {
        Rule::Smooth
    }
}

/// Every vertex's rule at this level.
fn rules(level: &Level, boundary: Boundary) -> Vec<Rule> {
    (0..level.positions.len()).map(|v| vertex_rule(level, v, 0.0, boundary)).collect()
}

fn lowered_sharpness(s: f64) -> f64 {
    if s.is_infinite() { s } else { (s - 1.0).max(0.0) }
}

/// One Catmull-Clark step.
fn subdivide(level: &Level, boundary: Boundary) -> Level {
    let (nv, ne, nf) = (level.positions.len(), level.edges.len(), level.face_count());
    let mut positions = vec![DVec3::ZERO; nv + ne + nf];

    // Face points.
    for f in 0..nf {
        let r = level.face(f);
        let n = r.len() as f64;
        positions[nv + ne + f] = r.map(|c| level.positions[level.face_verts[c] as usize]).sum::<DVec3>() / n;
    }
    // Edge points.
    for (e, edge) in level.edges.iter().enumerate() {
        let (a, b) = (level.positions[edge.v[0] as usize], level.positions[edge.v[1] as usize]);
        let mid = 0.5 * (a + b);
        positions[nv + e] = if edge.faces != 2 || edge.sharpness >= 1.0 {
            mid
        } else {
            let smooth = 0.25
                * (a + b
                    + positions[nv + ne + edge.face[0] as usize]
                    + positions[nv + ne + edge.face[1] as usize]);
            if edge.sharpness > 0.0 { smooth.lerp(mid, edge.sharpness) } else { smooth }
        };
    }
    // Vertex points.
    for v in 0..nv {
        let p = level.positions[v];
        let apply = |rule: Rule| -> DVec3 {
            match rule {
                Rule::Corner => p,
                Rule::Crease(a, b) => (level.positions[a] + 6.0 * p + level.positions[b]) / 8.0,
                Rule::Smooth => {
                    let faces = level.faces_of(v);
                    let edges = level.edges_of(v);
                    if faces.is_empty() || edges.is_empty() {
                        return p;
                    }
                    let n = edges.len() as f64;
                    let f_avg = faces.iter().map(|&(f, _)| positions[nv + ne + f as usize]).sum::<DVec3>()
                        / faces.len() as f64;
                    let r_avg = edges
                        .iter()
                        .map(|&e| 0.5 * (p + level.positions[level.other_end(e, v)]))
                        .sum::<DVec3>()
                        / n;
                    (f_avg + 2.0 * r_avg + (n - 3.0) * p) / n
                }
            }
        };
        let parent = vertex_rule(level, v, 0.0, boundary);
        let child = vertex_rule(level, v, 1.0, boundary);
        positions[v] = if parent == child || matches!(parent, Rule::Smooth) {
            apply(parent)
        } else {
            // Sharpness runs out here: blend by the fractional sharpness that runs out.
            let mut weights = Vec::new();
            for &e in level.edges_of(v) {
                let s = level.edges[e as usize].sharpness;
                if level.edges[e as usize].faces == 2 && s > 0.0 && s <= 1.0 {
                    weights.push(s);
                }
            }
            let vs = level.vertex_sharpness[v];
            if vs > 0.0 && vs <= 1.0 {
                weights.push(vs);
            }
            let alpha =
                if weights.is_empty() { 1.0 } else { weights.iter().sum::<f64>() / weights.len() as f64 };
            apply(child).lerp(apply(parent), alpha.clamp(0.0, 1.0))
        };
    }

    // Children: one quad per face corner, counter-clockwise like the parent. Child edges:
    // `2e` and `2e + 1` are the halves of parent edge `e` (from `v[0]` and to `v[1]`), and
    // `2E + c` joins the edge point of corner `c`'s edge to its face point.
    let corners = level.face_verts.len();
    let mut edges = Vec::with_capacity(2 * ne + corners);
    for (e, edge) in level.edges.iter().enumerate() {
        let (ep, s) = ((nv + e) as u32, lowered_sharpness(edge.sharpness));
        edges.push(Edge { v: [edge.v[0], ep], faces: 0, face: [u32::MAX; 2], sharpness: s });
        edges.push(Edge { v: [ep, edge.v[1]], faces: 0, face: [u32::MAX; 2], sharpness: s });
    }
    let mut child = Level {
        positions,
        face_start: (0..=corners as u32).map(|i| 4 * i).collect(),
        face_verts: Vec::with_capacity(4 * corners),
        face_edges: Vec::with_capacity(4 * corners),
        face_origin: Vec::with_capacity(corners),
        face_hidden: Vec::with_capacity(corners),
        face_tag: Vec::with_capacity(corners),
        vertex_sharpness: Vec::with_capacity(nv + ne + nf),
        st: level.st.as_ref().map(|_| Vec::with_capacity(4 * corners)),
        ..Default::default()
    };
    // The half of parent edge `e` that touches vertex `v`.
    let half = |e: u32, v: u32| 2 * e + u32::from(level.edges[e as usize].v[0] != v);
    for f in 0..nf {
        let r = level.face(f);
        let n = r.len();
        let fp = (nv + ne + f) as u32;
        let st_centre = level.st.as_ref().map(|st| r.clone().map(|c| st[c]).sum::<DVec2>() / n as f64);
        for k in 0..n {
            let c = r.start + k;
            let prev = r.start + (k + n - 1) % n;
            let v = level.face_verts[c];
            let (e_next, e_prev) = (level.face_edges[c], level.face_edges[prev]);
            edges.push(Edge { v: [nv as u32 + e_next, fp], faces: 0, face: [u32::MAX; 2], sharpness: 0.0 });
            child.face_verts.extend_from_slice(&[v, nv as u32 + e_next, fp, nv as u32 + e_prev]);
            child.face_edges.extend_from_slice(&[
                half(e_next, v),
                (2 * ne + c) as u32,
                (2 * ne + prev) as u32,
                half(e_prev, v),
            ]);
            child.face_origin.push(level.face_origin[f]);
            child.face_hidden.push(level.face_hidden[f]);
            child.face_tag.push(level.face_tag[f]);
            if let (Some(out), Some(st), Some(centre)) = (child.st.as_mut(), level.st.as_ref(), st_centre) {
                let next = r.start + (k + 1) % n;
                out.extend_from_slice(&[st[c], 0.5 * (st[c] + st[next]), centre, 0.5 * (st[prev] + st[c])]);
            }
        }
    }
    child.edges = edges;
    child.vertex_sharpness.extend(level.vertex_sharpness.iter().map(|&s| lowered_sharpness(s)));
    child.vertex_sharpness.resize(nv + ne + nf, 0.0);
    child.build_adjacency();
    child
}

/// Limit positions of every vertex of a quad level, and the exact limit normal where the
/// vertex is smooth (zero elsewhere).
fn limit(level: &Level, boundary: Boundary) -> (Vec<DVec3>, Vec<DVec3>) {
    let rule = rules(level, boundary);
    let nv = level.positions.len();
    let mut positions = vec![DVec3::ZERO; nv];
    let mut normals = vec![DVec3::ZERO; nv];
    for v in 0..nv {
        let p = level.positions[v];
        // Remaining semi-sharpness counts as sharp at the drawn level.
        positions[v] = match rule[v] {
            Rule::Corner => p,
            Rule::Crease(a, b) => (level.positions[a] + 4.0 * p + level.positions[b]) / 6.0,
            Rule::Smooth => match smooth_ring(level, v) {
                Some((ring_e, ring_f)) => {
                    let n = ring_e.len() as f64;
                    let sum_e: DVec3 = ring_e.iter().map(|&i| level.positions[i]).sum();
                    let sum_f: DVec3 = ring_f.iter().map(|&i| level.positions[i]).sum();
                    normals[v] = limit_normal(level, &ring_e, &ring_f);
                    (n * n * p + 4.0 * sum_e + sum_f) / (n * (n + 5.0))
                }
                // A boundary vertex with a smooth rule (it has no sharp edges) cannot happen;
                // non-manifold fans keep their position.
                None => p,
            },
        };
    }
    (positions, normals)
}

/// The one-ring of an interior vertex of a quad level in counter-clockwise order: edge
/// neighbours `e_i` and the opposite corners `f_i` of the quads between `e_i` and `e_{i+1}`.
fn smooth_ring(level: &Level, v: usize) -> Option<(Vec<usize>, Vec<usize>)> {
    let faces = level.faces_of(v);
    // A boundary vertex has fewer faces than edges (and its walk would not close anyway).
    if faces.is_empty() || faces.len() != level.edges_of(v).len() {
        return None;
    }
    let corner = |f: u32, k: u32, offset: u32| {
        let r = level.face(f as usize);
        let n = r.len() as u32;
        level.face_verts[r.start + ((k + offset) % n) as usize] as usize
    };
    let (mut ring_e, mut ring_f) = (Vec::with_capacity(faces.len()), Vec::with_capacity(faces.len()));
    let (mut f, mut k) = faces[0];
    for _ in 0..faces.len() {
        if level.face(f as usize).len() != 4 {
            return None;
        }
        ring_e.push(corner(f, k, 1));
        ring_f.push(corner(f, k, 2));
        // The next face counter-clockwise has the current face's previous corner as its next.
        let prev = corner(f, k, 3);
        let (nf, nk) = *faces.iter().find(|&&(g, j)| g != f && corner(g, j, 1) == prev)?;
        f = nf;
        k = nk;
    }
    (f == faces[0].0).then_some((ring_e, ring_f))
}

/// Halstead, Kass and DeRose's limit tangents; their cross product is the limit normal.
fn limit_normal(level: &Level, ring_e: &[usize], ring_f: &[usize]) -> DVec3 {
    let p = |i: usize| level.positions[i];
    if ring_e.len() == 4 {
        // The regular case, with the stencil's constants: A_4 = 4, cos and sin of i pi / 2.
        let t1 =
            4.0 * (p(ring_e[0]) - p(ring_e[2])) + p(ring_f[0]) - p(ring_f[1]) - p(ring_f[2]) + p(ring_f[3]);
        let t2 =
            4.0 * (p(ring_e[1]) - p(ring_e[3])) + p(ring_f[0]) + p(ring_f[1]) - p(ring_f[2]) - p(ring_f[3]);
        return t1.cross(t2);
    }
    let n = ring_e.len();
    let nf = n as f64;
    let a_n = 1.0 + (2.0 * PI / nf).cos() + (PI / nf).cos() * (2.0 * (9.0 + (2.0 * PI / nf).cos())).sqrt();
    let (mut t1, mut t2) = (DVec3::ZERO, DVec3::ZERO);
    let angle = |i: usize| (2.0 * PI * i as f64 / nf).sin_cos();
    let (mut s0, mut c0) = angle(0);
    for i in 0..n {
        let (s1, c1) = angle(i + 1);
        let (e, f) = (p(ring_e[i]), p(ring_f[i]));
        t1 += a_n * c0 * e + (c0 + c1) * f;
        t2 += a_n * s0 * e + (s0 + s1) * f;
        (s0, c0) = (s1, c1);
    }
    t1.cross(t2)
}

/// The control mesh with its tags, checked.
fn control_level(sm: &SubdivisionMesh) -> Result<(Level, Boundary, u32), TessellateError> {
    if !sm.scheme.eq_ignore_ascii_case("catmull-clark") {
        return Err(TessellateError::UnsupportedScheme(sm.scheme.clone()));
    }
    let total: u64 = sm.vertices_per_face.iter().map(|&n| n as u64).sum();
    if total != sm.vertex_indices.len() as u64 {
        return Err(invalid(format!(
            "the faces have {total} vertices in all but {} indices are given",
            sm.vertex_indices.len()
        )));
    }
    let nv = sm.positions.len();
    if let Some(&bad) = sm.vertex_indices.iter().find(|&&i| i as usize >= nv) {
        return Err(invalid(format!("vertex index {bad} but only {nv} positions")));
    }
    if let Some(p) = sm.positions.iter().find(|p| !p.is_finite()) {
        return Err(TessellateError::NonFinite { kind: KIND, reason: format!("position {p}") });
    }
    let faces = sm.vertices_per_face.len();
    let corners = sm.vertex_indices.len();
    let st_in = st_var(&sm.primvars).filter(|v| v.fits(faces, nv, corners));

    let mut level = Level {
        positions: sm.positions.iter().map(|p| p.as_dvec3()).collect(),
        face_start: vec![0],
        vertex_sharpness: vec![0.0; nv],
        st: st_in.as_ref().map(|_| Vec::new()),
        ..Default::default()
    };
    let mut degenerate = 0u32;
    let mut start = 0usize;
    let mut kept_face_of_input = vec![u32::MAX; faces];
    for (f, &n) in sm.vertices_per_face.iter().enumerate() {
        let range = start..start + n as usize;
        start += n as usize;
        // Drop repeated consecutive vertices; fewer than three left is no face.
        let mut verts: Vec<(u32, usize)> = Vec::with_capacity(n as usize);
        for c in range {
            let v = sm.vertex_indices[c];
            if verts.last().map(|&(w, _)| w) != Some(v) {
                verts.push((v, c));
            }
        }
        while verts.len() > 1 && verts.first().map(|x| x.0) == verts.last().map(|x| x.0) {
            verts.pop();
        }
        if verts.len() < 3 {
            degenerate += 1;
            continue;
        }
        kept_face_of_input[f] = level.face_origin.len() as u32;
        for &(v, c) in &verts {
            level.face_verts.push(v);
            if let (Some(out), Some(var)) = (level.st.as_mut(), st_in.as_ref()) {
                out.push(var.at(f, v as usize, c).filter(|s| s.is_finite()).unwrap_or(Vec2::ZERO).as_dvec2());
            }
        }
        level.face_start.push(level.face_verts.len() as u32);
        level.face_origin.push(f as u32);
        level.face_hidden.push(false);
        level.face_tag.push(u32::MAX);
    }

    let mut boundary = Boundary::None;
    let mut sharp: HashMap<(u32, u32), f64> = HashMap::new();
    let sharpness = |s: f32| -> f64 {
        let s = s as f64;
        if s >= INFINITE_SHARPNESS {
            f64::INFINITY
        } else if s.is_finite() {
            s.max(0.0)
        } else {
            0.0
        }
    };
    for tag in &sm.tags {
        match tag.name.as_str() {
            "interpolateboundary" => {
                boundary = match tag.int_args.first() {
                    Some(0) => Boundary::None,
                    Some(2) => Boundary::EdgeOnly,
                    _ => Boundary::EdgeAndCorner,
                };
            }
            "crease" => {
                let s = tag.float_args.first().copied().map(sharpness).unwrap_or(f64::INFINITY);
                for w in tag.int_args.windows(2) {
                    let (a, b) = (w[0], w[1]);
                    if a < 0 || b < 0 || a as usize >= nv || b as usize >= nv || a == b {
                        continue;
                    }
                    let key = ((a as u32).min(b as u32), (a as u32).max(b as u32));
                    let entry = sharp.entry(key).or_insert(0.0);
                    *entry = entry.max(s);
                }
            }
            "corner" => {
                for (k, &v) in tag.int_args.iter().enumerate() {
                    let s = tag.float_args.get(k).or(tag.float_args.first()).copied().map(sharpness);
                    if v >= 0 && (v as usize) < nv {
                        let slot = &mut level.vertex_sharpness[v as usize];
                        *slot = slot.max(s.unwrap_or(f64::INFINITY));
                    }
                }
            }
            "hole" => {
                for &f in &tag.int_args {
                    if f >= 0 && (f as usize) < faces && kept_face_of_input[f as usize] != u32::MAX {
                        level.face_hidden[kept_face_of_input[f as usize] as usize] = true;
                    }
                }
            }
            // Other tags ("facevaryinginterpolateboundary", "smoothtriangles", "stitch", ...)
            // do not change the surface's shape.
            _ => {}
        }
    }
    level.build_topology(&sharp);
    if boundary == Boundary::None {
        for f in 0..level.face_count() {
            if level.face(f).any(|c| level.is_boundary_vertex(level.face_verts[c] as usize)) {
                level.face_hidden[f] = true;
            }
        }
    }
    Ok((level, boundary, degenerate))
}

/// Vertices around which uniform refinement converges slowly: sharp corners, darts, and
/// extraordinary vertices (valence other than 4 inside or along a crease, other than 3 on a
/// boundary). The faces around them are refined adaptively.
fn special_vertices(level: &Level, boundary: Boundary) -> Vec<bool> {
    let rule = rules(level, boundary);
    (0..level.positions.len())
        .map(|v| {
            if level.faces_of(v).is_empty() {
                return false;
            }
            let valence = level.edges_of(v).len();
            let sharp = level
                .edges_of(v)
                .iter()
                .filter(|&&e| {
                    let e = &level.edges[e as usize];
                    e.faces != 2 || e.sharpness > 0.0
                })
                .count();
            match rule[v] {
                Rule::Corner => true,
                Rule::Crease(..) => valence != if level.is_boundary_vertex(v) { 3 } else { 4 },
                Rule::Smooth => sharp == 1 || valence != 4,
            }
        })
        .collect()
}

/// How far each face of a level is from the limit surface (0 for hidden faces): the next
/// level's edge and face points on the limit against the face's flat triangles, times 4/3
/// (sampled at edge midpoints and quad centres; inside a triangle a quadratic error reaches
/// up to 4/3 of its largest edge-midpoint value).
fn face_deviations(level: &Level, level_limit: &[DVec3], next_limit: &[DVec3]) -> Vec<f64> {
    let (nv, ne) = (level.positions.len(), level.edges.len());
    (0..level.face_count())
        .map(|f| {
            if level.face_hidden[f] {
                return 0.0;
            }
            let r = level.face(f);
            let q: Vec<DVec3> = r.clone().map(|c| level_limit[level.face_verts[c] as usize]).collect();
            let centre = next_limit[nv + ne + f];
            let mut worst = 0.0f64;
            if q.len() == 4 {
                worst = centre.distance(0.5 * (q[0] + q[2])).max(centre.distance(0.5 * (q[1] + q[3])));
            }
            for c in r {
                let e = level.face_edges[c] as usize;
                let [a, b] = level.edges[e].v.map(|v| level_limit[v as usize]);
                worst = worst.max(next_limit[nv + e].distance(0.5 * (a + b)));
            }
            4.0 / 3.0 * worst
        })
        .collect()
}

/// The one-ring sub-mesh of some faces of a level: those faces (tagged with their index in
/// `faces`) and every face sharing a vertex with them, which is all a Catmull-Clark face's
/// limit surface depends on.
struct Ring {
    mesh: Level,
    /// The level's vertex of each sub-mesh vertex.
    global: Vec<u32>,
    /// The sub-mesh vertex of each level vertex in it.
    local: HashMap<u32, u32>,
    /// The sub-mesh face of each of the given faces.
    face_of: Vec<u32>,
}

impl Ring {
    fn new(level: &Level, faces: &[usize]) -> Ring {
        let mut ring = vec![false; level.face_count()];
        let mut tag = vec![u32::MAX; level.face_count()];
        for (i, &f) in faces.iter().enumerate() {
            tag[f] = i as u32;
            for c in level.face(f) {
                for &(g, _) in level.faces_of(level.face_verts[c] as usize) {
                    ring[g as usize] = true;
                }
            }
        }
        let mut local: HashMap<u32, u32> = HashMap::new();
        let mut global = Vec::new();
        let mut face_of = vec![0u32; faces.len()];
        let mut sub =
            Level { face_start: vec![0], st: level.st.as_ref().map(|_| Vec::new()), ..Default::default() };
        for f in (0..level.face_count()).filter(|&f| ring[f]) {
            if tag[f] != u32::MAX {
                face_of[tag[f] as usize] = sub.face_origin.len() as u32;
            }
            for c in level.face(f) {
                let v = level.face_verts[c];
                let id = *local.entry(v).or_insert_with(|| {
                    global.push(v);
                    sub.positions.push(level.positions[v as usize]);
                    sub.vertex_sharpness.push(level.vertex_sharpness[v as usize]);
                    (global.len() - 1) as u32
                });
                sub.face_verts.push(id);
                if let (Some(out), Some(st)) = (sub.st.as_mut(), level.st.as_ref()) {
                    out.push(st[c]);
                }
            }
            sub.face_start.push(sub.face_verts.len() as u32);
            sub.face_origin.push(level.face_origin[f]);
            sub.face_hidden.push(level.face_hidden[f]);
            sub.face_tag.push(tag[f]);
        }
        let mut sharp = HashMap::new();
        for e in &level.edges {
            if e.sharpness > 0.0
                && let (Some(&a), Some(&b)) = (local.get(&e.v[0]), local.get(&e.v[1]))
            {
                sharp.insert((a.min(b), a.max(b)), e.sharpness);
            }
        }
        sub.build_topology(&sharp);
        Ring { mesh: sub, global, local, face_of }
    }
}

/// One node of the adaptive refinement: a level (the drawn level at the root, else one step
/// below its parent's ring of refined faces), the faces it draws, and the edges its child
/// splits.
struct Node {
    level: Level,
    limit: (Vec<DVec3>, Vec<DVec3>),
    /// For a child: its parent node, and the parent vertex of each of its first vertices
    /// (vertex points keep their index through a subdivision step).
    parent: Option<(usize, Vec<u32>)>,
    /// Faces of `level` drawn here.
    drawn: Vec<usize>,
    /// Edges of `level` (by their ends) that the child refines, with the child's vertex in
    /// their middle.
    split: HashMap<(u32, u32), u32>,
}

fn key(a: u32, b: u32) -> (u32, u32) {
    (a.min(b), a.max(b))
}

/// Refines, below node `id`, the faces among `candidates` that miss the tolerance, one level
/// at a time, until every drawn face meets it (faces at sharp corners excepted) or the budget
/// or depth runs out.
fn refine(
    nodes: &mut Vec<Node>,
    root: usize,
    root_candidates: Vec<usize>,
    (eps, boundary, tol): (f64, Boundary, &Tolerance),
    planning: &mut Planning,
) -> Result<(), TessellateError> {
    let (mut id, mut candidates, mut depth) = (root, root_candidates, 0u32);
    let mut faces_so_far = nodes[root].level.face_count() as f64;
    while !candidates.is_empty() && depth < MAX_LEVEL {
        let level = &nodes[id].level;
        let ring = Ring::new(level, &candidates);
        check_budget(KIND, 2.0 * (faces_so_far + 4.0 * ring.mesh.face_count() as f64), tol)?;
        let child_level = subdivide(&ring.mesh, boundary);
        let child_limit = limit(&child_level, boundary);
        let bad: Vec<bool> = match planning {
            // Another key's choice, face for face.
            Planning::Replay(plan) => match plan.refined.get(depth as usize) {
                Some(bad) if bad.len() == candidates.len() => bad.clone(),
                Some(_) => return Err(invalid("its keys refine different faces".into())),
                None => break,
            },
            _ => {
                // Each candidate against the child's edge and face points on the limit.
                let ring_limit: Vec<DVec3> =
                    ring.global.iter().map(|&g| nodes[id].limit.0[g as usize]).collect();
                let deviations = face_deviations(&ring.mesh, &ring_limit, &child_limit.0);
                if deviations.iter().any(|d| !d.is_finite()) {
                    return Err(TessellateError::NonFinite {
                        kind: KIND,
                        reason: "subdivision diverged".into(),
                    });
                }
                let level = &nodes[id].level;
                let rule = rules(level, boundary);
                candidates
                    .iter()
                    .enumerate()
                    .map(|(i, &f)| {
                        // Faces at sharp corners (cone points) converge only linearly however far
                        // they are refined: they do not decide anything.
                        let at_corner =
                            level.face(f).any(|c| rule[level.face_verts[c] as usize] == Rule::Corner);
                        deviations[ring.face_of[i] as usize] > eps && !at_corner
                    })
                    .collect()
            }
        };
        if !bad.contains(&true) {
            break;
        }
        if let Planning::Record(plan) = planning {
            plan.refined.push(bad.clone());
        }
        let level = &nodes[id].level;
        // The bad faces are replaced by their children; the others stay drawn here.
        let mut split = HashMap::new();
        let n_ring = ring.mesh.positions.len() as u32;
        let mut replaced = vec![false; level.face_count()];
        for (i, &f) in candidates.iter().enumerate().filter(|&(i, _)| bad[i]) {
            replaced[f] = true;
            for c in level.face(f) {
                let e = &level.edges[level.face_edges[c] as usize];
                let (a, b) = (e.v[0], e.v[1]);
                let (la, lb) = (ring.local[&a], ring.local[&b]);
                let ring_face = ring.face_of[i] as usize;
                // The ring's edge between them: one of its face's edges.
                let ring_edge = ring
                    .mesh
                    .face(ring_face)
                    .map(|rc| ring.mesh.face_edges[rc])
                    .find(|&re| {
                        key(ring.mesh.edges[re as usize].v[0], ring.mesh.edges[re as usize].v[1])
                            == key(la, lb)
                    })
                    .expect("a face's edge is in its ring");
                split.insert(key(a, b), n_ring + ring_edge);
            }
        }
        nodes[id].drawn.retain(|&f| !replaced[f]);
        nodes[id].split = split;
        let drawn: Vec<usize> = (0..child_level.face_count())
            .filter(|&f| {
                let tag = child_level.face_tag[f];
                tag != u32::MAX && bad[tag as usize] && !child_level.face_hidden[f]
            })
            .collect();
        // Tags of the child: the index of each face among its drawn faces, for the next step.
        faces_so_far += drawn.len() as f64;
        nodes.push(Node {
            level: child_level,
            limit: child_limit,
            parent: Some((id, ring.global)),
            drawn: drawn.clone(),
            split: HashMap::new(),
        });
        id = nodes.len() - 1;
        candidates = drawn;
        depth += 1;
    }
    Ok(())
}

pub(crate) fn tessellate_subdivision(
    sm: &SubdivisionMesh,
    tol: &Tolerance,
    scale: f64,
) -> Result<TriangleMesh, TessellateError> {
    tessellate_subdivision_planned(sm, tol, scale, &mut Planning::Free)
}

/// How the position-dependent choices of a tessellation (levels, refined faces, quad
/// diagonals) are made: from the mesh's own positions, recorded as well, or replayed from
/// another key of a deforming mesh so that every key gives the same triangles.
pub(crate) enum Planning {
    Free,
    Record(SubdivPlan),
    Replay(SubdivPlan),
}

/// The choices one key's positions led to (see [`Planning`]).
#[derive(Clone, Debug, Default, PartialEq)]
pub(crate) struct SubdivPlan {
    /// The uniform level drawn.
    level: u32,
    /// Faces of that level refined on their own.
    candidates: Vec<usize>,
    /// At each adaptive step, which of its candidates were refined.
    refined: Vec<Vec<bool>>,
    /// For every quad drawn, in order: split along its 1-3 diagonal (else 0-2).
    diagonals: Vec<bool>,
}

/// [`tessellate_subdivision`] with its choices made as `planning` says. Recorded and replayed
/// meshes keep their zero-area triangles (a key may give them area).
pub(crate) fn tessellate_subdivision_planned(
    sm: &SubdivisionMesh,
    tol: &Tolerance,
    scale: f64,
    planning: &mut Planning,
) -> Result<TriangleMesh, TessellateError> {
    let (control, boundary, degenerate) = control_level(sm)?;
    let size = diagonal_of(KIND, control.positions.iter().copied())?;
    let eps = tol.effective(size, scale)?;
    if control.face_count() == 0 {
        return Ok(TriangleMesh { degenerate_faces: degenerate, ..Default::default() });
    }
    // Triangles of level k: 2 * corners * 4^(k - 1).
    let corners = control.face_verts.len() as f64;
    let triangles_at = |k: u32| 2.0 * corners * 4f64.powi(k as i32 - 1);
    check_budget(KIND, triangles_at(1), tol)?;
    let cap = tol.max_triangles as f64;

    // Semi-sharp creases should have run out by the drawn level (then its limit positions are
    // exact), where that is affordable.
    let finite_sharpness = control
        .edges
        .iter()
        .map(|e| e.sharpness)
        .chain(control.vertex_sharpness.iter().copied())
        .filter(|s| s.is_finite())
        .fold(0.0f64, f64::max);
    let mut min_level = (finite_sharpness.ceil() as u32).clamp(1, MAX_LEVEL);
    while min_level > 1 && triangles_at(min_level) > cap {
        min_level -= 1;
    }

    // Uniform levels first. A level is measured with the next one; it is drawn once its
    // regular faces (away from special vertices) meet the tolerance, or once at most a tenth
    // of its faces miss it (those are then refined on their own). Once two successive decay
    // rates of the regular faces agree and are near-quadratic, the remaining levels are
    // predicted instead of built only to be measured.
    let mut current = subdivide(&control, boundary);
    let mut current_limit = limit(&current, boundary);
    let mut k = 1u32;
    let mut measured: Vec<f64> = Vec::new();
    if let Planning::Replay(plan) = planning {
        check_budget(KIND, triangles_at(plan.level), tol)?;
        while k < plan.level.min(MAX_LEVEL) {
            current = subdivide(&current, boundary);
            k += 1;
        }
        current_limit = limit(&current, boundary);
    }
    // The drawn level, its number, its limit, and the faces to refine further (None: those
    // around special vertices).
    let drawn = loop {
        if let Planning::Replay(plan) = planning {
            break (current, k, current_limit, Some(plan.candidates.clone()));
        }
        // Measuring needs the next level; it is only built while it is affordable.
        if k >= MAX_LEVEL || triangles_at(k + 1) > 4.0 * cap {
            break (current, k, current_limit, None);
        }
        let stable = match measured[..] {
            [.., a, b, c] if b > 0.0 && c > 0.0 => ((a / b) / (b / c) - 1.0).abs() < 0.15 && b / c >= 3.0,
            _ => false,
        };
        if let ([.., before, last], true) = (&measured[..], stable) {
            let (before, last) = (*before, *last);
            let ratio = (before / last).clamp(2.0, 4.0);
            let (mut predicted, mut level) = (last / ratio, k);
            while (predicted > eps || level < min_level) && level < MAX_LEVEL {
                predicted /= ratio;
                level += 1;
            }
            check_budget(KIND, triangles_at(level), tol)?;
            if level > k {
                while k < level {
                    current = subdivide(&current, boundary);
                    k += 1;
                }
                current_limit = limit(&current, boundary);
            }
            break (current, k, current_limit, None);
        }
        let next = subdivide(&current, boundary);
        let next_limit = limit(&next, boundary);
        let special = special_vertices(&current, boundary);
        let deviations = face_deviations(&current, &current_limit.0, &next_limit.0);
        if deviations.iter().any(|d| !d.is_finite()) {
            return Err(TessellateError::NonFinite { kind: KIND, reason: "subdivision diverged".into() });
        }
        let visible: Vec<usize> = (0..current.face_count()).filter(|&f| !current.face_hidden[f]).collect();
        let regular: Vec<usize> = visible
            .iter()
            .copied()
            .filter(|&f| !current.face(f).any(|c| special[current.face_verts[c] as usize]))
            .collect();
        let d = regular.iter().map(|&f| deviations[f]).fold(0.0f64, f64::max);
        let rule = rules(&current, boundary);
        let at_corner =
            |f: usize| current.face(f).any(|c| rule[current.face_verts[c] as usize] == Rule::Corner);
        let bad: Vec<usize> =
            visible.iter().copied().filter(|&f| deviations[f] > eps && !at_corner(f)).collect();
        if k >= min_level && (bad.is_empty() || (!regular.is_empty() && bad.len() * 10 <= visible.len())) {
            break (current, k, current_limit, Some(bad));
        }
        // A level with no regular face yet says nothing about the decay.
        if !regular.is_empty() {
            measured.push(d);
        }
        if measured.len() == 1 && d / 4.0 <= eps && k + 1 >= min_level {
            check_budget(KIND, triangles_at(k + 1), tol)?;
            break (next, k + 1, next_limit, None);
        }
        current = next;
        current_limit = next_limit;
        k += 1;
    };
    let (level, level_number, level_limit, known_bad) = drawn;
    check_budget(KIND, 2.0 * level.face_count() as f64, tol)?;

    // Faces around special vertices: refined on their own, level by level, until they meet
    // the tolerance too.
    let candidates: Vec<usize> = known_bad.unwrap_or_else(|| {
        let special = special_vertices(&level, boundary);
        (0..level.face_count())
            .filter(|&f| {
                !level.face_hidden[f] && level.face(f).any(|c| special[level.face_verts[c] as usize])
            })
            .collect()
    });
    if candidates.iter().any(|&f| f >= level.face_count()) {
        return Err(invalid("its keys refine different faces".into()));
    }
    if let Planning::Record(plan) = planning {
        (plan.level, plan.candidates) = (level_number, candidates.clone());
    }
    let drawn: Vec<usize> = (0..level.face_count()).filter(|&f| !level.face_hidden[f]).collect();
    let mut nodes = vec![Node { level, limit: level_limit, parent: None, drawn, split: HashMap::new() }];
    refine(&mut nodes, 0, candidates, (eps, boundary, tol), planning)?;
    let mesh = emit(&nodes, degenerate, planning)?;
    check_budget(KIND, mesh.triangle_count() as f64, tol)?;
    Ok(mesh)
}

/// Output vertices: shared per (source vertex, st), with the exact limit normal when known.
#[derive(Default)]
struct Output {
    mesh: TriangleMesh,
    st: Vec<Vec2>,
    exact_normals: Vec<DVec3>,
    ids: HashMap<(u32, u32, u64, u64), u32>,
    /// The first output vertex made for each source vertex.
    by_source: HashMap<(u32, u32), u32>,
    /// Without st: the output vertex of each node's vertices, a table instead of hashing.
    plain: Vec<Vec<u32>>,
    with_st: bool,
    /// A key of a deforming mesh: zero-area triangles are kept, quad diagonals recorded or
    /// replayed (see [`Planning`]).
    keyed: bool,
    diagonals: Vec<bool>,
    replayed: Option<std::vec::IntoIter<bool>>,
}

impl Output {
    /// The output vertex of vertex `v` of refinement node `space`.
    fn vertex(&mut self, space: u32, v: u32, st: Option<DVec2>, position: DVec3, normal: DVec3) -> u32 {
        if st.is_none() {
            if let Some(id) = self.lookup(space, v) {
                return id;
            }
            self.mesh.positions.push(position.as_vec3());
            self.exact_normals.push(normal);
            let id = (self.mesh.positions.len() - 1) as u32;
            let (space, v) = (space as usize, v as usize);
            if self.plain.len() <= space {
                self.plain.resize(space + 1, Vec::new());
            }
            if self.plain[space].len() <= v {
                self.plain[space].resize(v + 1, u32::MAX);
            }
            self.plain[space][v] = id;
            return id;
        }
        let key = st.map_or((space, v, 0, 0), |s| (space, v, s.x.to_bits(), s.y.to_bits()));
        let Output { mesh, st: st_out, exact_normals, ids, by_source, .. } = self;
        *ids.entry(key).or_insert_with(|| {
            mesh.positions.push(position.as_vec3());
            exact_normals.push(normal);
            if let Some(s) = st {
                st_out.push(s.as_vec2());
            }
            let id = (mesh.positions.len() - 1) as u32;
            by_source.entry((space, v)).or_insert(id);
            id
        })
    }

    /// The output vertex already made for vertex `v` of node `space`, if any.
    fn lookup(&self, space: u32, v: u32) -> Option<u32> {
        let found = match self.with_st {
            true => self.by_source.get(&(space, v)).copied(),
            false => self.plain.get(space as usize).and_then(|t| t.get(v as usize)).copied(),
        };
        found.filter(|&id| id != u32::MAX)
    }

    fn fresh_vertex(&mut self, position: DVec3, st: Option<DVec2>) -> u32 {
        self.mesh.positions.push(position.as_vec3());
        self.exact_normals.push(DVec3::ZERO);
        if let Some(s) = st {
            self.st.push(s.as_vec2());
        }
        (self.mesh.positions.len() - 1) as u32
    }

    fn triangle(&mut self, t: [u32; 3], face: u32) {
        let [a, b, c] = t.map(|i| self.mesh.positions[i as usize].as_dvec3());
        if t[0] != t[1] && t[1] != t[2] && t[0] != t[2] && (self.keyed || (b - a).cross(c - a) != DVec3::ZERO)
        {
            self.mesh.indices.push(t);
            self.mesh.face_index.push(face);
        }
    }

    /// Two triangles of a quad, split along its shorter diagonal.
    fn quad(&mut self, ids: [u32; 4], face: u32) {
        let p = |i: usize| self.mesh.positions[ids[i] as usize];
        let shorter_02 = match self.replayed.as_mut() {
            Some(recorded) => recorded.next().unwrap_or(true),
            None => p(0).distance_squared(p(2)) <= p(1).distance_squared(p(3)),
        };
        if self.keyed {
            self.diagonals.push(shorter_02);
        }
        let tris = if shorter_02 {
            [[ids[0], ids[1], ids[2]], [ids[0], ids[2], ids[3]]]
        } else {
            [[ids[0], ids[1], ids[3]], [ids[1], ids[2], ids[3]]]
        };
        for t in tris {
            self.triangle(t, face);
        }
    }

    /// Normals: the exact limit normal on the side the winding says, else the area-weighted
    /// normal of the vertex's triangles.
    fn finish(mut self) -> TriangleMesh {
        let mut sums = vec![DVec3::ZERO; self.mesh.positions.len()];
        for t in 0..self.mesh.indices.len() {
            let cross = self.mesh.face_cross(t);
            for &i in &self.mesh.indices[t] {
                sums[i as usize] += cross;
            }
        }
        let normals = sums
            .iter()
            .zip(&self.exact_normals)
            .map(|(&around, &exact)| {
                let n = if exact.length_squared() > 0.0 && exact.dot(around) >= 0.0 {
                    exact
                } else if exact.length_squared() > 0.0 && around.length_squared() > 0.0 {
                    -exact
                } else {
                    around
                };
                n.normalize_or(DVec3::Z).as_vec3()
            })
            .collect();
        self.mesh.normals = Some(normals);
        if self.with_st {
            self.mesh.st = Some(self.st);
        }
        super::grid::compact(&mut self.mesh);
        self.mesh
    }
}

/// The output vertex of vertex `v` of node `node`: a vertex that descends from a parent's
/// vertex is that vertex (so nodes share their boundaries exactly).
fn resolve(nodes: &[Node], mut node: usize, mut v: u32) -> (usize, u32) {
    while let Some((parent, global)) = &nodes[node].parent {
        match global.get(v as usize) {
            Some(&g) => {
                node = *parent;
                v = g;
            }
            None => break,
        }
    }
    (node, v)
}

/// The output vertices strictly inside edge `a`-`b` of node `node`, in order from `a`: the
/// middle vertices the descendants add.
fn chain(nodes: &[Node], out: &mut Output, node: usize, a: u32, b: u32, st: Option<DVec2>) -> Vec<u32> {
    let Some(&middle) = nodes[node].split.get(&key(a, b)) else { return Vec::new() };
    let child = nodes
        .iter()
        .position(|n| n.parent.as_ref().is_some_and(|(p, _)| *p == node))
        .expect("split by a child");
    let global = &nodes[child].parent.as_ref().expect("a child").1;
    let local = |v: u32| global.iter().position(|&g| g == v).expect("in the ring") as u32;
    let (la, lb) = (local(a), local(b));
    let mut points = chain(nodes, out, child, la, middle, st);
    points.push(output_vertex(nodes, out, child, middle, st));
    points.extend(chain(nodes, out, child, middle, lb, st));
    points
}

fn output_vertex(nodes: &[Node], out: &mut Output, node: usize, v: u32, st: Option<DVec2>) -> u32 {
    let (n, v) = resolve(nodes, node, v);
    if let Some(id) = out.lookup(n as u32, v) {
        return id;
    }
    out.vertex(n as u32, v, st, nodes[n].limit.0[v as usize], nodes[n].limit.1[v as usize])
}

/// Triangles of every node's drawn faces on the limit surface. A drawn face next to refined
/// ones is fanned from its centre through the vertices they add on the shared edges, so the
/// mesh stays closed.
fn emit(nodes: &[Node], degenerate: u32, planning: &mut Planning) -> Result<TriangleMesh, TessellateError> {
    let mut out = Output {
        with_st: nodes[0].level.st.is_some(),
        keyed: !matches!(planning, Planning::Free),
        replayed: match planning {
            Planning::Replay(plan) => Some(plan.diagonals.clone().into_iter()),
            _ => None,
        },
        ..Default::default()
    };
    out.mesh.degenerate_faces = degenerate;
    // Deepest nodes first, so the vertices shared along split edges exist with their st.
    for node in (0..nodes.len()).rev() {
        let level = &nodes[node].level;
        for &f in &nodes[node].drawn {
            let r = level.face(f);
            let n = r.len();
            let st_of = |c: usize| level.st.as_ref().map(|s| s[c]);
            let ids: Vec<u32> = r
                .clone()
                .map(|c| {
                    let (m, v) = resolve(nodes, node, level.face_verts[c]);
                    out.vertex(
                        m as u32,
                        v,
                        st_of(c),
                        nodes[m].limit.0[v as usize],
                        nodes[m].limit.1[v as usize],
                    )
                })
                .collect();
            let mut outline: Vec<u32> = Vec::with_capacity(n);
            for k in 0..n {
                let (c, next) = (r.start + k, r.start + (k + 1) % n);
                outline.push(ids[k]);
                let edge_st = level.st.as_ref().map(|s| s[c].lerp(s[next], 0.5));
                outline.extend(chain(
                    nodes,
                    &mut out,
                    node,
                    level.face_verts[c],
                    level.face_verts[next],
                    edge_st,
                ));
            }
            let face = level.face_origin[f];
            if outline.len() == 4 {
                out.quad([outline[0], outline[1], outline[2], outline[3]], face);
                continue;
            }
            let centre =
                r.clone().map(|c| out.mesh.positions[ids[c - r.start] as usize].as_dvec3()).sum::<DVec3>()
                    / n as f64;
            let centre_st = level.st.as_ref().map(|s| r.clone().map(|c| s[c]).sum::<DVec2>() / n as f64);
            let middle = out.fresh_vertex(centre, centre_st);
            for k in 0..outline.len() {
                out.triangle([middle, outline[k], outline[(k + 1) % outline.len()]], face);
            }
        }
    }
    match planning {
        Planning::Record(plan) => plan.diagonals = std::mem::take(&mut out.diagonals),
        Planning::Replay(plan) if out.diagonals != plan.diagonals => {
            return Err(invalid("its keys draw different quads".into()));
        }
        _ => {}
    }
    Ok(out.finish())
}
