use super::polygon::float_param;
use super::{assert_normals_follow_winding, assert_well_formed, max_deviation};
use crate::{TessellateError, Tolerance, TriangleMesh, tessellate};
use glam::{DVec3, Vec2, Vec3, Vec4};
use rib_parser::scene::{Basis, ParamList, ParamType, PatchKind, PatchMesh, Shape, StorageClass, Wrap};

pub(crate) const BEZIER: Basis = Basis {
    matrix: [-1.0, 3.0, -3.0, 1.0, 3.0, -6.0, 3.0, 0.0, -3.0, 3.0, 0.0, 0.0, 1.0, 0.0, 0.0, 0.0],
    step: 3,
};

pub(crate) fn bspline() -> Basis {
    let m = [-1.0, 3.0, -3.0, 1.0, 3.0, -6.0, 3.0, 0.0, -3.0, 0.0, 3.0, 0.0, 1.0, 4.0, 1.0, 0.0];
    Basis { matrix: m.map(|x: f32| x / 6.0), step: 1 }
}

fn catmull_rom() -> Basis {
    let m = [-1.0, 3.0, -3.0, 1.0, 2.0, -5.0, 4.0, -1.0, -1.0, 0.0, 1.0, 0.0, 0.0, 2.0, 0.0, 0.0];
    Basis { matrix: m.map(|x: f32| x / 2.0), step: 1 }
}

const HERMITE: Basis = Basis {
    matrix: [2.0, 1.0, -2.0, 1.0, -3.0, -2.0, 3.0, -1.0, 0.0, 1.0, 0.0, 0.0, 1.0, 0.0, 0.0, 0.0],
    step: 2,
};

const POWER: Basis = Basis {
    matrix: [1.0, 0.0, 0.0, 0.0, 0.0, 1.0, 0.0, 0.0, 0.0, 0.0, 1.0, 0.0, 0.0, 0.0, 0.0, 1.0],
    step: 4,
};

pub(crate) fn mesh(
    kind: PatchKind,
    nu: u32,
    nv: u32,
    wrap: (Wrap, Wrap),
    basis: Basis,
    positions: Vec<Vec4>,
) -> Shape {
    Shape::Patches(PatchMesh {
        kind,
        nu,
        nv,
        u_wrap: wrap.0,
        v_wrap: wrap.1,
        u_basis: basis,
        v_basis: basis,
        positions,
        primvars: ParamList::default(),
    })
}

fn run(shape: &Shape, eps: f64) -> TriangleMesh {
    let m = tessellate(shape, &Tolerance::absolute(eps)).unwrap();
    assert_well_formed(&m);
    assert_normals_follow_winding(&m, 1e-6);
    m
}

/// `z = x^2 + y^2` over the unit square as one bicubic Bezier patch (degree-elevated).
fn paraboloid_bezier() -> Shape {
    let zs = [0.0, 0.0, 1.0 / 3.0, 1.0];
    let mut p = Vec::new();
    for j in 0..4 {
        for i in 0..4 {
            p.push(Vec4::new(i as f32 / 3.0, j as f32 / 3.0, zs[i] + zs[j], 1.0));
        }
    }
    mesh(PatchKind::Bicubic, 4, 4, (Wrap::NonPeriodic, Wrap::NonPeriodic), BEZIER, p)
}

fn paraboloid_distance(p: DVec3) -> f64 {
    (p.z - p.x * p.x - p.y * p.y).abs() / (1.0 + 4.0 * p.x * p.x + 4.0 * p.y * p.y).sqrt()
}

#[test]
fn a_bicubic_bezier_patch_stays_within_tolerance() {
    for eps in [1e-2, 1e-3, 1e-4] {
        let m = run(&paraboloid_bezier(), eps);
        let (on, inside) = max_deviation(&m, paraboloid_distance);
        assert!(on < 1e-6, "vertices on the surface: {on}");
        assert!(inside <= eps, "{eps}: {inside}");
        assert!(inside > eps / 8.0, "{eps}: needlessly fine ({inside}, {} triangles)", m.triangle_count());
        // dPdu x dPdv: u along x, v along y, so the normal has +z.
        let n = m.normals.as_ref().unwrap();
        assert!(n.iter().all(|n| n.z > 0.0));
    }
}

#[test]
fn power_basis_gives_the_same_surface() {
    // z = u^2 + v^2, x = u, y = v in power form: G[b][a] multiplies u^(3-a) v^(3-b).
    let mut p = vec![Vec4::ZERO; 16];
    let at = |a: usize, b: usize| b * 4 + a;
    p[at(1, 3)].z = 1.0; // u^2
    p[at(3, 1)].z = 1.0; // v^2
    p[at(2, 3)].x = 1.0; // u
    p[at(3, 2)].y = 1.0; // v
    p[at(3, 3)].w = 1.0; // w = 1
    let shape = mesh(PatchKind::Bicubic, 4, 4, (Wrap::NonPeriodic, Wrap::NonPeriodic), POWER, p);
    let m = run(&shape, 1e-3);
    let (on, inside) = max_deviation(&m, paraboloid_distance);
    assert!(on < 1e-6 && inside <= 1e-3, "{on} {inside}");
}

#[test]
fn a_bilinear_patch_is_the_hyperbolic_paraboloid() {
    let p = vec![
        Vec4::new(0.0, 0.0, 0.0, 1.0),
        Vec4::new(1.0, 0.0, 0.0, 1.0),
        Vec4::new(0.0, 1.0, 0.0, 1.0),
        Vec4::new(1.0, 1.0, 1.0, 1.0),
    ];
    let shape = mesh(PatchKind::Bilinear, 2, 2, (Wrap::NonPeriodic, Wrap::NonPeriodic), BEZIER, p);
    for eps in [1e-1, 1e-3] {
        let m = run(&shape, eps);
        let d = |p: DVec3| (p.z - p.x * p.y).abs() / (1.0 + p.x * p.x + p.y * p.y).sqrt();
        let (on, inside) = max_deviation(&m, d);
        assert!(on < 1e-6 && inside <= eps, "{eps}: {on} {inside}");
    }
    // A flat bilinear patch is two triangles whatever the tolerance.
    let flat = vec![
        Vec4::new(0.0, 0.0, 0.0, 1.0),
        Vec4::new(1.0, 0.0, 0.0, 1.0),
        Vec4::new(0.0, 1.0, 0.0, 1.0),
        Vec4::new(1.0, 1.0, 0.0, 1.0),
    ];
    let m = run(&mesh(PatchKind::Bilinear, 2, 2, (Wrap::NonPeriodic, Wrap::NonPeriodic), BEZIER, flat), 1e-6);
    assert_eq!(m.triangle_count(), 2);
}

/// A quarter cylinder of radius 1 and height 1: a rational quadratic arc in u, degree-elevated
/// to a cubic, extruded linearly in v.
fn rational_quarter_cylinder() -> Shape {
    let h = std::f32::consts::FRAC_1_SQRT_2;
    let quad = [Vec4::new(1.0, 0.0, 0.0, 1.0), Vec4::new(h, h, 0.0, h), Vec4::new(0.0, 1.0, 0.0, 1.0)];
    let cubic = [quad[0], quad[0] / 3.0 + quad[1] * 2.0 / 3.0, quad[1] * 2.0 / 3.0 + quad[2] / 3.0, quad[2]];
    let mut p = Vec::new();
    for j in 0..4 {
        for c in cubic {
            // Homogeneous z: z * w.
            p.push(Vec4::new(c.x, c.y, j as f32 / 3.0 * c.w, c.w));
        }
    }
    mesh(PatchKind::Bicubic, 4, 4, (Wrap::NonPeriodic, Wrap::NonPeriodic), BEZIER, p)
}

#[test]
fn homogeneous_control_points_make_an_exact_circle() {
    for eps in [1e-2, 1e-4] {
        let m = run(&rational_quarter_cylinder(), eps);
        let (on, inside) = max_deviation(&m, |p| (p.truncate().length() - 1.0).abs());
        assert!(on < 1e-6, "the rational arc is a true circle: {on}");
        assert!(inside <= eps, "{eps}: {inside}");
        let (lo, hi) = m.bounds().unwrap();
        assert!(lo.z.abs() < 1e-6 && (hi.z - 1.0).abs() < 1e-6);
        // Normals: u runs counter-clockwise, v up: outward.
        let n = m.normals.as_ref().unwrap();
        for (p, n) in m.positions.iter().zip(n) {
            assert!(n.truncate().dot(p.truncate()) > 0.999);
        }
    }
}

/// A closed B-spline tube: `ring` points around, `rows` along, periodic in u, and in v when
/// `closed`.
fn bspline_torus(ring: usize, rows: usize) -> Vec<Vec4> {
    let mut p = Vec::new();
    for j in 0..rows {
        let phi = j as f32 / rows as f32 * std::f32::consts::TAU;
        for i in 0..ring {
            let theta = i as f32 / ring as f32 * std::f32::consts::TAU;
            let rho = 2.0 + 0.5 * phi.cos();
            p.push(Vec4::new(rho * theta.cos(), rho * theta.sin(), 0.5 * phi.sin(), 1.0));
        }
    }
    p
}

#[test]
fn a_periodic_bspline_mesh_is_closed() {
    let shape =
        mesh(PatchKind::Bicubic, 8, 6, (Wrap::Periodic, Wrap::Periodic), bspline(), bspline_torus(8, 6));
    for eps in [1e-1, 1e-3] {
        let m = run(&shape, eps);
        assert!(m.is_closed(), "{} open edges", m.boundary_edge_count());
        assert!(m.signed_volume() > 0.0);
        // 8 x 6 patches, each with its index.
        let mut faces: Vec<u32> = m.face_index.clone();
        faces.sort();
        faces.dedup();
        assert_eq!(faces, (0..48).collect::<Vec<_>>());
    }
}

#[test]
fn uniform_bspline_corners_are_the_one_four_one_average() {
    let ctrl = bspline_torus(8, 6);
    let shape = mesh(PatchKind::Bicubic, 8, 6, (Wrap::Periodic, Wrap::Periodic), bspline(), ctrl.clone());
    let m = run(&shape, 1e-2);
    let at = |i: usize, j: usize| ctrl[(j % 6) * 8 + i % 8].truncate().as_dvec3();
    // The corner of patches (i, j) is the tensor (1, 4, 1) / 6 average around control point
    // (i + 1, j + 1).
    for (i, j) in [(0, 0), (3, 2), (7, 5)] {
        let mut expect = DVec3::ZERO;
        for (b, wb) in [1.0, 4.0, 1.0].iter().enumerate() {
            for (a, wa) in [1.0, 4.0, 1.0].iter().enumerate() {
                expect += wa * wb / 36.0 * at(i + a, j + b);
            }
        }
        let nearest = m.positions.iter().map(|p| p.as_dvec3().distance(expect)).fold(f64::INFINITY, f64::min);
        assert!(nearest < 1e-5, "corner ({i}, {j}): {nearest}");
    }
}

#[test]
fn catmull_rom_and_hermite_interpolate_their_points() {
    // Catmull-Rom: a 5 x 4 grid with a bump; the mesh passes through the interior points.
    let mut p = Vec::new();
    for j in 0..4 {
        for i in 0..5 {
            p.push(Vec4::new(i as f32, j as f32, ((i * 7 + j * 3) % 5) as f32 * 0.2, 1.0));
        }
    }
    let m = run(
        &mesh(PatchKind::Bicubic, 5, 4, (Wrap::NonPeriodic, Wrap::NonPeriodic), catmull_rom(), p.clone()),
        1e-3,
    );
    for j in 1..3 {
        for i in 1..4 {
            let q = p[j * 5 + i].truncate();
            assert!(m.positions.iter().any(|v| v.distance(q) < 1e-5), "({i}, {j}) {q}");
        }
    }
    // Hermite (step 2): control points are P0, T0, P1, T1 in each direction.
    let pts = [
        Vec4::new(0.0, 0.0, 0.0, 1.0),
        Vec4::new(1.0, 0.0, 1.0, 0.0),
        Vec4::new(1.0, 0.0, 0.0, 1.0),
        Vec4::new(1.0, 0.0, -1.0, 0.0),
    ];
    let tangents_v = [Vec4::new(0.0, 1.0, 0.0, 0.0), Vec4::new(0.0, 0.0, 0.0, 0.0)];
    let mut h = Vec::new();
    for j in 0..4 {
        for i in 0..4 {
            let base = pts[i];
            h.push(match j {
                0 => base,
                1 => tangents_v[0],
                2 => {
                    if base.w == 1.0 {
                        base + Vec4::new(0.0, 1.0, 0.0, 0.0)
                    } else {
                        base
                    }
                }
                _ => tangents_v[0],
            });
        }
    }
    let m = run(&mesh(PatchKind::Bicubic, 4, 4, (Wrap::NonPeriodic, Wrap::NonPeriodic), HERMITE, h), 1e-3);
    for corner in [glam::Vec3::ZERO, glam::Vec3::X, glam::Vec3::Y, glam::Vec3::new(1.0, 1.0, 0.0)] {
        assert!(m.positions.iter().any(|v| v.distance(corner) < 1e-6), "{corner}");
    }
}

#[test]
fn varying_st_is_interpolated_over_patch_corners() {
    let Shape::Patches(mut pm) = paraboloid_bezier() else { unreachable!() };
    pm.primvars.0.push(float_param(
        "st",
        StorageClass::Varying,
        ParamType::Float,
        2,
        vec![0.0, 0.0, 2.0, 0.0, 0.0, 4.0, 2.0, 4.0],
    ));
    let m = run(&Shape::Patches(pm), 1e-2);
    let st = m.st.as_ref().unwrap();
    for (p, st) in m.positions.iter().zip(st) {
        // x = u and y = v on this patch.
        assert!((st.as_dvec2() - glam::DVec2::new(2.0 * p.x as f64, 4.0 * p.y as f64)).length() < 1e-5);
    }
    // Without st, (s, t) = (u, v) over the mesh.
    let m = run(&paraboloid_bezier(), 1e-2);
    assert!(m.st.as_ref().unwrap().contains(&Vec2::new(1.0, 1.0)));
}

#[test]
fn bad_patch_meshes_are_errors() {
    let tol = Tolerance::default();
    let bad_count =
        mesh(PatchKind::Bicubic, 5, 4, (Wrap::NonPeriodic, Wrap::NonPeriodic), BEZIER, vec![Vec4::W; 20]);
    assert!(matches!(tessellate(&bad_count, &tol), Err(TessellateError::InvalidShape { .. })));
    let short =
        mesh(PatchKind::Bicubic, 4, 4, (Wrap::NonPeriodic, Wrap::NonPeriodic), BEZIER, vec![Vec4::W; 15]);
    assert!(matches!(tessellate(&short, &tol), Err(TessellateError::InvalidShape { .. })));
    let step0 = mesh(
        PatchKind::Bicubic,
        4,
        4,
        (Wrap::NonPeriodic, Wrap::NonPeriodic),
        Basis { step: 0, ..BEZIER },
        vec![Vec4::W; 16],
    );
    assert!(matches!(tessellate(&step0, &tol), Err(TessellateError::InvalidShape { .. })));
    let zero_w =
        mesh(PatchKind::Bilinear, 2, 2, (Wrap::NonPeriodic, Wrap::NonPeriodic), BEZIER, vec![Vec4::ZERO; 4]);
    assert!(matches!(tessellate(&zero_w, &tol), Err(TessellateError::NonFinite { .. })));
    // Weights of opposite sign put a pole on the surface.
    let pole = vec![
        Vec4::new(0.0, 0.0, 0.0, 1.0),
        Vec4::new(1.0, 0.0, 0.0, -1.0),
        Vec4::new(0.0, 1.0, 0.0, 1.0),
        Vec4::new(1.0, 1.0, 0.0, -1.0),
    ];
    let pole = mesh(PatchKind::Bilinear, 2, 2, (Wrap::NonPeriodic, Wrap::NonPeriodic), BEZIER, pole);
    assert!(matches!(tessellate(&pole, &tol), Err(TessellateError::NonFinite { .. })));
    // A single point (all control points equal): no area, no triangles, no NaN.
    let point = mesh(
        PatchKind::Bicubic,
        4,
        4,
        (Wrap::NonPeriodic, Wrap::NonPeriodic),
        BEZIER,
        vec![Vec4::new(1.0, 2.0, 3.0, 1.0); 16],
    );
    let m = tessellate(&point, &tol).unwrap();
    assert!(m.is_empty());
}

#[test]
fn hermite_and_power_points_are_not_homogeneous() {
    // P(u, v) = (u, v, u v) in the power basis: the coefficients of u (x), v (y) and u v (z).
    // With "P" the weights are not summed: summing them (all 1) would divide by
    // (u^3 + u^2 + u + 1)(v^3 + v^2 + v + 1) and bend the surface away.
    let mut p = vec![Vec4::new(0.0, 0.0, 0.0, 1.0); 16];
    p[3 * 4 + 2] = Vec4::new(1.0, 0.0, 0.0, 1.0);
    p[2 * 4 + 3] = Vec4::new(0.0, 1.0, 0.0, 1.0);
    p[2 * 4 + 2] = Vec4::new(0.0, 0.0, 1.0, 1.0);
    let power = rib_parser::basis::named_basis("power").unwrap();
    let m = run(&mesh(PatchKind::Bicubic, 4, 4, (Wrap::NonPeriodic, Wrap::NonPeriodic), power, p), 1e-3);
    let (lo, hi) = m.bounds().unwrap();
    assert!(lo.abs().max_element() < 1e-6 && (hi - Vec3::ONE).abs().max_element() < 1e-6, "{lo} {hi}");
    for v in &m.positions {
        assert!((v.z - v.x * v.y).abs() < 1e-6, "{v}");
    }
    // A Hermite patch (3u, v, 0): positions and tangents (P0, T0, P1, T1) of x = 3u in u and
    // of y = v in v, each times the constant 1 (positions 1, tangents 0) in the other direction;
    // the tangent entries carry weights that do not sum to one.
    let (x, y, one) = ([0.0, 3.0, 3.0, 3.0], [0.0, 1.0, 1.0, 1.0], [1.0, 0.0, 1.0, 0.0]);
    let h: Vec<Vec4> =
        (0..16).map(|k| Vec4::new(x[k % 4] * one[k / 4], y[k / 4] * one[k % 4], 0.0, 1.0)).collect();
    let hermite = rib_parser::basis::named_basis("hermite").unwrap();
    let m = run(&mesh(PatchKind::Bicubic, 4, 4, (Wrap::NonPeriodic, Wrap::NonPeriodic), hermite, h), 1e-3);
    let (lo, hi) = m.bounds().unwrap();
    assert!(
        (lo - Vec3::ZERO).abs().max_element() < 1e-6
            && (hi - Vec3::new(3.0, 1.0, 0.0)).abs().max_element() < 1e-6,
        "{lo} {hi}"
    );
}
