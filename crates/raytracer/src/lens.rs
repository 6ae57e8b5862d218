//! The thin lens of `DepthOfField`, as PRMan and pbrt model it: every ray through a raster
//! position passes through the point where the pinhole ray meets the plane of focus, and
//! starts on a disk of radius `focal_length / (2 fstop)` around the eye.

use crate::sampling::sample_concentric_disk;
use depth_remap::camera::CameraRay;
use glam::{DVec3, Vec2};
use rib_parser::scene::DepthOfField;

/// A thin lens in camera space (left-handed, `+z` forward).
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct ThinLens {
    /// Aperture radius in camera-space units.
    pub radius: f64,
    /// Camera-space z of the plane in sharp focus.
    pub focal_distance: f64,
}

impl ThinLens {
    /// The lens a `DepthOfField` request describes.
    pub fn from_depth_of_field(d: &DepthOfField) -> ThinLens {
        ThinLens { radius: d.lens_radius(), focal_distance: f64::from(d.focal_distance) }
    }

    /// Bends a pinhole camera-space ray (perspective or orthographic, `direction.z > 0`)
    /// through the lens point that `u` (uniform in `[0, 1)^2`) picks on the aperture disk.
    /// The result keeps the pinhole ray's point on the plane of focus, so objects at the focal
    /// distance stay sharp; its direction has unit camera-space length.
    pub fn refract(&self, pinhole: CameraRay, u: Vec2) -> CameraRay {
        let d = pinhole.direction;
        if !(d.z > 0.0) {
            return pinhole;
        }
        let focus = pinhole.origin + d * ((self.focal_distance - pinhole.origin.z) / d.z);
        let disk = sample_concentric_disk(u).as_dvec2() * self.radius;
        let origin = pinhole.origin + DVec3::new(disk.x, disk.y, 0.0);
        CameraRay { origin, direction: (focus - origin).normalize() }
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    /// A point at depth `z` on the axis is seen through the rays that start on the lens disk and
    /// pass through its image on the plane of focus; on that plane they cover the circle of
    /// confusion of radius `R |z - F| / z` (similar triangles), here checked against the rays.
    #[test]
    fn circle_of_confusion_matches_the_closed_form() {
        let d = DepthOfField { fstop: 2.8, focal_length: 0.05, focal_distance: 2.0 };
        let lens = ThinLens::from_depth_of_field(&d);
        // The RIB's values are f32, so the radius is 0.05 / 5.6 to f32 precision.
        assert!((lens.radius / (0.05 / 5.6) - 1.0).abs() < 1e-6);
        let f = lens.focal_distance;
        for z in [0.5, 1.0, 3.0, 10.0] {
            let expected = lens.radius * (z - f).abs() / z;
            let mut largest: f64 = 0.0;
            for k in 0..64 {
                // A lens point on the rim, then the pinhole ray whose focus point lies on the line
                // from that lens point through the on-axis point at depth z.
                let angle = std::f64::consts::TAU * f64::from(k) / 64.0;
                let u = Vec2::new(1.0, (k as f32) / 64.0);
                let rim = sample_concentric_disk(u).as_dvec2() * lens.radius;
                let rim = DVec3::new(rim.x, rim.y, 0.0);
                let focus = rim + (DVec3::new(0.0, 0.0, z) - rim) * (f / z);
                let pinhole = CameraRay { origin: DVec3::ZERO, direction: focus.normalize() };
                let bent = lens.refract(pinhole, u);
                // The bent ray starts at the rim point and passes through the object point.
                assert!((bent.origin - rim).length() < 1e-12, "angle {angle}");
                let t = z / bent.direction.z;
                let at_z = bent.origin + bent.direction * t;
                assert!(at_z.truncate().length() < 1e-9, "z {z}: the ray misses the point by {at_z}");
                largest = largest.max(focus.truncate().length());
            }
            // The disk sample is f32, so its rim is a unit circle to about 1e-7.
            assert!((largest - expected).abs() < 1e-6 * expected, "z {z}: {largest} vs {expected}");
        }
    }

    /// Every lens sample of a pixel converges on the pinhole ray's point on the plane of focus.
    #[test]
    fn the_plane_of_focus_is_sharp() {
        let lens = ThinLens { radius: 0.1, focal_distance: 3.0 };
        let pinhole = CameraRay { origin: DVec3::ZERO, direction: DVec3::new(0.3, -0.2, 1.0).normalize() };
        let target = pinhole.direction * (3.0 / pinhole.direction.z);
        for k in 0..16 {
            let u = Vec2::new((k as f32 + 0.5) / 16.0, ((k * 7 % 16) as f32 + 0.5) / 16.0);
            let r = lens.refract(pinhole, u);
            let p = r.origin + r.direction * ((3.0 - r.origin.z) / r.direction.z);
            assert!((p - target).length() < 1e-12);
        }
    }
}
