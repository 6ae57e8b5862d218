//! User clipping planes (`ClippingPlane`, RenderMan 3.2): geometry on the side a plane's normal
//! points to is not there. The kept side of each plane is a half-space, so along any ray the
//! kept points form one interval of `t`: clipping a ray to it removes exactly the hits on the
//! clipped side, for camera rays, shadow rays and photons alike, with no change to traversal.

use super::Ray;
use glam::{DMat4, DVec3};
use rib_parser::scene::Scene;

/// A clipping plane in render space: points with `(p - point) . normal > 0` are clipped.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct RenderClippingPlane {
    pub point: DVec3,
    pub normal: DVec3,
}

/// The scene's clipping planes (camera space) in render space.
pub(super) fn render_clipping_planes(scene: &Scene, render_from_world: &DMat4) -> Vec<RenderClippingPlane> {
    let render_from_camera = *render_from_world * scene.camera.camera_from_world.inverse();
    let normal_matrix = render_from_camera.inverse().transpose();
    scene
        .render
        .clipping_planes
        .iter()
        .map(|p| RenderClippingPlane {
            point: render_from_camera.transform_point3(p.point),
            normal: normal_matrix.transform_vector3(p.normal),
        })
        .filter(|p| p.point.is_finite() && p.normal.is_finite() && p.normal != DVec3::ZERO)
        .collect()
}

/// `ray` with its `(t_min, t_max)` narrowed to where it is on the kept side of every plane, or
/// `None` when no part of it is.
pub(super) fn clip_ray(planes: &[RenderClippingPlane], ray: &Ray) -> Option<Ray> {
    let origin = ray.origin.as_dvec3();
    let direction = ray.direction.as_dvec3();
    let (mut t_min, mut t_max) = (f64::from(ray.t_min), f64::from(ray.t_max));
    for plane in planes {
        // Signed side along the ray: s(t) = s0 + t * ds, kept where s(t) <= 0.
        let s0 = (origin - plane.point).dot(plane.normal);
        let ds = direction.dot(plane.normal);
        if ds > 0.0 {
            t_max = t_max.min(-s0 / ds);
        } else if ds < 0.0 {
            t_min = t_min.max(-s0 / ds);
        } else if s0 > 0.0 {
            return None;
        }
        if !(t_min < t_max) {
            return None;
        }
    }
    // Rounded outward to f32 only where the range was not narrowed: a clipped range is rounded
    // inward so no hit on the clipped side slips through.
    let lo = if t_min == f64::from(ray.t_min) { ray.t_min } else { next_up(t_min as f32, t_min) };
    let hi = if t_max == f64::from(ray.t_max) { ray.t_max } else { next_down(t_max as f32, t_max) };
    (lo < hi).then_some(Ray { t_min: lo, t_max: hi, ..*ray })
}

/// The smallest `f32` not below `exact`, given its rounding `rounded`.
fn next_up(rounded: f32, exact: f64) -> f32 {
    if f64::from(rounded) >= exact { rounded } else { rounded.next_up() }
}

/// The largest `f32` not above `exact`, given its rounding `rounded`.
fn next_down(rounded: f32, exact: f64) -> f32 {
    if f64::from(rounded) <= exact { rounded } else { rounded.next_down() }
}

#[cfg(test)]
mod tests {
    use super::*;
    use glam::Vec3;

    fn plane(point: [f64; 3], normal: [f64; 3]) -> RenderClippingPlane {
        RenderClippingPlane { point: DVec3::from(point), normal: DVec3::from(normal) }
    }

    #[test]
    fn a_ray_keeps_the_interval_on_the_kept_side_of_every_plane() {
        let ray = Ray::new(Vec3::ZERO, Vec3::X);
        // Clip x > 2: the ray keeps t < 2.
        let r = clip_ray(&[plane([2.0, 0.0, 0.0], [1.0, 0.0, 0.0])], &ray).unwrap();
        assert_eq!((r.t_min, r.t_max), (0.0, 2.0));
        // Clip x < 1 as well (normal -x): t in (1, 2).
        let r = clip_ray(
            &[plane([2.0, 0.0, 0.0], [1.0, 0.0, 0.0]), plane([1.0, 5.0, 0.0], [-2.0, 0.0, 0.0])],
            &ray,
        )
        .unwrap();
        assert_eq!((r.t_min, r.t_max), (1.0, 2.0));
        // Planes that leave nothing, or a parallel ray on the clipped side.
        assert!(
            clip_ray(
                &[plane([2.0, 0.0, 0.0], [1.0, 0.0, 0.0]), plane([3.0, 0.0, 0.0], [-1.0, 0.0, 0.0])],
                &ray
            )
            .is_none()
        );
        assert!(clip_ray(&[plane([0.0, -1.0, 0.0], [0.0, 1.0, 0.0])], &ray).is_none());
        // A parallel ray on the kept side is untouched.
        let r = clip_ray(&[plane([0.0, 1.0, 0.0], [0.0, 1.0, 0.0])], &ray).unwrap();
        assert_eq!((r.t_min, r.t_max), (0.0, f32::INFINITY));
    }

    #[test]
    fn a_narrowed_range_is_rounded_inward() {
        let ray = Ray::new(Vec3::ZERO, Vec3::X);
        let r = clip_ray(&[plane([0.1, 0.0, 0.0], [1.0, 0.0, 0.0])], &ray).unwrap();
        assert!(f64::from(r.t_max) <= 0.1 && f64::from(r.t_max.next_up()) > 0.1);
        let r = clip_ray(&[plane([0.1, 0.0, 0.0], [-1.0, 0.0, 0.0])], &ray).unwrap();
        assert!(f64::from(r.t_min) >= 0.1 && f64::from(r.t_min.next_down()) < 0.1);
    }
}
