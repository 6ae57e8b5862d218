//! The drawn triangles: every node's faces on the limit surface, vertices shared per
//! (source vertex, st), neighbours of refined faces fanned so closed meshes stay closed.

use super::adaptive::{Node, key};
use super::{Planning, TessellateError, TriangleMesh, invalid};
use glam::{DVec2, DVec3, Vec2};
use std::collections::HashMap;

/// Output vertices: shared per (source vertex, st), with the exact limit normal when known.
#[derive(Default)]
pub(super) struct Output {
    pub(super) mesh: TriangleMesh,
    pub(super) st: Vec<Vec2>,
    pub(super) exact_normals: Vec<DVec3>,
    pub(super) ids: HashMap<(u32, u32, u64, u64), u32>,
    /// The first output vertex made for each source vertex.
    pub(super) by_source: HashMap<(u32, u32), u32>,
    /// Without st: the output vertex of each node's vertices, a table instead of hashing.
    pub(super) plain: Vec<Vec<u32>>,
    pub(super) with_st: bool,
    /// A key of a deforming mesh: zero-area triangles are kept, quad diagonals recorded or
    /// replayed (see [`Planning`]).
    pub(super) keyed: bool,
    pub(super) diagonals: Vec<bool>,
    pub(super) replayed: Option<std::vec::IntoIter<bool>>,
}

impl Output {
    /// The output vertex of vertex `v` of refinement node `space`.
    pub(super) fn vertex(
        &mut self,
        space: u32,
        v: u32,
        st: Option<DVec2>,
        position: DVec3,
        normal: DVec3,
    ) -> u32 {
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
    pub(super) fn lookup(&self, space: u32, v: u32) -> Option<u32> {
        let found = match self.with_st {
            true => self.by_source.get(&(space, v)).copied(),
            false => self.plain.get(space as usize).and_then(|t| t.get(v as usize)).copied(),
        };
        found.filter(|&id| id != u32::MAX)
    }

    pub(super) fn fresh_vertex(&mut self, position: DVec3, st: Option<DVec2>) -> u32 {
        self.mesh.positions.push(position.as_vec3());
        self.exact_normals.push(DVec3::ZERO);
        if let Some(s) = st {
            self.st.push(s.as_vec2());
        }
        (self.mesh.positions.len() - 1) as u32
    }

    pub(super) fn triangle(&mut self, t: [u32; 3], face: u32) {
        let [a, b, c] = t.map(|i| self.mesh.positions[i as usize].as_dvec3());
        if t[0] != t[1] && t[1] != t[2] && t[0] != t[2] && (self.keyed || (b - a).cross(c - a) != DVec3::ZERO)
        {
            self.mesh.indices.push(t);
            self.mesh.face_index.push(face);
        }
    }

    /// Two triangles of a quad, split along its shorter diagonal.
    pub(super) fn quad(&mut self, ids: [u32; 4], face: u32) {
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
    pub(super) fn finish(mut self) -> TriangleMesh {
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
        crate::grid::compact(&mut self.mesh);
        self.mesh
    }
}

/// The output vertex of vertex `v` of node `node`: a vertex that descends from a parent's
/// vertex is that vertex (so nodes share their boundaries exactly).
pub(super) fn resolve(nodes: &[Node], mut node: usize, mut v: u32) -> (usize, u32) {
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
pub(super) fn chain(
    nodes: &[Node],
    out: &mut Output,
    node: usize,
    a: u32,
    b: u32,
    st: Option<DVec2>,
) -> Vec<u32> {
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

pub(super) fn output_vertex(nodes: &[Node], out: &mut Output, node: usize, v: u32, st: Option<DVec2>) -> u32 {
    let (n, v) = resolve(nodes, node, v);
    if let Some(id) = out.lookup(n as u32, v) {
        return id;
    }
    out.vertex(n as u32, v, st, nodes[n].limit.0[v as usize], nodes[n].limit.1[v as usize])
}

/// Triangles of every node's drawn faces on the limit surface. A drawn face next to refined
/// ones is fanned from its centre through the vertices they add on the shared edges, so the
/// mesh stays closed.
pub(super) fn emit(
    nodes: &[Node],
    degenerate: u32,
    planning: &mut Planning,
) -> Result<TriangleMesh, TessellateError> {
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
