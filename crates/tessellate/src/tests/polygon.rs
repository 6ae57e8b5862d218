use super::assert_well_formed;
use crate::{TessellateError, Tolerance, TriangleMesh, tessellate};
use glam::{DVec3, Vec2, Vec3};
use rib_parser::scene::{
    FileLoc, Param, ParamDecl, ParamList, ParamType, ParamValues, PolygonMesh, Shape, StorageClass,
};

/// `GeneralPolygon`-style faces: every face a list of loops (outer first), every corner its own
/// vertex.
pub(crate) fn general(faces: &[Vec<Vec<[f32; 3]>>]) -> PolygonMesh {
    let mut pm = PolygonMesh {
        loops_per_face: Vec::new(),
        vertices_per_loop: Vec::new(),
        vertex_indices: Vec::new(),
        positions: Vec::new(),
        primvars: ParamList::default(),
    };
    for face in faces {
        pm.loops_per_face.push(face.len() as u32);
        for l in face {
            pm.vertices_per_loop.push(l.len() as u32);
            for p in l {
                pm.vertex_indices.push(pm.positions.len() as u32);
                pm.positions.push(Vec3::from_array(*p));
            }
        }
    }
    pm
}

/// `PointsPolygons`: shared positions, one loop per face.
pub(crate) fn points_polygons(positions: &[[f32; 3]], faces: &[&[u32]]) -> PolygonMesh {
    PolygonMesh {
        loops_per_face: vec![1; faces.len()],
        vertices_per_loop: faces.iter().map(|f| f.len() as u32).collect(),
        vertex_indices: faces.iter().flat_map(|f| f.iter().copied()).collect(),
        positions: positions.iter().map(|p| Vec3::from_array(*p)).collect(),
        primvars: ParamList::default(),
    }
}

pub(crate) fn float_param(
    name: &str,
    class: StorageClass,
    ty: ParamType,
    array_len: u32,
    values: Vec<f32>,
) -> Param {
    Param {
        name: name.into(),
        decl: ParamDecl { class, ty, array_len },
        values: ParamValues::Floats(values),
        loc: FileLoc::new("test.rib", 1, 1),
    }
}

fn run(pm: PolygonMesh) -> TriangleMesh {
    let mesh = tessellate(&Shape::Polygons(pm), &Tolerance::default()).unwrap();
    assert_well_formed(&mesh);
    mesh
}

fn square(x0: f32, y0: f32, x1: f32, y1: f32, ccw: bool) -> Vec<[f32; 3]> {
    let mut l = vec![[x0, y0, 0.0], [x1, y0, 0.0], [x1, y1, 0.0], [x0, y1, 0.0]];
    if !ccw {
        l.reverse();
    }
    l
}

/// Every triangle faces along `normal`.
fn assert_faces(mesh: &TriangleMesh, normal: DVec3) {
    for t in 0..mesh.triangle_count() {
        let c = mesh.face_cross(t);
        assert!(c.normalize().dot(normal) > 0.999, "triangle {t}: {c}");
    }
}

#[test]
fn a_square_with_holes_has_the_outer_area_minus_the_holes() {
    // Holes wound either way: the outer loop decides the orientation.
    let face = vec![
        square(0.0, 0.0, 10.0, 10.0, true),
        square(1.0, 1.0, 3.0, 4.0, false),
        square(5.0, 5.0, 9.0, 6.0, true),
        // A triangular hole.
        vec![[6.0, 1.0, 0.0], [9.0, 1.0, 0.0], [7.0, 3.0, 0.0]],
    ];
    let mesh = run(general(&[face]));
    let expected = 100.0 - 6.0 - 4.0 - 3.0;
    assert!((mesh.area() - expected).abs() < 1e-9, "{}", mesh.area());
    assert_faces(&mesh, DVec3::Z);
    assert!(mesh.face_index.iter().all(|&f| f == 0));
}

#[test]
fn concave_polygons_triangulate_inside_their_outline() {
    // An L and a comb, clockwise: normals follow the winding (-z).
    let mut l_shape = vec![
        [0.0, 0.0, 0.0],
        [4.0, 0.0, 0.0],
        [4.0, 1.0, 0.0],
        [1.0, 1.0, 0.0],
        [1.0, 3.0, 0.0],
        [0.0, 3.0, 0.0],
    ];
    l_shape.reverse();
    let comb: Vec<[f32; 3]> = vec![
        [0.0, 0.0, 0.0],
        [5.0, 0.0, 0.0],
        [5.0, 3.0, 0.0],
        [4.0, 3.0, 0.0],
        [4.0, 1.0, 0.0],
        [3.0, 1.0, 0.0],
        [3.0, 3.0, 0.0],
        [2.0, 3.0, 0.0],
        [2.0, 1.0, 0.0],
        [1.0, 1.0, 0.0],
        [1.0, 3.0, 0.0],
        [0.0, 3.0, 0.0],
    ];
    let mesh = run(general(&[vec![l_shape], vec![comb]]));
    let area = |f: u32| -> f64 {
        (0..mesh.triangle_count())
            .filter(|&t| mesh.face_index[t] == f)
            .map(|t| 0.5 * mesh.face_cross(t).length())
            .sum()
    };
    assert!((area(0) - 6.0).abs() < 1e-9);
    assert!((area(1) - 11.0).abs() < 1e-9, "{}", area(1));
    for t in 0..mesh.triangle_count() {
        let expect = if mesh.face_index[t] == 0 { -DVec3::Z } else { DVec3::Z };
        assert!(mesh.face_cross(t).normalize().dot(expect) > 0.999);
    }
}

#[test]
fn a_concave_quad_is_split_inside_it() {
    // A dart: vertex 2 is reflex, so the diagonal 0-2 is the only valid one.
    let dart = vec![[0.0, 0.0, 0.0], [2.0, 1.0, 0.0], [0.0, 0.5, 0.0], [-2.0, 1.0, 0.0]];
    let mesh = run(general(&[vec![dart]]));
    assert_eq!(mesh.triangle_count(), 2);
    // Shoelace area of the dart.
    assert!((mesh.area() - 1.0).abs() < 1e-9, "{}", mesh.area());
    assert_faces(&mesh, DVec3::Z);
}

#[test]
fn non_planar_polygons_are_projected_on_their_newell_plane() {
    // A saddle-like hexagon: alternate z up and down.
    let loop_: Vec<[f32; 3]> = (0..6)
        .map(|i| {
            let a = i as f32 * std::f32::consts::TAU / 6.0;
            [a.cos(), a.sin(), if i % 2 == 0 { 0.2 } else { -0.2 }]
        })
        .collect();
    let mesh = run(general(&[vec![loop_.clone()]]));
    assert_eq!(mesh.triangle_count(), 4);
    // Every triangle faces the Newell normal (+z here); corners stay where they were.
    assert_faces_loosely(&mesh, DVec3::Z);
    for p in &mesh.positions {
        assert!(loop_.iter().any(|q| Vec3::from_array(*q) == *p));
    }
}

fn assert_faces_loosely(mesh: &TriangleMesh, normal: DVec3) {
    for t in 0..mesh.triangle_count() {
        assert!(mesh.face_cross(t).dot(normal) > 0.0);
    }
}

#[test]
fn degenerate_faces_give_no_triangles_and_no_nans() {
    let faces = vec![
        // Collinear.
        vec![vec![[0.0, 0.0, 0.0], [1.0, 0.0, 0.0], [2.0, 0.0, 0.0]]],
        // All one point.
        vec![vec![[1.0, 1.0, 1.0]; 5]],
        // Two vertices.
        vec![vec![[0.0, 0.0, 0.0], [1.0, 0.0, 0.0]]],
        // Duplicate consecutive vertices and a collinear run on a valid square.
        vec![vec![
            [0.0, 0.0, 0.0],
            [0.0, 0.0, 0.0],
            [1.0, 0.0, 0.0],
            [2.0, 0.0, 0.0],
            [2.0, 2.0, 0.0],
            [2.0, 2.0, 0.0],
            [0.0, 2.0, 0.0],
        ]],
        // A hole with fewer than three vertices is ignored.
        vec![square(0.0, 0.0, 1.0, 1.0, true), vec![[0.5, 0.5, 0.0], [0.6, 0.5, 0.0]]],
        // A bow tie (self-intersecting): whatever comes out is finite.
        vec![vec![[0.0, 0.0, 0.0], [1.0, 1.0, 0.0], [1.0, 0.0, 0.0], [0.0, 1.0, 0.0]]],
    ];
    let mesh = run(general(&faces));
    assert_eq!(mesh.degenerate_faces, 4, "the bow tie has no net area either");
    let area_of = |f: u32| -> f64 {
        (0..mesh.triangle_count())
            .filter(|&t| mesh.face_index[t] == f)
            .map(|t| 0.5 * mesh.face_cross(t).length())
            .sum()
    };
    assert!((area_of(3) - 4.0).abs() < 1e-9);
    assert!((area_of(4) - 1.0).abs() < 1e-9);
    for t in 0..mesh.triangle_count() {
        assert!(mesh.face_cross(t).length() > 0.0);
    }
}

pub(crate) const CUBE_POSITIONS: [[f32; 3]; 8] = [
    [0.0, 0.0, 0.0],
    [1.0, 0.0, 0.0],
    [1.0, 1.0, 0.0],
    [0.0, 1.0, 0.0],
    [0.0, 0.0, 1.0],
    [1.0, 0.0, 1.0],
    [1.0, 1.0, 1.0],
    [0.0, 1.0, 1.0],
];

/// The unit cube's faces, counter-clockwise seen from outside.
pub(crate) const CUBE_FACES: [&[u32]; 6] =
    [&[0, 3, 2, 1], &[4, 5, 6, 7], &[0, 1, 5, 4], &[1, 2, 6, 5], &[2, 3, 7, 6], &[3, 0, 4, 7]];

#[test]
fn a_points_polygons_cube_is_closed_with_outward_winding() {
    let mesh = run(points_polygons(&CUBE_POSITIONS, &CUBE_FACES));
    assert_eq!(mesh.triangle_count(), 12);
    assert!(mesh.is_closed());
    assert!((mesh.signed_volume() - 1.0).abs() < 1e-12);
    assert!((mesh.area() - 6.0).abs() < 1e-12);
    assert!(mesh.normals.is_none() && mesh.st.is_none());
}

#[test]
fn vertex_normals_and_facevarying_st_are_carried() {
    let mut pm = points_polygons(&CUBE_POSITIONS, &CUBE_FACES);
    let normals: Vec<f32> = CUBE_POSITIONS.iter().flat_map(|p| p.map(|c| c - 0.5)).collect();
    pm.primvars.0.push(float_param("N", StorageClass::Vertex, ParamType::Normal, 1, normals));
    let st: Vec<f32> = (0..24).flat_map(|c| [c as f32, -(c as f32)]).collect();
    pm.primvars.0.push(float_param("st", StorageClass::FaceVarying, ParamType::Float, 2, st));
    let mesh = run(pm);
    // Face-varying data splits vertices per corner: closed once welded by position.
    assert_eq!(mesh.positions.len(), 24);
    assert!(!mesh.is_closed());
    assert!(mesh.welded().is_closed());
    let n = mesh.normals.as_ref().unwrap();
    let st = mesh.st.as_ref().unwrap();
    for (i, p) in mesh.positions.iter().enumerate() {
        assert!((n[i] - (*p - Vec3::splat(0.5)).normalize()).length() < 1e-6);
        // Every corner keeps its own st.
        assert_eq!(st[i].x, -st[i].y);
    }
    let mut corners: Vec<i32> = st.iter().map(|v| v.x as i32).collect();
    corners.sort();
    assert_eq!(corners, (0..24).collect::<Vec<_>>());
}

#[test]
fn uniform_normals_and_separate_s_t_are_carried() {
    let mut pm = general(&[vec![square(0.0, 0.0, 1.0, 1.0, true)], vec![square(2.0, 0.0, 3.0, 1.0, true)]]);
    pm.primvars.0.push(float_param(
        "N",
        StorageClass::Uniform,
        ParamType::Normal,
        1,
        vec![0.0, 0.0, 2.0, 0.0, 1.0, 0.0],
    ));
    pm.primvars.0.push(float_param(
        "s",
        StorageClass::Vertex,
        ParamType::Float,
        1,
        (0..8).map(|i| i as f32).collect(),
    ));
    pm.primvars.0.push(float_param(
        "t",
        StorageClass::Vertex,
        ParamType::Float,
        1,
        (0..8).map(|i| 10.0 + i as f32).collect(),
    ));
    let mesh = run(pm);
    let n = mesh.normals.as_ref().unwrap();
    let st = mesh.st.as_ref().unwrap();
    for t in 0..mesh.triangle_count() {
        for &i in &mesh.indices[t] {
            let expect = if mesh.face_index[t] == 0 { Vec3::Z } else { Vec3::Y };
            assert_eq!(n[i as usize], expect);
            assert_eq!(st[i as usize].y - st[i as usize].x, 10.0);
        }
    }
    assert!(st.contains(&Vec2::new(7.0, 17.0)));
}

#[test]
fn bad_indices_and_counts_are_errors() {
    let mut pm = points_polygons(&CUBE_POSITIONS, &CUBE_FACES);
    pm.vertex_indices[3] = 8;
    assert!(matches!(
        tessellate(&Shape::Polygons(pm), &Tolerance::default()),
        Err(TessellateError::InvalidShape { .. })
    ));
    let mut pm = points_polygons(&CUBE_POSITIONS, &CUBE_FACES);
    pm.vertices_per_loop[0] = 5;
    assert!(matches!(
        tessellate(&Shape::Polygons(pm), &Tolerance::default()),
        Err(TessellateError::InvalidShape { .. })
    ));
    let mut pm = points_polygons(&CUBE_POSITIONS, &CUBE_FACES);
    pm.loops_per_face[0] = 2;
    assert!(matches!(
        tessellate(&Shape::Polygons(pm), &Tolerance::default()),
        Err(TessellateError::InvalidShape { .. })
    ));
    let mut pm = points_polygons(&CUBE_POSITIONS, &CUBE_FACES);
    pm.positions[0].x = f32::NAN;
    assert!(matches!(
        tessellate(&Shape::Polygons(pm), &Tolerance::default()),
        Err(TessellateError::NonFinite { .. })
    ));
    // Too many triangles for the cap.
    let pm = points_polygons(&CUBE_POSITIONS, &CUBE_FACES);
    let tol = Tolerance::default().with_max_triangles(11);
    assert!(matches!(tessellate(&Shape::Polygons(pm), &tol), Err(TessellateError::TooManyTriangles { .. })));
}

#[test]
fn a_large_polygon_with_many_holes_keeps_its_area() {
    // A 40-gon disk with a grid of 25 small square holes.
    let outer: Vec<[f32; 3]> = (0..40)
        .map(|i| {
            let a = i as f32 * std::f32::consts::TAU / 40.0;
            [10.0 * a.cos(), 10.0 * a.sin(), 0.0]
        })
        .collect();
    let n = 40.0f64;
    let outer_area = 0.5 * n * 100.0 * (std::f64::consts::TAU / n).sin();
    let mut face = vec![outer];
    for i in 0..5 {
        for j in 0..5 {
            let (x, y) = (-5.0 + 2.0 * i as f32, -5.0 + 2.0 * j as f32);
            face.push(square(x, y, x + 1.0, y + 0.5, (i + j) % 2 == 0));
        }
    }
    let mesh = run(general(&[face]));
    assert!((mesh.area() - (outer_area - 25.0 * 0.5)).abs() < 1e-3, "{}", mesh.area());
    assert_faces(&mesh, DVec3::Z);
}
