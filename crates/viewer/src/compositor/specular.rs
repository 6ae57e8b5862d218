//! The live spheres seen in the pre-rendered scene's specular reflections (mirrors, glass's
//! Fresnel reflection) and glossy lobes (metal, plastic; `shaders/specular.wgsl`): one
//! full-screen draw per sphere and kind, scissored to the pixels the sidecar gives a
//! reflectance or a glossy lobe, replacing the reflected light where the mirror direction (or
//! one of the lobe's directions) meets the sphere first. While live objects move, the glossy
//! lobes are traced at one pixel of each block, over an eighth of the lobe's directions with the
//! sphere's radiance from its radiosity map, and spread (`reduced_gather.wgsl`
//! `fs_glossy_gather_from_maps`, `fs_glossy_spread`; `specular.wgsl` GLOSSY_TRACED_MOVING):
//! tracing them costs most of a moving frame in a scene with glossy surfaces.

use super::Compositor;
use super::lighting::{FrameUniform, MAX_SHADOW_SPHERES};
use super::overlay::{Overlay, offscreen_pipeline_from};
use super::settle::{ReflectionBand, ReflectionDraw, ReflectionDraws, intersect};

/// The pass's pipeline and what it last left in the frame.
#[derive(Debug)]
pub(super) struct SpecularReflections {
    /// The spheres seen in the scene's specular reflections, one draw per sphere.
    pipeline: wgpu::RenderPipeline,
    /// The spheres seen in the scene's glossy lobes, one draw per sphere adding its share to
    /// the backdrop after shadows as the previous draws left it.
    glossy_pipeline: wgpu::RenderPipeline,
    /// While live objects move: each sphere's change in the glossy lobes at one pixel of each
    /// block of [`GLOSSY_STRIDE`]^2, into the reduced grid (binding 22), and its spreading over
    /// the frame.
    glossy_gather: wgpu::RenderPipeline,
    /// The same where the frame draws the spheres' radiosity maps (the bounce light on): the
    /// spheres in the lobes shaded from their maps, by an entry point without the exact
    /// shading's code, which lavapipe would run with its lanes off (shaders/specular.wgsl,
    /// glossy_change_from_maps).
    glossy_gather_from_maps: wgpu::RenderPipeline,
    glossy_spread: wgpu::RenderPipeline,
    /// The frame's rectangle of pixels with a specular reflection as the pass last left it
    /// (`None` when no pixel has one), and the uniforms it was drawn from: a still frame copies
    /// it back instead of drawing the pass again. While the reflections settle in bands
    /// (`settle.rs`), it holds the bands of the draw being drawn, and is known as drawn from
    /// nothing until the last.
    cache: Option<wgpu::Texture>,
    drawn_from: super::DrawnFrom,
}

impl SpecularReflections {
    /// `overlay`: the module and the frame's formats; `with_mesh`: the frame's and a mesh's bind
    /// groups (a sphere's material); `rect`: the pixels with a specular reflection
    /// or a glossy lobe (`GpuLayers::specular_rect`), `[x, y, w, h]`.
    pub(super) fn new(
        device: &wgpu::Device,
        overlay: &Overlay<'_>,
        with_mesh: &wgpu::PipelineLayout,
        rect: Option<[u32; 4]>,
    ) -> SpecularReflections {
        let vertex = wgpu::VertexState {
            module: overlay.module,
            entry_point: Some("vs_reflection"),
            compilation_options: Default::default(),
            buffers: &[],
        };
        let pipeline = overlay.pipeline(
            device,
            "spheres in specular reflections",
            with_mesh,
            vertex.clone(),
            "fs_reflection",
        );
        let glossy_pipeline =
            overlay.pipeline(device, "spheres in glossy reflections", with_mesh, vertex.clone(), "fs_glossy");
        let glossy_spread = overlay.pipeline(
            device,
            "spheres in glossy reflections, spread",
            with_mesh,
            vertex.clone(),
            "fs_glossy_spread",
        );
        // The grid's draw: into the reduced grid, in the frame's linear format.
        let glossy_gather = offscreen_pipeline_from(
            device,
            with_mesh,
            vertex.clone(),
            ("spheres in glossy reflections, reduced", "fs_glossy_gather"),
            overlay.linear_format,
        );
        let glossy_gather_from_maps = offscreen_pipeline_from(
            device,
            with_mesh,
            vertex,
            ("spheres in glossy reflections, reduced, from the radiosity maps", "fs_glossy_gather_from_maps"),
            overlay.linear_format,
        );
        let cache = rect.map(|[_, _, width, height]| {
            device.create_texture(&wgpu::TextureDescriptor {
                label: Some("spheres in specular reflections, last drawn"),
                size: wgpu::Extent3d { width, height, depth_or_array_layers: 1 },
                mip_level_count: 1,
                sample_count: 1,
                dimension: wgpu::TextureDimension::D2,
                format: overlay.linear_format,
                usage: wgpu::TextureUsages::COPY_SRC | wgpu::TextureUsages::COPY_DST,
                view_formats: &[],
            })
        });
        SpecularReflections {
            pipeline,
            glossy_pipeline,
            glossy_gather,
            glossy_gather_from_maps,
            glossy_spread,
            cache,
            drawn_from: super::DrawnFrom::default(),
        }
    }
}

/// Pixels along each side of a block whose centre traces the glossy lobes while live objects
/// move (`reduced_gather.wgsl` REDUCED_GLOSSY_STRIDE): the layered shadows' stride, whose
/// spreading weights it reads. In the room at 512x384 the lobes cost 8.5 s of CPU a moving
/// frame on lavapipe and 80 ms on an H100 at full resolution (docs/viewer-frame-time.md).
pub const GLOSSY_STRIDE: u32 = super::reduced_gather::SHADOW_STRIDE;

impl SpecularReflections {
    /// Forgets what the pass was drawn from: the next frame draws it again.
    pub(super) fn forget(&self) {
        self.drawn_from.forget();
    }
}

impl Compositor {
    /// Whether [`Compositor::record_reflections`] draws anything for `uniform`: some pixel has a
    /// specular reflection or a glossy lobe, and there are spheres to show in them.
    pub(super) fn reflections_drawn(&self, uniform: &FrameUniform) -> bool {
        self.layers.specular_rect().is_some()
            && self.specular.cache.is_some()
            && uniform.reflection[0] == 1
            && uniform.layer_info[3] != 0
    }

    /// The draws [`Compositor::record_reflections`] and [`Compositor::record_transmission`]
    /// make for `uniform`, in order, for the frames that settle them (`settle.rs`); `None` when
    /// they draw nothing.
    pub(super) fn reflection_draws(&self, uniform: &FrameUniform) -> Option<ReflectionDraws> {
        let rect = self.layers.specular_rect().filter(|_| self.reflections_drawn(uniform));
        let glossy =
            if rect.is_some() && self.layers.glossy.is_some() { self.reflecting_spheres(uniform) } else { 0 };
        Some(ReflectionDraws {
            rect: rect.unwrap_or_default(),
            mirror: rect.is_some() && self.layers.reflection.is_some(),
            glossy,
            transmission: self.transmission_drawn(uniform),
        })
        .filter(|draws| draws.count() > 0 || draws.transmission)
    }

    /// The spheres the specular pass draws, one draw each.
    fn reflecting_spheres(&self, uniform: &FrameUniform) -> u32 {
        uniform.layer_info[3].min(MAX_SHADOW_SPHERES as u32)
    }

    /// Binds the material of the sphere in shadow-sphere row `row` (its mesh slot in `rows`, as
    /// for the radiosity maps).
    fn bind_sphere_row(&self, pass: &mut wgpu::RenderPass<'_>, rows: &[i32], row: u32) {
        let slot = rows.iter().position(|&r| r == row as i32).unwrap_or(0);
        let offset = (slot as u64 * self.mesh_uniform_stride) as u32;
        pass.set_bind_group(1, &self.mesh_bind_group, &[offset]);
    }

    /// Records `draw` into the frame's colour target within the pass's scissor: the mirror's
    /// draws of the `spheres` (a pixel changes in one at most), or one sphere's glossy draw.
    fn draw_reflection(
        &self,
        pass: &mut wgpu::RenderPass<'_>,
        rows: &[i32],
        spheres: u32,
        draw: ReflectionDraw,
    ) {
        match draw {
            ReflectionDraw::Mirror => {
                pass.set_pipeline(&self.specular.pipeline);
                for row in 0..spheres {
                    self.bind_sphere_row(pass, rows, row);
                    pass.draw(0..3, row..row + 1);
                }
            }
            ReflectionDraw::Glossy(row) => {
                pass.set_pipeline(&self.specular.glossy_pipeline);
                self.bind_sphere_row(pass, rows, row);
                pass.draw(0..3, row..row + 1);
            }
        }
    }

    /// Shows the live spheres in the scene's specular reflections (`fs_reflection`): within the
    /// pixels that have one, each sphere's draw (its material bound at its mesh slot, `rows`
    /// as for the radiosity maps) replaces the reflected light by the sphere where the mirror
    /// direction meets it first (a pixel that meets no sphere takes, in the first draw, what
    /// the live objects changed on the surface it reflects), then each sphere's glossy draw adds what it changes in the glossy lobes; the
    /// rectangle is copied into the backdrop after shadows after each pass. Runs after the bounce
    /// light. What it leaves depends only on the frame's and meshes' uniforms (`mesh_bytes`;
    /// the image never changes under a compositor), so the rectangle is kept, and a frame drawn
    /// from the same uniforms copies it back instead of drawing the pass again.
    pub(super) fn record_reflections(
        &self,
        encoder: &mut wgpu::CommandEncoder,
        uniform: &FrameUniform,
        rows: &[i32],
        mesh_bytes: &[u8],
    ) {
        let (Some([x, y, w, h]), Some(cache)) = (self.layers.specular_rect(), &self.specular.cache) else {
            return;
        };
        if !self.reflections_drawn(uniform) {
            return;
        }
        let frame_rect = wgpu::TexelCopyTextureInfo {
            texture: &self.linear_texture,
            mip_level: 0,
            origin: wgpu::Origin3d { x, y, z: 0 },
            aspect: wgpu::TextureAspect::All,
        };
        let size = wgpu::Extent3d { width: w, height: h, depth_or_array_layers: 1 };
        if self.specular.drawn_from.renew(uniform, mesh_bytes) {
            let spheres = self.reflecting_spheres(uniform);
            let bind_row = |pass: &mut wgpu::RenderPass<'_>, row: u32| self.bind_sphere_row(pass, rows, row);
            // The mirror draws replace the reflected light (read from the backdrop after
            // shadows; a pixel changes in one draw at most).
            if self.layers.reflection.is_some() {
                {
                    let mut pass = self.begin_frame_pass(encoder, &self.linear_view, false);
                    pass.set_scissor_rect(x, y, w, h);
                    self.draw_reflection(&mut pass, rows, spheres, ReflectionDraw::Mirror);
                }
                self.copy_to_shadowed(encoder, [x, y, w, h]);
            }
            // Each sphere's glossy draw adds its share to what the draws before it left (copied
            // into the backdrop after shadows, which the next draw reads): the frame's colour
            // target cannot be blended in every format.
            if self.layers.glossy.is_some() && self.reduced.moving() {
                self.record_glossy_reduced(encoder, uniform, [x, y, w, h], spheres, &bind_row);
            } else if self.layers.glossy.is_some() {
                for row in 0..spheres {
                    {
                        let mut pass = self.begin_frame_pass(encoder, &self.linear_view, false);
                        pass.set_scissor_rect(x, y, w, h);
                        self.draw_reflection(&mut pass, rows, spheres, ReflectionDraw::Glossy(row));
                    }
                    self.copy_to_shadowed(encoder, [x, y, w, h]);
                }
            }
            encoder.copy_texture_to_texture(frame_rect, cache.as_image_copy(), size);
        } else {
            encoder.copy_texture_to_texture(cache.as_image_copy(), frame_rect, size);
            self.copy_to_shadowed(encoder, [x, y, w, h]);
        }
    }

    /// One settling frame's band of the reflections (`settle.rs`): `band`'s draw within its
    /// rows, from the backdrop after shadows, which holds the draws before it complete (the
    /// settling frames' kept backdrop), its rows kept in the cache at their place. After a draw's
    /// last band the cache holds the draw complete ([`Compositor::copy_reflections_into`]), and
    /// after the last draw's what [`Compositor::record_reflections`] leaves, known as drawn from
    /// `uniform` and `mesh_bytes` from then on; until then from nothing.
    pub(super) fn record_reflection_band(
        &self,
        encoder: &mut wgpu::CommandEncoder,
        uniform: &FrameUniform,
        rows: &[i32],
        mesh_bytes: &[u8],
        band: ReflectionBand,
    ) {
        let (Some(rect @ [x, y, w, _]), Some(cache)) = (self.layers.specular_rect(), &self.specular.cache)
        else {
            return;
        };
        self.specular.forget();
        let [top, count] = band.rows;
        if let Some([bx, by, bw, bh]) = intersect(rect, [x, top, w, count]) {
            {
                let mut pass = self.begin_frame_pass(encoder, &self.linear_view, false);
                pass.set_scissor_rect(bx, by, bw, bh);
                self.draw_reflection(&mut pass, rows, self.reflecting_spheres(uniform), band.draw);
            }
            encoder.copy_texture_to_texture(
                wgpu::TexelCopyTextureInfo {
                    origin: wgpu::Origin3d { x: bx, y: by, z: 0 },
                    ..self.linear_texture.as_image_copy()
                },
                wgpu::TexelCopyTextureInfo {
                    origin: wgpu::Origin3d { x: bx - x, y: by - y, z: 0 },
                    ..cache.as_image_copy()
                },
                wgpu::Extent3d { width: bw, height: bh, depth_or_array_layers: 1 },
            );
        }
        if band.last {
            self.specular.drawn_from.renew(uniform, mesh_bytes);
        }
    }

    /// Copies the reflections' rectangle as the specular pass last left it (its cache) into `to`,
    /// a frame-sized texture, at its place.
    pub(super) fn copy_reflections_into(&self, encoder: &mut wgpu::CommandEncoder, to: &wgpu::Texture) {
        if let (Some([x, y, w, h]), Some(cache)) = (self.layers.specular_rect(), &self.specular.cache) {
            encoder.copy_texture_to_texture(
                cache.as_image_copy(),
                wgpu::TexelCopyTextureInfo { origin: wgpu::Origin3d { x, y, z: 0 }, ..to.as_image_copy() },
                wgpu::Extent3d { width: w, height: h, depth_or_array_layers: 1 },
            );
        }
    }

    /// The glossy draws of a moving frame within `rect` (the pixels with a lobe): each sphere's
    /// change gathered on the reduced grid at one pixel of each block of [`GLOSSY_STRIDE`]^2
    /// (`bind_row` binds a sphere's material), then spread over the frame and the rectangle
    /// copied into the backdrop after shadows. The frame's uniform marks it as moving, so the
    /// frame at rest after it draws the lobes again at full resolution.
    fn record_glossy_reduced(
        &self,
        encoder: &mut wgpu::CommandEncoder,
        uniform: &FrameUniform,
        rect: [u32; 4],
        spheres: u32,
        bind_row: &dyn Fn(&mut wgpu::RenderPass<'_>, u32),
    ) {
        self.record_spread_weights(encoder, uniform);
        let grid = self.reduced.grid();
        let size = (self.width.div_ceil(GLOSSY_STRIDE), self.height.div_ceil(GLOSSY_STRIDE));
        let [gx, gy, gw, gh] = super::reduced_gather::grid_rect(rect, GLOSSY_STRIDE, size);
        if gw == 0 || gh == 0 {
            return;
        }
        // A frame with the bounce light draws the spheres' radiosity maps before this pass.
        let gather = if uniform.bounce[0] == 1 {
            &self.specular.glossy_gather_from_maps
        } else {
            &self.specular.glossy_gather
        };
        for row in 0..spheres {
            {
                // Each draw after the first adds to what the draws before it left (read from the
                // grid's copy, binding 22).
                let load =
                    if row == 0 { wgpu::LoadOp::Clear(wgpu::Color::TRANSPARENT) } else { wgpu::LoadOp::Load };
                let mut pass = super::colour_pass(encoder, "glossy lobes, reduced", &grid.drawn_view, load);
                pass.set_pipeline(gather);
                pass.set_bind_group(0, &self.frame_bind_group, &[]);
                bind_row(&mut pass, row);
                pass.set_scissor_rect(gx, gy, gw, gh);
                pass.draw(0..3, row..row + 1);
            }
            grid.copy_drawn_to_read(encoder);
        }
        self.pass_timing.lap(
            &self.gpu.device,
            &self.gpu.queue,
            encoder,
            "spheres in glossy lobes: samples (moving)",
        );
        {
            let [x, y, w, h] = rect;
            let mut pass = self.begin_frame_pass(encoder, &self.linear_view, false);
            pass.set_scissor_rect(x, y, w, h);
            pass.set_pipeline(&self.specular.glossy_spread);
            bind_row(&mut pass, 0);
            pass.draw(0..3, 0..1);
        }
        self.copy_to_shadowed(encoder, rect);
    }
}
