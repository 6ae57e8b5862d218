//! Keys of deforming shapes whose own tessellations differ (other curvature, so other rates)
//! come out with the same triangles, each key's vertices on its own surface; Blobby keys whose
//! blobs come apart are refused.

use super::blobby::{blobby, ellipsoid_floats};
use super::nurbs::nurbs_cylinder;
use super::patch::{BEZIER, mesh};
use super::polygon::float_param;
use super::polygon::{CUBE_FACES, CUBE_POSITIONS};
use super::subdiv::subdivision;
use super::{assert_well_formed, max_distance_to_mesh};
use crate::subdiv::{Planning, SubdivPlan, tessellate_subdivision_planned};
use crate::{
    BLOBBY_THRESHOLD, BlobbyField, Tolerance, TriangleMesh, tessellate, tessellate_placed,
    tessellate_placed_keys,
};
use glam::{DMat4, Vec3, Vec4};
use rib_parser::scene::{ParamType, PatchKind, Shape, StorageClass, Wrap};

fn keyed(keys: &[&Shape], eps: f64) -> Vec<TriangleMesh> {
    let meshes = tessellate_placed_keys(keys, &DMat4::IDENTITY, false, &Tolerance::absolute(eps)).unwrap();
    assert_eq!(meshes.len(), keys.len());
    for m in &meshes {
        assert_eq!(m.indices, meshes[0].indices);
        assert_eq!(m.face_index, meshes[0].face_index);
        assert_eq!(m.positions.len(), meshes[0].positions.len());
        assert_eq!(m.normals.as_ref().map(Vec::len), Some(m.positions.len()));
    }
    meshes
}

/// The unit square as one bicubic Bezier patch, its four inner control points raised by `h`:
/// `z = 9 h u (1 - u) v (1 - v)` at `(x, y) = (u, v)`.
fn bump(h: f32) -> Shape {
    let mut p = Vec::new();
    for j in 0..4 {
        for i in 0..4 {
            let inner = (1..3).contains(&i) && (1..3).contains(&j);
            p.push(Vec4::new(i as f32 / 3.0, j as f32 / 3.0, if inner { h } else { 0.0 }, 1.0));
        }
    }
    mesh(PatchKind::Bicubic, 4, 4, (Wrap::NonPeriodic, Wrap::NonPeriodic), BEZIER, p)
}

#[test]
fn a_flat_and_a_bulging_patch_share_triangles_each_on_its_own_surface() {
    let (flat, bulging) = (bump(0.0), bump(1.0));
    let eps = 1e-3;
    let own = |s: &Shape| tessellate(s, &Tolerance::absolute(eps)).unwrap();
    // On their own the keys are diced at other rates.
    assert!(own(&flat).triangle_count() < own(&bulging).triangle_count());
    let meshes = keyed(&[&flat, &bulging], eps);
    // The bulging key decides, and keeps its own mesh.
    let placed = tessellate_placed(&bulging, &DMat4::IDENTITY, false, &Tolerance::absolute(eps)).unwrap();
    assert!(meshes[1] == placed, "the deciding key's mesh is not its own");
    for (key, h) in [(&meshes[0], 0.0), (&meshes[1], 1.0)] {
        assert_well_formed(key);
        for p in key.positions.iter().map(|p| p.as_dvec3()) {
            let z = 9.0 * h * p.x * (1.0 - p.x) * p.y * (1.0 - p.y);
            assert!((p.z - z).abs() < 1e-5, "key with h = {h}: {p} against z = {z}");
        }
    }
}

#[test]
fn patch_keys_with_texture_coordinates_keep_them_and_are_still_evaluated_at_their_parameters() {
    // st = (2u, 4v) at the corners: the vertex parameters must not be read from it.
    let with_st = |h: f32| {
        let Shape::Patches(mut pm) = bump(h) else { panic!("not a patch mesh") };
        let corners = vec![0.0, 0.0, 2.0, 0.0, 0.0, 4.0, 2.0, 4.0];
        pm.primvars.0.push(float_param("st", StorageClass::Varying, ParamType::Float, 2, corners));
        Shape::Patches(pm)
    };
    let (flat, bulging) = (with_st(0.0), with_st(1.0));
    let meshes = keyed(&[&flat, &bulging], 1e-3);
    for (key, h) in [(&meshes[0], 0.0), (&meshes[1], 1.0)] {
        let st = key.st.as_ref().expect("st");
        for (p, st) in key.positions.iter().map(|p| p.as_dvec3()).zip(st) {
            let z = 9.0 * h * p.x * (1.0 - p.x) * p.y * (1.0 - p.y);
            assert!((p.z - z).abs() < 1e-5, "key with h = {h}: {p} against z = {z}");
            assert!((st.as_dvec2() - glam::DVec2::new(2.0 * p.x, 4.0 * p.y)).length() < 1e-5, "{p} {st}");
        }
    }
}

#[test]
fn nurbs_cylinders_of_two_radii_share_triangles_each_on_its_own_circle() {
    let cylinder = |r: f32| Shape::NuPatch(nurbs_cylinder(r));
    let (thin, thick) = (cylinder(1.0), cylinder(3.0));
    let eps = 1e-3;
    let own = |s: &Shape| tessellate(s, &Tolerance::absolute(eps)).unwrap().triangle_count();
    assert!(own(&thin) < own(&thick));
    let meshes = keyed(&[&thin, &thick], eps);
    for (key, r) in [(&meshes[0], 1.0), (&meshes[1], 3.0)] {
        for p in key.positions.iter().map(|p| p.as_dvec3()) {
            assert!((p.truncate().length() - r).abs() < 1e-5 * r, "radius {r}: {p}");
        }
    }
}

#[test]
fn subdivision_keys_share_triangles_stay_closed_and_lie_on_their_own_limit_surfaces() {
    // The unit cube, and the cube with one corner pulled far out (another level and other
    // adaptively refined faces on its own).
    let cube = subdivision(&CUBE_POSITIONS, &CUBE_FACES, Vec::new());
    let mut pulled = cube.clone();
    pulled.positions[6] = Vec3::new(3.0, 2.5, 4.0);
    let (a, b) = (Shape::SubdivisionMesh(cube.clone()), Shape::SubdivisionMesh(pulled.clone()));
    let eps = 2e-3;
    let own = |s: &Shape, eps: f64| tessellate(s, &Tolerance::absolute(eps)).unwrap();
    assert_ne!(own(&a, eps).triangle_count(), own(&b, eps).triangle_count());
    let meshes = keyed(&[&a, &b], eps);
    for (k, key) in [&a, &b].into_iter().enumerate() {
        assert!(meshes[k].is_closed(), "key {k} is not closed");
        // Every vertex on the key's own limit surface: against a much finer mesh of it.
        let gap = max_distance_to_mesh(&meshes[k], &own(key, eps / 20.0));
        assert!(gap < 2.0 * eps, "key {k}: a vertex {gap} from its limit surface");
    }
}

#[test]
fn a_replayed_subdivision_plan_reproduces_the_recorded_mesh() {
    let mut pulled = subdivision(&CUBE_POSITIONS, &CUBE_FACES, Vec::new());
    pulled.positions[6] = Vec3::new(3.0, 2.5, 4.0);
    let tol = Tolerance::absolute(2e-3);
    let free = tessellate(&Shape::SubdivisionMesh(pulled.clone()), &tol).unwrap();
    let mut record = Planning::Record(SubdivPlan::default());
    let recorded = tessellate_subdivision_planned(&pulled, &tol, 1.0, &mut record).unwrap();
    let Planning::Record(plan) = record else { panic!("still recording") };
    let replayed = tessellate_subdivision_planned(&pulled, &tol, 1.0, &mut Planning::Replay(plan)).unwrap();
    // No zero-area triangle here, so recording changes nothing either.
    assert!(recorded == free, "recording changed the mesh");
    assert!(replayed == free, "replaying changed the mesh");
}

/// Two unit-size blobs (radius about 0.5 each) at `x = -d` and `d`, added.
fn two_blobs(d: f32) -> Shape {
    let mut floats = ellipsoid_floats([1.0; 3], [-d, 0.0, 0.0]);
    floats.extend(ellipsoid_floats([1.0; 3], [d, 0.0, 0.0]));
    blobby(2, vec![1001, 0, 1001, 16, 0, 2, 0, 1], floats)
}

#[test]
fn blobs_that_move_but_stay_merged_share_triangles_on_their_own_isosurfaces() {
    let (near, apart) = (two_blobs(0.2), two_blobs(0.35));
    let eps = 2e-3;
    let own = |s: &Shape| tessellate(s, &Tolerance::absolute(eps)).unwrap();
    assert_ne!(own(&near).indices, own(&apart).indices);
    let meshes = keyed(&[&near, &apart], eps);
    let mut scratch = Vec::new();
    for (key, shape) in meshes.iter().zip([&near, &apart]) {
        assert!(key.is_closed());
        let Shape::Blobby(b) = shape else { panic!("not a Blobby") };
        let field = BlobbyField::new(b).unwrap();
        for p in &key.positions {
            let (v, g) = field.eval(p.as_dvec3(), &mut scratch);
            // On the surface to f32 rounding.
            assert!((v - BLOBBY_THRESHOLD).abs() / g.length() < 1e-6, "{p}: off by {}", v - BLOBBY_THRESHOLD);
        }
    }
}

#[test]
fn blobs_that_come_apart_or_together_are_refused_with_the_reason() {
    let (merged, split) = (two_blobs(0.2), two_blobs(0.9));
    let tol = Tolerance::absolute(2e-3);
    let why = tessellate_placed_keys(&[&merged, &split], &DMat4::IDENTITY, false, &tol).unwrap_err();
    assert!(why.to_string().contains("cannot be mapped onto one another"), "{why}");
    // And blobs that come together.
    let why = tessellate_placed_keys(&[&split, &merged], &DMat4::IDENTITY, false, &tol).unwrap_err();
    assert!(why.to_string().contains("cannot be mapped onto one another"), "{why}");
}

/// A bicubic Bezier patch over `[x0, x0 + 1] x [0, 1]` whose control heights are `z(i, j)`.
fn heights(x0: f32, z: impl Fn(usize, usize) -> f32) -> Shape {
    let mut p = Vec::new();
    for j in 0..4 {
        for i in 0..4 {
            p.push(Vec4::new(x0 + i as f32 / 3.0, j as f32 / 3.0, z(i, j), 1.0));
        }
    }
    mesh(PatchKind::Bicubic, 4, 4, (Wrap::NonPeriodic, Wrap::NonPeriodic), BEZIER, p)
}

/// `[0, h, h, 0]`: the Bezier arch `3 h t (1 - t)`.
fn arch(k: usize, h: f32) -> f32 {
    if (1..3).contains(&k) { h } else { 0.0 }
}

#[test]
fn keys_curved_in_other_directions_are_each_diced_finely_enough() {
    // One key arches along u, the other along v: alone, each is diced finely only along its
    // own arch, so neither key's rates would do for the other.
    let h = 1.0;
    let (along_u, along_v) = (heights(0.0, |i, _| arch(i, h)), heights(0.0, |_, j| arch(j, h)));
    let eps = 1e-3;
    let meshes = keyed(&[&along_u, &along_v], eps);
    let own = |s: &Shape| tessellate(s, &Tolerance::absolute(eps)).unwrap().triangle_count();
    assert!(meshes[0].triangle_count() > own(&along_u).max(own(&along_v)));
    let surfaces: [&dyn Fn(f64, f64) -> f64; 2] =
        [&|u, _| 3.0 * h as f64 * u * (1.0 - u), &|_, v| 3.0 * h as f64 * v * (1.0 - v)];
    for (key, z) in meshes.iter().zip(surfaces) {
        assert_well_formed(key);
        let mut worst: f64 = 0.0;
        for t in &key.indices {
            let [a, b, c] = t.map(|i| key.positions[i as usize].as_dvec3());
            // x and y are the parameters: the flat triangle against the surface at its
            // centroid and edge midpoints.
            for p in [(a + b + c) / 3.0, (a + b) / 2.0, (b + c) / 2.0, (c + a) / 2.0] {
                worst = worst.max((p.z - z(p.x, p.y)).abs());
            }
        }
        assert!(worst <= eps, "a key is {worst} from its surface (eps {eps})");
    }
}

#[test]
fn neighbours_diced_at_their_keys_largest_rates_still_meet() {
    // Two patches share the side x = 1. At the first key that side arches (both patches arch
    // along v), at the second it is straight (one patch is flat, the other arches along u
    // with its ends flat and more curved, so that it alone would decide that patch's rates),
    // so each side's largest rate is the first key's, for both patches.
    let left = [heights(0.0, |_, j| arch(j, 1.0)), heights(0.0, |_, _| 0.0)];
    let right = [heights(1.0, |_, j| arch(j, 1.0)), heights(1.0, |i, _| arch(i, 2.0))];
    let eps = 1e-3;
    let l = keyed(&[&left[0], &left[1]], eps);
    let r = keyed(&[&right[0], &right[1]], eps);
    for key in 0..2 {
        // The vertices on x = 1 by parameter (y is the same sum on both sides), with their z.
        let on_side = |m: &TriangleMesh| {
            let mut side: Vec<(u32, f32)> =
                m.positions.iter().filter(|p| p.x == 1.0).map(|p| (p.y.to_bits(), p.z)).collect();
            side.sort_unstable_by_key(|s| s.0);
            side.dedup_by_key(|s| s.0);
            side
        };
        let (a, b) = (on_side(&l[key]), on_side(&r[key]));
        assert!(a.len() > 4, "the arched side is diced: {}", a.len());
        let ys = |s: &[(u32, f32)]| s.iter().map(|p| p.0).collect::<Vec<_>>();
        assert_eq!(ys(&a), ys(&b), "key {key}: the two patches' vertices on x = 1 are at other places");
        // The two surfaces are evaluated from their own sides: z agrees to rounding, which the
        // scene's SeamWelder snaps.
        for (p, q) in a.iter().zip(&b) {
            assert!((p.1 - q.1).abs() <= 1e-6, "key {key}: z {} against {}", p.1, q.1);
        }
    }
}
