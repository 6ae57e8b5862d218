//! The reflection probes on the GPU: each probe's prefiltered radiance as one layer of a
//! half-float texture array with the probes' roughness levels as mip levels (sampled linearly
//! within and between levels, as `sidecar::ReflectionProbes::sample` does), and its distance
//! map as one layer of a two-channel float texture array (read texel by texel for the parallax
//! correction), the second channel 1 where the texel's first surface is specular (the sidecar's
//! `specular` marks; 0 everywhere for probes without them).

use crate::gpu::Gpu;
use sidecar::{REFLECTION_LEVELS, REFLECTION_TEXELS, ReflectionProbes, reflection_level_texels};

/// What the compositor keeps of the reflection probes.
#[derive(Debug)]
pub(super) struct GpuReflections {
    pub(super) radiance: wgpu::TextureView,
    pub(super) distance: wgpu::TextureView,
    pub(super) sampler: wgpu::Sampler,
    /// The grid for the shaders: origin (w 1 when bound), spacing, counts.
    pub(super) origin: [f32; 4],
    pub(super) spacing: [f32; 4],
    pub(super) counts: [u32; 4],
}

/// Uploads `probes` (checked by `ViewerScene::set_reflections`); without them, 1x1 placeholders
/// keep the bind group valid and the shaders skip the lookup.
pub(super) fn upload(gpu: &Gpu, probes: Option<&ReflectionProbes>) -> GpuReflections {
    let device = &gpu.device;
    let n = probes.map_or(1, |p| p.probe_count()) as u32;
    let (side, levels) =
        if probes.is_some() { (REFLECTION_TEXELS as u32, REFLECTION_LEVELS as u32) } else { (1, 1) };
    let texture = |label: &str, format: wgpu::TextureFormat, mip_level_count: u32| {
        device.create_texture(&wgpu::TextureDescriptor {
            label: Some(label),
            size: wgpu::Extent3d { width: side, height: side, depth_or_array_layers: n },
            mip_level_count,
            sample_count: 1,
            dimension: wgpu::TextureDimension::D2,
            format,
            usage: wgpu::TextureUsages::TEXTURE_BINDING | wgpu::TextureUsages::COPY_DST,
            view_formats: &[],
        })
    };
    let radiance = texture("reflection radiance", wgpu::TextureFormat::Rgba16Float, levels);
    let distance = texture("reflection distance", wgpu::TextureFormat::Rg32Float, 1);
    let write = |texture: &wgpu::Texture, level: u32, texels: u32, bytes: &[u8], bytes_per_texel: u32| {
        gpu.queue.write_texture(
            wgpu::TexelCopyTextureInfo {
                texture,
                mip_level: level,
                origin: wgpu::Origin3d::ZERO,
                aspect: wgpu::TextureAspect::All,
            },
            bytes,
            wgpu::TexelCopyBufferLayout {
                offset: 0,
                bytes_per_row: Some(texels * bytes_per_texel),
                rows_per_image: Some(texels),
            },
            wgpu::Extent3d { width: texels, height: texels, depth_or_array_layers: n },
        );
    };
    let half =
        |v: f32| half::f16::from_f32(if v.is_finite() { v.clamp(0.0, 65504.0) } else { 0.0 }).to_bits();
    match probes {
        Some(p) => {
            for (level, texels) in p.radiance.iter().enumerate() {
                let data: Vec<u16> =
                    texels.iter().flat_map(|c| [half(c[0]), half(c[1]), half(c[2]), 0]).collect();
                let side = reflection_level_texels(level) as u32;
                write(&radiance, level as u32, side, bytemuck::cast_slice(&data), 8);
            }
            let marked = |t: usize| p.specular.get(t).is_some_and(|&s| s);
            let texels: Vec<[f32; 2]> =
                p.distance.iter().enumerate().map(|(t, &d)| [d, if marked(t) { 1.0 } else { 0.0 }]).collect();
            write(&distance, 0, side, bytemuck::cast_slice(&texels), 8);
        }
        None => {
            write(&radiance, 0, 1, bytemuck::cast_slice(&[0u16; 4]), 8);
            write(&distance, 0, 1, bytemuck::cast_slice(&[0f32; 2]), 8);
        }
    }
    let array = |t: &wgpu::Texture| {
        t.create_view(&wgpu::TextureViewDescriptor {
            dimension: Some(wgpu::TextureViewDimension::D2Array),
            ..Default::default()
        })
    };
    let sampler = device.create_sampler(&wgpu::SamplerDescriptor {
        label: Some("reflection probes"),
        address_mode_u: wgpu::AddressMode::ClampToEdge,
        address_mode_v: wgpu::AddressMode::ClampToEdge,
        address_mode_w: wgpu::AddressMode::ClampToEdge,
        mag_filter: wgpu::FilterMode::Linear,
        min_filter: wgpu::FilterMode::Linear,
        mipmap_filter: wgpu::MipmapFilterMode::Linear,
        ..Default::default()
    });
    let (origin, spacing, counts) = match probes {
        Some(p) => (
            [p.origin[0], p.origin[1], p.origin[2], 1.0],
            [p.spacing[0], p.spacing[1], p.spacing[2], 0.0],
            [p.counts[0], p.counts[1], p.counts[2], 0],
        ),
        None => ([0.0; 4], [1.0, 1.0, 1.0, 0.0], [1, 1, 1, 0]),
    };
    GpuReflections {
        radiance: array(&radiance),
        distance: array(&distance),
        sampler,
        origin,
        spacing,
        counts,
    }
}
