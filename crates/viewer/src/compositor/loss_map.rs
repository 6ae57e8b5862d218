//! Own-shadow loss maps: what the live objects' shadows took from the light each point of a live
//! sphere receives, computed once per sphere into a small map over its surface instead of once
//! per fragment (`shaders/shadow_loss.wgsl`, `fs_loss_map` and `own_shadow_loss`).
//!
//! With the camera, the spheres and the shadows fixed, the loss on a sphere depends on the point
//! alone (the view direction at a point of a sphere is the point's own), so a map of
//! [`LOSS_MAP_TEXELS`]^2 normals over the hemisphere facing the eye, read bilinearly, stands for
//! the per-fragment gather of 16 directions x (16 steps + 6 bisections): its cost no longer grows
//! with the sphere's size on screen. The map is drawn into an atlas (a row per sphere) only when
//! something it depends on changed (the frame's uniform or a live mesh's), then copied into the
//! texture the shading passes read, so that no pass reads the texture it draws into. Live meshes
//! other than spheres keep the per-fragment gather.

use super::Compositor;
use super::lighting::{FrameUniform, MAX_SHADOW_SPHERES};
use super::overlay::offscreen_pipeline;
use super::sphere_atlas::SphereMapAtlas;
use crate::live::LiveObjects;

/// Texels along each side of a sphere's map (`shadow_loss.wgsl` LOSS_MAP_TEXELS).
pub(super) const LOSS_MAP_TEXELS: u32 = 32;
/// Three half floats per texel (the irradiance loss) and a drawn flag, in 32-bit words.
pub(super) const ATLAS_FORMAT: wgpu::TextureFormat = wgpu::TextureFormat::Rgba32Uint;

/// The loss maps' pass and what it was last drawn from.
#[derive(Debug)]
pub(super) struct LossMaps {
    atlas: SphereMapAtlas,
    pipeline: wgpu::RenderPipeline,
    /// The frame and mesh uniforms the maps were last drawn from (empty: never drawn).
    drawn_from: super::DrawnFrom,
}

impl LossMaps {
    /// The pass over `atlas`, with the compositing shaders' `module` and layouts.
    pub(super) fn new(
        device: &wgpu::Device,
        atlas: SphereMapAtlas,
        module: &wgpu::ShaderModule,
        layout: &wgpu::PipelineLayout,
    ) -> LossMaps {
        let pipeline =
            offscreen_pipeline(device, module, layout, ("own-shadow loss maps", "fs_loss_map"), ATLAS_FORMAT);
        LossMaps { atlas, pipeline, drawn_from: super::DrawnFrom::default() }
    }
}

/// Each drawn live mesh's row in the atlas (-1: not a sphere with a map), in the order of the
/// finite instances of `live.meshes`: the rows of `FrameUniform::shadow_spheres`, which lists
/// the cursor sphere first, then live spheres (`lighting.rs`). Without light layers only the
/// cursor sphere has a row.
pub(super) fn mesh_rows(uniform: &FrameUniform, live: &LiveObjects) -> Vec<i32> {
    let layered = uniform.layer_info[0] == 1;
    let mut next = uniform.counts[2] as usize;
    live.meshes
        .iter()
        .filter(|m| m.world_from_object.is_finite())
        .map(|m| match m.exact_sphere {
            Some((c, r))
                if layered && c.is_finite() && r > 0.0 && r.is_finite() && next < MAX_SHADOW_SPHERES =>
            {
                next += 1;
                (next - 1) as i32
            }
            _ => -1,
        })
        .collect()
}

impl Compositor {
    /// Draws the spheres' loss maps when the live objects' shading reads them and they are not
    /// already drawn from the same `uniform` and mesh uniforms (`mesh_bytes`: the live meshes'
    /// shadows change the loss). Runs after the backdrop after shadows is kept.
    pub(super) fn record_loss_maps(
        &self,
        encoder: &mut wgpu::CommandEncoder,
        uniform: &FrameUniform,
        mesh_bytes: &[u8],
    ) {
        let maps = &self.loss_maps;
        let layered = uniform.layer_info[0] == 1;
        let row_count = if layered { uniform.layer_info[3] } else { uniform.counts[2] };
        // The shading reads the loss only with shadows and irradiance probes (`shade_with` and
        // `diffuse_radiance` in composite.wgsl); the reflection probes take the shadows per lobe
        // direction instead (probes.wgsl, `live_share_at_hit`).
        if !self.settings.own_shadow_maps
            || uniform.counts[1] != 1
            || uniform.counts[3] != 1
            || row_count == 0
        {
            return;
        }
        if !maps.drawn_from.renew(uniform, mesh_bytes) {
            return;
        }
        {
            let mut pass = super::colour_pass(
                encoder,
                "own-shadow loss maps",
                &maps.atlas.drawn_view,
                wgpu::LoadOp::Load,
            );
            pass.set_pipeline(&maps.pipeline);
            pass.set_bind_group(0, &self.frame_bind_group, &[]);
            // The layout's mesh group: the loss (irradiance only) reads no material.
            pass.set_bind_group(1, &self.mesh_bind_group, &[0]);
            for row in 0..row_count.min(MAX_SHADOW_SPHERES as u32) {
                pass.set_scissor_rect(0, row * LOSS_MAP_TEXELS, LOSS_MAP_TEXELS, LOSS_MAP_TEXELS);
                pass.draw(0..3, 0..1);
            }
        }
        maps.atlas.copy_drawn_to_read(encoder);
    }
}
