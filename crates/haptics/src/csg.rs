//! `SolidBegin` constructive solid geometry for the haptic proxy: the touchable surface is the
//! boundary of the result, as the ray tracer renders it (crates/raytracer/src/world/csg.rs).
//!
//! The tree is the ray tracer's: the leaves are primitive solids (all the surfaces of one
//! `"primitive"` block, or one shape given directly inside another operation), and a point is
//! inside a leaf when a ray from it crosses the leaf's triangles an odd number of times. A
//! point on leaf `L`'s surface is on the result's boundary when the tree's answer differs with
//! `L` taken as inside and as outside, the other leaves as they are there. Each tessellated
//! triangle of a solid's shape is kept where its points are on the boundary: vertices are
//! classified, and an edge whose ends differ is cut where the class changes (found by
//! bisection), the triangle clipped marching-triangles style. Where the result lies outside
//! `L` (a subtracted solid), the kept triangles are turned over to face out of the result.

use glam::DVec3;
use rib_parser::scene::{Scene, SolidOp, SolidPart};
use tessellate::{MeshOrigin, SceneMeshes};

/// Parity tests times triangles tested that one scene may spend on its solids; past it the
/// solids are touched as their union, with a warning (a hostile file cannot stall loading).
pub const MAX_CSG_WORK: u64 = 4_000_000_000;

/// Bisection steps for an edge's crossing: `2^-24` of the edge, far below any tolerance.
const BISECTION_STEPS: u32 = 24;

/// The ray direction of the parity test: no axis or diagonal, so that axis-aligned
/// tessellations are not met along their edges.
const RAY: DVec3 = DVec3::new(0.5773502691896258, 0.5773502691896257 + 1e-3, 0.5773502691896258 - 2e-3);

#[derive(Clone, Copy, Debug, PartialEq, Eq)]
enum Child {
    Node(usize),
    Leaf(usize),
}

#[derive(Clone, Debug)]
struct Node {
    op: SolidOp,
    children: Vec<Child>,
}

/// The triangles of one primitive solid, with their bounds for a quick outside answer.
#[derive(Clone, Debug, Default)]
struct Leaf {
    triangles: Vec<[DVec3; 3]>,
    lo: DVec3,
    hi: DVec3,
}

impl Leaf {
    fn add(&mut self, t: [DVec3; 3]) {
        if self.triangles.is_empty() {
            (self.lo, self.hi) = (t[0], t[0]);
        }
        for p in t {
            self.lo = self.lo.min(p);
            self.hi = self.hi.max(p);
        }
        self.triangles.push(t);
    }

    /// Crossing parity of the ray `p + t RAY`, `t > 0`, with the leaf's triangles.
    fn contains(&self, p: DVec3) -> bool {
        if self.triangles.is_empty() || p.cmplt(self.lo).any() || p.cmpgt(self.hi).any() {
            return false;
        }
        let mut inside = false;
        for &[a, b, c] in &self.triangles {
            if ray_crosses(p, a, b, c) {
                inside = !inside;
            }
        }
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

/// One outermost solid: its tree (node 0 the root) and leaves.
#[derive(Clone, Debug)]
struct Tree {
    nodes: Vec<Node>,
    leaves: Vec<Leaf>,
}

impl Tree {
    fn inside(&self, node: usize, states: &[bool]) -> bool {
        let n = &self.nodes[node];
        let child = |c: &Child| match *c {
            Child::Node(k) => self.inside(k, states),
            Child::Leaf(l) => states[l],
        };
        match n.op {
            SolidOp::Union | SolidOp::Primitive => n.children.iter().any(child),
            SolidOp::Intersection => !n.children.is_empty() && n.children.iter().all(child),
            SolidOp::Difference => match n.children.split_first() {
                Some((first, rest)) => child(first) && !rest.iter().any(child),
                None => false,
            },
        }
    }

    /// For a point on leaf `leaf`'s surface: whether it bounds the result, and whether the
    /// result lies outside the leaf there (the surface must face the other way).
    fn classify(&self, leaf: usize, p: DVec3, states: &mut [bool]) -> (bool, bool) {
        for (l, state) in states.iter_mut().enumerate() {
            *state = l != leaf && self.leaves[l].contains(p);
        }
        let outside_leaf = self.inside(0, states);
        states[leaf] = true;
        let inside_leaf = self.inside(0, states);
        (outside_leaf != inside_leaf, outside_leaf)
    }
}

/// The solids of a scene for the haptics: which tree and leaf each scene shape belongs to.
pub(crate) struct Solids {
    trees: Vec<Tree>,
    /// By scene shape index: `(tree, leaf)`.
    shape_leaf: Vec<Option<(usize, usize)>>,
}

impl Solids {
    /// The trees of `scene`'s outermost solid blocks, their leaves filled with the world
    /// triangles of `meshes`. `None` when the scene has no solid.
    pub(crate) fn new(scene: &Scene, meshes: &SceneMeshes) -> Option<Solids> {
        let mut solids = Solids { trees: Vec::new(), shape_leaf: vec![None; scene.shapes.len()] };
        for (root, solid) in scene.solids.iter().enumerate() {
            if solid.parent.is_some() {
                continue;
            }
            let mut tree = Tree { nodes: Vec::new(), leaves: Vec::new() };
            let tree_index = solids.trees.len();
            add_node(scene, root, &mut tree, &mut solids.shape_leaf, tree_index, 0);
            solids.trees.push(tree);
        }
        if solids.trees.is_empty() {
            return None;
        }
        for m in &meshes.meshes {
            let MeshOrigin::Shape { index } = m.origin else { continue };
            let Some(Some((tree, leaf))) = solids.shape_leaf.get(index).copied() else { continue };
            let p = |i: u32| m.mesh.positions[i as usize].as_dvec3();
            for &[a, b, c] in &m.mesh.indices {
                solids.trees[tree].leaves[leaf].add([p(a), p(b), p(c)]);
            }
        }
        Some(solids)
    }

    /// The work [`Solids::clip`] would do on `vertices` points of one shape: a parity test
    /// against every other leaf of its tree per point (and per bisection step on the edges that
    /// cross, counted as twice the vertices).
    pub(crate) fn work(&self, shape: usize, vertices: usize) -> u64 {
        let Some(Some((tree, _))) = self.shape_leaf.get(shape).copied() else { return 0 };
        let triangles: u64 = self.trees[tree].leaves.iter().map(|l| l.triangles.len() as u64).sum();
        (vertices as u64).saturating_mul(3).saturating_mul(triangles)
    }

    /// Clips one shape's world triangles to the result's boundary. `None` when the shape is in
    /// no solid (keep it as it is).
    pub(crate) fn clip(
        &self,
        shape: usize,
        positions: &[DVec3],
        triangles: &[[u32; 3]],
        normals: Option<&[DVec3]>,
    ) -> Option<ClippedMesh> {
        let (tree, leaf) = self.shape_leaf.get(shape).copied().flatten()?;
        let tree = &self.trees[tree];
        let mut states = vec![false; tree.leaves.len()];
        let class: Vec<(bool, bool)> =
            positions.iter().map(|&p| tree.classify(leaf, p, &mut states)).collect();
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
                        if tree.classify(leaf, p.lerp(q, mid), &mut states).0 {
                            on = mid;
                        } else {
                            off = mid;
                        }
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
        Some(out)
    }
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

/// Adds solid `id` to `tree`; returns its place in its parent. A `"primitive"` block is one
/// leaf, whatever it nests.
fn add_node(
    scene: &Scene,
    id: usize,
    tree: &mut Tree,
    shape_leaf: &mut [Option<(usize, usize)>],
    tree_index: usize,
    depth: usize,
) -> Child {
    let solid = &scene.solids[id];
    if solid.op == SolidOp::Primitive {
        let leaf = tree.leaves.len();
        tree.leaves.push(Leaf::default());
        collect_shapes(scene, id, (tree_index, leaf), shape_leaf, depth);
        if tree.nodes.is_empty() {
            tree.nodes.push(Node { op: SolidOp::Union, children: vec![Child::Leaf(leaf)] });
        }
        return Child::Leaf(leaf);
    }
    let index = tree.nodes.len();
    tree.nodes.push(Node { op: solid.op, children: Vec::new() });
    for part in &solid.parts {
        let child = match *part {
            SolidPart::Shape(s) => {
                let leaf = tree.leaves.len();
                tree.leaves.push(Leaf::default());
                if let Some(slot) = shape_leaf.get_mut(s as usize) {
                    *slot = Some((tree_index, leaf));
                }
                Child::Leaf(leaf)
            }
            // The parser bounds the nesting; this bound only keeps a hand-made scene finite.
            SolidPart::Solid(k) if depth < 1024 && (k as usize) < scene.solids.len() => {
                add_node(scene, k as usize, tree, shape_leaf, tree_index, depth + 1)
            }
            SolidPart::Solid(_) => continue,
        };
        tree.nodes[index].children.push(child);
    }
    Child::Node(index)
}

/// Every shape inside solid `id` (nested blocks included) as part of `at`.
fn collect_shapes(
    scene: &Scene,
    id: usize,
    at: (usize, usize),
    shape_leaf: &mut [Option<(usize, usize)>],
    depth: usize,
) {
    for part in &scene.solids[id].parts {
        match *part {
            SolidPart::Shape(s) => {
                if let Some(slot) = shape_leaf.get_mut(s as usize) {
                    *slot = Some(at);
                }
            }
            SolidPart::Solid(k) if depth < 1024 && (k as usize) < scene.solids.len() => {
                collect_shapes(scene, k as usize, at, shape_leaf, depth + 1)
            }
            SolidPart::Solid(_) => {}
        }
    }
}
