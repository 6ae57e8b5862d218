//! RenderMan quadrics intersected exactly in their own object space, in `f64`.
//!
//! Each quadric is the RISpec surface with its sweep (`thetamax`) and its z or angle limits. A
//! ray is brought into object space in `f64`, moved up to the quadric's bounding sphere (so that
//! far-away origins do not cost precision), and the implicit equation is solved with
//! cancellation-free formulas (the torus quartic by derivative bracketing, [`super::roots`]).
//! Hit points are projected back onto the surface where the projection is exact (sphere,
//! cylinder, disk, torus), so the error left is far below the `f32` rounding of render space.
//!
//! Normals: the geometric normal is the direction of `dP/du x dP/dv` of the RenderMan
//! parametrisation, found once per quadric by comparing that cross product with the implicit
//! gradient ([`Quadric::orientation`]); at every hit the (robust) gradient is used with that sign.

mod intersect;

use super::roots::solve_quadratic;
use glam::{DVec2, DVec3};
use std::f64::consts::TAU;

/// The hyperboloid's surface: `x^2 + y^2 = a z^2 + b z + c` for `z` in `[z_lo, z_hi]`, or a flat
/// annulus when the generating segment is horizontal.
#[derive(Clone, Copy, Debug, PartialEq)]
pub enum HyperboloidSurface {
    Revolved { a: f64, b: f64, c: f64, z_lo: f64, z_hi: f64 },
    Annulus { z: f64 },
}

/// The shape of a quadric, with every limit resolved (angles in radians).
#[derive(Clone, Copy, Debug, PartialEq)]
pub enum QuadricShape {
    Sphere { radius: f64, z_min: f64, z_max: f64, lat_min: f64, lat_max: f64 },
    Cylinder { radius: f64, z_min: f64, z_max: f64 },
    Cone { height: f64, radius: f64 },
    Disk { height: f64, radius: f64 },
    Paraboloid { r_max: f64, z_min: f64, z_max: f64 },
    Hyperboloid { p1: DVec3, p2: DVec3, surface: HyperboloidSurface },
    Torus { major: f64, minor: f64, phi_min: f64, phi_max: f64 },
}

/// A quadric ready for intersection.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct Quadric {
    pub shape: QuadricShape,
    /// The sweep angle in radians, signed as given, `|theta_max| <= 2 pi`.
    pub theta_max: f64,
    /// `+1` when `dP/du x dP/dv` points along the implicit gradient, `-1` otherwise.
    pub orientation: f64,
    /// Object-space bounding box.
    pub bounds_min: DVec3,
    pub bounds_max: DVec3,
    bound_centre: DVec3,
    bound_radius: f64,
}

/// A hit in object space.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct QuadricHit {
    pub t: f64,
    pub p: DVec3,
    /// Unit geometric normal, along `dP/du x dP/dv` (before any `ReverseOrientation`).
    pub n: DVec3,
    /// RenderMan parametric coordinates.
    pub uv: DVec2,
    /// `dP/du` (for the shading frame's tangent); may be zero at poles.
    pub dpdu: DVec3,
}

/// Why a quadric cannot be made.
#[derive(Clone, Debug, PartialEq)]
pub struct DegenerateQuadric(pub &'static str);

fn finite(values: &[f64]) -> bool {
    values.iter().all(|v| v.is_finite())
}

/// Angle of `(x, y)` in `[0, 2 pi)`.
#[inline]
fn angle_of(x: f64, y: f64) -> f64 {
    let a = y.atan2(x);
    if a < 0.0 { a + TAU } else { a }
}

impl Quadric {
    /// Makes a quadric from RIB parameters. `theta_max_degrees` etc. are in degrees.
    pub fn new(shape: &rib_parser::scene::Shape) -> Result<Quadric, DegenerateQuadric> {
        use rib_parser::scene::Shape as S;
        let f = |v: f32| f64::from(v);
        let (shape, theta_deg) = match *shape {
            S::Sphere { radius, z_min, z_max, theta_max_degrees } => {
                let r = f(radius).abs();
                if !finite(&[r, f(z_min), f(z_max)]) || r == 0.0 {
                    return Err(DegenerateQuadric("sphere with zero or non-finite radius"));
                }
                let z0 = f(z_min).clamp(-r, r);
                let z1 = f(z_max).clamp(-r, r);
                if z0 == z1 {
                    return Err(DegenerateQuadric("sphere with zmin = zmax"));
                }
                let shape = QuadricShape::Sphere {
                    radius: r,
                    z_min: z0,
                    z_max: z1,
                    lat_min: (z0 / r).asin(),
                    lat_max: (z1 / r).asin(),
                };
                (shape, theta_max_degrees)
            }
            S::Cylinder { radius, z_min, z_max, theta_max_degrees } => {
                let r = f(radius).abs();
                if !finite(&[r, f(z_min), f(z_max)]) || r == 0.0 || z_min == z_max {
                    return Err(DegenerateQuadric("cylinder with zero radius or height"));
                }
                (QuadricShape::Cylinder { radius: r, z_min: f(z_min), z_max: f(z_max) }, theta_max_degrees)
            }
            S::Cone { height, radius, theta_max_degrees } => {
                let (h, r) = (f(height), f(radius).abs());
                if !finite(&[h, r]) || h == 0.0 || r == 0.0 {
                    return Err(DegenerateQuadric("cone with zero height or radius"));
                }
                (QuadricShape::Cone { height: h, radius: r }, theta_max_degrees)
            }
            S::Disk { height, radius, theta_max_degrees } => {
                let (h, r) = (f(height), f(radius).abs());
                if !finite(&[h, r]) || r == 0.0 {
                    return Err(DegenerateQuadric("disk with zero radius"));
                }
                (QuadricShape::Disk { height: h, radius: r }, theta_max_degrees)
            }
            S::Paraboloid { r_max, z_min, z_max, theta_max_degrees } => {
                let (r, z0, z1) = (f(r_max).abs(), f(z_min), f(z_max));
                if !finite(&[r, z0, z1]) || r == 0.0 || z1 == 0.0 || z0 == z1 {
                    return Err(DegenerateQuadric("paraboloid with zero rmax, zmax or height"));
                }
                // Only the part with z / zmax >= 0 exists.
                let (lo, hi) = (z0.min(z1), z0.max(z1));
                let (lo, hi) = if z1 > 0.0 { (lo.max(0.0), hi.max(0.0)) } else { (lo.min(0.0), hi.min(0.0)) };
                if lo == hi {
                    return Err(DegenerateQuadric("paraboloid whose z range lies outside the surface"));
                }
                let (z0c, z1c) = if z0 <= z1 { (lo, hi) } else { (hi, lo) };
                (QuadricShape::Paraboloid { r_max: r, z_min: z0c, z_max: z1c }, theta_max_degrees)
            }
            S::Hyperboloid { point1, point2, theta_max_degrees } => {
                let (p1, p2) = (point1.as_dvec3(), point2.as_dvec3());
                if !(p1.is_finite() && p2.is_finite()) || p1 == p2 {
                    return Err(DegenerateQuadric("hyperboloid with coincident points"));
                }
                let dz = p2.z - p1.z;
                let surface = if dz == 0.0 {
                    HyperboloidSurface::Annulus { z: p1.z }
                } else {
                    let s = 1.0 / dz;
                    let (q, dq) = (DVec2::new(p1.x, p1.y), DVec2::new(p2.x - p1.x, p2.y - p1.y));
                    let dd = dq.dot(dq);
                    let qd = q.dot(dq);
                    HyperboloidSurface::Revolved {
                        a: dd * s * s,
                        b: 2.0 * qd * s - 2.0 * p1.z * dd * s * s,
                        c: q.dot(q) - 2.0 * qd * s * p1.z + dd * s * s * p1.z * p1.z,
                        z_lo: p1.z.min(p2.z),
                        z_hi: p1.z.max(p2.z),
                    }
                };
                let xy = |p: DVec3| DVec2::new(p.x, p.y).length();
                if xy(p1) == 0.0 && xy(p2) == 0.0 {
                    return Err(DegenerateQuadric("hyperboloid whose segment lies on the z axis"));
                }
                (QuadricShape::Hyperboloid { p1, p2, surface }, theta_max_degrees)
            }
            S::Torus { major_radius, minor_radius, phi_min_degrees, phi_max_degrees, theta_max_degrees } => {
                let (big, small) = (f(major_radius), f(minor_radius).abs());
                let (p0, p1) = (f(phi_min_degrees).to_radians(), f(phi_max_degrees).to_radians());
                if !finite(&[big, small, p0, p1]) || small == 0.0 || p0 == p1 {
                    return Err(DegenerateQuadric("torus with zero minor radius or phi range"));
                }
                // A phi range wider than a full turn is a full turn.
                let p1 = if (p1 - p0).abs() > TAU { p0 + TAU.copysign(p1 - p0) } else { p1 };
                (
                    QuadricShape::Torus { major: big, minor: small, phi_min: p0, phi_max: p1 },
                    theta_max_degrees,
                )
            }
            _ => return Err(DegenerateQuadric("not a quadric")),
        };
        let theta = f(theta_deg).to_radians();
        if !theta.is_finite() || theta == 0.0 {
            return Err(DegenerateQuadric("quadric with thetamax = 0"));
        }
        let theta_max = theta.clamp(-TAU, TAU);
        let (bounds_min, bounds_max) = object_bounds(&shape);
        let mut q = Quadric {
            shape,
            theta_max,
            orientation: 1.0,
            bounds_min,
            bounds_max,
            bound_centre: (bounds_min + bounds_max) * 0.5,
            bound_radius: (bounds_max - bounds_min).length() * 0.5,
        };
        q.orientation = q.find_orientation();
        Ok(q)
    }

    /// The RenderMan parametrisation `P(u, v)`.
    pub fn point_at(&self, u: f64, v: f64) -> DVec3 {
        let theta = u * self.theta_max;
        let (s, c) = theta.sin_cos();
        match self.shape {
            QuadricShape::Sphere { radius, lat_min, lat_max, .. } => {
                let lat = lat_min + v * (lat_max - lat_min);
                DVec3::new(radius * lat.cos() * c, radius * lat.cos() * s, radius * lat.sin())
            }
            QuadricShape::Cylinder { radius, z_min, z_max } => {
                DVec3::new(radius * c, radius * s, z_min + v * (z_max - z_min))
            }
            QuadricShape::Cone { height, radius } => {
                DVec3::new((1.0 - v) * radius * c, (1.0 - v) * radius * s, v * height)
            }
            QuadricShape::Disk { height, radius } => {
                DVec3::new((1.0 - v) * radius * c, (1.0 - v) * radius * s, height)
            }
            QuadricShape::Paraboloid { r_max, z_min, z_max } => {
                let z = z_min + v * (z_max - z_min);
                let rho = r_max * (z / z_max).max(0.0).sqrt();
                DVec3::new(rho * c, rho * s, z)
            }
            QuadricShape::Hyperboloid { p1, p2, .. } => {
                let l = p1 + (p2 - p1) * v;
                DVec3::new(l.x * c - l.y * s, l.x * s + l.y * c, l.z)
            }
            QuadricShape::Torus { major, minor, phi_min, phi_max } => {
                let phi = phi_min + v * (phi_max - phi_min);
                let rho = major + minor * phi.cos();
                DVec3::new(rho * c, rho * s, minor * phi.sin())
            }
        }
    }

    /// The implicit gradient at a surface point (not normalised): its sign convention is fixed
    /// per shape, and [`Quadric::orientation`] relates it to the parametric normal.
    fn gradient(&self, p: DVec3) -> DVec3 {
        match self.shape {
            QuadricShape::Sphere { .. } => p,
            QuadricShape::Cylinder { .. } => DVec3::new(p.x, p.y, 0.0),
            QuadricShape::Cone { height, radius } => {
                let k = (radius / height) * (radius / height);
                let g = DVec3::new(p.x, p.y, k * (height - p.z));
                if g.length_squared() > 0.0 { g } else { DVec3::new(0.0, 0.0, height.signum()) }
            }
            QuadricShape::Disk { .. } => DVec3::Z,
            QuadricShape::Paraboloid { r_max, z_max, .. } => {
                DVec3::new(p.x, p.y, -r_max * r_max / (2.0 * z_max))
            }
            QuadricShape::Hyperboloid { surface, .. } => match surface {
                HyperboloidSurface::Revolved { a, b, .. } => {
                    let g = DVec3::new(p.x, p.y, -(a * p.z + 0.5 * b));
                    if g.length_squared() > 0.0 { g } else { DVec3::Z }
                }
                HyperboloidSurface::Annulus { .. } => DVec3::Z,
            },
            QuadricShape::Torus { major, .. } => {
                let rho = (p.x * p.x + p.y * p.y).sqrt();
                let centre = if rho > 0.0 { DVec3::new(p.x, p.y, 0.0) * (major / rho) } else { DVec3::ZERO };
                let g = p - centre;
                if g.length_squared() > 0.0 { g } else { DVec3::new(0.0, 0.0, 1.0) }
            }
        }
    }

    /// Compares `dP/du x dP/dv` (central differences) with the gradient at a few generic
    /// parameter values, and returns the sign relating them.
    fn find_orientation(&self) -> f64 {
        for (u, v) in [(0.5, 0.5), (0.31, 0.27), (0.77, 0.63), (0.13, 0.91)] {
            let h = 1e-5;
            let dpdu = (self.point_at(u + h, v) - self.point_at(u - h, v)) / (2.0 * h);
            let dpdv = (self.point_at(u, v + h) - self.point_at(u, v - h)) / (2.0 * h);
            let n = dpdu.cross(dpdv);
            let g = self.gradient(self.point_at(u, v));
            let d = n.dot(g);
            if d.abs() > 1e-9 * n.length() * g.length() && d.is_finite() {
                return d.signum();
            }
        }
        1.0
    }

    /// The unit geometric normal at a surface point.
    #[inline]
    pub fn normal_at(&self, p: DVec3) -> DVec3 {
        (self.gradient(p) * self.orientation).normalize_or(DVec3::Z)
    }

    /// True when the angle of the point `(x, y)` lies inside the sweep.
    #[inline]
    fn in_sweep(&self, angle: f64) -> bool {
        if self.theta_max.abs() >= TAU {
            return true;
        }
        if self.theta_max >= 0.0 {
            angle <= self.theta_max
        } else {
            let a = if angle == 0.0 { 0.0 } else { TAU - angle };
            a <= -self.theta_max
        }
    }

    /// Parametric u of an angle in the sweep.
    #[inline]
    fn u_of(&self, angle: f64) -> f64 {
        if self.theta_max >= 0.0 {
            angle / self.theta_max
        } else {
            (if angle == 0.0 { 0.0 } else { TAU - angle }) / -self.theta_max
        }
    }

    /// `dP/du` from the angle direction (the sweep is about z).
    #[inline]
    fn dpdu_at(&self, p: DVec3) -> DVec3 {
        DVec3::new(-p.y, p.x, 0.0) * self.theta_max
    }

    // -----------------------------------------------------------------------------------------
    // Area sampling (for area lights): a sampling parametrisation S(a, b) over [0, 1)^2 and the
    // vector dS/da x dS/db, whose length is the object-space area per unit (a, b).

    /// A point on the surface for `(a, b)` in `[0, 1)^2`, with its unit normal.
    pub fn sample_point(&self, a: f64, b: f64) -> (DVec3, DVec3) {
        let theta = a * self.theta_max;
        let (s, c) = theta.sin_cos();
        let p = match self.shape {
            QuadricShape::Sphere { radius, z_min, z_max, .. } => {
                let z = z_min + b * (z_max - z_min);
                let rho = (radius * radius - z * z).max(0.0).sqrt();
                DVec3::new(rho * c, rho * s, z)
            }
            QuadricShape::Cylinder { radius, z_min, z_max } => {
                DVec3::new(radius * c, radius * s, z_min + b * (z_max - z_min))
            }
            QuadricShape::Disk { height, radius } => {
                let rho = radius * b.sqrt();
                DVec3::new(rho * c, rho * s, height)
            }
            QuadricShape::Cone { height, radius } => {
                let k = b.sqrt();
                DVec3::new(radius * k * c, radius * k * s, height * (1.0 - k))
            }
            _ => self.point_at(a, b),
        };
        (p, self.normal_at(p))
    }

    /// `dS/da x dS/db` at surface point `p` for the sampling parametrisation of
    /// [`Quadric::sample_point`] (its direction is the normal's, up to sign).
    pub fn sample_density_vector(&self, p: DVec3) -> DVec3 {
        let n = self.normal_at(p);
        let t = self.theta_max.abs();
        let magnitude = match self.shape {
            QuadricShape::Sphere { radius, z_min, z_max, .. } => t * (z_max - z_min).abs() * radius,
            QuadricShape::Cylinder { radius, z_min, z_max } => t * (z_max - z_min).abs() * radius,
            QuadricShape::Disk { radius, .. } => t * radius * radius * 0.5,
            QuadricShape::Cone { height, radius } => {
                t * radius * (height * height + radius * radius).sqrt() * 0.5
            }
            QuadricShape::Paraboloid { r_max, z_min, z_max } => {
                let dz = z_max - z_min;
                let rho = (p.x * p.x + p.y * p.y).sqrt();
                let k = r_max * r_max * dz / (2.0 * z_max);
                t * (rho * rho * dz * dz + k * k).sqrt()
            }
            QuadricShape::Hyperboloid { p1, p2, surface } => {
                let dl = p2 - p1;
                let angle = angle_of(p.x, p.y);
                // The segment parameter of the point, then the rotation that carries the segment
                // point onto it.
                let v = match surface {
                    HyperboloidSurface::Revolved { .. } => (p.z - p1.z) / dl.z,
                    HyperboloidSurface::Annulus { .. } => {
                        let (q, dq) = (DVec2::new(p1.x, p1.y), DVec2::new(dl.x, dl.y));
                        let rho2 = p.x * p.x + p.y * p.y;
                        let (vs, k) = solve_quadratic(dq.dot(dq), 2.0 * q.dot(dq), q.dot(q) - rho2);
                        if k == 0 { 0.0 } else { vs[k - 1].clamp(0.0, 1.0) }
                    }
                };
                let l = p1 + dl * v;
                let rot = if l.x == 0.0 && l.y == 0.0 { 0.0 } else { angle - angle_of(l.x, l.y) };
                let (s, c) = rot.sin_cos();
                let dldv = DVec3::new(dl.x * c - dl.y * s, dl.x * s + dl.y * c, dl.z);
                let dpdtheta = DVec3::new(-p.y, p.x, 0.0) * t;
                dpdtheta.cross(dldv).length()
            }
            QuadricShape::Torus { minor, phi_min, phi_max, .. } => {
                // |dP/dtheta x dP/dphi| = minor * (distance from the axis).
                let rho = (p.x * p.x + p.y * p.y).sqrt();
                t * (phi_max - phi_min).abs() * minor * rho
            }
        };
        n * magnitude
    }
}

fn object_bounds(shape: &QuadricShape) -> (DVec3, DVec3) {
    let cube = |r: f64, z0: f64, z1: f64| (DVec3::new(-r, -r, z0.min(z1)), DVec3::new(r, r, z0.max(z1)));
    match *shape {
        QuadricShape::Sphere { radius, z_min, z_max, .. } => cube(radius, z_min, z_max),
        QuadricShape::Cylinder { radius, z_min, z_max } => cube(radius, z_min, z_max),
        QuadricShape::Cone { height, radius } => cube(radius, 0.0, height),
        QuadricShape::Disk { height, radius } => cube(radius, height, height),
        QuadricShape::Paraboloid { r_max, z_min, z_max } => {
            let k = (z_min / z_max).max(1.0);
            cube(r_max * k.sqrt(), z_min, z_max)
        }
        QuadricShape::Hyperboloid { p1, p2, .. } => {
            let r = DVec2::new(p1.x, p1.y).length().max(DVec2::new(p2.x, p2.y).length());
            cube(r, p1.z, p2.z)
        }
        QuadricShape::Torus { major, minor, .. } => cube(major.abs() + minor, -minor, minor),
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use rib_parser::scene::Shape;
    use std::f64::consts::PI;

    fn q(shape: Shape) -> Quadric {
        Quadric::new(&shape).unwrap()
    }

    fn first_hit(quadric: &Quadric, o: DVec3, d: DVec3) -> Option<QuadricHit> {
        quadric.intersect(o, d, 0.0, f64::INFINITY, |_| true)
    }

    #[test]
    fn sphere_hits_and_normals_point_out() {
        let s = q(Shape::Sphere { radius: 2.0, z_min: -2.0, z_max: 2.0, theta_max_degrees: 360.0 });
        let h = first_hit(&s, DVec3::new(0.0, 0.0, -10.0), DVec3::Z).unwrap();
        assert!((h.t - 8.0).abs() < 1e-12);
        assert!((h.n - DVec3::new(0.0, 0.0, -1.0)).length() < 1e-12);
        // From inside: the far side, normal still pointing out.
        let h = first_hit(&s, DVec3::ZERO, DVec3::X).unwrap();
        assert!((h.t - 2.0).abs() < 1e-12 && h.n.x > 0.99);
        // Far away origin keeps precision.
        let h = first_hit(&s, DVec3::new(0.3, 0.1, -1e7), DVec3::Z).unwrap();
        let exact = 1e7 - (4.0f64 - 0.09 - 0.01).sqrt();
        assert!((h.t - exact).abs() < 1e-8 * exact, "{} vs {}", h.t, exact);
    }

    #[test]
    fn partial_sphere_sweep_and_z_limits() {
        let s = q(Shape::Sphere { radius: 1.0, z_min: -0.5, z_max: 0.5, theta_max_degrees: 90.0 });
        // Aim at angle 45 degrees, z = 0: inside the sweep.
        let target = DVec3::new(0.5f64.sqrt(), 0.5f64.sqrt(), 0.0);
        assert!(first_hit(&s, target * 3.0, -target).is_some());
        // Angle 135 degrees: outside the sweep; the ray then crosses the back at -45: outside too.
        let t2 = DVec3::new(-(0.5f64.sqrt()), 0.5f64.sqrt(), 0.0);
        assert!(first_hit(&s, t2 * 3.0, -t2).is_none());
        // Above zmax.
        assert!(first_hit(&s, DVec3::new(0.3, 0.3, 5.0), -DVec3::Z).is_none());
    }

    #[test]
    fn cylinder_cone_disk_paraboloid() {
        let c = q(Shape::Cylinder { radius: 1.0, z_min: 0.0, z_max: 2.0, theta_max_degrees: 360.0 });
        let h = first_hit(&c, DVec3::new(-5.0, 0.0, 1.0), DVec3::X).unwrap();
        assert!((h.t - 4.0).abs() < 1e-12 && h.n.x < -0.99);
        let cone = q(Shape::Cone { height: 2.0, radius: 1.0, theta_max_degrees: 360.0 });
        // At z = 1 the cone's radius is 0.5.
        let h = first_hit(&cone, DVec3::new(-5.0, 0.0, 1.0), DVec3::X).unwrap();
        assert!((h.t - 4.5).abs() < 1e-12);
        assert!(h.n.x < 0.0 && h.n.z > 0.0);
        let disk = q(Shape::Disk { height: 1.0, radius: 2.0, theta_max_degrees: 360.0 });
        let h = first_hit(&disk, DVec3::new(0.5, 0.5, 4.0), -DVec3::Z).unwrap();
        assert!((h.t - 3.0).abs() < 1e-12);
        assert!(h.n.z.abs() > 0.999);
        assert!(first_hit(&disk, DVec3::new(2.5, 0.0, 4.0), -DVec3::Z).is_none());
        let para = q(Shape::Paraboloid { r_max: 1.0, z_min: 0.0, z_max: 1.0, theta_max_degrees: 360.0 });
        // z = x^2 + y^2 hit from above at x = 0.5: z = 0.25; the ray enters through the open top.
        let h = first_hit(&para, DVec3::new(0.5, 0.0, 3.0), -DVec3::Z).unwrap();
        assert!((h.p.z - 0.25).abs() < 1e-12);
    }

    #[test]
    fn hyperboloid_matches_its_line() {
        // Segment from (1,0,-1) to (0,1,1): a one-sheet hyperboloid.
        let hy = q(Shape::Hyperboloid {
            point1: glam::Vec3::new(1.0, 0.0, -1.0),
            point2: glam::Vec3::new(0.0, 1.0, 1.0),
            theta_max_degrees: 360.0,
        });
        // At z = 0 the segment point is (0.5, 0.5): radius^2 = 0.5.
        let h = first_hit(&hy, DVec3::new(-5.0, 0.0, 0.0), DVec3::X).unwrap();
        assert!((h.p.x + 0.5f64.sqrt()).abs() < 1e-12, "{:?}", h.p);
        // Flat annulus from a horizontal segment.
        let an = q(Shape::Hyperboloid {
            point1: glam::Vec3::new(1.0, 0.0, 0.5),
            point2: glam::Vec3::new(2.0, 0.0, 0.5),
            theta_max_degrees: 360.0,
        });
        assert!(first_hit(&an, DVec3::new(1.5, 0.0, 3.0), -DVec3::Z).is_some());
        assert!(first_hit(&an, DVec3::new(0.5, 0.0, 3.0), -DVec3::Z).is_none());
    }

    #[test]
    fn torus_hits() {
        let t = q(Shape::Torus {
            major_radius: 2.0,
            minor_radius: 0.5,
            phi_min_degrees: 0.0,
            phi_max_degrees: 360.0,
            theta_max_degrees: 360.0,
        });
        let h = first_hit(&t, DVec3::new(-10.0, 0.0, 0.0), DVec3::X).unwrap();
        assert!((h.t - 7.5).abs() < 1e-9, "{}", h.t);
        assert!(h.n.x < -0.999);
        // Through the hole along z: miss.
        assert!(first_hit(&t, DVec3::new(0.0, 0.0, 5.0), -DVec3::Z).is_none());
        // Down onto the tube top at x = 2.
        let h = first_hit(&t, DVec3::new(2.0, 0.0, 5.0), -DVec3::Z).unwrap();
        assert!((h.t - 4.5).abs() < 1e-9 && h.n.z > 0.999);
        // Only the upper half of the tube (phi in [0, 180]): from below at x = 2, hit the inner
        // side of the upper half at z = +0.5.
        let half = q(Shape::Torus {
            major_radius: 2.0,
            minor_radius: 0.5,
            phi_min_degrees: 0.0,
            phi_max_degrees: 180.0,
            theta_max_degrees: 360.0,
        });
        let h = first_hit(&half, DVec3::new(2.0, 0.0, -5.0), DVec3::Z).unwrap();
        assert!((h.p.z - 0.5).abs() < 1e-9);
    }

    #[test]
    fn sampled_points_lie_on_the_surface_with_consistent_density() {
        let shapes = [
            Shape::Sphere { radius: 1.5, z_min: -0.5, z_max: 1.0, theta_max_degrees: 270.0 },
            Shape::Cylinder { radius: 1.0, z_min: -1.0, z_max: 1.0, theta_max_degrees: 360.0 },
            Shape::Disk { height: 0.3, radius: 2.0, theta_max_degrees: 180.0 },
            Shape::Cone { height: 2.0, radius: 1.0, theta_max_degrees: 360.0 },
            Shape::Paraboloid { r_max: 1.0, z_min: 0.2, z_max: 2.0, theta_max_degrees: 360.0 },
            Shape::Torus {
                major_radius: 2.0,
                minor_radius: 0.5,
                phi_min_degrees: 0.0,
                phi_max_degrees: 360.0,
                theta_max_degrees: 360.0,
            },
        ];
        let areas = [
            1.5 * PI * 1.5 * 1.5,
            2.0 * PI * 2.0,
            0.5 * PI * 4.0,
            PI * 1.0 * (5.0f64).sqrt(),
            0.0,
            4.0 * PI * PI * 2.0 * 0.5,
        ];
        for (shape, area) in shapes.iter().zip(areas) {
            let quad = q(shape.clone());
            // Monte Carlo area: mean of 1/pdf over samples (pdf = 1/|density|).
            let mut sum = 0.0;
            let n = 20_000;
            for i in 0..n {
                let a = (i as f64 + 0.5) / n as f64;
                let b = ((i as f64 * 0.618_033_988_75) % 1.0 + 0.5 / n as f64) % 1.0;
                let (p, nrm) = quad.sample_point(a, b);
                let dv = quad.sample_density_vector(p);
                sum += dv.length();
                assert!((nrm.length() - 1.0).abs() < 1e-9);
                // On the surface: a ray from outside along -n hits at p.
                let o = p + nrm * 1e-3;
                if let Some(h) = quad.intersect(o, -nrm, 0.0, 2e-3, |_| true) {
                    assert!((h.p - p).length() < 1e-6 * (1.0 + p.length()), "{shape:?}");
                }
            }
            let mc_area = sum / n as f64;
            if area > 0.0 {
                assert!((mc_area - area).abs() < 0.01 * area, "{shape:?}: {mc_area} vs {area}");
            }
        }
    }
}
