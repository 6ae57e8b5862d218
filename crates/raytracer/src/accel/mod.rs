//! Bounding volume hierarchies: obvhs' compressed wide BVH8 (CWBVH) with a conservative node test.
//!
//! obvhs builds the tree (PLOC with reinsertion, in parallel); the traversal loop is ours
//! (`walk.rs`: obvhs' `traverse!` step for step, without its per-query stack initialisation,
//! the primitive tests inlined). The ray-node test here replaces obvhs' own, which clamps the
//! entry distance to a fixed `1e-4` and so would cull hits closer than that at any scene scale. Ours
//! widens each quantised child box by a hundredth of a quantisation step and the exit distance
//! by a relative `2^-20`, both far above the rounding error of the test and far below anything
//! that costs time, so a primitive the exact primitive test would hit is never culled.

mod node_lanes;
mod walk;

pub(crate) use node_lanes::{Baseline, NodeLanes, X86_64V3};

use glam::{Vec3, Vec3A, Vec4};
use obvhs::aabb::Aabb;
use obvhs::cwbvh::CwBvh;
use obvhs::cwbvh::node::{CwBvhNode, extract_byte64};
use obvhs::ploc::PlocBuilder;
use std::time::{Duration, Instant};

/// Largest magnitude used for the reciprocal of a zero direction component: large enough that
/// a slab the ray does not cross is rejected, small enough that nothing overflows.
const BIG: f32 = 1e20;

/// Largest box coordinate the builder sees (2^40, about 1.1e12). obvhs' builder sums surface
/// areas in f32, which overflow for boxes near 1e19 and then break the tree it converts (an
/// out-of-bounds panic). Boxes are clamped to this range: a primitive reaching past it is
/// still found by every ray that meets it within the range, and f32 hit points beyond it
/// would carry errors larger than most scenes anyway.
pub const MAX_BOX_COORD: f32 = (1u64 << 40) as f32;

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

/// What the node test needs of a ray beyond [`TraversalRay`], made once per query: per axis,
/// which of a node's planes is near (1, the maximum, when the reciprocal direction is negative)
/// and the widening added to the near and the far plane (`-CHILD_PAD` and `+CHILD_PAD` for a
/// positive direction, the opposite for a negative one).
#[derive(Clone, Copy)]
pub(crate) struct NodeTest {
    near: [usize; 3],
    near_pad: [Vec4; 3],
    far_pad: [Vec4; 3],
}

impl NodeTest {
    #[inline(always)]
    fn new(ray: &TraversalRay) -> NodeTest {
        let negative = ray.inv_direction.cmplt(Vec3A::ZERO);
        let near = [0, 1, 2].map(|a| ((negative.bitmask() >> a) & 1) as usize);
        // The pads chosen in lanes from the comparison's mask, not per axis from `near` (three
        // branches or selects, and their values moved into place, per query).
        let near_pad = Vec3A::select(negative, Vec3A::splat(CHILD_PAD), Vec3A::splat(-CHILD_PAD));
        let [x, y, z] = near_pad.to_array().map(Vec4::splat);
        NodeTest { near, near_pad: [x, y, z], far_pad: [-x, -y, -z] }
    }
}

/// The conservative CWBVH node test: a hit mask in obvhs' layout.
///
/// Each child's entry and exit distances per axis are `(plane +- CHILD_PAD) * scale + offset`
/// with the near plane chosen by the sign of the reciprocal direction; `test` makes that choice
/// once per query, without a branch per node (the same `f32` operations, so the same mask, as
/// choosing per node).
#[inline(always)]
fn intersect_node(node: &CwBvhNode, ray: &TraversalRay, test: &NodeTest, lanes: impl NodeLanes) -> u32 {
    let extent = node.compute_extent();
    let adj_inv = extent * ray.inv_direction;
    let adj_origin = (Vec3A::from(node.p) - ray.origin) * ray.inv_direction;
    let (child_bits8, bit_index8) = node.get_child_and_index_bits(ray.oct_inv4);
    let t_limit = ray.t_max * EXIT_PAD;
    let mut mask = lanes.child_mask(node_planes(node), test, adj_inv, adj_origin, (ray.t_min, t_limit));
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
    /// relative `2^-20` of its coordinates so that rounding in the quantisation never shrinks it,
    /// and clamped to `±MAX_BOX_COORD`.
    pub fn build(boxes: &[(Vec3, Vec3)]) -> Bvh {
        let start = Instant::now();
        let limit = Vec3::splat(MAX_BOX_COORD);
        let aabbs: Vec<Aabb> = boxes
            .iter()
            .map(|&(lo, hi)| {
                let (lo, hi) = (lo.clamp(-limit, limit), hi.clamp(-limit, limit));
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
        let depth = walk::tree_depth(&cw);
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
        intersect: impl FnMut(&TraversalRay, u32) -> Option<f32>,
    ) -> bool {
        self.closest_with(Baseline, ray, intersect)
    }

    /// [`Bvh::closest`] with the node tests run by `lanes`. Always inlined, so that a caller
    /// compiled with more target features compiles the traversal with them.
    #[inline(always)]
    pub(crate) fn closest_with(
        &self,
        lanes: impl NodeLanes,
        ray: &mut TraversalRay,
        mut intersect: impl FnMut(&TraversalRay, u32) -> Option<f32>,
    ) -> bool {
        let mut hit = false;
        self.walk(
            lanes,
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
    pub fn any(&self, ray: &TraversalRay, visit: impl FnMut(&TraversalRay, u32) -> bool) -> bool {
        self.any_with(Baseline, ray, visit)
    }

    /// [`Bvh::any`] with the node tests run by `lanes`, always inlined as
    /// [`Bvh::closest_with`].
    #[inline(always)]
    pub(crate) fn any_with(
        &self,
        lanes: impl NodeLanes,
        ray: &TraversalRay,
        mut visit: impl FnMut(&TraversalRay, u32) -> bool,
    ) -> bool {
        let mut ray = *ray;
        self.walk(
            lanes,
            &mut ray,
            || {},
            #[inline(always)]
            |ray, slot| visit(ray, slot),
        )
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
            Baseline,
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

    pub(super) fn random_boxes(n: usize, scale: f32, offset: Vec3, rng: &mut Rng) -> Vec<(Vec3, Vec3)> {
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

    /// Boxes reaching past `MAX_BOX_COORD` (a polygon with a vertex at 1e30, say) used to make
    /// obvhs' conversion panic (surface areas overflow f32). They build, and every box is
    /// still visited by rays that enter it within the clamped range.
    #[test]
    fn huge_boxes_build_and_are_visited() {
        let mut rng = Rng::new(9, 9);
        for huge in [1e20f32, 1e30, f32::MAX] {
            let mut boxes = random_boxes(20, 1.0, Vec3::ZERO, &mut rng);
            boxes.push((Vec3::new(-huge, -0.5, -huge), Vec3::new(huge, 0.5, 1.0)));
            boxes.push((Vec3::splat(huge * 0.5), Vec3::splat(huge)));
            let bvh = Bvh::build(&boxes);
            for _ in 0..200 {
                let o = Vec3::new(rng.uniform(), rng.uniform(), rng.uniform()) * 1.2;
                let d = crate::sampling::sample_uniform_sphere(rng.uniform2());
                let ray = TraversalRay::new(o, d, 0.0, f32::INFINITY).unwrap();
                let mut seen = Vec::new();
                bvh.any(&ray, |_, slot| {
                    seen.push(bvh.order()[slot as usize]);
                    false
                });
                // The slab through the origin is entered by every ray that starts inside it.
                if o.y.abs() < 0.5 && o.z < 1.0 {
                    assert!(seen.contains(&20), "the huge slab was not visited at {huge}");
                }
            }
        }
    }

    /// The SIMD widening of a child plane gives exactly the bytes' values, in order, for every
    /// byte in every lane.
    #[test]
    fn child_planes_are_the_bytes() {
        for b in 0..=255u8 {
            let q: [u8; 8] = std::array::from_fn(|i| b.wrapping_add(37u8.wrapping_mul(i as u8)));
            let [a, c] = node_lanes::child_planes(&q);
            let got = [a.x, a.y, a.z, a.w, c.x, c.y, c.z, c.w];
            assert_eq!(got, q.map(f32::from));
        }
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
