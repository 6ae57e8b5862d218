//! The triangle mesh every tessellator produces.

use super::TessellateError;
use glam::{DVec3, Vec2, Vec3};
use std::collections::HashMap;

/// An indexed triangle mesh.
///
/// Triangles are wound counter-clockwise around the surface normal (see the
/// [module docs](super)). Vertices are shared between the triangles of one shape wherever the
/// surface is continuous (seams and poles of closed quadrics included), so a closed surface
/// gives a closed mesh by index; shapes with face-varying or uniform data carry one vertex per
/// face corner instead (use [`TriangleMesh::welded`] to merge them by position).
#[derive(Clone, Debug, Default, PartialEq)]
pub struct TriangleMesh {
    pub positions: Vec<Vec3>,
    /// Unit vertex normals on the front side: the smooth surface normal where the surface has
    /// one (quadrics, patches, NURBS, subdivision limit surfaces), the `N` primitive variable of
    /// polygons when given; `None` for polygons without `N` (use the face normals).
    pub normals: Option<Vec<Vec3>>,
    /// Texture coordinates: the `st` (or `s` and `t`) primitive variable when given, otherwise
    /// RenderMan's default `(s, t) = (u, v)` for parametric surfaces (the unit square for
    /// quadrics and patch meshes, knot values for NuPatch); `None` for polygons and
    /// subdivision meshes without `st`.
    pub st: Option<Vec<Vec2>>,
    /// Vertex indices, three per triangle. `indices.as_flattened()` gives a plain `&[u32]`.
    pub indices: Vec<[u32; 3]>,
    /// For every triangle, the index of the face it came from: the polygon of a polygon mesh,
    /// the patch of a patch mesh (u fastest), the face of the subdivision control mesh, the
    /// knot-span cell of a NuPatch (u fastest), 0 for quadrics.
    pub face_index: Vec<u32>,
    /// Faces that gave no triangles because they have no area (collinear or repeated
    /// vertices) or fewer than three vertices.
    pub degenerate_faces: u32,
}

impl TriangleMesh {
    pub fn triangle_count(&self) -> usize {
        self.indices.len()
    }

    pub fn is_empty(&self) -> bool {
        self.indices.is_empty()
    }

    /// The corners of triangle `t`.
    pub fn triangle(&self, t: usize) -> [Vec3; 3] {
        self.indices[t].map(|i| self.positions[i as usize])
    }

    /// `(b - a) x (c - a)` of triangle `t` in `f64`: twice its area, along its front normal.
    pub fn face_cross(&self, t: usize) -> DVec3 {
        let [a, b, c] = self.triangle(t).map(|p| p.as_dvec3());
        (b - a).cross(c - a)
    }

    /// Total area, summed in `f64`.
    pub fn area(&self) -> f64 {
        (0..self.indices.len()).map(|t| 0.5 * self.face_cross(t).length()).sum()
    }

    /// Signed enclosed volume (divergence theorem, `f64`): positive for a closed mesh whose
    /// normals point outward. Only meaningful for closed meshes.
    pub fn signed_volume(&self) -> f64 {
        self.indices
            .iter()
            .map(|tri| {
                let [a, b, c] = tri.map(|i| self.positions[i as usize].as_dvec3());
                a.dot(b.cross(c)) / 6.0
            })
            .sum()
    }

    /// Axis-aligned bounds `(min, max)` of the positions used by triangles, `None` when empty.
    pub fn bounds(&self) -> Option<(Vec3, Vec3)> {
        let mut it = self.indices.iter().flatten().map(|&i| self.positions[i as usize]);
        let first = it.next()?;
        Some(it.fold((first, first), |(lo, hi), p| (lo.min(p), hi.max(p))))
    }

    /// Number of edges used by exactly one triangle (by vertex index). Zero for a closed mesh.
    pub fn boundary_edge_count(&self) -> usize {
        self.edge_use_counts().values().filter(|&&n| n == 1).count()
    }

    /// True when every edge is shared by exactly two triangles, traversed in opposite
    /// directions (a closed, consistently oriented mesh, by vertex index).
    pub fn is_closed(&self) -> bool {
        if self.indices.is_empty() {
            return false;
        }
        let mut directed: HashMap<(u32, u32), u32> = HashMap::with_capacity(self.indices.len() * 3);
        for tri in &self.indices {
            for k in 0..3 {
                *directed.entry((tri[k], tri[(k + 1) % 3])).or_default() += 1;
            }
        }
        directed.iter().all(|(&(a, b), &n)| n == 1 && directed.get(&(b, a)) == Some(&1))
    }

    fn edge_use_counts(&self) -> HashMap<(u32, u32), u32> {
        let mut counts: HashMap<(u32, u32), u32> = HashMap::with_capacity(self.indices.len() * 3);
        for tri in &self.indices {
            for k in 0..3 {
                let (a, b) = (tri[k], tri[(k + 1) % 3]);
                *counts.entry((a.min(b), a.max(b))).or_default() += 1;
            }
        }
        counts
    }

    /// Appends `other`, offsetting its indices. Optional attributes stay only if both have them.
    pub fn append(&mut self, other: &TriangleMesh) {
        let offset = self.positions.len() as u32;
        let was_empty = self.positions.is_empty() && self.indices.is_empty();
        self.normals = match (self.normals.take(), &other.normals) {
            (Some(mut a), Some(b)) => {
                a.extend_from_slice(b);
                Some(a)
            }
            (None, Some(b)) if was_empty => Some(b.clone()),
            _ => None,
        };
        self.st = match (self.st.take(), &other.st) {
            (Some(mut a), Some(b)) => {
                a.extend_from_slice(b);
                Some(a)
            }
            (None, Some(b)) if was_empty => Some(b.clone()),
            _ => None,
        };
        self.positions.extend_from_slice(&other.positions);
        self.indices.extend(other.indices.iter().map(|t| t.map(|i| i + offset)));
        self.face_index.extend_from_slice(&other.face_index);
        self.degenerate_faces += other.degenerate_faces;
    }

    /// A copy whose vertices with bit-identical positions are merged (normals and `st` of the
    /// first one kept), e.g. to check watertightness of a mesh with per-corner vertices.
    /// Triangles that become degenerate are dropped.
    pub fn welded(&self) -> TriangleMesh {
        let mut first: HashMap<[u32; 3], u32> = HashMap::with_capacity(self.positions.len());
        let mut remap = Vec::with_capacity(self.positions.len());
        let mut out = TriangleMesh {
            normals: self.normals.as_ref().map(|_| Vec::new()),
            st: self.st.as_ref().map(|_| Vec::new()),
            degenerate_faces: self.degenerate_faces,
            ..Default::default()
        };
        for (i, p) in self.positions.iter().enumerate() {
            // +0.0 and -0.0 are one position.
            let key = [p.x + 0.0, p.y + 0.0, p.z + 0.0].map(f32::to_bits);
            let next = out.positions.len() as u32;
            let id = *first.entry(key).or_insert_with(|| {
                out.positions.push(*p);
                if let (Some(n), Some(src)) = (out.normals.as_mut(), self.normals.as_ref()) {
                    n.push(src[i]);
                }
                if let (Some(st), Some(src)) = (out.st.as_mut(), self.st.as_ref()) {
                    st.push(src[i]);
                }
                next
            });
            remap.push(id);
        }
        for (t, tri) in self.indices.iter().enumerate() {
            let [a, b, c] = tri.map(|i| remap[i as usize]);
            if a != b && b != c && a != c {
                out.indices.push([a, b, c]);
                out.face_index.push(self.face_index[t]);
            }
        }
        out
    }

    /// Errors if any position, normal or `st` is not finite.
    pub(crate) fn check_finite(&self, kind: &'static str) -> Result<(), TessellateError> {
        let bad = |what: &str| {
            Err(TessellateError::NonFinite { kind, reason: format!("a {what} came out non-finite") })
        };
        if !self.positions.iter().all(|p| p.is_finite()) {
            return bad("position");
        }
        if let Some(n) = &self.normals
            && !n.iter().all(|v| v.is_finite())
        {
            return bad("normal");
        }
        if let Some(st) = &self.st
            && !st.iter().all(|v| v.is_finite())
        {
            return bad("texture coordinate");
        }
        Ok(())
    }
}
