//! Lighting data for the shaders: lights, materials and live objects moved to camera space in
//! f64, packed into the uniform blocks the shaders read.

use super::{Compositor, MAX_LIGHTS};

/// Most spheres casting shadows with light layers in one frame (further ones cast none).
pub const MAX_SHADOW_SPHERES: usize = 8;
use crate::live::{LiveLight, LiveObjects, Material, ShadowSource};
use crate::pixel_filter::{FOOTPRINT_SAMPLES, footprint, footprint_rays};
use bytemuck::{Pod, Zeroable};
use glam::{DMat3, DMat4, DVec3};

#[repr(C)]
#[derive(Clone, Copy, Debug, Default, Pod, Zeroable)]
pub(super) struct GpuLight {
    pub(super) position: [f32; 4],
    pub(super) direction: [f32; 4],
    pub(super) colour: [f32; 4],
    pub(super) params: [f32; 4],
}

#[repr(C)]
#[derive(Clone, Copy, Debug, Default, Pod, Zeroable)]
pub(super) struct GpuMaterial {
    pub(super) colour: [f32; 4],
    pub(super) coefficients: [f32; 4],
    /// rgb: specular colour; w: the mip level of the reflection probes for its roughness.
    pub(super) specular_colour: [f32; 4],
    /// The Blinn lobe's directional albedo at `cos_o = max(i / 15, 1e-3)`, `i = 0..16`
    /// (`sidecar::blinn_albedo`): the split sum's second factor for the reflection probes.
    pub(super) albedo: [[f32; 4]; 4],
}

/// Entries of [`GpuMaterial::albedo`].
const ALBEDO_ENTRIES: usize = 16;

impl From<&Material> for GpuMaterial {
    fn from(m: &Material) -> Self {
        let exponent = sidecar::blinn_exponent(m.roughness);
        let mut albedo = [[0.0f32; 4]; 4];
        if m.ks != 0.0 && !m.unlit {
            for i in 0..ALBEDO_ENTRIES {
                let cos_o = (i as f32 / (ALBEDO_ENTRIES - 1) as f32).max(1e-3);
                albedo[i / 4][i % 4] = sidecar::blinn_albedo(exponent, cos_o);
            }
        }
        GpuMaterial {
            colour: [m.colour.x, m.colour.y, m.colour.z, if m.unlit { 1.0 } else { 0.0 }],
            coefficients: [m.ka, m.kd, m.ks, m.roughness],
            specular_colour: m.specular_colour.extend(sidecar::reflection_level(m.roughness)).to_array(),
            albedo,
        }
    }
}

#[repr(C)]
#[derive(Clone, Copy, Debug, Pod, Zeroable)]
pub(super) struct FrameUniform {
    pub(super) clip_from_camera: [[f32; 4]; 4],
    pub(super) clip_from_raster: [[f32; 4]; 4],
    pub(super) screen_window: [f32; 4],
    pub(super) raster: [f32; 4],
    /// x: radiance to image units; y: 1 when a moving frame shades the cursor sphere from its
    /// radiosity map; z: 1 when a moving frame's layered shadows are gathered at reduced
    /// resolution; w: 1 in a moving frame, which leaves out the near field and the traced glossy
    /// lobes (`frame.rs`, all set only in the buffer the shaders read).
    pub(super) tone: [f32; 4],
    pub(super) counts: [u32; 4],
    pub(super) shadow_light: [f32; 4],
    pub(super) shadow_params: [f32; 4],
    pub(super) sphere: [f32; 4],
    pub(super) sphere_material: GpuMaterial,
    /// 1 when light layers are bound, the indirect slice, the normal slice, the number of
    /// shadow-casting spheres.
    pub(super) layer_info: [u32; 4],
    /// Camera-space centre and radius of each sphere casting shadows with the layers: the
    /// cursor sphere and live spheres.
    pub(super) shadow_spheres: [[f32; 4]; MAX_SHADOW_SPHERES],
    /// Rotation from camera to world space (for the probes' world-space SH).
    pub(super) world_from_camera: [[f32; 4]; 4],
    /// Per light: its layer slice (`u32::MAX`: none), first area sample, sample count.
    pub(super) shadow_slots: [[u32; 4]; MAX_LIGHTS],
    /// Camera space to world space, points (the reflection probes' lookups are in world space).
    pub(super) world_from_camera_point: [[f32; 4]; 4],
    /// The reflection probes' grid: origin (w 1 when bound), spacing, counts.
    pub(super) reflection_origin: [f32; 4],
    pub(super) reflection_spacing: [f32; 4],
    pub(super) reflection_counts: [u32; 4],
    /// The irradiance probes' grid: origin (w 1 when bound), spacing, counts.
    pub(super) irradiance_origin: [f32; 4],
    pub(super) irradiance_spacing: [f32; 4],
    pub(super) irradiance_counts: [u32; 4],
    pub(super) lights: [GpuLight; MAX_LIGHTS],
    /// Shadow-ray hierarchies (`scene_shadows.rs`): the scene's, the live meshes', and the live
    /// meshes' camera-space bounding sphere.
    pub(super) scene_occluders: [u32; 4],
    pub(super) live_occluders: [u32; 4],
    pub(super) live_occluder_bound: [f32; 4],
    /// The light live spheres reflect onto the scene (`bounce.rs`): 1 when on, the albedo
    /// layer's slice, the visible surfaces' bounding diagonal (f32 bits), 1 when the spheres'
    /// occlusion of indirect light is corrected with the light from behind them.
    pub(super) bounce: [u32; 4],
    /// The light the shadows take from the rest of the scene (`shadow_bounce.rs`): 1 when on,
    /// the shadows' scissor as `x | y << 16` and `width | height << 16`, the albedo layer's
    /// slice. Set by `Compositor::render` from the shadows' scissor.
    pub(super) shadow_bounce: [u32; 4],
    /// The live spheres seen in the scene's specular reflections and glossy lobes
    /// (`specular.wgsl`): 1 when on (with the bounce light), the `reflectance` slice, the
    /// `reflected` slice, the `glossy` slice (`glossy_exponent` the next), each `NO_LAYER`
    /// where no pixel has one.
    pub(super) reflection: [u32; 4],
    /// The points of a pixel's footprint the lights' direct light on live objects the eye sees
    /// is integrated over, and their shadow rays' offsets (`pixel_filter::footprint`,
    /// `footprint_rays`, for the image's pixel filter).
    pub(super) footprint: [[f32; 4]; FOOTPRINT_SAMPLES],
    pub(super) footprint_rays: [[f32; 4]; 4],
}

#[repr(C)]
#[derive(Clone, Copy, Debug, Pod, Zeroable)]
pub(super) struct MeshUniform {
    pub(super) camera_from_object: [[f32; 4]; 4],
    pub(super) normal_from_object: [[f32; 4]; 4],
    pub(super) material: GpuMaterial,
    /// x: the mesh's row in the own-shadow loss maps when it is a sphere, else -1
    /// (`loss_map.rs`).
    pub(super) loss_map: [i32; 4],
}

pub(super) fn mat4_f32(m: DMat4) -> [[f32; 4]; 4] {
    m.as_mat4().to_cols_array_2d()
}

pub(super) fn vec4(v: DVec3, w: f32) -> [f32; 4] {
    [v.x as f32, v.y as f32, v.z as f32, w]
}

impl Compositor {
    /// The uniform block for this frame: live objects and lights moved to camera space in f64.
    pub(super) fn frame_uniform(&self, live: &LiveObjects) -> FrameUniform {
        let camera = self.projection.camera();
        let camera_from_world = camera.camera_from_world();
        let linear = DMat3::from_mat4(camera_from_world);
        // The camera transform's uniform scale (1 for a rigid camera, mirrors included).
        let scale = linear.determinant().abs().cbrt();
        let point = |p: DVec3| camera_from_world.transform_point3(p);
        let direction = |d: DVec3| (linear * d).normalize_or_zero();
        let sw = camera.screen_window();
        let (tan_half, perspective) = match camera.tan_half_fov() {
            Some(t) => (t as f32, 1.0),
            None => (0.0, 0.0),
        };
        let mut lights = [GpuLight::default(); MAX_LIGHTS];
        for (k, (slot, light)) in lights.iter_mut().zip(&self.lights).enumerate() {
            *slot = match light {
                LiveLight::Ambient { colour } => GpuLight {
                    position: [0.0, 0.0, 0.0, 0.0],
                    colour: colour.extend(0.0).to_array(),
                    ..Default::default()
                },
                LiveLight::Distant { direction: d, colour } => GpuLight {
                    position: [0.0, 0.0, 0.0, 1.0],
                    direction: vec4(direction(*d), 0.0),
                    colour: colour.extend(0.0).to_array(),
                    ..Default::default()
                },
                LiveLight::Point { position, colour } => GpuLight {
                    position: vec4(point(*position), 2.0),
                    colour: colour.extend(0.0).to_array(),
                    ..Default::default()
                },
                LiveLight::Spot {
                    position,
                    axis,
                    colour,
                    cone_angle,
                    cone_delta_angle,
                    beam_distribution,
                } => GpuLight {
                    position: vec4(point(*position), 3.0),
                    direction: vec4(direction(*axis), 0.0),
                    colour: colour.extend(0.0).to_array(),
                    params: [
                        cone_angle.cos(),
                        (cone_angle - cone_delta_angle).cos(),
                        *beam_distribution,
                        0.0,
                    ],
                },
                LiveLight::Area { centroid, normal, two_sided, radiance, area, .. } => GpuLight {
                    position: vec4(point(*centroid), 4.0),
                    direction: vec4(
                        normal.map(direction).unwrap_or(DVec3::ZERO),
                        if *two_sided { 1.0 } else { 0.0 },
                    ),
                    colour: (*radiance * (*area * scale * scale) as f32)
                        .extend(if normal.is_some() { 1.0 } else { 0.0 })
                        .to_array(),
                    // The radiance each emitter sample carries (the light's power spread over
                    // the samples' area) where the shaders integrate over them.
                    params: {
                        let sampled: f64 =
                            self.layers.world_samples.get(k).map_or(0.0, |s| s.iter().map(|s| s.area).sum());
                        let per_sample =
                            if sampled > 0.0 { *radiance * (*area / sampled) as f32 } else { *radiance };
                        per_sample.extend(0.0).to_array()
                    },
                },
            };
        }
        let sphere =
            live.sphere.as_ref().filter(|s| s.radius > 0.0 && s.radius.is_finite() && s.centre.is_finite());
        let (sphere_vec, sphere_material) = match sphere {
            Some(s) => (vec4(point(s.centre), (s.radius * scale) as f32), GpuMaterial::from(&s.material)),
            None => ([0.0; 4], GpuMaterial::default()),
        };
        let layered = self.layers.info[0] == 1;
        let mut shadow_spheres = [[0.0f32; 4]; MAX_SHADOW_SPHERES];
        let mut sphere_count = 0usize;
        let casters = sphere.map(|s| (s.centre, s.radius)).into_iter().chain(
            live.meshes.iter().filter(|m| m.world_from_object.is_finite()).filter_map(|m| m.exact_sphere),
        );
        for (centre, radius) in casters.filter(|(c, r)| c.is_finite() && *r > 0.0 && r.is_finite()) {
            if layered && sphere_count < MAX_SHADOW_SPHERES {
                shadow_spheres[sphere_count] = vec4(point(centre), (radius * scale) as f32);
                sphere_count += 1;
            }
        }
        let mut shadow_slots = [[super::layers::NO_LAYER, 0, 0, 0]; MAX_LIGHTS];
        for (slot, light_slot) in shadow_slots.iter_mut().zip(&self.layers.light_slots) {
            *slot = *light_slot;
        }
        // Live meshes other than spheres cast shadows through their hierarchy.
        let mesh_casters = self.occluders.live[2] > 0;
        let (shadow_on, shadow_light, shadow_params) =
            match (self.shadow_light, self.settings.shadows, sphere) {
                (_, Some(settings), _) if layered && (sphere_count > 0 || mesh_casters) => {
                    (1, [0.0; 4], [0.0, settings.strength, if self.layers.shared { 1.0 } else { 0.0 }, 0.0])
                }
                (Some(k), Some(settings), Some(_)) => match self.lights[k].shadow_source() {
                    Some(ShadowSource::Point { position, radius }) => (
                        1,
                        vec4(point(position), 1.0),
                        [(radius * scale) as f32, settings.strength, 0.0, 0.0],
                    ),
                    Some(ShadowSource::Direction(d)) => {
                        (1, vec4(direction(d), 0.0), [0.0, settings.strength, 0.0, 0.0])
                    }
                    None => (0, [0.0; 4], [0.0; 4]),
                },
                _ => (0, [0.0; 4], [0.0; 4]),
            };
        FrameUniform {
            clip_from_camera: mat4_f32(self.projection.clip_from_camera()),
            clip_from_raster: mat4_f32(self.projection.clip_from_raster()),
            screen_window: [sw.left as f32, sw.right as f32, sw.bottom as f32, sw.top as f32],
            raster: [self.width as f32, self.height as f32, tan_half, perspective],
            tone: self.tone,
            counts: [
                self.lights.len().min(MAX_LIGHTS) as u32,
                shadow_on,
                u32::from(sphere.is_some()),
                u32::from(self.irradiance.origin[3] == 1.0),
            ],
            shadow_light,
            shadow_params,
            sphere: sphere_vec,
            sphere_material,
            layer_info: [self.layers.info[0], self.layers.info[1], self.layers.info[2], sphere_count as u32],
            shadow_spheres,
            world_from_camera: mat4_f32(DMat4::from_mat3(linear.inverse())),
            shadow_slots,
            world_from_camera_point: mat4_f32(camera_from_world.inverse()),
            reflection_origin: self.reflections.origin,
            reflection_spacing: self.reflections.spacing,
            reflection_counts: self.reflections.counts,
            irradiance_origin: self.irradiance.origin,
            irradiance_spacing: self.irradiance.spacing,
            irradiance_counts: self.irradiance.counts,
            lights,
            scene_occluders: self.occluders.scene,
            live_occluders: if layered { self.occluders.live } else { [0; 4] },
            live_occluder_bound: self.occluders.live_bound,
            bounce: match self.layers.albedo_slice {
                Some(slice) if self.settings.bounce_light && shadow_on == 1 && sphere_count > 0 => {
                    let diagonal = self.surface_bounds.map_or(0.0, |(lo, hi)| (hi - lo).length() as f32);
                    [1, slice, diagonal.to_bits(), u32::from(self.settings.occlusion_from_behind)]
                }
                _ => [0; 4],
            },
            shadow_bounce: [0; 4],
            reflection: if self.settings.bounce_light && shadow_on == 1 && sphere_count > 0 {
                let (reflectance, reflected) = self
                    .layers
                    .reflection
                    .map_or((super::layers::NO_LAYER, super::layers::NO_LAYER), |(slice, _)| {
                        (slice, slice + 1)
                    });
                let glossy = self.layers.glossy.map_or(super::layers::NO_LAYER, |(slice, _)| slice);
                let on = u32::from(self.layers.specular_rect().is_some());
                [on, reflectance, reflected, glossy]
            } else {
                [0; 4]
            },
            footprint: footprint(&self.pixel_filter),
            footprint_rays: footprint_rays(&self.pixel_filter),
        }
    }
}
