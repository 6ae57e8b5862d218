//! One level of a subdivision mesh (faces, edges with their sharpness, vertex adjacency) and
//! the control mesh read from a `SubdivisionMesh` with its tags.

use super::super::primvar::st_var;
use super::{INFINITE_SHARPNESS, KIND, TessellateError, invalid};
use glam::{DVec2, DVec3, Vec2};
use rib_parser::scene::SubdivisionMesh;
use std::collections::HashMap;

#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub(super) enum Boundary {
    /// No `interpolateboundary`: faces around boundary vertices are not drawn.
    None,
    /// `interpolateboundary [1]`: boundary edges and one-face corners are sharp.
    EdgeAndCorner,
    /// `interpolateboundary [2]`: boundary edges are sharp, corners follow the crease rule.
    EdgeOnly,
}

#[derive(Clone, Debug)]
pub(super) struct Edge {
    pub(super) v: [u32; 2],
    /// Incident faces (two for an interior manifold edge).
    pub(super) faces: u32,
    /// First two incident faces.
    pub(super) face: [u32; 2],
    pub(super) sharpness: f64,
}

/// One level of the mesh: polygons at level 0, quads after.
#[derive(Clone, Debug, Default)]
pub(super) struct Level {
    pub(super) positions: Vec<DVec3>,
    pub(super) face_start: Vec<u32>,
    pub(super) face_verts: Vec<u32>,
    /// The edge from each face corner to the next corner.
    pub(super) face_edges: Vec<u32>,
    /// The control-mesh face every face descends from.
    pub(super) face_origin: Vec<u32>,
    pub(super) face_hidden: Vec<bool>,
    /// A marker every face passes to its children (the adaptive refinement's special faces).
    pub(super) face_tag: Vec<u32>,
    pub(super) edges: Vec<Edge>,
    pub(super) vertex_sharpness: Vec<f64>,
    /// Edges of each vertex (CSR).
    pub(super) vertex_edge_start: Vec<u32>,
    pub(super) vertex_edges: Vec<u32>,
    /// Faces of each vertex with the corner index in that face (CSR).
    pub(super) vertex_face_start: Vec<u32>,
    pub(super) vertex_faces: Vec<(u32, u32)>,
    /// `st` per face corner.
    pub(super) st: Option<Vec<DVec2>>,
}

impl Level {
    pub(super) fn face_count(&self) -> usize {
        self.face_start.len() - 1
    }

    pub(super) fn face(&self, f: usize) -> std::ops::Range<usize> {
        self.face_start[f] as usize..self.face_start[f + 1] as usize
    }

    /// Finds the edges of the faces (control mesh only: finer levels know theirs), with the
    /// sharpness of `sharp` edges, then the adjacency.
    pub(super) fn build_topology(&mut self, sharp: &HashMap<(u32, u32), f64>) {
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
    pub(super) fn build_adjacency(&mut self) {
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

    pub(super) fn edges_of(&self, v: usize) -> &[u32] {
        &self.vertex_edges[self.vertex_edge_start[v] as usize..self.vertex_edge_start[v + 1] as usize]
    }

    pub(super) fn faces_of(&self, v: usize) -> &[(u32, u32)] {
        &self.vertex_faces[self.vertex_face_start[v] as usize..self.vertex_face_start[v + 1] as usize]
    }

    pub(super) fn other_end(&self, e: u32, v: usize) -> usize {
        let e = &self.edges[e as usize];
        if e.v[0] as usize == v { e.v[1] as usize } else { e.v[0] as usize }
    }

    pub(super) fn is_boundary_vertex(&self, v: usize) -> bool {
        self.edges_of(v).iter().any(|&e| self.edges[e as usize].faces != 2)
    }
}

/// The control mesh with its tags, checked.
/// Also returns the number of degenerate faces dropped and each request face's index in the
/// control level (`u32::MAX` for a dropped one).
pub(super) fn control_level(
    sm: &SubdivisionMesh,
) -> Result<(Level, Boundary, u32, Vec<u32>), TessellateError> {
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
    Ok((level, boundary, degenerate, kept_face_of_input))
}
