//! `Curves` and `Points` against closed forms: tube radii, ribbon widths, chord bounds.

use super::assert_well_formed;
use crate::{RibbonFacing, Tolerance, curve_polylines, curve_ribbons, curve_ribbons_keys, tessellate};
use glam::{DMat4, DVec3, Vec3};
use rib_parser::basis::named_basis;
use rib_parser::scene::FileLoc;
use rib_parser::scene::{
    Curves, Param, ParamDecl, ParamList, ParamType, ParamValues, Points, Shape, StorageClass, Wrap,
};

fn float_param(name: &str, class: StorageClass, values: Vec<f32>) -> Param {
    Param {
        name: name.into(),
        decl: ParamDecl { class, ty: ParamType::Float, array_len: 1 },
        values: ParamValues::Floats(values),
        loc: FileLoc::new("t.rib", 1, 1),
    }
}

fn linear(positions: Vec<Vec3>, params: Vec<Param>) -> Curves {
    Curves {
        cubic: false,
        vertices_per_curve: vec![positions.len() as u32],
        wrap: Wrap::NonPeriodic,
        v_basis: named_basis("bezier").unwrap(),
        positions,
        primvars: ParamList(params),
    }
}

#[test]
fn a_linear_curve_is_a_closed_tube_of_its_width() {
    let c = linear(
        vec![Vec3::ZERO, Vec3::X * 2.0],
        vec![float_param("constantwidth", StorageClass::Constant, vec![0.5])],
    );
    let mesh = tessellate(&Shape::Curves(c), &Tolerance::absolute(1e-3)).unwrap();
    assert_well_formed(&mesh);
    assert!(mesh.is_closed());
    assert!(mesh.signed_volume() > 0.0, "outward winding");
    for p in &mesh.positions {
        let p = p.as_dvec3();
        let radial = DVec3::new(0.0, p.y, p.z).length();
        assert!((radial - 0.25).abs() < 1e-6 || ((p.x == 0.0 || p.x == 2.0) && radial < 0.2501), "{p}");
    }
}

#[test]
fn ribbons_face_the_eye_and_span_the_width() {
    // Varying widths 0.1 and 0.3 at the ends of a curve 5 units in front of the eye.
    let c = linear(
        vec![Vec3::new(-1.0, 0.0, 5.0), Vec3::new(1.0, 0.0, 5.0)],
        vec![float_param("width", StorageClass::Varying, vec![0.1, 0.3])],
    );
    let mesh =
        curve_ribbons(&c, &DMat4::IDENTITY, RibbonFacing::Eye(DVec3::ZERO), &Tolerance::absolute(1e-4))
            .unwrap();
    assert_eq!(mesh.triangle_count(), 2);
    let p: Vec<DVec3> = mesh.positions.iter().map(|p| p.as_dvec3()).collect();
    // Each end's pair is perpendicular to the curve and to the line of sight, `width` apart.
    assert!(((p[1] - p[0]).length() - 0.1).abs() < 1e-7);
    assert!(((p[3] - p[2]).length() - 0.3).abs() < 1e-7);
    assert!(
        (p[1] - p[0]).dot(DVec3::X).abs() < 1e-9 && (p[1] - p[0]).dot(DVec3::Z * 5.0 - DVec3::X).abs() < 1e-7
    );
    for t in 0..2 {
        let n = mesh.face_cross(t);
        assert!(n.dot(-p[mesh.indices[t][0] as usize]) > 0.0, "front faces the eye");
    }
}

#[test]
fn cubic_curves_stay_within_the_chord_tolerance() {
    // A periodic B-spline through the 8 corners of an octagon: every sample lies on the curve
    // (checked at the segment ends against the basis), and chords stay within eps of it.
    let ring: Vec<Vec3> = (0..8)
        .map(|k| {
            let a = std::f32::consts::TAU * k as f32 / 8.0;
            Vec3::new(a.cos(), a.sin(), 0.0)
        })
        .collect();
    let c = Curves {
        cubic: true,
        vertices_per_curve: vec![8],
        wrap: Wrap::Periodic,
        v_basis: named_basis("b-spline").unwrap(),
        positions: ring.clone(),
        primvars: ParamList(vec![float_param("constantwidth", StorageClass::Constant, vec![0.05])]),
    };
    let eps = 1e-4;
    let lines = curve_polylines(&c, eps).unwrap();
    assert_eq!(lines.len(), 1);
    let line = &lines[0];
    assert!(line.periodic);
    // A uniform B-spline segment starts at (P0 + 4 P1 + P2) / 6.
    let start = (ring[0] + ring[1] * 4.0 + ring[2]).as_dvec3() / 6.0;
    assert!((line.points[0] - start).length() < 1e-6);
    // The curve is nearly a circle of radius r0; chord midpoints are inside it by at most eps
    // plus the spline's own wobble, measured on the dense samples.
    let radii: Vec<f64> = line.points.iter().map(|p| p.length()).collect();
    let n = line.points.len();
    for i in 0..n {
        let mid = (line.points[i] + line.points[(i + 1) % n]) * 0.5;
        let local = 0.5 * (radii[i] + radii[(i + 1) % n]);
        assert!(local - mid.length() <= eps, "chord {i} sags {}", local - mid.length());
    }
    assert!(line.widths.iter().all(|&w| (w - 0.05).abs() < 1e-7));
}

#[test]
fn points_are_spheres_of_their_width() {
    let points = Points {
        positions: vec![Vec3::ZERO, Vec3::X * 3.0],
        primvars: ParamList(vec![float_param("width", StorageClass::Vertex, vec![1.0, 0.5])]),
    };
    let mesh = tessellate(&Shape::Points(points), &Tolerance::absolute(1e-3)).unwrap();
    assert_well_formed(&mesh);
    assert!(mesh.is_closed());
    for p in &mesh.positions {
        let p = p.as_dvec3();
        let r = if p.x > 1.5 { (p - DVec3::X * 3.0).length() - 0.25 } else { p.length() - 0.5 };
        assert!(r.abs() < 1e-6, "{p}");
    }
}

#[test]
fn deformation_keys_of_curves_are_sampled_alike() {
    // A straight cubic Bezier and a strongly bent one: alone the straight one needs one chord,
    // the bent one many; as keys both get the bent one's, vertex for vertex, and the bent key
    // is exactly its own ribbon.
    let cubic = |bend: f32| Curves {
        cubic: true,
        vertices_per_curve: vec![4],
        wrap: Wrap::NonPeriodic,
        v_basis: named_basis("bezier").unwrap(),
        positions: vec![
            Vec3::new(0.0, 0.0, 0.0),
            Vec3::new(0.333, bend, 0.0),
            Vec3::new(0.666, bend, 0.0),
            Vec3::new(1.0, 0.0, 0.0),
        ],
        primvars: ParamList(vec![float_param("constantwidth", StorageClass::Constant, vec![0.1])]),
    };
    let (straight, bent) = (cubic(0.0), cubic(-1.0));
    let place = DMat4::from_translation(DVec3::new(0.0, 0.0, 5.0));
    let facing = RibbonFacing::Eye(DVec3::ZERO);
    let tol = Tolerance::absolute(1e-3);
    let alone = curve_ribbons(&straight, &place, facing, &tol).unwrap();
    let own = curve_ribbons(&bent, &place, facing, &tol).unwrap();
    assert!(alone.positions.len() < own.positions.len());
    let keys = curve_ribbons_keys(&[&straight, &bent], &place, facing, &tol).unwrap();
    assert_eq!(keys[0].positions.len(), own.positions.len());
    assert_eq!(keys[0].indices, keys[1].indices);
    assert_eq!(keys[1].positions, own.positions);
    assert_well_formed(&keys[0]);
}
