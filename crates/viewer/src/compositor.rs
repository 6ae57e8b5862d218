//! The GPU compositor: the pre-rendered image and its depth, then live objects, into an
//! offscreen frame (colour, live-object mask and depth) that can be read back or presented.

use crate::backdrop::Rgba8Image;
use crate::error::ViewerError;
use crate::gpu::Gpu;
use crate::live::{LiveLight, LiveObjects, Material, Mesh, ShadowSource};
use crate::projection::{Projection, nearer};
use crate::scene::ViewerScene;
use bytemuck::{Pod, Zeroable};
use depth_remap::{DepthConvention, NearFar};
use glam::{DMat3, DMat4, DVec3, Mat4};
use std::sync::Arc;

/// Format of the composited frame: 8-bit unorm, not sRGB, so input bytes pass through untouched.
pub const FRAME_FORMAT: wgpu::TextureFormat = wgpu::TextureFormat::Rgba8Unorm;
/// Format of the live-object mask.
pub const MASK_FORMAT: wgpu::TextureFormat = wgpu::TextureFormat::R8Unorm;
/// Most lights passed to the shaders; further lights are dropped (the brightest are kept).
pub const MAX_LIGHTS: usize = 16;

/// How the pre-rendered image and its depth get into the frame. Both give identical colour and
/// depth buffers (the test suite checks it bit for bit).
#[derive(Clone, Copy, Debug, PartialEq, Eq, Hash)]
pub enum CompositeMode {
    /// The paper's: one point per pixel at `(i + 0.5, j + 0.5, window depth)` through the
    /// orthographic matrix that passes depth through.
    Points,
    /// Lawlor's: one full-screen triangle whose fragment shader reads the pixel's colour and
    /// writes its fragment depth from textures.
    Fullscreen,
}

impl CompositeMode {
    pub fn name(self) -> &'static str {
        match self {
            CompositeMode::Points => "points",
            CompositeMode::Fullscreen => "fullscreen",
        }
    }
}

/// The depth buffer: its format and which way it runs.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub struct DepthSettings {
    pub format: wgpu::TextureFormat,
    pub convention: DepthConvention,
}

impl Default for DepthSettings {
    /// Reversed-Z in a 32-bit float buffer: nearly constant relative precision in eye depth.
    fn default() -> Self {
        DepthSettings { format: wgpu::TextureFormat::Depth32Float, convention: DepthConvention::WgpuReversed }
    }
}

/// Shadows of the live sphere on the pre-rendered scene.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct ShadowSettings {
    /// The fraction of a pixel's value removed where the sphere hides the whole shadow light
    /// (the share of the pre-rendered radiance that light's direct illumination is taken to be).
    pub strength: f32,
    /// Index into the scene's lights; `None` picks the dominant light.
    pub light: Option<usize>,
}

impl Default for ShadowSettings {
    fn default() -> Self {
        ShadowSettings { strength: 0.6, light: None }
    }
}

/// How the compositor is set up.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct CompositorSettings {
    pub mode: CompositeMode,
    pub depth: DepthSettings,
    /// Near/far planes; `None` derives them from the depth table
    /// ([`crate::projection::near_far_policy`]).
    pub depth_range: Option<NearFar>,
    /// `None` disables shadows.
    pub shadows: Option<ShadowSettings>,
}

impl Default for CompositorSettings {
    fn default() -> Self {
        CompositorSettings {
            mode: CompositeMode::Fullscreen,
            depth: DepthSettings::default(),
            depth_range: None,
            shadows: Some(ShadowSettings::default()),
        }
    }
}

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

#[repr(C)]
#[derive(Clone, Copy, Debug, Default, Pod, Zeroable)]
struct GpuLight {
    position: [f32; 4],
    direction: [f32; 4],
    colour: [f32; 4],
    params: [f32; 4],
}

#[repr(C)]
#[derive(Clone, Copy, Debug, Default, Pod, Zeroable)]
struct GpuMaterial {
    colour: [f32; 4],
    coefficients: [f32; 4],
    specular_colour: [f32; 4],
}

impl From<&Material> for GpuMaterial {
    fn from(m: &Material) -> Self {
        GpuMaterial {
            colour: [m.colour.x, m.colour.y, m.colour.z, if m.unlit { 1.0 } else { 0.0 }],
            coefficients: [m.ka, m.kd, m.ks, m.roughness],
            specular_colour: m.specular_colour.extend(0.0).to_array(),
        }
    }
}

#[repr(C)]
#[derive(Clone, Copy, Debug, Pod, Zeroable)]
struct FrameUniform {
    clip_from_camera: [[f32; 4]; 4],
    clip_from_raster: [[f32; 4]; 4],
    screen_window: [f32; 4],
    raster: [f32; 4],
    tone: [f32; 4],
    counts: [u32; 4],
    shadow_light: [f32; 4],
    shadow_params: [f32; 4],
    sphere: [f32; 4],
    sphere_material: GpuMaterial,
    lights: [GpuLight; MAX_LIGHTS],
}

#[repr(C)]
#[derive(Clone, Copy, Debug, Pod, Zeroable)]
struct MeshUniform {
    camera_from_object: [[f32; 4]; 4],
    normal_from_object: [[f32; 4]; 4],
    material: GpuMaterial,
}

#[repr(C)]
#[derive(Clone, Copy, Debug, Pod, Zeroable)]
struct PointVertex {
    raster_depth: [f32; 3],
    colour: [u8; 4],
}

#[repr(C)]
#[derive(Clone, Copy, Debug, Pod, Zeroable)]
struct MeshVertex {
    position: [f32; 3],
    normal: [f32; 3],
}

#[derive(Debug)]
struct GpuMesh {
    source: Arc<Mesh>,
    vertices: wgpu::Buffer,
    indices: wgpu::Buffer,
    index_count: u32,
}

/// The compositor: GPU resources for one scene.
#[derive(Debug)]
pub struct Compositor {
    gpu: Gpu,
    projection: Projection,
    settings: CompositorSettings,
    width: u32,
    height: u32,
    lights: Vec<LiveLight>,
    shadow_light: Option<usize>,
    tone: [f32; 4],
    /// Window depth of every pixel, kept to build the point cloud on demand.
    window_depths: Vec<f32>,
    /// Camera-space bounds of every visible pre-rendered surface point (bounds the shadow pass).
    surface_bounds: Option<(DVec3, DVec3)>,
    image: Rgba8Image,
    frame_texture: wgpu::Texture,
    frame_view: wgpu::TextureView,
    mask_texture: wgpu::Texture,
    mask_view: wgpu::TextureView,
    depth_view: wgpu::TextureView,
    frame_uniform: wgpu::Buffer,
    frame_bind_group: wgpu::BindGroup,
    mesh_layout: wgpu::BindGroupLayout,
    mesh_uniform: wgpu::Buffer,
    mesh_uniform_capacity: u64,
    mesh_uniform_stride: u64,
    mesh_bind_group: wgpu::BindGroup,
    meshes: Vec<GpuMesh>,
    points: Option<wgpu::Buffer>,
    backdrop_points: wgpu::RenderPipeline,
    backdrop_fullscreen: wgpu::RenderPipeline,
    shadow_pipeline: wgpu::RenderPipeline,
    sphere_pipeline: wgpu::RenderPipeline,
    mesh_pipeline: wgpu::RenderPipeline,
    readback_pipeline: wgpu::ComputePipeline,
    readback_bind_group: wgpu::BindGroup,
    depth_storage: wgpu::Buffer,
}

/// Camera-space bounds of the surface points of a radial depth table (`None`: all misses).
fn camera_space_bounds(projection: &Projection, radial: &[f32]) -> Option<(DVec3, DVec3)> {
    let camera = projection.camera();
    let (w, _) = camera.resolution();
    let mut lo = DVec3::splat(f64::INFINITY);
    let mut hi = DVec3::splat(f64::NEG_INFINITY);
    for (k, &r) in radial.iter().enumerate() {
        if r.is_finite() {
            let ray = camera.pixel_centre_ray(k as u32 % w, k as u32 / w);
            let p = ray.origin + ray.direction * f64::from(r);
            lo = lo.min(p);
            hi = hi.max(p);
        }
    }
    lo.is_finite().then_some((lo, hi))
}

fn mat4_f32(m: DMat4) -> [[f32; 4]; 4] {
    m.as_mat4().to_cols_array_2d()
}

fn vec4(v: DVec3, w: f32) -> [f32; 4] {
    [v.x as f32, v.y as f32, v.z as f32, w]
}

const fn align_up(v: u64, a: u64) -> u64 {
    v.div_ceil(a) * a
}

impl Compositor {
    /// Uploads the scene and builds the pipelines.
    pub fn new(
        gpu: &Gpu,
        scene: &ViewerScene,
        settings: CompositorSettings,
    ) -> Result<Compositor, ViewerError> {
        let (width, height) = scene.size();
        let limits = gpu.device.limits();
        if width > limits.max_texture_dimension_2d || height > limits.max_texture_dimension_2d {
            return Err(ViewerError::Unsupported(format!(
                "image {width}x{height} exceeds the adapter's texture limit {}",
                limits.max_texture_dimension_2d
            )));
        }
        let depth_format = settings.depth.format;
        if !matches!(
            depth_format,
            wgpu::TextureFormat::Depth32Float
                | wgpu::TextureFormat::Depth24Plus
                | wgpu::TextureFormat::Depth16Unorm
        ) {
            return Err(ViewerError::Unsupported(format!("depth format {depth_format:?}")));
        }
        let projection = Projection::new(
            scene.camera().clone(),
            scene.depth(),
            settings.depth.convention,
            settings.depth_range,
        )?;
        let window_depths = projection.window_depths(scene.depth())?;
        let surface_bounds = camera_space_bounds(&projection, scene.depth().values());
        let device = &gpu.device;

        // Error scopes catch validation and memory errors of resource creation as values.
        let scope = device.push_error_scope(wgpu::ErrorFilter::Validation);
        let memory_scope = device.push_error_scope(wgpu::ErrorFilter::OutOfMemory);

        let size = wgpu::Extent3d { width, height, depth_or_array_layers: 1 };
        let texture = |label: &str, format: wgpu::TextureFormat, usage: wgpu::TextureUsages| {
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
        let frame_texture =
            texture("frame", FRAME_FORMAT, U::RENDER_ATTACHMENT | U::COPY_SRC | U::TEXTURE_BINDING);
        let mask_texture = texture("mask", MASK_FORMAT, U::RENDER_ATTACHMENT | U::COPY_SRC);
        let depth_texture = texture("depth", depth_format, U::RENDER_ATTACHMENT | U::TEXTURE_BINDING);
        let colour_texture = texture("backdrop colour", FRAME_FORMAT, U::TEXTURE_BINDING | U::COPY_DST);
        let window_depth_texture =
            texture("backdrop window depth", wgpu::TextureFormat::R32Float, U::TEXTURE_BINDING | U::COPY_DST);
        let radial_texture =
            texture("backdrop radial depth", wgpu::TextureFormat::R32Float, U::TEXTURE_BINDING | U::COPY_DST);
        let upload = |t: &wgpu::Texture, bytes: &[u8], bytes_per_pixel: u32| {
            gpu.queue.write_texture(
                wgpu::TexelCopyTextureInfo {
                    texture: t,
                    mip_level: 0,
                    origin: wgpu::Origin3d::ZERO,
                    aspect: wgpu::TextureAspect::All,
                },
                bytes,
                wgpu::TexelCopyBufferLayout {
                    offset: 0,
                    bytes_per_row: Some(width * bytes_per_pixel),
                    rows_per_image: Some(height),
                },
                size,
            )
        };
        upload(&colour_texture, &scene.image().pixels, 4);
        upload(&window_depth_texture, bytemuck::cast_slice(&window_depths), 4);
        // The GPU sees `inf` as a huge finite number on some backends; store misses as f32::MAX.
        let radial: Vec<f32> =
            scene.depth().values().iter().map(|&r| if r.is_finite() { r } else { f32::MAX }).collect();
        upload(&radial_texture, bytemuck::cast_slice(&radial), 4);

        let frame_uniform = device.create_buffer(&wgpu::BufferDescriptor {
            label: Some("frame uniform"),
            size: std::mem::size_of::<FrameUniform>() as u64,
            usage: wgpu::BufferUsages::UNIFORM | wgpu::BufferUsages::COPY_DST,
            mapped_at_creation: false,
        });
        let texture_entry = |binding: u32, visibility: wgpu::ShaderStages| wgpu::BindGroupLayoutEntry {
            binding,
            visibility,
            ty: wgpu::BindingType::Texture {
                sample_type: wgpu::TextureSampleType::Float { filterable: false },
                view_dimension: wgpu::TextureViewDimension::D2,
                multisampled: false,
            },
            count: None,
        };
        let vf = wgpu::ShaderStages::VERTEX | wgpu::ShaderStages::FRAGMENT;
        let frame_layout = device.create_bind_group_layout(&wgpu::BindGroupLayoutDescriptor {
            label: Some("frame"),
            entries: &[
                wgpu::BindGroupLayoutEntry {
                    binding: 0,
                    visibility: vf,
                    ty: wgpu::BindingType::Buffer {
                        ty: wgpu::BufferBindingType::Uniform,
                        has_dynamic_offset: false,
                        min_binding_size: None,
                    },
                    count: None,
                },
                texture_entry(1, wgpu::ShaderStages::FRAGMENT),
                texture_entry(2, wgpu::ShaderStages::FRAGMENT),
                texture_entry(3, wgpu::ShaderStages::FRAGMENT),
            ],
        });
        let view = |t: &wgpu::Texture| t.create_view(&wgpu::TextureViewDescriptor::default());
        let frame_bind_group = device.create_bind_group(&wgpu::BindGroupDescriptor {
            label: Some("frame"),
            layout: &frame_layout,
            entries: &[
                wgpu::BindGroupEntry { binding: 0, resource: frame_uniform.as_entire_binding() },
                wgpu::BindGroupEntry {
                    binding: 1,
                    resource: wgpu::BindingResource::TextureView(&view(&colour_texture)),
                },
                wgpu::BindGroupEntry {
                    binding: 2,
                    resource: wgpu::BindingResource::TextureView(&view(&window_depth_texture)),
                },
                wgpu::BindGroupEntry {
                    binding: 3,
                    resource: wgpu::BindingResource::TextureView(&view(&radial_texture)),
                },
            ],
        });
        let mesh_layout = device.create_bind_group_layout(&wgpu::BindGroupLayoutDescriptor {
            label: Some("mesh"),
            entries: &[wgpu::BindGroupLayoutEntry {
                binding: 0,
                visibility: vf,
                ty: wgpu::BindingType::Buffer {
                    ty: wgpu::BufferBindingType::Uniform,
                    has_dynamic_offset: true,
                    min_binding_size: wgpu::BufferSize::new(std::mem::size_of::<MeshUniform>() as u64),
                },
                count: None,
            }],
        });
        let mesh_uniform_stride = align_up(
            std::mem::size_of::<MeshUniform>() as u64,
            u64::from(limits.min_uniform_buffer_offset_alignment),
        );
        let mesh_uniform_capacity = 4;
        let mesh_uniform = Self::make_mesh_uniform(device, mesh_uniform_capacity * mesh_uniform_stride);
        let mesh_bind_group = Self::make_mesh_bind_group(device, &mesh_layout, &mesh_uniform);

        let module = device.create_shader_module(wgpu::ShaderModuleDescriptor {
            label: Some("composite.wgsl"),
            source: wgpu::ShaderSource::Wgsl(include_str!("shaders/composite.wgsl").into()),
        });
        let frame_only = device.create_pipeline_layout(&wgpu::PipelineLayoutDescriptor {
            label: Some("frame only"),
            bind_group_layouts: &[Some(&frame_layout)],
            immediate_size: 0,
        });
        let with_mesh = device.create_pipeline_layout(&wgpu::PipelineLayoutDescriptor {
            label: Some("frame and mesh"),
            bind_group_layouts: &[Some(&frame_layout), Some(&mesh_layout)],
            immediate_size: 0,
        });
        let nearer = nearer(settings.depth.convention);
        let depth_state = |compare: wgpu::CompareFunction, write: bool| wgpu::DepthStencilState {
            format: depth_format,
            depth_write_enabled: Some(write),
            depth_compare: Some(compare),
            stencil: wgpu::StencilState::default(),
            bias: wgpu::DepthBiasState::default(),
        };
        let write_all = [
            Some(wgpu::ColorTargetState {
                format: FRAME_FORMAT,
                blend: None,
                write_mask: wgpu::ColorWrites::ALL,
            }),
            Some(wgpu::ColorTargetState {
                format: MASK_FORMAT,
                blend: None,
                write_mask: wgpu::ColorWrites::ALL,
            }),
        ];
        let point_attributes = wgpu::vertex_attr_array![0 => Float32x3, 1 => Unorm8x4];
        let mesh_attributes = wgpu::vertex_attr_array![0 => Float32x3, 1 => Float32x3];
        let pipeline = |label: &str,
                        layout: &wgpu::PipelineLayout,
                        vs: &str,
                        fs: &str,
                        buffers: &[Option<wgpu::VertexBufferLayout>],
                        primitive: wgpu::PrimitiveState,
                        depth: wgpu::DepthStencilState,
                        targets: &[Option<wgpu::ColorTargetState>]| {
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
                depth_stencil: Some(depth),
                multisample: wgpu::MultisampleState::default(),
                fragment: Some(wgpu::FragmentState {
                    module: &module,
                    entry_point: Some(fs),
                    compilation_options: Default::default(),
                    targets,
                }),
                multiview_mask: None,
                cache: None,
            })
        };
        let triangles = wgpu::PrimitiveState::default();
        let backdrop_points = pipeline(
            "backdrop points",
            &frame_only,
            "vs_backdrop_points",
            "fs_backdrop_points",
            &[Some(wgpu::VertexBufferLayout {
                array_stride: std::mem::size_of::<PointVertex>() as u64,
                step_mode: wgpu::VertexStepMode::Vertex,
                attributes: &point_attributes,
            })],
            wgpu::PrimitiveState { topology: wgpu::PrimitiveTopology::PointList, ..Default::default() },
            depth_state(wgpu::CompareFunction::Always, true),
            &write_all,
        );
        let backdrop_fullscreen = pipeline(
            "backdrop full-screen",
            &frame_only,
            "vs_fullscreen",
            "fs_backdrop_fullscreen",
            &[],
            triangles,
            depth_state(wgpu::CompareFunction::Always, true),
            &write_all,
        );
        let multiply = wgpu::BlendState {
            color: wgpu::BlendComponent {
                src_factor: wgpu::BlendFactor::Zero,
                dst_factor: wgpu::BlendFactor::Src,
                operation: wgpu::BlendOperation::Add,
            },
            alpha: wgpu::BlendComponent {
                src_factor: wgpu::BlendFactor::Zero,
                dst_factor: wgpu::BlendFactor::One,
                operation: wgpu::BlendOperation::Add,
            },
        };
        let shadow_pipeline = pipeline(
            "shadow",
            &frame_only,
            "vs_fullscreen",
            "fs_shadow",
            &[],
            triangles,
            depth_state(wgpu::CompareFunction::Always, false),
            &[
                Some(wgpu::ColorTargetState {
                    format: FRAME_FORMAT,
                    blend: Some(multiply),
                    write_mask: wgpu::ColorWrites::COLOR,
                }),
                Some(wgpu::ColorTargetState {
                    format: MASK_FORMAT,
                    blend: None,
                    write_mask: wgpu::ColorWrites::empty(),
                }),
            ],
        );
        let sphere_pipeline = pipeline(
            "sphere impostor",
            &frame_only,
            "vs_sphere",
            "fs_sphere",
            &[],
            wgpu::PrimitiveState {
                front_face: wgpu::FrontFace::Ccw,
                cull_mode: Some(wgpu::Face::Front),
                ..Default::default()
            },
            depth_state(nearer, true),
            &write_all,
        );
        let mesh_pipeline = pipeline(
            "live mesh",
            &with_mesh,
            "vs_mesh",
            "fs_mesh",
            &[Some(wgpu::VertexBufferLayout {
                array_stride: std::mem::size_of::<MeshVertex>() as u64,
                step_mode: wgpu::VertexStepMode::Vertex,
                attributes: &mesh_attributes,
            })],
            triangles,
            depth_state(nearer, true),
            &write_all,
        );

        // Depth readback through a compute pass (GL cannot copy depth textures to buffers).
        let readback_module = device.create_shader_module(wgpu::ShaderModuleDescriptor {
            label: Some("readback.wgsl"),
            source: wgpu::ShaderSource::Wgsl(include_str!("shaders/readback.wgsl").into()),
        });
        let depth_bytes = u64::from(width) * u64::from(height) * 4;
        if depth_bytes > limits.max_storage_buffer_binding_size {
            return Err(ViewerError::Unsupported(format!(
                "depth readback of {width}x{height} exceeds the storage buffer limit {}",
                limits.max_storage_buffer_binding_size
            )));
        }
        let depth_storage = device.create_buffer(&wgpu::BufferDescriptor {
            label: Some("depth readback storage"),
            size: depth_bytes,
            usage: wgpu::BufferUsages::STORAGE | wgpu::BufferUsages::COPY_SRC,
            mapped_at_creation: false,
        });
        let readback_layout = device.create_bind_group_layout(&wgpu::BindGroupLayoutDescriptor {
            label: Some("depth readback"),
            entries: &[
                wgpu::BindGroupLayoutEntry {
                    binding: 0,
                    visibility: wgpu::ShaderStages::COMPUTE,
                    ty: wgpu::BindingType::Texture {
                        sample_type: wgpu::TextureSampleType::Float { filterable: false },
                        view_dimension: wgpu::TextureViewDimension::D2,
                        multisampled: false,
                    },
                    count: None,
                },
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
        let depth_view = view(&depth_texture);
        let readback_bind_group = device.create_bind_group(&wgpu::BindGroupDescriptor {
            label: Some("depth readback"),
            layout: &readback_layout,
            entries: &[
                wgpu::BindGroupEntry {
                    binding: 0,
                    resource: wgpu::BindingResource::TextureView(&depth_view),
                },
                wgpu::BindGroupEntry { binding: 1, resource: depth_storage.as_entire_binding() },
            ],
        });
        let readback_pipeline = device.create_compute_pipeline(&wgpu::ComputePipelineDescriptor {
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

        if let Some(e) = pollster::block_on(memory_scope.pop()) {
            return Err(ViewerError::Gpu(e.to_string()));
        }
        if let Some(e) = pollster::block_on(scope.pop()) {
            return Err(ViewerError::Gpu(e.to_string()));
        }

        let mut lights = scene.lights().to_vec();
        let shadow_light = match settings.shadows {
            None => None,
            Some(ShadowSettings { light: Some(k), .. }) => {
                if k >= lights.len() || lights[k].shadow_source().is_none() {
                    return Err(ViewerError::Invalid(format!(
                        "shadow light {k} is not a light that casts shadows"
                    )));
                }
                Some(k)
            }
            Some(ShadowSettings { light: None, .. }) => scene.dominant_light(),
        };
        // Keep the brightest lights if there are more than the shaders take (ambient lights
        // first, they cost nothing), remembering where the shadow light went.
        let shadow_light_value = shadow_light.map(|k| lights[k].clone());
        if lights.len() > MAX_LIGHTS {
            let at = scene.visible_centroid().unwrap_or(DVec3::ZERO);
            lights.sort_by(|a, b| {
                let weight = |l: &LiveLight| {
                    if matches!(l, LiveLight::Ambient { .. }) { f64::INFINITY } else { l.irradiance_at(at) }
                };
                weight(b).total_cmp(&weight(a))
            });
            lights.truncate(MAX_LIGHTS);
        }
        let shadow_light = shadow_light_value.and_then(|v| lights.iter().position(|l| *l == v));
        let tm = scene.tone_map();
        let tone = [tm.gain, 1.0 / tm.gamma, 0.0, 0.0];

        Ok(Compositor {
            gpu: gpu.clone(),
            projection,
            settings,
            width,
            height,
            lights,
            shadow_light,
            tone,
            window_depths,
            surface_bounds,
            image: scene.image().clone(),
            frame_view: view(&frame_texture),
            frame_texture,
            mask_view: view(&mask_texture),
            mask_texture,
            depth_view,
            frame_uniform,
            frame_bind_group,
            mesh_layout,
            mesh_uniform,
            mesh_uniform_capacity,
            mesh_uniform_stride,
            mesh_bind_group,
            meshes: Vec::new(),
            points: None,
            backdrop_points,
            backdrop_fullscreen,
            shadow_pipeline,
            sphere_pipeline,
            mesh_pipeline,
            readback_pipeline,
            readback_bind_group,
            depth_storage,
        })
    }

    fn make_mesh_uniform(device: &wgpu::Device, size: u64) -> wgpu::Buffer {
        device.create_buffer(&wgpu::BufferDescriptor {
            label: Some("mesh uniforms"),
            size,
            usage: wgpu::BufferUsages::UNIFORM | wgpu::BufferUsages::COPY_DST,
            mapped_at_creation: false,
        })
    }

    fn make_mesh_bind_group(
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

    pub fn gpu(&self) -> &Gpu {
        &self.gpu
    }

    pub fn projection(&self) -> &Projection {
        &self.projection
    }

    pub fn settings(&self) -> &CompositorSettings {
        &self.settings
    }

    pub fn size(&self) -> (u32, u32) {
        (self.width, self.height)
    }

    pub fn mode(&self) -> CompositeMode {
        self.settings.mode
    }

    pub fn set_mode(&mut self, mode: CompositeMode) {
        self.settings.mode = mode;
    }

    /// The index (into the scene's lights, after any trimming to [`MAX_LIGHTS`]) of the light
    /// that casts the sphere's shadow, if shadows are on.
    pub fn shadow_light(&self) -> Option<usize> {
        self.shadow_light
    }

    /// The composited frame's colour texture (for presenting it).
    pub fn frame_view(&self) -> &wgpu::TextureView {
        &self.frame_view
    }

    /// Window depths of the pre-rendered pixels, as the compositor writes them.
    pub fn backdrop_window_depths(&self) -> &[f32] {
        &self.window_depths
    }

    fn ensure_points(&mut self) -> Result<(), ViewerError> {
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
            .zip(self.image.pixels.chunks_exact(4))
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

    fn mesh_index(&mut self, mesh: &Arc<Mesh>) -> Result<usize, ViewerError> {
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
        };
        self.meshes.push(gpu_mesh);
        Ok(self.meshes.len() - 1)
    }

    /// The uniform block for this frame: live objects and lights moved to camera space in f64.
    fn frame_uniform(&self, live: &LiveObjects) -> FrameUniform {
        let camera = self.projection.camera();
        let camera_from_world = camera.camera_from_world();
        let linear = DMat3::from_mat4(camera_from_world);
        // The camera transform's uniform scale (1 for a rigid camera, mirrors included).
        let scale = linear.determinant().abs().cbrt();
        let point = |p: DVec3| camera_from_world.transform_point3(p);
        let direction = |d: DVec3| (linear * d).normalize_or_zero();
        let sw = camera.screen_window();
        let (tan_half, perspective) = match camera.tan_half_fov() {
            Some(t) => (t as f32, 1.0),
            None => (0.0, 0.0),
        };
        let mut lights = [GpuLight::default(); MAX_LIGHTS];
        for (slot, light) in lights.iter_mut().zip(&self.lights) {
            *slot = match light {
                LiveLight::Ambient { colour } => GpuLight {
                    position: [0.0, 0.0, 0.0, 0.0],
                    colour: colour.extend(0.0).to_array(),
                    ..Default::default()
                },
                LiveLight::Distant { direction: d, colour } => GpuLight {
                    position: [0.0, 0.0, 0.0, 1.0],
                    direction: vec4(direction(*d), 0.0),
                    colour: colour.extend(0.0).to_array(),
                    ..Default::default()
                },
                LiveLight::Point { position, colour } => GpuLight {
                    position: vec4(point(*position), 2.0),
                    colour: colour.extend(0.0).to_array(),
                    ..Default::default()
                },
                LiveLight::Spot {
                    position,
                    axis,
                    colour,
                    cone_angle,
                    cone_delta_angle,
                    beam_distribution,
                } => GpuLight {
                    position: vec4(point(*position), 3.0),
                    direction: vec4(direction(*axis), 0.0),
                    colour: colour.extend(0.0).to_array(),
                    params: [
                        cone_angle.cos(),
                        (cone_angle - cone_delta_angle).cos(),
                        *beam_distribution,
                        0.0,
                    ],
                },
                LiveLight::Area { centroid, normal, two_sided, radiance, area, .. } => GpuLight {
                    position: vec4(point(*centroid), 4.0),
                    direction: vec4(
                        normal.map(direction).unwrap_or(DVec3::ZERO),
                        if *two_sided { 1.0 } else { 0.0 },
                    ),
                    colour: (*radiance * (*area * scale * scale) as f32)
                        .extend(if normal.is_some() { 1.0 } else { 0.0 })
                        .to_array(),
                    ..Default::default()
                },
            };
        }
        let sphere =
            live.sphere.as_ref().filter(|s| s.radius > 0.0 && s.radius.is_finite() && s.centre.is_finite());
        let (sphere_vec, sphere_material) = match sphere {
            Some(s) => (vec4(point(s.centre), (s.radius * scale) as f32), GpuMaterial::from(&s.material)),
            None => ([0.0; 4], GpuMaterial::default()),
        };
        let (shadow_on, shadow_light, shadow_params) =
            match (self.shadow_light, self.settings.shadows, sphere) {
                (Some(k), Some(settings), Some(_)) => match self.lights[k].shadow_source() {
                    Some(ShadowSource::Point { position, radius }) => (
                        1,
                        vec4(point(position), 1.0),
                        [(radius * scale) as f32, settings.strength, 0.0, 0.0],
                    ),
                    Some(ShadowSource::Direction(d)) => {
                        (1, vec4(direction(d), 0.0), [0.0, settings.strength, 0.0, 0.0])
                    }
                    None => (0, [0.0; 4], [0.0; 4]),
                },
                _ => (0, [0.0; 4], [0.0; 4]),
            };
        FrameUniform {
            clip_from_camera: mat4_f32(self.projection.clip_from_camera()),
            clip_from_raster: mat4_f32(self.projection.clip_from_raster()),
            screen_window: [sw.left as f32, sw.right as f32, sw.bottom as f32, sw.top as f32],
            raster: [self.width as f32, self.height as f32, tan_half, perspective],
            tone: self.tone,
            counts: [self.lights.len().min(MAX_LIGHTS) as u32, shadow_on, u32::from(sphere.is_some()), 0],
            shadow_light,
            shadow_params,
            sphere: sphere_vec,
            sphere_material,
            lights,
        }
    }

    /// The pixels the sphere's shadow can fall on: the screen bounds of the shadow volume (the
    /// sphere's outer penumbra cone from the light, cut where it leaves the bounds of the
    /// visible surfaces), or the whole image when that volume reaches behind the eye. `None`
    /// when no visible surface can be in the shadow.
    fn shadow_scissor(&self, uniform: &FrameUniform) -> Option<[u32; 4]> {
        let full = Some([0, 0, self.width, self.height]);
        let (lo, hi) = self.surface_bounds?;
        let d = |a: [f32; 4]| DVec3::new(f64::from(a[0]), f64::from(a[1]), f64::from(a[2]));
        let centre = d(uniform.sphere);
        let r = f64::from(uniform.sphere[3]);
        let light = d(uniform.shadow_light);
        let light_radius = f64::from(uniform.shadow_params[0]);
        let corners = (0..8).map(|k| {
            DVec3::new(
                if k & 1 == 0 { lo.x } else { hi.x },
                if k & 2 == 0 { lo.y } else { hi.y },
                if k & 4 == 0 { lo.z } else { hi.z },
            )
        });
        // Cross-section discs (centre, radius) at the near end and the far end of the volume.
        let (axis, discs) = if uniform.shadow_light[3] > 0.5 {
            let to_sphere = centre - light;
            let d_s = to_sphere.length();
            if d_s <= r * 1.01 {
                return full;
            }
            let axis = to_sphere / d_s;
            let far = corners.map(|c| (c - light).length()).fold(0.0, f64::max);
            let near = d_s - r;
            if far <= near {
                return None;
            }
            let tan_half = r / (d_s * d_s - r * r).sqrt();
            let radius = |x: f64| (x * tan_half + light_radius * (x - d_s).max(0.0) / d_s) * 1.05 + r * 0.01;
            (axis, [(light + axis * near, radius(d_s)), (light + axis * far, radius(far))])
        } else {
            let axis = light.normalize_or_zero();
            let far = corners.map(|c| (c - centre).dot(axis)).fold(f64::NEG_INFINITY, f64::max);
            if far <= -r {
                return None;
            }
            (axis, [(centre - axis * r, r * 1.05), (centre + axis * far, r * 1.05)])
        };
        let u = axis.any_orthonormal_vector();
        let v = axis.cross(u);
        let clip_from_camera = self.projection.clip_from_camera();
        let (mut x0, mut y0, mut x1, mut y1) =
            (f64::INFINITY, f64::INFINITY, f64::NEG_INFINITY, f64::NEG_INFINITY);
        for (c, radius) in discs {
            for (a, b) in [(-1.0, -1.0), (1.0, -1.0), (1.0, 1.0), (-1.0, 1.0)] {
                let p = c + (u * a + v * b) * radius;
                let clip = clip_from_camera * p.extend(1.0);
                if clip.w.is_nan() || clip.w <= 1e-9 {
                    return full;
                }
                let x = (clip.x / clip.w + 1.0) * 0.5 * f64::from(self.width);
                let y = (1.0 - clip.y / clip.w) * 0.5 * f64::from(self.height);
                (x0, y0, x1, y1) = (x0.min(x), y0.min(y), x1.max(x), y1.max(y));
            }
        }
        let clamp_x = |v: f64| v.clamp(0.0, f64::from(self.width)) as u32;
        let clamp_y = |v: f64| v.clamp(0.0, f64::from(self.height)) as u32;
        let (ix0, iy0) = (clamp_x(x0.floor() - 1.0), clamp_y(y0.floor() - 1.0));
        let (ix1, iy1) = (clamp_x(x1.ceil() + 1.0), clamp_y(y1.ceil() + 1.0));
        (ix1 > ix0 && iy1 > iy0).then_some([ix0, iy0, ix1 - ix0, iy1 - iy0])
    }

    /// Draws one frame into the offscreen targets and submits it. Does not wait for the GPU.
    pub fn render(&mut self, live: &LiveObjects) -> Result<(), ViewerError> {
        if self.settings.mode == CompositeMode::Points {
            self.ensure_points()?;
        }
        let uniform = self.frame_uniform(live);
        self.gpu.queue.write_buffer(&self.frame_uniform, 0, bytemuck::bytes_of(&uniform));

        // Meshes: register new ones, then one uniform slot per instance.
        let mut draws = Vec::with_capacity(live.meshes.len());
        for instance in &live.meshes {
            if !instance.world_from_object.is_finite() {
                continue;
            }
            draws.push(self.mesh_index(&instance.mesh)?);
        }
        if !draws.is_empty() {
            let needed = draws.len() as u64;
            if needed > self.mesh_uniform_capacity {
                self.mesh_uniform_capacity = needed.next_power_of_two();
                self.mesh_uniform = Self::make_mesh_uniform(
                    &self.gpu.device,
                    self.mesh_uniform_capacity * self.mesh_uniform_stride,
                );
                self.mesh_bind_group =
                    Self::make_mesh_bind_group(&self.gpu.device, &self.mesh_layout, &self.mesh_uniform);
            }
            let camera_from_world = self.projection.camera().camera_from_world();
            let mut bytes = vec![0u8; (needed * self.mesh_uniform_stride) as usize];
            for (slot, instance) in live.meshes.iter().filter(|m| m.world_from_object.is_finite()).enumerate()
            {
                let camera_from_object = camera_from_world * instance.world_from_object;
                let normal = DMat3::from_mat4(camera_from_object).inverse().transpose();
                let u = MeshUniform {
                    camera_from_object: mat4_f32(camera_from_object),
                    normal_from_object: Mat4::from_mat3(normal.as_mat3()).to_cols_array_2d(),
                    material: GpuMaterial::from(&instance.material),
                };
                let at = slot * self.mesh_uniform_stride as usize;
                bytes[at..at + std::mem::size_of::<MeshUniform>()].copy_from_slice(bytemuck::bytes_of(&u));
            }
            self.gpu.queue.write_buffer(&self.mesh_uniform, 0, &bytes);
        }

        let mut encoder =
            self.gpu.device.create_command_encoder(&wgpu::CommandEncoderDescriptor { label: Some("frame") });
        {
            let far = self.settings.depth.convention.far_window_depth();
            let mut pass = encoder.begin_render_pass(&wgpu::RenderPassDescriptor {
                label: Some("composite"),
                color_attachments: &[
                    Some(wgpu::RenderPassColorAttachment {
                        view: &self.frame_view,
                        depth_slice: None,
                        resolve_target: None,
                        ops: wgpu::Operations {
                            load: wgpu::LoadOp::Clear(wgpu::Color::BLACK),
                            store: wgpu::StoreOp::Store,
                        },
                    }),
                    Some(wgpu::RenderPassColorAttachment {
                        view: &self.mask_view,
                        depth_slice: None,
                        resolve_target: None,
                        ops: wgpu::Operations {
                            load: wgpu::LoadOp::Clear(wgpu::Color::TRANSPARENT),
                            store: wgpu::StoreOp::Store,
                        },
                    }),
                ],
                depth_stencil_attachment: Some(wgpu::RenderPassDepthStencilAttachment {
                    view: &self.depth_view,
                    depth_ops: Some(wgpu::Operations {
                        load: wgpu::LoadOp::Clear(far),
                        store: wgpu::StoreOp::Store,
                    }),
                    stencil_ops: None,
                }),
                timestamp_writes: None,
                occlusion_query_set: None,
                multiview_mask: None,
            });
            pass.set_bind_group(0, &self.frame_bind_group, &[]);
            match (self.settings.mode, &self.points) {
                (CompositeMode::Points, Some(points)) => {
                    pass.set_pipeline(&self.backdrop_points);
                    pass.set_vertex_buffer(0, points.slice(..));
                    pass.draw(0..self.width * self.height, 0..1);
                }
                _ => {
                    pass.set_pipeline(&self.backdrop_fullscreen);
                    pass.draw(0..3, 0..1);
                }
            }
            if uniform.counts[1] == 1
                && let Some([x, y, w, h]) = self.shadow_scissor(&uniform)
            {
                pass.set_scissor_rect(x, y, w, h);
                pass.set_pipeline(&self.shadow_pipeline);
                pass.draw(0..3, 0..1);
                pass.set_scissor_rect(0, 0, self.width, self.height);
            }
            if !draws.is_empty() {
                pass.set_pipeline(&self.mesh_pipeline);
                for (slot, &k) in draws.iter().enumerate() {
                    let mesh = &self.meshes[k];
                    let offset = (slot as u64 * self.mesh_uniform_stride) as u32;
                    pass.set_bind_group(1, &self.mesh_bind_group, &[offset]);
                    pass.set_vertex_buffer(0, mesh.vertices.slice(..));
                    pass.set_index_buffer(mesh.indices.slice(..), wgpu::IndexFormat::Uint32);
                    pass.draw_indexed(0..mesh.index_count, 0, 0..1);
                }
            }
            if uniform.counts[2] == 1 {
                pass.set_pipeline(&self.sphere_pipeline);
                pass.draw(0..36, 0..1);
            }
        }
        self.gpu.queue.submit([encoder.finish()]);
        self.gpu.take_errors()
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
