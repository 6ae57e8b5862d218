//! Triangles that block light, in a bounding volume hierarchy the shaders traverse for shadow
//! rays: the tessellated scene (its shadows on live objects) and the live meshes (their shadows
//! on the pre-rendered scene).

use glam::{DMat4, DVec3, Vec3};

/// The scene's triangles in world space, as blockers of the RIB lights' light on live objects.
#[derive(Clone, Debug, Default)]
pub struct SceneOccluders {
    /// Triangles in world space.
    pub triangles: Vec<[DVec3; 3]>,
}

/// Most scene triangles the viewer traces shadow rays against (the rest are left out, smallest
/// first, with a note): 1M triangles take 48 MiB and their hierarchy at most 64 MiB.
pub const MAX_SCENE_OCCLUDER_TRIANGLES: usize = 1 << 20;

/// Most live-mesh triangles casting shadows on the pre-rendered scene in one frame (meshes
/// beyond are left out, with a note).
pub const MAX_LIVE_OCCLUDER_TRIANGLES: usize = 1 << 16;

/// Triangles per leaf of the hierarchy.
const LEAF_TRIANGLES: usize = 4;

/// Depth below which the hierarchy splits by median: from there at most log2(2^20 / 4) = 18
/// more levels, within the shaders' stack of 40 (`scene_visibility.wgsl` OCCLUDER_STACK).
const SAH_DEPTH: u32 = 20;

/// Bins per axis of the surface area heuristic.
const SAH_BINS: usize = 12;

/// Half the surface area of a box (the heuristic's measure).
fn half_area(lo: Vec3, hi: Vec3) -> f32 {
    let d = (hi - lo).max(Vec3::ZERO);
    d.x * d.y + d.y * d.z + d.z * d.x
}

/// Splits `range` (triangle indices) at the binned surface-area-heuristic's cheapest plane and
/// returns the count on the left, or `None` when no plane separates the centroids.
fn sah_split(
    range: &mut [u32],
    tris: &[[Vec3; 3]],
    centroids: &[Vec3],
    clo: Vec3,
    extent: Vec3,
) -> Option<usize> {
    let bin_of = |k: u32, axis: usize| {
        let f = (centroids[k as usize][axis] - clo[axis]) / extent[axis];
        ((f * SAH_BINS as f32) as usize).min(SAH_BINS - 1)
    };
    let mut best: Option<(f32, usize, usize)> = None;
    for axis in 0..3 {
        if extent[axis] <= 0.0 {
            continue;
        }
        let mut counts = [0usize; SAH_BINS];
        let mut boxes = [(Vec3::splat(f32::INFINITY), Vec3::splat(f32::NEG_INFINITY)); SAH_BINS];
        for &k in range.iter() {
            let b = bin_of(k, axis);
            counts[b] += 1;
            for p in tris[k as usize] {
                boxes[b].0 = boxes[b].0.min(p);
                boxes[b].1 = boxes[b].1.max(p);
            }
        }
        // Costs of the planes after bins 0..SAH_BINS-1: areas and counts swept from the right.
        let mut right_cost = [0.0f32; SAH_BINS];
        let (mut rlo, mut rhi, mut rn) = (Vec3::splat(f32::INFINITY), Vec3::splat(f32::NEG_INFINITY), 0usize);
        for b in (1..SAH_BINS).rev() {
            rlo = rlo.min(boxes[b].0);
            rhi = rhi.max(boxes[b].1);
            rn += counts[b];
            right_cost[b] = if rn > 0 { half_area(rlo, rhi) * rn as f32 } else { 0.0 };
        }
        let (mut llo, mut lhi, mut ln) = (Vec3::splat(f32::INFINITY), Vec3::splat(f32::NEG_INFINITY), 0usize);
        for b in 0..SAH_BINS - 1 {
            llo = llo.min(boxes[b].0);
            lhi = lhi.max(boxes[b].1);
            ln += counts[b];
            if ln == 0 || ln == range.len() {
                continue;
            }
            let cost = half_area(llo, lhi) * ln as f32 + right_cost[b + 1];
            if best.is_none_or(|(c, _, _)| cost < c) {
                best = Some((cost, axis, b));
            }
        }
    }
    let (_, axis, split) = best?;
    // Partition: bins up to `split` first.
    let mut left = 0;
    for i in 0..range.len() {
        if bin_of(range[i], axis) <= split {
            range.swap(i, left);
            left += 1;
        }
    }
    (left > 0 && left < range.len()).then_some(left)
}

impl SceneOccluders {
    /// The triangles kept within `budget`: all of them, or the `budget` largest by area (small
    /// triangles hide the least light), and how many were left out.
    pub fn within_budget(&self, budget: usize) -> (Vec<[DVec3; 3]>, usize) {
        let finite: Vec<[DVec3; 3]> =
            self.triangles.iter().filter(|t| t.iter().all(|p| p.is_finite())).copied().collect();
        if finite.len() <= budget {
            let dropped = self.triangles.len() - finite.len();
            return (finite, dropped);
        }
        let area = |t: &[DVec3; 3]| (t[1] - t[0]).cross(t[2] - t[0]).length();
        let mut by_area = finite;
        by_area.sort_by(|a, b| area(b).total_cmp(&area(a)));
        by_area.truncate(budget);
        (by_area, self.triangles.len() - budget)
    }
}

/// A flattened hierarchy of triangles in one space, in the layout the shaders read
/// (`scene_visibility.wgsl`).
#[derive(Clone, Debug, Default, PartialEq)]
pub struct FlatBvh {
    /// Per node two vec4s: bounds minimum with the first child's index (interior) or first
    /// triangle (leaf) as bits in w, bounds maximum with the triangle count (0: interior) in w.
    /// The second child of an interior node follows the first.
    pub nodes: Vec<[f32; 8]>,
    /// Per triangle three vec4s: a corner and the two edges from it (w unused).
    pub triangles: Vec<[f32; 12]>,
}

impl FlatBvh {
    /// Builds the hierarchy by the surface area heuristic over 12 bins of the centroids per
    /// axis (big triangles, such as a floor's two, end in leaves of their own instead of
    /// widening every box around small ones); below depth `SAH_DEPTH`, median splits keep the
    /// hierarchy within the shaders' traversal stack. Triangles with a non-finite corner are
    /// dropped.
    pub fn build(triangles: &[[Vec3; 3]]) -> FlatBvh {
        let tris: Vec<[Vec3; 3]> =
            triangles.iter().filter(|t| t.iter().all(|p| p.is_finite())).copied().collect();
        let mut order: Vec<u32> = (0..tris.len() as u32).collect();
        let centroids: Vec<Vec3> = tris.iter().map(|t| (t[0] + t[1] + t[2]) / 3.0).collect();
        let mut bvh = FlatBvh::default();
        if tris.is_empty() {
            return bvh;
        }
        bvh.nodes.push([0.0; 8]);
        // (node index, first, end, depth) of ranges still to place.
        let mut todo = vec![(0usize, 0usize, order.len(), 0u32)];
        while let Some((node, first, end, depth)) = todo.pop() {
            let (mut lo, mut hi) = (Vec3::splat(f32::INFINITY), Vec3::splat(f32::NEG_INFINITY));
            let (mut clo, mut chi) = (lo, hi);
            for &k in &order[first..end] {
                for p in tris[k as usize] {
                    lo = lo.min(p);
                    hi = hi.max(p);
                }
                clo = clo.min(centroids[k as usize]);
                chi = chi.max(centroids[k as usize]);
            }
            let extent = chi - clo;
            let count = end - first;
            if count <= LEAF_TRIANGLES || extent.max_element() <= 0.0 {
                let at = bvh.triangles.len() as u32;
                for &k in &order[first..end] {
                    let [a, b, c] = tris[k as usize];
                    let (e1, e2) = (b - a, c - a);
                    bvh.triangles.push([a.x, a.y, a.z, 0.0, e1.x, e1.y, e1.z, 0.0, e2.x, e2.y, e2.z, 0.0]);
                }
                bvh.nodes[node] = node_of(lo, hi, at, count as u32);
                continue;
            }
            let range = &mut order[first..end];
            let sah = if depth < SAH_DEPTH { sah_split(range, &tris, &centroids, clo, extent) } else { None };
            let mid = match sah {
                Some(m) => first + m,
                None => {
                    let axis = extent.max_position();
                    range.select_nth_unstable_by(count / 2, |&a, &b| {
                        centroids[a as usize][axis].total_cmp(&centroids[b as usize][axis])
                    });
                    first + count / 2
                }
            };
            let left = bvh.nodes.len();
            bvh.nodes.push([0.0; 8]);
            bvh.nodes.push([0.0; 8]);
            bvh.nodes[node] = node_of(lo, hi, left as u32, 0);
            todo.push((left + 1, mid, end, depth + 1));
            todo.push((left, first, mid, depth + 1));
        }
        bvh
    }

    /// Whether a triangle blocks the segment from `origin` along unit `dir` between `t_min`
    /// and `t_max`: the traversal the shaders do, on the CPU (for tests).
    pub fn blocks(&self, origin: Vec3, dir: Vec3, t_min: f32, t_max: f32) -> bool {
        if self.nodes.is_empty() {
            return false;
        }
        let inv = Vec3::select(dir.abs().cmplt(Vec3::splat(1e-30)), Vec3::splat(1e30), dir.recip());
        let mut stack = vec![0u32];
        while let Some(k) = stack.pop() {
            let n = &self.nodes[k as usize];
            let (lo, hi) = (Vec3::new(n[0], n[1], n[2]), Vec3::new(n[4], n[5], n[6]));
            let (t0, t1) = ((lo - origin) * inv, (hi - origin) * inv);
            let near = t0.min(t1).max_element().max(t_min);
            let far = t0.max(t1).min_element().min(t_max);
            if near > far {
                continue;
            }
            let (a, count) = (n[3].to_bits(), n[7].to_bits());
            if count == 0 {
                stack.extend([a, a + 1]);
                continue;
            }
            for t in &self.triangles[a as usize..(a + count) as usize] {
                let v0 = Vec3::new(t[0], t[1], t[2]);
                let e1 = Vec3::new(t[4], t[5], t[6]);
                let e2 = Vec3::new(t[8], t[9], t[10]);
                if let Some(hit) = ray_triangle(origin, dir, v0, e1, e2)
                    && hit > t_min
                    && hit < t_max
                {
                    return true;
                }
            }
        }
        false
    }
}

/// The ray parameter where `origin + t dir` meets the triangle (Möller-Trumbore, its
/// barycentric bounds widened by `EDGE_SLACK` so that shared edges leak no light), as
/// `scene_visibility.wgsl` computes it.
pub fn ray_triangle(origin: Vec3, dir: Vec3, v0: Vec3, e1: Vec3, e2: Vec3) -> Option<f32> {
    const EDGE_SLACK: f32 = 1e-5;
    let pv = dir.cross(e2);
    let det = e1.dot(pv);
    if det == 0.0 {
        return None;
    }
    let inv_det = 1.0 / det;
    let tv = origin - v0;
    let u = tv.dot(pv) * inv_det;
    let qv = tv.cross(e1);
    let v = dir.dot(qv) * inv_det;
    if u < -EDGE_SLACK || v < -EDGE_SLACK || u + v > 1.0 + EDGE_SLACK {
        return None;
    }
    Some(e2.dot(qv) * inv_det)
}

fn node_of(lo: Vec3, hi: Vec3, a: u32, count: u32) -> [f32; 8] {
    [lo.x, lo.y, lo.z, f32::from_bits(a), hi.x, hi.y, hi.z, f32::from_bits(count)]
}

/// Triangles of `positions`/`indices` moved by `m` (in f64) into f32, skipping bad indices.
pub fn transformed_triangles(positions: &[Vec3], indices: &[u32], m: DMat4) -> Vec<[Vec3; 3]> {
    let moved: Vec<Vec3> = positions.iter().map(|p| m.transform_point3(p.as_dvec3()).as_vec3()).collect();
    indices
        .chunks_exact(3)
        .filter_map(|t| {
            let corner = |i: u32| moved.get(i as usize).copied();
            Some([corner(t[0])?, corner(t[1])?, corner(t[2])?])
        })
        .collect()
}

#[cfg(test)]
mod tests {
    use super::*;

    /// A small deterministic generator (xorshift) for scattered triangles.
    fn scattered(n: usize) -> Vec<[Vec3; 3]> {
        let mut s = 0x9e37_79b9_7f4a_7c15u64;
        let mut next = || {
            s ^= s << 13;
            s ^= s >> 7;
            s ^= s << 17;
            (s >> 40) as f32 / (1u64 << 24) as f32
        };
        (0..n)
            .map(|_| {
                let c = Vec3::new(next(), next(), next()) * 10.0 - 5.0;
                let mut corner = || c + Vec3::new(next(), next(), next()) - 0.5;
                [corner(), corner(), corner()]
            })
            .collect()
    }

    #[test]
    fn the_hierarchy_blocks_exactly_the_rays_the_triangles_block() {
        let tris = scattered(500);
        let bvh = FlatBvh::build(&tris);
        assert_eq!(bvh.triangles.len(), 500);
        assert!(bvh.nodes.len() < 2 * 500);
        let rays = scattered(400);
        let mut blocked = 0;
        for r in &rays {
            let origin = r[0];
            let dir = (r[1] - r[0]).normalize();
            let t_max = 6.0;
            let brute = tris.iter().any(|t| {
                ray_triangle(origin, dir, t[0], t[1] - t[0], t[2] - t[0])
                    .is_some_and(|h| h > 1e-4 && h < t_max)
            });
            assert_eq!(bvh.blocks(origin, dir, 1e-4, t_max), brute, "ray from {origin} along {dir}");
            blocked += usize::from(brute);
        }
        // Both outcomes occur, so the comparison tests something.
        assert!(blocked > 20 && blocked < 380, "{blocked} of 400 blocked");
    }

    #[test]
    fn an_empty_or_degenerate_set_blocks_nothing() {
        assert!(!FlatBvh::build(&[]).blocks(Vec3::ZERO, Vec3::X, 0.0, 10.0));
        let nan = [[Vec3::NAN, Vec3::X, Vec3::Y]];
        let bvh = FlatBvh::build(&nan);
        assert!(bvh.nodes.is_empty());
        // Many triangles at one centroid end in one leaf, without endless splitting.
        let same = vec![[Vec3::new(-1.0, -1.0, 1.0), Vec3::new(1.0, -1.0, 1.0), Vec3::new(0.0, 2.0, 1.0)]; 9];
        let bvh = FlatBvh::build(&same);
        assert_eq!(bvh.nodes.len(), 1);
        assert!(bvh.blocks(Vec3::ZERO, Vec3::Z, 0.0, 2.0));
        assert!(!bvh.blocks(Vec3::ZERO, Vec3::Z, 0.0, 0.5));
    }

    #[test]
    fn over_budget_the_largest_triangles_are_kept() {
        let small = [DVec3::ZERO, DVec3::X * 0.1, DVec3::Y * 0.1];
        let large = [DVec3::ZERO, DVec3::X, DVec3::Y];
        let scene = SceneOccluders { triangles: vec![small, large, small] };
        let (kept, left_out) = scene.within_budget(1);
        assert_eq!((kept, left_out), (vec![large], 2));
        let (kept, left_out) = scene.within_budget(8);
        assert_eq!((kept.len(), left_out), (3, 0));
    }
}
