//! Near-field maps: the near field and the glossy lobes traced through the scene's triangles
//! (`shaders/near_field.wgsl`, `shaders/probes.wgsl` `glossy_reflection`) computed once per
//! texel of a map over each live sphere instead of once per fragment per frame.
//!
//! With the camera, the spheres and the lights fixed, both depend on the point of a sphere alone
//! (the view direction at a point of a sphere is the point's own), as the own-shadow loss does
//! (`loss_map.rs`): so each sphere's row of the atlas holds [`NEAR_FIELD_MAP_TEXELS`]^2 normals
//! over the hemisphere facing the eye (the loss maps' hemi-octahedral layout) twice, the
//! irradiance the near field adds and then the radiance the traced glossy lobe reflects, each
//! texel 16 traversals of the scene's hierarchy. Fragments read them bilinearly. The maps are
//! drawn only when something they depend on changed (the frame's uniform or a live mesh's), then
//! copied into the texture the shading passes read. Live meshes other than spheres keep the
//! per-fragment tracing.

use super::Compositor;
use super::lighting::{FrameUniform, MAX_SHADOW_SPHERES};
use super::overlay::offscreen_pipeline;
use super::sphere_atlas::DrawnAndRead;
use crate::scene::ViewerScene;

/// Texels along each side of a sphere's map (`near_field.wgsl` NEAR_FIELD_MAP_TEXELS).
pub(super) const NEAR_FIELD_MAP_TEXELS: u32 = 32;
/// Signed irradiance and radiance (the near field may take light away).
pub(super) const ATLAS_FORMAT: wgpu::TextureFormat = wgpu::TextureFormat::Rgba16Float;

/// The atlas: per sphere a row of two maps side by side (the near field, the glossy lobe).
pub(super) fn near_field_atlas(device: &wgpu::Device) -> DrawnAndRead {
    DrawnAndRead::new(
        device,
        "near-field maps",
        ATLAS_FORMAT,
        (2 * NEAR_FIELD_MAP_TEXELS, NEAR_FIELD_MAP_TEXELS * MAX_SHADOW_SPHERES as u32),
    )
}

/// The near-field maps' pass and what it was last drawn from.
#[derive(Debug)]
pub(super) struct NearFieldMaps {
    atlas: DrawnAndRead,
    pipeline: wgpu::RenderPipeline,
    /// The frame and mesh uniforms the maps were last drawn from (empty: never drawn).
    drawn_from: super::DrawnFrom,
    /// Whether the scene's triangles and their materials are bound (the maps have work).
    scene_materials: bool,
}

impl NearFieldMaps {
    /// The pass over `atlas`, with the compositing shaders' `module` and the layout with a
    /// mesh's group (a row's material), for `scene`: without its triangles' materials neither
    /// the near field nor the traced lobes run.
    pub(super) fn new(
        device: &wgpu::Device,
        atlas: DrawnAndRead,
        module: &wgpu::ShaderModule,
        layout: &wgpu::PipelineLayout,
        scene: &ViewerScene,
    ) -> NearFieldMaps {
        let scene_materials = scene.occluders().is_some()
            && scene.occluder_materials().is_some_and(|m| !m.materials.is_empty());
        let pipeline = offscreen_pipeline(
            device,
            module,
            layout,
            ("near-field maps", "fs_near_field_map"),
            ATLAS_FORMAT,
        );
        NearFieldMaps { atlas, pipeline, drawn_from: super::DrawnFrom::default(), scene_materials }
    }
}

impl Compositor {
    /// Draws the spheres' near-field maps when the shading reads them (the scene's materials
    /// bound, irradiance or reflection probes, live spheres) and they are not already drawn
    /// from the same `uniform` and mesh uniforms (`mesh_bytes`). `rows`: each mesh slot's row
    /// (`loss_map::mesh_rows`), whose material the glossy map reads. Runs after the backdrop
    /// after shadows is kept when it is (the traced lobes read what the shadows took).
    pub(super) fn record_near_field_maps(
        &self,
        encoder: &mut wgpu::CommandEncoder,
        uniform: &FrameUniform,
        rows: &[i32],
        mesh_bytes: &[u8],
    ) {
        let maps = &self.near_field_maps;
        let layered = uniform.layer_info[0] == 1;
        let row_count = if layered { uniform.layer_info[3] } else { uniform.counts[2] };
        let probes = uniform.counts[3] == 1 || uniform.reflection_origin[3] > 0.5;
        // A moving frame (tone.w) leaves the near field out and reads no maps.
        let moving = uniform.tone[3] > 0.5;
        if !self.settings.near_field_maps || !maps.scene_materials || !probes || row_count == 0 || moving {
            return;
        }
        if !maps.drawn_from.renew(uniform, mesh_bytes) {
            return;
        }
        {
            let mut pass =
                super::colour_pass(encoder, "near-field maps", &maps.atlas.drawn_view, wgpu::LoadOp::Load);
            pass.set_pipeline(&maps.pipeline);
            pass.set_bind_group(0, &self.frame_bind_group, &[]);
            for row in 0..row_count.min(MAX_SHADOW_SPHERES as u32) {
                // The row's material: the cursor sphere's (row 0 when drawn, from the frame
                // uniform) or its mesh's, bound at the mesh's slot.
                let slot = rows.iter().position(|&r| r == row as i32).unwrap_or(0);
                let offset = (slot as u64 * self.mesh_uniform_stride) as u32;
                pass.set_bind_group(1, &self.mesh_bind_group, &[offset]);
                pass.set_scissor_rect(
                    0,
                    row * NEAR_FIELD_MAP_TEXELS,
                    2 * NEAR_FIELD_MAP_TEXELS,
                    NEAR_FIELD_MAP_TEXELS,
                );
                pass.draw(0..3, 0..1);
            }
        }
        maps.atlas.copy_drawn_to_read(encoder);
    }
}
