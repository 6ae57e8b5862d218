//! The pre-rendered image as the paper draws it: one point per pixel at its window depth.

use super::Compositor;
use crate::error::ViewerError;
use bytemuck::{Pod, Zeroable};

#[repr(C)]
#[derive(Clone, Copy, Debug, Pod, Zeroable)]
pub(super) struct PointVertex {
    pub(super) raster_depth: [f32; 3],
    /// Linear RGBA in the image's units.
    pub(super) colour: [f32; 4],
}

impl Compositor {
    pub(super) fn ensure_points(&mut self) -> Result<(), ViewerError> {
        if self.points.is_some() {
            return Ok(());
        }
        let bytes =
            u64::from(self.width) * u64::from(self.height) * std::mem::size_of::<PointVertex>() as u64;
        if bytes > self.gpu.device.limits().max_buffer_size {
            return Err(ViewerError::Unsupported(format!(
                "a point cloud of {}x{} needs {bytes} bytes, more than the adapter's buffer limit",
                self.width, self.height
            )));
        }
        let w = self.width;
        let vertices: Vec<PointVertex> = self
            .window_depths
            .iter()
            .zip(self.linear_image.chunks_exact(4))
            .enumerate()
            .map(|(k, (&depth, rgba))| {
                let (i, j) = (k as u32 % w, k as u32 / w);
                PointVertex {
                    raster_depth: [i as f32 + 0.5, j as f32 + 0.5, depth],
                    colour: [rgba[0], rgba[1], rgba[2], rgba[3]],
                }
            })
            .collect();
        let buffer = self.gpu.device.create_buffer(&wgpu::BufferDescriptor {
            label: Some("backdrop points"),
            size: bytes,
            usage: wgpu::BufferUsages::VERTEX | wgpu::BufferUsages::COPY_DST,
            mapped_at_creation: false,
        });
        self.gpu.queue.write_buffer(&buffer, 0, bytemuck::cast_slice(&vertices));
        self.points = Some(buffer);
        Ok(())
    }
}
