//! Pipelines that draw over the frame's colour target in place (the bounce light, the spheres
//! seen in specular reflections, the shadows' second bounce): the mask and depth stay as the
//! backdrop left them, so the depth test always passes and nothing but colour is written.
//! Also the full-screen passes those draw from, which fill a target of their own.

/// The full-screen triangle's vertex stage (`vs_fullscreen`).
pub(super) fn fullscreen_vertex(module: &wgpu::ShaderModule) -> wgpu::VertexState<'_> {
    wgpu::VertexState {
        module,
        entry_point: Some("vs_fullscreen"),
        compilation_options: Default::default(),
        buffers: &[],
    }
}

/// A full-screen pass of `layout` that writes the fragment entry point `fragment` into one
/// target of its own (`format`: no depth, no blending), for a pass whose result another reads.
pub(super) fn offscreen_pipeline(
    device: &wgpu::Device,
    module: &wgpu::ShaderModule,
    layout: &wgpu::PipelineLayout,
    (label, fragment): (&str, &str),
    format: wgpu::TextureFormat,
) -> wgpu::RenderPipeline {
    offscreen_pipeline_from(device, layout, fullscreen_vertex(module), (label, fragment), format)
}

/// [`offscreen_pipeline`] with the vertex stage `vertex` (its module also the fragment's), for a
/// pass that needs another full-screen vertex entry point (the glossy lobes' per-sphere draws).
pub(super) fn offscreen_pipeline_from(
    device: &wgpu::Device,
    layout: &wgpu::PipelineLayout,
    vertex: wgpu::VertexState<'_>,
    (label, fragment): (&str, &str),
    format: wgpu::TextureFormat,
) -> wgpu::RenderPipeline {
    let module = vertex.module;
    let targets = [Some(wgpu::ColorTargetState { format, blend: None, write_mask: wgpu::ColorWrites::ALL })];
    device.create_render_pipeline(&wgpu::RenderPipelineDescriptor {
        label: Some(label),
        layout: Some(layout),
        vertex,
        primitive: wgpu::PrimitiveState::default(),
        depth_stencil: None,
        multisample: wgpu::MultisampleState::default(),
        fragment: Some(wgpu::FragmentState {
            module,
            entry_point: Some(fragment),
            compilation_options: Default::default(),
            targets: &targets,
        }),
        multiview_mask: None,
        cache: None,
    })
}

/// The shader module and the frame's target formats an overlay pipeline draws with.
pub(super) struct Overlay<'a> {
    pub(super) module: &'a wgpu::ShaderModule,
    pub(super) linear_format: wgpu::TextureFormat,
    pub(super) mask_format: wgpu::TextureFormat,
    pub(super) depth_format: wgpu::TextureFormat,
}

impl Overlay<'_> {
    /// A pipeline of `layout` running `vertex` and the fragment entry point `fragment` over the
    /// frame's colour target.
    pub(super) fn pipeline(
        &self,
        device: &wgpu::Device,
        label: &str,
        layout: &wgpu::PipelineLayout,
        vertex: wgpu::VertexState<'_>,
        fragment: &str,
    ) -> wgpu::RenderPipeline {
        let targets = [
            Some(wgpu::ColorTargetState {
                format: self.linear_format,
                blend: None,
                write_mask: wgpu::ColorWrites::COLOR,
            }),
            Some(wgpu::ColorTargetState {
                format: self.mask_format,
                blend: None,
                write_mask: wgpu::ColorWrites::empty(),
            }),
        ];
        device.create_render_pipeline(&wgpu::RenderPipelineDescriptor {
            label: Some(label),
            layout: Some(layout),
            vertex,
            primitive: wgpu::PrimitiveState::default(),
            depth_stencil: Some(wgpu::DepthStencilState {
                format: self.depth_format,
                depth_write_enabled: Some(false),
                depth_compare: Some(wgpu::CompareFunction::Always),
                stencil: wgpu::StencilState::default(),
                bias: wgpu::DepthBiasState::default(),
            }),
            multisample: wgpu::MultisampleState::default(),
            fragment: Some(wgpu::FragmentState {
                module: self.module,
                entry_point: Some(fragment),
                compilation_options: Default::default(),
                targets: &targets,
            }),
            multiview_mask: None,
            cache: None,
        })
    }
}
