//! The light the live objects' shadows take from the rest of the scene: the shadow's second
//! bounce (differential rendering's loss term beyond the shadowed pixels themselves;
//! `shaders/shadow_bounce.wgsl`).
//!
//! The floor a sphere shadows no longer lights the walls beside it, nor the sphere's
//! surroundings. What the shadow pass took from each backdrop pixel (the image less the
//! backdrop after shadows) is the outgoing radiance that surface lost, the same toward every
//! receiver for a Lambertian surface. So the pixels of the shadows' scissor are summed into
//! [`FINE`]^2 clusters (loss flux, area, loss-weighted position and normal per tile) and those
//! into [`COARSE`]^2; a full-frame pass then gives each pre-rendered pixel its albedo times the
//! coarse clusters' form factors times their flux (the fine ones' near the receiver), leaving
//! pixels that would lose a negligible share of their value at zero. These are drawn only when
//! the frame's uniform or a live mesh's changed, as the sphere maps are; every frame, a
//! full-screen pass removes the loss (pixels that lose nothing keep their value bit for bit) and
//! copies the frame into the backdrop after shadows.
//!
//! The loss costs most of a moving sphere's frame (every pixel sums 256 clusters). With
//! `CompositorSettings::amortise_while_moving`, a frame whose inputs changed draws it in one of
//! [`TAKEN_BANDS`] horizontal bands of the frame, the others keeping what earlier frames drew;
//! the first frame that repeats its predecessor's inputs draws the bands not yet drawn from
//! them, so a resting sphere's frame is the exact one from its second frame on.

use super::Compositor;
use super::lighting::FrameUniform;
use super::overlay::{Overlay, fullscreen_vertex, offscreen_pipeline};
use super::sphere_atlas::DrawnAndRead;

/// Fine clusters along each side of the shadows' scissor, and coarse ones (4x4 fine ones each;
/// `shadow_bounce.wgsl` SHADOW_BOUNCE_FINE and SHADOW_BOUNCE_COARSE).
const FINE: u32 = 64;
const COARSE: u32 = 16;
/// What each pixel loses: a small correction, so half floats (2^-11 of it) suffice.
pub(super) const TAKEN_FORMAT: wgpu::TextureFormat = wgpu::TextureFormat::Rgba16Float;
/// Horizontal bands of the frame the loss is drawn in, one a frame, while the inputs change (with
/// `amortise_while_moving`): a pixel's loss is then at most `TAKEN_BANDS - 1` frames old.
pub const TAKEN_BANDS: u32 = 16;

/// Which bands of the loss were drawn from the inputs `drawn_from` holds.
#[derive(Debug, Default)]
struct TakenBands {
    /// Bit k: band k was drawn from the current inputs.
    current: std::cell::Cell<u32>,
    /// Whether every band was drawn at least once (until then, a frame draws them all).
    complete_once: std::cell::Cell<bool>,
    /// The band the next frame with new inputs draws.
    next: std::cell::Cell<u32>,
}

impl TakenBands {
    const ALL: u32 = (1 << TAKEN_BANDS) - 1;

    /// Records the bands within the frame's first `rows` rows as drawn (a settling frame's rows
    /// are drawn from the top, settle.rs), for a frame of `size`. `changed`: as for
    /// [`TakenBands::to_draw`].
    fn drawn_down_to(&self, changed: bool, rows: u32, size: (u32, u32)) {
        if changed {
            self.current.set(0);
        }
        let within = (0..TAKEN_BANDS).filter(|&k| {
            let [_, top, _, height] = band_rect(k, size);
            top + height <= rows
        });
        self.current.set(within.fold(self.current.get(), |m, k| m | 1 << k));
        if self.current.get() == Self::ALL {
            self.complete_once.set(true);
        }
    }

    /// The bands to draw this frame (bit k: band k), and records them as drawn. `changed`: the
    /// inputs differ from those the bands were drawn from.
    fn to_draw(&self, changed: bool, amortise: bool) -> u32 {
        if changed {
            self.current.set(0);
        }
        let wanted = if changed && amortise && self.complete_once.get() {
            let k = self.next.get();
            self.next.set((k + 1) % TAKEN_BANDS);
            1 << k
        } else {
            Self::ALL & !self.current.get()
        };
        self.current.set(self.current.get() | wanted);
        if self.current.get() == Self::ALL {
            self.complete_once.set(true);
        }
        wanted
    }
}

/// Band `k`'s rows of a frame `height` rows high: `[x, y, w, h]`, possibly empty.
pub(super) fn band_rect(k: u32, (width, height): (u32, u32)) -> [u32; 4] {
    let top = k * height / TAKEN_BANDS;
    let bottom = (k + 1) * height / TAKEN_BANDS;
    [0, top, width, bottom - top]
}

/// The textures of the shadows' second bounce: the clusters (binding 16) and what each pixel
/// loses (binding 17).
#[derive(Debug)]
pub(super) struct ShadowBounceTextures {
    pub(super) clusters: DrawnAndRead,
    pub(super) taken: DrawnAndRead,
    /// The fine clusters' three parts, each [`FINE`]^2, drawn in one pass (each tile summed
    /// once) and copied side by side into the clusters' fine rows.
    fine_parts: [(wgpu::Texture, wgpu::TextureView); 3],
}

impl ShadowBounceTextures {
    /// Made before the frame bind group, which the pipelines' module needs. The clusters are
    /// in the frame's linear format: the pass is off unless that is 32-bit float
    /// ([`Compositor::shadow_bounce_uniform`]).
    pub(super) fn new(
        device: &wgpu::Device,
        frame_size: (u32, u32),
        linear_format: wgpu::TextureFormat,
    ) -> Self {
        ShadowBounceTextures {
            clusters: DrawnAndRead::new(
                device,
                "shadow bounce clusters",
                linear_format,
                (3 * FINE, FINE + COARSE),
            ),
            taken: DrawnAndRead::new(device, "shadow bounce taken", TAKEN_FORMAT, frame_size),
            fine_parts: std::array::from_fn(|_| {
                let texture = device.create_texture(&wgpu::TextureDescriptor {
                    label: Some("shadow bounce fine clusters"),
                    size: wgpu::Extent3d { width: FINE, height: FINE, depth_or_array_layers: 1 },
                    mip_level_count: 1,
                    sample_count: 1,
                    dimension: wgpu::TextureDimension::D2,
                    format: linear_format,
                    usage: wgpu::TextureUsages::RENDER_ATTACHMENT | wgpu::TextureUsages::COPY_SRC,
                    view_formats: &[],
                });
                let view = texture.create_view(&Default::default());
                (texture, view)
            }),
        }
    }
}

/// The textures, the three pipelines and what the clusters and the loss were last drawn from.
#[derive(Debug)]
pub(super) struct ShadowBounce {
    textures: ShadowBounceTextures,
    fine_cluster_pipeline: wgpu::RenderPipeline,
    coarse_cluster_pipeline: wgpu::RenderPipeline,
    taken_pipeline: wgpu::RenderPipeline,
    apply_pipeline: wgpu::RenderPipeline,
    /// The frame and mesh uniforms the clusters and the loss were last drawn from (empty:
    /// never drawn).
    drawn_from: super::DrawnFrom,
    /// Which bands of the loss were drawn from them.
    bands: TakenBands,
    /// Whether the clusters were last drawn from a moving frame's reduced shadows.
    clusters_from_reduced_shadows: std::cell::Cell<bool>,
}

/// What the pipelines are built from.
pub(super) struct ShadowBounceSetup<'a> {
    pub(super) module: &'a wgpu::ShaderModule,
    pub(super) frame_only: &'a wgpu::PipelineLayout,
    pub(super) linear_format: wgpu::TextureFormat,
    pub(super) mask_format: wgpu::TextureFormat,
    pub(super) depth_format: wgpu::TextureFormat,
}

impl ShadowBounce {
    pub(super) fn new(
        device: &wgpu::Device,
        textures: ShadowBounceTextures,
        setup: &ShadowBounceSetup<'_>,
    ) -> ShadowBounce {
        let vertex = fullscreen_vertex(setup.module);
        let alone = |label: &str, entry: &str, format: wgpu::TextureFormat| {
            offscreen_pipeline(device, setup.module, setup.frame_only, (label, entry), format)
        };
        let part = Some(wgpu::ColorTargetState {
            format: setup.linear_format,
            blend: None,
            write_mask: wgpu::ColorWrites::ALL,
        });
        let fine_cluster_pipeline = device.create_render_pipeline(&wgpu::RenderPipelineDescriptor {
            label: Some("shadow bounce fine clusters"),
            layout: Some(setup.frame_only),
            vertex: vertex.clone(),
            primitive: wgpu::PrimitiveState::default(),
            depth_stencil: None,
            multisample: wgpu::MultisampleState::default(),
            fragment: Some(wgpu::FragmentState {
                module: setup.module,
                entry_point: Some("fs_shadow_bounce_fine_clusters"),
                compilation_options: Default::default(),
                targets: &[part.clone(), part.clone(), part],
            }),
            multiview_mask: None,
            cache: None,
        });
        let coarse_cluster_pipeline =
            alone("shadow bounce coarse clusters", "fs_shadow_bounce_coarse_clusters", setup.linear_format);
        let taken_pipeline = alone("shadow bounce taken", "fs_shadow_bounce_taken", TAKEN_FORMAT);
        // Into the frame's colour target (the mask and depth stay as the backdrop left them).
        let overlay = Overlay {
            module: setup.module,
            linear_format: setup.linear_format,
            mask_format: setup.mask_format,
            depth_format: setup.depth_format,
        };
        let apply_pipeline =
            overlay.pipeline(device, "shadow bounce", setup.frame_only, vertex, "fs_shadow_bounce");
        ShadowBounce {
            textures,
            fine_cluster_pipeline,
            coarse_cluster_pipeline,
            taken_pipeline,
            apply_pipeline,
            drawn_from: super::DrawnFrom::default(),
            bands: TakenBands::default(),
            clusters_from_reduced_shadows: Default::default(),
        }
    }
}

impl Compositor {
    /// The light the shadows take from the rest of the scene in words (for `--stats`).
    pub fn shadow_bounce_summary(&self) -> &'static str {
        if !self.settings.shadow_bounce {
            "off (turned off)"
        } else if self.layers.info[0] != 1 {
            "off (no light layers: their albedo and normals are needed)"
        } else if self.layers.albedo_slice.is_none() {
            "off (the light layers hold no diffuse albedo)"
        } else if self.linear_format != super::LINEAR_FORMAT {
            "off (32-bit float targets cannot be rendered to here)"
        } else {
            "the shadowed pixels' loss in 16x16 clusters (64x64 near the receiver), form factors \
             without visibility (surfaces the camera does not see are left out)"
        }
    }

    /// The uniform's `shadow_bounce` field: on with layers holding an albedo, layered shadows
    /// drawn and a scissor for them, and 32-bit float targets (the clusters' sums).
    pub(super) fn shadow_bounce_uniform(&self, uniform: &FrameUniform) -> [u32; 4] {
        let slice = match self.layers.albedo_slice {
            Some(slice)
                if self.settings.shadow_bounce && uniform.layer_info[0] == 1 && uniform.counts[1] == 1 =>
            {
                slice
            }
            _ => return [0; 4],
        };
        match self.shadow_scissor_all(uniform) {
            Some([x, y, w, h]) if w > 0 && h > 0 => [1, x | y << 16, w | h << 16, slice],
            _ => [0; 4],
        }
    }

    /// Draws what each pixel loses where it is not already drawn from the same `uniform` and
    /// mesh uniforms (`mesh_bytes`): the whole frame, or while they change one band of it (see
    /// the module's notes), or in a settling frame (settle.rs) its rows `settling` (`[top, count]`)
    /// alone.
    /// Reads the backdrop after shadows: runs after the bounce light added to it, whose clusters
    /// ([`Compositor::record_shadow_bounce_clusters`]) ran before.
    pub(super) fn record_shadow_bounce_taken(
        &self,
        encoder: &mut wgpu::CommandEncoder,
        uniform: &FrameUniform,
        mesh_bytes: &[u8],
        settling: Option<[u32; 2]>,
    ) {
        let bounce = &self.shadow_bounce;
        if uniform.shadow_bounce[0] != 1 {
            return;
        }
        let changed = bounce.drawn_from.renew(uniform, mesh_bytes);
        // A moving frame draws all of it at reduced resolution (reduced_gather.rs), from which
        // no band counts as drawn: the first frame at rest draws every band.
        if changed && self.reduced.moving() {
            bounce.bands.current.set(0);
            self.record_loss_reduced(encoder, &bounce.textures.taken);
            return;
        }
        let size = (self.width, self.height);
        let rects: Vec<[u32; 4]> = if let Some([top, count]) = settling {
            bounce.bands.drawn_down_to(changed, top + count, size);
            vec![[0, top, self.width, count]]
        } else {
            let bands = bounce.bands.to_draw(changed, self.settings.amortise_while_moving);
            (0..TAKEN_BANDS)
                .filter(|k| bands & (1 << k) != 0)
                .map(|k| band_rect(k, size))
                .filter(|r| r[3] > 0)
                .collect()
        };
        if rects.iter().all(|r| r[3] == 0) {
            return;
        }
        let taken = &bounce.textures.taken;
        {
            let mut pass = super::colour_pass(
                encoder,
                "shadow bounce taken",
                &taken.drawn_view,
                wgpu::LoadOp::Clear(wgpu::Color::TRANSPARENT),
            );
            pass.set_pipeline(&bounce.taken_pipeline);
            pass.set_bind_group(0, &self.frame_bind_group, &[]);
            for &[x, y, w, h] in &rects {
                pass.set_scissor_rect(x, y, w, h);
                pass.draw(0..3, 0..1);
            }
        }
        // Only the bands drawn: the others keep what earlier frames drew.
        for &[x, y, w, h] in &rects {
            let origin = wgpu::Origin3d { x, y, z: 0 };
            encoder.copy_texture_to_texture(
                wgpu::TexelCopyTextureInfo { origin, ..taken.drawn.as_image_copy() },
                wgpu::TexelCopyTextureInfo { origin, ..taken.read.as_image_copy() },
                wgpu::Extent3d { width: w, height: h, depth_or_array_layers: 1 },
            );
        }
    }

    /// Draws the clusters of what the shadows took when the loss is to be drawn again this
    /// frame (see [`Compositor::record_shadow_bounce_taken`], which decides from the same key):
    /// before the bounce light adds to the backdrop after shadows, which they read.
    pub(super) fn record_shadow_bounce_clusters(
        &self,
        encoder: &mut wgpu::CommandEncoder,
        uniform: &FrameUniform,
        mesh_bytes: &[u8],
    ) {
        let bounce = &self.shadow_bounce;
        if uniform.shadow_bounce[0] != 1 {
            return;
        }
        // Clusters drawn from a moving frame's reduced shadows are drawn again.
        let approximate = bounce.clusters_from_reduced_shadows.get();
        if bounce.drawn_from.is_current(uniform, mesh_bytes) && !approximate {
            return;
        }
        bounce.clusters_from_reduced_shadows.set(self.reduced.shadows_reduced.get());
        // The fine rows from the pixels, their three parts at once and copied side by side into
        // the clusters the passes read.
        let clusters = &bounce.textures.clusters;
        let parts = &bounce.textures.fine_parts;
        {
            let clear = wgpu::Operations {
                load: wgpu::LoadOp::Clear(wgpu::Color::TRANSPARENT),
                store: wgpu::StoreOp::Store,
            };
            let attachment = |view| {
                Some(wgpu::RenderPassColorAttachment {
                    view,
                    depth_slice: None,
                    resolve_target: None,
                    ops: clear,
                })
            };
            let mut pass = encoder.begin_render_pass(&wgpu::RenderPassDescriptor {
                label: Some("shadow bounce fine clusters"),
                color_attachments: &[
                    attachment(&parts[0].1),
                    attachment(&parts[1].1),
                    attachment(&parts[2].1),
                ],
                depth_stencil_attachment: None,
                timestamp_writes: None,
                occlusion_query_set: None,
                multiview_mask: None,
            });
            pass.set_pipeline(&bounce.fine_cluster_pipeline);
            pass.set_bind_group(0, &self.frame_bind_group, &[]);
            pass.draw(0..3, 0..1);
        }
        for (k, (texture, _)) in parts.iter().enumerate() {
            let mut to = clusters.read.as_image_copy();
            to.origin.x = k as u32 * FINE;
            encoder.copy_texture_to_texture(texture.as_image_copy(), to, texture.size());
        }
        // Then the coarse rows from them, copied alone (the drawn texture's fine rows are none).
        {
            let load = wgpu::LoadOp::Load;
            let mut pass = super::colour_pass(encoder, "shadow bounce clusters", &clusters.drawn_view, load);
            pass.set_pipeline(&bounce.coarse_cluster_pipeline);
            pass.set_bind_group(0, &self.frame_bind_group, &[]);
            pass.set_scissor_rect(0, FINE, 3 * COARSE, COARSE);
            pass.draw(0..3, 0..1);
        }
        let mut from = clusters.drawn.as_image_copy();
        let mut to = clusters.read.as_image_copy();
        (from.origin.y, to.origin.y) = (FINE, FINE);
        let coarse = wgpu::Extent3d { width: 3 * COARSE, height: COARSE, depth_or_array_layers: 1 };
        encoder.copy_texture_to_texture(from, to, coarse);
    }

    /// Whether what each pixel loses is drawn in full from `uniform`'s inputs (or the pass is
    /// off): none of it is from earlier frames. Call after [`Compositor::record_shadow_bounce_taken`].
    pub(super) fn shadow_bounce_settled(&self, uniform: &FrameUniform) -> bool {
        uniform.shadow_bounce[0] != 1 || self.shadow_bounce.bands.current.get() == TakenBands::ALL
    }

    /// Removes what each pixel loses from the frame, then copies the frame into the backdrop
    /// after shadows, which the live objects' shading and edges read.
    pub(super) fn record_shadow_bounce(&self, encoder: &mut wgpu::CommandEncoder, uniform: &FrameUniform) {
        if uniform.shadow_bounce[0] != 1 {
            return;
        }
        {
            let mut pass = self.begin_frame_pass(encoder, &self.linear_view, false);
            pass.set_pipeline(&self.shadow_bounce.apply_pipeline);
            pass.draw(0..3, 0..1);
        }
        encoder.copy_texture_to_texture(
            self.linear_texture.as_image_copy(),
            self.shadowed_texture.as_image_copy(),
            wgpu::Extent3d { width: self.width, height: self.height, depth_or_array_layers: 1 },
        );
    }
}

#[cfg(test)]
mod tests {
    use super::{TAKEN_BANDS, TakenBands, band_rect};

    /// The first drawing is whole; then each change draws the next band in turn, and the first
    /// frame without a change draws the rest; without amortising every change draws the whole.
    #[test]
    fn bands_are_drawn_in_turn_while_moving_and_completed_at_rest() {
        let bands = TakenBands::default();
        assert_eq!(bands.to_draw(true, true), TakenBands::ALL, "the first frame draws every band");
        assert_eq!(bands.to_draw(false, true), 0, "a still frame after a whole drawing draws nothing");
        for k in 0..TAKEN_BANDS + 2 {
            assert_eq!(bands.to_draw(true, true), 1 << (k % TAKEN_BANDS), "move {k}");
        }
        let last = 1 << ((TAKEN_BANDS + 1) % TAKEN_BANDS);
        assert_eq!(bands.to_draw(false, true), TakenBands::ALL & !last, "at rest the rest is drawn");
        assert_eq!(bands.to_draw(false, true), 0);
        assert_eq!(bands.to_draw(true, false), TakenBands::ALL, "exact frames draw every band");
    }

    /// A settling frame's rows, drawn from the top, count a band as drawn once all of its rows
    /// are, and all of them once the last row is.
    #[test]
    fn settling_rows_complete_the_bands_they_cover() {
        let bands = TakenBands::default();
        bands.drawn_down_to(true, 40, (512, 512));
        assert_eq!(bands.current.get(), 0b1, "rows 0..40 cover band 0 (rows 0..32) alone");
        bands.drawn_down_to(false, 64, (512, 512));
        assert_eq!(bands.current.get(), 0b11);
        assert!(!bands.complete_once.get());
        bands.drawn_down_to(false, 512, (512, 512));
        assert_eq!(bands.current.get(), TakenBands::ALL);
        assert!(bands.complete_once.get());
        bands.drawn_down_to(true, 8, (512, 512));
        assert_eq!(bands.current.get(), 0, "new inputs: no band is drawn from them");
    }

    /// The bands cover every row once, for heights that do and do not divide evenly.
    #[test]
    fn the_bands_cover_every_row_once() {
        for height in [1, 7, 16, 511, 512, 2048] {
            let mut next_row = 0;
            for k in 0..TAKEN_BANDS {
                let [x, y, w, h] = band_rect(k, (300, height));
                assert_eq!((x, w, y), (0, 300, next_row), "height {height}, band {k}");
                next_row += h;
            }
            assert_eq!(next_row, height);
        }
    }
}
