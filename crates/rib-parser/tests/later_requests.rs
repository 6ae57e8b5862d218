//! Requests of RenderMan 3.3 and PRMan: `HierarchicalSubdivisionMesh` becomes the
//! `SubdivisionMesh` it describes with the hierarchical edits the tessellator applies, shader
//! networks stay warnings that say why.

use rib_parser::scene::*;
use rib_parser::{LoadOptions, load_bytes};

fn load(rib: &str) -> rib_parser::Loaded {
    load_bytes("test.rib", rib.as_bytes().to_vec(), &LoadOptions::default())
        .unwrap_or_else(|e| panic!("{}", e.render()))
}

fn load_err(rib: &str) -> String {
    match load_bytes("test.rib", rib.as_bytes().to_vec(), &LoadOptions::default()) {
        Ok(_) => panic!("expected an error for:\n{rib}"),
        Err(e) => e.render(),
    }
}

fn only_subdivision_mesh(loaded: &rib_parser::Loaded) -> &SubdivisionMesh {
    assert_eq!(loaded.scene.shapes.len(), 1, "{}", loaded.render_warnings());
    match &*loaded.scene.shapes[0].shape {
        Shape::SubdivisionMesh(m) => m,
        other => panic!("expected a SubdivisionMesh, got {other:?}"),
    }
}

/// A cube of six quads with the tags PRMan documents for both requests.
const CUBE: &str = "[4 4 4 4 4 4] [0 1 3 2 2 3 5 4 4 5 7 6 6 7 1 0 1 7 5 3 6 0 2 4]";
const CUBE_P: &str = "\"P\" [-1 -1 1 1 -1 1 -1 1 1 1 1 1 -1 1 -1 1 1 -1 -1 -1 -1 1 -1 -1]";

#[test]
fn hierarchical_subdivision_mesh_is_the_subdivision_mesh_with_its_tags() {
    let hierarchical = load(&format!(
        "WorldBegin\nHierarchicalSubdivisionMesh \"catmull-clark\" {CUBE} \
         [\"crease\" \"corner\" \"hole\" \"interpolateboundary\" \"facevaryinginterpolateboundary\"] \
         [2 1 0  1 1 0  1 0 0  1 0 0  1 0 0] [0 1 6 5 2 1] [2.5 10] [] {CUBE_P}\nWorldEnd\n"
    ));
    let plain = load(&format!(
        "WorldBegin\nSubdivisionMesh \"catmull-clark\" {CUBE} \
         [\"crease\" \"corner\" \"hole\" \"interpolateboundary\" \"facevaryinginterpolateboundary\"] \
         [2 1  1 1  1 0  1 0  1 0] [0 1 6 5 2 1] [2.5 10] {CUBE_P}\nWorldEnd\n"
    ));
    assert_eq!(hierarchical.diagnostics.warning_count(), 0, "{}", hierarchical.render_warnings());
    let (h, p) = (only_subdivision_mesh(&hierarchical), only_subdivision_mesh(&plain));
    assert_eq!(h, p);
    let names: Vec<&str> = h.tags.iter().map(|t| t.name.as_str()).collect();
    assert_eq!(names, ["crease", "corner", "hole", "interpolateboundary", "facevaryinginterpolateboundary"]);
    assert_eq!(h.tags[0].int_args, [0, 1]);
    assert_eq!(h.tags[0].float_args, [2.5]);
    assert_eq!(h.tags[2].int_args, [5]);
}

#[test]
fn hierarchical_edits_are_kept_and_unsupported_ones_dropped_with_a_warning() {
    // A vertex edit of face 0's child 2's vertex 1 (path length 3) adding to P, a hole at
    // face 4 (path length 1), and a colour edit, which the tessellator cannot apply.
    let loaded = load(&format!(
        "WorldBegin\nHierarchicalSubdivisionMesh \"catmull-clark\" {CUBE} \
         [\"interpolateboundary\" \"vertexedit\" \"faceedit\" \"vertexedit\"] [1 0 0  4 3 3  2 0 1  3 3 3] \
         [1  3 0 2 1  1 4  2 0 1] [0 0.5 0  1 0 0] [\"P\" \"value\" \"add\" \"hole\" \"Cs\" \"value\" \"set\"] \
         {CUBE_P}\nWorldEnd\n"
    ));
    let mesh = only_subdivision_mesh(&loaded);
    let names: Vec<&str> = mesh.tags.iter().map(|t| t.name.as_str()).collect();
    assert_eq!(names, ["interpolateboundary", "vertexedit", "faceedit"]);
    let edits = decode_hierarchical_edits(&mesh.tags[1], &mesh.vertices_per_face).unwrap();
    assert_eq!(
        edits,
        [HierarchicalEdit::Position {
            path: EditPath { face: 0, children: vec![2] },
            vertex: 1,
            operator: EditOperator::Add,
            value: [0.0, 0.5, 0.0]
        }]
    );
    let warnings = loaded.render_warnings();
    assert!(
        warnings.contains(
            "test.rib:2:1: warning: HierarchicalSubdivisionMesh: hierarchical edit \"vertexedit\" skipped: \
             a value edit of \"Cs\""
        ),
        "{warnings}"
    );
    assert_eq!(loaded.diagnostics.warning_count(), 1, "{warnings}");
    // The writer keeps the edits (a `SubdivisionMesh` with string arguments), read back alike.
    let text = rib_parser::writer::write_scene(&loaded.scene);
    let again = load(&text);
    assert_eq!(only_subdivision_mesh(&again), mesh, "{text}");
    assert_eq!(again.diagnostics.warning_count(), 0, "{}", again.render_warnings());
}

#[test]
fn hierarchical_subdivision_mesh_of_the_ricpp_samples_reads() {
    // ricpp2's Archive.rib and testcommands.rib give one tag with three counts and an empty
    // string array.
    let loaded = load(
        "WorldBegin\nHierarchicalSubdivisionMesh \"catmull-clark\" [4] [0 1 2 3] \
         [\"interpolateboundary\"] [0 0 0] [] [] [] \"P\" [0 0 0 1 0 0 1 1 0 0 1 0]\nWorldEnd\n",
    );
    let mesh = only_subdivision_mesh(&loaded);
    assert_eq!(mesh.tags.len(), 1);
    assert_eq!(loaded.diagnostics.warning_count(), 0, "{}", loaded.render_warnings());
}

#[test]
fn hierarchical_subdivision_mesh_errors_are_located() {
    // Two counts per tag is SubdivisionMesh's form; the hierarchical request needs three.
    let e = load_err(
        "WorldBegin\nHierarchicalSubdivisionMesh \"catmull-clark\" [4] [0 1 2 3] \
         [\"interpolateboundary\"] [0 0] [] [] [] \"P\" [0 0 0 1 0 0 1 1 0 0 1 0]\nWorldEnd\n",
    );
    assert!(
        e.contains("test.rib:2:1: error: HierarchicalSubdivisionMesh: 1 tags need 3 argument counts, got 2"),
        "{e}"
    );
    // String arguments the tags do not use.
    let e = load_err(
        "WorldBegin\nHierarchicalSubdivisionMesh \"catmull-clark\" [4] [0 1 2 3] \
         [\"interpolateboundary\"] [0 0 0] [] [] [\"stray\"] \"P\" [0 0 0 1 0 0 1 1 0 0 1 0]\nWorldEnd\n",
    );
    assert!(
        e.contains("test.rib:2:1: error: HierarchicalSubdivisionMesh: more tag arguments are given"),
        "{e}"
    );
    // A crease through a vertex that does not exist.
    let e = load_err(
        "WorldBegin\nHierarchicalSubdivisionMesh \"catmull-clark\" [4] [0 1 2 3] \
         [\"crease\"] [2 1 0] [0 9] [3] [] \"P\" [0 0 0 1 0 0 1 1 0 0 1 0]\nWorldEnd\n",
    );
    assert!(
        e.contains("HierarchicalSubdivisionMesh: \"crease\" tag refers to vertex 9, out of range"),
        "{e}"
    );
}

#[test]
fn shader_layers_say_they_hold_rsl_shaders() {
    let loaded = load(
        "WorldBegin\nShaderLayer \"surface\" \"texmap\" \"layer1\" \"string texturename\" [\"grid.tex\"]\n\
         ConnectShaderLayers \"surface\" \"layer1\" \"Cout\" \"layer2\" \"Cs\"\nSphere 1 -1 1 360\nWorldEnd\n",
    );
    let warnings = loaded.render_warnings();
    assert!(
        warnings.contains(
            "test.rib:2:1: warning: ShaderLayer \"surface\" \"texmap\": shader networks connect shaders \
             written in the RenderMan Shading Language, which a renderer without an RSL compiler cannot \
             evaluate; skipped with its arguments"
        ),
        "{warnings}"
    );
    assert!(
        warnings.contains("test.rib:3:1: warning: ConnectShaderLayers \"surface\": shader networks"),
        "{warnings}"
    );
    // The arguments are skipped, so the sphere after them is read.
    assert_eq!(loaded.scene.shapes.len(), 1);
}
