//! Triangles that block light, in a bounding volume hierarchy the shaders traverse for shadow
//! rays: the tessellated scene (its shadows on live objects) and the live meshes (their shadows
//! on the pre-rendered scene).

use glam::{DMat4, DVec3, Vec3};
use obvhs::BvhBuildParams;
use obvhs::aabb::Aabb;
use obvhs::bvh2::Bvh2;
use obvhs::bvh2::builder::build_bvh2;
use obvhs::bvh2::node::Bvh2Node;
use std::time::Duration;

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

/// Most triangles per leaf of the hierarchy.
const LEAF_TRIANGLES: usize = 4;

/// Depth from which a subtree of obvhs' hierarchy higher than `MEDIAN_HEIGHT` is rebuilt by
/// median splits: from there at most log2(2^20 / 4) = 18 more levels, so the hierarchy fits
/// the shaders' stack of 40 (`scene_visibility.wgsl` OCCLUDER_STACK) whatever obvhs builds.
const OBVHS_DEPTH: u32 = 20;

/// Levels a subtree at `OBVHS_DEPTH` may have below it.
const MEDIAN_HEIGHT: u32 = 18;

/// What a node of the flat hierarchy stands for while it is built.
enum Part {
    /// A node of obvhs' hierarchy.
    Tree(usize),
    /// Triangles (indices) to split by median.
    Triangles(Vec<u32>),
}

/// Levels below each node of obvhs' hierarchy (0 for a leaf).
fn subtree_heights(nodes: &[Bvh2Node]) -> Vec<u32> {
    let mut preorder = Vec::with_capacity(nodes.len());
    let mut stack = vec![0usize];
    while let Some(k) = stack.pop() {
        preorder.push(k);
        if !nodes[k].is_leaf() {
            let first = nodes[k].first_index as usize;
            stack.extend([first, first + 1]);
        }
    }
    let mut heights = vec![0u32; nodes.len()];
    for &k in preorder.iter().rev() {
        if !nodes[k].is_leaf() {
            let first = nodes[k].first_index as usize;
            heights[k] = 1 + heights[first].max(heights[first + 1]);
        }
    }
    heights
}

/// The triangles under node `k` of obvhs' hierarchy.
fn subtree_primitives(tree: &Bvh2, k: usize) -> Vec<u32> {
    let mut ids = Vec::new();
    let mut stack = vec![k];
    while let Some(k) = stack.pop() {
        let n = &tree.nodes[k];
        let first = n.first_index as usize;
        if n.is_leaf() {
            ids.extend_from_slice(&tree.primitive_indices[first..first + n.prim_count as usize]);
        } else {
            stack.extend([first, first + 1]);
        }
    }
    ids
}

fn centroid(t: &[Vec3; 3]) -> Vec3 {
    (t[0] + t[1] + t[2]) / 3.0
}

/// The bounds of triangles `ids` and the extent of their centroids.
fn bounds(tris: &[[Vec3; 3]], ids: &[u32]) -> (Vec3, Vec3, Vec3) {
    let (mut lo, mut hi) = (Vec3::splat(f32::INFINITY), Vec3::splat(f32::NEG_INFINITY));
    let (mut clo, mut chi) = (lo, hi);
    for &k in ids {
        let t = &tris[k as usize];
        for p in t {
            lo = lo.min(*p);
            hi = hi.max(*p);
        }
        clo = clo.min(centroid(t));
        chi = chi.max(centroid(t));
    }
    (lo, hi, chi - clo)
}

impl SceneOccluders {
    /// The triangles kept within `budget`: all of them, or the `budget` largest by area (small
    /// triangles hide the least light), and how many were left out.
    pub fn within_budget(&self, budget: usize) -> (Vec<[DVec3; 3]>, usize) {
        let (kept, left_out) = self.kept_within_budget(budget);
        (kept.iter().map(|&k| self.triangles[k]).collect(), left_out)
    }

    /// The indices of the triangles [`SceneOccluders::within_budget`] keeps, in its order, and
    /// how many were left out.
    pub fn kept_within_budget(&self, budget: usize) -> (Vec<usize>, usize) {
        let finite: Vec<usize> =
            (0..self.triangles.len()).filter(|&k| self.triangles[k].iter().all(|p| p.is_finite())).collect();
        if finite.len() <= budget {
            let dropped = self.triangles.len() - finite.len();
            return (finite, dropped);
        }
        let area = |t: &[DVec3; 3]| (t[1] - t[0]).cross(t[2] - t[0]).length();
        let mut by_area = finite;
        by_area.sort_by(|&a, &b| area(&self.triangles[b]).total_cmp(&area(&self.triangles[a])));
        by_area.truncate(budget);
        (by_area, self.triangles.len() - budget)
    }
}

/// A scene surface's light as the near field on live objects reads it
/// (`near_field.wgsl`, docs/viewer-lighting.md "Near a large scene surface"): its reflectances
/// as the ray tracer's BSDF has them (`raytracer::materials`), so that a live surface beside it
/// gets the light it sends instead of the irradiance probes' light from that direction.
#[derive(Clone, Copy, Debug, Default, PartialEq)]
pub struct SceneMaterial {
    /// The Lambertian lobe's reflectance (`Kd * Cs`, with plastic's energy bound).
    pub diffuse: Vec3,
    /// The Blinn lobe's reflectance (plastic's `Ks * specularcolor`, metal's `Ks * Cs`).
    pub glossy: Vec3,
    /// The Blinn lobe's exponent (`1 / roughness`, within 1 and 10^4).
    pub exponent: f32,
    /// `Ka * Cs`, times the ambient lights' sum.
    pub ambient: Vec3,
    /// A shader's own emission (`constant`, `defaultsurface`):
    /// `emission * (emission_flat + emission_cos2 * cos^2)` toward a direction at `cos` to the
    /// normal. Area lights' emission is not here: the lights' direct light counts it.
    pub emission: Vec3,
    pub emission_flat: f32,
    pub emission_cos2: f32,
    /// Mirror and glass: what they send depends on what lies behind or before them, so the
    /// near field keeps the probes' light from that direction; a glossy live surface's lobe
    /// follows a mirror (`specular_chain.wgsl`).
    pub specular: bool,
    /// A mirror's reflection weight (`Kr * Cs`, at most one).
    pub reflect: Vec3,
    /// Glass: its index of refraction (`eta`), which tells it from a mirror; 0 for a mirror.
    pub eta: f32,
}

/// The scene's surface materials and which one each of [`SceneOccluders::triangles`] has.
#[derive(Clone, Debug, Default)]
pub struct SceneMaterials {
    pub materials: Vec<SceneMaterial>,
    /// Per scene triangle (in the order of [`SceneOccluders::triangles`]) an index into
    /// `materials`; a triangle past the end, or with an index past `materials`, has none.
    pub of_triangle: Vec<u32>,
}

impl SceneMaterials {
    /// The tag [`FlatBvh::build_tagged`] stores for scene triangle `k`: its material's index
    /// plus one, 0 for none.
    pub fn tag_of(&self, k: usize) -> u32 {
        match self.of_triangle.get(k) {
            Some(&m) if (m as usize) < self.materials.len() => m + 1,
            _ => 0,
        }
    }
}

/// Largest occluder coordinate kept (2^40, about 1.1e12, as the ray tracer's BVH keeps). A
/// corner far beyond it (a control point at 1e30) overflows the builder's f32 surface areas,
/// which made the build take minutes; f32 shadow rays cannot resolve such a triangle anyway.
pub const MAX_OCCLUDER_COORD: f32 = (1u64 << 40) as f32;

/// A flattened hierarchy of triangles in one space, in the layout the shaders read
/// (`scene_visibility.wgsl`).
#[derive(Clone, Debug, Default, PartialEq)]
pub struct FlatBvh {
    /// Per node two vec4s: bounds minimum with the first child's index (interior) or first
    /// triangle (leaf) as bits in w, bounds maximum with the triangle count (0: interior) in w.
    /// The second child of an interior node follows the first.
    pub nodes: Vec<[f32; 8]>,
    /// Per triangle three vec4s: a corner and the two edges from it; the first w holds the
    /// triangle's tag as bits (`build_tagged`; 0 from `build`), the others are unused.
    pub triangles: Vec<[f32; 12]>,
}

impl FlatBvh {
    /// Builds the hierarchy with obvhs (PLOC, reinsertion, leaves of at most four triangles
    /// collapsed by its surface area heuristic: `BvhBuildParams::fast_build`) and flattens it
    /// to the shaders' layout, which is obvhs' own (two adjacent children, a leaf's triangles
    /// contiguous in its primitive order). A subtree that starts at depth `OBVHS_DEPTH` and is
    /// more than `MEDIAN_HEIGHT` levels high is rebuilt by median splits, so the hierarchy
    /// always fits the shaders' traversal stack of 40. Triangles with a non-finite corner, or a
    /// corner beyond [`MAX_OCCLUDER_COORD`], are dropped.
    pub fn build(triangles: &[[Vec3; 3]]) -> FlatBvh {
        FlatBvh::build_tagged(triangles, &[])
    }

    /// [`FlatBvh::build`], each triangle carrying `tags[k]` (0 past the end) as bits in the w of
    /// its first vec4: the scene's triangles their material (`SceneMaterials::tag_of`).
    pub fn build_tagged(triangles: &[[Vec3; 3]], tags: &[u32]) -> FlatBvh {
        let (tris, tags): (Vec<[Vec3; 3]>, Vec<u32>) = triangles
            .iter()
            .enumerate()
            .filter(|(_, t)| t.iter().all(|p| p.is_finite() && p.abs().max_element() <= MAX_OCCLUDER_COORD))
            .map(|(k, t)| (*t, tags.get(k).copied().unwrap_or(0)))
            .unzip();
        let mut flat = FlatBvh::default();
        if tris.is_empty() {
            return flat;
        }
        let aabbs: Vec<Aabb> =
            tris.iter().map(|&[a, b, c]| Aabb::from_points(&[a.into(), b.into(), c.into()])).collect();
        // PLOC needs two primitives to make an interior root; one triangle is one leaf.
        let tree = (tris.len() > 1).then(|| {
            let mut params = BvhBuildParams::fast_build();
            params.max_prims_per_leaf = LEAF_TRIANGLES as u32;
            let mut core_build_time = Duration::ZERO;
            build_bvh2(&aabbs, params, &mut core_build_time)
        });
        let heights = tree.as_ref().map(|t| subtree_heights(&t.nodes)).unwrap_or_default();
        flat.nodes.push([0.0; 8]);
        let root = match &tree {
            Some(_) => Part::Tree(0),
            None => Part::Triangles(vec![0]),
        };
        // (flat node index, what goes there, its depth) still to place.
        let mut todo = vec![(0usize, root, 0u32)];
        while let Some((at, part, depth)) = todo.pop() {
            let part = match (part, &tree) {
                (Part::Tree(k), Some(t)) if depth >= OBVHS_DEPTH && heights[k] > MEDIAN_HEIGHT => {
                    Part::Triangles(subtree_primitives(t, k))
                }
                (part, _) => part,
            };
            let children = match part {
                Part::Tree(k) => {
                    let Some(t) = &tree else { continue };
                    let n = &t.nodes[k];
                    let (lo, hi) = (Vec3::from(n.aabb.min), Vec3::from(n.aabb.max));
                    if n.is_leaf() {
                        let (first, count) = (n.first_index as usize, n.prim_count as usize);
                        flat.nodes[at] =
                            flat.leaf(lo, hi, &tris, &tags, &t.primitive_indices[first..first + count]);
                        continue;
                    }
                    let first = n.first_index as usize;
                    flat.nodes[at] = node_of(lo, hi, flat.nodes.len() as u32, 0);
                    [Part::Tree(first), Part::Tree(first + 1)]
                }
                Part::Triangles(mut ids) => {
                    let (lo, hi, extent) = bounds(&tris, &ids);
                    if ids.len() <= LEAF_TRIANGLES || extent.max_element() <= 0.0 {
                        flat.nodes[at] = flat.leaf(lo, hi, &tris, &tags, &ids);
                        continue;
                    }
                    let axis = extent.max_position();
                    let half = ids.len() / 2;
                    ids.select_nth_unstable_by(half, |&a, &b| {
                        centroid(&tris[a as usize])[axis].total_cmp(&centroid(&tris[b as usize])[axis])
                    });
                    let right = ids.split_off(half);
                    flat.nodes[at] = node_of(lo, hi, flat.nodes.len() as u32, 0);
                    [Part::Triangles(ids), Part::Triangles(right)]
                }
            };
            let left = flat.nodes.len();
            flat.nodes.extend([[0.0; 8]; 2]);
            let [l, r] = children;
            todo.push((left + 1, r, depth + 1));
            todo.push((left, l, depth + 1));
        }
        flat
    }

    /// A leaf node over triangles `ids` of `tris`, appended to the triangle list.
    fn leaf(&mut self, lo: Vec3, hi: Vec3, tris: &[[Vec3; 3]], tags: &[u32], ids: &[u32]) -> [f32; 8] {
        let at = self.triangles.len() as u32;
        for &k in ids {
            let [a, b, c] = tris[k as usize];
            let (e1, e2) = (b - a, c - a);
            let tag = f32::from_bits(tags[k as usize]);
            self.triangles.push([a.x, a.y, a.z, tag, e1.x, e1.y, e1.z, 0.0, e2.x, e2.y, e2.z, 0.0]);
        }
        node_of(lo, hi, at, ids.len() as u32)
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
        // Many triangles at one place make a small hierarchy, without endless splitting.
        let same = vec![[Vec3::new(-1.0, -1.0, 1.0), Vec3::new(1.0, -1.0, 1.0), Vec3::new(0.0, 2.0, 1.0)]; 9];
        let bvh = FlatBvh::build(&same);
        assert_eq!(bvh.triangles.len(), 9);
        assert!(bvh.nodes.len() < 2 * 9);
        assert!(bvh.blocks(Vec3::ZERO, Vec3::Z, 0.0, 2.0));
        assert!(!bvh.blocks(Vec3::ZERO, Vec3::Z, 0.0, 0.5));
    }

    /// Thousands of triangles reaching to 1e30 (a hostile patch) made obvhs' build take minutes
    /// (its f32 surface areas overflow); they are dropped, and the rest still blocks as before.
    #[test]
    fn triangles_far_beyond_the_range_are_dropped_quickly() {
        let mut tris = scattered(200);
        for i in 0..20_000 {
            let x = i as f32 * 1e-3;
            tris.push([Vec3::new(x, 0.0, 1e30), Vec3::new(x, 1.0, 1e30), Vec3::new(x, 0.0, -1e30)]);
        }
        let bvh = FlatBvh::build(&tris);
        assert_eq!(bvh.triangles.len(), 200);
        let near = FlatBvh::build(&tris[..200]);
        assert_eq!(bvh, near);
    }

    /// Levels from the root to the deepest leaf.
    fn levels(bvh: &FlatBvh) -> u32 {
        let mut deepest = 0;
        let mut stack = vec![(0u32, 1u32)];
        while let Some((k, d)) = stack.pop() {
            let n = &bvh.nodes[k as usize];
            deepest = deepest.max(d);
            if n[7].to_bits() == 0 {
                let first = n[3].to_bits();
                stack.extend([(first, d + 1), (first + 1, d + 1)]);
            }
        }
        deepest
    }

    #[test]
    fn a_chain_of_ever_larger_gaps_still_fits_the_shaders_stack() {
        // Triangles in z = 0 along x, gaps and sizes growing by 17% each time (to about 5e11,
        // within MAX_OCCLUDER_COORD): an agglomerative builder pairs the nearest first and
        // makes a chain as deep as the input.
        let mut x = 0.0f32;
        let tris: Vec<[Vec3; 3]> = (0..160)
            .map(|i| {
                let size = 0.25 * 1.17f32.powi(i);
                x += 4.0 * size;
                [Vec3::new(x, 0.0, 0.0), Vec3::new(x + size, 0.0, 0.0), Vec3::new(x, size, 0.0)]
            })
            .collect();
        let mut params = BvhBuildParams::fast_build();
        params.max_prims_per_leaf = LEAF_TRIANGLES as u32;
        let raw = build_bvh2(
            &tris
                .iter()
                .map(|&[a, b, c]| Aabb::from_points(&[a.into(), b.into(), c.into()]))
                .collect::<Vec<_>>(),
            params,
            &mut Duration::default(),
        );
        assert!(subtree_heights(&raw.nodes)[0] >= 40, "obvhs alone makes a deep chain here");
        let bvh = FlatBvh::build(&tris);
        assert_eq!(bvh.triangles.len(), 160);
        // The shaders' stack holds 40 entries, one per level at most.
        assert!(levels(&bvh) < 40, "{} levels", levels(&bvh));
        // Every triangle is still found, by a ray along -z through its inside.
        for t in &tris {
            let size = t[1].x - t[0].x;
            let origin = t[0] + Vec3::new(0.2 * size, 0.2 * size, 1.0);
            assert!(bvh.blocks(origin, -Vec3::Z, 0.0, 2.0), "{t:?}");
            assert!(!bvh.blocks(origin - Vec3::new(size, 0.0, 0.0), -Vec3::Z, 0.0, 2.0), "{t:?}");
        }
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
