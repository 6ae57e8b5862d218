//! `Blobby` against closed forms: a lone ellipsoid is the ellipsoid of half its matrix's size.

use super::assert_well_formed;
use crate::{BLOBBY_THRESHOLD, BlobbyField, TessellateError, Tolerance, tessellate};
use glam::DVec3;
use rib_parser::scene::{Blobby, ParamList, Shape};

/// A 1001 ellipsoid with the row-vector matrix `diag(sx, sy, sz)` translated by `t`.
pub(crate) fn ellipsoid_floats(s: [f32; 3], t: [f32; 3]) -> Vec<f32> {
    vec![s[0], 0., 0., 0., 0., s[1], 0., 0., 0., 0., s[2], 0., t[0], t[1], t[2], 1.]
}

pub(crate) fn blobby(leaf_count: u32, code: Vec<i32>, floats: Vec<f32>) -> Shape {
    Shape::Blobby(Blobby {
        leaf_count,
        code,
        floats,
        strings: vec![String::new()],
        primvars: ParamList::default(),
    })
}

#[test]
fn a_lone_ellipsoid_is_the_sphere_of_half_its_scale() {
    // Scale 2: the level set (1 - r^2)^3 = 0.421875 is r = 1/2 in the leaf, radius 1 here.
    let shape = blobby(1, vec![1001, 0], ellipsoid_floats([2.0; 3], [0.5, -1.0, 2.0]));
    let eps = 1e-3;
    let mesh = tessellate(&shape, &Tolerance::absolute(eps)).unwrap();
    assert_well_formed(&mesh);
    assert!(mesh.is_closed(), "a lone blob is a closed surface");
    let centre = DVec3::new(0.5, -1.0, 2.0);
    for p in &mesh.positions {
        let r = (p.as_dvec3() - centre).length();
        assert!((r - 1.0).abs() < 1e-6, "vertex at radius {r}");
    }
    // Chord error: every centroid within eps of the sphere (inside it).
    for t in 0..mesh.triangle_count() {
        let [a, b, c] = mesh.triangle(t).map(|p| p.as_dvec3());
        let r = ((a + b + c) / 3.0 - centre).length();
        assert!(r <= 1.0 + 1e-6 && r >= 1.0 - eps, "centroid at radius {r}");
    }
    // Outward winding and normals, and the enclosed volume of the unit sphere.
    let volume = mesh.signed_volume();
    let exact = 4.0 / 3.0 * std::f64::consts::PI;
    assert!(volume < exact && volume > exact * (1.0 - 3.0 * eps), "volume {volume}");
}

#[test]
fn operators_follow_the_spec() {
    // Two unit-scale blobs far apart: add of both, max, min (empty), sub (first minus second).
    let mut floats = ellipsoid_floats([1.0; 3], [0.0; 3]);
    floats.extend(ellipsoid_floats([1.0; 3], [0.2, 0.0, 0.0]));
    let field = |code: Vec<i32>| match blobby(2, code, floats.clone()) {
        Shape::Blobby(b) => BlobbyField::new(&b).unwrap(),
        _ => unreachable!(),
    };
    let mut s = Vec::new();
    let p = DVec3::new(0.1, 0.0, 0.0);
    let k = |r: f64| (1.0 - r * r).powi(3);
    let (a, b) = (k(0.1), k(0.1));
    let check = |code: Vec<i32>, want: f64, s: &mut Vec<_>| {
        let (v, _) = field(code.clone()).eval(p, s);
        assert!((v - want).abs() < 1e-6, "{code:?}: {v} != {want}");
    };
    check(vec![1001, 0, 1001, 16, 0, 2, 0, 1], a + b, &mut s);
    check(vec![1001, 0, 1001, 16, 1, 2, 0, 1], a * b, &mut s);
    check(vec![1001, 0, 1001, 16, 4, 0, 1], a - b, &mut s);
    check(vec![1001, 0, 1001, 16, 5, 0, 1], a / b, &mut s);
    check(vec![1001, 0, 1001, 16, 6, 0], -a, &mut s);
    check(vec![1001, 0, 1001, 16, 7, 1], b, &mut s);
    // The gradient is exact: compare with central differences.
    let f = field(vec![1001, 0, 1001, 16, 1, 2, 0, 1]);
    let q = DVec3::new(0.13, 0.21, -0.07);
    let (_, g) = f.eval(q, &mut s);
    let d = 1e-6;
    for axis in 0..3 {
        let e = DVec3::AXES[axis] * d;
        let numeric = (f.eval(q + e, &mut s).0 - f.eval(q - e, &mut s).0) / (2.0 * d);
        assert!((numeric - g[axis]).abs() < 1e-6, "axis {axis}: {numeric} vs {}", g[axis]);
    }
    assert_eq!(BLOBBY_THRESHOLD, 0.75f64.powi(3));
}

#[test]
fn a_segment_is_a_capsule() {
    // Segment from (0,0,0) to (2,0,0), radius 1, identity matrix: the surface is a capsule of
    // radius 1/2 around it.
    let mut floats = vec![0., 0., 0., 2., 0., 0., 1.];
    floats.extend(ellipsoid_floats([1.0; 3], [0.0; 3]));
    let mesh = tessellate(&blobby(1, vec![1002, 0], floats), &Tolerance::absolute(1e-3)).unwrap();
    assert!(mesh.is_closed());
    for p in &mesh.positions {
        let p = p.as_dvec3();
        let t = p.x.clamp(0.0, 2.0);
        let d = (p - DVec3::new(t, 0.0, 0.0)).length();
        assert!((d - 0.5).abs() < 1e-6, "vertex {p} at distance {d}");
    }
}

#[test]
fn hostile_programs_are_bounded_or_refused() {
    // A plane needs a depth map: refused with a message, not skipped silently.
    let mut floats = ellipsoid_floats([1.0; 3], [0.0; 3]);
    floats.extend([0.0; 4]);
    let b = Blobby {
        leaf_count: 1,
        code: vec![1003, 0, 16],
        floats,
        strings: vec!["flat.zfile".into()],
        primvars: ParamList::default(),
    };
    let err = tessellate(&Shape::Blobby(b), &Tolerance::absolute(1e-3)).unwrap_err();
    assert!(matches!(err, TessellateError::InvalidShape { .. }) && err.to_string().contains("flat.zfile"));
    // Half a million chained identities over one blob: the work limit refuses it quickly.
    let mut code = vec![1001, 0];
    for i in 0..500_000 {
        code.extend([7, i]);
    }
    let err = tessellate(&blobby(1, code, ellipsoid_floats([1.0; 3], [0.0; 3])), &Tolerance::absolute(1e-5))
        .unwrap_err();
    assert!(err.to_string().contains("limit"), "{err}");
}
