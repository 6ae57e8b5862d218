//! Constructive solid geometry (`SolidBegin "union" | "intersection" | "difference" |
//! "primitive"`), exact in the ray tracer.
//!
//! Each outermost world solid block becomes a BLAS of its own with a [`Csg`] tree (the tree
//! and its boolean evaluation are `rib_parser::csg`, shared with the haptics). The tree's
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
use rib_parser::csg::CsgTree;
use rib_parser::scene::Scene;

/// Crossings gathered per ray before the rest are dropped (a hostile solid of millions of
/// coplanar layers cannot make one ray allocate without bound).
const MAX_CROSSINGS: usize = 1 << 16;

/// The solid tree of one BLAS (rib-parser's reading of the block) and which leaf each BLAS
/// shape belongs to.
#[derive(Clone, Debug, PartialEq)]
pub(super) struct Csg {
    tree: CsgTree,
    /// The leaf (primitive solid) of each BLAS shape, by BLAS shape index.
    pub(super) leaf_of_shape: Vec<u32>,
}

/// An outermost solid of the scene: its tree, and which leaf each of its scene shapes
/// belongs to (scene shape index, leaf), in the order of the file.
pub(super) struct SolidPlan {
    pub(super) csg: Csg,
    pub(super) shapes: Vec<(u32, u32)>,
}

impl Csg {
    /// One plan per outermost world solid block that holds any shape.
    pub(super) fn plans(scene: &Scene) -> Vec<SolidPlan> {
        CsgTree::outermost(scene)
            .into_iter()
            .map(|tree| SolidPlan {
                shapes: tree.shapes().to_vec(),
                csg: Csg { tree, leaf_of_shape: Vec::new() },
            })
            .collect()
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
    let leaves = csg.tree.leaf_count();
    crossings.retain(|c| (c.1 as usize) < leaves);
    crossings.sort_by(|a, b| a.0.total_cmp(&b.0));
    // The origin is inside a leaf that the ray leaves more often than it enters.
    let mut inside = vec![false; leaves];
    for c in &crossings {
        inside[c.1 as usize] ^= true;
    }
    let mut state = csg.tree.inside(&inside);
    for (t, l, detail) in crossings {
        if t >= t_max {
            break;
        }
        inside[l as usize] ^= true;
        let after = csg.tree.inside(&inside);
        if after != state && t > t_min {
            return Some((t, detail, after));
        }
        state = after;
    }
    None
}
