//! The traversal loop over obvhs' CWBVH nodes: obvhs' `traverse!` step for step (the same order
//! of node and primitive visits) with our node test, the primitive tests inlined, and a stack
//! that is neither allocated nor cleared per query.

use super::{Bvh, NodeLanes, NodeTest, TraversalRay, intersect_node};
use obvhs::cwbvh::CwBvh;
use std::mem::MaybeUninit;

impl Bvh {
    /// The traversal loop: obvhs' CWBVH traversal (`obvhs::traverse!`, the same order of node
    /// and primitive visits) with our node test, and a stack that is neither allocated nor
    /// cleared per query. `node` is called on each node visit, `primitive(ray, slot)` on each
    /// primitive (the duplicate of a one-primitive tree skipped); it may change `ray.t_max`
    /// and returns `true` to stop. Returns whether it stopped. `lanes` runs the node tests.
    #[inline(always)]
    pub(super) fn walk(
        &self,
        lanes: impl NodeLanes,
        ray: &mut TraversalRay,
        node: impl FnMut(),
        primitive: impl FnMut(&mut TraversalRay, u32) -> bool,
    ) -> bool {
        if self.cw.nodes.is_empty() {
            return false;
        }
        if self.depth <= ArrayStack::CAPACITY {
            // The storage is a separate local: built inside `ArrayStack` next to `len: 0`, LLVM
            // merges the two stores into one `memset` of the whole array.
            let mut storage = MaybeUninit::uninit();
            self.walk_with(lanes, &mut ArrayStack::new(&mut storage), ray, node, primitive)
        } else {
            self.walk_with(lanes, &mut Vec::with_capacity(self.depth), ray, node, primitive)
        }
    }

    #[inline(always)]
    fn walk_with(
        &self,
        lanes: impl NodeLanes,
        stack: &mut impl GroupStack,
        ray: &mut TraversalRay,
        mut on_node: impl FnMut(),
        mut primitive: impl FnMut(&mut TraversalRay, u32) -> bool,
    ) -> bool {
        let nodes = &self.cw.nodes[..];
        let dummy = self.dummy_slot.unwrap_or(u32::MAX);
        let oct = ray.oct_inv4 & 0xff;
        let test = NodeTest::new(ray);
        // A node group: the index of its first child node and, in the top byte, the children
        // still to visit (with `imask` below); a primitive group: the first slot and a bit per
        // primitive still to test.
        let (mut group_base, mut group_bits) = (0u32, 0x8000_0000u32);
        let (mut prim_base, mut prim_bits) = (0u32, 0u32);
        loop {
            while prim_bits != 0 {
                let local = 31 - prim_bits.leading_zeros();
                prim_bits &= !(1u32 << local);
                let slot = prim_base + local;
                if slot != dummy && primitive(ray, slot) {
                    return true;
                }
            }
            if group_bits & 0xff00_0000 != 0 {
                let hits = group_bits;
                let offset = 31 - hits.leading_zeros();
                group_bits &= !(1u32 << offset);
                if group_bits & 0xff00_0000 != 0 {
                    stack.push(group_base, group_bits);
                }
                let slot_index = (offset - 24) ^ oct;
                // The interior children stored before this one: a popcount of the low byte
                // (`imask`) below the slot; x86-64's baseline has no popcount instruction.
                let relative = u32::from(POPCOUNT8[(hits & !(u32::MAX << slot_index) & 0xff) as usize]);
                let child = &nodes[(group_base + relative) as usize];
                on_node();
                let hit_mask = intersect_node(child, ray, &test, lanes);
                group_base = child.child_base_idx;
                group_bits = (hit_mask & 0xff00_0000) | u32::from(child.imask);
                prim_base = child.primitive_base_idx;
                prim_bits = hit_mask & 0x00ff_ffff;
            } else {
                group_bits = 0;
            }
            if prim_bits == 0 && group_bits & 0xff00_0000 == 0 {
                match stack.pop() {
                    Some((base, bits)) => (group_base, group_bits) = (base, bits),
                    None => return false,
                }
            }
        }
    }
}

/// The number of set bits of each byte value.
const POPCOUNT8: [u8; 256] = {
    let mut table = [0u8; 256];
    let mut i = 0;
    while i < 256 {
        table[i] = (i as u32).count_ones() as u8;
        i += 1;
    }
    table
};

/// The traversal stack of node groups (first child index, visit bits).
trait GroupStack {
    fn push(&mut self, base: u32, bits: u32);
    fn pop(&mut self) -> Option<(u32, u32)>;
}

/// A fixed-size traversal stack on the call stack, not initialised: only entries below `len`
/// are ever read, and each of them was written by `push`. Used for trees no deeper than its
/// capacity (a traversal pushes at most one group per level).
struct ArrayStack<'a> {
    entries: &'a mut MaybeUninit<[(u32, u32); ArrayStack::CAPACITY]>,
    len: usize,
}

impl ArrayStack<'_> {
    const CAPACITY: usize = 64;

    #[inline(always)]
    fn new(entries: &mut MaybeUninit<[(u32, u32); ArrayStack::CAPACITY]>) -> ArrayStack<'_> {
        ArrayStack { entries, len: 0 }
    }
}

impl GroupStack for ArrayStack<'_> {
    #[inline(always)]
    fn push(&mut self, base: u32, bits: u32) {
        // The tree's depth bounds the stack (checked when choosing this stack); the check keeps
        // an error there a panic rather than a write past the array.
        assert!(self.len < ArrayStack::CAPACITY, "traversal stack deeper than the tree");
        // SAFETY: `len` is in bounds (just checked); writing needs no initialised value.
        unsafe { self.entries.as_mut_ptr().cast::<(u32, u32)>().add(self.len).write((base, bits)) };
        self.len += 1;
    }

    #[inline(always)]
    fn pop(&mut self) -> Option<(u32, u32)> {
        if self.len == 0 {
            return None;
        }
        self.len -= 1;
        // SAFETY: entries below `len` are in bounds and were written by `push` (see the type's
        // comment).
        Some(unsafe { self.entries.as_ptr().cast::<(u32, u32)>().add(self.len).read() })
    }
}

impl GroupStack for Vec<(u32, u32)> {
    #[inline(always)]
    fn push(&mut self, base: u32, bits: u32) {
        Vec::push(self, (base, bits));
    }

    #[inline(always)]
    fn pop(&mut self) -> Option<(u32, u32)> {
        Vec::pop(self)
    }
}

/// The number of levels of a CWBVH (1 for a root alone; 0 when empty): the most groups a
/// traversal can have on its stack.
pub(super) fn tree_depth(cw: &CwBvh) -> usize {
    if cw.nodes.is_empty() {
        return 0;
    }
    let mut depth = 0;
    let mut pending = vec![(0u32, 1usize)];
    while let Some((index, level)) = pending.pop() {
        depth = depth.max(level);
        let node = &cw.nodes[index as usize];
        // Interior children are stored consecutively from `child_base_idx`, in slot order.
        let interior = node.imask.count_ones();
        for k in 0..interior {
            pending.push((node.child_base_idx + k, level + 1));
        }
    }
    depth
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::accel::tests::random_boxes;
    use crate::accel::{Baseline, X86_64V3};
    use crate::sampling::Rng;
    use glam::{Vec3, Vec3A};

    impl Bvh {
        /// The traversal this module used before its own loop: obvhs' `traverse!` macro with our
        /// node test. Every primitive visit and the `t_max` it saw, in order. The octant is the
        /// ray's: obvhs' `new_traversal` takes it from the direction before tiny components are
        /// flushed, which disagrees with the node test's for a negative component below `1e-20`.
        fn visits_with_obvhs_loop(
            &self,
            ray: &mut TraversalRay,
            closest: bool,
            test: &mut dyn FnMut(u32) -> Option<f32>,
        ) -> Vec<(u32, f32)> {
            use glam::UVec2;
            let mut out = Vec::new();
            if self.cw.nodes.is_empty() {
                return out;
            }
            let mut state = self.cw.new_traversal(Vec3A::from(Vec3::from(ray.direction)));
            state.oct_inv4 = ray.oct_inv4;
            let mut node;
            let dummy = self.dummy_slot.unwrap_or(u32::MAX);
            obvhs::traverse!(
                self.cw,
                node,
                state,
                intersect_node(node, ray, &NodeTest::new(ray), Baseline),
                {
                    if state.primitive_id == dummy {
                        continue;
                    }
                    out.push((state.primitive_id, ray.t_max));
                    if let Some(t) = test(state.primitive_id)
                        && closest
                        && t < ray.t_max
                    {
                        ray.t_max = t;
                    }
                }
            );
            out
        }

        /// The same record from our loop, with the array stack or the growing one.
        fn visits_with_walk(
            &self,
            lanes: impl NodeLanes,
            ray: &mut TraversalRay,
            heap: bool,
            test: &mut dyn FnMut(u32) -> Option<f32>,
        ) -> Vec<(u32, f32)> {
            let mut out = Vec::new();
            let visit = |ray: &mut TraversalRay, slot: u32| {
                out.push((slot, ray.t_max));
                if let Some(t) = test(slot)
                    && t < ray.t_max
                {
                    ray.t_max = t;
                }
                false
            };
            if heap {
                self.walk_with(lanes, &mut Vec::new(), ray, || {}, visit);
            } else {
                self.walk_with(lanes, &mut ArrayStack::new(&mut MaybeUninit::uninit()), ray, || {}, visit);
            }
            out
        }
    }

    /// Random triangles (a "mesh" of small and large, overlapping triangles) and their boxes.
    fn random_triangles(n: usize, rng: &mut Rng) -> Vec<[Vec3; 3]> {
        (0..n)
            .map(|k| {
                let c = Vec3::new(rng.uniform(), rng.uniform(), rng.uniform()) * 10.0 - 5.0;
                let size = if k % 7 == 0 { 4.0 } else { 0.6 };
                [0; 3].map(|_| c + (Vec3::new(rng.uniform(), rng.uniform(), rng.uniform()) - 0.5) * size)
            })
            .collect()
    }

    fn random_ray(rng: &mut Rng, k: usize) -> TraversalRay {
        let o = Vec3::new(rng.uniform(), rng.uniform(), rng.uniform()) * 14.0 - 7.0;
        let mut d = crate::sampling::sample_uniform_sphere(rng.uniform2());
        // Axis-aligned directions, zero and tiny components of either sign, too.
        if k.is_multiple_of(5) {
            d[k % 3] = [0.0, -0.0, 1e-25, -1e-25, 1e-30][(k / 3) % 5];
        }
        TraversalRay::new(o, d, 0.0, f32::INFINITY)
            .unwrap_or_else(|| TraversalRay::new(o, Vec3::X, 0.0, f32::INFINITY).unwrap())
    }

    /// Our traversal loop visits the same primitives in the same order, with the same `t_max`
    /// at each visit, as obvhs' `traverse!` with the same node test, for closest-hit and
    /// visit-all queries on random meshes; so it finds the same closest hit (the first of equal
    /// `t`s too). Both of its stacks agree.
    #[test]
    fn walk_matches_obvhs_traversal() {
        use crate::shapes::{RayShear, intersect_triangle};
        let mut rng = Rng::new(21, 4);
        for (trial, n) in [1usize, 2, 3, 9, 40, 300, 2000].into_iter().enumerate() {
            let tris = random_triangles(n, &mut rng);
            let boxes: Vec<(Vec3, Vec3)> =
                tris.iter().map(|t| (t[0].min(t[1]).min(t[2]), t[0].max(t[1]).max(t[2]))).collect();
            let bvh = Bvh::build(&boxes);
            let mut hits = 0;
            for k in 0..400 {
                let ray = random_ray(&mut rng, k + trial);
                let shear = RayShear::for_traversal(&ray);
                let mut test = |slot: u32| {
                    let p = tris[bvh.order()[slot as usize] as usize];
                    intersect_triangle(&shear, p[0], p[1], p[2], f32::INFINITY).map(|h| h.t)
                };
                for closest in [true, false] {
                    let (mut a, mut b, mut c) = (ray, ray, ray);
                    let expected = bvh.visits_with_obvhs_loop(&mut a, closest, &mut test);
                    let mut test_walk = |slot: u32| if closest { test(slot) } else { None };
                    let got = bvh.visits_with_walk(Baseline, &mut b, false, &mut test_walk);
                    let got_heap = bvh.visits_with_walk(Baseline, &mut c, true, &mut test_walk);
                    assert_eq!(got, expected, "{n} triangles, ray {k}, closest {closest}");
                    assert_eq!(got_heap, expected);
                    // The eight-lane node tests visit the same primitives with the same `t_max`.
                    if let Some(v3) = X86_64V3::detect() {
                        let mut d = ray;
                        assert_eq!(bvh.visits_with_walk(v3, &mut d, false, &mut test_walk), expected);
                        assert_eq!(d.t_max.to_bits(), b.t_max.to_bits());
                    }
                    assert_eq!(a.t_max.to_bits(), b.t_max.to_bits());
                    hits += usize::from(closest && b.t_max < f32::INFINITY);
                }
            }
            assert!(n < 300 || hits > 40, "too few hits ({hits}) to compare closest hits");
        }
    }

    /// `any` stops at the first primitive that reports a hit, and finds one exactly when the
    /// closest-hit query does.
    #[test]
    fn any_hit_agrees_with_closest_hit() {
        use crate::shapes::{RayShear, intersect_triangle};
        let mut rng = Rng::new(8, 9);
        let tris = random_triangles(500, &mut rng);
        let boxes: Vec<(Vec3, Vec3)> =
            tris.iter().map(|t| (t[0].min(t[1]).min(t[2]), t[0].max(t[1]).max(t[2]))).collect();
        let bvh = Bvh::build(&boxes);
        let (mut hit_count, mut miss_count) = (0, 0);
        for k in 0..2000 {
            let mut ray = random_ray(&mut rng, k);
            // Segments of random length, as shadow rays are.
            ray.t_max = rng.uniform() * 12.0;
            let shear = RayShear::for_traversal(&ray);
            let test = |slot: u32, t_max: f32| {
                let p = tris[bvh.order()[slot as usize] as usize];
                intersect_triangle(&shear, p[0], p[1], p[2], t_max).map(|h| h.t)
            };
            let mut closest = ray;
            let found = bvh.closest(&mut closest, |r, slot| test(slot, r.t_max));
            let mut after_stop = 0;
            let mut stopped_at = None;
            let any = bvh.any(&ray, |r, slot| {
                if stopped_at.is_some() {
                    after_stop += 1;
                }
                let hit = test(slot, r.t_max).is_some();
                if hit {
                    stopped_at = Some(slot);
                }
                hit
            });
            assert_eq!(any, found, "ray {k}");
            assert_eq!(after_stop, 0);
            if found { hit_count += 1 } else { miss_count += 1 }
        }
        assert!(hit_count > 100 && miss_count > 100, "{hit_count} hits, {miss_count} misses");
    }

    /// The depth that chooses the stack: a root alone is one level, and every level of a large
    /// tree is counted (a traversal's stack never holds more groups than that).
    #[test]
    fn depth_bounds_the_stack() {
        let mut rng = Rng::new(3, 3);
        assert_eq!(Bvh::build(&[]).depth, 0);
        assert_eq!(Bvh::build(&[(Vec3::ZERO, Vec3::ONE)]).depth, 1);
        let boxes = random_boxes(5000, 1.0, Vec3::ZERO, &mut rng);
        let bvh = Bvh::build(&boxes);
        assert!(bvh.depth >= 4 && bvh.depth <= ArrayStack::CAPACITY, "depth {}", bvh.depth);
        // A stack that records its largest size, on rays through the whole tree.
        struct Deepest(Vec<(u32, u32)>, usize);
        impl GroupStack for Deepest {
            fn push(&mut self, base: u32, bits: u32) {
                self.0.push((base, bits));
                self.1 = self.1.max(self.0.len());
            }
            fn pop(&mut self) -> Option<(u32, u32)> {
                self.0.pop()
            }
        }
        let mut deepest = Deepest(Vec::new(), 0);
        for k in 0..200 {
            let mut ray = random_ray(&mut rng, k);
            bvh.walk_with(Baseline, &mut deepest, &mut ray, || {}, |_, _| false);
        }
        assert!(deepest.1 > 0 && deepest.1 < bvh.depth, "stack {} for depth {}", deepest.1, bvh.depth);
    }
}
