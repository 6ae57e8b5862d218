use super::{assert_normals_follow_winding, assert_well_formed, max_deviation};
use crate::{ShapeOptions, TessellateError, Tolerance, TriangleMesh, tessellate, tessellate_scaled};
use glam::{DVec3, Vec4};
use rib_parser::scene::{NuPatch, NuPatchBasis, ParamList, Shape, TrimCurves};
use std::f64::consts::PI;
use std::sync::Arc;

const H: f32 = std::f32::consts::FRAC_1_SQRT_2;

/// The standard 9-point rational quadratic unit circle: (x, y, w), not premultiplied.
const CIRCLE: [(f32, f32, f32); 9] = [
    (1.0, 0.0, 1.0),
    (1.0, 1.0, H),
    (0.0, 1.0, 1.0),
    (-1.0, 1.0, H),
    (-1.0, 0.0, 1.0),
    (-1.0, -1.0, H),
    (0.0, -1.0, 1.0),
    (1.0, -1.0, H),
    (1.0, 0.0, 1.0),
];
const CIRCLE_KNOTS: [f32; 12] = [0.0, 0.0, 0.0, 0.25, 0.25, 0.5, 0.5, 0.75, 0.75, 1.0, 1.0, 1.0];

pub(crate) fn nupatch(
    (nu, u_order, u_knots): (u32, u32, Vec<f32>),
    (nv, v_order, v_knots): (u32, u32, Vec<f32>),
    positions: Vec<Vec4>,
) -> NuPatch {
    let (u_min, u_max) = (u_knots[u_order as usize - 1], u_knots[nu as usize]);
    let (v_min, v_max) = (v_knots[v_order as usize - 1], v_knots[nv as usize]);
    NuPatch {
        basis: NuPatchBasis { nu, u_order, u_knots, u_min, u_max, nv, v_order, v_knots, v_min, v_max },
        positions,
        trim: None,
        primvars: ParamList::default(),
    }
}

/// A cylinder of radius `r` from z = 0 to 1: the circle in u, a line in v.
pub(crate) fn nurbs_cylinder(r: f32) -> NuPatch {
    let mut p = Vec::new();
    for z in [0.0, 1.0] {
        for (x, y, w) in CIRCLE {
            p.push(Vec4::new(x * r * w, y * r * w, z * w, w));
        }
    }
    nupatch((9, 3, CIRCLE_KNOTS.to_vec()), (2, 2, vec![0.0, 0.0, 1.0, 1.0]), p)
}

/// The unit sphere: the circle in u times the half circle from the south to the north pole.
fn nurbs_sphere() -> NuPatch {
    let half: [(f32, f32, f32); 5] =
        [(0.0, -1.0, 1.0), (1.0, -1.0, H), (1.0, 0.0, 1.0), (1.0, 1.0, H), (0.0, 1.0, 1.0)];
    let mut p = Vec::new();
    for (rho, z, wv) in half {
        for (x, y, wu) in CIRCLE {
            let w = wu * wv;
            p.push(Vec4::new(x * rho * w, y * rho * w, z * w, w));
        }
    }
    nupatch((9, 3, CIRCLE_KNOTS.to_vec()), (5, 3, vec![0.0, 0.0, 0.0, 0.5, 0.5, 1.0, 1.0, 1.0]), p)
}

fn run(np: NuPatch, eps: f64) -> TriangleMesh {
    let m = tessellate(&Shape::NuPatch(np), &Tolerance::absolute(eps)).unwrap();
    assert_well_formed(&m);
    m
}

#[test]
fn a_rational_nurbs_cylinder_lies_on_the_exact_cylinder() {
    for eps in [1e-2, 1e-3, 1e-4] {
        let m = run(nurbs_cylinder(2.0), eps);
        assert_normals_follow_winding(&m, 1e-6);
        let (on, inside) = max_deviation(&m, |p| (p.truncate().length() - 2.0).abs());
        assert!(on < 2e-6, "{eps}: vertices {on}");
        assert!(inside <= eps, "{eps}: {inside}");
        // The seam at u = 0 and u = 1 is welded: only the two rims are open.
        let rim_vertices = m.positions.iter().filter(|p| p.z == 0.0).count();
        assert_eq!(m.boundary_edge_count(), 2 * rim_vertices);
        let n = m.normals.as_ref().unwrap();
        for (p, n) in m.positions.iter().zip(n) {
            assert!(n.truncate().dot(p.truncate()) > 0.0 && n.z.abs() < 1e-5, "outward {n} at {p}");
        }
    }
}

#[test]
fn a_nurbs_sphere_is_closed_and_converges() {
    let mut errors = Vec::new();
    for eps in [1e-2, 1e-3, 1e-4] {
        let m = run(nurbs_sphere(), eps);
        assert_normals_follow_winding(&m, 1e-3);
        let (on, inside) = max_deviation(&m, |p| (p.length() - 1.0).abs());
        assert!(on < 2e-6, "{eps}: vertices {on}");
        assert!(inside <= eps, "{eps}: {inside}");
        assert!(m.is_closed(), "{eps}: {} open edges", m.boundary_edge_count());
        errors.push((m.signed_volume() - 4.0 / 3.0 * PI).abs());
    }
    assert!(errors.windows(2).all(|w| w[1] < w[0]), "{errors:?}");
}

#[test]
fn parameter_ranges_cut_the_surface() {
    let mut np = nurbs_cylinder(1.0);
    np.basis.u_max = 0.25; // the first quarter of the circle
    np.basis.v_min = 0.5;
    let m = run(np, 1e-3);
    for p in &m.positions {
        assert!(p.x >= -1e-6 && p.y >= -1e-6 && p.z >= 0.5 - 1e-6);
    }
    // A quarter of the lateral area of a half-height cylinder.
    assert!((m.area() - PI / 4.0).abs() < 2e-3 * PI / 4.0 * 2.0);
    // Ranges outside the knots clamp; an empty range gives nothing.
    let mut np = nurbs_cylinder(1.0);
    np.basis.u_min = -5.0;
    np.basis.u_max = 5.0;
    assert!(!run(np, 1e-2).is_closed());
    let mut np = nurbs_cylinder(1.0);
    np.basis.u_min = 0.7;
    np.basis.u_max = 0.2;
    assert!(run(np, 1e-2).is_empty());
}

#[test]
fn a_single_span_nurbs_is_the_bezier_patch() {
    let zs = [0.0, 0.0, 1.0 / 3.0, 1.0];
    let mut p = Vec::new();
    for j in 0..4 {
        for i in 0..4 {
            p.push(Vec4::new(i as f32 / 3.0, j as f32 / 3.0, zs[i] + zs[j], 1.0));
        }
    }
    let bez = vec![0.0, 0.0, 0.0, 0.0, 1.0, 1.0, 1.0, 1.0];
    let m = run(nupatch((4, 4, bez.clone()), (4, 4, bez), p), 1e-3);
    let d = |p: DVec3| (p.z - p.x * p.x - p.y * p.y).abs() / (1.0 + 4.0 * p.x * p.x + 4.0 * p.y * p.y).sqrt();
    let (on, inside) = max_deviation(&m, d);
    assert!(on < 1e-6 && inside <= 1e-3, "{on} {inside}");
    // Default st are the knot-space parameters.
    let st = m.st.as_ref().unwrap();
    for (p, st) in m.positions.iter().zip(st) {
        assert!((p.x - st.x).abs() < 1e-6 && (p.y - st.y).abs() < 1e-6);
    }
}

/// A flat unit square, bilinear, in the z = 0 plane.
fn square() -> NuPatch {
    let p = vec![
        Vec4::new(0.0, 0.0, 0.0, 1.0),
        Vec4::new(1.0, 0.0, 0.0, 1.0),
        Vec4::new(0.0, 1.0, 0.0, 1.0),
        Vec4::new(1.0, 1.0, 0.0, 1.0),
    ];
    nupatch((2, 2, vec![0.0, 0.0, 1.0, 1.0]), (2, 2, vec![0.0, 0.0, 1.0, 1.0]), p)
}

/// A circle trim loop of radius `r` about `(cx, cy)`, premultiplied, as `TrimCurve` takes it.
fn circle_loop(cx: f32, cy: f32, r: f32) -> (Vec<f32>, Vec<f32>, Vec<f32>) {
    let (mut u, mut v, mut w) = (Vec::new(), Vec::new(), Vec::new());
    for (x, y, wt) in CIRCLE {
        u.push((cx + r * x) * wt);
        v.push((cy + r * y) * wt);
        w.push(wt);
    }
    (u, v, w)
}

/// One trim loop of a single curve: `u`, `v`, `w` (premultiplied), order, knots.
type TrimLoop = (Vec<f32>, Vec<f32>, Vec<f32>, u32, Vec<f32>);

fn trims(loops: &[TrimLoop]) -> TrimCurves {
    let mut t = TrimCurves {
        curves_per_loop: Vec::new(),
        order: Vec::new(),
        knots: Vec::new(),
        min: Vec::new(),
        max: Vec::new(),
        n: Vec::new(),
        u: Vec::new(),
        v: Vec::new(),
        w: Vec::new(),
    };
    for (u, v, w, order, knots) in loops {
        t.curves_per_loop.push(1);
        t.order.push(*order);
        t.min.push(knots[*order as usize - 1]);
        t.max.push(knots[u.len()]);
        t.n.push(u.len() as u32);
        t.knots.extend_from_slice(knots);
        t.u.extend_from_slice(u);
        t.v.extend_from_slice(v);
        t.w.extend_from_slice(w);
    }
    t
}

fn circle_trim(cx: f32, cy: f32, r: f32) -> TrimLoop {
    let (u, v, w) = circle_loop(cx, cy, r);
    (u, v, w, 3, CIRCLE_KNOTS.to_vec())
}

fn square_trim(x0: f32, x1: f32) -> TrimLoop {
    // A closed linear loop: order 2 through five points.
    let u = vec![x0, x1, x1, x0, x0];
    let v = vec![x0, x0, x1, x1, x0];
    (u, v, vec![1.0; 5], 2, vec![0.0, 0.0, 1.0, 2.0, 3.0, 4.0, 4.0])
}

fn trimmed(loops: &[TrimLoop], eps: f64, outside: bool) -> TriangleMesh {
    let mut np = square();
    np.trim = Some(Arc::new(trims(loops)));
    let m = tessellate_scaled(
        &Shape::NuPatch(np),
        &Tolerance::absolute(eps),
        1.0,
        ShapeOptions { trim_keeps_outside: outside },
    )
    .unwrap();
    assert_well_formed(&m);
    assert_normals_follow_winding(&m, 1e-6);
    m
}

#[test]
fn a_circle_trim_keeps_its_inside_and_sense_outside_keeps_the_rest() {
    let disk = PI * 0.3 * 0.3;
    for eps in [1e-2, 1e-3] {
        let inside = trimmed(&[circle_trim(0.5, 0.5, 0.3)], eps, false);
        assert!(
            (inside.area() - disk).abs() < 4.0 * eps * 0.3 * 2.0 * PI,
            "{eps}: {} vs {disk}",
            inside.area()
        );
        for p in &inside.positions {
            assert!(p.as_dvec3().distance(DVec3::new(0.5, 0.5, 0.0)) <= 0.3 + 1e-6, "{p}");
        }
        let outside = trimmed(&[circle_trim(0.5, 0.5, 0.3)], eps, true);
        assert!(
            (outside.area() - (1.0 - disk)).abs() < 4.0 * eps * 0.3 * 2.0 * PI,
            "{eps}: {}",
            outside.area()
        );
        assert!((inside.area() + outside.area() - 1.0).abs() < 1e-9, "the two senses partition the square");
    }
}

#[test]
fn an_outer_loop_with_a_hole_removes_the_hole() {
    // Even-odd: inside the outer square (one loop) is kept, inside the circle (two) is not.
    let m = trimmed(&[square_trim(0.1, 0.9), circle_trim(0.5, 0.5, 0.2)], 1e-3, false);
    let expected = 0.8 * 0.8 - PI * 0.04;
    assert!((m.area() - expected).abs() < 5e-3, "{} vs {expected}", m.area());
    for t in 0..m.triangle_count() {
        let [a, b, c] = m.triangle(t).map(|p| p.as_dvec3());
        let centroid = (a + b + c) / 3.0;
        let r = centroid.distance(DVec3::new(0.5, 0.5, 0.0));
        assert!(r > 0.2 - 1e-3, "a triangle inside the hole at {centroid}");
        assert!(centroid.x > 0.1 - 1e-9 && centroid.x < 0.9 + 1e-9);
    }
    // The polyline's own points classify as the boundary they are.
    let np = {
        let mut np = square();
        np.trim = Some(Arc::new(trims(&[square_trim(0.1, 0.9), circle_trim(0.5, 0.5, 0.2)])));
        np
    };
    let surface = crate::nurbs::Surface::new(&np).unwrap();
    let loops =
        crate::trim::TrimLoops::new(np.trim.as_ref().unwrap(), 1e-3, &surface, (0.0, 1.0, 0.0, 1.0)).unwrap();
    assert!(loops.inside(glam::DVec2::new(0.15, 0.5)));
    assert!(!loops.inside(glam::DVec2::new(0.5, 0.5)));
    assert!(!loops.inside(glam::DVec2::new(0.05, 0.5)));
}

#[test]
fn bad_nurbs_are_errors_not_panics() {
    let tol = Tolerance::default();
    let check = |np: NuPatch| {
        let r = tessellate(&Shape::NuPatch(np), &tol);
        assert!(
            matches!(r, Err(TessellateError::InvalidShape { .. }) | Err(TessellateError::NonFinite { .. })),
            "{r:?}"
        );
    };
    let mut np = nurbs_cylinder(1.0);
    np.basis.u_knots.pop();
    check(np);
    let mut np = nurbs_cylinder(1.0);
    np.basis.u_knots.swap(3, 8);
    check(np);
    let mut np = nurbs_cylinder(1.0);
    np.basis.u_order = 1;
    check(np);
    let mut np = nurbs_cylinder(1.0);
    np.basis.u_order = 40;
    check(np);
    let mut np = nurbs_cylinder(1.0);
    np.positions.pop();
    check(np);
    let mut np = nurbs_cylinder(1.0);
    np.basis.v_knots = vec![0.0, 0.0, 0.0, 0.0];
    check(np);
    let mut np = nurbs_cylinder(1.0);
    np.positions[3].w = -1.0;
    check(np);
    let mut np = square();
    np.trim = Some(Arc::new(TrimCurves { n: vec![3], ..trims(&[circle_trim(0.5, 0.5, 0.3)]) }));
    check(np);
}
