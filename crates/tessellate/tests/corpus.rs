//! Every scene of the shared RIB corpus tessellates: every surface gives finite, well-formed
//! world-space triangles (only `Points` and `Curves` are refused, as not surfaces), and the
//! corpus's NURBS, subdivision and patch models keep the properties their geometry implies.

#[path = "../../rib-parser/tests/support/corpus_fs.rs"]
mod corpus_fs;

use corpus_fs::{CorpusFs, corpus_files};
use rib_parser::scene::Shape;
use rib_parser::{LoadOptions, Loaded, ReadOptions};
use std::sync::Arc;
use tessellate::{SceneMeshes, TessellateError, Tolerance, TriangleMesh, tessellate, tessellate_scene};

fn options() -> LoadOptions {
    LoadOptions {
        read: ReadOptions { file_system: Arc::new(CorpusFs::new()), ..Default::default() },
        frame: None,
    }
}

fn load(repo: &str, file: &str) -> Option<Loaded> {
    rib_parser::load_scene(&CorpusFs::virtual_path(repo, file), &options()).ok()
}

/// A file that is only a fragment of a world block, read as the scene including it would.
fn load_fragment(repo: &str, file: &str) -> Loaded {
    let path = CorpusFs::virtual_path(repo, file);
    let text = format!("WorldBegin\nReadArchive \"{}\"\nWorldEnd\n", path.display());
    let wrapper = path.parent().expect("a directory").join("wrapper.rib");
    rib_parser::load_bytes_at(&wrapper, text.into_bytes(), &options()).expect("the fragment loads")
}

fn assert_sound(mesh: &TriangleMesh, what: &str) {
    assert_eq!(mesh.indices.len(), mesh.face_index.len(), "{what}");
    assert!(mesh.positions.iter().all(|p| p.is_finite()), "{what}: non-finite position");
    for tri in &mesh.indices {
        assert!(tri.iter().all(|&i| (i as usize) < mesh.positions.len()), "{what}: index out of range");
    }
    if let Some(n) = &mesh.normals {
        assert_eq!(n.len(), mesh.positions.len());
        assert!(n.iter().all(|v| (v.length() - 1.0).abs() < 1e-3), "{what}: normal not unit");
    }
    if let Some(st) = &mesh.st {
        assert!(st.iter().all(|v| v.is_finite()), "{what}: non-finite st");
    }
}

fn tessellated(repo: &str, file: &str, tol: &Tolerance) -> (Loaded, SceneMeshes) {
    let loaded = load(repo, file).unwrap_or_else(|| panic!("{repo}/{file} does not load"));
    let out = tessellate_scene(&loaded.scene, tol);
    for m in &out.meshes {
        assert_sound(&m.mesh, &format!("{repo}/{file} at {}", m.loc));
    }
    (loaded, out)
}

#[test]
fn every_corpus_scene_tessellates() {
    // A coarse tolerance keeps this quick; the finer checks are below.
    let tol = Tolerance::relative(1e-2);
    let (mut scenes, mut meshes, mut triangles) = (0, 0, 0u64);
    let mut failures = Vec::new();
    for (repo, file) in corpus_files() {
        let Some(loaded) = load(&repo, &file) else { continue };
        scenes += 1;
        let out = tessellate_scene(&loaded.scene, &tol);
        for m in &out.meshes {
            assert_sound(&m.mesh, &format!("{repo}/{file} at {}", m.loc));
        }
        meshes += out.meshes.len();
        triangles += out.triangle_count();
        for s in &out.skipped {
            if !s.error.is_not_a_surface() {
                failures.push(format!("{repo}/{file} at {}: {}", s.loc, s.error));
            }
        }
    }
    assert!(scenes > 60, "only {scenes} corpus scenes loaded");
    assert!(meshes > 1000 && triangles > 100_000, "{meshes} meshes, {triangles} triangles");
    assert!(failures.is_empty(), "shapes that did not tessellate:\n{}", failures.join("\n"));
}

#[test]
fn the_teapot_nupatches_tessellate_within_tolerance() {
    let (loaded, out) = tessellated("aqsis__aqsis", "librib2__tests__teapot.rib", &Tolerance::relative(1e-3));
    let nupatches = loaded.scene.shapes.iter().filter(|s| matches!(*s.shape, Shape::NuPatch(_))).count();
    assert_eq!(nupatches, 32);
    assert_eq!(out.meshes.len(), 32);
    assert!(out.skipped.is_empty());
    // Each patch on its own: the grid density check holds the tolerance at its edge midpoints.
    for e in &loaded.scene.shapes {
        let m = tessellate(&e.shape, &Tolerance::relative(1e-3)).unwrap();
        assert!(!m.is_empty());
        assert!(m.normals.is_some() && m.st.is_some());
    }
}

#[test]
fn the_subdivision_bunny_tessellates_and_is_closed_where_its_control_mesh_is() {
    let loaded = load_fragment("aqsis__aqsis", "testing__regression__RIBs__Scenes__sdsbunny.rib");
    let out = tessellate_scene(&loaded.scene, &Tolerance::relative(2e-3));
    let Shape::SubdivisionMesh(sm) = &*loaded.scene.shapes[0].shape else { panic!("not a SubdivisionMesh") };
    assert_eq!(out.meshes.len(), 1);
    let mesh = &out.meshes[0].mesh;
    // Drawn at level 1 or deeper: four quads (eight triangles) per control-mesh corner at least.
    assert!(mesh.triangle_count() >= 2 * sm.vertex_indices.len(), "{}", mesh.triangle_count());
    // Its face-varying st split vertices along seams; welded by position, the surface is
    // closed exactly where the control mesh is (no boundary edges in one means none in the other).
    let control = tessellate::tessellate(
        &Shape::Polygons(rib_parser::scene::PolygonMesh {
            loops_per_face: vec![1; sm.vertices_per_face.len()],
            vertices_per_loop: sm.vertices_per_face.clone(),
            vertex_indices: sm.vertex_indices.clone(),
            positions: sm.positions.clone(),
            primvars: Default::default(),
        }),
        &Tolerance::default(),
    )
    .unwrap();
    let welded = mesh.welded();
    eprintln!(
        "sdsbunny: {} control faces, {} triangles, {} open edges (control mesh: {})",
        sm.vertices_per_face.len(),
        mesh.triangle_count(),
        welded.boundary_edge_count(),
        control.boundary_edge_count()
    );
    assert_eq!(welded.boundary_edge_count() == 0, control.boundary_edge_count() == 0);
    if control.boundary_edge_count() == 0 {
        assert!(welded.is_closed());
    }
    assert!(mesh.st.is_some(), "the bunny's facevarying s, t are carried");
}

#[test]
fn vase_and_dragonhead_patches_tessellate() {
    for (repo, file) in [
        ("aqsis__aqsis", "examples__scenes__vase__vase.rib"),
        ("dpasca__RibTools", "DistribSrc__base__TestScenes__dragonhead.rib"),
    ] {
        if load(repo, file).is_none() {
            panic!("{repo}/{file} does not load");
        }
        let (_, out) = tessellated(repo, file, &Tolerance::relative(1e-3));
        assert!(!out.meshes.is_empty(), "{file}");
        let errors: Vec<&TessellateError> =
            out.skipped.iter().map(|s| &s.error).filter(|e| !e.is_not_a_surface()).collect();
        assert!(errors.is_empty(), "{file}: {errors:?}");
    }
}

#[test]
fn the_trim_test_keeps_the_disk_inside_its_trim_circle() {
    let (loaded, out) = tessellated(
        "aqsis__aqsis",
        "testing__regression__RIBs__Primitives__trim_test.rib",
        &Tolerance::relative(1e-3),
    );
    assert_eq!(out.meshes.len(), 1);
    // The patch is a square of side 0.659916; the trim circle is inscribed in its parameter
    // square: a disk of radius 0.329958 remains.
    let Shape::NuPatch(np) = &*loaded.scene.shapes[0].shape else { panic!("not a NuPatch") };
    let side = (np.positions[1] - np.positions[0]).truncate().length() as f64;
    let disk = std::f64::consts::PI * (side / 2.0).powi(2);
    let area = out.meshes[0].mesh.area();
    assert!((area - disk).abs() < 0.01 * disk, "area {area}, disk {disk}");
}

#[test]
fn the_quadrics_test_scene_is_closed_where_the_quadrics_are() {
    let (loaded, out) = tessellated(
        "aqsis__aqsis",
        "testing__regression__RIBs__Primitives__quads_test.rib",
        &Tolerance::relative(1e-3),
    );
    assert_eq!(out.meshes.len(), loaded.scene.shapes.len());
    for m in &out.meshes {
        let shape = &*loaded.scene.shapes[match m.origin {
            tessellate::MeshOrigin::Shape { index } => index,
            _ => unreachable!(),
        }]
        .shape;
        if let Shape::Sphere { radius, z_min, z_max, theta_max_degrees } = *shape {
            let full = z_min <= -radius && z_max >= radius && theta_max_degrees.abs() >= 360.0;
            assert_eq!(m.mesh.is_closed(), full, "{shape:?}");
        }
    }
}
