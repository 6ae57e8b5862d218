//! The GPU compositor: the pre-rendered image and its depth, then live objects, into an
//! offscreen frame (colour, live-object mask and depth) that can be read back or presented.

mod antialias;
mod backdrop_points;
mod bindings;
mod bounce;
mod caustic_shadow;
mod cursor_radiance_map;
mod drawn_from;
mod encode;
mod frame;
mod irradiance;
mod layers;
mod lighting;
mod live_objects;
mod loss_map;
mod near_field;
mod near_field_map;
mod overlay;
mod pass_timing;
mod pipelines;
mod readback;
mod reduced_gather;
mod reflections;
mod scene_shadows;
mod settings;
mod settle;
mod settle_sphere;
mod shadow_bounce;
mod shadows;
mod specular;
mod sphere_atlas;
mod transmission;

pub use cursor_radiance_map::CURSOR_RADIANCE_TEXELS as MOVING_SPHERE_MAP_TEXELS;
pub use pass_timing::{PassTime, process_cpu_time};
pub use readback::{FrameReadback, LinearFrame, is_exr_path};
pub use reduced_gather::{
    BOUNCE_STRIDE as MOVING_BOUNCE_STRIDE, LOSS_STRIDE as MOVING_LOSS_STRIDE,
    SHADOW_STRIDE as MOVING_SHADOW_STRIDE,
};
pub use settings::{
    CompositeMode, CompositorSettings, DepthSettings, FRAME_FORMAT, LINEAR_FORMAT, LINEAR_FORMAT_FALLBACK,
    MASK_FORMAT, MAX_LIGHTS, ShadowSettings, linear_format,
};
pub use settle::{SETTLE_PIXELS, SETTLE_REFLECTION_PIXELS, SETTLE_SHADOW_PIXELS};
pub use settle_sphere::SETTLE_SPHERE_PIXELS;
pub use shadow_bounce::TAKEN_BANDS as SHADOW_BOUNCE_BANDS;

use crate::error::ViewerError;
use crate::gpu::Gpu;
use crate::live::LiveLight;
use crate::projection::{Projection, nearer};
use crate::scene::ViewerScene;
use glam::DVec3;

use drawn_from::DrawnFrom;
use lighting::{FrameUniform, MeshUniform};
use live_objects::GpuMesh;
use shadows::camera_space_bounds;
use sphere_atlas::colour_pass;

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
    /// The image's pixel filter, over whose footprint live objects' direct light is integrated.
    pixel_filter: crate::pixel_filter::PixelFilter,
    /// The light layers on the GPU (a placeholder without them).
    layers: layers::GpuLayers,
    /// The renderer's irradiance probes on the GPU (placeholders without them): live objects'
    /// diffuse light from the scene.
    irradiance: irradiance::GpuIrradiance,
    /// The renderer's reflection probes on the GPU (placeholders without them).
    reflections: reflections::GpuReflections,
    /// Shadow-ray hierarchies of the scene (its shadows on live objects) and the live meshes.
    occluders: scene_shadows::GpuOccluders,
    /// Window depth of every pixel, kept to build the point cloud on demand.
    window_depths: Vec<f32>,
    /// Camera-space bounds of every visible pre-rendered surface point (bounds the shadow pass).
    surface_bounds: Option<(DVec3, DVec3)>,
    /// The pre-rendered image's linear RGBA (kept to build the point cloud on demand).
    linear_image: Vec<f32>,
    /// The displayed frame (8-bit), written by the encode pass.
    frame_texture: wgpu::Texture,
    frame_view: wgpu::TextureView,
    /// The composited frame in linear values, before display encoding.
    linear_texture: wgpu::Texture,
    linear_view: wgpu::TextureView,
    linear_format: wgpu::TextureFormat,
    encode: encode::EncodePass,
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
    /// The cursor sphere read from its radiance map (a moving frame's, `cursor_radiance_map.rs`).
    sphere_mapped_pipeline: wgpu::RenderPipeline,
    mesh_pipeline: wgpu::RenderPipeline,
    readback_pipeline: wgpu::ComputePipeline,
    readback_bind_group: wgpu::BindGroup,
    depth_storage: wgpu::Buffer,
    /// The frame after shadows, before live objects (copied each frame with live objects).
    shadowed_texture: wgpu::Texture,
    /// The inputs `shadowed_texture` holds the backdrop after shadows, bounce light and second
    /// bounce of in full (empty: none): a frame with the same inputs copies it back instead of
    /// drawing them again.
    shadowed_from: DrawnFrom,
    /// The inputs (and compositing mode) of the last exact frame, which the frame's targets
    /// still hold (empty: none): a frame at rest with the same inputs is that frame (frame.rs).
    finished_from: DrawnFrom,
    /// The live spheres' own-shadow loss maps (binding 14).
    loss_maps: loss_map::LossMaps,
    /// The live spheres' near field and traced glossy lobes (binding 32).
    near_field_maps: near_field_map::NearFieldMaps,
    /// The light live spheres reflect onto the scene: their radiosity maps (binding 15) and
    /// the pass that adds it.
    bounce: bounce::Bounce,
    /// A moving cursor sphere's radiance over its half facing the eye (binding 33).
    cursor_radiance: cursor_radiance_map::CursorRadianceMap,
    /// The live spheres seen in the scene's specular reflections, and through its glass.
    specular: specular::SpecularReflections,
    transmission: Option<transmission::Transmission>,
    /// The light the shadows take from the rest of the scene: its clusters (binding 16), what
    /// each pixel loses (binding 17) and the passes that draw and remove it.
    shadow_bounce: shadow_bounce::ShadowBounce,
    /// Live objects' edges at four samples per pixel, filtered (`None`: off, for the reason
    /// in `antialias_off`).
    antialias: Option<antialias::Antialias>,
    antialias_off: Option<String>,
    /// A moving frame's bounce light and second bounce at reduced resolution (binding 22).
    reduced: reduced_gather::ReducedGather,
    /// Each pass's time, when frames are timed (`set_pass_timing`).
    pass_timing: pass_timing::PassTiming,
    /// What the live spheres take from the caustics (binding 30).
    caustic_shadow: caustic_shadow::CausticShadow,
}

/// The compositing shaders: one module from the files of its parts (WGSL has no includes).
pub(super) const COMPOSITE_WGSL: &str = concat!(
    include_str!("../shaders/composite.wgsl"),
    include_str!("../shaders/probes.wgsl"),
    include_str!("../shaders/shadow_loss.wgsl"),
    include_str!("../shaders/shadows.wgsl"),
    include_str!("../shaders/shadow_footprint.wgsl"),
    include_str!("../shaders/scene_visibility.wgsl"),
    include_str!("../shaders/near_field.wgsl"),
    include_str!("../shaders/bounce.wgsl"),
    include_str!("../shaders/cursor_radiance.wgsl"),
    include_str!("../shaders/specular.wgsl"),
    include_str!("../shaders/transmission.wgsl"),
    include_str!("../shaders/shadow_bounce.wgsl"),
    include_str!("../shaders/reduced_gather.wgsl"),
    include_str!("../shaders/specular_chain.wgsl"),
);

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
        let linear_format = linear_format(&gpu.adapter).ok_or_else(|| {
            ViewerError::Unsupported("neither Rgba32Float nor Rgba16Float can be rendered to".into())
        })?;
        // With half-float targets, the backdrop is rounded to half precision up front so that
        // writing it into the frame changes nothing and unchanged pixels still compare equal.
        let linear_image: Vec<f32> = if linear_format == LINEAR_FORMAT {
            scene.backdrop().linear.clone()
        } else {
            scene
                .backdrop()
                .linear
                .iter()
                .map(|&v| half::f16::from_f32(v.clamp(-65504.0, 65504.0)).to_f32())
                .collect()
        };

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
        // first, they cost nothing), remembering where the shadow light went and which scene
        // light each kept one is (for its light layer).
        let mut kept: Vec<usize> = (0..lights.len()).collect();
        if lights.len() > MAX_LIGHTS {
            let at = scene.visible_centroid().unwrap_or(DVec3::ZERO);
            let weight = |l: &LiveLight| {
                if matches!(l, LiveLight::Ambient { .. }) { f64::INFINITY } else { l.irradiance_at(at) }
            };
            kept.sort_by(|&a, &b| weight(&lights[b]).total_cmp(&weight(&lights[a])));
            kept.truncate(MAX_LIGHTS);
        }
        let shadow_light = shadow_light.and_then(|k| kept.iter().position(|&x| x == k));
        let two_sided: Vec<bool> =
            lights.iter().map(|l| matches!(l, LiveLight::Area { two_sided: true, .. })).collect();
        lights = kept.iter().map(|&k| lights[k].clone()).collect();

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
        let mask_texture =
            texture("mask", MASK_FORMAT, U::RENDER_ATTACHMENT | U::COPY_SRC | U::TEXTURE_BINDING);
        let depth_texture = texture("depth", depth_format, U::RENDER_ATTACHMENT | U::TEXTURE_BINDING);
        let linear_texture = texture(
            "linear frame",
            linear_format,
            U::RENDER_ATTACHMENT | U::COPY_SRC | U::COPY_DST | U::TEXTURE_BINDING,
        );
        let colour_texture = texture("backdrop colour", LINEAR_FORMAT, U::TEXTURE_BINDING | U::COPY_DST);
        // The frame after shadows, before live objects: what the shadows took, for the live
        // objects' own shading and the antialiased edges' backdrop.
        let shadowed_texture =
            texture("backdrop after shadows", linear_format, U::TEXTURE_BINDING | U::COPY_DST | U::COPY_SRC);
        let display_texture = texture("backdrop display", FRAME_FORMAT, U::TEXTURE_BINDING | U::COPY_DST);
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
        upload(&colour_texture, bytemuck::cast_slice(&linear_image), 16);
        upload(&display_texture, &scene.backdrop().display.pixels, 4);
        upload(&window_depth_texture, bytemuck::cast_slice(&window_depths), 4);
        // The GPU sees `inf` as a huge finite number on some backends; store misses as f32::MAX.
        let radial: Vec<f32> =
            scene.depth().values().iter().map(|&r| if r.is_finite() { r } else { f32::MAX }).collect();
        upload(&radial_texture, bytemuck::cast_slice(&radial), 4);

        let frame_uniform = device.create_buffer(&wgpu::BufferDescriptor {
            label: Some("frame uniform"),
            size: std::mem::size_of::<FrameUniform>() as u64,
            usage: wgpu::BufferUsages::STORAGE | wgpu::BufferUsages::COPY_DST,
            mapped_at_creation: false,
        });
        let frame_layout = bindings::frame_layout(device);
        // Layers serve only shadows: without shadows a placeholder keeps the bind group valid.
        let bound_layers = scene.light_layers().filter(|_| settings.shadows.is_some());
        let gpu_layers =
            layers::upload(gpu, &projection, bound_layers, &kept, &lights, &two_sided, (width, height));
        let gpu_reflections = reflections::upload(gpu, scene.reflections());
        let gpu_irradiance =
            irradiance::upload(gpu, scene.probes_arc().as_deref(), &lights, &gpu_layers.world_samples);
        let occluders = scene_shadows::upload(
            device,
            &gpu.queue,
            scene.occluders(),
            scene.occluder_materials(),
            projection.camera().camera_from_world(),
        );
        let scene_materials = near_field::upload(device, scene.occluder_materials());
        let view = |t: &wgpu::Texture| t.create_view(&wgpu::TextureViewDescriptor::default());
        let loss_map_textures = sphere_atlas::sphere_map_atlas(
            device,
            "own-shadow loss maps",
            loss_map::ATLAS_FORMAT,
            loss_map::LOSS_MAP_TEXELS,
        );
        let radiosity_map_textures = bounce::radiosity_atlas(device);
        let near_field_map_textures = near_field_map::near_field_atlas(device);
        let cursor_radiance_textures = cursor_radiance_map::cursor_radiance_textures(device, linear_format);
        let shadow_bounce_textures =
            shadow_bounce::ShadowBounceTextures::new(device, (width, height), linear_format);
        let reduced_grid = reduced_gather::grid_textures(device, (width, height), linear_format);
        let spread_weights = reduced_gather::SpreadWeights::new(device, (width, height));
        let caustic_shadow =
            caustic_shadow::CausticShadow::new(device, scene.caustics_arc(), (width, height));
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
                wgpu::BindGroupEntry {
                    binding: 4,
                    resource: wgpu::BindingResource::TextureView(&gpu_layers.view),
                },
                wgpu::BindGroupEntry { binding: 5, resource: gpu_layers.samples.as_entire_binding() },
                wgpu::BindGroupEntry {
                    binding: 6,
                    resource: wgpu::BindingResource::TextureView(&gpu_reflections.radiance),
                },
                wgpu::BindGroupEntry {
                    binding: 7,
                    resource: wgpu::BindingResource::TextureView(&gpu_reflections.distance),
                },
                wgpu::BindGroupEntry {
                    binding: 8,
                    resource: wgpu::BindingResource::Sampler(&gpu_reflections.sampler),
                },
                wgpu::BindGroupEntry { binding: 9, resource: gpu_irradiance.sh.as_entire_binding() },
                wgpu::BindGroupEntry { binding: 10, resource: gpu_irradiance.visibility.as_entire_binding() },
                wgpu::BindGroupEntry {
                    binding: 11,
                    resource: wgpu::BindingResource::TextureView(&view(&shadowed_texture)),
                },
                wgpu::BindGroupEntry { binding: 12, resource: occluders.nodes.as_entire_binding() },
                wgpu::BindGroupEntry { binding: 13, resource: occluders.triangles.as_entire_binding() },
                wgpu::BindGroupEntry {
                    binding: 14,
                    resource: wgpu::BindingResource::TextureView(&loss_map_textures.read_view),
                },
                wgpu::BindGroupEntry {
                    binding: 15,
                    resource: wgpu::BindingResource::TextureView(&radiosity_map_textures.read_view),
                },
                wgpu::BindGroupEntry {
                    binding: 16,
                    resource: wgpu::BindingResource::TextureView(&shadow_bounce_textures.clusters.read_view),
                },
                wgpu::BindGroupEntry {
                    binding: 17,
                    resource: wgpu::BindingResource::TextureView(&shadow_bounce_textures.taken.read_view),
                },
                wgpu::BindGroupEntry {
                    binding: 22,
                    resource: wgpu::BindingResource::TextureView(&reduced_grid.read_view),
                },
                wgpu::BindGroupEntry {
                    binding: 30,
                    resource: wgpu::BindingResource::TextureView(&caustic_shadow.view()),
                },
                wgpu::BindGroupEntry { binding: 31, resource: scene_materials.as_entire_binding() },
                wgpu::BindGroupEntry {
                    binding: 32,
                    resource: wgpu::BindingResource::TextureView(&near_field_map_textures.read_view),
                },
                wgpu::BindGroupEntry {
                    binding: 33,
                    resource: wgpu::BindingResource::TextureView(&cursor_radiance_textures.read_view),
                },
                wgpu::BindGroupEntry {
                    binding: 34,
                    resource: wgpu::BindingResource::TextureView(&spread_weights.read_view),
                },
            ],
        });
        let mesh_layout = device.create_bind_group_layout(&wgpu::BindGroupLayoutDescriptor {
            label: Some("mesh"),
            entries: &[wgpu::BindGroupLayoutEntry {
                binding: 0,
                visibility: wgpu::ShaderStages::VERTEX | wgpu::ShaderStages::FRAGMENT,
                ty: wgpu::BindingType::Buffer {
                    ty: wgpu::BufferBindingType::Storage { read_only: true },
                    has_dynamic_offset: true,
                    min_binding_size: wgpu::BufferSize::new(std::mem::size_of::<MeshUniform>() as u64),
                },
                count: None,
            }],
        });
        let mesh_uniform_stride = align_up(
            std::mem::size_of::<MeshUniform>() as u64,
            u64::from(limits.min_storage_buffer_offset_alignment),
        );
        let mesh_uniform_capacity = 4;
        let mesh_uniform = Self::make_mesh_uniform(device, mesh_uniform_capacity * mesh_uniform_stride);
        let mesh_bind_group = Self::make_mesh_bind_group(device, &mesh_layout, &mesh_uniform);

        let module = device.create_shader_module(wgpu::ShaderModuleDescriptor {
            label: Some("composite shaders"),
            source: wgpu::ShaderSource::Wgsl(COMPOSITE_WGSL.into()),
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
        let loss_maps = loss_map::LossMaps::new(device, loss_map_textures, &module, &with_mesh);
        let near_field_maps =
            near_field_map::NearFieldMaps::new(device, near_field_map_textures, &module, &with_mesh, scene);
        let cursor_radiance = cursor_radiance_map::CursorRadianceMap::new(
            device,
            (cursor_radiance_textures, linear_format),
            &module,
            &frame_only,
        );
        let bounce = bounce::Bounce::new(
            device,
            radiosity_map_textures,
            &bounce::BounceSetup {
                module: &module,
                frame_only: &frame_only,
                with_mesh: &with_mesh,
                linear_format,
                mask_format: MASK_FORMAT,
                depth_format,
            },
        );
        let specular = specular::SpecularReflections::new(
            device,
            &overlay::Overlay { module: &module, linear_format, mask_format: MASK_FORMAT, depth_format },
            &with_mesh,
            gpu_layers.specular_rect(),
        );
        let formats = (linear_format, depth_format);
        let layouts = [&frame_layout, &mesh_layout];
        let transmission =
            transmission::Transmission::new(gpu, &projection, bound_layers, &module, formats, layouts);
        let shadow_bounce = shadow_bounce::ShadowBounce::new(
            device,
            shadow_bounce_textures,
            &shadow_bounce::ShadowBounceSetup {
                module: &module,
                frame_only: &frame_only,
                linear_format,
                mask_format: MASK_FORMAT,
                depth_format,
            },
        );
        let formats = (linear_format, depth_format);
        let reduced = reduced_gather::ReducedGather::new(
            device,
            (reduced_grid, spread_weights),
            (&module, &frame_only),
            formats,
            settings.occlusion_from_behind,
        );
        let nearer = nearer(settings.depth.convention);
        let pipelines::FramePipelines {
            backdrop_points,
            backdrop_fullscreen,
            shadow: shadow_pipeline,
            sphere: sphere_pipeline,
            sphere_mapped: sphere_mapped_pipeline,
            mesh: mesh_pipeline,
        } = pipelines::FramePipelines::new(&pipelines::PipelineSetup {
            device,
            module: &module,
            frame_only: &frame_only,
            with_mesh: &with_mesh,
            linear_format,
            depth_format,
            nearer,
        });

        let (antialias, antialias_off) = if !settings.antialias {
            (None, Some("turned off".to_string()))
        } else if gpu.adapter.get_info().backend == wgpu::Backend::Gl {
            // wgpu's GLSL output assigns the sample mask with the wrong type (it fails to link,
            // and only after the error scopes have closed), so GL keeps centre samples.
            (
                None,
                Some("the GL backend cannot write the sample mask the sphere's coverage needs".to_string()),
            )
        } else {
            let setup = antialias::AntialiasSetup {
                frame_layout: &frame_layout,
                mesh_layout: &mesh_layout,
                depth_format,
                nearer,
                linear_format,
                mask_view: &view(&mask_texture),
                shadowed_view: &view(&shadowed_texture),
                size: (width, height),
                filter: scene.pixel_filter(),
            };
            match antialias::Antialias::new(device, &setup) {
                Ok(a) => (Some(a), None),
                Err(e) => (
                    None,
                    Some(format!("this adapter cannot draw live objects at four samples per pixel: {e}")),
                ),
            }
        };

        let depth_view = view(&depth_texture);
        let readback::DepthReadback {
            pipeline: readback_pipeline,
            bind_group: readback_bind_group,
            storage: depth_storage,
        } = readback::DepthReadback::new(device, &depth_view, (width, height))?;

        let encode = encode::EncodePass::new(
            gpu,
            &scene.backdrop().encoding,
            width,
            &view(&linear_texture),
            &view(&colour_texture),
            &view(&display_texture),
        );

        if let Some(e) = pollster::block_on(memory_scope.pop()) {
            return Err(ViewerError::Gpu(e.to_string()));
        }
        if let Some(e) = pollster::block_on(scope.pop()) {
            return Err(ViewerError::Gpu(e.to_string()));
        }

        let tm = scene.tone_map();
        // Live radiance into the image's units: `lrt-depth` applies Exposure's gain to all it
        // writes (the display transfer is the encode pass's).
        let tone = [tm.gain, 0.0, 0.0, 0.0];

        Ok(Compositor {
            gpu: gpu.clone(),
            projection,
            settings,
            width,
            height,
            lights,
            shadow_light,
            tone,
            pixel_filter: scene.pixel_filter(),
            layers: gpu_layers,
            irradiance: gpu_irradiance,
            reflections: gpu_reflections,
            occluders,
            window_depths,
            surface_bounds,
            linear_image,
            frame_view: view(&frame_texture),
            frame_texture,
            linear_view: view(&linear_texture),
            linear_texture,
            linear_format,
            encode,
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
            sphere_mapped_pipeline,
            mesh_pipeline,
            readback_pipeline,
            readback_bind_group,
            depth_storage,
            shadowed_texture,
            shadowed_from: DrawnFrom::default(),
            finished_from: DrawnFrom::default(),
            loss_maps,
            near_field_maps,
            bounce,
            cursor_radiance,
            specular,
            transmission,
            shadow_bounce,
            antialias,
            antialias_off,
            reduced,
            pass_timing: pass_timing::PassTiming::default(),
            caustic_shadow,
        })
    }

    /// Why live objects' edges are not antialiased, `None` when they are.
    pub fn antialias_off(&self) -> Option<&str> {
        self.antialias_off.as_deref()
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

    /// The linear frame's format: [`LINEAR_FORMAT`], or [`LINEAR_FORMAT_FALLBACK`] where the
    /// adapter cannot render 32-bit floats (then the linear screenshot has half precision).
    pub fn linear_format(&self) -> wgpu::TextureFormat {
        self.linear_format
    }

    /// The composited frame's colour texture (for presenting it).
    pub fn frame_view(&self) -> &wgpu::TextureView {
        &self.frame_view
    }

    /// Window depths of the pre-rendered pixels, as the compositor writes them.
    pub fn backdrop_window_depths(&self) -> &[f32] {
        &self.window_depths
    }
}
