//! The light layers on the GPU: one half-float texture array (the light layers of the kept
//! lights, then `indirect`, then the camera-space shading normal, then the diffuse albedo when
//! the layers hold one, then the specular reflection's reflectance and reflected radiance when
//! some pixel has one, then the glossy lobe's weight and exponent when some pixel has one) and a
//! uniform block of
//! area-light samples in camera space, with each kept light's slice and samples.

use super::lighting::vec4;
use crate::gpu::Gpu;
use crate::light_layers::{AREA_SAMPLES_PER_LIGHT, MAX_AREA_SAMPLES, SceneLayers};
use crate::projection::Projection;
use bytemuck::{Pod, Zeroable};
use glam::DMat3;

/// No layer (the light's `shadow` slot).
pub(super) const NO_LAYER: u32 = u32::MAX;

/// The shaders' area-sample block: per sample, camera-space position and represented area,
/// then unit normal and whether the emitter is two-sided.
#[repr(C)]
#[derive(Clone, Copy, Debug, Pod, Zeroable)]
pub(super) struct SampleUniform {
    pub(super) samples: [[f32; 4]; 2 * MAX_AREA_SAMPLES],
}

/// What the compositor keeps of the layers.
#[derive(Debug)]
pub(super) struct GpuLayers {
    pub(super) view: wgpu::TextureView,
    pub(super) samples: wgpu::Buffer,
    /// Per kept light: `[slice, first sample, sample count, bounding radius of its samples about
    /// its centroid as f32 bits]`.
    pub(super) light_slots: Vec<[u32; 4]>,
    /// `[1 if layers are bound, indirect slice, normal slice, 0]`.
    pub(super) info: [u32; 4],
    /// The diffuse albedo's slice (the slice after the normal's), `None` when the layers hold
    /// no albedo anywhere (older files, or no diffuse surface): the bounce light then has nothing
    /// to reflect it with.
    pub(super) albedo_slice: Option<u32>,
    /// The specular reflection's slices (`reflectance`, then `reflected` in the next slice) and
    /// the pixels that have one (`[x, y, width, height]`); `None` when no pixel has one.
    pub(super) reflection: Option<(u32, [u32; 4])>,
    /// The glossy lobe's slices (`glossy`, then `glossy_exponent` in the next slice) and the
    /// pixels that have one; `None` when no pixel has one.
    pub(super) glossy: Option<(u32, [u32; 4])>,
    /// Whether two kept lights share a layer (the shaders then weigh them).
    pub(super) shared: bool,
    /// Per kept light, the world-space emitter samples the shaders integrate it over (each
    /// standing for its share of the area; empty where the shaders use a representative point).
    pub(super) world_samples: Vec<Vec<crate::light_layers::AreaSample>>,
}

/// Uploads the layers for the kept lights (`kept[i]` = index of kept light `i` in the scene's
/// lights; `two_sided[k]` whether scene light `k` emits from both sides). Without layers, a 1x1 placeholder keeps the bind
/// group valid.
pub(super) fn upload(
    gpu: &Gpu,
    projection: &Projection,
    layers: Option<&SceneLayers>,
    kept: &[usize],
    lights: &[crate::live::LiveLight],
    two_sided: &[bool],
    (width, height): (u32, u32),
) -> GpuLayers {
    let device = &gpu.device;
    let camera_from_world = projection.camera().camera_from_world();
    let linear = DMat3::from_mat4(camera_from_world);
    let normal_from_world = linear.inverse().transpose();
    let scale = linear.determinant().abs().cbrt();
    let mut light_slots = vec![[NO_LAYER, 0, 0, 0]; kept.len()];
    let mut samples = SampleUniform { samples: [[0.0; 4]; 2 * MAX_AREA_SAMPLES] };
    let mut slices: Vec<Vec<[f32; 3]>> = Vec::new();
    let mut info = [0u32; 4];
    let mut world_samples = vec![Vec::new(); kept.len()];
    let mut albedo_slice = None;
    let mut reflection = None;
    let mut glossy = None;
    if let Some(bound) = layers {
        let mut slice_of_layer = vec![None; bound.layers.light.len()];
        let area_lights = kept.iter().filter(|&&k| !bound.area_samples[k].is_empty()).count().max(1);
        let per_light = (MAX_AREA_SAMPLES / area_lights).min(AREA_SAMPLES_PER_LIGHT);
        let mut next_sample = 0usize;
        for (slot_index, (slot, &k)) in light_slots.iter_mut().zip(kept).enumerate() {
            let Some(layer) = bound.layer_of_light[k] else { continue };
            let slice = *slice_of_layer[layer].get_or_insert_with(|| {
                slices.push(bound.layers.light[layer].clone());
                slices.len() - 1
            });
            let light_samples = &bound.area_samples[k];
            // Every `step`-th sample, each standing for `step` times its area.
            let step = light_samples.len().div_ceil(per_light.max(1)).max(1);
            let first = next_sample;
            for s in light_samples.iter().step_by(step) {
                world_samples[slot_index]
                    .push(crate::light_layers::AreaSample { area: s.area * step as f64, ..*s });
                let p = camera_from_world.transform_point3(s.position);
                let n = (normal_from_world * s.normal).normalize_or_zero();
                let area = (s.area * step as f64 * scale * scale) as f32;
                samples.samples[2 * next_sample] = vec4(p, area);
                samples.samples[2 * next_sample + 1] = vec4(n, if two_sided[k] { 1.0 } else { 0.0 });
                next_sample += 1;
            }
            // The samples' bounding radius about the light's centroid (the shaders' cone test).
            let centroid = match &lights[slot_index] {
                crate::live::LiveLight::Area { centroid, .. } => Some(*centroid),
                _ => None,
            };
            let bound = centroid.map_or(0.0, |c| {
                light_samples.iter().map(|s| (s.position - c).length()).fold(0.0, f64::max) * scale * 1.001
            });
            *slot = [slice as u32, first as u32, (next_sample - first) as u32, (bound as f32).to_bits()];
        }
        info = [1, slices.len() as u32, slices.len() as u32 + 1, 0];
        slices.push(bound.layers.indirect.clone());
        slices.push(
            bound
                .layers
                .normal
                .iter()
                .map(|n| {
                    let c = (normal_from_world
                        * glam::DVec3::new(f64::from(n[0]), f64::from(n[1]), f64::from(n[2])))
                    .normalize_or_zero();
                    [c.x as f32, c.y as f32, c.z as f32]
                })
                .collect(),
        );
        if bound.layers.albedo.iter().any(|a| a.iter().any(|&v| v > 0.0)) {
            albedo_slice = Some(slices.len() as u32);
            slices.push(bound.layers.albedo.clone());
        }
        if let Some(rect) = reflecting_pixels(&bound.layers.reflectance, width as usize) {
            reflection = Some((slices.len() as u32, rect));
            slices.push(bound.layers.reflectance.clone());
            slices.push(bound.layers.reflected.clone());
        }
        if let Some(rect) = reflecting_pixels(&bound.layers.glossy, width as usize) {
            glossy = Some((slices.len() as u32, rect));
            slices.push(bound.layers.glossy.clone());
            slices.push(bound.layers.glossy_exponent.clone());
        }
    }
    let (w, h) = if layers.is_some() { (width, height) } else { (1, 1) };
    let count = slices.len().max(2) as u32;
    let texture = super::bindings::input_texture(
        device,
        "light layers",
        wgpu::Extent3d { width: w, height: h, depth_or_array_layers: count },
        wgpu::TextureFormat::Rgba16Float,
    );
    for (z, slice) in slices.iter().enumerate() {
        let texels: Vec<u16> = slice
            .iter()
            .flat_map(|c| {
                let half = |v: f32| half::f16::from_f32(v.clamp(-65504.0, 65504.0)).to_bits();
                [half(c[0]), half(c[1]), half(c[2]), 0]
            })
            .collect();
        gpu.queue.write_texture(
            wgpu::TexelCopyTextureInfo {
                texture: &texture,
                mip_level: 0,
                origin: wgpu::Origin3d { x: 0, y: 0, z: z as u32 },
                aspect: wgpu::TextureAspect::All,
            },
            bytemuck::cast_slice(&texels),
            wgpu::TexelCopyBufferLayout { offset: 0, bytes_per_row: Some(w * 8), rows_per_image: Some(h) },
            wgpu::Extent3d { width: w, height: h, depth_or_array_layers: 1 },
        );
    }
    let view = texture.create_view(&wgpu::TextureViewDescriptor {
        dimension: Some(wgpu::TextureViewDimension::D2Array),
        ..Default::default()
    });
    let buffer = device.create_buffer(&wgpu::BufferDescriptor {
        label: Some("area light samples"),
        size: std::mem::size_of::<SampleUniform>() as u64,
        usage: wgpu::BufferUsages::STORAGE | wgpu::BufferUsages::COPY_DST,
        mapped_at_creation: false,
    });
    gpu.queue.write_buffer(&buffer, 0, bytemuck::bytes_of(&samples));
    let shared = {
        let mut slices: Vec<u32> = light_slots.iter().map(|s| s[0]).filter(|&s| s != NO_LAYER).collect();
        let n = slices.len();
        slices.sort_unstable();
        slices.dedup();
        slices.len() != n
    };
    GpuLayers {
        view,
        samples: buffer,
        light_slots,
        info,
        albedo_slice,
        reflection,
        glossy,
        shared,
        world_samples,
    }
}

/// The bounding rectangle `[x, y, width, height]` of the pixels whose `reflectance` (or
/// `glossy`; rows of `width`) is not zero, `None` when there are none.
fn reflecting_pixels(reflectance: &[[f32; 3]], width: usize) -> Option<[u32; 4]> {
    let mut bounds: Option<[usize; 4]> = None;
    for (i, r) in reflectance.iter().enumerate() {
        if r.iter().all(|&v| v <= 0.0) {
            continue;
        }
        let (x, y) = (i % width.max(1), i / width.max(1));
        let b = bounds.get_or_insert([x, y, x, y]);
        *b = [b[0].min(x), b[1].min(y), b[2].max(x), b[3].max(y)];
    }
    bounds.map(|[x0, y0, x1, y1]| [x0 as u32, y0 as u32, (x1 - x0 + 1) as u32, (y1 - y0 + 1) as u32])
}

impl GpuLayers {
    /// The pixels the specular pass draws over (`[x, y, width, height]`): those with a specular
    /// reflection or a glossy lobe, `None` when there are none.
    pub(super) fn specular_rect(&self) -> Option<[u32; 4]> {
        let rects = [self.reflection, self.glossy];
        rects.iter().flatten().map(|&(_, r)| r).reduce(|a, b| {
            let (x0, y0) = (a[0].min(b[0]), a[1].min(b[1]));
            let (x1, y1) = ((a[0] + a[2]).max(b[0] + b[2]), (a[1] + a[3]).max(b[1] + b[3]));
            [x0, y0, x1 - x0, y1 - y0]
        })
    }
}
