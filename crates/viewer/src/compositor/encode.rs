//! The display encode pass: the linear frame becomes the displayed 8-bit frame with the one
//! encoding of `crate::display` (transfer and dither), the same for pre-rendered and live
//! pixels. A pixel whose linear value is still the backdrop's, bit for bit, shows the
//! backdrop's own display bytes, so a frame with nothing live in view equals the input image.

use super::overlay::offscreen_pipeline;
use super::settings::FRAME_FORMAT;
use crate::display::DisplayEncoding;
use crate::gpu::Gpu;
use bytemuck::{Pod, Zeroable};

/// `encode.wgsl`'s uniform.
#[repr(C)]
#[derive(Clone, Copy, Debug, Pod, Zeroable)]
struct EncodeUniform {
    /// 1 / gamma, 1 if sRGB, dither amplitude, unused.
    parameters: [f32; 4],
    /// Image width, unused x3.
    size: [u32; 4],
}

#[derive(Debug)]
pub(super) struct EncodePass {
    pipeline: wgpu::RenderPipeline,
    bind_group: wgpu::BindGroup,
}

impl EncodePass {
    pub(super) fn new(
        gpu: &Gpu,
        encoding: &DisplayEncoding,
        width: u32,
        linear_frame: &wgpu::TextureView,
        backdrop_linear: &wgpu::TextureView,
        backdrop_display: &wgpu::TextureView,
    ) -> EncodePass {
        let device = &gpu.device;
        let uniform = EncodeUniform { parameters: encoding.shader_parameters(), size: [width, 0, 0, 0] };
        let buffer = device.create_buffer(&wgpu::BufferDescriptor {
            label: Some("encode uniform"),
            size: std::mem::size_of::<EncodeUniform>() as u64,
            usage: wgpu::BufferUsages::STORAGE | wgpu::BufferUsages::COPY_DST,
            mapped_at_creation: false,
        });
        gpu.queue.write_buffer(&buffer, 0, bytemuck::bytes_of(&uniform));
        let texture_entry = |binding: u32| wgpu::BindGroupLayoutEntry {
            binding,
            visibility: wgpu::ShaderStages::FRAGMENT,
            ty: wgpu::BindingType::Texture {
                sample_type: wgpu::TextureSampleType::Float { filterable: false },
                view_dimension: wgpu::TextureViewDimension::D2,
                multisampled: false,
            },
            count: None,
        };
        let layout = device.create_bind_group_layout(&wgpu::BindGroupLayoutDescriptor {
            label: Some("encode"),
            entries: &[
                wgpu::BindGroupLayoutEntry {
                    binding: 0,
                    visibility: wgpu::ShaderStages::FRAGMENT,
                    ty: wgpu::BindingType::Buffer {
                        ty: wgpu::BufferBindingType::Storage { read_only: true },
                        has_dynamic_offset: false,
                        min_binding_size: None,
                    },
                    count: None,
                },
                texture_entry(1),
                texture_entry(2),
                texture_entry(3),
            ],
        });
        let bind_group = device.create_bind_group(&wgpu::BindGroupDescriptor {
            label: Some("encode"),
            layout: &layout,
            entries: &[
                wgpu::BindGroupEntry { binding: 0, resource: buffer.as_entire_binding() },
                wgpu::BindGroupEntry {
                    binding: 1,
                    resource: wgpu::BindingResource::TextureView(linear_frame),
                },
                wgpu::BindGroupEntry {
                    binding: 2,
                    resource: wgpu::BindingResource::TextureView(backdrop_linear),
                },
                wgpu::BindGroupEntry {
                    binding: 3,
                    resource: wgpu::BindingResource::TextureView(backdrop_display),
                },
            ],
        });
        let module = device.create_shader_module(wgpu::ShaderModuleDescriptor {
            label: Some("encode.wgsl"),
            source: wgpu::ShaderSource::Wgsl(include_str!("../shaders/encode.wgsl").into()),
        });
        let pipeline_layout = device.create_pipeline_layout(&wgpu::PipelineLayoutDescriptor {
            label: Some("encode"),
            bind_group_layouts: &[Some(&layout)],
            immediate_size: 0,
        });
        let pipeline =
            offscreen_pipeline(device, &module, &pipeline_layout, ("encode", "fs_encode"), FRAME_FORMAT);
        EncodePass { pipeline, bind_group }
    }

    /// Records the pass: the whole linear frame into `target`.
    pub(super) fn record(&self, encoder: &mut wgpu::CommandEncoder, target: &wgpu::TextureView) {
        let mut pass =
            super::colour_pass(encoder, "display encode", target, wgpu::LoadOp::Clear(wgpu::Color::BLACK));
        pass.set_pipeline(&self.pipeline);
        pass.set_bind_group(0, &self.bind_group, &[]);
        pass.draw(0..3, 0..1);
    }
}
