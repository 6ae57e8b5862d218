//! The seven RenderMan quadrics with their full sweeps (RISpec 3.2 §5.4).
//!
//! Every quadric is a surface of revolution about z: `u` runs along the sweep
//! `theta = u * thetamax`, `v` along the profile. Grid density comes from closed-form chord
//! bounds: around z each ring of radius `rho` deviates by the sagitta
//! `rho (1 - cos(dtheta / 2))`, along the profile by the profile's own sagitta (circles for the
//! sphere and torus, the parabola for the paraboloid; straight lines for the rest), and the
//! hyperboloid's skew rulings add a twist term. Each direction gets half the budget, so a grid
//! cell stays within `eps`. Normals are RenderMan's `dPdu x dPdv`, normalised, in closed form
//! (the sphere's and paraboloid's poles included).

use super::grid::{Grid, GridSpec, linspace};
use super::{Shape, TessellateError, Tolerance, TriangleMesh, check_budget};
use glam::{DVec3, Vec2};
use std::f64::consts::{PI, TAU};

/// Segments for an arc of `radius` sweeping `sweep` radians with sagitta at most `eps`, and at
/// least one segment per 120 degrees so closed rings stay solids.
fn arc_segments(radius: f64, sweep: f64, eps: f64) -> f64 {
    let sweep = sweep.abs();
    if sweep == 0.0 {
        return 1.0;
    }
    let floor = (sweep / (TAU / 3.0) - 1e-9).ceil().max(1.0);
    let radius = radius.abs();
    if radius <= 0.0 || eps >= radius {
        return floor;
    }
    let step = 2.0 * (1.0 - eps / radius).clamp(-1.0, 1.0).acos();
    if step <= 0.0 {
        return f64::INFINITY;
    }
    (sweep / step - 1e-9).ceil().max(floor)
}

fn finite(kind: &'static str, values: &[f32]) -> Result<(), TessellateError> {
    if values.iter().all(|v| v.is_finite()) {
        Ok(())
    } else {
        Err(TessellateError::NonFinite { kind, reason: format!("parameters {values:?}") })
    }
}

/// RenderMan clamps sweep angles to one turn.
fn sweep_radians(degrees: f32) -> f64 {
    (degrees as f64).clamp(-360.0, 360.0).to_radians()
}

fn is_full_turn(theta_max: f64) -> bool {
    (theta_max.abs() - TAU).abs() < 1e-9
}

/// A quadric ready to grid: its evaluation, grid values and size.
struct Plan {
    spec: GridSpec,
    size: f64,
}

pub(crate) fn tessellate_quadric(
    shape: &Shape,
    tol: &Tolerance,
    scale: f64,
) -> Result<TriangleMesh, TessellateError> {
    let kind = super::shape_kind(shape);
    // Each quadric gives: its size (bounding-box diagonal), a function from eps to the grid,
    // and its evaluation (position, normal direction) at (u, v).
    match *shape {
        Shape::Sphere { radius, z_min, z_max, theta_max_degrees } => {
            finite(kind, &[radius, z_min, z_max, theta_max_degrees])?;
            let r = radius as f64;
            let theta_max = sweep_radians(theta_max_degrees);
            if r == 0.0 || theta_max == 0.0 {
                return Ok(TriangleMesh::default());
            }
            let ra = r.abs();
            let phi = |z: f64| (z / ra).clamp(-1.0, 1.0).asin();
            let (phi_min, phi_max) = (phi(z_min as f64), phi(z_max as f64));
            if phi_min == phi_max {
                return Ok(TriangleMesh::default());
            }
            let size = DVec3::new(2.0 * ra, 2.0 * ra, (z_max - z_min).abs() as f64).length();
            let eps = tol.effective(size, scale)?;
            // The widest ring: the equator if the band contains it.
            let rho_max = if phi_min.min(phi_max) <= 0.0 && phi_min.max(phi_max) >= 0.0 {
                ra
            } else {
                ra * phi_min.cos().max(phi_max.cos())
            };
            let nu = arc_segments(rho_max, theta_max, eps / 2.0);
            let nv = arc_segments(ra, phi_max - phi_min, eps / 2.0);
            check_budget(kind, 2.0 * nu * nv, tol)?;
            let mut spec = GridSpec::uniform(0.0, 1.0, nu as usize, 0.0, 1.0, nv as usize);
            spec.u_periodic = is_full_turn(theta_max);
            let sign = (theta_max * (phi_max - phi_min)).signum();
            let eval = move |u: f64, v: f64| {
                let theta = u * theta_max;
                let phi = phi_min + v * (phi_max - phi_min);
                let dir = DVec3::new(theta.cos() * phi.cos(), theta.sin() * phi.cos(), phi.sin());
                (r * dir, sign * dir)
            };
            Ok(build(Plan { spec, size }, eval))
        }
        Shape::Cylinder { radius, z_min, z_max, theta_max_degrees } => {
            finite(kind, &[radius, z_min, z_max, theta_max_degrees])?;
            let r = radius as f64;
            let (z0, z1) = (z_min as f64, z_max as f64);
            let theta_max = sweep_radians(theta_max_degrees);
            if r == 0.0 || theta_max == 0.0 || z0 == z1 {
                return Ok(TriangleMesh::default());
            }
            let size = DVec3::new(2.0 * r, 2.0 * r, z1 - z0).length();
            let eps = tol.effective(size, scale)?;
            // Straight rulings: the quads are planar, the whole budget goes around.
            let nu = arc_segments(r, theta_max, eps);
            check_budget(kind, 2.0 * nu, tol)?;
            let mut spec = GridSpec::uniform(0.0, 1.0, nu as usize, 0.0, 1.0, 1);
            spec.u_periodic = is_full_turn(theta_max);
            let sign = (theta_max * (z1 - z0) * r).signum();
            let eval = move |u: f64, v: f64| {
                let theta = u * theta_max;
                let (s, c) = theta.sin_cos();
                (DVec3::new(r * c, r * s, z0 + v * (z1 - z0)), sign * DVec3::new(c, s, 0.0))
            };
            Ok(build(Plan { spec, size }, eval))
        }
        Shape::Cone { height, radius, theta_max_degrees } => {
            finite(kind, &[height, radius, theta_max_degrees])?;
            let (h, r) = (height as f64, radius as f64);
            let theta_max = sweep_radians(theta_max_degrees);
            if r == 0.0 || theta_max == 0.0 {
                return Ok(TriangleMesh::default());
            }
            let size = DVec3::new(2.0 * r, 2.0 * r, h).length();
            let eps = tol.effective(size, scale)?;
            // Rulings through the apex: planar cells, the budget goes to the base ring.
            let nu = arc_segments(r, theta_max, eps);
            check_budget(kind, 2.0 * nu, tol)?;
            let mut spec = GridSpec::uniform(0.0, 1.0, nu as usize, 0.0, 1.0, 1);
            spec.u_periodic = is_full_turn(theta_max);
            let sign = (theta_max * r).signum();
            let eval = move |u: f64, v: f64| {
                let (s, c) = (u * theta_max).sin_cos();
                let rho = r * (1.0 - v);
                (DVec3::new(rho * c, rho * s, v * h), sign * DVec3::new(h * c, h * s, r))
            };
            Ok(build(Plan { spec, size }, eval))
        }
        Shape::Disk { height, radius, theta_max_degrees } => {
            finite(kind, &[height, radius, theta_max_degrees])?;
            let (h, r) = (height as f64, radius as f64);
            let theta_max = sweep_radians(theta_max_degrees);
            if r == 0.0 || theta_max == 0.0 {
                return Ok(TriangleMesh::default());
            }
            let size = 2.0 * r.abs() * std::f64::consts::SQRT_2;
            let eps = tol.effective(size, scale)?;
            // Flat: only the rim's chords deviate (from the disk's outline).
            let nu = arc_segments(r, theta_max, eps);
            check_budget(kind, nu, tol)?;
            let mut spec = GridSpec::uniform(0.0, 1.0, nu as usize, 0.0, 1.0, 1);
            spec.u_periodic = is_full_turn(theta_max);
            let normal = DVec3::new(0.0, 0.0, theta_max.signum());
            let eval = move |u: f64, v: f64| {
                let (s, c) = (u * theta_max).sin_cos();
                let rho = r * (1.0 - v);
                (DVec3::new(rho * c, rho * s, h), normal)
            };
            Ok(build(Plan { spec, size }, eval))
        }
        Shape::Paraboloid { r_max, z_min, z_max, theta_max_degrees } => {
            finite(kind, &[r_max, z_min, z_max, theta_max_degrees])?;
            let (rm, z0, z1, zm) = (r_max as f64, z_min as f64, z_max as f64, z_max as f64);
            let theta_max = sweep_radians(theta_max_degrees);
            if rm == 0.0 || zm == 0.0 || theta_max == 0.0 || z0 == z1 {
                return Ok(TriangleMesh::default());
            }
            // rho(z) = rmax sqrt(z / zmax); points beyond the apex side clamp to it.
            let rho_of = move |z: f64| rm * (z / zm).max(0.0).sqrt();
            let (rho0, rho1) = (rho_of(z0), rho_of(z1));
            let rho_max = rho0.abs().max(rho1.abs());
            let size = DVec3::new(2.0 * rho_max, 2.0 * rho_max, z1 - z0).length();
            let eps = tol.effective(size, scale)?;
            let nu = arc_segments(rho_max, theta_max, eps / 2.0);
            // The profile z = a rho^2 deviates from a chord of width h by a h^2 / 4: sample
            // evenly in rho with that sagitta at most eps / 2.
            let a = zm.abs() / (rm * rm);
            let h = (2.0 * eps / a).sqrt();
            let nv = ((rho1 - rho0).abs() / h - 1e-9).ceil().max(1.0);
            check_budget(kind, 2.0 * nu * nv, tol)?;
            let mut spec = GridSpec::uniform(0.0, 1.0, nu as usize, 0.0, 1.0, 1);
            spec.vs = linspace(rho0, rho1, nv as usize)
                .into_iter()
                .map(|rho| (zm * (rho / rm) * (rho / rm) - z0) / (z1 - z0))
                .collect();
            spec.vs[0] = 0.0;
            *spec.vs.last_mut().expect("two rows") = 1.0;
            spec.u_periodic = is_full_turn(theta_max);
            let sign = (theta_max * (z1 - z0)).signum();
            let eval = move |u: f64, v: f64| {
                let (s, c) = (u * theta_max).sin_cos();
                let z = z0 + v * (z1 - z0);
                let rho = rho_of(z);
                let p = DVec3::new(rho * c, rho * s, z);
                // dPdu x dPdv scaled by the positive rho / (theta_max dz) factor.
                let n = DVec3::new(p.x, p.y, -rm * rm / (2.0 * zm));
                (p, sign * n)
            };
            Ok(build(Plan { spec, size }, eval))
        }
        Shape::Hyperboloid { point1, point2, theta_max_degrees } => {
            finite(kind, &[point1.x, point1.y, point1.z, point2.x, point2.y, point2.z, theta_max_degrees])?;
            let (p1, p2) = (point1.as_dvec3(), point2.as_dvec3());
            let theta_max = sweep_radians(theta_max_degrees);
            let (rho1, rho2) = (p1.truncate().length(), p2.truncate().length());
            let rho_max = rho1.max(rho2);
            if theta_max == 0.0 || rho_max == 0.0 || p1 == p2 {
                return Ok(TriangleMesh::default());
            }
            let size = DVec3::new(2.0 * rho_max, 2.0 * rho_max, (p2.z - p1.z).abs()).length();
            let eps = tol.effective(size, scale)?;
            let nu = arc_segments(rho_max, theta_max, eps / 2.0);
            // Twist of a cell: |(R0 - R1)(L1 - L0)| / 4 <= 2 sin(dtheta / 2) |d_xy| dv / 4.
            let dtheta = theta_max.abs() / nu;
            let twist_per_v = 2.0 * (dtheta / 2.0).sin() * (p2 - p1).truncate().length() / 4.0;
            let nv = if twist_per_v > 0.0 { (twist_per_v / (eps / 2.0) - 1e-9).ceil().max(1.0) } else { 1.0 };
            check_budget(kind, 2.0 * nu * nv, tol)?;
            let mut spec = GridSpec::uniform(0.0, 1.0, nu as usize, 0.0, 1.0, nv as usize);
            spec.u_periodic = is_full_turn(theta_max);
            let d = p2 - p1;
            let eval = move |u: f64, v: f64| {
                let (s, c) = (u * theta_max).sin_cos();
                let l = p1 + v * d;
                let p = DVec3::new(l.x * c - l.y * s, l.x * s + l.y * c, l.z);
                let dpdu = theta_max * DVec3::new(-p.y, p.x, 0.0);
                let dpdv = DVec3::new(d.x * c - d.y * s, d.x * s + d.y * c, d.z);
                (p, dpdu.cross(dpdv))
            };
            Ok(build(Plan { spec, size }, eval))
        }
        Shape::Torus { major_radius, minor_radius, phi_min_degrees, phi_max_degrees, theta_max_degrees } => {
            finite(kind, &[major_radius, minor_radius, phi_min_degrees, phi_max_degrees, theta_max_degrees])?;
            let (big_r, r) = (major_radius as f64, minor_radius as f64);
            let theta_max = sweep_radians(theta_max_degrees);
            let phi_min = (phi_min_degrees as f64).to_radians();
            let mut phi_max = (phi_max_degrees as f64).to_radians();
            // More than a turn of the tube overlaps itself: clamp to one turn.
            if (phi_max - phi_min).abs() > TAU {
                phi_max = phi_min + TAU * (phi_max - phi_min).signum();
            }
            if r == 0.0 || theta_max == 0.0 || phi_max == phi_min {
                return Ok(TriangleMesh::default());
            }
            let outer = big_r.abs() + r.abs();
            let size = DVec3::new(2.0 * outer, 2.0 * outer, 2.0 * r.abs()).length();
            let eps = tol.effective(size, scale)?;
            // The widest ring over the phi range (cos phi largest where the range allows).
            let max_cos = max_cos_over(phi_min, phi_max);
            let rho_max = (big_r + r * max_cos).abs().max((big_r + r * min_cos_over(phi_min, phi_max)).abs());
            let nu = arc_segments(rho_max, theta_max, eps / 2.0);
            let nv = arc_segments(r, phi_max - phi_min, eps / 2.0);
            check_budget(kind, 2.0 * nu * nv, tol)?;
            let mut spec = GridSpec::uniform(0.0, 1.0, nu as usize, 0.0, 1.0, nv as usize);
            spec.u_periodic = is_full_turn(theta_max);
            spec.v_periodic = is_full_turn(phi_max - phi_min);
            let sign = (theta_max * (phi_max - phi_min) * r).signum();
            let eval = move |u: f64, v: f64| {
                let (s, c) = (u * theta_max).sin_cos();
                let phi = phi_min + v * (phi_max - phi_min);
                let (sp, cp) = phi.sin_cos();
                let rho = big_r + r * cp;
                let dir = DVec3::new(c * cp, s * cp, sp);
                (DVec3::new(rho * c, rho * s, r * sp), sign * rho.signum() * dir)
            };
            Ok(build(Plan { spec, size }, eval))
        }
        _ => Err(TessellateError::InvalidShape { kind, reason: "not a quadric".into() }),
    }
}

/// Largest `cos(phi)` for `phi` between `a` and `b`.
fn max_cos_over(a: f64, b: f64) -> f64 {
    let (lo, hi) = (a.min(b), a.max(b));
    let k = (lo / TAU).ceil();
    if k * TAU <= hi { 1.0 } else { lo.cos().max(hi.cos()) }
}

/// Smallest `cos(phi)` for `phi` between `a` and `b`.
fn min_cos_over(a: f64, b: f64) -> f64 {
    let (lo, hi) = (a.min(b), a.max(b));
    let k = ((lo - PI) / TAU).ceil();
    if PI + k * TAU <= hi { -1.0 } else { lo.cos().min(hi.cos()) }
}

fn build(plan: Plan, eval: impl Fn(f64, f64) -> (DVec3, DVec3)) -> TriangleMesh {
    let Plan { spec, size } = plan;
    let mut eval = eval;
    let st = |u: f64, v: f64| Vec2::new(u as f32, v as f32);
    let mut grid = Grid::evaluate(&spec, &mut eval, size * 1e-9, Some(&st));
    grid.emit_all(&|_, _| 0);
    grid.finish()
}
