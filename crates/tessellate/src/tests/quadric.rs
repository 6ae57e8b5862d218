use super::{assert_normals_follow_winding, assert_well_formed, max_deviation};
use crate::{TessellateError, Tolerance, TriangleMesh, tessellate};
use glam::{DVec3, Vec3};
use rib_parser::scene::Shape;
use std::f64::consts::PI;

fn rho(p: DVec3) -> f64 {
    p.truncate().length()
}

fn sphere(radius: f32, z_min: f32, z_max: f32, theta_max_degrees: f32) -> Shape {
    Shape::Sphere { radius, z_min, z_max, theta_max_degrees }
}

fn torus(major: f32, minor: f32, phi_min: f32, phi_max: f32, theta_max: f32) -> Shape {
    Shape::Torus {
        major_radius: major,
        minor_radius: minor,
        phi_min_degrees: phi_min,
        phi_max_degrees: phi_max,
        theta_max_degrees: theta_max,
    }
}

/// Distance from `p` to the (unbounded) surface of a quadric: exact for the sphere, cylinder,
/// cone, disk and torus, first order (|F| / |grad F|) for the paraboloid and hyperboloid, which
/// is far more accurate than the tolerances tested.
fn distance_to(shape: &Shape, p: DVec3) -> f64 {
    match *shape {
        Shape::Sphere { radius, .. } => (p.length() - radius.abs() as f64).abs(),
        Shape::Cylinder { radius, .. } => (rho(p) - radius.abs() as f64).abs(),
        Shape::Cone { height, radius, .. } => {
            let (h, r) = (height as f64, radius.abs() as f64);
            (h * rho(p) + r * p.z - r * h).abs() / (h * h + r * r).sqrt()
        }
        Shape::Disk { height, .. } => (p.z - height as f64).abs(),
        Shape::Paraboloid { r_max, z_max, .. } => {
            let a = z_max as f64 / (r_max as f64).powi(2);
            let f = p.z - a * rho(p).powi(2);
            f.abs() / (1.0 + 4.0 * a * a * rho(p).powi(2)).sqrt()
        }
        Shape::Hyperboloid { point1, point2, .. } => {
            let (p1, d) = (point1.as_dvec3(), (point2 - point1).as_dvec3());
            let t = (p.z - p1.z) / d.z;
            let c = p1.truncate() + t * d.truncate();
            let f = rho(p).powi(2) - c.length_squared();
            let grad = DVec3::new(2.0 * p.x, 2.0 * p.y, -2.0 * c.dot(d.truncate()) / d.z);
            f.abs() / grad.length()
        }
        Shape::Torus { major_radius, minor_radius, .. } => {
            ((rho(p) - major_radius as f64).hypot(p.z) - minor_radius.abs() as f64).abs()
        }
        _ => unreachable!("not a quadric"),
    }
}

fn all_quadrics() -> Vec<Shape> {
    vec![
        sphere(1.0, -1.0, 1.0, 360.0),
        sphere(2.0, -0.5, 1.6, 270.0),
        sphere(0.5, 0.1, 0.5, 90.0),
        Shape::Cylinder { radius: 1.0, z_min: -1.0, z_max: 2.0, theta_max_degrees: 360.0 },
        Shape::Cylinder { radius: 0.7, z_min: 0.0, z_max: 0.5, theta_max_degrees: 135.0 },
        Shape::Cone { height: 2.0, radius: 1.0, theta_max_degrees: 360.0 },
        Shape::Cone { height: 0.5, radius: 1.5, theta_max_degrees: 200.0 },
        Shape::Disk { height: 0.3, radius: 1.0, theta_max_degrees: 360.0 },
        Shape::Disk { height: -1.0, radius: 2.0, theta_max_degrees: 45.0 },
        Shape::Paraboloid { r_max: 1.0, z_min: 0.0, z_max: 2.0, theta_max_degrees: 360.0 },
        Shape::Paraboloid { r_max: 2.0, z_min: 0.5, z_max: 1.0, theta_max_degrees: 300.0 },
        Shape::Hyperboloid {
            point1: Vec3::new(1.0, -1.0, -1.0),
            point2: Vec3::new(1.0, 1.0, 1.0),
            theta_max_degrees: 360.0,
        },
        Shape::Hyperboloid {
            point1: Vec3::new(0.5, 0.0, 0.0),
            point2: Vec3::new(0.0, 1.0, 1.5),
            theta_max_degrees: 250.0,
        },
        torus(1.0, 0.25, 0.0, 360.0, 360.0),
        torus(2.0, 0.5, -90.0, 180.0, 200.0),
    ]
}

#[test]
fn every_quadric_stays_within_tolerance_and_is_well_formed() {
    for shape in all_quadrics() {
        for eps in [1e-2, 1e-3] {
            let mesh = tessellate(&shape, &Tolerance::absolute(eps)).unwrap();
            assert!(!mesh.is_empty(), "{shape:?}");
            assert_well_formed(&mesh);
            assert_normals_follow_winding(&mesh, 1e-9);
            let (on_vertices, inside) = max_deviation(&mesh, |p| distance_to(&shape, p));
            assert!(on_vertices < 1e-6, "{shape:?}: vertices {on_vertices} off the surface");
            assert!(inside <= eps * 1.0001, "{shape:?} at {eps}: deviation {inside}");
            // Not grossly finer than needed either: the worst point uses a good part of eps.
            let flat = matches!(shape, Shape::Disk { .. });
            assert!(
                flat || inside > eps * 0.1 || mesh.triangle_count() < 64,
                "{shape:?} at {eps}: only {inside}"
            );
            assert!(mesh.st.is_some());
        }
    }
}

#[test]
fn relative_tolerance_scales_with_size() {
    let small = tessellate(&sphere(1.0, -1.0, 1.0, 360.0), &Tolerance::relative(1e-3)).unwrap();
    let big = tessellate(&sphere(1000.0, -1000.0, 1000.0, 360.0), &Tolerance::relative(1e-3)).unwrap();
    assert_eq!(small.triangle_count(), big.triangle_count());
    let both =
        Tolerance { max_deviation: Some(1e-2), max_relative_deviation: Some(1e-3), ..Default::default() };
    // The tighter bound wins: 1e-2 absolute on a sphere of radius 1000 is tighter.
    let tight = tessellate(&sphere(1000.0, -1000.0, 1000.0, 360.0), &both).unwrap();
    assert!(tight.triangle_count() > big.triangle_count());
}

fn areas_and_volumes(shape: &Shape) -> Vec<(f64, f64, usize)> {
    [1e-2, 1e-3, 1e-4]
        .iter()
        .map(|&eps| {
            let m = tessellate(shape, &Tolerance::absolute(eps)).unwrap();
            (m.area(), m.signed_volume(), m.triangle_count())
        })
        .collect()
}

fn assert_converges(values: &[f64], exact: f64, final_relative: f64) {
    let errors: Vec<f64> = values.iter().map(|v| (v - exact).abs()).collect();
    for w in errors.windows(2) {
        assert!(w[1] < w[0], "errors do not shrink: {errors:?} (exact {exact})");
    }
    assert!(errors.last().unwrap() / exact < final_relative, "errors {errors:?} of {exact}");
}

#[test]
fn sphere_area_and_volume_converge_to_the_closed_form() {
    let r = 1.5f64;
    let results = areas_and_volumes(&sphere(r as f32, -r as f32, r as f32, 360.0));
    let areas: Vec<f64> = results.iter().map(|r| r.0).collect();
    let volumes: Vec<f64> = results.iter().map(|r| r.1).collect();
    // The relative error of an inscribed mesh is about 2 eps / r.
    assert_converges(&areas, 4.0 * PI * r * r, 2e-4);
    assert_converges(&volumes, 4.0 / 3.0 * PI * r.powi(3), 3e-4);
    // An inscribed polyhedron: below the true values.
    assert!(areas.iter().all(|&a| a < 4.0 * PI * r * r));
}

#[test]
fn torus_area_and_volume_converge_to_the_closed_form() {
    let (big_r, r) = (2.0f64, 0.5f64);
    let results = areas_and_volumes(&torus(big_r as f32, r as f32, 0.0, 360.0, 360.0));
    let areas: Vec<f64> = results.iter().map(|r| r.0).collect();
    let volumes: Vec<f64> = results.iter().map(|r| r.1).collect();
    assert_converges(&areas, 4.0 * PI * PI * big_r * r, 4e-4);
    assert_converges(&volumes, 2.0 * PI * PI * big_r * r * r, 8e-4);
}

#[test]
fn cylinder_area_converges_to_the_closed_form() {
    let results =
        areas_and_volumes(&Shape::Cylinder { radius: 1.0, z_min: 0.0, z_max: 3.0, theta_max_degrees: 360.0 });
    let areas: Vec<f64> = results.iter().map(|r| r.0).collect();
    assert_converges(&areas, 2.0 * PI * 3.0, 1e-4);
}

#[test]
fn closed_quadrics_are_watertight_and_open_ones_are_not() {
    for shape in
        [sphere(1.0, -1.0, 1.0, 360.0), sphere(3.0, -5.0, 5.0, 720.0), torus(1.0, 0.3, 0.0, 360.0, 360.0)]
    {
        for eps in [0.5, 1e-2, 1e-4] {
            let mesh = tessellate(&shape, &Tolerance::absolute(eps)).unwrap();
            assert!(mesh.is_closed(), "{shape:?} at {eps}: {} open edges", mesh.boundary_edge_count());
            assert!(mesh.signed_volume() > 0.0, "{shape:?}: outward normals enclose positive volume");
        }
    }
    for shape in [
        sphere(1.0, -1.0, 1.0, 359.0),
        sphere(1.0, -0.9, 1.0, 360.0),
        torus(1.0, 0.3, 0.0, 300.0, 360.0),
        Shape::Cylinder { radius: 1.0, z_min: 0.0, z_max: 1.0, theta_max_degrees: 360.0 },
    ] {
        let mesh = tessellate(&shape, &Tolerance::absolute(1e-2)).unwrap();
        assert!(mesh.boundary_edge_count() > 0, "{shape:?}");
    }
    // A full cone and disk close at the apex / centre: only the rim is open.
    let cone = tessellate(
        &Shape::Cone { height: 1.0, radius: 1.0, theta_max_degrees: 360.0 },
        &Tolerance::absolute(1e-2),
    )
    .unwrap();
    let rim = cone.boundary_edge_count();
    assert_eq!(rim, cone.positions.len() - 1, "one apex vertex, the rest on the open rim");
}

#[test]
fn normals_point_the_way_renderman_parametric_normals_point() {
    let tol = Tolerance::absolute(1e-2);
    let check = |shape: Shape, expect: &dyn Fn(DVec3, DVec3) -> bool| {
        let mesh = tessellate(&shape, &tol).unwrap();
        let normals = mesh.normals.as_ref().unwrap();
        for (p, n) in mesh.positions.iter().zip(normals) {
            assert!(expect(p.as_dvec3(), n.as_dvec3()), "{shape:?}: normal {n} at {p}");
        }
    };
    check(sphere(1.0, -1.0, 1.0, 360.0), &|p, n| n.dot(p) > 0.99);
    // A negative sweep reverses dPdu, so the parametric normal points inward.
    check(sphere(1.0, -1.0, 1.0, -360.0), &|p, n| n.dot(p) < -0.99);
    // zmin > zmax reverses dPdv likewise.
    check(sphere(1.0, 1.0, -1.0, 360.0), &|p, n| n.dot(p) < -0.99);
    check(Shape::Cylinder { radius: 1.0, z_min: 0.0, z_max: 1.0, theta_max_degrees: 360.0 }, &|p, n| {
        n.z.abs() < 1e-6 && n.dot(p.with_z(0.0)) > 0.99
    });
    check(Shape::Cone { height: 2.0, radius: 1.0, theta_max_degrees: 360.0 }, &|p, n| {
        n.z > 0.0 && (rho(p) < 1e-6 || n.dot(p.with_z(0.0)) > 0.0)
    });
    check(Shape::Disk { height: 1.0, radius: 1.0, theta_max_degrees: 360.0 }, &|_, n| n == DVec3::Z);
    check(Shape::Paraboloid { r_max: 1.0, z_min: 0.0, z_max: 1.0, theta_max_degrees: 360.0 }, &|p, n| {
        n.z < 0.0 && (rho(p) < 1e-6 || n.dot(p.with_z(0.0)) > 0.0)
    });
    check(
        Shape::Hyperboloid {
            point1: Vec3::new(1.0, -1.0, -1.0),
            point2: Vec3::new(1.0, 1.0, 1.0),
            theta_max_degrees: 360.0,
        },
        &|p, n| n.dot(p.with_z(0.0)) > 0.0,
    );
    check(torus(2.0, 0.5, 0.0, 360.0, 360.0), &|p, n| {
        let centre = p.with_z(0.0).normalize() * 2.0;
        n.dot(p - centre) > 0.99 * 0.5
    });
}

#[test]
fn poles_and_apexes_are_single_vertices_with_the_limit_normal() {
    let mesh = tessellate(&sphere(1.0, -1.0, 1.0, 360.0), &Tolerance::absolute(1e-3)).unwrap();
    let normals = mesh.normals.as_ref().unwrap();
    let poles: Vec<usize> =
        (0..mesh.positions.len()).filter(|&i| mesh.positions[i].z.abs() > 0.999_999).collect();
    assert_eq!(poles.len(), 2);
    for i in poles {
        assert!((normals[i].as_dvec3() - mesh.positions[i].as_dvec3()).length() < 1e-6);
    }
}

#[test]
fn degenerate_quadrics_give_empty_meshes_and_bad_ones_errors() {
    let tol = Tolerance::default();
    for shape in [
        sphere(0.0, -1.0, 1.0, 360.0),
        sphere(1.0, 0.5, 0.5, 360.0),
        sphere(1.0, -1.0, 1.0, 0.0),
        Shape::Cylinder { radius: 1.0, z_min: 1.0, z_max: 1.0, theta_max_degrees: 360.0 },
        Shape::Disk { height: 0.0, radius: 0.0, theta_max_degrees: 360.0 },
        Shape::Paraboloid { r_max: 1.0, z_min: 0.0, z_max: 0.0, theta_max_degrees: 360.0 },
        Shape::Hyperboloid { point1: Vec3::ZERO, point2: Vec3::Z, theta_max_degrees: 360.0 },
        torus(1.0, 0.0, 0.0, 360.0, 360.0),
    ] {
        let mesh = tessellate(&shape, &tol).unwrap();
        assert!(mesh.is_empty(), "{shape:?}");
    }
    for shape in [sphere(f32::NAN, -1.0, 1.0, 360.0), torus(1.0, 0.5, 0.0, f32::INFINITY, 360.0)] {
        assert!(matches!(tessellate(&shape, &tol), Err(TessellateError::NonFinite { .. })), "{shape:?}");
    }
}

#[test]
fn the_triangle_cap_refuses_before_allocating() {
    let tol = Tolerance::absolute(1e-9).with_max_triangles(1_000_000);
    match tessellate(&sphere(1.0, -1.0, 1.0, 360.0), &tol) {
        Err(TessellateError::TooManyTriangles { estimated, limit, .. }) => {
            assert!(estimated > limit);
        }
        other => panic!("expected TooManyTriangles, got {other:?}"),
    }
    // A bound below what f32 positions can resolve is raised to 2^-20 of the size.
    let size = 3.0e30;
    let floor = size * (-20f64).exp2();
    assert_eq!(Tolerance::absolute(1e-6).effective(size, 1.0).unwrap(), floor);
    assert_eq!(Tolerance::relative(1e-9).effective(size, 1.0).unwrap(), floor);
    assert_eq!(Tolerance::absolute(1e28).effective(size, 10.0).unwrap(), 1e27);
}

#[test]
fn invalid_tolerances_are_errors() {
    let shape = sphere(1.0, -1.0, 1.0, 360.0);
    for tol in [
        Tolerance::absolute(0.0),
        Tolerance::absolute(f64::NAN),
        Tolerance::relative(-1.0),
        Tolerance { max_deviation: None, max_relative_deviation: None, ..Default::default() },
    ] {
        assert!(matches!(tessellate(&shape, &tol), Err(TessellateError::InvalidTolerance(_))), "{tol:?}");
    }
}

#[test]
fn texture_coordinates_are_the_surface_parameters() {
    let mesh: TriangleMesh = tessellate(&sphere(1.0, -1.0, 1.0, 180.0), &Tolerance::absolute(1e-2)).unwrap();
    let st = mesh.st.as_ref().unwrap();
    for (p, st) in mesh.positions.iter().zip(st) {
        // v runs from the south pole (0) to the north pole (1); u along the sweep.
        let phi = (p.z as f64).clamp(-1.0, 1.0).asin();
        assert!((st.y as f64 - (phi / PI + 0.5)).abs() < 1e-5, "{p} {st}");
        if rho(p.as_dvec3()) > 1e-3 {
            let theta = (p.y as f64).atan2(p.x as f64).rem_euclid(2.0 * PI);
            assert!((st.x as f64 - theta / PI).abs() < 1e-4, "{p} {st}");
        }
    }
}
