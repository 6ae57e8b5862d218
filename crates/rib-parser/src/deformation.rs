//! Deformation motion (`MotionBegin [t0 t1 ...]` around one geometry request per time, all of
//! one type and topology): the shape at each key time, and the shape between keys as PRMan and
//! pbrt interpolate it, linearly in its positions (`P`, `Pw`), its float primitive variables
//! (`N`, `width`, ...) and, for quadrics, its parameters.
//!
//! Keys match when they are the same request with the same topology: the same counts, indices,
//! wraps, bases, knots, tags and number of positions. Everything that is not interpolated
//! (integer and string variables, a variable a later key lacks) is the first key's.

use crate::scene::{ParamValues, PrimVars, Shape};
use std::sync::Arc;

/// A shape given at increasing key times.
#[derive(Clone, Debug, PartialEq)]
pub struct Deformation {
    times: Vec<f64>,
    shapes: Vec<Arc<Shape>>,
}

impl Deformation {
    /// The deformation through `shapes` at `times` (same length, at least two, times finite
    /// and non-decreasing, every key matching the first), or why not.
    pub fn new(times: Vec<f64>, shapes: Vec<Arc<Shape>>) -> Result<Deformation, String> {
        if times.len() != shapes.len() {
            return Err(format!("{} times but {} shapes", times.len(), shapes.len()));
        }
        if shapes.len() < 2 {
            return Err("a deformation needs two keys or more".into());
        }
        if !times.iter().all(|t| t.is_finite()) || times.windows(2).any(|w| w[0] > w[1]) {
            return Err("the times must be finite and increasing".into());
        }
        for (k, shape) in shapes.iter().enumerate().skip(1) {
            if let Some(why) = mismatch(&shapes[0], shape) {
                return Err(format!("key {} differs from the first: {why}", k + 1));
            }
        }
        Ok(Deformation { times, shapes })
    }

    pub fn times(&self) -> &[f64] {
        &self.times
    }

    pub fn shapes(&self) -> &[Arc<Shape>] {
        &self.shapes
    }

    /// Whether every key is the same shape (no deformation at all).
    pub fn is_static(&self) -> bool {
        self.shapes.iter().all(|s| **s == *self.shapes[0])
    }

    /// The same shapes at times `f(t)` (e.g. scene time to shutter fraction).
    pub fn retimed(&self, f: impl Fn(f64) -> f64) -> Option<Deformation> {
        Deformation::new(self.times.iter().map(|t| f(*t)).collect(), self.shapes.clone()).ok()
    }

    /// The shape at `time`: the first key before the first time, the last after the last, a
    /// key's own shape at its time (bit for bit), interpolated in between.
    pub fn at(&self, time: f64) -> Shape {
        let (i, j, f) = key_segment(&self.times, time);
        if f == 0.0 {
            return (*self.shapes[i]).clone();
        }
        lerp_shape(&self.shapes[i], &self.shapes[j], f)
    }
}

/// The keys `(i, j)` around `time` in the non-decreasing `times` and the fraction `f` of the way
/// from `i` to `j`, as [`crate::motion::TransformMotion::at`] chooses them: `f = 0` before the
/// first time, after the last (then `i = j` is the last key) and at a key's own time;
/// zero-length segments are never chosen.
pub fn key_segment(times: &[f64], time: f64) -> (usize, usize, f64) {
    let n = times.len();
    if n == 0 || time.is_nan() || time <= times[0] {
        return (0, 0, 0.0);
    }
    if time >= times[n - 1] {
        return (n - 1, n - 1, 0.0);
    }
    let i = times.partition_point(|&t| t <= time) - 1;
    let (t0, t1) = (times[i], times[i + 1]);
    (i, i + 1, (time - t0) / (t1 - t0))
}

/// `a (1 - f) + b f`, exact at both ends.
#[inline]
pub fn lerp32(a: f32, b: f32, f: f64) -> f32 {
    (f64::from(a) * (1.0 - f) + f64::from(b) * f) as f32
}

fn lerp_primvars(a: &PrimVars, b: &PrimVars, f: f64) -> PrimVars {
    let mut out = a.clone();
    for p in &mut out.0 {
        if let (ParamValues::Floats(va), Some(vb)) = (&mut p.values, b.floats(&p.name))
            && va.len() == vb.len()
        {
            for (x, y) in va.iter_mut().zip(vb) {
                *x = lerp32(*x, *y, f);
            }
        }
    }
    out
}

/// The shape `f` of the way from `a` to `b` (two keys that match, see [`mismatch`]): positions,
/// float primitive variables and quadric parameters interpolated, the rest `a`'s.
pub fn lerp_shape(a: &Shape, b: &Shape, f: f64) -> Shape {
    let l = |x: f32, y: f32| lerp32(x, y, f);
    let l3 = |x: &[glam::Vec3], y: &[glam::Vec3]| -> Vec<glam::Vec3> {
        x.iter().zip(y).map(|(p, q)| (p.as_dvec3() * (1.0 - f) + q.as_dvec3() * f).as_vec3()).collect()
    };
    let l4 = |x: &[glam::Vec4], y: &[glam::Vec4]| -> Vec<glam::Vec4> {
        x.iter().zip(y).map(|(p, q)| (p.as_dvec4() * (1.0 - f) + q.as_dvec4() * f).as_vec4()).collect()
    };
    match (a, b) {
        (
            Shape::Sphere { radius, z_min, z_max, theta_max_degrees: t },
            Shape::Sphere { radius: r2, z_min: z0, z_max: z1, theta_max_degrees: t2 },
        ) => Shape::Sphere {
            radius: l(*radius, *r2),
            z_min: l(*z_min, *z0),
            z_max: l(*z_max, *z1),
            theta_max_degrees: l(*t, *t2),
        },
        (
            Shape::Cylinder { radius, z_min, z_max, theta_max_degrees: t },
            Shape::Cylinder { radius: r2, z_min: z0, z_max: z1, theta_max_degrees: t2 },
        ) => Shape::Cylinder {
            radius: l(*radius, *r2),
            z_min: l(*z_min, *z0),
            z_max: l(*z_max, *z1),
            theta_max_degrees: l(*t, *t2),
        },
        (
            Shape::Cone { height, radius, theta_max_degrees: t },
            Shape::Cone { height: h2, radius: r2, theta_max_degrees: t2 },
        ) => Shape::Cone { height: l(*height, *h2), radius: l(*radius, *r2), theta_max_degrees: l(*t, *t2) },
        (
            Shape::Disk { height, radius, theta_max_degrees: t },
            Shape::Disk { height: h2, radius: r2, theta_max_degrees: t2 },
        ) => Shape::Disk { height: l(*height, *h2), radius: l(*radius, *r2), theta_max_degrees: l(*t, *t2) },
        (
            Shape::Paraboloid { r_max, z_min, z_max, theta_max_degrees: t },
            Shape::Paraboloid { r_max: r2, z_min: z0, z_max: z1, theta_max_degrees: t2 },
        ) => Shape::Paraboloid {
            r_max: l(*r_max, *r2),
            z_min: l(*z_min, *z0),
            z_max: l(*z_max, *z1),
            theta_max_degrees: l(*t, *t2),
        },
        (
            Shape::Hyperboloid { point1, point2, theta_max_degrees: t },
            Shape::Hyperboloid { point1: p1, point2: p2, theta_max_degrees: t2 },
        ) => Shape::Hyperboloid {
            point1: l3(&[*point1], &[*p1])[0],
            point2: l3(&[*point2], &[*p2])[0],
            theta_max_degrees: l(*t, *t2),
        },
        (
            Shape::Torus { major_radius, minor_radius, phi_min_degrees, phi_max_degrees, theta_max_degrees },
            Shape::Torus {
                major_radius: m2,
                minor_radius: n2,
                phi_min_degrees: p0,
                phi_max_degrees: p1,
                theta_max_degrees: t2,
            },
        ) => Shape::Torus {
            major_radius: l(*major_radius, *m2),
            minor_radius: l(*minor_radius, *n2),
            phi_min_degrees: l(*phi_min_degrees, *p0),
            phi_max_degrees: l(*phi_max_degrees, *p1),
            theta_max_degrees: l(*theta_max_degrees, *t2),
        },
        (Shape::Polygons(x), Shape::Polygons(y)) => {
            let mut m = x.clone();
            m.positions = l3(&x.positions, &y.positions);
            m.primvars = lerp_primvars(&x.primvars, &y.primvars, f);
            Shape::Polygons(m)
        }
        (Shape::Patches(x), Shape::Patches(y)) => {
            let mut m = x.clone();
            m.positions = l4(&x.positions, &y.positions);
            m.primvars = lerp_primvars(&x.primvars, &y.primvars, f);
            Shape::Patches(m)
        }
        (Shape::NuPatch(x), Shape::NuPatch(y)) => {
            let mut m = x.clone();
            m.positions = l4(&x.positions, &y.positions);
            m.primvars = lerp_primvars(&x.primvars, &y.primvars, f);
            Shape::NuPatch(m)
        }
        (Shape::SubdivisionMesh(x), Shape::SubdivisionMesh(y)) => {
            let mut m = x.clone();
            m.positions = l3(&x.positions, &y.positions);
            m.primvars = lerp_primvars(&x.primvars, &y.primvars, f);
            Shape::SubdivisionMesh(m)
        }
        (Shape::Points(x), Shape::Points(y)) => {
            let mut m = x.clone();
            m.positions = l3(&x.positions, &y.positions);
            m.primvars = lerp_primvars(&x.primvars, &y.primvars, f);
            Shape::Points(m)
        }
        (Shape::Curves(x), Shape::Curves(y)) => {
            let mut m = x.clone();
            m.positions = l3(&x.positions, &y.positions);
            m.primvars = lerp_primvars(&x.primvars, &y.primvars, f);
            Shape::Curves(m)
        }
        (Shape::Blobby(x), Shape::Blobby(y)) => {
            let mut m = x.clone();
            m.floats = x.floats.iter().zip(&y.floats).map(|(p, q)| l(*p, *q)).collect();
            m.primvars = lerp_primvars(&x.primvars, &y.primvars, f);
            Shape::Blobby(m)
        }
        // Keys that do not match: the first.
        _ => a.clone(),
    }
}

/// Why `b` cannot be a later key of `a` (another request, or other topology), or `None`.
pub fn mismatch(a: &Shape, b: &Shape) -> Option<String> {
    fn differ(what: &str, same: bool) -> Option<String> {
        (!same).then(|| what.to_string())
    }
    fn count(what: &str, a: usize, b: usize) -> Option<String> {
        (a != b).then(|| format!("{b} {what} instead of {a}"))
    }
    let kind = crate::summary::shape_kind;
    match (a, b) {
        (Shape::Sphere { .. }, Shape::Sphere { .. })
        | (Shape::Cylinder { .. }, Shape::Cylinder { .. })
        | (Shape::Cone { .. }, Shape::Cone { .. })
        | (Shape::Disk { .. }, Shape::Disk { .. })
        | (Shape::Paraboloid { .. }, Shape::Paraboloid { .. })
        | (Shape::Hyperboloid { .. }, Shape::Hyperboloid { .. })
        | (Shape::Torus { .. }, Shape::Torus { .. }) => None,
        (Shape::Polygons(x), Shape::Polygons(y)) => differ(
            "other polygons or vertex indices",
            x.loops_per_face == y.loops_per_face
                && x.vertices_per_loop == y.vertices_per_loop
                && x.vertex_indices == y.vertex_indices,
        )
        .or_else(|| count("positions", x.positions.len(), y.positions.len())),
        (Shape::Patches(x), Shape::Patches(y)) => differ(
            "another patch type, size, wrap or basis",
            x.kind == y.kind
                && x.nu == y.nu
                && x.nv == y.nv
                && x.u_wrap == y.u_wrap
                && x.v_wrap == y.v_wrap
                && x.u_basis == y.u_basis
                && x.v_basis == y.v_basis,
        )
        .or_else(|| count("positions", x.positions.len(), y.positions.len())),
        (Shape::NuPatch(x), Shape::NuPatch(y)) => differ(
            "other orders, knots, parameter ranges or trim curves",
            x.basis == y.basis && x.trim == y.trim,
        )
        .or_else(|| count("positions", x.positions.len(), y.positions.len())),
        (Shape::SubdivisionMesh(x), Shape::SubdivisionMesh(y)) => differ(
            "another scheme, other faces, vertex indices or tags",
            x.scheme == y.scheme
                && x.vertices_per_face == y.vertices_per_face
                && x.vertex_indices == y.vertex_indices
                && x.tags == y.tags,
        )
        .or_else(|| count("positions", x.positions.len(), y.positions.len())),
        (Shape::Points(x), Shape::Points(y)) => count("points", x.positions.len(), y.positions.len()),
        (Shape::Curves(x), Shape::Curves(y)) => differ(
            "another curve type, wrap, basis or other vertex counts",
            x.cubic == y.cubic
                && x.wrap == y.wrap
                && x.v_basis == y.v_basis
                && x.vertices_per_curve == y.vertices_per_curve,
        )
        .or_else(|| count("positions", x.positions.len(), y.positions.len())),
        (Shape::Blobby(x), Shape::Blobby(y)) => differ(
            "another program",
            x.leaf_count == y.leaf_count && x.code == y.code && x.strings == y.strings,
        )
        .or_else(|| count("float operands", x.floats.len(), y.floats.len())),
        _ => Some(format!("{} after {}", kind(b), kind(a))),
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::scene::{PolygonMesh, PrimVars};
    use glam::Vec3;

    fn sphere(radius: f32, theta: f32) -> Arc<Shape> {
        Arc::new(Shape::Sphere { radius, z_min: -radius, z_max: radius, theta_max_degrees: theta })
    }

    fn triangle(x: f32) -> Arc<Shape> {
        Arc::new(Shape::Polygons(PolygonMesh {
            loops_per_face: vec![1],
            vertices_per_loop: vec![3],
            vertex_indices: vec![0, 1, 2],
            positions: vec![Vec3::new(x, 0.0, 0.0), Vec3::new(x + 1.0, 0.0, 0.0), Vec3::new(x, 1.0, 0.0)],
            primvars: PrimVars::default(),
        }))
    }

    #[test]
    fn keys_are_exact_and_parameters_linear_between() {
        let d = Deformation::new(vec![0.0, 2.0], vec![sphere(1.0, 360.0), sphere(3.0, 180.0)]).unwrap();
        assert_eq!(d.at(-1.0), *sphere(1.0, 360.0));
        assert_eq!(d.at(2.0), *sphere(3.0, 180.0));
        assert_eq!(d.at(1.0), *sphere(2.0, 270.0));
        let d =
            Deformation::new(vec![0.0, 1.0, 3.0], vec![triangle(0.0), triangle(1.0), triangle(5.0)]).unwrap();
        assert_eq!(d.at(0.5), *triangle(0.5));
        assert_eq!(d.at(2.0), *triangle(3.0));
        assert_eq!(d.at(1.0), *triangle(1.0));
        assert!(!d.is_static());
    }

    #[test]
    fn keys_that_do_not_match_are_refused_with_the_reason() {
        let why = Deformation::new(vec![0.0, 1.0], vec![sphere(1.0, 360.0), triangle(0.0)]).unwrap_err();
        assert!(why.contains("Polygons after Sphere"), "{why}");
        let mut square = (*triangle(0.0)).clone();
        if let Shape::Polygons(m) = &mut square {
            m.vertices_per_loop = vec![4];
            m.vertex_indices = vec![0, 1, 2, 3];
            m.positions.push(Vec3::ONE);
        }
        let why = Deformation::new(vec![0.0, 1.0], vec![triangle(0.0), Arc::new(square)]).unwrap_err();
        assert!(why.contains("key 2") && why.contains("vertex indices"), "{why}");
        assert!(Deformation::new(vec![1.0, 0.0], vec![triangle(0.0), triangle(1.0)]).is_err());
        assert!(Deformation::new(vec![0.0], vec![triangle(0.0)]).is_err());
    }

    #[test]
    fn segments_follow_the_transformation_motion() {
        let times = [0.0, 0.5, 0.5, 1.0];
        assert_eq!(key_segment(&times, -1.0), (0, 0, 0.0));
        assert_eq!(key_segment(&times, 0.25), (0, 1, 0.5));
        assert_eq!(key_segment(&times, 0.5), (2, 3, 0.0));
        assert_eq!(key_segment(&times, 0.75), (2, 3, 0.5));
        assert_eq!(key_segment(&times, 2.0), (3, 3, 0.0));
        assert_eq!(key_segment(&times, f64::NAN), (0, 0, 0.0));
    }
}
