//! The live sphere's shadow on the pre-rendered scene: which pixels it can fall on.

use super::Compositor;
use super::lighting::FrameUniform;
use crate::projection::Projection;
use glam::DVec3;

/// Camera-space bounds of the surface points of a radial depth table (`None`: all misses).
pub(super) fn camera_space_bounds(projection: &Projection, radial: &[f32]) -> Option<(DVec3, DVec3)> {
    let camera = projection.camera();
    let (w, _) = camera.resolution();
    let mut lo = DVec3::splat(f64::INFINITY);
    let mut hi = DVec3::splat(f64::NEG_INFINITY);
    for (k, &r) in radial.iter().enumerate() {
        if r.is_finite() {
            let ray = camera.pixel_centre_ray(k as u32 % w, k as u32 / w);
            let p = ray.origin + ray.direction * f64::from(r);
            lo = lo.min(p);
            hi = hi.max(p);
        }
    }
    lo.is_finite().then_some((lo, hi))
}

impl Compositor {
    /// The pixels the sphere's shadow can fall on: the screen bounds of the shadow volume (the
    /// sphere's outer penumbra cone from the light, cut where it leaves the bounds of the
    /// visible surfaces), or the whole image when that volume reaches behind the eye. `None`
    /// when no visible surface can be in the shadow.
    pub(super) fn shadow_scissor(&self, uniform: &FrameUniform) -> Option<[u32; 4]> {
        let full = Some([0, 0, self.width, self.height]);
        let (lo, hi) = self.surface_bounds?;
        let d = |a: [f32; 4]| DVec3::new(f64::from(a[0]), f64::from(a[1]), f64::from(a[2]));
        let centre = d(uniform.sphere);
        let r = f64::from(uniform.sphere[3]);
        let light = d(uniform.shadow_light);
        let light_radius = f64::from(uniform.shadow_params[0]);
        let corners = (0..8).map(|k| {
            DVec3::new(
                if k & 1 == 0 { lo.x } else { hi.x },
                if k & 2 == 0 { lo.y } else { hi.y },
                if k & 4 == 0 { lo.z } else { hi.z },
            )
        });
        // Cross-section discs (centre, radius) at the near end and the far end of the volume.
        let (axis, discs) = if uniform.shadow_light[3] > 0.5 {
            let to_sphere = centre - light;
            let d_s = to_sphere.length();
            if d_s <= r * 1.01 {
                return full;
            }
            let axis = to_sphere / d_s;
            let far = corners.map(|c| (c - light).length()).fold(0.0, f64::max);
            let near = d_s - r;
            if far <= near {
                return None;
            }
            let tan_half = r / (d_s * d_s - r * r).sqrt();
            let radius = |x: f64| (x * tan_half + light_radius * (x - d_s).max(0.0) / d_s) * 1.05 + r * 0.01;
            (axis, [(light + axis * near, radius(d_s)), (light + axis * far, radius(far))])
        } else {
            let axis = light.normalize_or_zero();
            let far = corners.map(|c| (c - centre).dot(axis)).fold(f64::NEG_INFINITY, f64::max);
            if far <= -r {
                return None;
            }
            (axis, [(centre - axis * r, r * 1.05), (centre + axis * far, r * 1.05)])
        };
        let u = axis.any_orthonormal_vector();
        let v = axis.cross(u);
        let clip_from_camera = self.projection.clip_from_camera();
        let (mut x0, mut y0, mut x1, mut y1) =
            (f64::INFINITY, f64::INFINITY, f64::NEG_INFINITY, f64::NEG_INFINITY);
        for (c, radius) in discs {
            for (a, b) in [(-1.0, -1.0), (1.0, -1.0), (1.0, 1.0), (-1.0, 1.0)] {
                let p = c + (u * a + v * b) * radius;
                let clip = clip_from_camera * p.extend(1.0);
                if clip.w.is_nan() || clip.w <= 1e-9 {
                    return full;
                }
                let x = (clip.x / clip.w + 1.0) * 0.5 * f64::from(self.width);
                let y = (1.0 - clip.y / clip.w) * 0.5 * f64::from(self.height);
                (x0, y0, x1, y1) = (x0.min(x), y0.min(y), x1.max(x), y1.max(y));
            }
        }
        let clamp_x = |v: f64| v.clamp(0.0, f64::from(self.width)) as u32;
        let clamp_y = |v: f64| v.clamp(0.0, f64::from(self.height)) as u32;
        let (ix0, iy0) = (clamp_x(x0.floor() - 1.0), clamp_y(y0.floor() - 1.0));
        let (ix1, iy1) = (clamp_x(x1.ceil() + 1.0), clamp_y(y1.ceil() + 1.0));
        (ix1 > ix0 && iy1 > iy0).then_some([ix0, iy0, ix1 - ix0, iy1 - iy0])
    }
}
