//! Depth tables against distances computed in closed form in this file: quadrics with partial
//! sweeps and z limits, a disk, a polygon, under nested, non-uniform transforms, seen by
//! perspective and orthographic cameras with non-square frames. Pixels near silhouettes (where
//! the surface a pixel sees changes within a fraction of a pixel) are left out; everywhere else
//! the relative error must stay below 1e-5.

use depth_remap::Camera;
use glam::{DMat4, DVec2, DVec3};
use raytracer::render::{RenderOptions, render};
use rib_parser::scene::{Scene, Shape};

const WORLD: &str = r#"
WorldBegin
  TransformBegin
    Translate -2 0.5 0
    Rotate 30 0 0 1
    TransformBegin
      Scale 1 1.5 1
      Sphere 1 -0.8 0.9 300
    TransformEnd
  TransformEnd
  TransformBegin
    Translate 1.5 0 1
    Rotate -90 1 0 0
    Cylinder 0.7 -1 1 270
    Disk 1 0.7 360
  TransformEnd
  TransformBegin
    Translate 0 -1.5 -1
    Rotate -80 1 0 0
    Rotate 15 0 1 0
    Cone 1.5 1 330
  TransformEnd
  TransformBegin
    Translate -0.5 1.8 -2
    Rotate 70 1 0 0
    Paraboloid 1 0.2 1.5 360
  TransformEnd
  TransformBegin
    Translate 2.5 1.5 -1
    Scale 0.8 0.8 0.8
    Hyperboloid 1 0 -1  0 1 1 360
  TransformEnd
  Polygon "P" [-7 -4 4  7 -4 4  7 5 4  -7 5 4]
WorldEnd
"#;

const PERSPECTIVE: &str = r#"
Option "lrt" "string depthfile" ["unused.depth"]
Format 160 90 1
Projection "perspective" "fov" [50]
Translate 0.2 -0.1 8
Rotate -15 1 0 0
Rotate 20 0 1 0
"#;

const ORTHOGRAPHIC: &str = r#"
Format 90 120 1
Projection "orthographic"
ScreenWindow -4 4 -4 5.5
Translate 0 0 10
Rotate -25 1 0 0
Rotate 10 0 1 0
"#;

/// Roots of `a t^2 + b t + c` in f64.
fn quadratic(a: f64, b: f64, c: f64) -> Vec<f64> {
    if a.abs() < 1e-300 {
        return if b != 0.0 { vec![-c / b] } else { vec![] };
    }
    let d = b * b - 4.0 * a * c;
    if d < 0.0 {
        return vec![];
    }
    let s = d.sqrt();
    let q = if b < 0.0 { -0.5 * (b - s) } else { -0.5 * (b + s) };
    let mut r = vec![q / a, c / q];
    r.sort_by(|x, y| x.partial_cmp(y).unwrap());
    r
}

fn angle(p: DVec3) -> f64 {
    let a = p.y.atan2(p.x);
    if a < 0.0 { a + std::f64::consts::TAU } else { a }
}

/// Every hit `(t, surface id)` of the world ray `o + t d` (unit `d`) with a shape.
fn hits(shape: &Shape, world_from_object: &DMat4, o: DVec3, d: DVec3, id: usize) -> Vec<(f64, usize)> {
    let inv = world_from_object.inverse();
    let (o, d) = (inv.transform_point3(o), inv.transform_vector3(d));
    let within = |t: f64, z_lo: f64, z_hi: f64, theta_max: f64| {
        let p = o + d * t;
        t > 0.0 && p.z >= z_lo && p.z <= z_hi && angle(p) <= theta_max.to_radians()
    };
    let mut out = Vec::new();
    let mut push = |roots: Vec<f64>, ok: &dyn Fn(f64) -> bool| {
        for (k, t) in roots.into_iter().enumerate() {
            if ok(t) {
                out.push((t, id * 4 + k));
            }
        }
    };
    match *shape {
        Shape::Sphere { radius, z_min, z_max, theta_max_degrees } => {
            let r = f64::from(radius);
            let roots = quadratic(d.dot(d), 2.0 * o.dot(d), o.dot(o) - r * r);
            push(roots, &|t| within(t, f64::from(z_min), f64::from(z_max), f64::from(theta_max_degrees)));
        }
        Shape::Cylinder { radius, z_min, z_max, theta_max_degrees } => {
            let r = f64::from(radius);
            let roots = quadratic(
                d.x * d.x + d.y * d.y,
                2.0 * (o.x * d.x + o.y * d.y),
                o.x * o.x + o.y * o.y - r * r,
            );
            push(roots, &|t| within(t, f64::from(z_min), f64::from(z_max), f64::from(theta_max_degrees)));
        }
        Shape::Disk { height, radius, theta_max_degrees } => {
            let h = f64::from(height);
            let t = (h - o.z) / d.z;
            let p = o + d * t;
            let ok = t > 0.0
                && p.x * p.x + p.y * p.y <= f64::from(radius).powi(2)
                && angle(p) <= f64::from(theta_max_degrees).to_radians();
            push(vec![t], &|_| ok);
        }
        Shape::Cone { height, radius, theta_max_degrees } => {
            let (h, r) = (f64::from(height), f64::from(radius));
            let k = (r / h) * (r / h);
            let oz = o.z - h;
            let roots = quadratic(
                d.x * d.x + d.y * d.y - k * d.z * d.z,
                2.0 * (o.x * d.x + o.y * d.y - k * oz * d.z),
                o.x * o.x + o.y * o.y - k * oz * oz,
            );
            push(roots, &|t| within(t, 0.0, h, f64::from(theta_max_degrees)));
        }
        Shape::Paraboloid { r_max, z_min, z_max, theta_max_degrees } => {
            let k = f64::from(r_max).powi(2) / f64::from(z_max);
            let roots = quadratic(
                d.x * d.x + d.y * d.y,
                2.0 * (o.x * d.x + o.y * d.y) - k * d.z,
                o.x * o.x + o.y * o.y - k * o.z,
            );
            push(roots, &|t| within(t, f64::from(z_min), f64::from(z_max), f64::from(theta_max_degrees)));
        }
        Shape::Hyperboloid { point1, point2, theta_max_degrees } => {
            // Radius^2 at height z along the segment: |q + v e|^2 with v = (z - z1) / (z2 - z1).
            let (p1, p2) = (point1.as_dvec3(), point2.as_dvec3());
            let (q, e) = (DVec2::new(p1.x, p1.y), DVec2::new(p2.x - p1.x, p2.y - p1.y));
            let s = 1.0 / (p2.z - p1.z);
            // v(t) = s (o.z + t d.z - z1) = v0 + v1 t
            let (v0, v1) = (s * (o.z - p1.z), s * d.z);
            // |q + (v0 + v1 t) e|^2 = (x^2 + y^2)(t)
            let a = d.x * d.x + d.y * d.y - v1 * v1 * e.dot(e);
            let b = 2.0 * (o.x * d.x + o.y * d.y) - 2.0 * v1 * (q.dot(e) + v0 * e.dot(e));
            let c = o.x * o.x + o.y * o.y - (q.dot(q) + 2.0 * v0 * q.dot(e) + v0 * v0 * e.dot(e));
            let full = f64::from(theta_max_degrees) >= 360.0;
            push(quadratic(a, b, c), &|t| {
                let p = o + d * t;
                t > 0.0 && p.z >= p1.z.min(p2.z) && p.z <= p1.z.max(p2.z) && full
            });
        }
        Shape::Polygons(ref mesh) => {
            // One convex polygon.
            let p: Vec<DVec3> = mesh.positions.iter().map(|p| p.as_dvec3()).collect();
            let n = (p[1] - p[0]).cross(p[2] - p[0]);
            let t = (p[0] - o).dot(n) / d.dot(n);
            let x = o + d * t;
            let inside = (0..p.len()).all(|i| (p[(i + 1) % p.len()] - p[i]).cross(x - p[i]).dot(n) >= 0.0);
            push(vec![t], &|_| t > 0.0 && inside);
        }
        _ => {}
    }
    out
}

/// The closest hit of a world ray over the scene: (distance, surface id).
fn closest(scene: &Scene, o: DVec3, d: DVec3) -> Option<(f64, usize)> {
    scene
        .shapes
        .iter()
        .enumerate()
        .flat_map(|(i, s)| hits(&s.shape, &s.world_from_object, o, d, i))
        .min_by(|a, b| a.0.partial_cmp(&b.0).unwrap())
}

fn check(camera_block: &str) -> usize {
    let rib = format!("{camera_block}{WORLD}");
    let scene =
        rib_parser::load_bytes("closed-form.rib", rib.into_bytes(), &Default::default()).unwrap().scene;
    let out =
        render(&scene, &RenderOptions { spp: Some(1), depth: true, threads: Some(2), ..Default::default() })
            .unwrap();
    let depth = out.depth.unwrap();
    let camera = Camera::new(scene.camera.clone()).unwrap();
    let (w, h) = camera.resolution();
    assert_eq!((depth.width, depth.height), (w, h));
    let mut compared = 0;
    let mut seen = std::collections::BTreeSet::new();
    let mut worst = (0.0f64, 0, 0);
    for j in 0..h {
        for i in 0..w {
            let ray = camera.pixel_centre_world_ray(i, j);
            let centre = closest(&scene, ray.origin, ray.direction);
            // Leave out pixels near a silhouette: nearby rays must see the same surface.
            let stable = [(-0.4, 0.0), (0.4, 0.0), (0.0, -0.4), (0.0, 0.4)].iter().all(|(dx, dy)| {
                let r = camera
                    .world_ray_through_raster(DVec2::new(f64::from(i) + 0.5 + dx, f64::from(j) + 0.5 + dy));
                closest(&scene, r.origin, r.direction).map(|x| x.1) == centre.map(|x| x.1)
            });
            if !stable {
                continue;
            }
            let ours = depth.values[(j * w + i) as usize];
            match centre {
                None => assert!(ours.is_infinite(), "pixel ({i}, {j}): expected a miss, got {ours}"),
                Some((t, surface)) => {
                    seen.insert(surface / 4);
                    let e = (f64::from(ours) - t).abs() / t;
                    if e > worst.0 {
                        worst = (e, i, j);
                    }
                }
            }
            compared += 1;
        }
    }
    assert!(worst.0 < 1e-5, "worst relative error {:.3e} at pixel ({}, {})", worst.0, worst.1, worst.2);
    let hits = depth.values.iter().filter(|v| v.is_finite()).count();
    eprintln!("{compared} pixels compared, {hits} hits, worst relative error {:.3e}", worst.0);
    // The view must be mostly covered by the surfaces, or the test would prove little.
    assert!(hits > (w * h) as usize / 2, "only {hits} pixels hit anything");
    // And every shape must be compared somewhere.
    assert_eq!(seen.len(), scene.shapes.len(), "shapes compared: {seen:?}");
    compared
}

#[test]
fn perspective_depth_matches_closed_form() {
    let n = check(PERSPECTIVE);
    assert!(n > 160 * 90 * 3 / 4, "only {n} pixels compared");
}

#[test]
fn orthographic_depth_matches_closed_form() {
    let n = check(ORTHOGRAPHIC);
    assert!(n > 90 * 120 * 3 / 4, "only {n} pixels compared");
}
