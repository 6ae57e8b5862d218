//! A ray against a quadric: the implicit equation's roots in the ray's interval
//! (cancellation-free quadratics, the torus quartic by derivative bracketing), then each
//! candidate checked against the sweep and the z or angle limits and projected onto the surface.

use super::{HyperboloidSurface, Quadric, QuadricHit, QuadricShape, angle_of};
use crate::shapes::roots::{roots_in_interval, solve_quadratic};
use glam::{DVec2, DVec3};
use std::f64::consts::TAU;

impl Quadric {
    /// The closest hit of the ray `o + t d` with `t_min < t < t_max` that `accept` takes (it
    /// rejects e.g. back faces of one-sided shapes, letting the next root be tried).
    pub fn intersect(
        &self,
        o: DVec3,
        d: DVec3,
        t_min: f64,
        t_max: f64,
        mut accept: impl FnMut(&QuadricHit) -> bool,
    ) -> Option<QuadricHit> {
        let dd = d.length_squared();
        if !(dd > 0.0) || !o.is_finite() || !dd.is_finite() {
            return None;
        }
        // Clip to the bounding sphere (slightly enlarged) and move the origin up to it.
        let oc = o - self.bound_centre;
        let r = self.bound_radius * (1.0 + 1e-6) + 1e-300;
        let b = oc.dot(d);
        let f = oc - d * (b / dd);
        let disc = dd * (r + f.length()) * (r - f.length());
        if disc < 0.0 {
            return None;
        }
        let root = disc.sqrt();
        let q = if b < 0.0 { -(b - root) } else { -(b + root) };
        let (s0, s1) = if q == 0.0 {
            (0.0, 0.0)
        } else {
            let (x, y) = (q / dd, oc.length_squared() - r * r);
            (x, y / q)
        };
        let (s0, s1) = if s0 <= s1 { (s0, s1) } else { (s1, s0) };
        let lo = s0.max(t_min);
        let hi = s1.min(t_max);
        if lo > hi {
            return None;
        }
        let shift = if lo.is_finite() { lo } else { 0.0 };
        let os = o + d * shift;

        let mut roots = [0.0f64; 4];
        let n = self.candidate_roots(os, d, lo - shift, hi - shift, &mut roots);
        for &ts in &roots[..n] {
            let t = ts + shift;
            if !(t > t_min && t < t_max) {
                continue;
            }
            if let Some(hit) = self.hit_at(o, d, t)
                && accept(&hit)
            {
                return Some(hit);
            }
        }
        None
    }

    /// Ascending roots of the implicit equation along `o + t d` within `[lo, hi]` (a superset of
    /// the actual hits: limits are checked by [`Quadric::hit_at`]).
    fn candidate_roots(&self, o: DVec3, d: DVec3, lo: f64, hi: f64, out: &mut [f64; 4]) -> usize {
        let push_quadratic = |a: f64, b: f64, c: f64, out: &mut [f64; 4]| {
            let (r, n) = solve_quadratic(a, b, c);
            let mut k = 0;
            for &t in &r[..n] {
                if t >= lo && t <= hi {
                    out[k] = t;
                    k += 1;
                }
            }
            k
        };
        match self.shape {
            QuadricShape::Sphere { radius, .. } => {
                // pbrt-v4's discriminant: 4 a (r + |f|)(r - |f|), f = o - (b / 2a) d.
                let a = d.length_squared();
                let b = 2.0 * d.dot(o);
                let c = o.length_squared() - radius * radius;
                let f = o - d * (b / (2.0 * a));
                let fl = f.length();
                let disc = 4.0 * a * (radius + fl) * (radius - fl);
                quadratic_from_discriminant(a, b, c, disc, lo, hi, out)
            }
            QuadricShape::Cylinder { radius, .. } => {
                let a = d.x * d.x + d.y * d.y;
                if a == 0.0 {
                    return 0;
                }
                let b = 2.0 * (d.x * o.x + d.y * o.y);
                let c = o.x * o.x + o.y * o.y - radius * radius;
                let fx = o.x - d.x * (b / (2.0 * a));
                let fy = o.y - d.y * (b / (2.0 * a));
                let fl = (fx * fx + fy * fy).sqrt();
                let disc = 4.0 * a * (radius + fl) * (radius - fl);
                quadratic_from_discriminant(a, b, c, disc, lo, hi, out)
            }
            QuadricShape::Disk { height, .. } => plane_root(o.z, d.z, height, lo, hi, out),
            QuadricShape::Cone { height, radius } => {
                let k = (radius / height) * (radius / height);
                let oz = o.z - height;
                let a = d.x * d.x + d.y * d.y - k * d.z * d.z;
                let b = 2.0 * (d.x * o.x + d.y * o.y - k * d.z * oz);
                let c = o.x * o.x + o.y * o.y - k * oz * oz;
                push_quadratic(a, b, c, out)
            }
            QuadricShape::Paraboloid { r_max, z_max, .. } => {
                let k = z_max / (r_max * r_max);
                let a = k * (d.x * d.x + d.y * d.y);
                let b = 2.0 * k * (d.x * o.x + d.y * o.y) - d.z;
                let c = k * (o.x * o.x + o.y * o.y) - o.z;
                push_quadratic(a, b, c, out)
            }
            QuadricShape::Hyperboloid { surface, .. } => match surface {
                HyperboloidSurface::Revolved { a: ka, b: kb, c: kc, .. } => {
                    let a = d.x * d.x + d.y * d.y - ka * d.z * d.z;
                    let b = 2.0 * (o.x * d.x + o.y * d.y) - 2.0 * ka * o.z * d.z - kb * d.z;
                    let c = o.x * o.x + o.y * o.y - ka * o.z * o.z - kb * o.z - kc;
                    push_quadratic(a, b, c, out)
                }
                HyperboloidSurface::Annulus { z } => plane_root(o.z, d.z, z, lo, hi, out),
            },
            QuadricShape::Torus { major, minor, .. } => {
                // Solve with a unit direction for conditioning, then scale back.
                let len = d.length();
                let du = d / len;
                let od = o.dot(du);
                let k = o.length_squared() + major * major - minor * minor;
                let r2 = 4.0 * major * major;
                let c4 = 1.0;
                let c3 = 4.0 * od;
                let c2 = 4.0 * od * od + 2.0 * k - r2 * (du.x * du.x + du.y * du.y);
                let c1 = 4.0 * od * k - 2.0 * r2 * (o.x * du.x + o.y * du.y);
                let c0 = k * k - r2 * (o.x * o.x + o.y * o.y);
                let mut roots = Vec::with_capacity(4);
                roots_in_interval(&[c0, c1, c2, c3, c4], lo * len, hi * len, &mut roots);
                let n = roots.len().min(4);
                for (slot, t) in out.iter_mut().zip(roots.iter()) {
                    *slot = t / len;
                }
                n
            }
        }
    }

    /// The surface point at ray parameter `t`, if it lies within the quadric's limits.
    fn hit_at(&self, o: DVec3, d: DVec3, t: f64) -> Option<QuadricHit> {
        let mut p = o + d * t;
        let uv;
        match self.shape {
            QuadricShape::Sphere { radius, z_min, z_max, lat_min, lat_max } => {
                let len = p.length();
                if len == 0.0 {
                    return None;
                }
                p *= radius / len;
                if p.z < z_min.min(z_max) || p.z > z_min.max(z_max) {
                    return None;
                }
                let u = self.sweep_u(p)?;
                let lat = (p.z / radius).clamp(-1.0, 1.0).asin();
                uv = DVec2::new(u, (lat - lat_min) / (lat_max - lat_min));
            }
            QuadricShape::Cylinder { radius, z_min, z_max } => {
                let rho = (p.x * p.x + p.y * p.y).sqrt();
                if rho == 0.0 {
                    return None;
                }
                p.x *= radius / rho;
                p.y *= radius / rho;
                if p.z < z_min.min(z_max) || p.z > z_min.max(z_max) {
                    return None;
                }
                uv = DVec2::new(self.sweep_u(p)?, (p.z - z_min) / (z_max - z_min));
            }
            QuadricShape::Disk { height, radius } => {
                p.z = height;
                let rho = (p.x * p.x + p.y * p.y).sqrt();
                if rho > radius {
                    return None;
                }
                uv = DVec2::new(self.sweep_u(p)?, 1.0 - rho / radius);
            }
            QuadricShape::Cone { height, .. } => {
                if p.z < height.min(0.0) || p.z > height.max(0.0) {
                    return None;
                }
                uv = DVec2::new(self.sweep_u(p)?, p.z / height);
            }
            QuadricShape::Paraboloid { z_min, z_max, .. } => {
                if p.z < z_min.min(z_max) || p.z > z_min.max(z_max) {
                    return None;
                }
                uv = DVec2::new(self.sweep_u(p)?, (p.z - z_min) / (z_max - z_min));
            }
            QuadricShape::Hyperboloid { p1, p2, surface } => {
                let dl = p2 - p1;
                let angle = angle_of(p.x, p.y);
                match surface {
                    HyperboloidSurface::Revolved { z_lo, z_hi, .. } => {
                        if p.z < z_lo || p.z > z_hi {
                            return None;
                        }
                        let v = (p.z - p1.z) / dl.z;
                        let theta = self.sweep_angle_from_line(angle, p1 + dl * v)?;
                        uv = DVec2::new(theta, v);
                    }
                    HyperboloidSurface::Annulus { z } => {
                        p.z = z;
                        // Points of the segment at the hit's radius: |q + v dq|^2 = rho^2.
                        let (q, dq) = (DVec2::new(p1.x, p1.y), DVec2::new(dl.x, dl.y));
                        let rho2 = p.x * p.x + p.y * p.y;
                        let (vs, n) = solve_quadratic(dq.dot(dq), 2.0 * q.dot(dq), q.dot(q) - rho2);
                        let mut found = None;
                        for &v in &vs[..n] {
                            if (-1e-12..=1.0 + 1e-12).contains(&v) {
                                let v = v.clamp(0.0, 1.0);
                                if let Some(u) = self.sweep_angle_from_line(angle, p1 + dl * v) {
                                    found = Some(DVec2::new(u, v));
                                    break;
                                }
                            }
                        }
                        uv = found?;
                    }
                }
            }
            QuadricShape::Torus { major, minor, phi_min, phi_max } => {
                let rho = (p.x * p.x + p.y * p.y).sqrt();
                if rho == 0.0 {
                    return None;
                }
                let centre = DVec3::new(p.x, p.y, 0.0) * (major / rho);
                let off = p - centre;
                let ol = off.length();
                if ol == 0.0 {
                    return None;
                }
                p = centre + off * (minor / ol);
                let u = self.sweep_u(p)?;
                let rho = (p.x * p.x + p.y * p.y).sqrt();
                let phi = p.z.atan2(rho - major);
                let v = phi_param(phi, phi_min, phi_max)?;
                uv = DVec2::new(u, v);
            }
        }
        let n = self.normal_at(p);
        Some(QuadricHit { t, p, n, uv, dpdu: self.dpdu_at(p) })
    }

    /// The parametric u of a hit `p` (object space) whose angle about z lies in the sweep.
    fn sweep_u(&self, p: DVec3) -> Option<f64> {
        let angle = angle_of(p.x, p.y);
        if self.in_sweep(angle) { Some(self.u_of(angle)) } else { None }
    }

    /// For a surface of revolution of a line point `l`: the parametric u of the hit at `angle`,
    /// when the rotation from `l` to the hit lies in the sweep.
    fn sweep_angle_from_line(&self, angle: f64, l: DVec3) -> Option<f64> {
        if l.x == 0.0 && l.y == 0.0 {
            return Some(0.0);
        }
        let rotation = (angle - angle_of(l.x, l.y)).rem_euclid(TAU);
        if self.in_sweep(rotation) { Some(self.u_of(rotation)) } else { None }
    }
}

/// Solves `a t^2 + b t + c = 0` given an accurately computed discriminant; roots in `[lo, hi]`.
fn quadratic_from_discriminant(
    a: f64,
    b: f64,
    c: f64,
    disc: f64,
    lo: f64,
    hi: f64,
    out: &mut [f64; 4],
) -> usize {
    if !(disc >= 0.0) || a == 0.0 {
        return 0;
    }
    let root = disc.sqrt();
    let q = if b < 0.0 { -0.5 * (b - root) } else { -0.5 * (b + root) };
    let (t0, t1) = if q == 0.0 { (0.0, 0.0) } else { (q / a, c / q) };
    let (t0, t1) = if t0 <= t1 { (t0, t1) } else { (t1, t0) };
    let mut k = 0;
    for t in [t0, t1] {
        if t >= lo && t <= hi {
            out[k] = t;
            k += 1;
        }
    }
    k
}

/// The torus v parameter of angle `phi`, if it lies in `[phi_min, phi_max]` (either order).
fn phi_param(phi: f64, phi_min: f64, phi_max: f64) -> Option<f64> {
    let (lo, hi) = if phi_min <= phi_max { (phi_min, phi_max) } else { (phi_max, phi_min) };
    // Bring phi into [lo, lo + 2 pi).
    let p = lo + (phi - lo).rem_euclid(TAU);
    let tolerance = 1e-12 * (1.0 + hi.abs());
    if p <= hi + tolerance {
        Some((p - phi_min) / (phi_max - phi_min))
    } else if (p - TAU) >= lo - tolerance {
        Some((p - TAU - phi_min) / (phi_max - phi_min))
    } else {
        None
    }
}

/// The root of `o_z + t d_z = z` in `[lo, hi]` (a disk's or a flat annulus's plane), into
/// `out[0]`; the number of roots.
fn plane_root(o_z: f64, d_z: f64, z: f64, lo: f64, hi: f64, out: &mut [f64; 4]) -> usize {
    if d_z == 0.0 {
        return 0;
    }
    let t = (z - o_z) / d_z;
    if t >= lo && t <= hi {
        out[0] = t;
        1
    } else {
        0
    }
}
