//! The hierarchical edits of PRMan's `HierarchicalSubdivisionMesh` (tags `vertexedit`,
//! `edgeedit`, `faceedit`), decoded from their tag arguments.
//!
//! PRMan's application note "Hierarchical Subdivision Surfaces" (2004) names a face of any
//! level by a path: a face of the control mesh, then at each level the child face incident to
//! the parent's vertex with that label (a face's vertices are labelled from 0 in winding order;
//! edges by their origin vertex). A vertex or edge path ends with the label of the vertex or
//! edge in the face it names. The integer arguments hold one path after another, each as its
//! length followed by its entries; the float arguments hold each path's value in turn; the
//! string arguments say what is edited: a primitive variable's name with `"value"` or
//! `"sharpness"` and the operator `"set"` or `"add"` (in either order: PRMan's note writes
//! `"P" "value" "add"`, OpenSubdiv's test shapes `add P value`), or `"hole"` for a face.

use super::SubdivisionTag;

/// How an edit combines with the value subdivision computes.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum EditOperator {
    Set,
    Add,
}

/// A face of some level: a control face and the child labels that lead from it.
#[derive(Clone, Debug, PartialEq, Eq)]
pub struct EditPath {
    /// The control face (its index in the request's faces).
    pub face: u32,
    /// One child label per level below the control mesh: the edit acts on level `children.len()`.
    pub children: Vec<u32>,
}

/// One decoded hierarchical edit.
#[derive(Clone, Debug, PartialEq)]
pub enum HierarchicalEdit {
    /// `vertexedit` of `"P"` `"value"`: the vertex labelled `vertex` in the face `path` names.
    Position { path: EditPath, vertex: u32, operator: EditOperator, value: [f32; 3] },
    /// `vertexedit` `"sharpness"`: the vertex's corner sharpness.
    VertexSharpness { path: EditPath, vertex: u32, operator: EditOperator, value: f32 },
    /// `edgeedit` `"sharpness"`: the sharpness of the edge from the vertex labelled `edge`.
    EdgeSharpness { path: EditPath, edge: u32, operator: EditOperator, value: f32 },
    /// `faceedit` `"hole"`: the face and all its children are not drawn.
    Hole { path: EditPath },
}

impl HierarchicalEdit {
    pub fn path(&self) -> &EditPath {
        match self {
            HierarchicalEdit::Position { path, .. }
            | HierarchicalEdit::VertexSharpness { path, .. }
            | HierarchicalEdit::EdgeSharpness { path, .. }
            | HierarchicalEdit::Hole { path } => path,
        }
    }
}

/// Whether `name` is one of the hierarchical edit tags.
pub fn is_hierarchical_edit(name: &str) -> bool {
    matches!(name, "vertexedit" | "edgeedit" | "faceedit")
}

/// Decodes one edit tag of a mesh whose control faces have `vertices_per_face` vertices.
/// Paths are checked against the faces they walk (a control face's vertex count at level 0,
/// four below: every child of a Catmull-Clark face is a quad). Floats beyond the paths' values
/// are ignored (OpenSubdiv's own test shapes give twice as many). The error says what is
/// unsupported or malformed.
pub fn decode_hierarchical_edits(
    tag: &SubdivisionTag,
    vertices_per_face: &[u32],
) -> Result<Vec<HierarchicalEdit>, String> {
    let words: Vec<&str> = tag.string_args.iter().map(String::as_str).collect();
    let operator = match (words.contains(&"set"), words.contains(&"add")) {
        (true, false) => Some(EditOperator::Set),
        (false, true) => Some(EditOperator::Add),
        (true, true) => return Err("it names both \"set\" and \"add\"".into()),
        (false, false) => None,
    };
    let operation = ["value", "sharpness", "hole", "attributes"].into_iter().find(|w| words.contains(w));
    let variable =
        words.iter().find(|w| !matches!(**w, "set" | "add" | "value" | "sharpness" | "hole" | "attributes"));
    // What is edited, and how many floats each path takes.
    #[derive(Clone, Copy, PartialEq)]
    enum What {
        Position,
        VertexSharpness,
        EdgeSharpness,
        Hole,
    }
    let what = match (tag.name.as_str(), operation) {
        ("vertexedit", Some("value")) => match variable {
            Some(&"P") => What::Position,
            Some(other) => {
                return Err(format!(
                    "a value edit of \"{other}\" (only \"P\" changes the surface, and the other primitive variables of a subdivision mesh are not carried through its levels)"
                ));
            }
            None => return Err("a value edit that names no primitive variable".into()),
        },
        ("vertexedit", Some("sharpness")) => What::VertexSharpness,
        ("edgeedit", Some("sharpness")) => What::EdgeSharpness,
        ("faceedit", Some("hole")) => What::Hole,
        ("faceedit", Some("attributes")) => {
            return Err(
                "an \"attributes\" edit (attributes per refined face; a shape has one attribute state)"
                    .into(),
            );
        }
        ("faceedit", Some("value")) => {
            return Err(
                "a value edit of a face (uniform primitive variables are not carried through the levels)"
                    .into(),
            );
        }
        (name, operation) => {
            return Err(format!(
                "\"{name}\" with {} is not an edit PRMan documents",
                match operation {
                    Some(op) => format!("\"{op}\""),
                    None => "no operation".to_string(),
                }
            ));
        }
    };
    let operator = match (what, operator) {
        (What::Hole, _) => EditOperator::Set,
        (_, Some(op)) => op,
        (_, None) => return Err("it names neither \"set\" nor \"add\"".into()),
    };
    let width = match what {
        What::Position => 3,
        What::VertexSharpness | What::EdgeSharpness => 1,
        What::Hole => 0,
    };
    let mut edits = Vec::new();
    let mut i = 0usize;
    while i < tag.int_args.len() {
        let length = usize::try_from(tag.int_args[i])
            .map_err(|_| format!("path length {} is negative", tag.int_args[i]))?;
        let entries = tag.int_args.get(i + 1..i + 1 + length).ok_or_else(|| {
            format!("a path of length {length} runs past the {} integer arguments", tag.int_args.len())
        })?;
        i += 1 + length;
        let entries: Vec<u32> = entries
            .iter()
            .map(|&e| u32::try_from(e).map_err(|_| format!("path entry {e} is negative")))
            .collect::<Result<_, _>>()?;
        let faces_in_path = if what == What::Hole { entries.len() } else { entries.len().saturating_sub(1) };
        if faces_in_path == 0 {
            return Err(format!("a path of length {length} names no face"));
        }
        let face = entries[0];
        let mut sides = *vertices_per_face
            .get(face as usize)
            .ok_or_else(|| format!("face {face} is out of range ({} faces)", vertices_per_face.len()))?;
        for &child in &entries[1..faces_in_path] {
            if child >= sides {
                return Err(format!("child {child} of a face with {sides} vertices"));
            }
            sides = 4;
        }
        let path = EditPath { face, children: entries[1..faces_in_path].to_vec() };
        let last = entries.last().copied().unwrap_or(0);
        if what != What::Hole && last >= sides {
            return Err(format!("vertex or edge {last} of a face with {sides} vertices"));
        }
        let k = edits.len() * width;
        let floats = tag.float_args.get(k..k + width).ok_or_else(|| {
            format!(
                "{} values are needed for its paths, {} are given",
                (edits.len() + 1) * width,
                tag.float_args.len()
            )
        })?;
        edits.push(match what {
            What::Position => HierarchicalEdit::Position {
                path,
                vertex: last,
                operator,
                value: [floats[0], floats[1], floats[2]],
            },
            What::VertexSharpness => {
                HierarchicalEdit::VertexSharpness { path, vertex: last, operator, value: floats[0] }
            }
            What::EdgeSharpness => {
                HierarchicalEdit::EdgeSharpness { path, edge: last, operator, value: floats[0] }
            }
            What::Hole => HierarchicalEdit::Hole { path },
        });
    }
    Ok(edits)
}

#[cfg(test)]
mod tests {
    use super::*;

    fn tag(name: &str, ints: &[i32], floats: &[f32], strings: &[&str]) -> SubdivisionTag {
        SubdivisionTag {
            name: name.into(),
            int_args: ints.to_vec(),
            float_args: floats.to_vec(),
            string_args: strings.iter().map(|s| s.to_string()).collect(),
        }
    }

    #[test]
    fn opensubdivs_test_shape_decodes() {
        // catmark_square_hedit4: four vertex edits at level 2 of face 4, and a hole at level 2.
        let faces = [4u32; 9];
        let t = tag(
            "vertexedit",
            &[4, 4, 1, 1, 0, 4, 4, 1, 1, 1, 4, 4, 1, 1, 2, 4, 4, 1, 1, 3],
            &[0.0, 0.0, 1.0, 0.0, 0.0, 1.0, 0.0, 0.0, 1.0, 0.0, 0.0, 1.0],
            &["add", "P", "value"],
        );
        let edits = decode_hierarchical_edits(&t, &faces).unwrap();
        assert_eq!(edits.len(), 4);
        assert_eq!(
            edits[3],
            HierarchicalEdit::Position {
                path: EditPath { face: 4, children: vec![1, 1] },
                vertex: 3,
                operator: EditOperator::Add,
                value: [0.0, 0.0, 1.0]
            }
        );
        let hole =
            decode_hierarchical_edits(&tag("faceedit", &[3, 4, 1, 1], &[], &["hole"]), &faces).unwrap();
        assert_eq!(hole, [HierarchicalEdit::Hole { path: EditPath { face: 4, children: vec![1, 1] } }]);
        // PRMan's word order, and a sharpness edit of an edge.
        let e = tag("edgeedit", &[3, 0, 2, 1], &[10.0], &["P", "sharpness", "set"]);
        assert_eq!(
            decode_hierarchical_edits(&e, &faces).unwrap(),
            [HierarchicalEdit::EdgeSharpness {
                path: EditPath { face: 0, children: vec![2] },
                edge: 1,
                operator: EditOperator::Set,
                value: 10.0
            }]
        );
    }

    #[test]
    fn malformed_and_unsupported_edits_say_why() {
        let faces = [4u32, 5];
        let err = |t: SubdivisionTag| decode_hierarchical_edits(&t, &faces).unwrap_err();
        assert!(err(tag("vertexedit", &[2, 0, 1], &[1.0], &["Cs", "value", "set"])).contains("\"Cs\""));
        assert!(err(tag("faceedit", &[1, 0], &[], &["attributes"])).contains("attributes"));
        assert!(err(tag("vertexedit", &[2, 2, 0], &[0.0; 3], &["P", "value", "add"])).contains("face 2"));
        // Face 1 has five vertices: child 4 exists, child 5 does not; below it faces are quads.
        assert!(decode_hierarchical_edits(&tag("faceedit", &[2, 1, 4], &[], &["hole"]), &faces).is_ok());
        assert!(err(tag("faceedit", &[2, 1, 5], &[], &["hole"])).contains("child 5"));
        assert!(err(tag("faceedit", &[3, 1, 4, 4], &[], &["hole"])).contains("child 4"));
        assert!(err(tag("vertexedit", &[3, 0, 1], &[0.0; 3], &["P", "value", "add"])).contains("runs past"));
        assert!(err(tag("vertexedit", &[2, 0, 1], &[0.0; 2], &["P", "value", "add"])).contains("3 values"));
        assert!(err(tag("vertexedit", &[2, 0, 1], &[0.0; 3], &["P", "value"])).contains("neither"));
    }
}
