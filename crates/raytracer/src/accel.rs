//! Bounding volume hierarchies: obvhs' compressed wide BVH8 (CWBVH) with a conservative node test.
//!
//! obvhs builds the tree (PLOC with reinsertion, in parallel) and provides the traversal loop
//! (`obvhs::traverse!`); the ray-node test here replaces obvhs' own, which clamps the entry
//! distance to a fixed `1e-4` and so would cull hits closer than that at any scene scale. Ours
//! widens each quantised child box by a hundredth of a quantisation step and the exit distance
//! by a relative `2^-20`, both far above the rounding error of the test and far below anything
//! that costs time, so a primitive the exact primitive test would hit is never culled.

use glam::{Vec3, Vec3A, Vec4};
use obvhs::aabb::Aabb;
use obvhs::cwbvh::CwBvh;
use obvhs::cwbvh::node::{CwBvhNode, extract_byte64};
use obvhs::ploc::PlocBuilder;
use std::mem::MaybeUninit;
use std::time::{Duration, Instant};

/// Largest magnitude used for the reciprocal of a zero direction component: large enough that
/// a slab the ray does not cross is rejected, small enough that nothing overflows.
const BIG: f32 = 1e20;

/// Widening of every quantised child box, in quantisation steps.
const CHILD_PAD: f32 = 0.01;

/// Relative widening of the exit distance of a box.
const EXIT_PAD: f32 = 1.0 + 1.0 / (1u32 << 20) as f32;

/// A ray prepared for traversal: reciprocal direction and octant, and the live `[t_min, t_max]`.
#[derive(Clone, Copy, Debug)]
pub struct TraversalRay {
    pub origin: Vec3A,
    pub direction: Vec3A,
    inv_direction: Vec3A,
    oct_inv4: u32,
    pub t_min: f32,
    pub t_max: f32,
}

impl TraversalRay {
    /// `None` when the origin or direction is not finite or the direction is zero.
    #[inline]
    pub fn new(origin: Vec3, direction: Vec3, t_min: f32, t_max: f32) -> Option<TraversalRay> {
        let (o, d) = (Vec3A::from(origin), Vec3A::from(direction));
        // Lane-wise checks (glam's `Vec3::is_finite` tests one component at a time).
        if !(o.is_finite() && d.is_finite()) || t_max.is_nan() {
            return None;
        }
        // Flush tiny components to +0 so that the sign used to pick the near plane and the sign
        // of the reciprocal always agree. One vector division gives the three reciprocals.
        let tiny = d.abs().cmplt(Vec3A::splat(1.0 / BIG));
        let flushed = Vec3A::select(tiny, Vec3A::ZERO, d);
        if flushed.cmpeq(Vec3A::ZERO).all() {
            return None;
        }
        let inv_direction = Vec3A::select(tiny, Vec3A::splat(BIG), Vec3A::ONE / flushed);
        // obvhs' octant code: per byte, 4 when x is not negative, 2 for y, 1 for z.
        const OCT_INV4: [u32; 8] = {
            let mut table = [0u32; 8];
            let mut negative = 0;
            while negative < 8 {
                let positive = (if negative & 1 == 0 { 4 } else { 0 })
                    | (if negative & 2 == 0 { 2 } else { 0 })
                    | (if negative & 4 == 0 { 1 } else { 0 });
                table[negative] = positive * 0x0101_0101;
                negative += 1;
            }
            table
        };
        let oct_inv4 = OCT_INV4[(flushed.cmplt(Vec3A::ZERO).bitmask() & 7) as usize];
        Some(TraversalRay { origin: o, direction: d, inv_direction, oct_inv4, t_min, t_max })
    }

    /// The reciprocal direction used by the node test (`1e20` with the sign of zero for
    /// components below `1e-20`).
    #[inline(always)]
    pub fn inv_direction(&self) -> Vec3A {
        self.inv_direction
    }
}

/// One quantised plane of a node's eight children (`child_min_x` and so on) as two groups of
/// four floats. Exact: every byte is a small integer. On x86-64 the bytes are widened with
/// SSE2 unpacks (six instructions instead of eight scalar conversions and inserts).
#[inline(always)]
fn child_planes(q: &[u8; 8]) -> [Vec4; 2] {
    #[cfg(target_arch = "x86_64")]
    {
        use std::arch::x86_64::{
            _mm_cvtepi32_ps, _mm_cvtsi64_si128, _mm_setzero_si128, _mm_unpackhi_epi16, _mm_unpacklo_epi8,
            _mm_unpacklo_epi16,
        };
        // SAFETY: SSE2 is part of the x86-64 baseline, and these intrinsics touch no memory.
        unsafe {
            let zero = _mm_setzero_si128();
            let words = _mm_unpacklo_epi8(_mm_cvtsi64_si128(i64::from_le_bytes(*q)), zero);
            [
                Vec4::from(_mm_cvtepi32_ps(_mm_unpacklo_epi16(words, zero))),
                Vec4::from(_mm_cvtepi32_ps(_mm_unpackhi_epi16(words, zero))),
            ]
        }
    }
    #[cfg(not(target_arch = "x86_64"))]
    {
        let group = |i: usize| {
            Vec4::new(f32::from(q[i]), f32::from(q[i + 1]), f32::from(q[i + 2]), f32::from(q[i + 3]))
        };
        [group(0), group(4)]
    }
}

/// What the node test needs of a ray beyond [`TraversalRay`], made once per query: per axis,
/// which of a node's planes is near (1, the maximum, when the reciprocal direction is negative)
/// and the widening added to the near and the far plane (`-CHILD_PAD` and `+CHILD_PAD` for a
/// positive direction, the opposite for a negative one).
#[derive(Clone, Copy)]
struct NodeTest {
    near: [usize; 3],
    near_pad: [Vec4; 3],
    far_pad: [Vec4; 3],
}

impl NodeTest {
    #[inline(always)]
    fn new(ray: &TraversalRay) -> NodeTest {
        let negative = ray.inv_direction.cmplt(Vec3A::ZERO).bitmask();
        let near = [0, 1, 2].map(|a| ((negative >> a) & 1) as usize);
        let pad = |near: usize| Vec4::splat(if near == 1 { CHILD_PAD } else { -CHILD_PAD });
        NodeTest { near, near_pad: near.map(pad), far_pad: near.map(|n| pad(n ^ 1)) }
    }
}

/// The conservative CWBVH node test: a hit mask in obvhs' layout.
///
/// Each child's entry and exit distances per axis are `(plane +- CHILD_PAD) * scale + offset`
/// with the near plane chosen by the sign of the reciprocal direction; `test` makes that choice
/// once per query, without a branch per node (the same `f32` operations, so the same mask, as
/// choosing per node).
#[inline(always)]
fn intersect_node(node: &CwBvhNode, ray: &TraversalRay, test: &NodeTest) -> u32 {
    let extent = node.compute_extent();
    let adj_inv = extent * ray.inv_direction;
    let adj_origin = (Vec3A::from(node.p) - ray.origin) * ray.inv_direction;
    let (child_bits8, bit_index8) = node.get_child_and_index_bits(ray.oct_inv4);
    let t_limit = ray.t_max * EXIT_PAD;
    let planes = node_planes(node);
    // Entry and exit distances of the eight children along one axis, as two groups of four.
    let axis = |a: usize, scale: f32, offset: f32| {
        let near = child_planes(&planes[2 * a + (test.near[a] & 1)]);
        let far = child_planes(&planes[2 * a + ((test.near[a] & 1) ^ 1)]);
        let (scale, offset) = (Vec4::splat(scale), Vec4::splat(offset));
        [0, 1].map(|g| {
            ((near[g] + test.near_pad[a]) * scale + offset, (far[g] + test.far_pad[a]) * scale + offset)
        })
    };
    let x = axis(0, adj_inv.x, adj_origin.x);
    let y = axis(1, adj_inv.y, adj_origin.y);
    let z = axis(2, adj_inv.z, adj_origin.z);
    let mut mask = 0u32;
    for g in 0..2 {
        let t_near = x[g].0.max(y[g].0).max(z[g].0).max(Vec4::splat(ray.t_min));
        let t_far = (x[g].1.min(y[g].1).min(z[g].1) * EXIT_PAD).min(Vec4::splat(t_limit));
        mask |= t_near.cmple(t_far).bitmask() << (4 * g);
    }
    let mut hit_mask = 0u32;
    while mask != 0 {
        let child = mask.trailing_zeros() as usize;
        mask &= mask - 1;
        hit_mask |= extract_byte64(child_bits8, child) << extract_byte64(bit_index8, child);
    }
    hit_mask
}

/// A node's six quantised plane arrays, `[min_x, max_x, min_y, max_y, min_z, max_z]`.
#[inline(always)]
fn node_planes(node: &CwBvhNode) -> &[[u8; 8]; 6] {
    // The node is `repr(C)` and `Pod`, 80 bytes: 32 bytes of header, then the six arrays.
    let all: &[[u8; 8]; 10] = bytemuck::cast_ref(node);
    all[4..].try_into().expect("ten groups of eight bytes")
}

/// Build statistics of one BVH.
#[derive(Clone, Copy, Debug, Default, PartialEq)]
pub struct BvhStats {
    pub primitives: usize,
    pub nodes: usize,
    pub bytes: usize,
    pub build_time: Duration,
}

/// A CWBVH over primitives given by their bounding boxes. The primitives are referred to by
/// their position in the BVH's order ([`Bvh::order`]); callers store their data in that order.
#[derive(Clone, Debug)]
pub struct Bvh {
    cw: CwBvh,
    /// `order[i]` is the caller's index of BVH primitive `i`.
    order: Vec<u32>,
    /// The slot of the duplicate made for a one-primitive tree, skipped by traversal.
    dummy_slot: Option<u32>,
    /// Levels of the tree ([`tree_depth`]), which bound the traversal stack.
    depth: usize,
    pub stats: BvhStats,
}

impl Bvh {
    /// Builds a BVH over boxes (`[min, max]`, finite, in one space). Each box is widened by a
    /// relative `2^-20` of its coordinates so that rounding in the quantisation never shrinks it.
    pub fn build(boxes: &[(Vec3, Vec3)]) -> Bvh {
        let start = Instant::now();
        let aabbs: Vec<Aabb> = boxes
            .iter()
            .map(|&(lo, hi)| {
                let pad =
                    lo.abs().max(hi.abs()) * (1.0 / (1u32 << 20) as f32) + Vec3::splat(f32::MIN_POSITIVE);
                Aabb::new((lo - pad).into(), (hi + pad).into())
            })
            .collect();
        let cw = if aabbs.is_empty() {
            CwBvh::default()
        } else if aabbs.len() == 1 {
            // PLOC needs two leaves to make an interior root: duplicate the only box; the
            // duplicate is dropped from the order below.
            build_cwbvh(&[aabbs[0], aabbs[0]])
        } else {
            build_cwbvh(&aabbs)
        };
        let dummy_slot = if boxes.len() == 1 {
            cw.primitive_indices.iter().position(|&i| i == 1).map(|s| s as u32)
        } else {
            None
        };
        let order: Vec<u32> = cw.primitive_indices.iter().map(|&i| i.min(boxes.len() as u32 - 1)).collect();
        let stats = BvhStats {
            primitives: boxes.len(),
            nodes: cw.nodes.len(),
            bytes: cw.nodes.len() * std::mem::size_of::<CwBvhNode>() + cw.primitive_indices.len() * 4,
            build_time: start.elapsed(),
        };
        let depth = tree_depth(&cw);
        Bvh { cw, order, dummy_slot, depth, stats }
    }

    /// The caller's primitive index of each BVH slot, in traversal order.
    pub fn order(&self) -> &[u32] {
        &self.order
    }

    pub fn is_empty(&self) -> bool {
        self.cw.nodes.is_empty()
    }

    /// Closest-hit traversal. `intersect(ray, slot)` tests BVH slot `slot` against `ray` (whose
    /// `t_max` is the closest hit so far) and returns a closer `t` when it hits.
    #[inline]
    pub fn closest(
        &self,
        ray: &mut TraversalRay,
        mut intersect: impl FnMut(&TraversalRay, u32) -> Option<f32>,
    ) -> bool {
        let mut hit = false;
        self.walk(
            ray,
            || {},
            #[inline(always)]
            |ray, slot| {
                if let Some(t) = intersect(ray, slot)
                    && t < ray.t_max
                {
                    ray.t_max = t;
                    hit = true;
                }
                false
            },
        );
        hit
    }

    /// Visits every primitive whose box the ray crosses until `visit` returns `true` (stop).
    /// Returns whether it stopped.
    #[inline]
    pub fn any(&self, ray: &TraversalRay, mut visit: impl FnMut(&TraversalRay, u32) -> bool) -> bool {
        let mut ray = *ray;
        self.walk(
            &mut ray,
            || {},
            #[inline(always)]
            |ray, slot| visit(ray, slot),
        )
    }

    /// The traversal loop: obvhs' CWBVH traversal (`obvhs::traverse!`, the same order of node
    /// and primitive visits) with our node test, and a stack that is neither allocated nor
    /// cleared per query. `node` is called on each node visit, `primitive(ray, slot)` on each
    /// primitive (the duplicate of a one-primitive tree skipped); it may change `ray.t_max`
    /// and returns `true` to stop. Returns whether it stopped.
    #[inline(always)]
    fn walk(
        &self,
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
            self.walk_with(&mut ArrayStack::new(&mut storage), ray, node, primitive)
        } else {
            self.walk_with(&mut Vec::with_capacity(self.depth), ray, node, primitive)
        }
    }

    #[inline(always)]
    fn walk_with(
        &self,
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
                let hit_mask = intersect_node(child, ray, &test);
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

    /// obvhs' own closest-hit traversal of the same tree (its node test), for benchmarks.
    pub fn closest_with_obvhs_traversal(
        &self,
        origin: Vec3,
        direction: Vec3,
        t_max: f32,
        mut intersect: impl FnMut(&obvhs::ray::Ray, u32) -> f32,
    ) -> Option<(u32, f32)> {
        let ray = obvhs::ray::Ray::new(origin.into(), direction.into(), 0.0, t_max);
        let mut hit = obvhs::ray::RayHit::none();
        self.cw
            .ray_traverse(ray, &mut hit, |r, slot| intersect(r, slot as u32))
            .then_some((hit.primitive_id, hit.t))
    }
    /// obvhs' own occlusion traversal of the same tree (its node test), for benchmarks: true
    /// when `intersect` reports a hit closer than `t_max` for some primitive.
    pub fn occluded_with_obvhs_traversal(
        &self,
        origin: Vec3,
        direction: Vec3,
        t_max: f32,
        mut intersect: impl FnMut(&obvhs::ray::Ray, u32) -> f32,
    ) -> bool {
        let ray = obvhs::ray::Ray::new(origin.into(), direction.into(), 0.0, t_max);
        !self.cw.ray_traverse_miss(ray, |r, slot| intersect(r, slot as u32))
    }

    /// For benchmarks: the node visits and primitive tests of a closest-hit traversal with our
    /// node test, `intersect` as in [`Bvh::closest`].
    #[doc(hidden)]
    pub fn closest_counting(
        &self,
        ray: &mut TraversalRay,
        mut intersect: impl FnMut(&TraversalRay, u32) -> Option<f32>,
    ) -> (u32, u32) {
        let (mut nodes, mut prims) = (0u32, 0u32);
        self.walk(
            ray,
            || nodes += 1,
            |ray, slot| {
                prims += 1;
                if let Some(t) = intersect(ray, slot)
                    && t < ray.t_max
                {
                    ray.t_max = t;
                }
                false
            },
        );
        (nodes, prims)
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
fn tree_depth(cw: &CwBvh) -> usize {
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

/// obvhs' `build_cwbvh` without its debug-build validation pass (which is quadratic-ish in
/// practice and would dominate test times for large meshes).
fn build_cwbvh(aabbs: &[Aabb]) -> CwBvh {
    let config = obvhs::BvhBuildParams::medium_build();
    let mut bvh2 = PlocBuilder::with_capacity(aabbs.len()).build(
        config.ploc_search_distance,
        aabbs,
        (0..aabbs.len() as u32).collect::<Vec<_>>(),
        config.sort_precision,
        config.search_depth_threshold,
    );
    obvhs::bvh2::reinsertion::ReinsertionOptimizer::default().run(
        &mut bvh2,
        config.reinsertion_batch_ratio,
        None,
    );
    obvhs::cwbvh::bvh2_to_cwbvh::bvh2_to_cwbvh(&bvh2, config.max_prims_per_leaf.clamp(1, 3), true, false)
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::sampling::Rng;

    fn random_boxes(n: usize, scale: f32, offset: Vec3, rng: &mut Rng) -> Vec<(Vec3, Vec3)> {
        (0..n)
            .map(|_| {
                let c = Vec3::new(rng.uniform(), rng.uniform(), rng.uniform()) * scale + offset;
                let e = Vec3::new(rng.uniform(), rng.uniform(), rng.uniform()) * scale * 0.05;
                (c - e, c + e)
            })
            .collect()
    }

    /// Every box a brute-force slab test says the ray enters is visited (no false negatives), at
    /// scales from 1e-4 to 1e4 and far from the origin.
    #[test]
    fn traversal_never_misses_a_box() {
        let mut rng = Rng::new(5, 5);
        for (scale, offset) in
            [(1.0, Vec3::ZERO), (1e-4, Vec3::ZERO), (1e4, Vec3::ZERO), (1.0, Vec3::splat(1e5))]
        {
            let boxes = random_boxes(500, scale, offset, &mut rng);
            let bvh = Bvh::build(&boxes);
            for _ in 0..300 {
                let o = Vec3::new(rng.uniform(), rng.uniform(), rng.uniform()) * scale * 1.2 + offset;
                let d = crate::sampling::sample_uniform_sphere(rng.uniform2());
                let mut expected: Vec<u32> = (0..boxes.len() as u32)
                    .filter(|&i| {
                        let (lo, hi) = boxes[i as usize];
                        let t0 = (lo - o) / d;
                        let t1 = (hi - o) / d;
                        let near = t0.min(t1).max_element().max(0.0);
                        let far = t0.max(t1).min_element();
                        near <= far
                    })
                    .collect();
                let ray = TraversalRay::new(o, d, 0.0, f32::INFINITY).unwrap();
                let mut seen = Vec::new();
                bvh.any(&ray, |_, slot| {
                    seen.push(bvh.order()[slot as usize]);
                    false
                });
                seen.sort_unstable();
                expected.retain(|i| seen.binary_search(i).is_err());
                assert!(expected.is_empty(), "missed boxes {expected:?} at scale {scale}");
            }
        }
    }

    /// The SIMD widening of a child plane gives exactly the bytes' values, in order, for every
    /// byte in every lane.
    #[test]
    fn child_planes_are_the_bytes() {
        for b in 0..=255u8 {
            let q: [u8; 8] = std::array::from_fn(|i| b.wrapping_add(37u8.wrapping_mul(i as u8)));
            let [a, c] = child_planes(&q);
            let got = [a.x, a.y, a.z, a.w, c.x, c.y, c.z, c.w];
            assert_eq!(got, q.map(f32::from));
        }
    }

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
            obvhs::traverse!(self.cw, node, state, intersect_node(node, ray, &NodeTest::new(ray)), {
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
            });
            out
        }

        /// The same record from our loop, with the array stack or the growing one.
        fn visits_with_walk(
            &self,
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
                self.walk_with(&mut Vec::new(), ray, || {}, visit);
            } else {
                self.walk_with(&mut ArrayStack::new(&mut MaybeUninit::uninit()), ray, || {}, visit);
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
                    let got = bvh.visits_with_walk(&mut b, false, &mut test_walk);
                    let got_heap = bvh.visits_with_walk(&mut c, true, &mut test_walk);
                    assert_eq!(got, expected, "{n} triangles, ray {k}, closest {closest}");
                    assert_eq!(got_heap, expected);
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
            bvh.walk_with(&mut deepest, &mut ray, || {}, |_, _| false);
        }
        assert!(deepest.1 > 0 && deepest.1 < bvh.depth, "stack {} for depth {}", deepest.1, bvh.depth);
    }

    #[test]
    fn single_and_empty() {
        let empty = Bvh::build(&[]);
        assert!(empty.is_empty());
        let one = Bvh::build(&[(Vec3::ZERO, Vec3::ONE)]);
        let mut ray = TraversalRay::new(Vec3::new(0.5, 0.5, -1.0), Vec3::Z, 0.0, f32::INFINITY).unwrap();
        let mut visits = 0;
        one.closest(&mut ray, |_, slot| {
            assert_eq!(one.order()[slot as usize], 0);
            visits += 1;
            Some(1.0)
        });
        assert_eq!(visits, 1);
        assert_eq!(ray.t_max, 1.0);
    }
}
