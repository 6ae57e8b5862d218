//! The compositor's own render pipelines over the frame's targets (the linear frame and the
//! mask, with the depth buffer): the backdrop written as points or as one full-screen
//! triangle, the layered shadows' full-screen pass, the cursor sphere's impostor (shaded per
//! fragment, and from its radiance map in a moving frame: cursor_radiance_map.rs) and live
//! meshes. The passes with targets of their own build their pipelines in their own files.

use super::MASK_FORMAT;
use super::backdrop_points::PointVertex;
use super::live_objects::MeshVertex;

/// What the pipelines are built from: the compositing module, its two pipeline layouts (the
/// frame's bind group alone, and with a live mesh's), the frame's formats and the depth test
/// that keeps the nearer fragment.
pub(super) struct PipelineSetup<'a> {
    pub device: &'a wgpu::Device,
    pub module: &'a wgpu::ShaderModule,
    pub frame_only: &'a wgpu::PipelineLayout,
    pub with_mesh: &'a wgpu::PipelineLayout,
    pub linear_format: wgpu::TextureFormat,
    pub depth_format: wgpu::TextureFormat,
    pub nearer: wgpu::CompareFunction,
}

/// The pipelines of [`PipelineSetup`]'s module the frame pass draws with.
pub(super) struct FramePipelines {
    pub backdrop_points: wgpu::RenderPipeline,
    pub backdrop_fullscreen: wgpu::RenderPipeline,
    pub shadow: wgpu::RenderPipeline,
    pub sphere: wgpu::RenderPipeline,
    pub sphere_mapped: wgpu::RenderPipeline,
    pub mesh: wgpu::RenderPipeline,
}

impl FramePipelines {
    pub(super) fn new(setup: &PipelineSetup<'_>) -> FramePipelines {
        let PipelineSetup { device, module, frame_only, with_mesh, linear_format, depth_format, nearer } =
            *setup;
        let depth_state = |compare: wgpu::CompareFunction, write: bool| wgpu::DepthStencilState {
            format: depth_format,
            depth_write_enabled: Some(write),
            depth_compare: Some(compare),
            stencil: wgpu::StencilState::default(),
            bias: wgpu::DepthBiasState::default(),
        };
        let write_all = [
            Some(wgpu::ColorTargetState {
                format: linear_format,
                blend: None,
                write_mask: wgpu::ColorWrites::ALL,
            }),
            Some(wgpu::ColorTargetState {
                format: MASK_FORMAT,
                blend: None,
                write_mask: wgpu::ColorWrites::ALL,
            }),
        ];
        let point_attributes = wgpu::vertex_attr_array![0 => Float32x3, 1 => Float32x4];
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
                    module,
                    entry_point: Some(vs),
                    compilation_options: Default::default(),
                    buffers,
                },
                primitive,
                depth_stencil: Some(depth),
                multisample: wgpu::MultisampleState::default(),
                fragment: Some(wgpu::FragmentState {
                    module,
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
            frame_only,
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
            frame_only,
            "vs_fullscreen",
            "fs_backdrop_fullscreen",
            &[],
            triangles,
            depth_state(wgpu::CompareFunction::Always, true),
            &write_all,
        );
        let shadow_pipeline = pipeline(
            "shadow",
            frame_only,
            "vs_fullscreen",
            "fs_shadow",
            &[],
            triangles,
            depth_state(wgpu::CompareFunction::Always, false),
            &[
                // The shadow pass writes the darkened backdrop itself: 32-bit float targets
                // cannot blend everywhere.
                Some(wgpu::ColorTargetState {
                    format: linear_format,
                    blend: None,
                    write_mask: wgpu::ColorWrites::COLOR,
                }),
                Some(wgpu::ColorTargetState {
                    format: MASK_FORMAT,
                    blend: None,
                    write_mask: wgpu::ColorWrites::empty(),
                }),
            ],
        );
        // The cursor sphere's impostor, shaded per fragment or read from its map: the same proxy
        // geometry, culling and depth test either way.
        let sphere = |label: &str, fs: &str| {
            let front_faces = wgpu::PrimitiveState {
                front_face: wgpu::FrontFace::Ccw,
                cull_mode: Some(wgpu::Face::Front),
                ..Default::default()
            };
            pipeline(
                label,
                frame_only,
                "vs_sphere",
                fs,
                &[],
                front_faces,
                depth_state(nearer, true),
                &write_all,
            )
        };
        let sphere_pipeline = sphere("sphere impostor", "fs_sphere");
        // A moving frame's cursor sphere from its radiance map (cursor_radiance_map.rs).
        let sphere_mapped_pipeline = sphere("sphere impostor from its radiance map", "fs_sphere_mapped");
        let mesh_pipeline = pipeline(
            "live mesh",
            with_mesh,
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

        FramePipelines {
            backdrop_points,
            backdrop_fullscreen,
            shadow: shadow_pipeline,
            sphere: sphere_pipeline,
            sphere_mapped: sphere_mapped_pipeline,
            mesh: mesh_pipeline,
        }
    }
}
