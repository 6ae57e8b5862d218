//! The constructive solid geometry tree of a `SolidBegin` block, read once for every consumer
//! (the ray tracer traces it exactly, the haptics clip their triangles to it).
//!
//! The leaves are primitive solids: all the surfaces of one `"primitive"` block together, or
//! one shape given directly inside another operation (the RenderMan specification's reading).
//! [`CsgTree::inside`] combines the leaves' inside flags with the blocks' operations; how a
//! consumer decides whether a point is inside a leaf (crossing parity along a ray, for both)
//! is its own business. This is scene structure only: no geometry.

use crate::scene::{Scene, SolidOp, SolidPart};

/// Nesting followed before the rest is dropped: the parser bounds it far lower, this bound
/// only keeps a hand-made scene finite.
const MAX_DEPTH: usize = 1024;

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

/// The tree of one outermost solid block. Node 0 is the root.
#[derive(Clone, Debug, PartialEq)]
pub struct CsgTree {
    nodes: Vec<Node>,
    leaves: u32,
    /// `(scene shape index, leaf)` for every shape of the block, in the order of the file.
    shapes: Vec<(u32, u32)>,
}

impl CsgTree {
    /// One tree per outermost world solid block of `scene` that holds any shape.
    pub fn outermost(scene: &Scene) -> Vec<CsgTree> {
        let mut trees = Vec::new();
        for (root, solid) in scene.solids.iter().enumerate() {
            if solid.parent.is_some() {
                continue;
            }
            let mut tree = CsgTree { nodes: Vec::new(), leaves: 0, shapes: Vec::new() };
            tree.add_node(scene, root, 0);
            if !tree.shapes.is_empty() {
                trees.push(tree);
            }
        }
        trees
    }

    /// How many primitive solids the tree combines (leaves are numbered `0..leaf_count()`).
    pub fn leaf_count(&self) -> usize {
        self.leaves as usize
    }

    /// `(scene shape index, leaf)` for every shape of the block, in the order of the file.
    /// Indices are as the scene gives them: a consumer checks them against `scene.shapes`.
    pub fn shapes(&self) -> &[(u32, u32)] {
        &self.shapes
    }

    /// Whether a point is inside the solid, given whether it is inside each leaf
    /// (`leaf_inside[l]`; a leaf past the slice's end counts as outside).
    pub fn inside(&self, leaf_inside: &[bool]) -> bool {
        !self.nodes.is_empty() && self.node_inside(0, leaf_inside)
    }

    fn node_inside(&self, node: u32, leaf_inside: &[bool]) -> bool {
        let n = &self.nodes[node as usize];
        let child = |c: &Child| match *c {
            Child::Node(k) => self.node_inside(k, leaf_inside),
            Child::Leaf(l) => leaf_inside.get(l as usize).copied().unwrap_or(false),
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

    /// Adds solid `id` and what it holds; returns its place in its parent. A `"primitive"`
    /// block is one leaf, whatever it nests.
    fn add_node(&mut self, scene: &Scene, id: usize, depth: usize) -> Child {
        let solid = &scene.solids[id];
        if solid.op == SolidOp::Primitive {
            let leaf = self.new_leaf();
            self.collect_shapes(scene, id, leaf, depth);
            if self.nodes.is_empty() {
                // A primitive block on its own: a one-leaf union.
                self.nodes.push(Node { op: SolidOp::Union, children: vec![Child::Leaf(leaf)] });
            }
            return Child::Leaf(leaf);
        }
        let index = self.nodes.len();
        self.nodes.push(Node { op: solid.op, children: Vec::new() });
        for part in &solid.parts {
            let child = match *part {
                SolidPart::Shape(s) => {
                    let leaf = self.new_leaf();
                    self.shapes.push((s, leaf));
                    Child::Leaf(leaf)
                }
                SolidPart::Solid(k) if depth < MAX_DEPTH && (k as usize) < scene.solids.len() => {
                    self.add_node(scene, k as usize, depth + 1)
                }
                SolidPart::Solid(_) => continue,
            };
            self.nodes[index].children.push(child);
        }
        Child::Node(index as u32)
    }

    /// Every shape inside solid `id` (nested blocks included) as part of `leaf`.
    fn collect_shapes(&mut self, scene: &Scene, id: usize, leaf: u32, depth: usize) {
        for part in &scene.solids[id].parts {
            match *part {
                SolidPart::Shape(s) => self.shapes.push((s, leaf)),
                SolidPart::Solid(k) if depth < MAX_DEPTH && (k as usize) < scene.solids.len() => {
                    self.collect_shapes(scene, k as usize, leaf, depth + 1)
                }
                SolidPart::Solid(_) => {}
            }
        }
    }

    fn new_leaf(&mut self) -> u32 {
        self.leaves += 1;
        self.leaves - 1
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    fn tree(op: SolidOp, children: Vec<Child>, leaves: u32) -> CsgTree {
        CsgTree { nodes: vec![Node { op, children }], leaves, shapes: Vec::new() }
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
        let t = CsgTree {
            nodes: vec![
                Node { op: SolidOp::Difference, children: vec![Child::Leaf(0), Child::Node(1)] },
                Node { op: SolidOp::Intersection, children: vec![Child::Leaf(1), Child::Leaf(2)] },
            ],
            leaves: 3,
            shapes: Vec::new(),
        };
        assert!(t.inside(&[true, true, false]));
        assert!(!t.inside(&[true, true, true]));
        // Leaves missing from the slice count as outside.
        assert!(t.inside(&[true]));
        assert!(!tree(SolidOp::Intersection, Vec::new(), 0).inside(&[]));
    }

    #[test]
    fn blocks_become_trees_with_primitive_blocks_as_one_leaf() {
        let rib = "WorldBegin\n\
            SolidBegin \"difference\"\nSphere 1 -1 1 360\n\
              SolidBegin \"primitive\"\nSphere 1 -1 1 360\n\
                SolidBegin \"union\"\nSphere 1 -1 1 360\nSolidEnd\n\
              SolidEnd\n\
            SolidEnd\n\
            SolidBegin \"union\"\nSolidEnd\n\
            SolidBegin \"intersection\"\nSphere 1 -1 1 360\nSphere 1 -1 1 360\nSolidEnd\n\
            WorldEnd\n";
        let mut scene = crate::load_bytes("csg.rib", rib.as_bytes().to_vec(), &crate::LoadOptions::default())
            .unwrap_or_else(|e| panic!("{}", e.render()))
            .scene;
        // A block index past the scene's solids (only a hand-made scene has one) is skipped.
        let last = scene.solids.len() - 1;
        scene.solids[last].parts.insert(1, SolidPart::Solid(99));
        let trees = CsgTree::outermost(&scene);
        assert_eq!(trees.len(), 2, "the empty block makes no tree");
        assert_eq!(trees[0].leaf_count(), 2);
        assert_eq!(trees[0].shapes(), &[(0, 0), (1, 1), (2, 1)]);
        assert!(trees[0].inside(&[true, false]));
        assert!(!trees[0].inside(&[true, true]));
        assert_eq!(trees[1].leaf_count(), 2);
        assert_eq!(trees[1].shapes(), &[(3, 0), (4, 1)]);
        assert!(trees[1].inside(&[true, true]) && !trees[1].inside(&[true, false]));
    }
}
