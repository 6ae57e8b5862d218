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
//!
//! Two shapes may still dice a shared edge at different rates where each picks its own level
//! (two subdivision meshes: 2^a and 2^b segments per control edge). Their vertices nest (the
//! coarse side's are among the fine side's, welded), so the welder then closes each coarse
//! edge `p q` against the fine chain `p m1 .. q` with a fan of thin triangles from `p`, added
//! to the newer mesh: every edge of the fan is then shared, bitwise, by both sides.

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
    /// The open-boundary edges of the meshes welded so far, both ways, by position bits.
    boundary_edges: HashMap<[u32; 3], Vec<Vec3>>,
}

/// The longest chain of fine boundary edges one coarse edge is closed against.
const MAX_CHAIN: usize = 4096;

/// How many triangles use an edge, and the first one's direction along it and index.
type EdgeUse = (u32, (u32, u32), usize);

fn bits(p: Vec3) -> [u32; 3] {
    p.to_array().map(f32::to_bits)
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
        SeamWelder { radius, origin, cells: HashMap::new(), boundary_edges: HashMap::new() }
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
    /// within the radius (bitwise), closes the edges its neighbours dice at another rate (see
    /// the module docs), then records its own. Returns how many vertices moved.
    pub fn weld(&mut self, mesh: &mut TriangleMesh) -> usize {
        // Each edge: how many triangles use it, and the first one's direction and triangle.
        let mut edges: HashMap<(u32, u32), EdgeUse> = HashMap::with_capacity(mesh.indices.len() * 3 / 2);
        for (t, tri) in mesh.indices.iter().enumerate() {
            for k in 0..3 {
                let (a, b) = (tri[k], tri[(k + 1) % 3]);
                edges.entry((a.min(b), a.max(b))).or_insert((0, (a, b), t)).0 += 1;
            }
        }
        let mut open: Vec<((u32, u32), usize)> =
            edges.values().filter(|e| e.0 == 1).map(|&(_, directed, t)| (directed, t)).collect();
        open.sort_unstable();
        let mut boundary: Vec<u32> = open.iter().flat_map(|&((a, b), _)| [a, b]).collect();
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
        self.close_rate_changes(mesh, &open);
        for &((a, b), _) in &open {
            let (p, q) = (mesh.positions[a as usize], mesh.positions[b as usize]);
            if p.is_finite() && q.is_finite() && p != q {
                self.boundary_edges.entry(bits(p)).or_default().push(q);
                self.boundary_edges.entry(bits(q)).or_default().push(p);
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

impl SeamWelder {
    /// Adds to `mesh` the fans that close its open edges (`open`: directed as its triangles
    /// walk them, with the triangle) against earlier meshes that dice them at another rate.
    fn close_rate_changes(&self, mesh: &mut TriangleMesh, open: &[((u32, u32), usize)]) {
        if self.boundary_edges.is_empty() {
            return;
        }
        let known = |p: Vec3| self.boundary_edges.get(&bits(p));
        // A coarse edge of this mesh, a finer chain of earlier meshes between its ends.
        for &((a, b), t) in open {
            let (p, q) = (mesh.positions[a as usize], mesh.positions[b as usize]);
            let Some(next) = known(p) else { continue };
            if known(q).is_none() || next.contains(&q) {
                continue;
            }
            let Some(chain) = shortest_chain(p, q, |x| known(x).map_or(&[][..], Vec::as_slice)) else {
                continue;
            };
            // New vertices at the chain's inner points, their normal and `st` taken along `p q`.
            let lengths: Vec<f32> = chain.windows(2).map(|w| (w[1] - w[0]).length()).collect();
            let total: f32 = lengths.iter().sum();
            let mut along = 0.0;
            let mut ids = vec![a];
            for (k, &m) in chain[1..chain.len() - 1].iter().enumerate() {
                along += lengths[k];
                let f = if total > 0.0 { along / total } else { 0.5 };
                ids.push(mesh.positions.len() as u32);
                mesh.positions.push(m);
                if let Some(normals) = mesh.normals.as_mut() {
                    let n = normals[a as usize].lerp(normals[b as usize], f);
                    normals.push(n.try_normalize().unwrap_or(normals[a as usize]));
                }
                if let Some(st) = mesh.st.as_mut() {
                    st.push(st[a as usize].lerp(st[b as usize], f));
                }
            }
            ids.push(b);
            // The fan walks `p q` backwards and the chain forwards, as the neighbour does not.
            let face = mesh.face_index.get(t).copied().unwrap_or(0);
            for w in ids[1..].windows(2) {
                mesh.indices.push([a, w[0], w[1]]);
                mesh.face_index.push(face);
            }
        }
        // A coarse edge of an earlier mesh, a finer chain of this one between its ends.
        let mut index_of: HashMap<[u32; 3], u32> = HashMap::new();
        let mut neighbours: HashMap<u32, Vec<u32>> = HashMap::new();
        let mut forward: HashMap<(u32, u32), usize> = HashMap::new();
        for &((a, b), t) in open {
            index_of.insert(bits(mesh.positions[a as usize]), a);
            neighbours.entry(a).or_default().push(b);
            neighbours.entry(b).or_default().push(a);
            forward.insert((a, b), t);
        }
        let positions = &mesh.positions;
        let mut starts: Vec<u32> = neighbours.keys().copied().collect();
        starts.sort_unstable();
        for a in starts {
            let p = positions[a as usize];
            let Some(earlier) = known(p) else { continue };
            for &q in earlier {
                let Some(&b) = index_of.get(&bits(q)) else { continue };
                if b <= a || neighbours[&a].contains(&b) {
                    continue;
                }
                let near = |x: Vec3| {
                    index_of
                        .get(&bits(x))
                        .and_then(|i| neighbours.get(i))
                        .map(|n| n.iter().map(|&j| positions[j as usize]).collect::<Vec<_>>())
                        .unwrap_or_default()
                };
                let Some(chain) = shortest_chain_owned(p, q, near) else { continue };
                let ids: Vec<u32> = chain.iter().map(|x| index_of[&bits(*x)]).collect();
                let walked_forward = forward.contains_key(&(ids[0], ids[1]));
                let face = forward.get(&(ids[0], ids[1])).or(forward.get(&(ids[1], ids[0]))).copied();
                let face = face.and_then(|t| mesh.face_index.get(t).copied()).unwrap_or(0);
                for w in ids[1..].windows(2) {
                    let tri = if walked_forward { [a, w[1], w[0]] } else { [a, w[0], w[1]] };
                    mesh.indices.push(tri);
                    mesh.face_index.push(face);
                }
            }
        }
    }
}

/// The shortest chain of boundary edges from `p` to `q` (`next` gives a point's neighbours)
/// with at least one point between them, at most [`MAX_CHAIN`] edges and at most twice as long
/// as the straight edge `p q` (else it is not the same stretch of curve).
fn shortest_chain<'a>(p: Vec3, q: Vec3, next: impl Fn(Vec3) -> &'a [Vec3]) -> Option<Vec<Vec3>> {
    shortest_chain_owned(p, q, |x| next(x).to_vec())
}

fn shortest_chain_owned(p: Vec3, q: Vec3, next: impl Fn(Vec3) -> Vec<Vec3>) -> Option<Vec<Vec3>> {
    let limit = 2.0 * (q - p).length();
    let mut from: HashMap<[u32; 3], Vec3> = HashMap::new();
    let mut frontier = vec![(p, 0.0f32)];
    from.insert(bits(p), p);
    for _ in 0..MAX_CHAIN {
        let mut grown = Vec::new();
        for &(x, travelled) in &frontier {
            for y in next(x) {
                let d = travelled + (y - x).length();
                if d > limit || from.contains_key(&bits(y)) || (x == p && y == q) {
                    continue;
                }
                from.insert(bits(y), x);
                if y == q {
                    let mut chain = vec![q];
                    let mut at = q;
                    while at != p {
                        at = from[&bits(at)];
                        chain.push(at);
                    }
                    chain.reverse();
                    return Some(chain);
                }
                grown.push((y, d));
            }
        }
        if grown.is_empty() {
            return None;
        }
        frontier = grown;
    }
    None
}
