//! PRMan's hierarchical edits on the unit cube (`CUBE_FACES`: face 1 is the top, z = 1, its
//! vertices labelled 0 to 3 at (0,0), (1,0), (1,1), (0,1)), against closed forms: Catmull-Clark
//! limit stencils and the level-1 points worked out by hand.

use super::point_triangle_distance;
use super::polygon::{CUBE_FACES, CUBE_POSITIONS};
use super::subdiv::subdivision;
use super::{assert_normals_follow_winding, assert_well_formed};
use crate::{Tolerance, TriangleMesh, tessellate};
use glam::DVec3;
use rib_parser::scene::{Shape, SubdivisionTag};

const EPS: f64 = 2e-3;

fn edit(name: &str, int_args: Vec<i32>, float_args: Vec<f32>, words: &[&str]) -> SubdivisionTag {
    SubdivisionTag {
        name: name.into(),
        int_args,
        float_args,
        string_args: words.iter().map(|w| w.to_string()).collect(),
    }
}

fn cube(tags: Vec<SubdivisionTag>) -> TriangleMesh {
    let sm = subdivision(&CUBE_POSITIONS, &CUBE_FACES, tags);
    let m = tessellate(&Shape::SubdivisionMesh(sm), &Tolerance::absolute(EPS)).unwrap();
    assert_well_formed(&m);
    assert_normals_follow_winding(&m, 0.05);
    m
}

fn distance_to_mesh(p: DVec3, mesh: &TriangleMesh) -> f64 {
    (0..mesh.triangle_count())
        .map(|t| {
            let [a, b, c] = mesh.triangle(t).map(|q| q.as_dvec3());
            point_triangle_distance(p, a, b, c)
        })
        .fold(f64::INFINITY, f64::min)
}

fn nearest_vertex(p: DVec3, mesh: &TriangleMesh) -> f64 {
    mesh.positions.iter().map(|q| q.as_dvec3().distance(p)).fold(f64::INFINITY, f64::min)
}

/// The limit of the top face's centre, unedited (tests/subdiv.rs works it out).
fn top_centre() -> f64 {
    (16.0 + 16.0 * 7.0 / 8.0 + 4.0 * 7.0 / 9.0) / 36.0
}

#[test]
fn a_vertex_edit_moves_its_limit_point_by_the_stencil_weight_and_nothing_far() {
    let plain = cube(Vec::new());
    // Face 1, child 2, vertex 0: child 2 is stored from the parent's vertex 2 (label 2), so its
    // label 0 is its third stored vertex, the face point: the top face's centre at level 1.
    let edited =
        cube(vec![edit("vertexedit", vec![3, 1, 2, 0], vec![0.0, 0.0, 1.0], &["P", "value", "add"])]);
    // A regular (valence 4) vertex's limit is 16/36 of itself plus its neighbours': the
    // centre's limit rises by 4/9.
    let moved = DVec3::new(0.5, 0.5, top_centre() + 4.0 / 9.0);
    assert!(nearest_vertex(moved, &edited) < 1e-5, "{}", nearest_vertex(moved, &edited));
    assert!((edited.bounds().unwrap().1.z as f64 - moved.z).abs() < 1e-5);
    assert!(nearest_vertex(DVec3::new(0.5, 0.5, top_centre()), &plain) < 1e-5);
    // A level-1 vertex's basis reaches two level-1 faces (half the cube's side) around it:
    // below z = 0.4 the surface is the unedited one, within the two tolerances.
    let mut far = 0;
    for p in edited.positions.iter().map(|p| p.as_dvec3()).filter(|p| p.z < 0.4) {
        let d = distance_to_mesh(p, &plain);
        assert!(d <= 2.0 * EPS, "{p} is {d} from the unedited surface");
        far += 1;
    }
    assert!(far > 100, "{far}");
}

#[test]
fn a_hole_edit_removes_exactly_the_named_child_face() {
    // Face 1, child 1: the quarter of the top at its vertex 1, (1, 0, 1). The children's
    // shared edges lie on x = 1/2 and y = 1/2 by the cube's mirror symmetries.
    let m = cube(vec![edit("faceedit", vec![2, 1, 1], Vec::new(), &["hole"])]);
    assert!(!m.is_closed());
    let mut up_facing = [0usize; 4];
    for t in 0..m.triangle_count() {
        let [a, b, c] = m.triangle(t).map(|p| p.as_dvec3());
        let normal = (b - a).cross(c - a).normalize();
        if normal.z < 0.9 {
            continue;
        }
        let centroid = (a + b + c) / 3.0;
        let quarter = usize::from(centroid.x > 0.5) + 2 * usize::from(centroid.y > 0.5);
        up_facing[quarter] += 1;
    }
    // Quarters: 0 at (0, 0), 1 at (1, 0) (the hole), 2 at (0, 1), 3 at (1, 1).
    assert_eq!(up_facing[1], 0, "{up_facing:?}");
    assert!(up_facing[0] > 10 && up_facing[2] > 10 && up_facing[3] > 10, "{up_facing:?}");
    // A hole at level 0 is the `hole` tag.
    let level0 = cube(vec![edit("faceedit", vec![1, 1], Vec::new(), &["hole"])]);
    let tag =
        subdivision(&CUBE_POSITIONS, &CUBE_FACES, vec![super::subdiv::tag("hole", vec![1], Vec::new())]);
    let tagged = tessellate(&Shape::SubdivisionMesh(tag), &Tolerance::absolute(EPS)).unwrap();
    assert_eq!(level0, tagged);
}

#[test]
fn a_vertex_sharpness_edit_pins_the_limit_at_the_level_1_point() {
    // Face 1, child 0, vertex 0: the level-1 point of the cube's corner (0, 0, 1), by the smooth
    // rule (F + 2R) / 3 with face centres averaging (1/3, 1/3, 2/3) and edge midpoints
    // (1/6, 1/6, 5/6): (2/9, 2/9, 7/9). Infinitely sharp from level 1, it stays there.
    let corner = DVec3::new(2.0, 2.0, 7.0) / 9.0;
    let sharp = cube(vec![edit("vertexedit", vec![3, 1, 0, 0], vec![10.0], &["P", "sharpness", "set"])]);
    assert!(nearest_vertex(corner, &sharp) < 1e-6, "{}", nearest_vertex(corner, &sharp));
    let smooth = cube(Vec::new());
    assert!(nearest_vertex(corner, &smooth) > 1e-2, "{}", nearest_vertex(corner, &smooth));
}

/// The largest angle between the normals of the triangles around the vertex nearest `p`.
fn normal_spread_at(p: DVec3, mesh: &TriangleMesh) -> f64 {
    let (nearest, _) = mesh
        .positions
        .iter()
        .enumerate()
        .map(|(i, q)| (i as u32, q.as_dvec3().distance(p)))
        .fold((0, f64::INFINITY), |a, b| if b.1 < a.1 { b } else { a });
    let normals: Vec<DVec3> = (0..mesh.triangle_count())
        .filter(|&t| mesh.indices[t].contains(&nearest))
        .map(|t| {
            let [a, b, c] = mesh.triangle(t).map(|q| q.as_dvec3());
            (b - a).cross(c - a).normalize()
        })
        .collect();
    let mut largest = 0f64;
    for a in &normals {
        for b in &normals {
            largest = largest.max(a.angle_between(*b));
        }
    }
    largest.to_degrees()
}

#[test]
fn an_edge_sharpness_edit_makes_a_crease_from_its_level() {
    // The two level-1 halves of the top face's edge 0 ((0,0,1) to (1,0,1)): child 0's edge 0
    // (from the vertex point) and child 1's edge 0 (child 1 is labelled from the parent's
    // vertex 1, so its edge 0 runs from the edge point). Their shared edge point then follows
    // the crease rule, and the surface folds there.
    let halves = edit("edgeedit", vec![3, 1, 0, 0, 3, 1, 1, 0], vec![10.0, 10.0], &["set", "P", "sharpness"]);
    let creased = cube(vec![halves]);
    let smooth = cube(Vec::new());
    // The edge point's limit lies on the plane x = 1/2, outermost towards the edge.
    let on_edge = |m: &TriangleMesh| {
        m.positions
            .iter()
            .map(|p| p.as_dvec3())
            .filter(|p| (p.x - 0.5).abs() < 1e-5)
            .fold(DVec3::new(0.5, 0.5, 0.5), |a, b| if b.z - b.y > a.z - a.y { b } else { a })
    };
    let (crease, round) =
        (normal_spread_at(on_edge(&creased), &creased), normal_spread_at(on_edge(&smooth), &smooth));
    eprintln!("normal spread at the edge point: {crease} degrees creased, {round} smooth");
    assert!(crease > 40.0, "normals around the creased point differ by at most {crease} degrees");
    assert!(round < 15.0, "normals around the smooth point differ by {round} degrees");
}
