//! `ClippingPlane`s for the haptic proxy: what the ray tracer does not show is not touched
//! either. Each triangle is clipped to the kept side of every plane (the side the normal points
//! away from) and the kept polygon is fanned back into triangles. A point where an edge crosses
//! a plane is computed from the edge's endpoints in a fixed order, so the two triangles sharing
//! that edge get the same bits there and the clipped surface stays free of cracks.

use glam::DVec3;
use rib_parser::scene::Scene;

/// A plane in world space: points with `(p - point) . normal > 0` are clipped.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct WorldClippingPlane {
    pub point: DVec3,
    pub normal: DVec3,
}

/// The scene's clipping planes (kept in camera space) in world space.
pub fn world_clipping_planes(scene: &Scene) -> Vec<WorldClippingPlane> {
    let world_from_camera = scene.camera.camera_from_world.inverse();
    let normal_matrix = scene.camera.camera_from_world.transpose();
    scene
        .render
        .clipping_planes
        .iter()
        .map(|p| WorldClippingPlane {
            point: world_from_camera.transform_point3(p.point),
            normal: normal_matrix.transform_vector3(p.normal),
        })
        .filter(|p| p.point.is_finite() && p.normal.is_finite() && p.normal != DVec3::ZERO)
        .collect()
}

/// A vertex of a mesh being clipped: position and, where the mesh has them, normal.
#[derive(Clone, Copy, Debug)]
struct Vertex {
    p: DVec3,
    n: Option<DVec3>,
}

/// `positions`/`triangles`/`normals` clipped to the kept side of `planes`: the new positions,
/// triangles and normals (`None` when the input had none).
pub fn clip_mesh(
    planes: &[WorldClippingPlane],
    positions: &[DVec3],
    triangles: &[[u32; 3]],
    normals: Option<&[DVec3]>,
) -> (Vec<DVec3>, Vec<[u32; 3]>, Option<Vec<DVec3>>) {
    let mut out_p = Vec::new();
    let mut out_n = normals.map(|_| Vec::new());
    let mut out_t = Vec::new();
    let vertex = |k: u32| Vertex { p: positions[k as usize], n: normals.map(|n| n[k as usize]) };
    for tri in triangles {
        if tri.iter().any(|&k| k as usize >= positions.len()) {
            continue;
        }
        let mut polygon: Vec<Vertex> = tri.iter().map(|&k| vertex(k)).collect();
        for plane in planes {
            polygon = clip_polygon(&polygon, plane);
            if polygon.len() < 3 {
                break;
            }
        }
        if polygon.len() < 3 {
            continue;
        }
        let base = out_p.len() as u32;
        for v in &polygon {
            out_p.push(v.p);
            if let (Some(out), Some(n)) = (out_n.as_mut(), v.n) {
                out.push(n);
            }
        }
        for k in 1..polygon.len() as u32 - 1 {
            out_t.push([base, base + k, base + k + 1]);
        }
    }
    (out_p, out_t, out_n)
}

/// Sutherland-Hodgman against one plane, keeping `(p - point) . normal <= 0`.
fn clip_polygon(polygon: &[Vertex], plane: &WorldClippingPlane) -> Vec<Vertex> {
    let side = |v: &Vertex| (v.p - plane.point).dot(plane.normal);
    let mut out = Vec::with_capacity(polygon.len() + 1);
    for (i, a) in polygon.iter().enumerate() {
        let b = &polygon[(i + 1) % polygon.len()];
        let (sa, sb) = (side(a), side(b));
        if sa <= 0.0 {
            out.push(*a);
        }
        if (sa <= 0.0) != (sb <= 0.0) {
            out.push(crossing(a, b, plane));
        }
    }
    out
}

/// Where edge `ab` crosses the plane, computed from the endpoints in a fixed order (the
/// lexicographically smaller first) so that both triangles of a shared edge agree bit for bit.
fn crossing(a: &Vertex, b: &Vertex, plane: &WorldClippingPlane) -> Vertex {
    let (a, b) = if a.p.to_array() <= b.p.to_array() { (a, b) } else { (b, a) };
    let (sa, sb) = ((a.p - plane.point).dot(plane.normal), (b.p - plane.point).dot(plane.normal));
    let f = (sa / (sa - sb)).clamp(0.0, 1.0);
    let n = match (a.n, b.n) {
        (Some(na), Some(nb)) => Some(na.lerp(nb, f).try_normalize().unwrap_or(na)),
        _ => None,
    };
    Vertex { p: a.p.lerp(b.p, f), n }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn triangles_keep_only_the_side_the_normal_points_away_from() {
        let plane = WorldClippingPlane { point: DVec3::new(0.5, 0.0, 0.0), normal: DVec3::X };
        // Two triangles of a unit square sharing its diagonal.
        let positions = [DVec3::ZERO, DVec3::X, DVec3::new(1.0, 1.0, 0.0), DVec3::Y];
        let (p, t, n) = clip_mesh(&[plane], &positions, &[[0, 1, 2], [0, 2, 3]], None);
        assert!(n.is_none());
        assert!(p.iter().all(|v| v.x <= 0.5), "{p:?}");
        let area: f64 = t
            .iter()
            .map(|[a, b, c]| 0.5 * (p[*b as usize] - p[*a as usize]).cross(p[*c as usize] - p[*a as usize]).z)
            .sum();
        assert!((area - 0.5).abs() < 1e-12, "kept area {area}");
        // The diagonal's crossing is the same point in both triangles.
        let on_diagonal: Vec<DVec3> = p.iter().copied().filter(|v| v.x == 0.5 && v.y == 0.5).collect();
        assert_eq!(on_diagonal.len(), 2);
        assert_eq!(on_diagonal[0].to_array(), on_diagonal[1].to_array());
        // A plane that keeps nothing.
        let all = WorldClippingPlane { point: DVec3::new(-1.0, 0.0, 0.0), normal: DVec3::X };
        assert!(clip_mesh(&[all], &positions, &[[0, 1, 2]], None).1.is_empty());
    }
}
