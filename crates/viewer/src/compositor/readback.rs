//! Reading a frame back from the GPU: colour, live-object mask and depth (the depth through a
//! compute pass, since GL cannot copy depth textures to buffers).

use super::{Compositor, align_up};
use crate::backdrop::Rgba8Image;
use crate::error::ViewerError;

/// A frame read back from the GPU.
#[derive(Clone, Debug, PartialEq)]
pub struct FrameReadback {
    pub colour: Rgba8Image,
    /// One byte per pixel: 255 where a live object is visible, 0 elsewhere.
    pub mask: Vec<u8>,
    /// The depth buffer's values, row-major, top row first.
    pub depth: Vec<f32>,
}

impl FrameReadback {
    /// The mask as a grey PNG (white exactly where a live object is visible), written atomically.
    pub fn write_mask_png(&self, path: &std::path::Path) -> Result<(), ViewerError> {
        crate::backdrop::write_png_atomically(
            path,
            self.colour.width,
            self.colour.height,
            image::ExtendedColorType::L8,
            &self.mask,
        )
    }
}

/// Whether a screenshot path asks for the linear OpenEXR frame (by its `.exr` extension,
/// CONTRACTS §6) rather than the displayed PNG.
pub fn is_exr_path(path: &std::path::Path) -> bool {
    path.extension().and_then(|e| e.to_str()).is_some_and(|e| e.eq_ignore_ascii_case("exr"))
}

/// The composited frame in linear values (the image's own units), before display encoding.
#[derive(Clone, Debug, PartialEq)]
pub struct LinearFrame {
    pub width: u32,
    pub height: u32,
    /// RGBA, 4 floats per pixel, rows top to bottom.
    pub rgba: Vec<f32>,
}

impl LinearFrame {
    /// Writes the RGB channels as a 32-bit float OpenEXR file (ZIP-compressed), atomically:
    /// CONTRACTS §6's `--screenshot OUT.exr`.
    pub fn write_exr(&self, path: &std::path::Path) -> Result<(), ViewerError> {
        use exr::prelude::*;
        let w = self.width as usize;
        let rgba = &self.rgba;
        let pixel = |x: usize, y: usize| {
            let k = (y * w + x) * 4;
            (rgba[k], rgba[k + 1], rgba[k + 2])
        };
        let channels = SpecificChannels::rgb(|p: Vec2<usize>| pixel(p.x(), p.y()));
        let layer = Layer::new(
            (w, self.height as usize),
            LayerAttributes::default(),
            Encoding { compression: Compression::ZIP16, ..Encoding::FAST_LOSSLESS },
            channels,
        );
        crate::backdrop::write_atomically(path, |tmp| {
            Image::from_layer(layer).write().to_file(tmp).map_err(|e| match e {
                exr::error::Error::Io(e) => ViewerError::Io { path: path.to_path_buf(), source: e },
                other => ViewerError::BadInput {
                    path: path.to_path_buf(),
                    message: format!("cannot encode OpenEXR: {other}"),
                },
            })
        })
    }
}

impl Compositor {
    /// Reads the last rendered frame's linear values back.
    pub fn read_back_linear(&self) -> Result<LinearFrame, ViewerError> {
        let device = &self.gpu.device;
        let (w, h) = (self.width, self.height);
        let half = self.linear_format != super::LINEAR_FORMAT;
        let texel_bytes: u64 = if half { 8 } else { 16 };
        let padded_row = align_up(u64::from(w) * texel_bytes, 256);
        let buffer = device.create_buffer(&wgpu::BufferDescriptor {
            label: Some("linear readback"),
            size: padded_row * u64::from(h),
            usage: wgpu::BufferUsages::MAP_READ | wgpu::BufferUsages::COPY_DST,
            mapped_at_creation: false,
        });
        let mut encoder =
            device.create_command_encoder(&wgpu::CommandEncoderDescriptor { label: Some("linear readback") });
        encoder.copy_texture_to_buffer(
            wgpu::TexelCopyTextureInfo {
                texture: &self.linear_texture,
                mip_level: 0,
                origin: wgpu::Origin3d::ZERO,
                aspect: wgpu::TextureAspect::All,
            },
            wgpu::TexelCopyBufferInfo {
                buffer: &buffer,
                layout: wgpu::TexelCopyBufferLayout {
                    offset: 0,
                    bytes_per_row: Some(padded_row as u32),
                    rows_per_image: Some(h),
                },
            },
            wgpu::Extent3d { width: w, height: h, depth_or_array_layers: 1 },
        );
        self.gpu.queue.submit([encoder.finish()]);
        let (tx, rx) = std::sync::mpsc::channel();
        buffer.map_async(wgpu::MapMode::Read, .., move |r| {
            let _ = tx.send(r);
        });
        self.wait_idle()?;
        rx.recv()
            .map_err(|e| ViewerError::Gpu(e.to_string()))?
            .map_err(|e| ViewerError::Gpu(format!("mapping the linear readback buffer: {e}")))?;
        self.gpu.take_errors()?;
        let view = buffer.get_mapped_range(..).map_err(|e| ViewerError::Gpu(e.to_string()))?;
        let row_bytes = w as usize * texel_bytes as usize;
        let mut rgba = Vec::with_capacity(w as usize * h as usize * 4);
        for r in 0..h as usize {
            let row = &view[r * padded_row as usize..][..row_bytes];
            if half {
                rgba.extend(row.chunks_exact(2).map(|b| half::f16::from_le_bytes([b[0], b[1]]).to_f32()));
            } else {
                rgba.extend(row.chunks_exact(4).map(|b| f32::from_le_bytes([b[0], b[1], b[2], b[3]])));
            }
        }
        Ok(LinearFrame { width: w, height: h, rgba })
    }

    /// Waits until the GPU has finished everything submitted so far.
    pub fn wait_idle(&self) -> Result<(), ViewerError> {
        self.gpu
            .device
            .poll(wgpu::PollType::wait_indefinitely())
            .map_err(|e| ViewerError::Gpu(e.to_string()))?;
        Ok(())
    }

    /// Reads the last rendered frame back: colour, mask and depth.
    pub fn read_back(&self) -> Result<FrameReadback, ViewerError> {
        let device = &self.gpu.device;
        let (w, h) = (self.width, self.height);
        let row = |bytes_per_pixel: u32| align_up(u64::from(w * bytes_per_pixel), 256);
        let colour_row = row(4);
        let mask_row = row(1);
        let map_buffer = |label: &str, size: u64| {
            device.create_buffer(&wgpu::BufferDescriptor {
                label: Some(label),
                size,
                usage: wgpu::BufferUsages::MAP_READ | wgpu::BufferUsages::COPY_DST,
                mapped_at_creation: false,
            })
        };
        let colour_buffer = map_buffer("colour readback", colour_row * u64::from(h));
        let mask_buffer = map_buffer("mask readback", mask_row * u64::from(h));
        let depth_buffer = map_buffer("depth readback", u64::from(w) * u64::from(h) * 4);
        let mut encoder =
            device.create_command_encoder(&wgpu::CommandEncoderDescriptor { label: Some("readback") });
        let size = wgpu::Extent3d { width: w, height: h, depth_or_array_layers: 1 };
        for (texture, buffer, bytes_per_row) in
            [(&self.frame_texture, &colour_buffer, colour_row), (&self.mask_texture, &mask_buffer, mask_row)]
        {
            encoder.copy_texture_to_buffer(
                wgpu::TexelCopyTextureInfo {
                    texture,
                    mip_level: 0,
                    origin: wgpu::Origin3d::ZERO,
                    aspect: wgpu::TextureAspect::All,
                },
                wgpu::TexelCopyBufferInfo {
                    buffer,
                    layout: wgpu::TexelCopyBufferLayout {
                        offset: 0,
                        bytes_per_row: Some(bytes_per_row as u32),
                        rows_per_image: Some(h),
                    },
                },
                size,
            );
        }
        {
            let mut pass = encoder.begin_compute_pass(&wgpu::ComputePassDescriptor {
                label: Some("depth readback"),
                timestamp_writes: None,
            });
            pass.set_pipeline(&self.readback_pipeline);
            pass.set_bind_group(0, &self.readback_bind_group, &[]);
            pass.dispatch_workgroups(w.div_ceil(8), h.div_ceil(8), 1);
        }
        encoder.copy_buffer_to_buffer(
            &self.depth_storage,
            0,
            &depth_buffer,
            0,
            u64::from(w) * u64::from(h) * 4,
        );
        self.gpu.queue.submit([encoder.finish()]);

        let (tx, rx) = std::sync::mpsc::channel();
        for (k, buffer) in [&colour_buffer, &mask_buffer, &depth_buffer].into_iter().enumerate() {
            let tx = tx.clone();
            buffer.map_async(wgpu::MapMode::Read, .., move |r| {
                let _ = tx.send((k, r));
            });
        }
        drop(tx);
        self.wait_idle()?;
        for (k, result) in rx.iter() {
            result.map_err(|e| ViewerError::Gpu(format!("mapping readback buffer {k}: {e}")))?;
        }
        self.gpu.take_errors()?;
        let unpad =
            |buffer: &wgpu::Buffer, padded_row: u64, row_bytes: usize| -> Result<Vec<u8>, ViewerError> {
                let view = buffer.get_mapped_range(..).map_err(|e| ViewerError::Gpu(e.to_string()))?;
                let mut out = Vec::with_capacity(row_bytes * h as usize);
                for r in 0..h as usize {
                    let start = r * padded_row as usize;
                    out.extend_from_slice(&view[start..start + row_bytes]);
                }
                Ok(out)
            };
        let colour = unpad(&colour_buffer, colour_row, w as usize * 4)?;
        let mask = unpad(&mask_buffer, mask_row, w as usize)?;
        let depth_bytes = unpad(&depth_buffer, u64::from(w) * 4, w as usize * 4)?;
        let depth =
            depth_bytes.chunks_exact(4).map(|b| f32::from_le_bytes([b[0], b[1], b[2], b[3]])).collect();
        Ok(FrameReadback { colour: Rgba8Image { width: w, height: h, pixels: colour }, mask, depth })
    }
}

/// The depth readback's compute pass (`readback.wgsl`): it copies the depth texture into a
/// storage buffer, which is then copied to a mappable one.
pub(super) struct DepthReadback {
    pub(super) pipeline: wgpu::ComputePipeline,
    pub(super) bind_group: wgpu::BindGroup,
    pub(super) storage: wgpu::Buffer,
}

impl DepthReadback {
    /// The pass over `depth_view`, an image of `width x height`; a storage buffer that large
    /// beyond the adapter's limit is refused.
    pub(super) fn new(
        device: &wgpu::Device,
        depth_view: &wgpu::TextureView,
        (width, height): (u32, u32),
    ) -> Result<DepthReadback, ViewerError> {
        let readback_module = device.create_shader_module(wgpu::ShaderModuleDescriptor {
            label: Some("readback.wgsl"),
            source: wgpu::ShaderSource::Wgsl(include_str!("../shaders/readback.wgsl").into()),
        });
        let depth_bytes = u64::from(width) * u64::from(height) * 4;
        let limits = device.limits();
        if depth_bytes > limits.max_storage_buffer_binding_size {
            return Err(ViewerError::Unsupported(format!(
                "depth readback of {width}x{height} exceeds the storage buffer limit {}",
                limits.max_storage_buffer_binding_size
            )));
        }
        let storage = device.create_buffer(&wgpu::BufferDescriptor {
            label: Some("depth readback storage"),
            size: depth_bytes,
            usage: wgpu::BufferUsages::STORAGE | wgpu::BufferUsages::COPY_SRC,
            mapped_at_creation: false,
        });
        let readback_layout = device.create_bind_group_layout(&wgpu::BindGroupLayoutDescriptor {
            label: Some("depth readback"),
            entries: &[
                super::bindings::texture_layout_entry(
                    0,
                    wgpu::ShaderStages::COMPUTE,
                    wgpu::TextureViewDimension::D2,
                    false,
                ),
                wgpu::BindGroupLayoutEntry {
                    binding: 1,
                    visibility: wgpu::ShaderStages::COMPUTE,
                    ty: wgpu::BindingType::Buffer {
                        ty: wgpu::BufferBindingType::Storage { read_only: false },
                        has_dynamic_offset: false,
                        min_binding_size: None,
                    },
                    count: None,
                },
            ],
        });
        let bind_group = device.create_bind_group(&wgpu::BindGroupDescriptor {
            label: Some("depth readback"),
            layout: &readback_layout,
            entries: &[
                wgpu::BindGroupEntry { binding: 0, resource: wgpu::BindingResource::TextureView(depth_view) },
                wgpu::BindGroupEntry { binding: 1, resource: storage.as_entire_binding() },
            ],
        });
        let pipeline = device.create_compute_pipeline(&wgpu::ComputePipelineDescriptor {
            label: Some("depth readback"),
            layout: Some(&device.create_pipeline_layout(&wgpu::PipelineLayoutDescriptor {
                label: Some("depth readback"),
                bind_group_layouts: &[Some(&readback_layout)],
                immediate_size: 0,
            })),
            module: &readback_module,
            entry_point: Some("cs_copy_depth"),
            compilation_options: Default::default(),
            cache: None,
        });
        Ok(DepthReadback { pipeline, bind_group, storage })
    }
}
