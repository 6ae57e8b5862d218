//! PRMan's hierarchical edits (`rib_parser::scene::HierarchicalEdit`) applied at the level
//! they name, as each uniform level is made: a `P` value set or added to the position the
//! subdivision rules computed, a vertex's or edge's sharpness set or raised, a face (and so all
//! its children) made a hole. The levels below then subdivide the edited level.
//!
//! A path's labels (PRMan's note, OpenSubdiv's `hedits`): the child labelled `n` of a face is
//! the one at the face's vertex labelled `n`. `subdivide` stores the child at stored corner `k`
//! of face `f` as face `face_start[f] + k`, its vertices as `[vertex point, next edge point,
//! face point, previous edge point]`. A child's vertex labels run in that same winding order and
//! start at its vertex point, which is labelled `n` when the parent is a quad and 0 otherwise;
//! so a face's labels are its stored corners turned by an offset.

use super::INFINITE_SHARPNESS;
use super::level::{Boundary, Level};
use super::rules::subdivide;
use glam::DVec3;
use rib_parser::scene::{
    EditOperator, HierarchicalEdit, SubdivisionMesh, decode_hierarchical_edits, is_hierarchical_edit,
};

/// A face of some level found from a path: its index there and the label of its stored
/// corner 0.
#[derive(Clone, Copy, Debug)]
struct Found {
    face: usize,
    offset: usize,
}

/// The edits of a mesh, each with the face its path names (found when the control level is
/// known).
pub(super) struct Edits {
    edits: Vec<(HierarchicalEdit, Found)>,
}

impl Edits {
    /// The edits of `sm`'s tags (the parser has warned about any it could not decode; those
    /// are left out here too), on the control level `control` whose faces are
    /// `face_of_input[f]` for the request's face `f` (`u32::MAX` for a dropped degenerate face).
    pub(super) fn new(sm: &SubdivisionMesh, control: &Level, face_of_input: &[u32]) -> Edits {
        let mut edits = Vec::new();
        for tag in sm.tags.iter().filter(|t| is_hierarchical_edit(&t.name)) {
            let Ok(decoded) = decode_hierarchical_edits(tag, &sm.vertices_per_face) else { continue };
            for edit in decoded {
                if let Some(found) = find(control, face_of_input, edit.path()) {
                    edits.push((edit, found));
                }
            }
        }
        Edits { edits }
    }

    /// The deepest level an edit acts on (0 without edits).
    pub(super) fn deepest(&self) -> u32 {
        self.edits.iter().map(|(e, _)| e.path().children.len() as u32).max().unwrap_or(0)
    }

    /// One Catmull-Clark step from level `number - 1`, then the edits of level `number`.
    pub(super) fn subdivide(&self, level: &Level, number: u32, boundary: Boundary) -> Level {
        let mut next = subdivide(level, boundary);
        self.apply(&mut next, number);
        next
    }

    /// Applies the edits of level `number` to `level`.
    pub(super) fn apply(&self, level: &mut Level, number: u32) {
        for (edit, found) in &self.edits {
            if edit.path().children.len() as u32 != number || found.face >= level.face_count() {
                continue;
            }
            let corners = level.face(found.face);
            let n = corners.len();
            // The stored corner of the label `label` of this face.
            let corner = |label: u32| corners.start + (label as usize + n - found.offset % n) % n;
            match edit {
                HierarchicalEdit::Position { vertex, operator, value, .. } => {
                    let v = level.face_verts[corner(*vertex)] as usize;
                    let value = DVec3::new(value[0] as f64, value[1] as f64, value[2] as f64);
                    if !value.is_finite() {
                        continue;
                    }
                    let p = &mut level.positions[v];
                    *p = match operator {
                        EditOperator::Set => value,
                        EditOperator::Add => *p + value,
                    };
                }
                HierarchicalEdit::VertexSharpness { vertex, operator, value, .. } => {
                    let v = level.face_verts[corner(*vertex)] as usize;
                    let s = &mut level.vertex_sharpness[v];
                    *s = edited_sharpness(*s, *operator, *value);
                }
                HierarchicalEdit::EdgeSharpness { edge, operator, value, .. } => {
                    let e = level.face_edges[corner(*edge)] as usize;
                    let s = &mut level.edges[e].sharpness;
                    *s = edited_sharpness(*s, *operator, *value);
                }
                HierarchicalEdit::Hole { .. } => level.face_hidden[found.face] = true,
            }
        }
    }
}

/// A sharpness after an edit: RenderMan's scale (10 and above is infinitely sharp, below 0 is
/// smooth).
fn edited_sharpness(current: f64, operator: EditOperator, value: f32) -> f64 {
    let value = value as f64;
    if !value.is_finite() {
        return current;
    }
    let s = match operator {
        EditOperator::Set => value,
        EditOperator::Add => current + value,
    };
    if s >= INFINITE_SHARPNESS { f64::INFINITY } else { s.max(0.0) }
}

/// The face `path` names, walked from the control level: at level 0 its stored corners are its
/// labels; below, every face is a quad stored from its vertex point (see the module docs).
fn find(control: &Level, face_of_input: &[u32], path: &rib_parser::scene::EditPath) -> Option<Found> {
    let face = *face_of_input.get(path.face as usize)?;
    if face as usize >= control.face_count() {
        return None;
    }
    let (mut face, mut start, mut sides, mut offset) = (
        face as usize,
        control.face_start[face as usize] as usize,
        control.face(face as usize).len(),
        0usize,
    );
    for &child in &path.children {
        let child = child as usize;
        if child >= sides {
            return None;
        }
        let corner = (child + sides - offset % sides) % sides;
        face = start + corner;
        offset = if sides == 4 { child } else { 0 };
        sides = 4;
        start = 4 * face;
    }
    Some(Found { face, offset })
}
