//! One frame: the uniforms and live meshes uploaded, then the backdrop, the live objects, the
//! shadows, the antialiased edges and the readback copies recorded and submitted.

use super::lighting::{FrameUniform, GpuMaterial, MeshUniform, mat4_f32};
use super::pass_timing::PassTime;
use super::settle::{SettlePart, SettleStep};
use super::{CompositeMode, Compositor, loss_map, reduced_gather};
use crate::error::ViewerError;
use crate::live::LiveObjects;
use glam::{DMat3, Mat4};

impl Compositor {
    /// Draws one frame into the offscreen targets and submits it. Does not wait for the GPU.
    pub fn render(&mut self, live: &LiveObjects) -> Result<(), ViewerError> {
        if self.settings.mode == CompositeMode::Points {
            self.ensure_points()?;
        }
        self.occluders.update_live(&self.gpu.queue, live, self.projection.camera().camera_from_world());
        self.caustic_shadow.update(&self.gpu.queue, super::caustic_shadow::blocking_spheres(live));
        let mut uniform = self.frame_uniform(live);
        uniform.shadow_bounce = self.shadow_bounce_uniform(&uniform);

        let loss_map_rows = loss_map::mesh_rows(&uniform, live);
        // Meshes: register new ones, then one uniform slot per instance.
        let mut mesh_bytes = Vec::new();
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
            mesh_bytes = vec![0u8; (needed * self.mesh_uniform_stride) as usize];
            for (slot, instance) in live.meshes.iter().filter(|m| m.world_from_object.is_finite()).enumerate()
            {
                let camera_from_object = camera_from_world * instance.world_from_object;
                let normal = DMat3::from_mat4(camera_from_object).inverse().transpose();
                let u = MeshUniform {
                    camera_from_object: mat4_f32(camera_from_object),
                    normal_from_object: Mat4::from_mat3(normal.as_mat3()).to_cols_array_2d(),
                    material: GpuMaterial::from(&instance.material),
                    loss_map: [loss_map_rows[slot], 0, 0, 0],
                };
                let at = slot * self.mesh_uniform_stride as usize;
                mesh_bytes[at..at + std::mem::size_of::<MeshUniform>()]
                    .copy_from_slice(bytemuck::bytes_of(&u));
            }
            self.gpu.queue.write_buffer(&self.mesh_uniform, 0, &mesh_bytes);
        }

        let sphere = uniform.counts[2] == 1;
        let antialiased =
            self.antialias.as_ref().and_then(|aa| Some((aa, self.live_bounds(&uniform, live, &draws)?)));
        let mut encoder =
            self.gpu.device.create_command_encoder(&wgpu::CommandEncoderDescriptor { label: Some("frame") });
        // Live objects' edges are resolved into the linear frame from a copy of it near them.
        let (target, target_texture) = (&self.linear_view, &self.linear_texture);
        let live_drawn = !draws.is_empty() || sphere;
        // The backdrop after shadows is read by live objects' shading (the light their shadows
        // took, with shadows on) and by their edges' resolve: kept only for them.
        let keep_shadowed = live_drawn && (uniform.counts[1] == 1 || antialiased.is_some());
        // At rest (the inputs of the last frame that drew the backdrop after shadows, bounce
        // light and second bounce in full), that backdrop is the copy the last frame left.
        let mut rest_key = mesh_bytes.clone();
        rest_key.extend(draws.iter().flat_map(|&k| (k as u64).to_le_bytes()));
        let at_rest = keep_shadowed && self.shadowed_from.is_current(&uniform, &rest_key);
        let mut frame_key = bytemuck::bytes_of(&uniform).to_vec();
        frame_key.extend_from_slice(&rest_key);
        let reduce = self.settings.amortise_while_moving && self.settings.reduce_while_moving;
        self.reduced.begin_frame(frame_key, reduce);
        let moving = self.reduced.moving();
        // The uniform the shaders read: a moving frame whose radiosity maps are drawn (this
        // frame, before the live objects) shades the cursor sphere, their row 0, from its map
        // (composite.wgsl shade_cursor_sphere), and with `cursor_map_while_moving` from the
        // map of its radiance drawn from it (2: cursor_radiance_map.rs). The flag stays out of
        // the keys above, so that the frame at rest after a move is known as such and shades
        // the sphere exactly.
        let bounce_rect = if keep_shadowed { self.bounce_scissor(&uniform) } else { None };
        let mut written = uniform;
        let sphere_from_maps = moving && sphere && bounce_rect.is_some() && uniform.layer_info[3] >= 1;
        // The radiance map holds the sphere's outside: only where the eye sees nothing else of
        // it (the sphere wholly beyond the near plane, so every visible hit is a near one).
        let [_, _, centre_depth, radius] = uniform.sphere.map(f64::from);
        let sphere_outside = centre_depth - radius > self.projection.planes().near * (1.0 + 1e-4);
        let cursor_map = sphere_from_maps && sphere_outside && self.settings.cursor_map_while_moving;
        if sphere_from_maps {
            written.tone[1] = if cursor_map { 2.0 } else { 1.0 };
        }
        // A moving frame gathers the layered shadows at reduced resolution (reduced_gather.rs)
        // after the backdrop's pass.
        let shadows_reduced = (moving
            && uniform.counts[1] == 1
            && uniform.layer_info[0] == 1
            && reduced_gather::shadows_fit(&uniform))
        .then(|| self.shadow_scissor_all(&uniform))
        .flatten();
        self.reduced.shadows_reduced.set(shadows_reduced.is_some());
        // The first frames at rest after a move draw the exact layered shadows, bounce light and
        // second bounce a part at a time (settle.rs), when there are any to draw.
        let settle = &self.reduced.settle;
        settle.begin_frame(moving, reduce && self.settings.settle_at_rest, cursor_map);
        let shadow_scissor = if uniform.counts[1] == 1 { self.shadow_scissor_all(&uniform) } else { None };
        let reflections = self.reflection_draws(&uniform);
        let settling =
            (keep_shadowed && !at_rest && (bounce_rect.is_some() || uniform.shadow_bounce[0] == 1))
                .then(|| settle.step((self.width, self.height), shadow_scissor, reflections))
                .flatten();
        // A settling frame draws the layered shadows in its step's rows alone, if any: the kept
        // backdrop holds them elsewhere (settle.rs).
        let shadow_rows = match settling.map(|step| step.part) {
            Some(SettlePart::Shadows(rows)) => Some(Some(rows)),
            Some(_) => None,
            None => Some(None),
        };
        // Only a step of the rows draws the loss (and the bounce light, unless steps of its own
        // drew it before the reflections); the others show the last moving frame's backdrop.
        let settling_without_rows = settling.is_some_and(|step| step.rows().is_none());
        // The cursor sphere's exact shading settles after the backdrop (settle.rs): from the
        // last moving frame's radiance map while the backdrop settles, then a band of its rows
        // exactly a frame at rest.
        let sphere_settling = sphere && keep_shadowed && settle.sphere.settling();
        let sphere_step = if sphere_settling && at_rest {
            let [x, y, z, r] = uniform.sphere.map(f64::from);
            // Off screen, the sphere has no rows: the first step is the last.
            let bounds = self.box_scissor(glam::DVec3::new(x, y, z), r * 1.001);
            settle.sphere.step(bounds.unwrap_or_default())
        } else {
            None
        };
        let sphere_from_map = sphere_settling && !sphere_step.is_some_and(|step| step.last);
        if shadows_reduced.is_some() {
            written.tone[2] = 1.0;
        }
        // A moving frame leaves out the near field and traces no glossy lobes (their maps would
        // be drawn again every frame); the frame at rest draws them (near_field_map.rs).
        if moving {
            written.tone[3] = 1.0;
        }
        self.gpu.queue.write_buffer(&self.frame_uniform, 0, bytemuck::bytes_of(&written));
        // A moving frame's spreading passes read weights drawn once (reduced_gather.rs).
        if moving {
            self.record_spread_weights(&mut encoder, &written);
        }
        // The maps and reflections kept while their inputs stay (loss, radiosity, specular) are
        // keyed with these flags too: what a moving frame drew of them from its approximate
        // shadows or shading is drawn again at rest.
        let keyed = written;
        // Timed frames (pass_timing.rs) draw the backdrop, its shadows and the live objects in
        // passes of their own, which gives the same pixels.
        let timing = &self.pass_timing;
        let lap = |encoder: &mut wgpu::CommandEncoder, pass: &'static str| {
            timing.lap(&self.gpu.device, &self.gpu.queue, encoder, pass)
        };
        // A frame at rest with the inputs and compositing mode of the last exact frame is that
        // frame, which the targets (colour, mask, depth and the encoded frame) still hold, as
        // nothing but `render` draws into them: nothing is drawn again. Most of such a frame's
        // cost is the live objects' exact shading (with the scene's triangles bound, hundreds
        // of shadow rays a fragment toward each area light), which depends on these inputs
        // alone.
        let mut finished_key = rest_key.clone();
        finished_key.extend_from_slice(self.settings.mode.name().as_bytes());
        if self.settings.keep_frame_at_rest
            && at_rest
            && !moving
            && settling.is_none()
            && self.finished_from.is_current(&uniform, &finished_key)
        {
            lap(&mut encoder, "the frame kept at rest");
            if timing.on {
                timing.frames.set(timing.frames.get() + 1);
            }
            self.gpu.queue.submit([encoder.finish()]);
            return self.gpu.take_errors();
        }
        // Whether this frame is exact (what a fresh compositor draws of these inputs).
        let mut exact = at_rest && !moving;
        // Live objects drawn with the backdrop read their near-field maps drawn before it (the
        // maps read the backdrop after shadows only with shadows on, which keeps that copy).
        if live_drawn && !keep_shadowed {
            self.record_near_field_maps(&mut encoder, &keyed, &loss_map_rows, &mesh_bytes);
        }
        {
            let mut pass = self.begin_frame_pass(&mut encoder, target, true);
            self.record_backdrop(&mut pass);
            if let Some(rows) = shadow_rows
                && !at_rest
                && !timing.on
                && shadows_reduced.is_none()
            {
                self.record_layered_shadows(&mut pass, &uniform, rows);
            }
            if live_drawn && !keep_shadowed && !timing.on {
                self.record_live(&mut pass, &draws, sphere);
            }
        }
        lap(&mut encoder, "backdrop");
        if let Some(rect) = shadows_reduced {
            self.record_shadows_reduced(&mut encoder, rect);
            lap(&mut encoder, "layered shadows");
        } else if let Some(rows) = shadow_rows
            && timing.on
            && !at_rest
        {
            let mut pass = self.begin_frame_pass(&mut encoder, target, false);
            self.record_layered_shadows(&mut pass, &uniform, rows);
            drop(pass);
            lap(&mut encoder, "layered shadows");
        }
        if timing.on && live_drawn && !keep_shadowed {
            self.record_live(&mut self.begin_frame_pass(&mut encoder, target, false), &draws, sphere);
            lap(&mut encoder, "live objects");
        }
        let frame_extent =
            wgpu::Extent3d { width: self.width, height: self.height, depth_or_array_layers: 1 };
        if at_rest {
            encoder.copy_texture_to_texture(
                self.shadowed_texture.as_image_copy(),
                target_texture.as_image_copy(),
                frame_extent,
            );
        } else if let Some(step) = settling
            && matches!(step.part, SettlePart::Shadows(_))
        {
            // A step of the layered shadows keeps its rows and shows the last moving frame's
            // backdrop: the maps and clusters read the exact shadows everywhere.
            self.begin_settling(&mut encoder, step);
            self.show_settling(&mut encoder, step);
            settle.finish(step, self.height);
            self.shadowed_from.forget();
            lap(&mut encoder, "settling: the last moving frame's backdrop");
        } else if keep_shadowed {
            if let Some(step) = settling {
                self.begin_settling(&mut encoder, step);
            }
            encoder.copy_texture_to_texture(
                target_texture.as_image_copy(),
                self.shadowed_texture.as_image_copy(),
                frame_extent,
            );
            lap(&mut encoder, "copy of the backdrop after shadows");
            self.record_loss_maps(&mut encoder, &keyed, &mesh_bytes);
            lap(&mut encoder, "own-shadow loss maps");
            // Before the radiosity maps, which read them on the half facing the eye.
            self.record_near_field_maps(&mut encoder, &keyed, &loss_map_rows, &mesh_bytes);
            lap(&mut encoder, "near-field maps");
            // What the shadows took, before the bounce light adds to the backdrop after them.
            self.record_shadow_bounce_clusters(&mut encoder, &uniform, &mesh_bytes);
            lap(&mut encoder, "second bounce: clusters");
            // The light the spheres reflect onto the scene, from their radiosity maps, which
            // read the loss maps (bounce.rs).
            if let Some(rect) = bounce_rect {
                self.record_radiosity_maps(&mut encoder, &keyed, &loss_map_rows, &mesh_bytes);
                lap(&mut encoder, "radiosity maps");
                if cursor_map {
                    self.record_cursor_radiance_map(&mut encoder);
                    lap(&mut encoder, "cursor sphere's radiance map");
                }
                if moving {
                    self.record_bounce_reduced(&mut encoder, rect);
                } else if let Some(step) = settling {
                    self.record_bounce_settling(&mut encoder, rect, step);
                } else {
                    self.record_bounce(&mut encoder, rect);
                }
                lap(&mut encoder, "bounce light");
            }
            // The spheres seen in mirrors and glass, after the bounce light they may reflect. The
            // settling frames draw them a band at a time, from the exact backdrop (settle.rs),
            // never from the cache, which may hold a moving frame's reflections.
            if let Some(band) = settling.and_then(SettleStep::reflection_band) {
                self.record_reflection_band(&mut encoder, &keyed, &loss_map_rows, &mesh_bytes, band);
                lap(&mut encoder, "spheres in reflections: a band");
            } else if settling.is_none_or(SettleStep::draws_reflections) {
                if settling.is_some() {
                    self.specular.forget();
                }
                self.record_reflections(&mut encoder, &keyed, &loss_map_rows, &mesh_bytes);
                lap(&mut encoder, "spheres in reflections");
            }
            // The settling frames draw the glass after the reflections, from the kept backdrop
            // (settle.rs): it reads other pixels, before the loss's removal.
            if settling.is_none_or(SettleStep::draws_transmission) {
                self.record_transmission(&mut encoder, &uniform, &loss_map_rows);
                lap(&mut encoder, "spheres seen through glass");
            }
            if !settling_without_rows {
                let rows = settling.and_then(SettleStep::rows);
                self.record_shadow_bounce_taken(&mut encoder, &uniform, &mesh_bytes, rows);
                lap(&mut encoder, "second bounce: what each pixel loses");
                self.record_shadow_bounce(&mut encoder, &uniform);
                lap(&mut encoder, "second bounce: removed");
            }
            if let Some(step) = settling {
                self.show_settling(&mut encoder, step);
                lap(&mut encoder, "settling: the rows finished and the last moving frame's");
            }
            // A frame whose second bounce is partly from earlier inputs (amortised), or a moving
            // frame (its bounce light from reduced resolution), is no copy to keep.
            // A settling frame is exact once its last rows are drawn.
            let settled = settling.is_none_or(|step| settle.finish(step, self.height));
            if self.shadow_bounce_settled(&uniform) && !moving && settled {
                self.shadowed_from.renew(&uniform, &rest_key);
                exact = !sphere_settling;
            } else {
                self.shadowed_from.forget();
            }
        }
        if at_rest {
            lap(&mut encoder, "copy of the backdrop kept at rest");
        }
        if let Some(step) = sphere_step {
            self.record_live_settling(&mut encoder, &draws, step);
            lap(&mut encoder, "live objects");
            if !settle.sphere.finish(step) {
                exact = false;
            }
        } else if keep_shadowed {
            let mut pass = self.begin_frame_pass(&mut encoder, target, false);
            let sphere_pipeline = if cursor_map || sphere_from_map {
                &self.sphere_mapped_pipeline
            } else {
                &self.sphere_pipeline
            };
            self.draw_live(&mut pass, (&self.mesh_pipeline, sphere_pipeline), &draws, sphere);
            drop(pass);
            lap(&mut encoder, "live objects");
            if sphere_from_map {
                exact = false;
            }
        }
        if let Some((_, bounds)) = antialiased {
            self.record_antialiased(&mut encoder, bounds, &draws, (sphere, cursor_map || sphere_from_map));
            lap(&mut encoder, "antialiased edges");
        }
        self.encode.record(&mut encoder, &self.frame_view);
        lap(&mut encoder, "display encoding");
        if exact {
            self.finished_from.renew(&uniform, &finished_key);
        } else {
            self.finished_from.forget();
        }
        if timing.on {
            timing.frames.set(timing.frames.get() + 1);
        }
        self.gpu.queue.submit([encoder.finish()]);
        self.gpu.take_errors()
    }

    /// Begins a pass over the frame's colour, mask and depth targets (colour into `view`),
    /// clearing them or keeping what an earlier pass drew.
    pub(super) fn begin_frame_pass<'e>(
        &self,
        encoder: &'e mut wgpu::CommandEncoder,
        view: &wgpu::TextureView,
        clear: bool,
    ) -> wgpu::RenderPass<'e> {
        let far = self.settings.depth.convention.far_window_depth();
        let (colour, mask, depth) = if clear {
            (
                wgpu::LoadOp::Clear(wgpu::Color::BLACK),
                wgpu::LoadOp::Clear(wgpu::Color::TRANSPARENT),
                wgpu::LoadOp::Clear(far),
            )
        } else {
            (wgpu::LoadOp::Load, wgpu::LoadOp::Load, wgpu::LoadOp::Load)
        };
        let mut pass = encoder.begin_render_pass(&wgpu::RenderPassDescriptor {
            label: Some("composite"),
            color_attachments: &[
                Some(wgpu::RenderPassColorAttachment {
                    view,
                    depth_slice: None,
                    resolve_target: None,
                    ops: wgpu::Operations { load: colour, store: wgpu::StoreOp::Store },
                }),
                Some(wgpu::RenderPassColorAttachment {
                    view: &self.mask_view,
                    depth_slice: None,
                    resolve_target: None,
                    ops: wgpu::Operations { load: mask, store: wgpu::StoreOp::Store },
                }),
            ],
            depth_stencil_attachment: Some(wgpu::RenderPassDepthStencilAttachment {
                view: &self.depth_view,
                depth_ops: Some(wgpu::Operations { load: depth, store: wgpu::StoreOp::Store }),
                stencil_ops: None,
            }),
            timestamp_writes: None,
            occlusion_query_set: None,
            multiview_mask: None,
        });
        pass.set_bind_group(0, &self.frame_bind_group, &[]);
        pass
    }

    /// Times each pass of the frames that follow (`pass_timing.rs`; `false`: no longer).
    pub fn set_pass_timing(&mut self, on: bool) {
        self.pass_timing.on = on;
    }

    /// What each pass took over the frames timed so far, and how many frames were timed.
    pub fn pass_times(&self) -> (Vec<PassTime>, u32) {
        (self.pass_timing.totals(), self.pass_timing.frames.get())
    }

    /// The pre-rendered image and depth.
    fn record_backdrop(&self, pass: &mut wgpu::RenderPass<'_>) {
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
    }

    /// The live objects' shadows on the backdrop, within `rows` (`[x, y, w, h]`) if given.
    fn record_layered_shadows(
        &self,
        pass: &mut wgpu::RenderPass<'_>,
        uniform: &FrameUniform,
        rows: Option<[u32; 4]>,
    ) {
        let scissor = self.shadow_scissor_all(uniform);
        let scissor = match rows {
            Some(rows) => scissor.and_then(|all| super::settle::intersect(all, rows)),
            None => scissor,
        };
        if uniform.counts[1] == 1
            && let Some([x, y, w, h]) = scissor
        {
            pass.set_scissor_rect(x, y, w, h);
            pass.set_pipeline(&self.shadow_pipeline);
            pass.draw(0..3, 0..1);
            pass.set_scissor_rect(0, 0, self.width, self.height);
        }
    }

    /// The live meshes (`draws`: their slots) and the cursor sphere, sampled at pixel centres.
    fn record_live(&self, pass: &mut wgpu::RenderPass<'_>, draws: &[usize], sphere: bool) {
        self.draw_live(pass, (&self.mesh_pipeline, &self.sphere_pipeline), draws, sphere);
    }

    /// Draws the live meshes (`draws`: their slots) and the cursor sphere with these pipelines
    /// (the centre-sampled ones; the antialiasing's coverage has its own loop, which covers
    /// live spheres drawn as meshes as exact spheres).
    pub(super) fn draw_live(
        &self,
        pass: &mut wgpu::RenderPass<'_>,
        (mesh_pipeline, sphere_pipeline): (&wgpu::RenderPipeline, &wgpu::RenderPipeline),
        draws: &[usize],
        sphere: bool,
    ) {
        if !draws.is_empty() {
            pass.set_pipeline(mesh_pipeline);
            for (slot, &k) in draws.iter().enumerate() {
                let mesh = &self.meshes[k];
                let offset = (slot as u64 * self.mesh_uniform_stride) as u32;
                pass.set_bind_group(1, &self.mesh_bind_group, &[offset]);
                pass.set_vertex_buffer(0, mesh.vertices.slice(..));
                pass.set_index_buffer(mesh.indices.slice(..), wgpu::IndexFormat::Uint32);
                pass.draw_indexed(0..mesh.index_count, 0, 0..1);
            }
        }
        if sphere {
            pass.set_pipeline(sphere_pipeline);
            pass.draw(0..36, 0..1);
        }
    }
}
