//! Live meshes on the GPU: vertex and index buffers uploaded once per mesh, and one uniform
//! slot per drawn instance.

use super::lighting::MeshUniform;
use super::{Compositor, align_up};
use crate::error::ViewerError;
use crate::live::Mesh;
use bytemuck::{Pod, Zeroable};
use std::sync::Arc;

#[repr(C)]
#[derive(Clone, Copy, Debug, Pod, Zeroable)]
pub(super) struct MeshVertex {
    pub(super) position: [f32; 3],
    pub(super) normal: [f32; 3],
}

#[derive(Debug)]
pub(super) struct GpuMesh {
    pub(super) source: Arc<Mesh>,
    pub(super) vertices: wgpu::Buffer,
    pub(super) indices: wgpu::Buffer,
    pub(super) index_count: u32,
    /// Object-space bounds of the vertices (`None` for a mesh without vertices).
    pub(super) bounds: Option<(glam::DVec3, glam::DVec3)>,
}

impl Compositor {
    pub(super) fn make_mesh_uniform(device: &wgpu::Device, size: u64) -> wgpu::Buffer {
        device.create_buffer(&wgpu::BufferDescriptor {
            label: Some("mesh uniforms"),
            size,
            usage: wgpu::BufferUsages::STORAGE | wgpu::BufferUsages::COPY_DST,
            mapped_at_creation: false,
        })
    }

    pub(super) fn make_mesh_bind_group(
        device: &wgpu::Device,
        layout: &wgpu::BindGroupLayout,
        buffer: &wgpu::Buffer,
    ) -> wgpu::BindGroup {
        device.create_bind_group(&wgpu::BindGroupDescriptor {
            label: Some("mesh"),
            layout,
            entries: &[wgpu::BindGroupEntry {
                binding: 0,
                resource: wgpu::BindingResource::Buffer(wgpu::BufferBinding {
                    buffer,
                    offset: 0,
                    size: wgpu::BufferSize::new(std::mem::size_of::<MeshUniform>() as u64),
                }),
            }],
        })
    }

    pub(super) fn mesh_index(&mut self, mesh: &Arc<Mesh>) -> Result<usize, ViewerError> {
        if let Some(k) = self.meshes.iter().position(|m| Arc::ptr_eq(&m.source, mesh)) {
            return Ok(k);
        }
        mesh.validate().map_err(|e| ViewerError::Invalid(format!("live mesh: {e}")))?;
        let vertices: Vec<MeshVertex> = mesh
            .positions
            .iter()
            .zip(&mesh.normals)
            .map(|(p, n)| MeshVertex { position: p.to_array(), normal: n.to_array() })
            .collect();
        let device = &self.gpu.device;
        let make = |label: &str, bytes: &[u8], usage: wgpu::BufferUsages| {
            let buffer = device.create_buffer(&wgpu::BufferDescriptor {
                label: Some(label),
                size: align_up(bytes.len().max(4) as u64, 4),
                usage: usage | wgpu::BufferUsages::COPY_DST,
                mapped_at_creation: false,
            });
            self.gpu.queue.write_buffer(&buffer, 0, bytes);
            buffer
        };
        let gpu_mesh = GpuMesh {
            source: mesh.clone(),
            vertices: make("mesh vertices", bytemuck::cast_slice(&vertices), wgpu::BufferUsages::VERTEX),
            indices: make("mesh indices", bytemuck::cast_slice(&mesh.indices), wgpu::BufferUsages::INDEX),
            index_count: mesh.indices.len() as u32,
            bounds: mesh.positions.iter().fold(None, |b, p| {
                let p = p.as_dvec3();
                Some(b.map_or((p, p), |(lo, hi): (glam::DVec3, glam::DVec3)| (lo.min(p), hi.max(p))))
            }),
        };
        self.meshes.push(gpu_mesh);
        Ok(self.meshes.len() - 1)
    }
}
