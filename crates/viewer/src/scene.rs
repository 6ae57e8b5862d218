//! The viewer's input: the camera, the pre-rendered image and depth table, and the lights.

use crate::backdrop::{Backdrop, Rgba8Image, ToneMap};
use crate::error::ViewerError;
use crate::light_layers::SceneLayers;
use crate::live::LiveLight;
use crate::pixel_filter::PixelFilter;
use depth_remap::{Camera, DepthTable};
use glam::DVec3;

/// Everything the viewer needs from the offline side, checked for consistency.
#[derive(Clone, Debug)]
pub struct ViewerScene {
    camera: Camera,
    backdrop: Backdrop,
    depth: DepthTable,
    lights: Vec<LiveLight>,
    tone_map: ToneMap,
    layers: Option<std::sync::Arc<SceneLayers>>,
    probes: Option<std::sync::Arc<sidecar::ProbeGrid>>,
    reflections: Option<std::sync::Arc<sidecar::ReflectionProbes>>,
    caustics: Option<std::sync::Arc<sidecar::CausticPhotons>>,
    pixel_filter: PixelFilter,
    occluders: Option<std::sync::Arc<crate::occluders::SceneOccluders>>,
    occluder_materials: Option<std::sync::Arc<crate::occluders::SceneMaterials>>,
}

/// Most reflection probes the viewer binds: the texture-array layers every wgpu adapter has
/// (`Limits::default().max_texture_array_layers`).
pub const MAX_VIEWER_REFLECTION_PROBES: usize = 256;

impl ViewerScene {
    /// Checks that the image, the depth table and the camera's `Format` have the same size, and
    /// that the camera's crop window is the whole image (the viewer shows whole frames). The
    /// image's bytes are display values under `tone_map`'s gamma ([`Backdrop::from_rgba8`]).
    pub fn new(
        camera: Camera,
        image: Rgba8Image,
        depth: DepthTable,
        lights: Vec<LiveLight>,
        tone_map: ToneMap,
    ) -> Result<ViewerScene, ViewerError> {
        if image.pixels.len() != image.width as usize * image.height as usize * 4 {
            return Err(ViewerError::Invalid("the image's pixel buffer does not match its size".into()));
        }
        let backdrop = Backdrop::from_rgba8(image, tone_map.gamma);
        ViewerScene::with_backdrop(camera, backdrop, depth, lights, tone_map)
    }

    /// As [`ViewerScene::new`], for an image already in linear form (e.g. a float image read
    /// with [`Backdrop::read`]). `tone_map.gain` scales live objects' radiance into the image's
    /// units (`lrt-depth` applies `Exposure`'s gain to everything it writes).
    pub fn with_backdrop(
        camera: Camera,
        backdrop: Backdrop,
        depth: DepthTable,
        lights: Vec<LiveLight>,
        tone_map: ToneMap,
    ) -> Result<ViewerScene, ViewerError> {
        let image_size = (backdrop.width, backdrop.height);
        let depth_size = (depth.width(), depth.height());
        if image_size != depth_size {
            return Err(ViewerError::SizeMismatch {
                first_what: "the image".into(),
                first: image_size,
                second_what: "the depth table".into(),
                second: depth_size,
            });
        }
        let pixels = backdrop.width as usize * backdrop.height as usize;
        if backdrop.linear.len() != pixels * 4 || backdrop.display.pixels.len() != pixels * 4 {
            return Err(ViewerError::Invalid("the image's pixel buffer does not match its size".into()));
        }
        if camera.resolution() != image_size {
            return Err(ViewerError::SizeMismatch {
                first_what: "the image".into(),
                first: image_size,
                second_what: "the scene's Format".into(),
                second: camera.resolution(),
            });
        }
        Ok(ViewerScene {
            camera,
            backdrop,
            depth,
            lights,
            tone_map,
            layers: None,
            probes: None,
            reflections: None,
            caustics: None,
            pixel_filter: PixelFilter::BOX,
            occluders: None,
            occluder_materials: None,
        })
    }

    /// Sets the pixel filter the image was rendered with (the RIB's `PixelFilter`): live
    /// objects' edges are filtered with it. Without this call it is `PixelFilter::BOX` (each
    /// sample counts for its own pixel).
    pub fn set_pixel_filter(&mut self, filter: PixelFilter) {
        self.pixel_filter = filter;
    }

    /// The pixel filter the image was rendered with.
    pub fn pixel_filter(&self) -> PixelFilter {
        self.pixel_filter
    }

    /// Binds the renderer's light layers: shadows of live objects then remove exactly the
    /// occluded share of each light's direct light (and occluded indirect light near contact).
    pub fn set_light_layers(&mut self, layers: SceneLayers) -> Result<(), ViewerError> {
        layers.check(self.backdrop.width, self.backdrop.height, self.lights.len())?;
        self.layers = Some(std::sync::Arc::new(layers));
        Ok(())
    }

    /// Binds the scene's own geometry as triangles: the RIB lights' light on live objects is
    /// then shadowed by the scene (without it, live objects get every light unshadowed).
    pub fn set_occluders(&mut self, occluders: crate::occluders::SceneOccluders) {
        self.occluders = Some(std::sync::Arc::new(occluders));
    }

    /// The scene's triangles shadowing live objects, if bound.
    pub fn occluders(&self) -> Option<&crate::occluders::SceneOccluders> {
        self.occluders.as_deref()
    }

    /// Binds the materials of the scene's triangles (`set_occluders`): live surfaces within a
    /// probe spacing of a scene surface then get the light that surface sends instead of the
    /// irradiance probes' light from its direction (the near field, docs/viewer-lighting.md).
    /// Without them the probes light live surfaces alone.
    pub fn set_occluder_materials(&mut self, materials: crate::occluders::SceneMaterials) {
        self.occluder_materials = Some(std::sync::Arc::new(materials));
    }

    /// The materials of the scene's triangles, if bound.
    pub fn occluder_materials(&self) -> Option<&crate::occluders::SceneMaterials> {
        self.occluder_materials.as_deref()
    }

    /// Binds the renderer's irradiance probes: live objects' diffuse light then comes from the
    /// scene's own global illumination instead of the bare lights.
    pub fn set_probes(&mut self, probes: sidecar::ProbeGrid) {
        self.probes = Some(std::sync::Arc::new(probes));
    }

    /// The bound irradiance probes, if any.
    pub fn probes(&self) -> Option<&sidecar::ProbeGrid> {
        self.probes.as_deref()
    }

    pub(crate) fn probes_arc(&self) -> Option<std::sync::Arc<sidecar::ProbeGrid>> {
        self.probes.clone()
    }

    /// Binds the renderer's caustic photons: live spheres then take from the image the caustic
    /// light whose photons they block (docs/viewer-specular.md). Refuses photons of another frame size.
    pub fn set_caustics(&mut self, caustics: sidecar::CausticPhotons) -> Result<(), ViewerError> {
        let (width, height) = self.size();
        if (caustics.width, caustics.height) != (width, height) {
            return Err(ViewerError::Unsupported(format!(
                "caustic photons for {}x{}, the image is {width}x{height}",
                caustics.width, caustics.height
            )));
        }
        self.caustics = Some(std::sync::Arc::new(caustics));
        Ok(())
    }

    /// The bound caustic photons, if any.
    pub fn caustics(&self) -> Option<&sidecar::CausticPhotons> {
        self.caustics.as_deref()
    }

    pub(crate) fn caustics_arc(&self) -> Option<std::sync::Arc<sidecar::CausticPhotons>> {
        self.caustics.clone()
    }

    /// Binds the renderer's reflection probes: glossy live surfaces then reflect the scene's
    /// prefiltered radiance (docs/sidecar.md), area lights included. Refuses more probes than
    /// [`MAX_VIEWER_REFLECTION_PROBES`] or a grid whose arrays do not match its counts.
    pub fn set_reflections(&mut self, probes: sidecar::ReflectionProbes) -> Result<(), ViewerError> {
        let n = probes.probe_count();
        if n == 0 || n > MAX_VIEWER_REFLECTION_PROBES {
            return Err(ViewerError::Invalid(format!(
                "{n} reflection probes: the viewer binds 1 to {MAX_VIEWER_REFLECTION_PROBES}"
            )));
        }
        let texels = |level: usize| sidecar::reflection_level_texels(level).pow(2) * n;
        let consistent = probes.radiance.len() == sidecar::REFLECTION_LEVELS
            && probes.radiance.iter().enumerate().all(|(k, level)| level.len() == texels(k))
            && probes.distance.len() == texels(0)
            && probes.spacing.iter().all(|s| s.is_finite() && *s > 0.0)
            && probes.origin.iter().all(|o| o.is_finite());
        if !consistent {
            return Err(ViewerError::Invalid("reflection probes: arrays do not match the grid".into()));
        }
        self.reflections = Some(std::sync::Arc::new(probes));
        Ok(())
    }

    /// The bound reflection probes, if any.
    pub fn reflections(&self) -> Option<&sidecar::ReflectionProbes> {
        self.reflections.as_deref()
    }

    /// The bound light layers, if any.
    pub fn light_layers(&self) -> Option<&SceneLayers> {
        self.layers.as_deref()
    }

    pub fn camera(&self) -> &Camera {
        &self.camera
    }

    /// The image as the window shows it where nothing live changes it.
    pub fn image(&self) -> &Rgba8Image {
        &self.backdrop.display
    }

    /// The image in linear form, with its display encoding.
    pub fn backdrop(&self) -> &Backdrop {
        &self.backdrop
    }

    pub fn depth(&self) -> &DepthTable {
        &self.depth
    }

    pub fn lights(&self) -> &[LiveLight] {
        &self.lights
    }

    pub fn tone_map(&self) -> ToneMap {
        self.tone_map
    }

    pub fn size(&self) -> (u32, u32) {
        (self.backdrop.width, self.backdrop.height)
    }

    /// The world-space point of pixel `(i, j)`'s surface, `None` for a miss.
    pub fn surface_point(&self, i: u32, j: u32) -> Option<DVec3> {
        let r = self.depth.get(i, j)?;
        if !r.is_finite() {
            return None;
        }
        let ray = self.camera.pixel_centre_ray(i, j);
        let p = ray.origin + ray.direction * f64::from(r);
        Some(self.camera.world_from_camera().transform_point3(p))
    }

    /// The centroid of every visible surface point (world space), `None` when every pixel is
    /// a miss. Used to pick the dominant light.
    pub fn visible_centroid(&self) -> Option<DVec3> {
        let (w, h) = self.size();
        let mut sum = DVec3::ZERO;
        let mut n = 0u64;
        // A 64x64 grid of samples is plenty for a centroid.
        let step_i = (w / 64).max(1);
        let step_j = (h / 64).max(1);
        for j in (0..h).step_by(step_j as usize) {
            for i in (0..w).step_by(step_i as usize) {
                if let Some(p) = self.surface_point(i, j) {
                    sum += p;
                    n += 1;
                }
            }
        }
        (n > 0).then(|| sum / n as f64)
    }

    /// The light that dominates the direct illumination of the visible scene (largest
    /// irradiance at the centroid of the visible surfaces): it casts the live objects' shadows.
    pub fn dominant_light(&self) -> Option<usize> {
        let at = self.visible_centroid().unwrap_or(DVec3::ZERO);
        self.lights
            .iter()
            .enumerate()
            .filter(|(_, l)| l.shadow_source().is_some())
            .map(|(k, l)| (k, l.irradiance_at(at)))
            .filter(|(_, e)| *e > 0.0 && e.is_finite())
            .max_by(|a, b| a.1.total_cmp(&b.1))
            .map(|(k, _)| k)
    }
}
