//! `SubdivisionMesh "catmull-clark"`: arbitrary polygons, boundaries, the tags
//! `interpolateboundary`, `crease`, `corner` and `hole`, and PRMan's hierarchical edits
//! (`edits.rs`), applied to the uniform level they name as it is made.
//!
//! Rules (DeRose, Kass and Truong, "Subdivision surfaces in character animation", 1998, as
//! OpenSubdiv implements them with its default uniform sharpness decrement):
//! - Face points are face centroids; smooth edge points average the edge's ends and the two
//!   face points; edges with sharpness >= 1, boundary and non-manifold edges take the midpoint;
//!   sharpness in (0, 1) blends the two.
//! - A vertex with no or one sharp edge takes the smooth rule `(F + 2R + (n - 3) v) / n`, with
//!   two the crease rule `(a + 6v + b) / 8`, with three or more (or a sharp vertex) stays put.
//!   When the rule changes between a level and the next because sharpness runs out, the two
//!   rules are blended by the fractional sharpness of the edges that run out.
//! - Every level lowers every sharpness by one; `sharpness >= 10` is infinite.
//! - Without `interpolateboundary` the faces around boundary vertices are not drawn (as in
//!   RenderMan and OpenSubdiv's "boundary none"); with it, boundary edges are sharp creases and
//!   (for `interpolateboundary [1]`, the default) corners with one face are sharp vertices.
//! - `hole` faces (and their children) are subdivided but not drawn.
//!
//! The level comes from the tolerance, measured: a level's deviation is the distance of the
//! next level's edge and face points, pushed to the limit surface, from the level's flat
//! triangles (times 4/3, the most a quadratic error inside a triangle exceeds its
//! edge-midpoint values). Uniform levels are built until the regular faces (those away from
//! extraordinary vertices, darts and sharp corners) meet the tolerance or at most a tenth of
//! all faces miss it; once the regular faces' decay is steady and near-quadratic the remaining
//! uniform levels are predicted instead of measured, and semi-sharp creases are given levels
//! enough to run out where affordable. Then the faces that still miss the tolerance (or, after
//! a prediction, the faces around special vertices, where Catmull-Clark converges slowly) are
//! refined on their own, one level at a time, each time with the one-ring their limit depends
//! on, until they meet it; a drawn face next to refined ones is fanned from its centre through
//! the vertices they add on the shared edge, so closed meshes stay closed. Faces at sharp
//! corners (cone points, where refinement converges only linearly) take no part in the
//! measure. The drawn vertices are on the limit surface: the smooth limit stencil
//! `(n^2 v + 4 sum e + sum f) / (n (n + 5))` with the exact limit normal from Halstead et
//! al.'s tangent stencils at smooth vertices, the cubic B-spline limit `(a + 4v + b) / 6` on
//! creases, the vertex itself at corners; normals elsewhere are averaged from the limit
//! faces. Edges still semi-sharp at the drawn level are taken as sharp there.
//!
//! `st` of any class is carried per face corner and interpolated bilinearly (face-varying
//! linear); vertices are split only where the values differ.
//!
//! Layout: `level.rs` (the face, edge and vertex tables of one level and the checked
//! control mesh with its tags), `rules.rs` (one Catmull-Clark step with creases and corners),
//! `limit.rs` (limit positions and normals, special vertices, the per-face deviation measure),
//! `adaptive.rs` (the one-ring sub-meshes and the refinement of the faces that miss the
//! tolerance), `emit.rs` (the drawn triangles and their shared output vertices), `edits.rs`
//! (hierarchical edits).

mod adaptive;
mod edits;
mod emit;
mod level;
mod limit;
mod rules;

use super::{TessellateError, Tolerance, TriangleMesh, check_budget, diagonal_of};
use adaptive::{Node, refine};
use edits::Edits;
use emit::emit;
use level::control_level;
use limit::{face_deviations, limit, special_vertices};
use rib_parser::scene::SubdivisionMesh;
use rules::{Rule, rules};
use std::collections::HashMap;

const KIND: &str = "SubdivisionMesh";
/// OpenSubdiv's infinite sharpness.
const INFINITE_SHARPNESS: f64 = 10.0;
const MAX_LEVEL: u32 = 12;

fn invalid(reason: String) -> TessellateError {
    TessellateError::InvalidShape { kind: KIND, reason }
}

pub(crate) fn tessellate_subdivision(
    sm: &SubdivisionMesh,
    tol: &Tolerance,
    scale: f64,
) -> Result<TriangleMesh, TessellateError> {
    tessellate_subdivision_planned(sm, tol, scale, &mut Planning::Free)
}

/// How the position-dependent choices of a tessellation (levels, refined faces, quad
/// diagonals) are made: from the mesh's own positions, recorded as well, or replayed from
/// another key of a deforming mesh so that every key gives the same triangles.
pub(crate) enum Planning {
    Free,
    Record(SubdivPlan),
    Replay(SubdivPlan),
}

/// The choices one key's positions led to (see [`Planning`]).
#[derive(Clone, Debug, Default, PartialEq)]
pub(crate) struct SubdivPlan {
    /// The uniform level drawn.
    level: u32,
    /// Faces of that level refined on their own.
    candidates: Vec<usize>,
    /// At each adaptive step, which of its candidates were refined.
    refined: Vec<Vec<bool>>,
    /// For every quad drawn, in order: split along its 1-3 diagonal (else 0-2).
    diagonals: Vec<bool>,
}

/// [`tessellate_subdivision`] with its choices made as `planning` says. Recorded and replayed
/// meshes keep their zero-area triangles (a key may give them area).
pub(crate) fn tessellate_subdivision_planned(
    sm: &SubdivisionMesh,
    tol: &Tolerance,
    scale: f64,
    planning: &mut Planning,
) -> Result<TriangleMesh, TessellateError> {
    let (mut control, boundary, degenerate, face_of_input) = control_level(sm)?;
    // Hierarchical edits act on the uniform levels as they are made (`edits.rs`).
    let edits = Edits::new(sm, &control, &face_of_input);
    edits.apply(&mut control, 0);
    let size = diagonal_of(KIND, control.positions.iter().copied())?;
    let eps = tol.effective(size, scale)?;
    if control.face_count() == 0 {
        return Ok(TriangleMesh { degenerate_faces: degenerate, ..Default::default() });
    }
    // Triangles of level k: 2 * corners * 4^(k - 1).
    let corners = control.face_verts.len() as f64;
    let triangles_at = |k: u32| 2.0 * corners * 4f64.powi(k as i32 - 1);
    check_budget(KIND, triangles_at(1), tol)?;
    let cap = tol.max_triangles as f64;

    // Semi-sharp creases should have run out by the drawn level (then its limit positions are
    // exact), where that is affordable.
    let finite_sharpness = control
        .edges
        .iter()
        .map(|e| e.sharpness)
        .chain(control.vertex_sharpness.iter().copied())
        .filter(|s| s.is_finite())
        .fold(0.0f64, f64::max);
    // Hierarchical edits need the uniform levels down to the deepest they act on.
    let mut min_level = (finite_sharpness.ceil() as u32).max(edits.deepest()).clamp(1, MAX_LEVEL);
    while min_level > 1 && triangles_at(min_level) > cap {
        min_level -= 1;
    }

    // Uniform levels first. A level is measured with the next one; it is drawn once its
    // regular faces (away from special vertices) meet the tolerance, or once at most a tenth
    // of its faces miss it (those are then refined on their own). Once two successive decay
    // rates of the regular faces agree and are near-quadratic, the remaining levels are
    // predicted instead of built only to be measured.
    let mut current = edits.subdivide(&control, 1, boundary);
    let mut current_limit = limit(&current, boundary);
    let mut k = 1u32;
    let mut measured: Vec<f64> = Vec::new();
    if let Planning::Replay(plan) = planning {
        check_budget(KIND, triangles_at(plan.level), tol)?;
        while k < plan.level.min(MAX_LEVEL) {
            current = edits.subdivide(&current, k + 1, boundary);
            k += 1;
        }
        current_limit = limit(&current, boundary);
    }
    // The drawn level, its number, its limit, and the faces to refine further (None: those
    // around special vertices).
    let drawn = loop {
        if let Planning::Replay(plan) = planning {
            break (current, k, current_limit, Some(plan.candidates.clone()));
        }
        // Measuring needs the next level; it is only built while it is affordable.
        if k >= MAX_LEVEL || triangles_at(k + 1) > 4.0 * cap {
            break (current, k, current_limit, None);
        }
        let stable = match measured[..] {
            [.., a, b, c] if b > 0.0 && c > 0.0 => ((a / b) / (b / c) - 1.0).abs() < 0.15 && b / c >= 3.0,
            _ => false,
        };
        if let ([.., before, last], true) = (&measured[..], stable) {
            let (before, last) = (*before, *last);
            let ratio = (before / last).clamp(2.0, 4.0);
            let (mut predicted, mut level) = (last / ratio, k);
            while (predicted > eps || level < min_level) && level < MAX_LEVEL {
                predicted /= ratio;
                level += 1;
            }
            check_budget(KIND, triangles_at(level), tol)?;
            if level > k {
                while k < level {
                    current = edits.subdivide(&current, k + 1, boundary);
                    k += 1;
                }
                current_limit = limit(&current, boundary);
            }
            break (current, k, current_limit, None);
        }
        let next = edits.subdivide(&current, k + 1, boundary);
        let next_limit = limit(&next, boundary);
        let special = special_vertices(&current, boundary);
        let deviations = face_deviations(&current, &current_limit.0, &next_limit.0);
        if deviations.iter().any(|d| !d.is_finite()) {
            return Err(TessellateError::NonFinite { kind: KIND, reason: "subdivision diverged".into() });
        }
        let visible: Vec<usize> = (0..current.face_count()).filter(|&f| !current.face_hidden[f]).collect();
        let regular: Vec<usize> = visible
            .iter()
            .copied()
            .filter(|&f| !current.face(f).any(|c| special[current.face_verts[c] as usize]))
            .collect();
        let d = regular.iter().map(|&f| deviations[f]).fold(0.0f64, f64::max);
        let rule = rules(&current, boundary);
        let at_corner =
            |f: usize| current.face(f).any(|c| rule[current.face_verts[c] as usize] == Rule::Corner);
        let bad: Vec<usize> =
            visible.iter().copied().filter(|&f| deviations[f] > eps && !at_corner(f)).collect();
        if k >= min_level && (bad.is_empty() || (!regular.is_empty() && bad.len() * 10 <= visible.len())) {
            break (current, k, current_limit, Some(bad));
        }
        // A level with no regular face yet says nothing about the decay.
        if !regular.is_empty() {
            measured.push(d);
        }
        if measured.len() == 1 && d / 4.0 <= eps && k + 1 >= min_level {
            check_budget(KIND, triangles_at(k + 1), tol)?;
            break (next, k + 1, next_limit, None);
        }
        current = next;
        current_limit = next_limit;
        k += 1;
    };
    let (level, level_number, level_limit, known_bad) = drawn;
    check_budget(KIND, 2.0 * level.face_count() as f64, tol)?;

    // Faces around special vertices: refined on their own, level by level, until they meet
    // the tolerance too.
    let candidates: Vec<usize> = known_bad.unwrap_or_else(|| {
        let special = special_vertices(&level, boundary);
        (0..level.face_count())
            .filter(|&f| {
                !level.face_hidden[f] && level.face(f).any(|c| special[level.face_verts[c] as usize])
            })
            .collect()
    });
    if candidates.iter().any(|&f| f >= level.face_count()) {
        return Err(invalid("its keys refine different faces".into()));
    }
    if let Planning::Record(plan) = planning {
        (plan.level, plan.candidates) = (level_number, candidates.clone());
    }
    let drawn: Vec<usize> = (0..level.face_count()).filter(|&f| !level.face_hidden[f]).collect();
    let mut nodes = vec![Node { level, limit: level_limit, parent: None, drawn, split: HashMap::new() }];
    refine(&mut nodes, 0, candidates, (eps, boundary, tol), planning)?;
    let mesh = emit(&nodes, degenerate, planning)?;
    check_budget(KIND, mesh.triangle_count() as f64, tol)?;
    Ok(mesh)
}
