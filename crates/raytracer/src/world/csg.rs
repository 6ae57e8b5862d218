//! Constructive solid geometry (`SolidBegin "union" | "intersection" | "difference" |
//! "primitive"`), exact in the ray tracer.
//!
//! Each outermost world solid block becomes a BLAS of its own with a [`Csg`] tree. The tree's
//! leaves are primitive solids: all the surfaces of one `"primitive"` block together, or one
//! shape given directly inside another operation (the RenderMan specification's reading). A
//! ray is classified against the tree by crossing parity: the ray's origin is inside a leaf when
//! the ray crosses the leaf's surfaces an odd number of times on its way out, and each crossing
//! toggles that leaf. The first crossing in `(t_min, t_max)` where the tree's inside state
//! changes is the hit; whether the ray enters or leaves the composite there orients the
//! outward normal (the surfaces of a subtracted solid face into it).

use super::{Blas, HitDetail, Prim};
use crate::accel::TraversalRay;
use crate::shapes::{RayShear, intersect_triangle};
use glam::Vec3;
use rib_parser::scene::{Scene, SolidOp, SolidPart};

/// Crossings gathered per ray before the rest are dropped (a hostile solid of millions of
/// coplanar layers cannot make one ray allocate without bound).
const MAX_CROSSINGS: usize = 1 << 16;

#[derive(Clone, Copy, Debug, PartialEq, Eq)]
enum Child {
    Node(u32),
    Leaf(u32),
}

#[derive(Clone, Debug, PartialEq)]
struct Node {
    op: SolidOp,
    children: Vec<Child>,
}

/// The solid tree of one BLAS. Node 0 is the root.
#[derive(Clone, Debug, PartialEq)]
pub(super) struct Csg {
    nodes: Vec<Node>,
    /// The leaf (primitive solid) of each BLAS shape, by BLAS shape index.
    pub(super) leaf_of_shape: Vec<u32>,
    leaves: usize,
}

/// An outermost solid of the scene: its tree, and which leaf each of its scene shapes
/// belongs to (scene shape index, leaf), in the order of the file.
pub(super) struct SolidPlan {
    pub(super) csg: Csg,
    pub(super) shapes: Vec<(u32, u32)>,
}

impl Csg {
    /// Whether a point with leaf states `inside` is inside the solid.
    fn inside(&self, inside: &[bool]) -> bool {
        self.node_inside(0, inside)
    }

    fn node_inside(&self, node: u32, inside: &[bool]) -> bool {
        let n = &self.nodes[node as usize];
        let child = |c: &Child| match *c {
            Child::Node(k) => self.node_inside(k, inside),
            Child::Leaf(l) => inside[l as usize],
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

    /// One plan per outermost world solid block that holds any shape.
    pub(super) fn plans(scene: &Scene) -> Vec<SolidPlan> {
        let mut plans = Vec::new();
        for (root, solid) in scene.solids.iter().enumerate() {
            if solid.parent.is_some() {
                continue;
            }
            let mut csg = Csg { nodes: Vec::new(), leaf_of_shape: Vec::new(), leaves: 0 };
            let mut shapes = Vec::new();
            csg.add_node(scene, root as u32, &mut shapes, 0);
            if !shapes.is_empty() {
                plans.push(SolidPlan { csg, shapes });
            }
        }
        plans
    }

    /// Adds solid `id` and what it holds; returns its place in its parent. A `"primitive"`
    /// block is one leaf, whatever it nests.
    fn add_node(&mut self, scene: &Scene, id: u32, shapes: &mut Vec<(u32, u32)>, depth: usize) -> Child {
        let solid = &scene.solids[id as usize];
        if solid.op == SolidOp::Primitive {
            let leaf = self.new_leaf();
            collect_shapes(scene, id, leaf, shapes, depth);
            if self.nodes.is_empty() {
                // A primitive block on its own: a one-leaf union.
                self.nodes.push(Node { op: SolidOp::Union, children: vec![Child::Leaf(leaf)] });
            }
            return Child::Leaf(leaf);
        }
        let index = self.nodes.len() as u32;
        self.nodes.push(Node { op: solid.op, children: Vec::new() });
        for part in &solid.parts {
            let child = match *part {
                SolidPart::Shape(s) => {
                    let leaf = self.new_leaf();
                    shapes.push((s, leaf));
                    Child::Leaf(leaf)
                }
                // The parser bounds the nesting; this bound only keeps a hand-made scene finite.
                SolidPart::Solid(k) if depth < 1024 => self.add_node(scene, k, shapes, depth + 1),
                SolidPart::Solid(_) => continue,
            };
            self.nodes[index as usize].children.push(child);
        }
        Child::Node(index)
    }

    fn new_leaf(&mut self) -> u32 {
        self.leaves += 1;
        self.leaves as u32 - 1
    }
}

/// Every shape inside solid `id` (nested blocks included) as part of `leaf`.
fn collect_shapes(scene: &Scene, id: u32, leaf: u32, shapes: &mut Vec<(u32, u32)>, depth: usize) {
    for part in &scene.solids[id as usize].parts {
        match *part {
            SolidPart::Shape(s) => shapes.push((s, leaf)),
            SolidPart::Solid(k) if depth < 1024 => collect_shapes(scene, k, leaf, shapes, depth + 1),
            SolidPart::Solid(_) => {}
        }
    }
}

/// The first crossing of the solid's boundary along `o + t d` with `t` in `(t_min, t_max)`
/// (BLAS space): `(t, hit, entering)`.
pub(super) fn intersect(
    blas: &Blas,
    csg: &Csg,
    o: Vec3,
    d: Vec3,
    t_min: f32,
    t_max: f32,
) -> Option<(f32, HitDetail, bool)> {
    let shear = RayShear::new(o, d)?;
    let tray = TraversalRay::new(o, d, 0.0, f32::INFINITY)?;
    let (o64, d64) = (o.as_dvec3(), d.as_dvec3());
    let mut crossings: Vec<(f32, u32, HitDetail)> = Vec::new();
    let leaf = |shape: u32| csg.leaf_of_shape.get(shape as usize).copied().unwrap_or(u32::MAX);
    blas.bvh.any(&tray, |_, slot| {
        match blas.prims[slot as usize] {
            Prim::Triangle(i) => {
                let tri = &blas.triangles[i as usize];
                if let Some(h) = intersect_triangle(&shear, tri.p[0], tri.p[1], tri.p[2], f32::INFINITY) {
                    crossings.push((h.t, leaf(tri.shape), HitDetail::Triangle(i, h.b)));
                }
            }
            Prim::Quadric(i) => {
                let q = &blas.quadrics[i as usize];
                let oo = q.object_from_blas.transform_point3(o64);
                let od = q.object_from_blas.transform_vector3(d64);
                let l = leaf(q.shape);
                q.quadric.intersect(oo, od, 0.0, f64::INFINITY, |h| {
                    let t = h.t as f32;
                    if t > 0.0 && t.is_finite() {
                        crossings.push((t, l, HitDetail::Quadric(i, *h)));
                    }
                    false
                });
            }
        }
        crossings.len() >= MAX_CROSSINGS
    });
    crossings.retain(|c| (c.1 as usize) < csg.leaves);
    crossings.sort_by(|a, b| a.0.total_cmp(&b.0));
    // The origin is inside a leaf that the ray leaves more often than it enters.
    let mut inside = vec![false; csg.leaves];
    for c in &crossings {
        inside[c.1 as usize] ^= true;
    }
    let mut state = csg.inside(&inside);
    for (t, l, detail) in crossings {
        if t >= t_max {
            break;
        }
        inside[l as usize] ^= true;
        let after = csg.inside(&inside);
        if after != state && t > t_min {
            return Some((t, detail, after));
        }
        state = after;
    }
    None
}

#[cfg(test)]
mod tests {
    use super::*;

    fn tree(op: SolidOp, children: Vec<Child>, leaves: usize) -> Csg {
        Csg { nodes: vec![Node { op, children }], leaf_of_shape: Vec::new(), leaves }
    }

    #[test]
    fn operations_combine_leaf_states_as_set_operations() {
        let leaves = vec![Child::Leaf(0), Child::Leaf(1)];
        let states = [[false, false], [true, false], [false, true], [true, true]];
        let cases = [
            (SolidOp::Union, [false, true, true, true]),
            (SolidOp::Intersection, [false, false, false, true]),
            (SolidOp::Difference, [false, true, false, false]),
        ];
        for (op, expected) in cases {
            let t = tree(op, leaves.clone(), 2);
            for (s, e) in states.iter().zip(expected) {
                assert_eq!(t.inside(s), e, "{op:?} {s:?}");
            }
        }
        // Nested: a - (b & c).
        let t = Csg {
            nodes: vec![
                Node { op: SolidOp::Difference, children: vec![Child::Leaf(0), Child::Node(1)] },
                Node { op: SolidOp::Intersection, children: vec![Child::Leaf(1), Child::Leaf(2)] },
            ],
            leaf_of_shape: Vec::new(),
            leaves: 3,
        };
        assert!(t.inside(&[true, true, false]));
        assert!(!t.inside(&[true, true, true]));
        assert!(!tree(SolidOp::Intersection, Vec::new(), 0).inside(&[]));
    }
}
