//! The renderer's light layers (docs/sidecar.md) as the compositor uses them: exact shadows of
//! live objects remove the occluded share of each light's own direct contribution, and the
//! live sphere's occlusion of indirect light near contact removes part of the indirect layer
//! (differential rendering, Debevec 1998, with the renderer's own split of the image).

use crate::error::ViewerError;
use glam::DVec3;
use sidecar::LightLayers;

/// Most samples of area-light surfaces passed to the shaders, over all lights.
pub const MAX_AREA_SAMPLES: usize = 256;
/// Samples per area light when few area lights share [`MAX_AREA_SAMPLES`].
pub const AREA_SAMPLES_PER_LIGHT: usize = 64;

/// A point of an area light's emitting surface standing for `area` of it.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct AreaSample {
    pub position: DVec3,
    /// Unit emitting normal; zero for an emitter without one orientation (a sphere).
    pub normal: DVec3,
    pub area: f64,
}

/// Light layers bound to the scene's live lights.
#[derive(Clone, Debug, PartialEq)]
pub struct SceneLayers {
    pub layers: LightLayers,
    /// For each live light (`ViewerScene::lights` order), the `light.K` layer holding its
    /// direct light, or `None` (e.g. an ambient light, whose light is in `emission`).
    pub layer_of_light: Vec<Option<usize>>,
    /// For each live light, samples of its emitting surface (area lights; empty for others),
    /// over which the shadow pass integrates the occluded share as the ray tracer does.
    pub area_samples: Vec<Vec<AreaSample>>,
}

impl SceneLayers {
    /// Checks the binding against the image size and the number of live lights.
    pub fn check(&self, width: u32, height: u32, light_count: usize) -> Result<(), ViewerError> {
        if (self.layers.width, self.layers.height) != (width, height) {
            return Err(ViewerError::SizeMismatch {
                first_what: "the light layers".into(),
                first: (self.layers.width, self.layers.height),
                second_what: "the image".into(),
                second: (width, height),
            });
        }
        if self.layer_of_light.len() != light_count || self.area_samples.len() != light_count {
            return Err(ViewerError::Invalid(format!(
                "light layers bound to {} lights, the scene has {light_count}",
                self.layer_of_light.len()
            )));
        }
        let layers = self.layers.light.len();
        if let Some(k) = self.layer_of_light.iter().flatten().find(|&&k| k >= layers) {
            return Err(ViewerError::Invalid(format!("light layer {k} does not exist ({layers} layers)")));
        }
        let samples_finite = self
            .area_samples
            .iter()
            .flatten()
            .all(|s| s.position.is_finite() && s.normal.is_finite() && s.area.is_finite());
        if !samples_finite {
            return Err(ViewerError::Invalid("an area light sample is not finite".into()));
        }
        Ok(())
    }
}

/// `count` samples spread evenly over triangles by area (a stratified walk along the area CDF,
/// with a golden-ratio sequence as the second axis, so every k-th sample is still spread
/// evenly): deterministic, so a frame is the same each run.
pub fn area_samples(triangles: &[[DVec3; 3]], count: usize) -> Vec<AreaSample> {
    let areas: Vec<f64> = triangles.iter().map(|[a, b, c]| 0.5 * (*b - *a).cross(*c - *a).length()).collect();
    let total: f64 = areas.iter().sum();
    if count == 0 || total.is_nan() || total <= 0.0 || !total.is_finite() {
        return Vec::new();
    }
    let mut out = Vec::with_capacity(count);
    let (mut t, mut below) = (0usize, 0.0f64);
    for i in 0..count {
        let u = (i as f64 + 0.5) / count as f64 * total;
        while t + 1 < triangles.len() && below + areas[t] < u {
            below += areas[t];
            t += 1;
        }
        let [a, b, c] = triangles[t];
        // Uniform on the triangle from the unit square.
        let golden = (i as f64 * 0.618_033_988_749_894_9).fract();
        let (mut s, mut v) = ((u - below) / areas[t].max(f64::MIN_POSITIVE), golden);
        s = s.clamp(0.0, 1.0);
        if s + v > 1.0 {
            (s, v) = (1.0 - s, 1.0 - v);
        }
        let normal = (b - a).cross(c - a).normalize_or_zero();
        out.push(AreaSample { position: a + (b - a) * s + (c - a) * v, normal, area: total / count as f64 });
    }
    out
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn samples_cover_the_area_evenly() {
        let quad = [
            [DVec3::ZERO, DVec3::X, DVec3::new(1.0, 1.0, 0.0)],
            [DVec3::ZERO, DVec3::new(1.0, 1.0, 0.0), DVec3::Y * 3.0],
        ];
        let s = area_samples(&quad, 64);
        assert_eq!(s.len(), 64);
        let total: f64 = s.iter().map(|s| s.area).sum();
        assert!((total - 2.0).abs() < 1e-12);
        // The mean of uniform samples is the area centroid.
        let centroid = (DVec3::new(2.0, 1.0, 0.0) / 3.0 * 0.5 + DVec3::new(1.0, 4.0, 0.0) / 3.0 * 1.5) / 2.0;
        let mean = s.iter().map(|s| s.position).sum::<DVec3>() / 64.0;
        assert!((mean - centroid).length() < 0.05, "{mean} vs {centroid}");
        assert!(s.iter().all(|s| (s.normal - DVec3::Z).length() < 1e-12 && s.position.z == 0.0));
        assert!(area_samples(&[], 8).is_empty());
        assert!(area_samples(&[[DVec3::ZERO; 3]], 8).is_empty());
    }
}
