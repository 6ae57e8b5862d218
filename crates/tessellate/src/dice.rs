//! Dicing a triangle mesh into micropolygons for displacement: every edge longer than the
//! dicing rule allows where it lies is halved, pass after pass, until none is.
//!
//! The decision to split is taken per edge (its length against the rule at its midpoint), and
//! a split edge's midpoint is computed from its two end points alone, symmetrically, so two
//! triangles that share an edge (by index or only by position, across a seam of duplicated
//! vertices) split it alike: the diced mesh has no T-junctions. Each triangle is cut by one of
//! the red-green templates (one, two or three of its edges halved), which keep its winding.

use glam::{DVec3, Vec2};
use std::collections::HashMap;

/// How long a micropolygon's edge may be, in the units of the space the mesh is placed in.
#[derive(Clone, Copy, Debug, PartialEq)]
pub enum DicingRule {
    /// A perspective camera at `eye`: `sqrt(shading_rate)` pixels of `radians_per_pixel` at the
    /// edge's distance from the eye (RenderMan's shading rate is a micropolygon's area in
    /// pixels).
    Perspective { eye: DVec3, radians_per_pixel: f64, shading_rate: f64 },
    /// An orthographic camera: `sqrt(shading_rate)` pixels of `pixel` units each.
    Orthographic { pixel: f64, shading_rate: f64 },
    /// No camera: this fraction of the mesh's bounding-box diagonal.
    RelativeToSize(f64),
}

impl DicingRule {
    /// The longest edge allowed at `midpoint`, at least `floor`.
    fn edge_at(&self, midpoint: DVec3, floor: f64, size: f64) -> f64 {
        let edge = match *self {
            DicingRule::Perspective { eye, radians_per_pixel, shading_rate } => {
                shading_rate.sqrt() * radians_per_pixel * (midpoint - eye).length()
            }
            DicingRule::Orthographic { pixel, shading_rate } => shading_rate.sqrt() * pixel,
            DicingRule::RelativeToSize(fraction) => fraction * size,
        };
        // NaN (a hostile rule) dices as coarsely as the floor allows, never finer.
        if edge.is_nan() { f64::INFINITY } else { edge.max(floor) }
    }
}

/// A mesh being diced, in `f64`: positions, smooth normals (the direction each vertex is
/// displaced along), texture coordinates.
pub(crate) struct DiceMesh {
    pub positions: Vec<DVec3>,
    pub normals: Vec<DVec3>,
    pub st: Vec<Vec2>,
    pub indices: Vec<[u32; 3]>,
    pub face_index: Vec<u32>,
}

/// What dicing did.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct DiceReport {
    /// Triangles before dicing.
    pub base_triangles: usize,
    /// Triangles after.
    pub triangles: usize,
    /// `Some(factor)` when the budget stopped the dicing before every edge met the rule: the
    /// longest remaining edge divided by what the rule asks for there.
    pub coarsened_by: Option<f64>,
}

/// Halves edges until each is within `rule` at its midpoint, or until the next pass would
/// exceed `max_triangles`. `floor` is the shortest edge ever asked for (the `f32` resolution
/// of the shape), `size` the mesh's bounding-box diagonal.
pub(crate) fn dice(
    mesh: &mut DiceMesh,
    rule: &DicingRule,
    floor: f64,
    size: f64,
    max_triangles: u64,
) -> DiceReport {
    let base_triangles = mesh.indices.len();
    let too_long = |m: &DiceMesh, a: u32, b: u32| -> Option<f64> {
        let (pa, pb) = (m.positions[a as usize], m.positions[b as usize]);
        let length = (pa - pb).length();
        let allowed = rule.edge_at(0.5 * (pa + pb), floor, size);
        (length > allowed).then_some(length / allowed)
    };
    // Each pass at least halves every edge it splits; 64 passes reach any f64 ratio.
    for _ in 0..64 {
        // Midpoint vertex of every edge to split, keyed by its end positions (so duplicated
        // seam vertices find the same split), and how many triangles the pass makes.
        let mut split: HashMap<EdgeKey, u32> = HashMap::new();
        let mut marks = Vec::with_capacity(mesh.indices.len());
        let mut after: u64 = 0;
        for tri in &mesh.indices {
            let mut mark = [false; 3];
            for k in 0..3 {
                let (a, b) = (tri[k], tri[(k + 1) % 3]);
                mark[k] = too_long(mesh, a, b).is_some();
            }
            after += 1 + mark.iter().filter(|&&m| m).count() as u64;
            marks.push(mark);
        }
        if after == mesh.indices.len() as u64 {
            return DiceReport { base_triangles, triangles: mesh.indices.len(), coarsened_by: None };
        }
        if after > max_triangles {
            let worst = mesh
                .indices
                .iter()
                .flat_map(|t| (0..3).map(move |k| (t[k], t[(k + 1) % 3])))
                .filter_map(|(a, b)| too_long(mesh, a, b))
                .fold(1.0f64, f64::max);
            return DiceReport { base_triangles, triangles: mesh.indices.len(), coarsened_by: Some(worst) };
        }
        let old_indices = std::mem::take(&mut mesh.indices);
        let old_faces = std::mem::take(&mut mesh.face_index);
        for ((tri, mark), face) in old_indices.iter().zip(&marks).zip(old_faces) {
            let mut mid = [u32::MAX; 3];
            for k in 0..3 {
                if mark[k] {
                    mid[k] = midpoint(mesh, &mut split, tri[k], tri[(k + 1) % 3]);
                }
            }
            for t in cut(*tri, mid, &mesh.positions) {
                mesh.indices.push(t);
                mesh.face_index.push(face);
            }
        }
    }
    DiceReport { base_triangles, triangles: mesh.indices.len(), coarsened_by: None }
}

/// [`dice`] for the keys of a deforming mesh (the same triangles, each key its own vertices):
/// an edge is halved when it is too long at any key, so every key gets the same triangles;
/// the budget counts the triangles of one key.
pub(crate) fn dice_keys(
    keys: &mut [DiceMesh],
    rule: &DicingRule,
    floor: f64,
    size: f64,
    max_triangles: u64,
) -> DiceReport {
    let base_triangles = keys.first().map_or(0, |k| k.indices.len());
    let too_long = |keys: &[DiceMesh], a: u32, b: u32| -> Option<f64> {
        keys.iter()
            .filter_map(|m| {
                let (pa, pb) = (m.positions[a as usize], m.positions[b as usize]);
                let ratio = (pa - pb).length() / rule.edge_at(0.5 * (pa + pb), floor, size);
                (ratio > 1.0).then_some(ratio)
            })
            .reduce(f64::max)
    };
    let Some(first) = keys.first() else {
        return DiceReport { base_triangles, triangles: 0, coarsened_by: None };
    };
    let mut indices = first.indices.clone();
    let mut faces = first.face_index.clone();
    for _ in 0..64 {
        let marks: Vec<[bool; 3]> = indices
            .iter()
            .map(|t| std::array::from_fn(|k| too_long(keys, t[k], t[(k + 1) % 3]).is_some()))
            .collect();
        let after: u64 = marks.iter().map(|m| 1 + m.iter().filter(|&&x| x).count() as u64).sum();
        if after == indices.len() as u64 {
            break;
        }
        if after > max_triangles {
            let worst = indices
                .iter()
                .flat_map(|t| (0..3).map(move |k| (t[k], t[(k + 1) % 3])))
                .filter_map(|(a, b)| too_long(keys, a, b))
                .fold(1.0f64, f64::max);
            for key in keys.iter_mut() {
                (key.indices, key.face_index) = (indices.clone(), faces.clone());
            }
            return DiceReport { base_triangles, triangles: indices.len(), coarsened_by: Some(worst) };
        }
        // Midpoints keyed by the edge's vertex indices, the same in every key.
        let mut split: HashMap<(u32, u32), u32> = HashMap::new();
        let (old_indices, old_faces) = (std::mem::take(&mut indices), std::mem::take(&mut faces));
        for ((tri, mark), face) in old_indices.iter().zip(&marks).zip(old_faces) {
            let mut mid = [u32::MAX; 3];
            for k in 0..3 {
                if mark[k] {
                    let (a, b) = (tri[k], tri[(k + 1) % 3]);
                    let key = (a.min(b), a.max(b));
                    mid[k] = *split.entry(key).or_insert_with(|| {
                        for m in keys.iter_mut() {
                            let (ia, ib) = (a as usize, b as usize);
                            m.positions.push(0.5 * (m.positions[ia] + m.positions[ib]));
                            m.normals.push((m.normals[ia] + m.normals[ib]).normalize_or_zero());
                            m.st.push(0.5 * (m.st[ia] + m.st[ib]));
                        }
                        keys[0].positions.len() as u32 - 1
                    });
                }
            }
            for t in cut(*tri, mid, &keys[0].positions) {
                indices.push(t);
                faces.push(face);
            }
        }
    }
    let triangles = indices.len();
    for key in keys.iter_mut() {
        (key.indices, key.face_index) = (indices.clone(), faces.clone());
    }
    DiceReport { base_triangles, triangles, coarsened_by: None }
}

/// An edge by its end positions' bits, in a fixed order.
type EdgeKey = ([u64; 3], [u64; 3]);

fn bits(p: DVec3) -> [u64; 3] {
    [p.x.to_bits(), p.y.to_bits(), p.z.to_bits()]
}

/// The vertex halving edge `(a, b)`: made once per pair of end positions.
fn midpoint(mesh: &mut DiceMesh, split: &mut HashMap<EdgeKey, u32>, a: u32, b: u32) -> u32 {
    let (ka, kb) = (bits(mesh.positions[a as usize]), bits(mesh.positions[b as usize]));
    let key = if ka <= kb { (ka, kb) } else { (kb, ka) };
    // Index-keyed attributes (normals, st) may differ across a seam of duplicated vertices;
    // the first triangle to split the edge decides them, the position is the same either way.
    *split.entry(key).or_insert_with(|| {
        let (ia, ib) = (a as usize, b as usize);
        let position = 0.5 * (mesh.positions[ia] + mesh.positions[ib]);
        let normal = (mesh.normals[ia] + mesh.normals[ib]).normalize_or_zero();
        let st = 0.5 * (mesh.st[ia] + mesh.st[ib]);
        mesh.positions.push(position);
        mesh.normals.push(normal);
        mesh.st.push(st);
        mesh.positions.len() as u32 - 1
    })
}

/// Cuts triangle `tri` at the midpoints `mid[k]` of its edges `k` (from corner `k` to
/// `k + 1`; `u32::MAX` where the edge is kept), keeping the winding.
fn cut(tri: [u32; 3], mid: [u32; 3], positions: &[DVec3]) -> Vec<[u32; 3]> {
    let split = mid.iter().filter(|&&m| m != u32::MAX).count();
    match split {
        0 => vec![tri],
        3 => vec![
            [tri[0], mid[0], mid[2]],
            [mid[0], tri[1], mid[1]],
            [mid[2], mid[1], tri[2]],
            [mid[0], mid[1], mid[2]],
        ],
        1 => {
            // Rotate so that edge 0 (a -> b) is the split one.
            let k = mid.iter().position(|&m| m != u32::MAX).unwrap_or(0);
            let (a, b, c) = (tri[k], tri[(k + 1) % 3], tri[(k + 2) % 3]);
            vec![[a, mid[k], c], [mid[k], b, c]]
        }
        _ => {
            // Rotate so that edge 2 (c -> a) is the kept one: edges 0 and 1 are split.
            let kept = mid.iter().position(|&m| m == u32::MAX).unwrap_or(2);
            let k = (kept + 1) % 3;
            let (a, b, c) = (tri[k], tri[(k + 1) % 3], tri[(k + 2) % 3]);
            let (m0, m1) = (mid[k], mid[(k + 1) % 3]);
            // The corner triangle at b, and the quad a-m0-m1-c cut along its shorter diagonal.
            let p = |i: u32| positions[i as usize];
            let mut out = vec![[m0, b, m1]];
            if (p(a) - p(m1)).length_squared() <= (p(m0) - p(c)).length_squared() {
                out.extend([[a, m0, m1], [a, m1, c]]);
            } else {
                out.extend([[a, m0, c], [m0, m1, c]]);
            }
            out
        }
    }
}
