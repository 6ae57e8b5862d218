//! Antialiased edges of live objects, as the ray tracer's pixel filter makes its own objects'
//! edges: the centre-sampled frame (colour, mask and depth, as without antialiasing) is drawn
//! first, into the linear frame; live objects are then drawn again at four samples per pixel,
//! depth-tested against the pre-rendered depth, each sample holding the live colour or nothing;
//! the centre-sampled colours near them are copied aside, and a resolve pass filters the samples
//! with the image's pixel filter over the pixel's neighbourhood and blends them with the pixel's
//! own backdrop after shadows (`shaders/resolve.wgsl`).
//!
//! Only pixels near live objects are touched, by every pass and copy (the live objects' screen
//! bounds plus the filter's reach, twice for what the resolve reads); elsewhere, and wherever no
//! live sample reaches, the frame keeps the centre-sampled value bit for bit. The mask and depth
//! read back stay those of the pixel centre.

use super::Compositor;
use super::lighting::FrameUniform;
use super::live_objects::MeshVertex;
use crate::live::LiveObjects;
use crate::pixel_filter::{MAX_FILTER_MARGIN, PixelFilter, kind_code};
use glam::DVec3;

/// Samples per pixel of the live objects' coverage.
pub(super) const SAMPLE_COUNT: u32 = 4;
/// The samples' format: half floats, which every adapter can multisample.
const SAMPLE_FORMAT: wgpu::TextureFormat = wgpu::TextureFormat::Rgba16Float;

/// The resolve pass's uniform (`resolve.wgsl` `Resolve`).
#[repr(C)]
#[derive(Clone, Copy, Debug, bytemuck::Pod, bytemuck::Zeroable)]
struct ResolveUniform {
    kind_reach: [u32; 4],
    widths: [f32; 4],
}

/// The GPU resources of antialiasing.
#[derive(Debug)]
pub(super) struct Antialias {
    /// The centre-sampled frame near the live objects, copied before the resolve overwrites it.
    centre_texture: wgpu::Texture,
    samples_view: wgpu::TextureView,
    depth_view: wgpu::TextureView,
    backdrop_pipeline: wgpu::RenderPipeline,
    sphere_pipeline: wgpu::RenderPipeline,
    /// The cursor sphere's samples shaded from its radiance map (a moving frame's).
    sphere_mapped_pipeline: wgpu::RenderPipeline,
    mesh_pipeline: wgpu::RenderPipeline,
    /// Live spheres drawn as meshes, covered as exact spheres (`fs_mesh_sphere_coverage`).
    mesh_sphere_pipeline: wgpu::RenderPipeline,
    resolve_pipeline: wgpu::RenderPipeline,
    resolve_bind_group: wgpu::BindGroup,
    /// The centre-sampled mask, for the mesh coverage pass (group 2).
    mask_bind_group: wgpu::BindGroup,
    /// How many pixels the filter reaches along x and y.
    pub(super) reach: (u32, u32),
}

/// What [`Antialias::new`] needs from the compositor.
pub(super) struct AntialiasSetup<'a> {
    pub(super) frame_layout: &'a wgpu::BindGroupLayout,
    pub(super) mesh_layout: &'a wgpu::BindGroupLayout,
    pub(super) depth_format: wgpu::TextureFormat,
    pub(super) nearer: wgpu::CompareFunction,
    pub(super) linear_format: wgpu::TextureFormat,
    /// The centre-sampled live-object mask.
    pub(super) mask_view: &'a wgpu::TextureView,
    /// The frame after shadows, before live objects.
    pub(super) shadowed_view: &'a wgpu::TextureView,
    pub(super) size: (u32, u32),
    pub(super) filter: PixelFilter,
}

impl Antialias {
    /// Builds the targets and pipelines; an adapter that cannot run them (e.g. without the
    /// sample mask in its shading language, or without memory for four samples per pixel of a
    /// large image) gives the reason as an error, and the frame keeps pixel centres.
    pub(super) fn new(device: &wgpu::Device, setup: &AntialiasSetup<'_>) -> Result<Antialias, String> {
        let validation = device.push_error_scope(wgpu::ErrorFilter::Validation);
        let memory = device.push_error_scope(wgpu::ErrorFilter::OutOfMemory);
        let built = Self::build(device, setup);
        // Scopes pop in reverse order of their pushes.
        let out_of_memory = pollster::block_on(memory.pop());
        match (pollster::block_on(validation.pop()), out_of_memory) {
            (Some(e), _) | (None, Some(e)) => Err(e.to_string()),
            (None, None) => Ok(built),
        }
    }

    fn build(device: &wgpu::Device, setup: &AntialiasSetup<'_>) -> Antialias {
        let (width, height) = setup.size;
        let texture = |label: &str, format: wgpu::TextureFormat, samples: u32, usage: wgpu::TextureUsages| {
            device.create_texture(&wgpu::TextureDescriptor {
                label: Some(label),
                size: wgpu::Extent3d { width, height, depth_or_array_layers: 1 },
                mip_level_count: 1,
                sample_count: samples,
                dimension: wgpu::TextureDimension::D2,
                format,
                usage,
                view_formats: &[],
            })
        };
        use wgpu::TextureUsages as U;
        let view = |t: &wgpu::Texture| t.create_view(&wgpu::TextureViewDescriptor::default());
        let centre_texture =
            texture("centre-sampled frame", setup.linear_format, 1, U::COPY_DST | U::TEXTURE_BINDING);
        let samples_texture =
            texture("live samples", SAMPLE_FORMAT, SAMPLE_COUNT, U::RENDER_ATTACHMENT | U::TEXTURE_BINDING);
        let depth_texture =
            texture("live sample depth", setup.depth_format, SAMPLE_COUNT, U::RENDER_ATTACHMENT);

        // The coverage entry points use the compositor's shading, so they share its source.
        let module = device.create_shader_module(wgpu::ShaderModuleDescriptor {
            label: Some("composite shaders + live_coverage.wgsl"),
            source: wgpu::ShaderSource::Wgsl(
                format!("{}{}", super::COMPOSITE_WGSL, include_str!("../shaders/live_coverage.wgsl")).into(),
            ),
        });
        let frame_only = device.create_pipeline_layout(&wgpu::PipelineLayoutDescriptor {
            label: Some("coverage, frame only"),
            bind_group_layouts: &[Some(setup.frame_layout)],
            immediate_size: 0,
        });
        let mask_layout = device.create_bind_group_layout(&wgpu::BindGroupLayoutDescriptor {
            label: Some("coverage mask"),
            entries: &[wgpu::BindGroupLayoutEntry {
                binding: 0,
                visibility: wgpu::ShaderStages::FRAGMENT,
                ty: wgpu::BindingType::Texture {
                    sample_type: wgpu::TextureSampleType::Float { filterable: false },
                    view_dimension: wgpu::TextureViewDimension::D2,
                    multisampled: false,
                },
                count: None,
            }],
        });
        let mask_bind_group = device.create_bind_group(&wgpu::BindGroupDescriptor {
            label: Some("coverage mask"),
            layout: &mask_layout,
            entries: &[wgpu::BindGroupEntry {
                binding: 0,
                resource: wgpu::BindingResource::TextureView(setup.mask_view),
            }],
        });
        let with_mesh = device.create_pipeline_layout(&wgpu::PipelineLayoutDescriptor {
            label: Some("coverage, frame, mesh and mask"),
            bind_group_layouts: &[Some(setup.frame_layout), Some(setup.mesh_layout), Some(&mask_layout)],
            immediate_size: 0,
        });
        let mesh_attributes = wgpu::vertex_attr_array![0 => Float32x3, 1 => Float32x3];
        let mesh_buffers = [Some(wgpu::VertexBufferLayout {
            array_stride: std::mem::size_of::<MeshVertex>() as u64,
            step_mode: wgpu::VertexStepMode::Vertex,
            attributes: &mesh_attributes,
        })];
        let pipeline = |label: &str,
                        layout: &wgpu::PipelineLayout,
                        (vs, fs): (&str, &str),
                        buffers: &[Option<wgpu::VertexBufferLayout>],
                        primitive: wgpu::PrimitiveState,
                        compare: wgpu::CompareFunction| {
            device.create_render_pipeline(&wgpu::RenderPipelineDescriptor {
                label: Some(label),
                layout: Some(layout),
                vertex: wgpu::VertexState {
                    module: &module,
                    entry_point: Some(vs),
                    compilation_options: Default::default(),
                    buffers,
                },
                primitive,
                depth_stencil: Some(wgpu::DepthStencilState {
                    format: setup.depth_format,
                    depth_write_enabled: Some(true),
                    depth_compare: Some(compare),
                    stencil: wgpu::StencilState::default(),
                    bias: wgpu::DepthBiasState::default(),
                }),
                multisample: wgpu::MultisampleState { count: SAMPLE_COUNT, ..Default::default() },
                fragment: Some(wgpu::FragmentState {
                    module: &module,
                    entry_point: Some(fs),
                    compilation_options: Default::default(),
                    targets: &[Some(wgpu::ColorTargetState {
                        format: SAMPLE_FORMAT,
                        blend: None,
                        write_mask: wgpu::ColorWrites::ALL,
                    })],
                }),
                multiview_mask: None,
                cache: None,
            })
        };
        let triangles = wgpu::PrimitiveState::default();
        let backdrop_pipeline = pipeline(
            "coverage backdrop depth",
            &frame_only,
            ("vs_fullscreen", "fs_coverage_backdrop"),
            &[],
            triangles,
            wgpu::CompareFunction::Always,
        );
        // The spheres' bounding cubes: back faces, so the cube covers the sphere with the eye
        // inside it (composite.wgsl vs_sphere).
        let cube = wgpu::PrimitiveState {
            front_face: wgpu::FrontFace::Ccw,
            cull_mode: Some(wgpu::Face::Front),
            ..Default::default()
        };
        let sphere_pipeline = pipeline(
            "sphere coverage",
            &frame_only,
            ("vs_sphere", "fs_sphere_coverage"),
            &[],
            cube,
            setup.nearer,
        );
        let sphere_mapped_pipeline = pipeline(
            "sphere coverage from its radiance map",
            &frame_only,
            ("vs_sphere", "fs_sphere_coverage_mapped"),
            &[],
            cube,
            setup.nearer,
        );
        let mesh_sphere_pipeline = pipeline(
            "mesh sphere coverage",
            &with_mesh,
            ("vs_mesh_sphere_coverage", "fs_mesh_sphere_coverage"),
            &[],
            cube,
            setup.nearer,
        );
        let mesh_pipeline = pipeline(
            "mesh coverage",
            &with_mesh,
            ("vs_mesh", "fs_mesh_coverage"),
            &mesh_buffers,
            triangles,
            setup.nearer,
        );

        let (reach_x, reach_y) = setup.filter.pixel_margin();
        let reach = (reach_x.min(MAX_FILTER_MARGIN), reach_y.min(MAX_FILTER_MARGIN));
        let uniform = ResolveUniform {
            kind_reach: [kind_code(setup.filter.kind), reach.0, reach.1, 0],
            widths: [setup.filter.x_width, setup.filter.y_width, 0.0, 0.0],
        };
        let resolve_uniform = wgpu::util::DeviceExt::create_buffer_init(
            device,
            &wgpu::util::BufferInitDescriptor {
                label: Some("resolve uniform"),
                contents: bytemuck::bytes_of(&uniform),
                usage: wgpu::BufferUsages::STORAGE,
            },
        );
        let texture_entry = |binding: u32, multisampled: bool| wgpu::BindGroupLayoutEntry {
            binding,
            visibility: wgpu::ShaderStages::FRAGMENT,
            ty: wgpu::BindingType::Texture {
                sample_type: wgpu::TextureSampleType::Float { filterable: false },
                view_dimension: wgpu::TextureViewDimension::D2,
                multisampled,
            },
            count: None,
        };
        let resolve_layout = device.create_bind_group_layout(&wgpu::BindGroupLayoutDescriptor {
            label: Some("resolve"),
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
                texture_entry(1, false),
                texture_entry(2, false),
                texture_entry(3, true),
                texture_entry(4, false),
            ],
        });
        let centre_view = view(&centre_texture);
        let samples_view = view(&samples_texture);
        let resolve_bind_group = device.create_bind_group(&wgpu::BindGroupDescriptor {
            label: Some("resolve"),
            layout: &resolve_layout,
            entries: &[
                wgpu::BindGroupEntry { binding: 0, resource: resolve_uniform.as_entire_binding() },
                wgpu::BindGroupEntry {
                    binding: 1,
                    resource: wgpu::BindingResource::TextureView(&centre_view),
                },
                wgpu::BindGroupEntry {
                    binding: 2,
                    resource: wgpu::BindingResource::TextureView(setup.shadowed_view),
                },
                wgpu::BindGroupEntry {
                    binding: 3,
                    resource: wgpu::BindingResource::TextureView(&samples_view),
                },
                wgpu::BindGroupEntry {
                    binding: 4,
                    resource: wgpu::BindingResource::TextureView(setup.mask_view),
                },
            ],
        });
        let resolve_module = device.create_shader_module(wgpu::ShaderModuleDescriptor {
            label: Some("resolve.wgsl"),
            source: wgpu::ShaderSource::Wgsl(include_str!("../shaders/resolve.wgsl").into()),
        });
        let resolve_pipeline = device.create_render_pipeline(&wgpu::RenderPipelineDescriptor {
            label: Some("resolve"),
            layout: Some(&device.create_pipeline_layout(&wgpu::PipelineLayoutDescriptor {
                label: Some("resolve"),
                bind_group_layouts: &[Some(&resolve_layout)],
                immediate_size: 0,
            })),
            vertex: wgpu::VertexState {
                module: &resolve_module,
                entry_point: Some("vs_fullscreen"),
                compilation_options: Default::default(),
                buffers: &[],
            },
            primitive: triangles,
            depth_stencil: None,
            multisample: wgpu::MultisampleState::default(),
            fragment: Some(wgpu::FragmentState {
                module: &resolve_module,
                entry_point: Some("fs_resolve"),
                compilation_options: Default::default(),
                targets: &[Some(wgpu::ColorTargetState {
                    format: setup.linear_format,
                    blend: None,
                    write_mask: wgpu::ColorWrites::ALL,
                })],
            }),
            multiview_mask: None,
            cache: None,
        });
        Antialias {
            centre_texture,
            samples_view,
            depth_view: view(&depth_texture),
            backdrop_pipeline,
            sphere_pipeline,
            sphere_mapped_pipeline,
            mesh_pipeline,
            mesh_sphere_pipeline,
            resolve_pipeline,
            resolve_bind_group,
            mask_bind_group,
            reach,
        }
    }
}

/// Where live objects can be this frame, for their coverage.
#[derive(Debug)]
pub(super) struct LiveBounds {
    /// The pixels they can cover (x, y, width, height).
    rect: [u32; 4],
    /// Per mesh slot: whether it draws an exact sphere (its transform a translation and a
    /// uniform scale of the unit sphere), covered by ray casting rather than by its triangles.
    exact_spheres: Vec<bool>,
}

/// Whether `instance` draws its exact sphere with a transform that moves the unit sphere onto it.
fn covered_as_sphere(instance: &crate::live::MeshInstance) -> bool {
    instance.exact_sphere.is_some_and(|(c, r)| {
        let placed = glam::DMat4::from_translation(c) * glam::DMat4::from_scale(DVec3::splat(r));
        r > 0.0 && instance.world_from_object.abs_diff_eq(placed, 1e-9 * (1.0 + c.abs().max_element() + r))
    })
}

impl Compositor {
    /// The pixels live objects can cover this frame (their screen bounds), `None` when none is
    /// drawn. `draws` are the mesh slots of `live.meshes` with finite transforms.
    pub(super) fn live_bounds(
        &self,
        uniform: &FrameUniform,
        live: &LiveObjects,
        draws: &[usize],
    ) -> Option<LiveBounds> {
        let mut union = None;
        if uniform.counts[2] == 1 {
            let s = uniform.sphere;
            let centre = DVec3::new(f64::from(s[0]), f64::from(s[1]), f64::from(s[2]));
            union = super::shadows::merge(union, self.box_scissor(centre, f64::from(s[3]) * 1.001));
        }
        let camera_from_world = self.projection.camera().camera_from_world();
        let instances = live.meshes.iter().filter(|m| m.world_from_object.is_finite());
        for (instance, &k) in instances.zip(draws) {
            let Some((lo, hi)) = self.meshes[k].bounds else { continue };
            let camera_from_object = camera_from_world * instance.world_from_object;
            let corners: Vec<DVec3> = (0..8)
                .map(|c| {
                    let p = DVec3::new(
                        if c & 1 == 0 { lo.x } else { hi.x },
                        if c & 2 == 0 { lo.y } else { hi.y },
                        if c & 4 == 0 { lo.z } else { hi.z },
                    );
                    camera_from_object.transform_point3(p)
                })
                .collect();
            union = super::shadows::merge(union, self.screen_bounds(&corners));
        }
        let exact_spheres =
            live.meshes.iter().filter(|m| m.world_from_object.is_finite()).map(covered_as_sphere).collect();
        Some(LiveBounds { rect: union?, exact_spheres })
    }

    /// Draws live objects at four samples per pixel into the antialiasing targets and filters
    /// them into the linear frame (drawn at pixel centres) within `bounds` plus the filter's
    /// reach. Every pass and copy is cut to the live objects' bounds: the frame elsewhere is
    /// never touched.
    pub(super) fn record_antialiased(
        &self,
        encoder: &mut wgpu::CommandEncoder,
        bounds: LiveBounds,
        draws: &[usize],
        (sphere, cursor_mapped): (bool, bool),
    ) {
        let Some(aa) = &self.antialias else { return };
        let LiveBounds { rect: bounds, exact_spheres } = bounds;
        // The resolve writes the pixels the filter carries live samples to (`reach` beyond the
        // bounds) and reads the samples and centre values `reach` beyond those.
        let (rx, ry) = aa.reach;
        let [x0, y0, x1, y1] = self.grown(bounds, rx, ry);
        let [sx0, sy0, sx1, sy1] = self.grown(bounds, 2 * rx, 2 * ry);
        {
            // Loaded, not cleared: the backdrop's depth pass below writes every sample the
            // resolve reads (colour zero, the pre-rendered depth), so clearing all of a large
            // frame's samples would be wasted.
            let mut pass = encoder.begin_render_pass(&wgpu::RenderPassDescriptor {
                label: Some("live coverage"),
                color_attachments: &[Some(wgpu::RenderPassColorAttachment {
                    view: &aa.samples_view,
                    depth_slice: None,
                    resolve_target: None,
                    ops: wgpu::Operations { load: wgpu::LoadOp::Load, store: wgpu::StoreOp::Store },
                })],
                depth_stencil_attachment: Some(wgpu::RenderPassDepthStencilAttachment {
                    view: &aa.depth_view,
                    depth_ops: Some(wgpu::Operations {
                        load: wgpu::LoadOp::Load,
                        store: wgpu::StoreOp::Discard,
                    }),
                    stencil_ops: None,
                }),
                timestamp_writes: None,
                occlusion_query_set: None,
                multiview_mask: None,
            });
            pass.set_scissor_rect(sx0, sy0, sx1 - sx0, sy1 - sy0);
            pass.set_bind_group(0, &self.frame_bind_group, &[]);
            pass.set_pipeline(&aa.backdrop_pipeline);
            pass.draw(0..3, 0..1);
            // The mesh coverage pipelines read the centre mask (group 2).
            pass.set_bind_group(2, &aa.mask_bind_group, &[]);
            for (slot, &k) in draws.iter().enumerate() {
                let offset = (slot as u64 * self.mesh_uniform_stride) as u32;
                pass.set_bind_group(1, &self.mesh_bind_group, &[offset]);
                if exact_spheres.get(slot).copied().unwrap_or(false) {
                    pass.set_pipeline(&aa.mesh_sphere_pipeline);
                    pass.draw(0..36, 0..1);
                } else {
                    let mesh = &self.meshes[k];
                    pass.set_pipeline(&aa.mesh_pipeline);
                    pass.set_vertex_buffer(0, mesh.vertices.slice(..));
                    pass.set_index_buffer(mesh.indices.slice(..), wgpu::IndexFormat::Uint32);
                    pass.draw_indexed(0..mesh.index_count, 0, 0..1);
                }
            }
            if sphere {
                pass.set_pipeline(if cursor_mapped {
                    &aa.sphere_mapped_pipeline
                } else {
                    &aa.sphere_pipeline
                });
                pass.draw(0..36, 0..1);
            }
        }
        let origin = wgpu::Origin3d { x: sx0, y: sy0, z: 0 };
        encoder.copy_texture_to_texture(
            wgpu::TexelCopyTextureInfo { origin, ..self.linear_texture.as_image_copy() },
            wgpu::TexelCopyTextureInfo { origin, ..aa.centre_texture.as_image_copy() },
            wgpu::Extent3d { width: sx1 - sx0, height: sy1 - sy0, depth_or_array_layers: 1 },
        );
        let mut pass = super::colour_pass(encoder, "resolve", &self.linear_view, wgpu::LoadOp::Load);
        pass.set_scissor_rect(x0, y0, x1 - x0, y1 - y0);
        pass.set_pipeline(&aa.resolve_pipeline);
        pass.set_bind_group(0, &aa.resolve_bind_group, &[]);
        pass.draw(0..3, 0..1);
    }

    /// `bounds` (x, y, width, height) grown by `mx` and `my` pixels on each side, within the
    /// frame, as corners (x0, y0, x1, y1).
    fn grown(&self, [x, y, w, h]: [u32; 4], mx: u32, my: u32) -> [u32; 4] {
        [
            x.saturating_sub(mx),
            y.saturating_sub(my),
            x.saturating_add(w).saturating_add(mx).min(self.width),
            y.saturating_add(h).saturating_add(my).min(self.height),
        ]
    }
}
