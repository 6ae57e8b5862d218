//! The camera model against an independent renderer: the reference Cornell box depth table in
//! `../shared/reference/cornell` was computed in float64 from Mitsuba 3's camera and the
//! scene's polygons. Tracing the same polygons along `Camera::pixel_centre_world_ray` must
//! reproduce it, which pins down the pixel centres, the fov rule, raster y and handedness.

use depth_remap::*;
use glam::{DMat4, DVec3};
use std::path::PathBuf;

fn shared() -> PathBuf {
    PathBuf::from(concat!(env!("CARGO_MANIFEST_DIR"), "/../../../shared"))
}

/// The world-space polygons of the RIB (each `Polygon "P" [...]` is on one line there).
fn polygons(rib: &str) -> Vec<Vec<DVec3>> {
    rib.lines()
        .filter_map(|line| line.trim_start().strip_prefix("Polygon \"P\" ["))
        .map(|rest| {
            let numbers: Vec<f64> =
                rest.trim_end_matches(']').split_whitespace().map(|t| t.parse().unwrap()).collect();
            numbers.chunks(3).map(|p| DVec3::new(p[0], p[1], p[2])).collect()
        })
        .collect()
}

/// Nearest hit of a ray with a convex polygon (fan of triangles), Möller-Trumbore in f64.
fn hit(origin: DVec3, direction: DVec3, polygon: &[DVec3]) -> Option<f64> {
    let mut best: Option<f64> = None;
    for k in 1..polygon.len() - 1 {
        let (a, b, c) = (polygon[0], polygon[k], polygon[k + 1]);
        let (e1, e2) = (b - a, c - a);
        let p = direction.cross(e2);
        let det = e1.dot(p);
        if det.abs() < 1e-300 {
            continue;
        }
        let s = origin - a;
        let u = s.dot(p) / det;
        let q = s.cross(e1);
        let v = direction.dot(q) / det;
        let t = e2.dot(q) / det;
        if u >= 0.0 && v >= 0.0 && u + v <= 1.0 && t > 0.0 {
            best = Some(best.map_or(t, |b: f64| b.min(t)));
        }
    }
    best
}

#[test]
fn pixel_centre_rays_reproduce_the_reference_depth() {
    let dir = shared().join("reference/cornell");
    let rib =
        std::fs::read_to_string(dir.join("cornell.rib")).expect("../shared/reference/cornell/cornell.rib");
    let reference = DepthTable::read(dir.join("depth-analytic.depth")).unwrap();
    // Both reference forms hold the same table.
    assert_eq!(DepthTable::read(dir.join("depth-analytic.exr")).unwrap(), reference);
    reference.check_size(512, 512).unwrap();

    // `Scale 1 1 -1` then `Translate 0 0 -3.9`: the last one given is applied to points first.
    let camera = Camera::new(CameraSettings {
        x_resolution: 512,
        y_resolution: 512,
        projection: Projection::Perspective { fov_degrees: 39.3077 },
        clipping: Clipping { near: 0.001, far: 100.0 },
        camera_from_world: DMat4::from_scale(DVec3::new(1.0, 1.0, -1.0))
            * DMat4::from_translation(DVec3::new(0.0, 0.0, -3.9)),
        ..CameraSettings::default()
    })
    .unwrap();
    let polygons = polygons(&rib);
    assert_eq!(polygons.len(), 18);

    let (mut worst, mut disagreements, mut hits) = (0.0f64, 0, 0);
    for j in 0..512 {
        for i in 0..512 {
            let ray = camera.pixel_centre_world_ray(i, j);
            let ours = polygons
                .iter()
                .filter_map(|p| hit(ray.origin, ray.direction, p))
                .fold(f64::INFINITY, f64::min);
            let theirs = f64::from(reference.get(i, j).unwrap());
            match (ours.is_finite(), theirs.is_finite()) {
                (true, true) => {
                    hits += 1;
                    worst = worst.max((ours - theirs).abs() / theirs);
                }
                (false, false) => {}
                // Rays that graze a shared edge exactly may go either way.
                _ => disagreements += 1,
            }
        }
    }
    let reference_hits = reference.values().iter().filter(|v| v.is_finite()).count();
    eprintln!("{hits} pixels hit in both, {disagreements} disagree, worst relative difference {worst:e}");
    assert!(hits + disagreements >= reference_hits && hits > 200_000, "{hits} hits of {reference_hits}");
    assert!(disagreements <= 32, "{disagreements} pixels disagree on hit or miss");
    // The reference is float64 rounded to float32: half an ulp, 6e-8 relative.
    assert!(worst < 1.2e-7, "worst relative difference {worst}");
}
