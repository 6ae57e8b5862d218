//! An atlas of square maps over live spheres, a row per shadow-casting sphere: the texture a
//! pass draws the maps into and the copy the shading passes read, so that no pass reads the
//! texture it draws into. The own-shadow loss maps (`loss_map.rs`) and the radiosity maps
//! (`bounce.rs`) are both kept this way.

use super::lighting::MAX_SHADOW_SPHERES;

#[derive(Debug)]
pub(super) struct SphereMapAtlas {
    drawn: wgpu::Texture,
    read: wgpu::Texture,
    /// The view the maps are drawn through.
    pub(super) drawn_view: wgpu::TextureView,
    /// The view of the copy, for the frame bind group.
    pub(super) read_view: wgpu::TextureView,
    size: wgpu::Extent3d,
}

impl SphereMapAtlas {
    /// Maps of `texels`^2 in `format`, one row for each of `MAX_SHADOW_SPHERES`.
    pub(super) fn new(device: &wgpu::Device, label: &str, format: wgpu::TextureFormat, texels: u32) -> Self {
        let size = wgpu::Extent3d {
            width: texels,
            height: texels * MAX_SHADOW_SPHERES as u32,
            depth_or_array_layers: 1,
        };
        let texture = |label: &str, usage: wgpu::TextureUsages| {
            device.create_texture(&wgpu::TextureDescriptor {
                label: Some(label),
                size,
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
        let drawn_view = drawn.create_view(&wgpu::TextureViewDescriptor::default());
        let read_view = read.create_view(&wgpu::TextureViewDescriptor::default());
        SphereMapAtlas { drawn, read, drawn_view, read_view, size }
    }

    /// Records the copy of what was drawn into the texture the shading passes read.
    pub(super) fn copy_drawn_to_read(&self, encoder: &mut wgpu::CommandEncoder) {
        encoder.copy_texture_to_texture(self.drawn.as_image_copy(), self.read.as_image_copy(), self.size);
    }
}
