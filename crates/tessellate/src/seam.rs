//! Bitwise-equal seams between separately tessellated primitives.
//!
//! Two patches that share an edge dice it at the same rate and put their boundary vertices at
//! the same curve parameters (the `stitch` module), but each evaluates its own surface there:
//! a different summation order, another direction along the edge, a basis matrix given in
//! `f32` whose weights do not sum to exactly one, or another transform leave the two positions
//! a rounding error apart. A watertight ray-triangle test only closes a seam whose vertices
//! are bitwise equal, so [`SeamWelder`] snaps each new mesh's open-boundary vertices onto the
//! boundary vertices of the meshes placed before it that lie within a few `f32` units in the
//! last place.

use super::TriangleMesh;
use super::shape_kind;
use glam::{DVec3, Vec3};
use rib_parser::scene::Shape;
use std::collections::HashMap;

/// Snaps the open-boundary vertices of meshes in one space onto each other's (see the module
/// docs). Feed it every mesh of that space that may share edges, in a fixed order.
#[derive(Debug)]
pub struct SeamWelder {
    /// Largest distance (per coordinate) between two positions taken as the same seam vertex.
    radius: f64,
    origin: DVec3,
    cells: HashMap<[i64; 3], Vec<Vec3>>,
}

impl SeamWelder {
    /// A welder for meshes within the box `lo..hi` (the scene's bounds in the meshes' space).
    ///
    /// The radius is 16 `f32` units in the last place of the box's largest coordinate (and at
    /// least `2^-24` of its diagonal): far above the rounding that separates two evaluations of
    /// the same edge, far below any tessellation tolerance or vertex spacing.
    pub fn new(lo: DVec3, hi: DVec3) -> SeamWelder {
        let extent = lo.abs().max(hi.abs()).max_element();
        let diagonal = (hi - lo).length();
        let radius = (extent * (-19f64).exp2()).max(diagonal * (-24f64).exp2());
        let radius = if radius.is_finite() && radius > 0.0 { radius } else { f64::MIN_POSITIVE };
        let origin = if lo.is_finite() { lo } else { DVec3::ZERO };
        SeamWelder { radius, origin, cells: HashMap::new() }
    }

    /// The snapping radius.
    pub fn radius(&self) -> f64 {
        self.radius
    }

    /// True for the shapes whose tessellations have seams worth welding: patches, NURBS and
    /// subdivision meshes (polygon vertices are given exactly; quadrics are closed or stand
    /// alone).
    pub fn applies_to(shape: &Shape) -> bool {
        matches!(shape_kind(shape), "PatchMesh" | "NuPatch" | "SubdivisionMesh")
    }

    fn key(&self, p: Vec3) -> [i64; 3] {
        ((p.as_dvec3() - self.origin) / self.radius).floor().as_i64vec3().to_array()
    }

    /// Moves the open-boundary vertices of `mesh` onto boundary vertices of earlier meshes
    /// within the radius (bitwise), then records its own. Returns how many vertices moved.
    pub fn weld(&mut self, mesh: &mut TriangleMesh) -> usize {
        let mut edges: HashMap<(u32, u32), u32> = HashMap::with_capacity(mesh.indices.len() * 3 / 2);
        for tri in &mesh.indices {
            for k in 0..3 {
                let (a, b) = (tri[k], tri[(k + 1) % 3]);
                *edges.entry((a.min(b), a.max(b))).or_insert(0) += 1;
            }
        }
        let mut boundary: Vec<u32> =
            edges.iter().filter(|&(_, &count)| count == 1).flat_map(|(&(a, b), _)| [a, b]).collect();
        boundary.sort_unstable();
        boundary.dedup();

        let mut moved = 0;
        for &v in &boundary {
            let p = mesh.positions[v as usize];
            if !p.is_finite() {
                continue;
            }
            let c = self.key(p);
            let mut best: Option<(f32, Vec3)> = None;
            for dx in -1..=1 {
                for dy in -1..=1 {
                    for dz in -1..=1 {
                        let cell =
                            [c[0].saturating_add(dx), c[1].saturating_add(dy), c[2].saturating_add(dz)];
                        for &q in self.cells.get(&cell).into_iter().flatten() {
                            let d = (q - p).abs().max_element();
                            if (d as f64) <= self.radius && best.is_none_or(|(bd, _)| d < bd) {
                                best = Some((d, q));
                            }
                        }
                    }
                }
            }
            if let Some((_, q)) = best
                && q != p
            {
                mesh.positions[v as usize] = q;
                moved += 1;
            }
        }
        for &v in &boundary {
            let p = mesh.positions[v as usize];
            if p.is_finite() {
                let members = self.cells.entry(self.key(p)).or_default();
                if !members.contains(&p) {
                    members.push(p);
                }
            }
        }
        moved
    }
}
