//! A bounding-volume hierarchy over a [`CollisionMesh`] for the two queries haptic rendering
//! needs: the first contact of a swept sphere (the proxy moving towards its goal) and the
//! closest point within a distance. Built once with a binned surface-area heuristic.
//!
//! Layout: a flat array of 32-byte nodes (two `f32` corners, an index and a count); the two
//! children of a node are adjacent. Triangles are copied into leaf order so that a leaf's
//! triangles sit together in memory. Boxes are computed from the same `f32` vertices the
//! queries use, so they bound them exactly and no padding is needed.

use crate::geometry::{
    CollisionMesh, Feature, SweepContact, SweepTolerance, closest_point_on_triangle, sweep_sphere_triangle,
};
use glam::{DVec3, Vec3};
use std::time::{Duration, Instant};

const MAX_LEAF_TRIANGLES: usize = 4;
const BINS: usize = 12;
/// Cost of visiting a node relative to testing one triangle (the SAH's traversal constant).
const TRAVERSAL_COST: f32 = 1.0;
/// Deepest tree the traversal stacks allow; the build makes leaves rather than go deeper.
const MAX_DEPTH: usize = 60;

#[derive(Clone, Copy, Debug)]
#[repr(C)]
struct Node {
    min: Vec3,
    /// For an interior node the index of its first child (the second follows); for a leaf the
    /// index of its first triangle.
    first: u32,
    max: Vec3,
    /// Triangles in a leaf; 0 for an interior node.
    count: u32,
}

/// One triangle in leaf order: its stored vertices, its index in the mesh, and a bounding
/// sphere (centre and radius, the radius rounded up so the sphere holds the vertices exactly)
/// that rejects most triangles near the proxy before the exact test.
#[derive(Clone, Copy, Debug)]
struct LeafTriangle {
    vertices: [Vec3; 3],
    mesh_index: u32,
    centre: Vec3,
    bound: f32,
}

impl LeafTriangle {
    fn new(vertices: [Vec3; 3], mesh_index: u32) -> LeafTriangle {
        let centre = (vertices[0] + vertices[1] + vertices[2]) / 3.0;
        let c = centre.as_dvec3();
        let reach = vertices.iter().map(|v| (v.as_dvec3() - c).length()).fold(0.0f64, f64::max);
        let mut bound = reach as f32;
        while (bound as f64) < reach {
            bound = bound.next_up();
        }
        LeafTriangle { vertices, mesh_index, centre, bound: bound.next_up() }
    }

    /// True when the segment `p0 + t d` (`t` in `[0, t_max]`) stays further than `reach` from
    /// every point of the triangle.
    fn beyond(&self, p0: DVec3, d: DVec3, dd: f64, t_max: f64, reach: f64) -> bool {
        let c = self.centre.as_dvec3();
        let t = ((c - p0).dot(d) / dd).clamp(0.0, t_max);
        let gap = (p0 + d * t - c).length() - self.bound as f64;
        gap > reach
    }
}

/// A contact found by [`Bvh::sweep_sphere`]: the triangle-level contact and the triangle.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct MeshContact {
    pub contact: SweepContact,
    /// Index of the triangle in the [`CollisionMesh`].
    pub triangle: u32,
}

/// The closest point of the mesh to a query point.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct ClosestPoint {
    pub point: DVec3,
    pub distance: f64,
    pub triangle: u32,
    pub feature: Feature,
}

/// The BVH and its build statistics.
#[derive(Clone, Debug, Default)]
pub struct Bvh {
    nodes: Vec<Node>,
    triangles: Vec<LeafTriangle>,
    build_time: Duration,
    depth: usize,
}

impl Bvh {
    /// Builds the hierarchy over every triangle of `mesh`.
    pub fn build(mesh: &CollisionMesh) -> Bvh {
        let start = Instant::now();
        let n = mesh.triangle_count();
        if n == 0 {
            return Bvh { build_time: start.elapsed(), ..Bvh::default() };
        }
        let mut bounds_min = Vec::with_capacity(n);
        let mut bounds_max = Vec::with_capacity(n);
        let mut centroids = Vec::with_capacity(n);
        for i in 0..n {
            let [a, b, c] = mesh.triangle_f32(i);
            let lo = a.min(b).min(c);
            let hi = a.max(b).max(c);
            bounds_min.push(lo);
            bounds_max.push(hi);
            centroids.push((lo + hi) * 0.5);
        }
        let mut order: Vec<u32> = (0..n as u32).collect();
        let mut nodes: Vec<Node> = Vec::with_capacity(2 * n / MAX_LEAF_TRIANGLES + 1);
        let (lo, hi) = range_bounds(&order, &bounds_min, &bounds_max);
        nodes.push(Node { min: lo, first: 0, max: hi, count: 0 });
        let mut depth_max = 0;
        // (node, start, end, depth)
        let mut stack = vec![(0usize, 0usize, n, 0usize)];
        while let Some((node, start, end, depth)) = stack.pop() {
            depth_max = depth_max.max(depth);
            let count = end - start;
            let split = if count <= MAX_LEAF_TRIANGLES || depth >= MAX_DEPTH {
                None
            } else {
                choose_split(
                    &order[start..end],
                    &bounds_min,
                    &bounds_max,
                    &centroids,
                    nodes[node].min,
                    nodes[node].max,
                )
            };
            let Some(split) = split else {
                nodes[node].first = start as u32;
                nodes[node].count = count as u32;
                continue;
            };
            let mid = match split {
                Split::Plane { axis, position } => {
                    let slice = &mut order[start..end];
                    let mut left = 0;
                    for i in 0..slice.len() {
                        if centroids[slice[i] as usize][axis] < position {
                            slice.swap(i, left);
                            left += 1;
                        }
                    }
                    start + left
                }
                Split::Median { axis } => {
                    let slice = &mut order[start..end];
                    let half = slice.len() / 2;
                    slice.select_nth_unstable_by(half, |&x, &y| {
                        centroids[x as usize][axis].total_cmp(&centroids[y as usize][axis]).then(x.cmp(&y))
                    });
                    start + half
                }
            };
            // A plane split that leaves one side empty falls back to a median split.
            let mid = if mid == start || mid == end { start + count / 2 } else { mid };
            let first_child = nodes.len();
            let (llo, lhi) = range_bounds(&order[start..mid], &bounds_min, &bounds_max);
            let (rlo, rhi) = range_bounds(&order[mid..end], &bounds_min, &bounds_max);
            nodes.push(Node { min: llo, first: 0, max: lhi, count: 0 });
            nodes.push(Node { min: rlo, first: 0, max: rhi, count: 0 });
            nodes[node].first = first_child as u32;
            nodes[node].count = 0;
            stack.push((first_child + 1, mid, end, depth + 1));
            stack.push((first_child, start, mid, depth + 1));
        }
        let triangles = order.iter().map(|&i| LeafTriangle::new(mesh.triangle_f32(i as usize), i)).collect();
        Bvh { nodes, triangles, build_time: start.elapsed(), depth: depth_max }
    }

    /// How long [`Bvh::build`] took.
    pub fn build_time(&self) -> Duration {
        self.build_time
    }

    pub fn node_count(&self) -> usize {
        self.nodes.len()
    }

    pub fn depth(&self) -> usize {
        self.depth
    }

    pub fn triangle_count(&self) -> usize {
        self.triangles.len()
    }

    /// The first contact of a sphere of `radius` whose centre moves from `p0` by `d` (local
    /// frame), as a fraction of the motion; see [`sweep_sphere_triangle`] for what counts.
    /// Among contacts at the start of the motion the closest triangle wins; among other equally
    /// early contacts the one whose normal most opposes the motion, so that the result does not
    /// depend on triangle order in the common case of a shared edge.
    pub fn sweep_sphere(&self, p0: DVec3, d: DVec3, radius: f64, tol: SweepTolerance) -> Option<MeshContact> {
        if self.nodes.is_empty() || !(d.length_squared() > 0.0) {
            return None;
        }
        let inflate = radius + tol.skin;
        let dd = d.length_squared();
        let inv = DVec3::new(safe_inverse(d.x), safe_inverse(d.y), safe_inverse(d.z));
        let mut best: Option<MeshContact> = None;
        let mut t_best = 1.0f64;
        let mut stack = [0u32; MAX_DEPTH + 2];
        let mut top = 0usize;
        slab_entry(&self.nodes[0], p0, d, inv, inflate, t_best)?;
        stack[top] = 0;
        top += 1;
        while top > 0 {
            top -= 1;
            let node = &self.nodes[stack[top] as usize];
            if node.count > 0 {
                let first = node.first as usize;
                for leaf in &self.triangles[first..first + node.count as usize] {
                    if leaf.beyond(p0, d, dd, t_best, inflate) {
                        continue;
                    }
                    let tri = leaf.vertices.map(Vec3::as_dvec3);
                    if let Some(c) = sweep_sphere_triangle(p0, d, radius, tri, t_best, tol) {
                        let better = match &best {
                            None => true,
                            Some(b) => {
                                c.t < b.contact.t
                                    || (c.t == b.contact.t
                                        && c.t == 0.0
                                        && c.start_distance < b.contact.start_distance)
                                    || (c.t == b.contact.t
                                        && c.start_distance == b.contact.start_distance
                                        && c.normal.dot(d) < b.contact.normal.dot(d))
                            }
                        };
                        if better {
                            t_best = c.t;
                            best = Some(MeshContact { contact: c, triangle: leaf.mesh_index });
                        }
                    }
                }
                continue;
            }
            let left = node.first as usize;
            let right = left + 1;
            let tl = slab_entry(&self.nodes[left], p0, d, inv, inflate, t_best);
            let tr = slab_entry(&self.nodes[right], p0, d, inv, inflate, t_best);
            // Push the farther child first so the nearer one is visited first.
            match (tl, tr) {
                (Some(a), Some(b)) => {
                    let (near, far) = if a <= b { (left, right) } else { (right, left) };
                    stack[top] = far as u32;
                    stack[top + 1] = near as u32;
                    top += 2;
                }
                (Some(_), None) => {
                    stack[top] = left as u32;
                    top += 1;
                }
                (None, Some(_)) => {
                    stack[top] = right as u32;
                    top += 1;
                }
                (None, None) => {}
            }
        }
        best
    }

    /// Calls `visit(vertices, triangle index)` (local frame) for the triangles of every leaf
    /// whose box, grown by `margin`, the ray `o + t d` (`t >= 0`) meets: every triangle the ray
    /// can cross and a few more. Returns how many nodes it tested (the caller's work bound).
    pub fn for_each_on_ray(
        &self,
        o: DVec3,
        d: DVec3,
        margin: f64,
        mut visit: impl FnMut([DVec3; 3], u32),
    ) -> u64 {
        if self.nodes.is_empty() || !(d.length_squared() > 0.0) {
            return 0;
        }
        let inv = DVec3::new(safe_inverse(d.x), safe_inverse(d.y), safe_inverse(d.z));
        let mut stack = [0u32; MAX_DEPTH + 2];
        let mut top = 1usize;
        let mut tested = 0u64;
        while top > 0 {
            top -= 1;
            let node = &self.nodes[stack[top] as usize];
            tested += 1;
            if slab_entry(node, o, d, inv, margin, f64::INFINITY).is_none() {
                continue;
            }
            if node.count > 0 {
                let first = node.first as usize;
                for leaf in &self.triangles[first..first + node.count as usize] {
                    visit(leaf.vertices.map(Vec3::as_dvec3), leaf.mesh_index);
                }
                continue;
            }
            stack[top] = node.first;
            stack[top + 1] = node.first + 1;
            top += 2;
        }
        tested
    }

    /// The closest point of the mesh to `p` among points closer than `max_distance`.
    pub fn closest_point(&self, p: DVec3, max_distance: f64) -> Option<ClosestPoint> {
        let mut best: Option<ClosestPoint> = None;
        let mut limit = max_distance;
        self.visit_near(p, &mut limit, &mut |tri, index, limit| {
            let (q, feature, _) = closest_point_on_triangle(p, tri);
            let distance = (p - q).length();
            if distance < *limit {
                *limit = distance;
                best = Some(ClosestPoint { point: q, distance, triangle: index, feature });
            }
        });
        best
    }

    /// Calls `f(triangle_index, closest point, distance)` for every triangle closer than
    /// `max_distance` to `p`.
    pub fn for_each_within(&self, p: DVec3, max_distance: f64, mut f: impl FnMut(u32, DVec3, f64)) {
        let mut limit = max_distance;
        self.visit_near(p, &mut limit, &mut |tri, index, limit| {
            let (q, _, _) = closest_point_on_triangle(p, tri);
            let distance = (p - q).length();
            if distance < *limit {
                f(index, q, distance);
            }
        });
    }

    /// Visits the triangles of every leaf whose box is closer to `p` than `*limit`; the visitor
    /// may shrink the limit.
    fn visit_near(&self, p: DVec3, limit: &mut f64, visit: &mut dyn FnMut([DVec3; 3], u32, &mut f64)) {
        if self.nodes.is_empty() {
            return;
        }
        let mut stack = [0u32; MAX_DEPTH + 2];
        let mut top = 1usize;
        while top > 0 {
            top -= 1;
            let node = &self.nodes[stack[top] as usize];
            if box_distance_squared(node, p) >= *limit * *limit {
                continue;
            }
            if node.count > 0 {
                let first = node.first as usize;
                for leaf in &self.triangles[first..first + node.count as usize] {
                    visit(leaf.vertices.map(Vec3::as_dvec3), leaf.mesh_index, limit);
                }
                continue;
            }
            let left = node.first;
            let dl = box_distance_squared(&self.nodes[left as usize], p);
            let dr = box_distance_squared(&self.nodes[left as usize + 1], p);
            let (near, far) = if dl <= dr { (left, left + 1) } else { (left + 1, left) };
            stack[top] = far;
            stack[top + 1] = near;
            top += 2;
        }
    }
}

fn safe_inverse(x: f64) -> f64 {
    if x == 0.0 { f64::INFINITY } else { 1.0 / x }
}

/// Entry parameter of the segment `p0 + t d`, `t` in `[0, t_max]`, into the node's box grown by
/// `inflate`; `None` when it misses.
fn slab_entry(node: &Node, p0: DVec3, d: DVec3, inv: DVec3, inflate: f64, t_max: f64) -> Option<f64> {
    let lo = node.min.as_dvec3() - DVec3::splat(inflate);
    let hi = node.max.as_dvec3() + DVec3::splat(inflate);
    let mut t0 = 0.0f64;
    let mut t1 = t_max;
    for axis in 0..3 {
        if d[axis] == 0.0 {
            if p0[axis] < lo[axis] || p0[axis] > hi[axis] {
                return None;
            }
            continue;
        }
        let a = (lo[axis] - p0[axis]) * inv[axis];
        let b = (hi[axis] - p0[axis]) * inv[axis];
        let (near, far) = if a <= b { (a, b) } else { (b, a) };
        t0 = t0.max(near);
        t1 = t1.min(far);
        if t0 > t1 {
            return None;
        }
    }
    Some(t0)
}

fn box_distance_squared(node: &Node, p: DVec3) -> f64 {
    let lo = node.min.as_dvec3();
    let hi = node.max.as_dvec3();
    let q = p.clamp(lo, hi);
    (p - q).length_squared()
}

fn range_bounds(order: &[u32], bounds_min: &[Vec3], bounds_max: &[Vec3]) -> (Vec3, Vec3) {
    let mut lo = Vec3::splat(f32::INFINITY);
    let mut hi = Vec3::splat(f32::NEG_INFINITY);
    for &i in order {
        lo = lo.min(bounds_min[i as usize]);
        hi = hi.max(bounds_max[i as usize]);
    }
    (lo, hi)
}

fn half_area(lo: Vec3, hi: Vec3) -> f32 {
    let e = (hi - lo).max(Vec3::ZERO);
    e.x * e.y + e.y * e.z + e.z * e.x
}

enum Split {
    Plane { axis: usize, position: f32 },
    Median { axis: usize },
}

/// The binned-SAH split of a node's triangles, or `None` when a leaf is cheaper.
fn choose_split(
    order: &[u32],
    bounds_min: &[Vec3],
    bounds_max: &[Vec3],
    centroids: &[Vec3],
    node_min: Vec3,
    node_max: Vec3,
) -> Option<Split> {
    let mut c_lo = Vec3::splat(f32::INFINITY);
    let mut c_hi = Vec3::splat(f32::NEG_INFINITY);
    for &i in order {
        c_lo = c_lo.min(centroids[i as usize]);
        c_hi = c_hi.max(centroids[i as usize]);
    }
    let extent = c_hi - c_lo;
    let widest = if extent.x >= extent.y && extent.x >= extent.z {
        0
    } else if extent.y >= extent.z {
        1
    } else {
        2
    };
    if !(extent[widest] > 0.0) {
        // Every centroid coincides: only a split by count can make progress.
        return Some(Split::Median { axis: widest });
    }
    let mut best_cost = f32::INFINITY;
    let mut best: Option<(usize, f32)> = None;
    for axis in 0..3 {
        if !(extent[axis] > 0.0) {
            continue;
        }
        let scale = BINS as f32 / extent[axis];
        let mut counts = [0u32; BINS];
        let mut lo = [Vec3::splat(f32::INFINITY); BINS];
        let mut hi = [Vec3::splat(f32::NEG_INFINITY); BINS];
        for &i in order {
            let i = i as usize;
            let b = (((centroids[i][axis] - c_lo[axis]) * scale) as usize).min(BINS - 1);
            counts[b] += 1;
            lo[b] = lo[b].min(bounds_min[i]);
            hi[b] = hi[b].max(bounds_max[i]);
        }
        // Sweep from the right to get suffix areas, then from the left.
        let mut right_area = [0.0f32; BINS];
        let mut right_count = [0u32; BINS];
        let (mut rlo, mut rhi, mut rc) = (Vec3::splat(f32::INFINITY), Vec3::splat(f32::NEG_INFINITY), 0u32);
        for b in (1..BINS).rev() {
            rlo = rlo.min(lo[b]);
            rhi = rhi.max(hi[b]);
            rc += counts[b];
            right_area[b] = half_area(rlo, rhi);
            right_count[b] = rc;
        }
        let (mut llo, mut lhi, mut lc) = (Vec3::splat(f32::INFINITY), Vec3::splat(f32::NEG_INFINITY), 0u32);
        for b in 0..BINS - 1 {
            llo = llo.min(lo[b]);
            lhi = lhi.max(hi[b]);
            lc += counts[b];
            if lc == 0 || right_count[b + 1] == 0 {
                continue;
            }
            let cost = half_area(llo, lhi) * lc as f32 + right_area[b + 1] * right_count[b + 1] as f32;
            if cost < best_cost {
                best_cost = cost;
                best = Some((axis, c_lo[axis] + (b + 1) as f32 / scale));
            }
        }
    }
    let node_area = half_area(node_min, node_max);
    let leaf_cost = order.len() as f32;
    let Some((axis, position)) = best else {
        return Some(Split::Median { axis: widest });
    };
    let split_cost = if node_area > 0.0 { TRAVERSAL_COST + best_cost / node_area } else { TRAVERSAL_COST };
    if split_cost >= leaf_cost && order.len() <= 4 * MAX_LEAF_TRIANGLES {
        return None;
    }
    Some(Split::Plane { axis, position })
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::geometry::MaterialId;

    /// A bumpy height field of `2 * n * n` triangles over the unit square.
    fn terrain(n: usize) -> CollisionMesh {
        let mut mesh = CollisionMesh::new(DVec3::ZERO);
        let h = |x: f64, y: f64| 0.05 * (7.0 * x).sin() * (5.0 * y).cos();
        let mut positions = Vec::new();
        for j in 0..=n {
            for i in 0..=n {
                let (x, y) = (i as f64 / n as f64, j as f64 / n as f64);
                positions.push(DVec3::new(x, y, h(x, y)));
            }
        }
        let mut tris = Vec::new();
        let row = n as u32 + 1;
        for j in 0..n as u32 {
            for i in 0..n as u32 {
                let a = j * row + i;
                tris.push([a, a + 1, a + row + 1]);
                tris.push([a, a + row + 1, a + row]);
            }
        }
        mesh.push_indexed(&positions, &tris, None, MaterialId(0)).unwrap();
        mesh
    }

    /// A tiny deterministic generator for test points.
    fn lcg(state: &mut u64) -> f64 {
        *state = state.wrapping_mul(6364136223846793005).wrapping_add(1442695040888963407);
        (*state >> 11) as f64 / (1u64 << 53) as f64
    }

    #[test]
    fn sweep_matches_brute_force() {
        let mesh = terrain(20);
        let bvh = Bvh::build(&mesh);
        assert_eq!(bvh.triangle_count(), mesh.triangle_count());
        let radius = 0.02;
        let tol = SweepTolerance::for_radius(radius);
        let mut seed = 7u64;
        for _ in 0..500 {
            let p0 = DVec3::new(lcg(&mut seed), lcg(&mut seed), 0.1 + 0.3 * lcg(&mut seed));
            let d = DVec3::new(lcg(&mut seed) - 0.5, lcg(&mut seed) - 0.5, -0.5 * lcg(&mut seed)) * 0.8;
            let fast = bvh.sweep_sphere(p0, d, radius, tol).map(|c| c.contact.t);
            let mut slow: Option<f64> = None;
            for i in 0..mesh.triangle_count() {
                if let Some(c) =
                    sweep_sphere_triangle(p0, d, radius, mesh.triangle_local(i), slow.unwrap_or(1.0), tol)
                    && slow.is_none_or(|t| c.t < t)
                {
                    slow = Some(c.t);
                }
            }
            assert_eq!(fast, slow, "p0 {p0} d {d}");
        }
    }

    #[test]
    fn closest_point_matches_brute_force() {
        let mesh = terrain(15);
        let bvh = Bvh::build(&mesh);
        let mut seed = 11u64;
        for _ in 0..300 {
            let p = DVec3::new(
                1.2 * lcg(&mut seed) - 0.1,
                1.2 * lcg(&mut seed) - 0.1,
                0.4 * lcg(&mut seed) - 0.2,
            );
            let fast = bvh.closest_point(p, f64::INFINITY).unwrap();
            let slow = (0..mesh.triangle_count())
                .map(|i| (p - closest_point_on_triangle(p, mesh.triangle_local(i)).0).length())
                .fold(f64::INFINITY, f64::min);
            assert!((fast.distance - slow).abs() < 1e-12);
        }
    }

    #[test]
    fn a_ray_visits_every_triangle_it_crosses() {
        let mesh = terrain(20);
        let bvh = Bvh::build(&mesh);
        let mut seed = 5u64;
        // Whether the ray `o + t d`, `t >= 0`, meets the triangle (closed barycentric bounds).
        let crosses = |o: DVec3, d: DVec3, [a, b, c]: [DVec3; 3]| {
            let (e1, e2) = (b - a, c - a);
            let q = d.cross(e2);
            let det = e1.dot(q);
            let s = o - a;
            let (u, r) = (s.dot(q) / det, s.cross(e1));
            let v = d.dot(r) / det;
            det != 0.0 && u >= 0.0 && v >= 0.0 && u + v <= 1.0 && e2.dot(r) / det >= 0.0
        };
        let (mut crossed_any, mut visited_total) = (0, 0);
        for _ in 0..300 {
            let o = DVec3::new(lcg(&mut seed), lcg(&mut seed), 0.3 * lcg(&mut seed) - 0.15);
            let d = DVec3::new(lcg(&mut seed) - 0.5, lcg(&mut seed) - 0.5, lcg(&mut seed) - 0.5);
            let mut visited = vec![false; mesh.triangle_count()];
            let tested = bvh.for_each_on_ray(o, d, 1e-9, |_, i| visited[i as usize] = true);
            assert!(tested >= 1 && tested <= bvh.node_count() as u64);
            for (i, seen) in visited.iter().enumerate() {
                if crosses(o, d, mesh.triangle_local(i)) {
                    crossed_any += 1;
                    assert!(seen, "ray {o} {d} crosses triangle {i} unvisited");
                }
            }
            visited_total += visited.iter().filter(|v| **v).count();
        }
        assert!(crossed_any > 100, "the rays cross the terrain ({crossed_any} crossings)");
        // The tree is worth having: on average a ray visits a small part of the mesh.
        assert!(visited_total < 300 * mesh.triangle_count() / 10, "{visited_total} triangles visited");
    }

    #[test]
    fn empty_mesh_has_no_contacts() {
        let bvh = Bvh::build(&CollisionMesh::new(DVec3::ZERO));
        assert!(bvh.sweep_sphere(DVec3::ZERO, DVec3::X, 0.1, SweepTolerance::for_radius(0.1)).is_none());
        assert!(bvh.closest_point(DVec3::ZERO, 1.0).is_none());
    }

    #[test]
    fn identical_triangles_build_a_bounded_tree() {
        let mut mesh = CollisionMesh::new(DVec3::ZERO);
        for _ in 0..1000 {
            mesh.push_world_triangle([DVec3::ZERO, DVec3::X, DVec3::Y], MaterialId(0)).unwrap();
        }
        let bvh = Bvh::build(&mesh);
        assert!(bvh.depth() <= MAX_DEPTH);
        let hit = bvh
            .sweep_sphere(
                DVec3::new(0.2, 0.2, 1.0),
                DVec3::new(0.0, 0.0, -2.0),
                0.1,
                SweepTolerance::for_radius(0.1),
            )
            .unwrap();
        assert!((hit.contact.t - 0.45).abs() < 1e-12);
    }
}
