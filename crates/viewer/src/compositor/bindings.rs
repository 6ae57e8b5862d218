//! The layout of the frame bind group every compositing pass reads: the frame uniform, the
//! backdrop's colour and depths, the light layers and their area samples, the reflection
//! probes with their sampler, the irradiance probes, the backdrop after shadows, the
//! shadow-ray hierarchies' nodes and triangles, the own-shadow loss maps, the radiosity maps, the clusters of what the shadows took, what each pixel loses to them, and a moving frame's
//! samples of the bounce light or that loss, the scene's surface materials (the near field) and
//! the live spheres' near-field maps.

/// A texture the CPU fills (`COPY_DST`) and the shaders read, of one mip level: the light
/// layers, the transmission layers, the caustic loss.
pub(super) fn input_texture(
    device: &wgpu::Device,
    label: &str,
    size: wgpu::Extent3d,
    format: wgpu::TextureFormat,
) -> wgpu::Texture {
    device.create_texture(&wgpu::TextureDescriptor {
        label: Some(label),
        size,
        mip_level_count: 1,
        sample_count: 1,
        dimension: wgpu::TextureDimension::D2,
        format,
        usage: wgpu::TextureUsages::TEXTURE_BINDING | wgpu::TextureUsages::COPY_DST,
        view_formats: &[],
    })
}

/// A layout entry for a float texture the shaders read.
pub(super) fn texture_layout_entry(
    binding: u32,
    visibility: wgpu::ShaderStages,
    view_dimension: wgpu::TextureViewDimension,
    filterable: bool,
) -> wgpu::BindGroupLayoutEntry {
    wgpu::BindGroupLayoutEntry {
        binding,
        visibility,
        ty: wgpu::BindingType::Texture {
            sample_type: wgpu::TextureSampleType::Float { filterable },
            view_dimension,
            multisampled: false,
        },
        count: None,
    }
}

/// A layout entry for a read-only storage buffer the fragment shaders read.
fn storage_entry(binding: u32) -> wgpu::BindGroupLayoutEntry {
    wgpu::BindGroupLayoutEntry {
        binding,
        visibility: wgpu::ShaderStages::FRAGMENT,
        ty: wgpu::BindingType::Buffer {
            ty: wgpu::BufferBindingType::Storage { read_only: true },
            has_dynamic_offset: false,
            min_binding_size: None,
        },
        count: None,
    }
}

/// The frame bind group's layout (`composite.wgsl` and the files appended to it, group 0).
pub(super) fn frame_layout(device: &wgpu::Device) -> wgpu::BindGroupLayout {
    let texture_entry = |binding: u32, visibility: wgpu::ShaderStages| {
        texture_layout_entry(binding, visibility, wgpu::TextureViewDimension::D2, false)
    };
    let vf = wgpu::ShaderStages::VERTEX | wgpu::ShaderStages::FRAGMENT;
    device.create_bind_group_layout(&wgpu::BindGroupLayoutDescriptor {
        label: Some("frame"),
        entries: &[
            wgpu::BindGroupLayoutEntry {
                binding: 0,
                visibility: vf,
                ty: wgpu::BindingType::Buffer {
                    ty: wgpu::BufferBindingType::Storage { read_only: true },
                    has_dynamic_offset: false,
                    min_binding_size: None,
                },
                count: None,
            },
            texture_entry(1, wgpu::ShaderStages::FRAGMENT),
            texture_entry(2, wgpu::ShaderStages::FRAGMENT),
            texture_entry(3, wgpu::ShaderStages::FRAGMENT),
            texture_layout_entry(4, wgpu::ShaderStages::FRAGMENT, wgpu::TextureViewDimension::D2Array, false),
            wgpu::BindGroupLayoutEntry {
                binding: 5,
                visibility: wgpu::ShaderStages::FRAGMENT,
                ty: wgpu::BindingType::Buffer {
                    ty: wgpu::BufferBindingType::Storage { read_only: true },
                    has_dynamic_offset: false,
                    min_binding_size: None,
                },
                count: None,
            },
            texture_layout_entry(6, wgpu::ShaderStages::FRAGMENT, wgpu::TextureViewDimension::D2Array, true),
            texture_layout_entry(7, wgpu::ShaderStages::FRAGMENT, wgpu::TextureViewDimension::D2Array, false),
            wgpu::BindGroupLayoutEntry {
                binding: 8,
                visibility: wgpu::ShaderStages::FRAGMENT,
                ty: wgpu::BindingType::Sampler(wgpu::SamplerBindingType::Filtering),
                count: None,
            },
            storage_entry(9),
            storage_entry(10),
            texture_entry(11, wgpu::ShaderStages::FRAGMENT),
            storage_entry(12),
            storage_entry(13),
            // The live spheres' own-shadow loss maps (compositor/loss_map.rs), packed halves.
            wgpu::BindGroupLayoutEntry {
                binding: 14,
                visibility: wgpu::ShaderStages::FRAGMENT,
                ty: wgpu::BindingType::Texture {
                    sample_type: wgpu::TextureSampleType::Uint,
                    view_dimension: wgpu::TextureViewDimension::D2,
                    multisampled: false,
                },
                count: None,
            },
            // The live spheres' radiosity maps (compositor/bounce.rs).
            texture_entry(15, wgpu::ShaderStages::FRAGMENT),
            // The clusters of what the shadows took (compositor/shadow_bounce.rs).
            texture_entry(16, wgpu::ShaderStages::FRAGMENT),
            // What each pixel loses to the shadows' second bounce (compositor/shadow_bounce.rs).
            texture_entry(17, wgpu::ShaderStages::FRAGMENT),
            // A moving frame's samples of the bounce light or the second bounce
            // (compositor/reduced_gather.rs).
            texture_entry(22, wgpu::ShaderStages::FRAGMENT),
            // What live objects take from the caustics (caustic_shadow.rs).
            texture_entry(30, wgpu::ShaderStages::FRAGMENT),
            // The scene's surface materials for the near field on live objects (near_field.rs).
            storage_entry(31),
            // The live spheres' near-field maps (compositor/near_field_map.rs).
            texture_entry(32, wgpu::ShaderStages::FRAGMENT),
            // A moving cursor sphere's radiance map (compositor/cursor_radiance_map.rs), full
            // floats, read texel by texel.
            texture_entry(33, wgpu::ShaderStages::FRAGMENT),
            // The moving frame's spreading weights, a layer per stride
            // (compositor/reduced_gather.rs).
            texture_layout_entry(
                34,
                wgpu::ShaderStages::FRAGMENT,
                wgpu::TextureViewDimension::D2Array,
                false,
            ),
        ],
    })
}
