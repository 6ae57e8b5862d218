//! The live objects' shadows on the pre-rendered scene: which pixels they can fall on.

use super::Compositor;
use super::lighting::{FrameUniform, vec4};
use crate::live::ShadowSource;
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

/// How far from the sphere's centre, in radii, its occlusion of indirect light is counted (it
/// fades out over the last quarter; `(1/8)^2` of the indirect light is left out beyond).
pub(super) const AO_REACH: f64 = 8.0;

impl Compositor {
    /// The pixels live objects' shadows can fall on: with light layers, the union over the
    /// lights that have one of each sphere's shadow volume and the box where its occlusion of
    /// indirect light is counted, and the live meshes' bounding sphere's shadow volumes;
    /// without, the shadow light's volume.
    pub(super) fn shadow_scissor_all(&self, uniform: &FrameUniform) -> Option<[u32; 4]> {
        let d = |a: [f32; 4]| DVec3::new(f64::from(a[0]), f64::from(a[1]), f64::from(a[2]));
        if uniform.layer_info[0] == 0 {
            let (centre, r) = (d(uniform.sphere), f64::from(uniform.sphere[3]));
            return self.shadow_scissor(centre, r, uniform.shadow_light, f64::from(uniform.shadow_params[0]));
        }
        let spheres = &uniform.shadow_spheres[..uniform.layer_info[3] as usize];
        let mut union = None;
        for s in spheres {
            let (centre, r) = (d(*s), f64::from(s[3]));
            union = merge(union, self.box_scissor(centre, r * AO_REACH));
            union = merge(union, self.layered_scissor(centre, r));
        }
        let bound = uniform.live_occluder_bound;
        if uniform.live_occluders[2] > 0 && bound[3] > 0.0 {
            union = merge(union, self.layered_scissor(d(bound), f64::from(bound[3])));
        }
        union
    }

    /// The pixels a sphere's layered shadows can reach (the union of its shadow volumes from
    /// the lights that have a layer).
    fn layered_scissor(&self, centre: DVec3, r: f64) -> Option<[u32; 4]> {
        let camera_from_world = self.projection.camera().camera_from_world();
        let linear = glam::DMat3::from_mat4(camera_from_world);
        let scale = linear.determinant().abs().cbrt();
        let mut union: Option<[u32; 4]> = None;
        for (light, slot) in self.lights.iter().zip(&self.layers.light_slots) {
            if slot[0] == super::layers::NO_LAYER {
                continue;
            }
            let (source, radius) = match light.shadow_source() {
                Some(ShadowSource::Point { position, radius }) => {
                    (vec4(camera_from_world.transform_point3(position), 1.0), radius * scale)
                }
                Some(ShadowSource::Direction(dir)) => (vec4((linear * dir).normalize_or_zero(), 0.0), 0.0),
                None => continue,
            };
            union = merge(union, self.shadow_scissor(centre, r, source, radius));
        }
        union
    }

    /// The screen bounds of a camera-space box of half-size `half` about `centre` (the whole
    /// image when it reaches behind the eye).
    pub(super) fn box_scissor(&self, centre: DVec3, half: f64) -> Option<[u32; 4]> {
        let corners: Vec<DVec3> = (0..8)
            .map(|k| {
                centre
                    + DVec3::new(
                        if k & 1 == 0 { -half } else { half },
                        if k & 2 == 0 { -half } else { half },
                        if k & 4 == 0 { -half } else { half },
                    )
            })
            .collect();
        self.screen_bounds(&corners)
    }

    /// The pixels the sphere's shadow from one light can fall on: the screen bounds of the
    /// shadow volume (the sphere's outer penumbra cone from the light, cut where it leaves the
    /// bounds of the visible surfaces), or the whole image when that volume reaches behind the
    /// eye. `None` when no visible surface can be in the shadow. `light` is a camera-space
    /// position (w = 1) or direction of travel (w = 0).
    fn shadow_scissor(
        &self,
        centre: DVec3,
        r: f64,
        light_vec: [f32; 4],
        light_radius: f64,
    ) -> Option<[u32; 4]> {
        let full = Some([0, 0, self.width, self.height]);
        let (lo, hi) = self.surface_bounds?;
        let d = |a: [f32; 4]| DVec3::new(f64::from(a[0]), f64::from(a[1]), f64::from(a[2]));
        let light = d(light_vec);
        let corners = (0..8).map(|k| {
            DVec3::new(
                if k & 1 == 0 { lo.x } else { hi.x },
                if k & 2 == 0 { lo.y } else { hi.y },
                if k & 4 == 0 { lo.z } else { hi.z },
            )
        });
        // Cross-section discs (centre, radius) at the near end and the far end of the volume.
        let (axis, discs) = if light_vec[3] > 0.5 {
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
        let points: Vec<DVec3> = discs
            .iter()
            .flat_map(|&(c, radius)| {
                [(-1.0, -1.0), (1.0, -1.0), (1.0, 1.0), (-1.0, 1.0)]
                    .map(|(a, b)| c + (u * a + v * b) * radius)
            })
            .collect();
        self.screen_bounds(&points)
    }

    /// The pixel rectangle covering camera-space `points` (the whole image when one is behind
    /// the eye), `None` when it is empty.
    pub(super) fn screen_bounds(&self, points: &[DVec3]) -> Option<[u32; 4]> {
        let full = Some([0, 0, self.width, self.height]);
        let clip_from_camera = self.projection.clip_from_camera();
        let (mut x0, mut y0, mut x1, mut y1) =
            (f64::INFINITY, f64::INFINITY, f64::NEG_INFINITY, f64::NEG_INFINITY);
        for p in points {
            let clip = clip_from_camera * p.extend(1.0);
            if clip.w.is_nan() || clip.w <= 1e-9 {
                return full;
            }
            let x = (clip.x / clip.w + 1.0) * 0.5 * f64::from(self.width);
            let y = (1.0 - clip.y / clip.w) * 0.5 * f64::from(self.height);
            (x0, y0, x1, y1) = (x0.min(x), y0.min(y), x1.max(x), y1.max(y));
        }
        let clamp_x = |v: f64| v.clamp(0.0, f64::from(self.width)) as u32;
        let clamp_y = |v: f64| v.clamp(0.0, f64::from(self.height)) as u32;
        let (ix0, iy0) = (clamp_x(x0.floor() - 1.0), clamp_y(y0.floor() - 1.0));
        let (ix1, iy1) = (clamp_x(x1.ceil() + 1.0), clamp_y(y1.ceil() + 1.0));
        (ix1 > ix0 && iy1 > iy0).then_some([ix0, iy0, ix1 - ix0, iy1 - iy0])
    }
}

/// The smallest rectangle holding both.
pub(super) fn merge(a: Option<[u32; 4]>, b: Option<[u32; 4]>) -> Option<[u32; 4]> {
    match (a, b) {
        (Some([ax, ay, aw, ah]), Some([bx, by, bw, bh])) => {
            let (x0, y0) = (ax.min(bx), ay.min(by));
            let (x1, y1) = ((ax + aw).max(bx + bw), (ay + ah).max(by + bh));
            Some([x0, y0, x1 - x0, y1 - y0])
        }
        (a, None) => a,
        (None, b) => b,
    }
}
