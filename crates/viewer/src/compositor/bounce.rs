//! The light live spheres reflect onto the pre-rendered scene (differential rendering's added
//! term; `shaders/bounce.wgsl`).
//!
//! A live sphere's diffuse outgoing radiance is what the viewer shades it with (its lights with
//! the scene's shadows, the probes' indirect light less its own-shadow loss), a function of the
//! point on it alone. It is computed once per texel of a [`RADIOSITY_MAP_TEXELS`]^2 octahedral
//! map over the whole sphere, a row of an atlas per shadow-casting sphere (as the own-shadow loss
//! maps are, `loss_map.rs`), redrawn only when what it depends on changed (the frame's uniform or
//! a live mesh's). Then a full-screen pass, scissored to where the spheres' occlusion of
//! indirect light is counted, adds to each pre-rendered pixel `albedo / pi` times the integral of
//! that radiance times `cos` over the part of the sphere's cap the scene lets it see (4 to 32
//! directions by the sphere's size in view, rings of equal solid angle times sectors, each
//! reading the map and tracing a shadow ray), from the sidecar's `albedo` and `normal` layers;
//! optionally the light the sphere hides is taken from behind it (`occlusion_from_behind`).
//! A glossy sphere also sends its lights' highlights, which depend on the direction: the pass
//! integrates the Blinn lobe of each light toward the pixel over 16 or 64 of the sphere's normals
//! facing it, scaled by the share of the lights the scene lets reach each point (the maps'
//! alpha) and by the share of the cap's directions the scene lets the pixel see; the sphere's
//! `Ks` colour and exponent sit in an extra column of the atlas.
//! Pixels that change by nothing are discarded and keep their value bit for bit. The pass
//! writes the frame after shadows and then copies what it touched into the backdrop after
//! shadows, which the live objects' edges blend with.

use super::Compositor;
use super::lighting::{FrameUniform, MAX_SHADOW_SPHERES};
use super::overlay::Overlay;
use super::shadows::{AO_REACH, merge};
use super::sphere_atlas::SphereMapAtlas;
use glam::DVec3;

/// Texels along each side of a sphere's map (`bounce.wgsl` RADIOSITY_MAP_TEXELS).
pub(super) const RADIOSITY_MAP_TEXELS: u32 = 32;
pub(super) const ATLAS_FORMAT: wgpu::TextureFormat = wgpu::TextureFormat::Rgba16Float;

/// The radiosity maps' atlas: a row of `RADIOSITY_MAP_TEXELS`^2 texels per shadow-casting
/// sphere, and one more column whose first texel in each row holds the sphere's specular lobe
/// (`Ks` times its specular colour, and the Blinn exponent), which the bounce pass cannot read
/// from the sphere's material (it draws every sphere at once).
pub(super) fn radiosity_atlas(device: &wgpu::Device) -> SphereMapAtlas {
    SphereMapAtlas::new(
        device,
        "radiosity maps",
        ATLAS_FORMAT,
        (RADIOSITY_MAP_TEXELS + 1, RADIOSITY_MAP_TEXELS * MAX_SHADOW_SPHERES as u32),
    )
}

/// The radiosity maps' pass, the bounce pass and what the maps were last drawn from.
#[derive(Debug)]
pub(super) struct Bounce {
    atlas: SphereMapAtlas,
    map_pipeline: wgpu::RenderPipeline,
    /// The maps of a moving frame, without the own-shadow loss on the spheres' far halves
    /// (`fs_radiosity_map_moving`).
    map_pipeline_moving: wgpu::RenderPipeline,
    bounce_pipeline: wgpu::RenderPipeline,
    /// The frame and mesh uniforms the maps were last drawn from (empty: never drawn).
    drawn_from: super::DrawnFrom,
}

/// What the bounce's pipelines are built from.
pub(super) struct BounceSetup<'a> {
    pub(super) module: &'a wgpu::ShaderModule,
    /// The frame bind group alone (the bounce pass) and with a mesh's (the maps: a row's material).
    pub(super) frame_only: &'a wgpu::PipelineLayout,
    pub(super) with_mesh: &'a wgpu::PipelineLayout,
    pub(super) linear_format: wgpu::TextureFormat,
    pub(super) mask_format: wgpu::TextureFormat,
    pub(super) depth_format: wgpu::TextureFormat,
}

impl Bounce {
    pub(super) fn new(device: &wgpu::Device, atlas: SphereMapAtlas, setup: &BounceSetup<'_>) -> Bounce {
        let fragment = |entry: &'static str, targets| wgpu::FragmentState {
            module: setup.module,
            entry_point: Some(entry),
            compilation_options: Default::default(),
            targets,
        };
        let vertex = wgpu::VertexState {
            module: setup.module,
            entry_point: Some("vs_fullscreen"),
            compilation_options: Default::default(),
            buffers: &[],
        };
        let map_targets = [Some(wgpu::ColorTargetState {
            format: ATLAS_FORMAT,
            blend: None,
            write_mask: wgpu::ColorWrites::ALL,
        })];
        let map_pipeline_from = |label, entry| {
            device.create_render_pipeline(&wgpu::RenderPipelineDescriptor {
                label: Some(label),
                layout: Some(setup.with_mesh),
                vertex: vertex.clone(),
                primitive: wgpu::PrimitiveState::default(),
                depth_stencil: None,
                multisample: wgpu::MultisampleState::default(),
                fragment: Some(fragment(entry, &map_targets)),
                multiview_mask: None,
                cache: None,
            })
        };
        let map_pipeline = map_pipeline_from("radiosity maps", "fs_radiosity_map");
        let map_pipeline_moving = map_pipeline_from("radiosity maps, moving", "fs_radiosity_map_moving");
        // Into the frame's colour target (the mask and depth stay as the backdrop left them).
        let overlay = Overlay {
            module: setup.module,
            linear_format: setup.linear_format,
            mask_format: setup.mask_format,
            depth_format: setup.depth_format,
        };
        let bounce_pipeline = overlay.pipeline(device, "bounce light", setup.frame_only, vertex, "fs_bounce");
        Bounce {
            atlas,
            map_pipeline,
            map_pipeline_moving,
            bounce_pipeline,
            drawn_from: super::DrawnFrom::default(),
        }
    }
}

impl Compositor {
    /// The light live spheres reflect onto the scene in words (for `--stats`): whether it is
    /// added, and why not.
    pub fn bounce_light_summary(&self) -> &'static str {
        if !self.settings.bounce_light {
            "off (turned off)"
        } else if self.layers.info[0] != 1 {
            "off (no light layers: their albedo and normals are needed)"
        } else if self.layers.albedo_slice.is_none() {
            "off (the light layers hold no diffuse albedo)"
        } else if self.settings.occlusion_from_behind {
            "live spheres' diffuse light, 4 to 32 directions over each sphere's cap with shadow rays, \
             and their lights' highlights over 16 or 64 of their normals; the light they hide taken \
             from behind them (live meshes add none)"
        } else {
            "live spheres' diffuse light, 4 to 32 directions over each sphere's cap with shadow rays, \
             and their lights' highlights over 16 or 64 of their normals (live meshes add none)"
        }
    }

    /// The pixels the spheres' bounce light can reach: where their occlusion of indirect light
    /// is counted (`AO_REACH` radii), `None` when the bounce is off.
    pub(super) fn bounce_scissor(&self, uniform: &FrameUniform) -> Option<[u32; 4]> {
        if uniform.bounce[0] != 1 {
            return None;
        }
        let spheres = &uniform.shadow_spheres[..(uniform.layer_info[3] as usize).min(MAX_SHADOW_SPHERES)];
        spheres.iter().fold(None, |union, s| {
            let centre = DVec3::new(f64::from(s[0]), f64::from(s[1]), f64::from(s[2]));
            merge(union, self.box_scissor(centre, f64::from(s[3]) * AO_REACH))
        })
    }

    /// Draws the spheres' radiosity maps when the bounce is on and they are not already drawn
    /// from the same `uniform` and mesh uniforms (`mesh_bytes`). `rows`: each mesh slot's row
    /// (`loss_map::mesh_rows`). Runs after the own-shadow loss maps, which it reads.
    pub(super) fn record_radiosity_maps(
        &self,
        encoder: &mut wgpu::CommandEncoder,
        uniform: &FrameUniform,
        rows: &[i32],
        mesh_bytes: &[u8],
    ) {
        let maps = &self.bounce;
        if uniform.bounce[0] != 1 || uniform.layer_info[3] == 0 {
            return;
        }
        if !maps.drawn_from.renew(uniform, mesh_bytes) {
            return;
        }
        {
            let mut pass =
                super::colour_pass(encoder, "radiosity maps", &maps.atlas.drawn_view, wgpu::LoadOp::Load);
            // A moving frame (`tone[3]`, frame.rs) leaves out the far halves' own-shadow loss.
            let moving = uniform.tone[3] == 1.0;
            pass.set_pipeline(if moving { &maps.map_pipeline_moving } else { &maps.map_pipeline });
            pass.set_bind_group(0, &self.frame_bind_group, &[]);
            for row in 0..uniform.layer_info[3].min(MAX_SHADOW_SPHERES as u32) {
                // The row's material: the cursor sphere's (row 0 when drawn, from the frame
                // uniform) or its mesh's, bound at the mesh's slot.
                let slot = rows.iter().position(|&r| r == row as i32).unwrap_or(0);
                let offset = (slot as u64 * self.mesh_uniform_stride) as u32;
                pass.set_bind_group(1, &self.mesh_bind_group, &[offset]);
                pass.set_scissor_rect(
                    0,
                    row * RADIOSITY_MAP_TEXELS,
                    RADIOSITY_MAP_TEXELS + 1,
                    RADIOSITY_MAP_TEXELS,
                );
                pass.draw(0..3, 0..1);
            }
        }
        maps.atlas.copy_drawn_to_read(encoder);
    }

    /// Adds the spheres' bounce light to the frame after shadows within `rect`
    /// ([`Compositor::bounce_scissor`]), then copies that rectangle into the backdrop after
    /// shadows, so that the live objects' edges blend with the lit backdrop.
    pub(super) fn record_bounce(&self, encoder: &mut wgpu::CommandEncoder, [x, y, w, h]: [u32; 4]) {
        {
            let mut pass = self.begin_frame_pass(encoder, &self.linear_view, false);
            pass.set_scissor_rect(x, y, w, h);
            pass.set_pipeline(&self.bounce.bounce_pipeline);
            pass.draw(0..3, 0..1);
        }
        self.copy_to_shadowed(encoder, [x, y, w, h]);
    }

    /// Copies the rectangle `[x, y, w, h]` of the frame into the backdrop after shadows, which
    /// the live objects' edges blend with.
    pub(super) fn copy_to_shadowed(&self, encoder: &mut wgpu::CommandEncoder, rect: [u32; 4]) {
        self.copy_frame_rect_into(encoder, rect, &self.shadowed_texture);
    }

    /// Copies `[x, y, w, h]` of the frame's colour target into `to`, a frame-sized texture, at
    /// its place.
    pub(super) fn copy_frame_rect_into(
        &self,
        encoder: &mut wgpu::CommandEncoder,
        [x, y, w, h]: [u32; 4],
        to: &wgpu::Texture,
    ) {
        let origin = wgpu::Origin3d { x, y, z: 0 };
        encoder.copy_texture_to_texture(
            wgpu::TexelCopyTextureInfo { origin, ..self.linear_texture.as_image_copy() },
            wgpu::TexelCopyTextureInfo { origin, ..to.as_image_copy() },
            wgpu::Extent3d { width: w, height: h, depth_or_array_layers: 1 },
        );
    }
}
