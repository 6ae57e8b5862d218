use super::polygon::{CUBE_FACES, CUBE_POSITIONS, float_param};
use super::{assert_normals_follow_winding, assert_well_formed};
use crate::{TessellateError, Tolerance, TriangleMesh, tessellate};
use glam::{DVec3, Vec3};
use rib_parser::scene::{ParamList, ParamType, Shape, StorageClass, SubdivisionMesh, SubdivisionTag};

pub(crate) fn subdivision(
    positions: &[[f32; 3]],
    faces: &[&[u32]],
    tags: Vec<SubdivisionTag>,
) -> SubdivisionMesh {
    SubdivisionMesh {
        scheme: "catmull-clark".into(),
        vertices_per_face: faces.iter().map(|f| f.len() as u32).collect(),
        vertex_indices: faces.iter().flat_map(|f| f.iter().copied()).collect(),
        tags,
        positions: positions.iter().map(|p| Vec3::from_array(*p)).collect(),
        primvars: ParamList::default(),
    }
}

pub(crate) fn tag(name: &str, int_args: Vec<i32>, float_args: Vec<f32>) -> SubdivisionTag {
    SubdivisionTag { name: name.into(), int_args, float_args, string_args: Vec::new() }
}

fn run(sm: SubdivisionMesh, eps: f64) -> TriangleMesh {
    let m = tessellate(&Shape::SubdivisionMesh(sm), &Tolerance::absolute(eps)).unwrap();
    assert_well_formed(&m);
    assert_normals_follow_winding(&m, 0.05);
    m
}

fn cube() -> SubdivisionMesh {
    subdivision(&CUBE_POSITIONS, &CUBE_FACES, Vec::new())
}

#[test]
fn a_subdivided_cube_is_closed_symmetric_and_converges() {
    let centre = DVec3::splat(0.5);
    let mut volumes = Vec::new();
    let mut counts = Vec::new();
    for eps in [3e-2, 1e-2, 3e-3, 1e-3, 3e-4] {
        let m = run(cube(), eps);
        assert!(m.is_closed(), "{eps}: {} open edges", m.boundary_edge_count());
        // Outward normals, on the side of the winding.
        let n = m.normals.as_ref().unwrap();
        for (p, n) in m.positions.iter().zip(n) {
            assert!(n.as_dvec3().dot(p.as_dvec3() - centre) > 0.0);
        }
        // Symmetric under the cube's mirror symmetries: the bounds are centred. The face
        // centres are vertices of every level; their limit is worked out by hand: the
        // level-1 corner vertex point is 7/9 of the way out, the edge points sit at
        // z = 7/8, so the limit of the top face point is (16 + 16 * 7/8 + 4 * 7/9) / 36.
        let (lo, hi) = m.bounds().unwrap();
        let top = (16.0 + 16.0 * 7.0 / 8.0 + 4.0 * 7.0 / 9.0) / 36.0;
        assert!(
            (hi.z as f64 - top).abs() < 1e-6 && (lo.z as f64 - (1.0 - top)).abs() < 1e-6,
            "{lo} {hi} vs {top}"
        );
        assert!(((lo + hi).as_dvec3() / 2.0 - centre).abs().max_element() < 1e-6, "{lo} {hi}");
        assert!(((hi - lo).max_element() - (hi - lo).min_element()).abs() < 1e-6);
        volumes.push(m.signed_volume());
        counts.push(m.triangle_count());
        // Every face of the cube contributes.
        let mut faces = m.face_index.clone();
        faces.sort();
        faces.dedup();
        assert_eq!(faces, vec![0, 1, 2, 3, 4, 5]);
    }
    // Finer levels are chosen as the tolerance shrinks, and the inscribed volume grows toward
    // the limit surface's with differences shrinking about fourfold per level.
    assert!(counts.windows(2).all(|w| w[1] >= w[0]), "{counts:?}");
    let mut levels: Vec<(usize, f64)> = counts.iter().copied().zip(volumes.iter().copied()).collect();
    levels.dedup_by_key(|l| l.0);
    assert!(levels.len() >= 3, "{levels:?}");
    let diffs: Vec<f64> = levels.windows(2).map(|w| w[1].1 - w[0].1).collect();
    assert!(diffs.iter().all(|&d| d > 0.0), "{levels:?}");
    for w in diffs.windows(2) {
        assert!(w[1] < w[0] / 2.5, "{diffs:?}");
    }
    // The limit of the unit cube lies strictly inside it (a rounded cube).
    let v = levels.last().unwrap().1;
    assert!(v > 0.3 && v < 0.5, "{v}");
}

#[test]
fn the_control_mesh_volume_shrinks_and_the_limit_sits_inside() {
    // Vertices of every drawn level are on the limit surface, inside the cube's hull.
    let m = run(cube(), 1e-3);
    for p in &m.positions {
        assert!(p.min_element() > 0.0 && p.max_element() < 1.0, "{p}");
    }
}

/// A height field on a `(n x n)` vertex grid.
fn height(i: usize, j: usize) -> f32 {
    ((i * 7 + j * 13) % 5) as f32 * 0.1 + (i as f32 * 0.3).sin()
}

fn grid_mesh(n: usize, tags: Vec<SubdivisionTag>) -> SubdivisionMesh {
    let mut positions = Vec::new();
    for j in 0..n {
        for i in 0..n {
            positions.push([i as f32, j as f32, height(i, j)]);
        }
    }
    let mut faces: Vec<Vec<u32>> = Vec::new();
    for j in 0..n - 1 {
        for i in 0..n - 1 {
            let v = |a: usize, b: usize| (b * n + a) as u32;
            faces.push(vec![v(i, j), v(i + 1, j), v(i + 1, j + 1), v(i, j + 1)]);
        }
    }
    let refs: Vec<&[u32]> = faces.iter().map(|f| f.as_slice()).collect();
    subdivision(&positions, &refs, tags)
}

/// The uniform bicubic B-spline height field over the same control points at `(x, y)`.
fn bspline_height(n: usize, x: f64, y: f64) -> f64 {
    let w = |t: f64| {
        [
            (1.0 - t).powi(3) / 6.0,
            (3.0 * t.powi(3) - 6.0 * t * t + 4.0) / 6.0,
            (-3.0 * t.powi(3) + 3.0 * t * t + 3.0 * t + 1.0) / 6.0,
            t.powi(3) / 6.0,
        ]
    };
    // Control point i sits at x = i; the span [i, i + 1] uses points i - 1 .. i + 2.
    let (i, j) = ((x.floor() as usize).clamp(1, n - 3), (y.floor() as usize).clamp(1, n - 3));
    let (wu, wv) = (w(x - i as f64), w(y - j as f64));
    let mut z = 0.0;
    for b in 0..4 {
        for a in 0..4 {
            z += wu[a] * wv[b] * height(i - 1 + a, j - 1 + b) as f64;
        }
    }
    z
}

#[test]
fn limit_positions_on_a_regular_grid_equal_the_bicubic_bspline() {
    let n = 7;
    for eps in [1e-2, 1e-3] {
        let m = run(grid_mesh(n, Vec::new()), eps);
        // Without interpolateboundary only faces whose corners are all interior are drawn:
        // x and y in [1, n - 2].
        let (lo, hi) = m.bounds().unwrap();
        assert!((lo.x - 1.0).abs() < 1e-6 && (hi.x - (n - 2) as f32).abs() < 1e-6, "{lo} {hi}");
        for p in &m.positions {
            let expect = bspline_height(n, p.x as f64, p.y as f64);
            assert!((p.z as f64 - expect).abs() < 1e-5, "{p}: B-spline gives {expect}");
        }
        assert_eq!(m.face_index.iter().min(), Some(&7), "face 7 is the first interior face");
    }
}

#[test]
fn interpolateboundary_draws_to_the_boundary_and_keeps_corners() {
    let n = 5;
    let m = run(grid_mesh(n, vec![tag("interpolateboundary", vec![], vec![])]), 1e-3);
    let (lo, hi) = m.bounds().unwrap();
    assert!(lo.x.abs() < 1e-6 && lo.y.abs() < 1e-6 && (hi.x - 4.0).abs() < 1e-6);
    // Corners are interpolated exactly.
    for (i, j) in [(0, 0), (4, 0), (0, 4), (4, 4)] {
        let corner = Vec3::new(i as f32, j as f32, height(i, j));
        assert!(m.positions.iter().any(|p| p.distance(corner) < 1e-6), "{corner}");
    }
    // The boundary is the cubic B-spline of the boundary points: at a boundary control point
    // (2, 0) the limit is (a + 4 v + b) / 6.
    let b = (height(1, 0) + 4.0 * height(2, 0) + height(3, 0)) as f64 / 6.0;
    let target = DVec3::new(2.0, 0.0, b);
    assert!(m.positions.iter().any(|p| p.as_dvec3().distance(target) < 1e-6));
    assert!(m.boundary_edge_count() > 0);
}

#[test]
fn infinitely_sharp_creases_keep_the_cube() {
    // Every cube edge creased: the limit is the cube itself.
    let mut tags = Vec::new();
    for f in CUBE_FACES {
        let mut chain: Vec<i32> = f.iter().map(|&v| v as i32).collect();
        chain.push(f[0] as i32);
        tags.push(tag("crease", chain, vec![10.0]));
    }
    let m = run(subdivision(&CUBE_POSITIONS, &CUBE_FACES, tags), 1e-3);
    assert!(m.is_closed());
    assert!((m.signed_volume() - 1.0).abs() < 1e-9, "{}", m.signed_volume());
    for p in &m.positions {
        let on_face = p.to_array().iter().any(|&c| c.abs() < 1e-6 || (c - 1.0).abs() < 1e-6);
        assert!(on_face, "{p}");
    }
}

#[test]
fn semi_sharp_creases_sit_between_smooth_and_sharp() {
    // Crease the cube's top square with increasing sharpness: the crease's midpoint moves
    // monotonically toward the infinitely sharp position.
    let top: Vec<i32> = vec![4, 5, 6, 7, 4];
    let probe = |sharpness: Option<f32>| -> f64 {
        let tags = sharpness.map(|s| vec![tag("crease", top.clone(), vec![s])]).unwrap_or_default();
        let m = run(subdivision(&CUBE_POSITIONS, &CUBE_FACES, tags), 1e-3);
        // The crease's midpoint: the vertex in the plane x = 0.5 farthest toward the edge
        // 4-5 (y = 0, z = 1).
        m.positions
            .iter()
            .filter(|p| (p.x - 0.5).abs() < 1e-6)
            .map(|p| (p.z - p.y) as f64)
            .fold(f64::NEG_INFINITY, f64::max)
    };
    let heights: Vec<f64> =
        [None, Some(0.5), Some(1.0), Some(2.0), Some(3.0), Some(10.0)].iter().map(|&s| probe(s)).collect();
    assert!(heights.windows(2).all(|w| w[1] > w[0]), "{heights:?}");
    // Infinitely sharp, the crease is the closed cubic B-spline of the top square: at the
    // middle of edge 4-5 it is (P7 + 23 P4 + 23 P5 + P6) / 48 = (0.5, 1/24, 1).
    assert!((heights[5] - (1.0 - 1.0 / 24.0)).abs() < 1e-6, "{heights:?}");
}

#[test]
fn corner_tags_pin_vertices() {
    let m = run(subdivision(&CUBE_POSITIONS, &CUBE_FACES, vec![tag("corner", vec![6], vec![10.0])]), 1e-3);
    assert!(m.positions.contains(&Vec3::ONE));
    let smooth = run(cube(), 1e-3);
    assert!(!smooth.positions.iter().any(|p| p.distance(Vec3::ONE) < 0.1));
}

#[test]
fn holes_are_not_drawn() {
    let m = run(subdivision(&CUBE_POSITIONS, &CUBE_FACES, vec![tag("hole", vec![1], vec![])]), 1e-3);
    assert!(!m.face_index.contains(&1));
    assert!(m.boundary_edge_count() > 0);
    // The rest of the surface is as without the hole.
    let full = run(cube(), 1e-3);
    assert_eq!(m.triangle_count() * 6, full.triangle_count() * 5);
}

#[test]
fn triangles_and_ngons_subdivide() {
    // A square pyramid (four triangles, one quad) and a pentagonal prism cap.
    let positions = [[0.0, 0.0, 0.0], [1.0, 0.0, 0.0], [1.0, 1.0, 0.0], [0.0, 1.0, 0.0], [0.5, 0.5, 1.0]];
    let faces: [&[u32]; 5] = [&[0, 3, 2, 1], &[0, 1, 4], &[1, 2, 4], &[2, 3, 4], &[3, 0, 4]];
    let m = run(subdivision(&positions, &faces, Vec::new()), 1e-3);
    assert!(m.is_closed());
    assert!(m.signed_volume() > 0.0);
    let angle = std::f32::consts::TAU / 5.0;
    let mut positions: Vec<[f32; 3]> =
        (0..5).map(|i| [(angle * i as f32).cos(), (angle * i as f32).sin(), 0.0]).collect();
    positions.extend((0..5).map(|i| [(angle * i as f32).cos(), (angle * i as f32).sin(), 1.0]));
    let top: Vec<u32> = (5..10).collect();
    let bottom: Vec<u32> = (0..5).rev().collect();
    let sides: Vec<Vec<u32>> = (0..5).map(|i| vec![i, (i + 1) % 5, 5 + (i + 1) % 5, 5 + i]).collect();
    let mut faces: Vec<&[u32]> = vec![&top, &bottom];
    faces.extend(sides.iter().map(|s| s.as_slice()));
    let m = run(subdivision(&positions, &faces, Vec::new()), 1e-3);
    assert!(m.is_closed());
    assert!(m.signed_volume() > 0.0);
}

#[test]
fn facevarying_st_is_carried_and_splits_only_where_it_differs() {
    let mut sm = cube();
    // One st per face corner; each face gets its own square in st space.
    let st: Vec<f32> = (0..6)
        .flat_map(|f| {
            [[0.0, 0.0], [1.0, 0.0], [1.0, 1.0], [0.0, 1.0]]
                .into_iter()
                .flat_map(move |c| [c[0] + 2.0 * f as f32, c[1]])
        })
        .collect();
    sm.primvars.0.push(float_param("st", StorageClass::FaceVarying, ParamType::Float, 2, st));
    let m = run(sm, 1e-2);
    let st = m.st.as_ref().unwrap();
    assert!(!m.is_closed(), "seams split vertices");
    assert!(m.welded().is_closed());
    for t in 0..m.triangle_count() {
        let f = m.face_index[t] as f32;
        for &i in &m.indices[t] {
            let s = st[i as usize];
            assert!(
                s.x >= 2.0 * f - 1e-6 && s.x <= 2.0 * f + 1.0 + 1e-6 && (0.0..=1.0).contains(&s.y),
                "{s} on face {f}"
            );
        }
    }
    // Vertex st (continuous): no split.
    let mut sm = cube();
    sm.primvars.0.push(float_param(
        "st",
        StorageClass::Vertex,
        ParamType::Float,
        2,
        (0..16).map(|i| i as f32).collect(),
    ));
    assert!(run(sm, 1e-2).is_closed());
}

#[test]
fn bad_subdivision_meshes_are_errors_not_panics() {
    let tol = Tolerance::default();
    let mut sm = cube();
    sm.scheme = "loop".into();
    assert!(matches!(
        tessellate(&Shape::SubdivisionMesh(sm), &tol),
        Err(TessellateError::UnsupportedScheme(_))
    ));
    let mut sm = cube();
    sm.vertex_indices[0] = 99;
    assert!(matches!(
        tessellate(&Shape::SubdivisionMesh(sm), &tol),
        Err(TessellateError::InvalidShape { .. })
    ));
    let mut sm = cube();
    sm.vertices_per_face[0] = 5;
    assert!(matches!(
        tessellate(&Shape::SubdivisionMesh(sm), &tol),
        Err(TessellateError::InvalidShape { .. })
    ));
    // Degenerate faces and nonsense tags are skipped.
    let mut sm = cube();
    sm.vertices_per_face.push(2);
    sm.vertex_indices.extend([0, 1]);
    sm.vertices_per_face.push(3);
    sm.vertex_indices.extend([2, 2, 2]);
    sm.tags = vec![
        tag("crease", vec![-1, 99, 0, 0], vec![f32::NAN]),
        tag("corner", vec![-3, 100], vec![]),
        tag("hole", vec![-1, 50], vec![]),
        tag("stitch", vec![], vec![]),
    ];
    let m = tessellate(&Shape::SubdivisionMesh(sm), &tol).unwrap();
    assert_eq!(m.degenerate_faces, 2);
    assert!(m.is_closed());
    // The triangle budget refuses deep levels up front.
    let r =
        tessellate(&Shape::SubdivisionMesh(cube()), &Tolerance::absolute(1e-9).with_max_triangles(10_000));
    assert!(matches!(r, Err(TessellateError::TooManyTriangles { .. })), "{r:?}");
}

#[test]
fn the_drawn_level_meets_the_tolerance() {
    // Vertices of a much finer tessellation lie on the limit surface; none may be farther
    // than the tolerance from the coarse one.
    // A ten-sided bipyramid: two extraordinary vertices of valence 10, where uniform
    // refinement converges slowly and the faces around them are refined further.
    let mut bipyramid: Vec<[f32; 3]> = (0..10)
        .map(|i| {
            let a = i as f32 * std::f32::consts::TAU / 10.0;
            [a.cos(), a.sin(), 0.0]
        })
        .collect();
    bipyramid.extend([[0.0, 0.0, 1.0], [0.0, 0.0, -1.0]]);
    let faces: Vec<[u32; 3]> =
        (0..10u32).flat_map(|i| [[i, (i + 1) % 10, 10], [(i + 1) % 10, i, 11]]).collect();
    let face_refs: Vec<&[u32]> = faces.iter().map(|f| f.as_slice()).collect();
    let shapes = [
        subdivision(&bipyramid, &face_refs, Vec::new()),
        cube(),
        subdivision(&CUBE_POSITIONS, &CUBE_FACES, vec![tag("crease", vec![4, 5, 6, 7, 4], vec![2.5])]),
        grid_mesh(6, vec![tag("interpolateboundary", vec![], vec![])]),
    ];
    for (i, sm) in shapes.into_iter().enumerate() {
        for eps in [5e-2, 2e-2] {
            let coarse = run(sm.clone(), eps);
            let fine = run(sm.clone(), eps / 8.0);
            // The closed ones stay closed where refined faces meet unrefined ones.
            if i < 3 {
                assert!(coarse.is_closed() && fine.is_closed(), "shape {i} at {eps}");
            }
            let d = super::max_distance_to_mesh(&fine, &coarse);
            assert!(d <= eps, "{eps}: {d} with {} triangles", coarse.triangle_count());
        }
    }
}
