//! A texture a pass draws into and the copy the shading passes read, so that no pass reads the
//! texture it draws into; and the atlas of square maps over live spheres kept that way, a row
//! per shadow-casting sphere, with the colour pass they are drawn in. The own-shadow loss maps
//! (`loss_map.rs`), the radiosity maps (`bounce.rs`), the near-field maps (`near_field_map.rs`)
//! and the shadows' second bounce (`shadow_bounce.rs`) use them.

use super::lighting::MAX_SHADOW_SPHERES;

#[derive(Debug)]
pub(super) struct DrawnAndRead {
    pub(super) drawn: wgpu::Texture,
    pub(super) read: wgpu::Texture,
    /// The view the pass draws through.
    pub(super) drawn_view: wgpu::TextureView,
    /// The view of the copy, for the frame bind group.
    pub(super) read_view: wgpu::TextureView,
}

impl DrawnAndRead {
    /// A pair of `width` x `height` textures in `format`.
    pub(super) fn new(
        device: &wgpu::Device,
        label: &str,
        format: wgpu::TextureFormat,
        (width, height): (u32, u32),
    ) -> Self {
        let texture = |label: &str, usage: wgpu::TextureUsages| {
            device.create_texture(&wgpu::TextureDescriptor {
                label: Some(label),
                size: wgpu::Extent3d { width, height, depth_or_array_layers: 1 },
                mip_level_count: 1,
                sample_count: 1,
                dimension: wgpu::TextureDimension::D2,
                format,
                usage,
                view_formats: &[],
            })
        };
        use wgpu::TextureUsages as U;
        let drawn = texture(&format!("{label}, drawn"), U::RENDER_ATTACHMENT | U::COPY_SRC);
        let read = texture(label, U::TEXTURE_BINDING | U::COPY_DST);
        let view = |t: &wgpu::Texture| t.create_view(&wgpu::TextureViewDescriptor::default());
        DrawnAndRead { drawn_view: view(&drawn), read_view: view(&read), drawn, read }
    }

    /// Records the copy of what was drawn into the texture the shading passes read.
    pub(super) fn copy_drawn_to_read(&self, encoder: &mut wgpu::CommandEncoder) {
        encoder.copy_texture_to_texture(
            self.drawn.as_image_copy(),
            self.read.as_image_copy(),
            self.drawn.size(),
        );
    }
}

/// An atlas of square maps over live spheres, a row per shadow-casting sphere.
pub(super) type SphereMapAtlas = DrawnAndRead;

/// Maps of `texels`^2 in `format`, one row for each of `MAX_SHADOW_SPHERES`.
pub(super) fn sphere_map_atlas(
    device: &wgpu::Device,
    label: &str,
    format: wgpu::TextureFormat,
    texels: u32,
) -> SphereMapAtlas {
    DrawnAndRead::new(device, label, format, (texels, texels * MAX_SHADOW_SPHERES as u32))
}

/// A render pass into one colour target, without depth, that starts from what the target holds
/// (`load`) and stores what it draws: the shape of the full-screen and per-sphere map passes.
pub(super) fn colour_pass<'e>(
    encoder: &'e mut wgpu::CommandEncoder,
    label: &str,
    view: &wgpu::TextureView,
    load: wgpu::LoadOp<wgpu::Color>,
) -> wgpu::RenderPass<'e> {
    encoder.begin_render_pass(&wgpu::RenderPassDescriptor {
        label: Some(label),
        color_attachments: &[Some(wgpu::RenderPassColorAttachment {
            view,
            depth_slice: None,
            resolve_target: None,
            ops: wgpu::Operations { load, store: wgpu::StoreOp::Store },
        })],
        depth_stencil_attachment: None,
        timestamp_writes: None,
        occlusion_query_set: None,
        multiview_mask: None,
    })
}
