//! The live spheres seen through the pre-rendered scene's glass (`shaders/transmission.wgsl`):
//! the render's transmission layers (docs/sidecar.md) give each glass pixel the exit ray of its
//! transmitted chain; one full-screen draw per sphere, scissored to the pixels that transmit,
//! replaces the light that ray brought by the sphere where it meets the sphere before the
//! surface the render saw.

use super::Compositor;
use super::bindings::texture_layout_entry;
use super::lighting::{FrameUniform, MAX_SHADOW_SPHERES};
use super::overlay::Overlay;
use crate::gpu::Gpu;
use crate::light_layers::SceneLayers;
use crate::projection::Projection;
use glam::{DMat3, DVec3};
use sidecar::LightLayers;

/// The binding (group 2) of the exit rays' texture array.
const TRANSMISSION_BINDING: u32 = 26;

/// The pass's pipeline, its texture's bind group and the pixels it draws over.
#[derive(Debug)]
pub(super) struct Transmission {
    pipeline: wgpu::RenderPipeline,
    bind_group: wgpu::BindGroup,
    /// The pixels whose primary hit transmits, `[x, y, width, height]`.
    rect: [u32; 4],
}

/// The shader's four slices, one `[f32; 4]` per pixel each.
type ExitRaySlices = [Vec<[f32; 4]>; 4];

/// The transmission layers as the shader reads them, one `[f32; 4]` per pixel and slice: the
/// chain's weight, the radiance it brought, the exit ray's camera-space origin and distance to
/// the surface it met, its camera-space unit direction and the length of the samples' mean
/// direction (below 1 where their chains diverge); and the pixels that transmit,
/// `[x, y, width, height]`. `None` when no pixel transmits.
pub(super) fn exit_ray_slices(
    layers: &LightLayers,
    projection: &Projection,
) -> Option<(ExitRaySlices, [u32; 4])> {
    if !layers.has_transmission() {
        return None;
    }
    let camera_from_world = projection.camera().camera_from_world();
    let linear = DMat3::from_mat4(camera_from_world);
    let scale = linear.determinant().abs().cbrt();
    let n = layers.pixel_count();
    let width = layers.width.max(1) as usize;
    let mut slices: ExitRaySlices = std::array::from_fn(|_| vec![[0.0; 4]; n]);
    let mut bounds: Option<[usize; 4]> = None;
    for (p, &t) in layers.transmittance.iter().enumerate() {
        if t.iter().all(|&v| v <= 0.0) {
            continue;
        }
        let (x, y) = (p % width, p / width);
        let b = bounds.get_or_insert([x, y, x, y]);
        *b = [b[0].min(x), b[1].min(y), b[2].max(x), b[3].max(y)];
        let v = |a: [f32; 3]| DVec3::new(f64::from(a[0]), f64::from(a[1]), f64::from(a[2]));
        let origin = camera_from_world.transform_point3(v(layers.transmission_origin[p]));
        let mean = v(layers.transmission_direction[p]);
        let direction = (linear * mean).normalize_or_zero();
        let distance = f64::from(layers.transmission_distance[p][0]) * scale;
        let c = layers.transmitted[p];
        slices[0][p] = [t[0], t[1], t[2], 0.0];
        slices[1][p] = [c[0], c[1], c[2], 0.0];
        slices[2][p] = [origin.x as f32, origin.y as f32, origin.z as f32, distance as f32];
        slices[3][p] = [direction.x as f32, direction.y as f32, direction.z as f32, mean.length() as f32];
    }
    let [x0, y0, x1, y1] = bounds?;
    Some((slices, [x0 as u32, y0 as u32, (x1 - x0 + 1) as u32, (y1 - y0 + 1) as u32]))
}

impl Transmission {
    /// The pass for `layers` (`None` without layers or when no pixel transmits), drawn with
    /// `module` into the frame's targets of `(linear, depth)` formats, its pipeline layout the
    /// frame's and a mesh's bind group layouts (`layouts`) and its own.
    pub(super) fn new(
        gpu: &Gpu,
        projection: &Projection,
        layers: Option<&SceneLayers>,
        module: &wgpu::ShaderModule,
        (linear_format, depth_format): (wgpu::TextureFormat, wgpu::TextureFormat),
        [frame_layout, mesh_layout]: [&wgpu::BindGroupLayout; 2],
    ) -> Option<Transmission> {
        let layers = &layers?.layers;
        let (slices, rect) = exit_ray_slices(layers, projection)?;
        let device = &gpu.device;
        let (width, height) = (layers.width, layers.height);
        let texture = super::bindings::input_texture(
            device,
            "transmission layers",
            wgpu::Extent3d { width, height, depth_or_array_layers: slices.len() as u32 },
            wgpu::TextureFormat::Rgba32Float,
        );
        for (z, slice) in slices.iter().enumerate() {
            gpu.queue.write_texture(
                wgpu::TexelCopyTextureInfo {
                    texture: &texture,
                    mip_level: 0,
                    origin: wgpu::Origin3d { x: 0, y: 0, z: z as u32 },
                    aspect: wgpu::TextureAspect::All,
                },
                bytemuck::cast_slice(slice),
                wgpu::TexelCopyBufferLayout {
                    offset: 0,
                    bytes_per_row: Some(width * 16),
                    rows_per_image: Some(height),
                },
                wgpu::Extent3d { width, height, depth_or_array_layers: 1 },
            );
        }
        let view = texture.create_view(&wgpu::TextureViewDescriptor {
            dimension: Some(wgpu::TextureViewDimension::D2Array),
            ..Default::default()
        });
        let layout = device.create_bind_group_layout(&wgpu::BindGroupLayoutDescriptor {
            label: Some("transmission layers"),
            entries: &[texture_layout_entry(
                TRANSMISSION_BINDING,
                wgpu::ShaderStages::FRAGMENT,
                wgpu::TextureViewDimension::D2Array,
                false,
            )],
        });
        let bind_group = device.create_bind_group(&wgpu::BindGroupDescriptor {
            label: Some("transmission layers"),
            layout: &layout,
            entries: &[wgpu::BindGroupEntry {
                binding: TRANSMISSION_BINDING,
                resource: wgpu::BindingResource::TextureView(&view),
            }],
        });
        let pipeline_layout = device.create_pipeline_layout(&wgpu::PipelineLayoutDescriptor {
            label: Some("frame, mesh and transmission layers"),
            bind_group_layouts: &[Some(frame_layout), Some(mesh_layout), Some(&layout)],
            immediate_size: 0,
        });
        let vertex = wgpu::VertexState {
            module,
            entry_point: Some("vs_reflection"),
            compilation_options: Default::default(),
            buffers: &[],
        };
        let overlay = Overlay { module, linear_format, mask_format: super::MASK_FORMAT, depth_format };
        let pipeline = overlay.pipeline(
            device,
            "spheres seen through glass",
            &pipeline_layout,
            vertex,
            "fs_transmission",
        );
        Some(Transmission { pipeline, bind_group, rect })
    }
}

impl Compositor {
    /// Whether [`Compositor::record_transmission`] draws anything for `uniform`: some pixel
    /// transmits and there are spheres, with the spheres in reflections' switch (the bounce
    /// light's, layered shadows on).
    pub(super) fn transmission_drawn(&self, uniform: &FrameUniform) -> bool {
        self.transmission.is_some()
            && self.settings.bounce_light
            && uniform.counts[1] == 1
            && uniform.layer_info[3] != 0
    }

    /// Copies the pixels that transmit from the frame's colour target into `to`, a frame-sized
    /// texture, at their place.
    pub(super) fn copy_transmission_into(&self, encoder: &mut wgpu::CommandEncoder, to: &wgpu::Texture) {
        if let Some(transmission) = &self.transmission {
            self.copy_frame_rect_into(encoder, transmission.rect, to);
        }
    }

    /// Shows the live spheres seen through the scene's glass (`fs_transmission`): within the
    /// pixels that transmit, each sphere's draw (its material bound at its mesh slot, `rows` as
    /// for the radiosity maps) replaces the light the exit ray brought by the sphere where that
    /// ray meets it first, and gives back the share of the transmitted light the shadow pass
    /// took as the spheres' occlusion of indirect light; the rectangle is then copied into the
    /// backdrop after shadows. Runs after the spheres in reflections, with the same switch.
    pub(super) fn record_transmission(
        &self,
        encoder: &mut wgpu::CommandEncoder,
        uniform: &FrameUniform,
        rows: &[i32],
    ) {
        let Some(transmission) = self.transmission.as_ref().filter(|_| self.transmission_drawn(uniform))
        else {
            return;
        };
        let [x, y, w, h] = transmission.rect;
        let spheres = uniform.layer_info[3].min(MAX_SHADOW_SPHERES as u32);
        {
            let mut pass = self.begin_frame_pass(encoder, &self.linear_view, false);
            pass.set_scissor_rect(x, y, w, h);
            pass.set_pipeline(&transmission.pipeline);
            pass.set_bind_group(2, &transmission.bind_group, &[]);
            for row in 0..spheres {
                let slot = rows.iter().position(|&r| r == row as i32).unwrap_or(0);
                let offset = (slot as u64 * self.mesh_uniform_stride) as u32;
                pass.set_bind_group(1, &self.mesh_bind_group, &[offset]);
                pass.draw(0..3, row..row + 1);
            }
        }
        self.copy_to_shadowed(encoder, [x, y, w, h]);
    }
}
