//! `SolidBegin` constructive solid geometry for the haptic proxy: the touchable surface is the
//! boundary of the result, as the ray tracer renders it (crates/raytracer/src/world/csg.rs).
//!
//! The tree and its boolean evaluation are rib-parser's (`rib_parser::csg`), the ray tracer's
//! too: the leaves are primitive solids (all the surfaces of one `"primitive"` block, or one
//! shape given directly inside another operation), and a point is inside a leaf when a ray from
//! it crosses the leaf's triangles an odd number of times; each leaf's triangles are in a
//! [`Bvh`], so a test costs about the logarithm of their number. A point on leaf `L`'s surface
//! is on the result's boundary when the tree's answer differs with `L` taken as inside and as
//! outside, the other leaves as they are there. Each tessellated triangle of a solid's shape is
//! kept where its points are on the boundary: vertices are classified, and an edge whose ends
//! differ is cut where the class changes (found by bisection), the triangle clipped
//! marching-triangles style. Where the result lies outside `L` (a subtracted solid), the kept
//! triangles are turned over to face out of the result.

use crate::bvh::Bvh;
use crate::geometry::{CollisionMesh, MaterialId};
use glam::DVec3;
use rib_parser::csg::CsgTree;
use rib_parser::scene::Scene;
use tessellate::{MeshOrigin, SceneMeshes};

/// BVH nodes and triangles that one scene's solids may test; past it a solid's shapes are
/// touched as they are (the union), with a warning, so a hostile file (thousands of coplanar
/// layers that every ray crosses) cannot stall loading. Counted as spent, so an ordinary
/// solid, about a logarithm of its triangles per test, stays far below it.
pub const MAX_CSG_WORK: u64 = 1_000_000_000;

/// Bisection steps for an edge's crossing: `2^-24` of the edge, far below any tolerance.
const BISECTION_STEPS: u32 = 24;

/// The ray direction of the parity test: no axis or diagonal, so that axis-aligned
/// tessellations are not met along their edges.
const RAY: DVec3 = DVec3::new(0.5773502691896258, 0.5773502691896257 + 1e-3, 0.5773502691896258 - 2e-3);

/// Why a shape could not be clipped to its solid's boundary.
#[derive(Debug, thiserror::Error)]
pub(crate) enum CsgError {
    #[error("its solid's CSG would test more than {MAX_CSG_WORK} BVH nodes and triangles")]
    TooMuchWork,
    #[error("its solid's triangles cannot be indexed: {0}")]
    Leaf(String),
}

/// The triangles of one primitive solid in a hierarchy (world coordinates: local frame at the
/// origin, so the stored `f32` vertices are the tessellation's own).
#[derive(Clone, Debug, Default)]
struct Leaf {
    mesh: CollisionMesh,
    bvh: Bvh,
    lo: DVec3,
    hi: DVec3,
    /// The box test's margin: far above the rounding of the slab test, far below any triangle.
    margin: f64,
}

impl Leaf {
    fn finish(&mut self) {
        self.bvh = Bvh::build(&self.mesh);
        if let Some((lo, hi)) = self.mesh.local_bounds() {
            (self.lo, self.hi) = (lo, hi);
            self.margin = 1e-9 * (hi - lo).max_element().max(lo.abs().max(hi.abs()).max_element());
        }
    }

    /// Crossing parity of the ray `p + t RAY`, `t > 0`, with the leaf's triangles; adds the
    /// nodes and triangles tested to `work`.
    fn contains(&self, p: DVec3, work: &mut u64) -> bool {
        if self.mesh.is_empty() || p.cmplt(self.lo).any() || p.cmpgt(self.hi).any() {
            return false;
        }
        let mut inside = false;
        let mut triangles = 0u64;
        let nodes = self.bvh.for_each_on_ray(p, RAY, self.margin, |[a, b, c], _| {
            triangles += 1;
            if ray_crosses(p, a, b, c) {
                inside = !inside;
            }
        });
        *work = work.saturating_add(nodes + triangles);
        inside
    }
}

/// Möller-Trumbore with half-open barycentric bounds, so a ray through a shared edge counts
/// one of its two triangles.
fn ray_crosses(o: DVec3, a: DVec3, b: DVec3, c: DVec3) -> bool {
    let (e1, e2) = (b - a, c - a);
    let q = RAY.cross(e2);
    let det = e1.dot(q);
    if det == 0.0 || !det.is_finite() {
        return false;
    }
    let s = o - a;
    let u = s.dot(q) / det;
    if !(0.0..1.0).contains(&u) {
        return false;
    }
    let r = s.cross(e1);
    let v = RAY.dot(r) / det;
    if v < 0.0 || u + v >= 1.0 {
        return false;
    }
    e2.dot(r) / det > 0.0
}

/// One outermost solid: its tree and leaves, and the first problem met filling them.
#[derive(Debug)]
struct Tree {
    csg: CsgTree,
    leaves: Vec<Leaf>,
    broken: Option<String>,
}

impl Tree {
    /// For a point on leaf `leaf`'s surface: whether it bounds the result, and whether the
    /// result lies outside the leaf there (the surface must face the other way).
    fn classify(&self, leaf: usize, p: DVec3, states: &mut [bool], work: &mut u64) -> (bool, bool) {
        for (l, state) in states.iter_mut().enumerate() {
            *state = l != leaf && self.leaves[l].contains(p, work);
        }
        let outside_leaf = self.csg.inside(states);
        states[leaf] = true;
        let inside_leaf = self.csg.inside(states);
        (outside_leaf != inside_leaf, outside_leaf)
    }
}

/// The solids of a scene for the haptics: which tree and leaf each scene shape belongs to.
pub(crate) struct Solids {
    trees: Vec<Tree>,
    /// By scene shape index: `(tree, leaf)`.
    shape_leaf: Vec<Option<(usize, usize)>>,
    /// Work left to [`Solids::clip`] (see [`MAX_CSG_WORK`]).
    budget: u64,
}

impl Solids {
    /// The trees of `scene`'s outermost solid blocks, their leaves filled with the world
    /// triangles of `meshes`. `None` when the scene has no solid.
    pub(crate) fn new(scene: &Scene, meshes: &SceneMeshes) -> Option<Solids> {
        let mut shape_leaf = vec![None; scene.shapes.len()];
        let mut trees = Vec::new();
        for csg in CsgTree::outermost(scene) {
            for &(shape, leaf) in csg.shapes() {
                if let Some(slot) = shape_leaf.get_mut(shape as usize) {
                    *slot = Some((trees.len(), leaf as usize));
                }
            }
            let leaves = (0..csg.leaf_count()).map(|_| Leaf::default()).collect();
            trees.push(Tree { csg, leaves, broken: None });
        }
        if trees.is_empty() {
            return None;
        }
        for m in &meshes.meshes {
            let MeshOrigin::Shape { index } = m.origin else { continue };
            let Some(Some((tree, leaf))) = shape_leaf.get(index).copied() else { continue };
            let positions: Vec<DVec3> = m.mesh.positions.iter().map(|p| p.as_dvec3()).collect();
            let tree = &mut trees[tree];
            if let Err(e) =
                tree.leaves[leaf].mesh.push_indexed(&positions, &m.mesh.indices, None, MaterialId(0))
            {
                tree.broken.get_or_insert(e.to_string());
            }
        }
        for leaf in trees.iter_mut().flat_map(|t| t.leaves.iter_mut()) {
            leaf.finish();
        }
        Some(Solids { trees, shape_leaf, budget: MAX_CSG_WORK })
    }

    /// Clips one shape's world triangles to the result's boundary. `Ok(None)` when the shape is
    /// in no solid (keep it as it is); an error when its solid cannot be evaluated within what
    /// is left of the scene's work bound, or its leaves could not be filled.
    pub(crate) fn clip(
        &mut self,
        shape: usize,
        positions: &[DVec3],
        triangles: &[[u32; 3]],
        normals: Option<&[DVec3]>,
    ) -> Result<Option<ClippedMesh>, CsgError> {
        let Some((tree, leaf)) = self.shape_leaf.get(shape).copied().flatten() else { return Ok(None) };
        let tree = &self.trees[tree];
        if let Some(e) = &tree.broken {
            return Err(CsgError::Leaf(e.clone()));
        }
        let mut work = 0u64;
        let result = clip_to_tree(tree, leaf, positions, triangles, normals, self.budget, &mut work);
        self.budget = self.budget.saturating_sub(work);
        result.map(Some)
    }
}

/// [`Solids::clip`] for leaf `leaf` of `tree`, spending at most `budget` (the work done is
/// added to `work`).
fn clip_to_tree(
    tree: &Tree,
    leaf: usize,
    positions: &[DVec3],
    triangles: &[[u32; 3]],
    normals: Option<&[DVec3]>,
    budget: u64,
    work: &mut u64,
) -> Result<ClippedMesh, CsgError> {
    let mut states = vec![false; tree.leaves.len()];
    let mut class: Vec<(bool, bool)> = Vec::with_capacity(positions.len());
    for &p in positions {
        class.push(tree.classify(leaf, p, &mut states, work));
        if *work > budget {
            return Err(CsgError::TooMuchWork);
        }
    }
    let mut out = ClippedMesh {
        positions: positions.to_vec(),
        triangles: Vec::new(),
        normals: normals.map(<[DVec3]>::to_vec),
        flipped: class.iter().map(|c| c.1).collect(),
    };
    for &[a, b, c] in triangles {
        let corners = [a, b, c];
        let kept = corners.map(|v| class.get(v as usize).is_some_and(|c| c.0));
        if kept.iter().all(|&k| !k) {
            continue;
        }
        // The polygon of the kept part: kept corners and the crossings of mixed edges.
        let mut polygon: Vec<u32> = Vec::with_capacity(4);
        for i in 0..3 {
            let (v, w) = (corners[i], corners[(i + 1) % 3]);
            if kept[i] {
                polygon.push(v);
            }
            if kept[i] != kept[(i + 1) % 3] {
                let (p, q) = (positions[v as usize], positions[w as usize]);
                // Bisection between the kept end and the other.
                let (mut on, mut off) = if kept[i] { (0.0, 1.0) } else { (1.0, 0.0) };
                for _ in 0..BISECTION_STEPS {
                    let mid = 0.5 * (on + off);
                    if tree.classify(leaf, p.lerp(q, mid), &mut states, work).0 {
                        on = mid;
                    } else {
                        off = mid;
                    }
                }
                if *work > budget {
                    return Err(CsgError::TooMuchWork);
                }
                let (kept_end, other, t) = if kept[i] { (v, w, on) } else { (w, v, 1.0 - on) };
                polygon.push(out.push_vertex(kept_end, other, t));
            }
        }
        // Which way the kept part faces: from its first kept corner.
        let flip = kept.iter().zip(corners).find(|(k, _)| **k).is_some_and(|(_, v)| class[v as usize].1);
        for k in 1..polygon.len().saturating_sub(1) {
            let t = [polygon[0], polygon[k], polygon[k + 1]];
            out.triangles.push(if flip { [t[0], t[2], t[1]] } else { t });
        }
    }
    // Turned-over triangles carry turned-over normals.
    if let Some(n) = out.normals.as_mut() {
        for (normal, &flip) in n.iter_mut().zip(&out.flipped) {
            if flip {
                *normal = -*normal;
            }
        }
    }
    Ok(out)
}

/// A shape's triangles clipped to a solid's boundary (vertices added on cut edges).
#[derive(Clone, Debug, Default)]
pub(crate) struct ClippedMesh {
    pub positions: Vec<DVec3>,
    pub triangles: Vec<[u32; 3]>,
    pub normals: Option<Vec<DVec3>>,
    /// Per vertex: whether the result lies outside the shape's solid there.
    flipped: Vec<bool>,
}

impl ClippedMesh {
    /// A vertex at `t` from `v` (a kept vertex) towards `w`.
    fn push_vertex(&mut self, v: u32, w: u32, t: f64) -> u32 {
        let (p, q) = (self.positions[v as usize], self.positions[w as usize]);
        self.positions.push(p.lerp(q, t));
        self.flipped.push(self.flipped[v as usize]);
        if let Some(n) = self.normals.as_mut() {
            let (a, b) = (n[v as usize], n[w as usize]);
            n.push(a.lerp(b, t).normalize_or(a));
        }
        (self.positions.len() - 1) as u32
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use rib_parser::{LoadOptions, load_bytes};
    use tessellate::{Tolerance, tessellate_scene};

    /// A sphere minus a sphere, tessellated; the solids and the first shape's triangles.
    fn difference() -> (Solids, Vec<DVec3>, Vec<[u32; 3]>) {
        let rib = "WorldBegin\nSolidBegin \"difference\"\nSphere 1 -1 1 360\nTranslate 1 0 0\n\
                   Sphere 0.8 -0.8 0.8 360\nSolidEnd\nWorldEnd\n";
        let scene = load_bytes("csg.rib", rib.as_bytes().to_vec(), &LoadOptions::default())
            .unwrap_or_else(|e| panic!("{}", e.render()))
            .scene;
        let meshes = tessellate_scene(&scene, &Tolerance::relative(1e-3));
        let solids = Solids::new(&scene, &meshes).expect("a solid");
        let first =
            meshes.meshes.iter().find(|m| m.origin == MeshOrigin::Shape { index: 0 }).expect("sphere 0");
        let positions = first.mesh.positions.iter().map(|p| p.as_dvec3()).collect();
        (solids, positions, first.mesh.indices.clone())
    }

    #[test]
    fn the_hierarchy_gives_the_parity_of_every_triangle() {
        let (solids, positions, _) = difference();
        let leaf = &solids.trees[0].leaves[1];
        assert!(leaf.mesh.triangle_count() > 1000);
        let mut work = 0;
        let mut inside = 0;
        // The first sphere's vertices and points between them and the second sphere's centre.
        for (i, &p) in positions.iter().enumerate() {
            let q = p.lerp(DVec3::X, (i % 7) as f64 / 7.0);
            for point in [p, q] {
                let brute = (0..leaf.mesh.triangle_count())
                    .filter(|&t| {
                        let [a, b, c] = leaf.mesh.triangle_local(t);
                        ray_crosses(point, a, b, c)
                    })
                    .count()
                    % 2
                    == 1;
                assert_eq!(leaf.contains(point, &mut work), brute, "{point}");
                inside += usize::from(brute);
            }
        }
        assert!(inside > 100, "{inside} points inside the second sphere");
        // A logarithmic search, not a brute force: far fewer tests than points times triangles.
        let brute_work = 2 * positions.len() as u64 * leaf.mesh.triangle_count() as u64;
        assert!(work < brute_work / 20, "{work} tests vs {brute_work}");
    }

    #[test]
    fn a_solid_past_the_work_bound_is_refused_not_evaluated() {
        let (mut solids, positions, triangles) = difference();
        let clipped =
            solids.clip(0, &positions, &triangles, None).expect("within the bound").expect("in a solid");
        assert!(clipped.triangles.len() < triangles.len(), "the bite is cut away");
        solids.budget = 1000;
        assert!(matches!(solids.clip(0, &positions, &triangles, None), Err(CsgError::TooMuchWork)));
        // The budget is the scene's: once spent, the other shapes are refused too.
        assert!(solids.budget < 1000);
        assert!(matches!(solids.clip(1, &positions, &triangles, None), Err(CsgError::TooMuchWork)));
        assert!(matches!(solids.clip(7, &positions, &triangles, None), Ok(None)), "no shape 7");
    }
}
