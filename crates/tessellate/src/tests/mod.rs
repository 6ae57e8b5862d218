//! Tests of the tessellators against closed-form surfaces.

mod blobby;
mod curves;
mod displace;
mod hedits;
mod keys;
mod nurbs;
mod patch;
mod placed;
mod polygon;
mod props;
mod quadric;
mod subdiv;

use super::TriangleMesh;
use glam::DVec3;

/// Asserts the invariants every mesh keeps: finite data, indices in range, unit normals, one
/// face index per triangle, no triangle with a repeated vertex.
pub(super) fn assert_well_formed(mesh: &TriangleMesh) {
    assert_eq!(mesh.indices.len(), mesh.face_index.len());
    for p in &mesh.positions {
        assert!(p.is_finite(), "position {p}");
    }
    for tri in &mesh.indices {
        for &i in tri {
            assert!((i as usize) < mesh.positions.len(), "index {i} of {}", mesh.positions.len());
        }
        assert!(tri[0] != tri[1] && tri[1] != tri[2] && tri[0] != tri[2], "degenerate {tri:?}");
    }
    if let Some(n) = &mesh.normals {
        assert_eq!(n.len(), mesh.positions.len());
        for v in n {
            assert!((v.length() - 1.0).abs() < 1e-4, "normal {v}");
        }
    }
    if let Some(st) = &mesh.st {
        assert_eq!(st.len(), mesh.positions.len());
        assert!(st.iter().all(|v| v.is_finite()));
    }
}

/// Asserts every triangle's winding agrees with its vertex normals (the cross product of the
/// triangle points to the same side as each normal, up to `slack` in cosine).
pub(super) fn assert_normals_follow_winding(mesh: &TriangleMesh, slack: f64) {
    let normals = mesh.normals.as_ref().expect("normals");
    for t in 0..mesh.triangle_count() {
        let cross = mesh.face_cross(t);
        if cross.length() == 0.0 {
            continue;
        }
        let face = cross.normalize();
        for &i in &mesh.indices[t] {
            let n = normals[i as usize].as_dvec3();
            assert!(face.dot(n) > -slack, "triangle {t}: face normal {face} against vertex normal {n}");
        }
    }
}

/// The largest of `distance(x)` over every vertex, edge midpoint and triangle centroid.
pub(super) fn max_deviation(mesh: &TriangleMesh, distance: impl Fn(DVec3) -> f64) -> (f64, f64) {
    let vertex_max = mesh
        .indices
        .iter()
        .flatten()
        .map(|&i| distance(mesh.positions[i as usize].as_dvec3()))
        .fold(0.0, f64::max);
    let mut inner_max = 0.0f64;
    for t in 0..mesh.triangle_count() {
        let [a, b, c] = mesh.triangle(t).map(|p| p.as_dvec3());
        for q in [(a + b + c) / 3.0, (a + b) / 2.0, (b + c) / 2.0, (c + a) / 2.0] {
            inner_max = inner_max.max(distance(q));
        }
    }
    (vertex_max, inner_max)
}

/// Distance from `p` to triangle `abc` (Ericson, Real-Time Collision Detection, 5.1.5).
pub(super) fn point_triangle_distance(p: DVec3, a: DVec3, b: DVec3, c: DVec3) -> f64 {
    let (ab, ac, ap) = (b - a, c - a, p - a);
    let (d1, d2) = (ab.dot(ap), ac.dot(ap));
    if d1 <= 0.0 && d2 <= 0.0 {
        return p.distance(a);
    }
    let bp = p - b;
    let (d3, d4) = (ab.dot(bp), ac.dot(bp));
    if d3 >= 0.0 && d4 <= d3 {
        return p.distance(b);
    }
    let vc = d1 * d4 - d3 * d2;
    if vc <= 0.0 && d1 >= 0.0 && d3 <= 0.0 {
        return p.distance(a + ab * (d1 / (d1 - d3)));
    }
    let cp = p - c;
    let (d5, d6) = (ab.dot(cp), ac.dot(cp));
    if d6 >= 0.0 && d5 <= d6 {
        return p.distance(c);
    }
    let vb = d5 * d2 - d1 * d6;
    if vb <= 0.0 && d2 >= 0.0 && d6 <= 0.0 {
        return p.distance(a + ac * (d2 / (d2 - d6)));
    }
    let va = d3 * d6 - d5 * d4;
    if va <= 0.0 && d4 - d3 >= 0.0 && d5 - d6 >= 0.0 {
        return p.distance(b + (c - b) * ((d4 - d3) / ((d4 - d3) + (d5 - d6))));
    }
    let denom = 1.0 / (va + vb + vc);
    p.distance(a + ab * (vb * denom) + ac * (vc * denom))
}

/// The largest distance from the vertices of `fine` (a sample of them) to the triangles of
/// `coarse` (brute force).
pub(super) fn max_distance_to_mesh(fine: &TriangleMesh, coarse: &TriangleMesh) -> f64 {
    let tris: Vec<[DVec3; 3]> =
        (0..coarse.triangle_count()).map(|t| coarse.triangle(t).map(|p| p.as_dvec3())).collect();
    let mut worst = 0.0f64;
    // A spread-out sample of at most about 2000 vertices keeps this quick.
    let stride = (fine.positions.len() / 2000).max(1);
    for p in fine.positions.iter().step_by(stride) {
        let p = p.as_dvec3();
        let d =
            tris.iter().map(|[a, b, c]| point_triangle_distance(p, *a, *b, *c)).fold(f64::INFINITY, f64::min);
        worst = worst.max(d);
    }
    worst
}
