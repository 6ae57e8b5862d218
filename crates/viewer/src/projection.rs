//! The viewer's projection: `depth_remap`'s camera and depth mapping, as the GPU gets them.
//!
//! All depth arithmetic lives in `depth_remap` (the conventions, the clip matrices, the
//! per-pixel radial-to-window conversion, near/far from the data, the point-cloud matrix);
//! this module only picks what the viewer uses and hands it to the shaders:
//!
//! | depth buffer | convention | window depth at eye depth `d` | compare | clear |
//! |---|---|---|---|---|
//! | default: `Depth32Float` | [`DepthConvention::WgpuReversed`], infinite far | `n / d` | `Greater` | 0 |
//! | `Depth32Float`, `Depth24Plus` | [`DepthConvention::Wgpu`], finite far | `f (d - n) / ((f - n) d)` | `Less` | 1 |
//!
//! The near plane sits at 1/64 of the nearest pre-rendered surface's eye depth with reversed-Z
//! (a float buffer's relative precision does not depend on it, so live objects may come far in
//! front of the scene at no cost), and at `depth_remap`'s default (half the nearest surface,
//! far at twice the farthest) with the conventional mapping, whose precision it governs.

use crate::error::ViewerError;
use depth_remap::{
    Camera, DepthConvention, DepthMapping, DepthOutput, DepthTable, NearFar, NearFarPolicy, choose_near_far,
    point_cloud_matrix, remap_depth_table,
};
use glam::DMat4;

/// The near/far policy the viewer uses with `convention`.
pub fn near_far_policy(convention: DepthConvention) -> NearFarPolicy {
    if convention.is_reversed() {
        NearFarPolicy { near_factor: 1.0 / 64.0, ..NearFarPolicy::default() }
    } else {
        NearFarPolicy { infinite_far: false, ..NearFarPolicy::default() }
    }
}

/// The wgpu comparison that keeps the nearer fragment under `convention`.
pub fn nearer(convention: DepthConvention) -> wgpu::CompareFunction {
    match convention.compare() {
        depth_remap::DepthCompare::Greater => wgpu::CompareFunction::Greater,
        depth_remap::DepthCompare::Less => wgpu::CompareFunction::Less,
    }
}

/// The live projection for one camera and depth mapping.
#[derive(Clone, Debug, PartialEq)]
pub struct Projection {
    camera: Camera,
    planes: NearFar,
    mapping: DepthMapping,
}

impl Projection {
    /// The projection for `camera` with `convention`; near and far from `table` unless `planes`
    /// are given. Only wgpu's `[0, 1]` conventions are accepted.
    pub fn new(
        camera: Camera,
        table: &DepthTable,
        convention: DepthConvention,
        planes: Option<NearFar>,
    ) -> Result<Projection, ViewerError> {
        if convention.is_gl() {
            return Err(ViewerError::Unsupported(format!(
                "depth convention {convention}: wgpu's depth range is [0, 1]"
            )));
        }
        let planes = match planes {
            Some(p) => p,
            None => {
                let range = camera.eye_depth_range(table).map_err(|e| ViewerError::Camera(e.to_string()))?;
                choose_near_far(range, camera.clipping(), near_far_policy(convention))
            }
        };
        let mapping = camera
            .depth_mapping(convention, planes)
            .map_err(|e| ViewerError::Camera(format!("depth mapping: {e}")))?;
        Ok(Projection { camera, planes, mapping })
    }

    pub fn camera(&self) -> &Camera {
        &self.camera
    }

    pub fn planes(&self) -> NearFar {
        self.planes
    }

    pub fn mapping(&self) -> &DepthMapping {
        &self.mapping
    }

    pub fn convention(&self) -> DepthConvention {
        self.mapping.convention()
    }

    /// Clip from RenderMan camera space: `depth_remap`'s projection for the camera's frustum.
    pub fn clip_from_camera(&self) -> DMat4 {
        self.mapping.clip_from_camera(&self.camera.frustum())
    }

    /// The paper's point-cloud matrix (raster `x, y` to clip space, depth passed through).
    pub fn clip_from_raster(&self) -> DMat4 {
        let (w, h) = self.camera.resolution();
        point_cloud_matrix(w, h)
    }

    /// Window depths of a whole radial table (row-major, top row first), as the depth buffer
    /// must hold them; a miss is the far value. For wgpu, window and NDC depth are equal, so
    /// these are also the point cloud's vertex depths.
    pub fn window_depths(&self, table: &DepthTable) -> Result<Vec<f32>, ViewerError> {
        remap_depth_table(&self.camera, table, &self.mapping, DepthOutput::Window, 0)
            .map(|r| r.values)
            .map_err(|e| ViewerError::Camera(e.to_string()))
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use depth_remap::{CameraSettings, Projection as RibProjection};
    use glam::{DVec2, DVec3, DVec4};

    fn camera(w: u32, h: u32, fov: f64) -> Camera {
        Camera::new(CameraSettings {
            x_resolution: w,
            y_resolution: h,
            projection: RibProjection::Perspective { fov_degrees: fov },
            ..CameraSettings::default()
        })
        .unwrap()
    }

    fn wall(cam: &Camera, eye_depth: f64) -> DepthTable {
        let (w, h) = cam.resolution();
        let values = (0..w * h).map(|k| cam.eye_depth_to_radial(k % w, k / w, eye_depth) as f32).collect();
        DepthTable::new(w, h, values).unwrap()
    }

    /// A camera-space point on the ray through a raster position projects back onto that raster
    /// position: the live projection and the depth table's rays agree.
    #[test]
    fn projection_matches_the_camera_rays() {
        for (w, h) in [(64, 48), (48, 64), (50, 50)] {
            let cam = camera(w, h, 39.3);
            let p =
                Projection::new(cam.clone(), &wall(&cam, 3.0), DepthConvention::WgpuReversed, None).unwrap();
            let m = p.clip_from_camera();
            for raster in [DVec2::new(0.5, 0.5), DVec2::new(17.25, 3.5), DVec2::new(f64::from(w) - 0.5, 9.0)]
            {
                let ray = cam.ray_through_raster(raster);
                let point = ray.origin + ray.direction * 3.7;
                let clip = m * point.extend(1.0);
                let ndc = DVec3::new(clip.x / clip.w, clip.y / clip.w, clip.z / clip.w);
                let back = DVec2::new((ndc.x + 1.0) * 0.5 * f64::from(w), (1.0 - ndc.y) * 0.5 * f64::from(h));
                assert!((back - raster).length() < 1e-9, "{raster} -> {back}");
            }
        }
    }

    /// The viewer's default: reversed-Z, infinite far, near at 1/64 of the nearest surface.
    #[test]
    fn default_planes_leave_room_in_front_of_the_scene() {
        let cam = camera(32, 32, 60.0);
        let p = Projection::new(cam.clone(), &wall(&cam, 4.0), DepthConvention::WgpuReversed, None).unwrap();
        assert!(p.planes().infinite_far);
        assert!(p.planes().near <= 4.0 / 64.0 && p.planes().near > 4.0 / 65.0);
        // Window depth n / d: a point at the near plane is 1, twice as far is 0.5.
        let n = p.planes().near;
        let m = p.clip_from_camera();
        let at = |d: f64| {
            let c = m * DVec4::new(0.0, 0.0, d, 1.0);
            c.z / c.w
        };
        assert!((at(n) - 1.0).abs() < 1e-6 && (at(2.0 * n) - 0.5).abs() < 1e-6);
        let standard = Projection::new(cam.clone(), &wall(&cam, 4.0), DepthConvention::Wgpu, None).unwrap();
        assert!(!standard.planes().infinite_far);
        assert!(Projection::new(cam.clone(), &wall(&cam, 4.0), DepthConvention::Gl, None).is_err());
    }

    #[test]
    fn raster_matrix_maps_pixel_centres_and_passes_depth_through() {
        let cam = camera(8, 4, 45.0);
        let p = Projection::new(cam.clone(), &wall(&cam, 2.0), DepthConvention::WgpuReversed, None).unwrap();
        let c = p.clip_from_raster() * DVec4::new(0.5, 0.5, 0.123, 1.0);
        assert_eq!((c.x, c.y, c.z, c.w), (-0.875, 0.75, 0.123, 1.0));
    }
}
