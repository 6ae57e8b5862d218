//! The first frames at rest after a move, with `CompositorSettings::settle_at_rest`: the exact
//! frame's costliest full-resolution passes drawn over several frames instead of in one, each
//! frame's work bounded.
//!
//! A moving frame gathers the layered shadows, the bounce light and the second bounce's loss at
//! reduced resolution (`reduced_gather.rs`). The frame that first repeats its predecessor's
//! inputs must draw them exactly, and on a software rasteriser that is a multi-second frame (256
//! clusters a pixel for the loss over the whole frame, hundreds of shadow rays a pixel for the
//! layered shadows): a hitch each time the user stops. So the frames at rest settle in steps
//! ([`SettleStep`]), in order: the exact layered shadows a band of their scissor's rows at a
//! time ([`SETTLE_SHADOW_PIXELS`] a frame); then the maps and the clusters, which read the
//! backdrop after shadows everywhere, from the exact shadows; then the exact bounce light, loss
//! and its removal a band of the frame's rows at a time ([`SETTLE_PIXELS`] a frame), from the
//! top. In a scene with spheres seen in mirrors, glossy lobes or through glass, which read the
//! backdrop after the exact shadows and bounce light at other pixels than their own, the bounce
//! light settles first, in bands of rows kept ([`SettlePart::Bounce`]), then the reflections from
//! the kept backdrop ([`SettlePart::Reflections`]), then the glass, whole, from the kept backdrop
//! with the reflections ([`SettlePart::Transmission`]), then the loss and its removal settle in
//! bands of rows.
//! The reflections are drawn a draw at a time, as the specular pass draws them
//! ([`ReflectionDraws`]): the mirror's in one frame, then each sphere's glossy lobes a band of
//! the reflections' rectangle's rows a frame ([`SETTLE_REFLECTION_PIXELS`]). Each draw reads the
//! backdrop after shadows as the draws before it left it, at other pixels than its own: its bands
//! are drawn from the kept backdrop, which holds the draws before it complete, and kept in the
//! specular pass's cache until its last band, when the cache, the draw complete, goes into the
//! kept backdrop. The backdrop after the exact shadows is kept between the frames (`kept`), and in
//! the rows done the finished backdrop replaces it, so each band is drawn once. Every frame shows
//! the rows done and, below them, the backdrop the last moving frame drew for these very inputs
//! (`moving_backdrop`): no frame is further from the exact one than the moving frame was. The
//! bounce light, loss and removal read only their own pixel of what the bands change, so when the
//! last band is drawn the frame is, bit for bit, the exact one; the frames after it copy it as any
//! frame at rest does.
//!
//! The cursor sphere's exact shading settles after the backdrop (`settle_sphere.rs`).

use super::Compositor;
use super::settle_sphere::SphereSettle;
use std::cell::{Cell, RefCell};

/// The pixels a settling frame draws the bounce light, the loss and its removal in exactly, at
/// most (one row at least): 4 rows at 512^2, 128 frames for the whole frame. On lavapipe the
/// loss costs 25 to 50 us of CPU a pixel in the frame bench's room (its clusters refined near
/// the receiver and where the sphere stands between), so a band of 4 rows costs 60 to 100 ms
/// of CPU besides the frame's other 35 to 60; with 8 rows the floor's bands cost up to 250 ms
/// (docs/viewer-frame-time.md). The plain frame then cost 118 to 154 ms, half of it a pipeline
/// lavapipe compiled every frame; it is 80 ms since the storage buffers, and a frame after a
/// stop with a band of 4 rows of the loss costs 90 to 190 ms.
pub const SETTLE_PIXELS: u32 = 1 << 11;

/// The pixels of the layered shadows' scissor a settling frame draws them in exactly, at most
/// (one row at least): a quarter of the frame at 512^2 (about 0.5 s in full on lavapipe).
pub const SETTLE_SHADOW_PIXELS: u32 = 1 << 16;

/// The pixels of the reflections' rectangle a settling frame draws a sphere's glossy lobes in
/// exactly, at most (one row at least): 2 rows at 512 wide. Each pixel traces 64 lobe directions
/// through the depth. In the frame bench's glossy-floor room at 512^2 on lavapipe a frame with a
/// band of 2 rows costs 97 to 175 ms of CPU (the settling frame's other passes about 35 of them;
/// the floor's far rows the cheapest), about one plain frame (125 ms), less than the loss's bands
/// (up to 230 ms); with 4 rows a band it cost up to 290 ms (docs/viewer-frame-time.md).
pub const SETTLE_REFLECTION_PIXELS: u32 = 1 << 10;

/// Where the frames since the last move stand.
#[derive(Debug, Default)]
pub(super) struct Settle {
    /// Whether the frame before moved.
    was_moving: Cell<bool>,
    /// Whether the frames since the last move are settling: from the first frame at rest after a
    /// move until its exact frame is complete.
    active: Cell<bool>,
    /// Whether a settling frame was drawn since the move (the first copies the last moving
    /// frame's backdrop into `moving_backdrop`).
    started: Cell<bool>,
    /// Rows of the layered shadows' scissor drawn exactly since the move, from its top.
    shadow_rows_done: Cell<u32>,
    /// Whether the maps and clusters were drawn from the exact shadows since the move.
    maps_done: Cell<bool>,
    /// Rows of the frame whose exact bounce light is kept (`kept`) since the move, from the top,
    /// when the reflections settle on their own ([`SettlePart::Bounce`]).
    bounce_rows_done: Cell<u32>,
    /// The reflections' draws ([`ReflectionDraws`]) complete since the move, in their order.
    reflection_draws_done: Cell<u32>,
    /// Rows of the reflections' rectangle the draw after them has drawn, from its top.
    reflection_rows_done: Cell<u32>,
    /// Whether the spheres in reflections were drawn from the exact backdrop since the move.
    reflections_done: Cell<bool>,
    /// Whether the spheres seen through glass were drawn from the exact backdrop since the move.
    transmission_done: Cell<bool>,
    /// Rows of the frame whose backdrop is finished (exact) since the move, from the top.
    rows_done: Cell<u32>,
    /// The backdrop after the exact shadows, and in the rows done the finished backdrop.
    kept: RefCell<Option<wgpu::Texture>>,
    /// The backdrop the last moving frame drew (before its live objects), shown below the rows
    /// done.
    moving_backdrop: RefCell<Option<wgpu::Texture>>,
    /// The cursor sphere's exact shading, settling after the backdrop.
    pub(super) sphere: SphereSettle,
}

/// What one settling frame draws.
#[derive(Clone, Copy, Debug, PartialEq)]
pub(super) struct SettleStep {
    /// The first settling frame since the move.
    pub(super) first: bool,
    pub(super) part: SettlePart,
    /// Whether the spheres in reflections settle on their own ([`SettlePart::Bounce`], then
    /// [`SettlePart::Reflections`]): then the rows' steps draw neither the bounce light nor the
    /// reflections, which the kept backdrop holds.
    pub(super) reflections: bool,
}

/// The part of the exact frame a settling frame draws.
#[derive(Clone, Copy, Debug, PartialEq)]
pub(super) enum SettlePart {
    /// The layered shadows exactly within `[x, y, w, h]` (rows of their scissor).
    Shadows([u32; 4]),
    /// The maps and the clusters, from the exact shadows.
    Maps,
    /// With reflections: the bounce light exactly in the frame's rows `[top, count]`, kept.
    Bounce([u32; 2]),
    /// With reflections: a band of one of the reflections' draws, from the kept backdrop (the
    /// exact shadows and bounce light everywhere, which the mirror reads at the surfaces it
    /// reflects, and the draws before it), kept once the draw is complete.
    Reflections(ReflectionBand),
    /// With spheres seen through glass: their draw, whole, from the kept backdrop after the
    /// reflections (it reads the backdrop after the exact shadows, bounce light and reflections
    /// where the exit rays meet the scene, before the loss's removal), kept. Every moving frame
    /// draws it whole too, so it costs no more than theirs.
    Transmission,
    /// The bounce light (without reflections), the loss and its removal exactly in the frame's
    /// rows `[top, count]`.
    Rows([u32; 2]),
}

impl SettleStep {
    /// The frame's rows `[top, count]` this step finishes (none before the rows' steps).
    pub(super) fn rows(self) -> Option<[u32; 2]> {
        match self.part {
            SettlePart::Rows(rows) => Some(rows),
            _ => None,
        }
    }

    /// The frame's rows `[top, count]` this step draws the exact bounce light in, if any.
    pub(super) fn bounce_rows(self) -> Option<[u32; 2]> {
        match self.part {
            SettlePart::Bounce(rows) => Some(rows),
            SettlePart::Rows(rows) if !self.reflections => Some(rows),
            _ => None,
        }
    }

    /// Whether this step draws the spheres in reflections whole (a step of the rows does when
    /// they do not settle on their own, for a scene without them: nothing).
    pub(super) fn draws_reflections(self) -> bool {
        matches!(self.part, SettlePart::Rows(_)) && !self.reflections
    }

    /// Whether this step draws the spheres seen through glass: their own step, or a step of
    /// the rows when the glass does not settle on its own.
    pub(super) fn draws_transmission(self) -> bool {
        self.part == SettlePart::Transmission || self.draws_reflections()
    }

    /// The band of the reflections this step draws, if any.
    pub(super) fn reflection_band(self) -> Option<ReflectionBand> {
        match self.part {
            SettlePart::Reflections(band) => Some(band),
            _ => None,
        }
    }
}

/// The draws of the spheres in reflections and seen through glass, in the exact frame's order
/// (`Compositor::record_reflections`, then `Compositor::record_transmission`): the mirror's
/// (every sphere in one pass), then each sphere's glossy draw, each reading what the draws
/// before it left at other pixels than its own, then the glass's ([`SettlePart::Transmission`]).
#[derive(Clone, Copy, Debug, PartialEq)]
pub(super) struct ReflectionDraws {
    /// The pixels with a specular reflection or a glossy lobe, `[x, y, w, h]` (unused without
    /// mirror and glossy draws).
    pub(super) rect: [u32; 4],
    /// Whether the frame has mirrors: the mirror's draw comes first.
    pub(super) mirror: bool,
    /// The glossy draws, one per sphere (none without glossy lobes).
    pub(super) glossy: u32,
    /// Whether the frame shows spheres through glass: that draw comes last, whole in one frame.
    pub(super) transmission: bool,
}

/// One of [`ReflectionDraws`].
#[derive(Clone, Copy, Debug, PartialEq)]
pub(super) enum ReflectionDraw {
    /// The spheres in mirrors, all in one pass.
    Mirror,
    /// The glossy lobes of the sphere in this row of the shadow spheres.
    Glossy(u32),
}

/// What one settling frame draws of the reflections: `draw` within the frame's rows `rows`
/// (`[top, count]`, of the reflections' rectangle).
#[derive(Clone, Copy, Debug, PartialEq)]
pub(super) struct ReflectionBand {
    pub(super) draw: ReflectionDraw,
    pub(super) rows: [u32; 2],
    /// The draw's last band: the draw is complete after it.
    pub(super) draw_complete: bool,
    /// The last draw's last band: the reflections are complete after it.
    pub(super) last: bool,
}

impl ReflectionDraws {
    /// How many draws there are.
    /// How many draws the specular pass makes (the glass's is not one).
    pub(super) fn count(self) -> u32 {
        u32::from(self.mirror) + self.glossy
    }

    /// The band drawn after `draws_done` draws and `rows_done` rows of the next: the mirror's
    /// whole rectangle (the moving frames draw it in full too, so it costs no more than theirs),
    /// a glossy draw's rows as [`SETTLE_REFLECTION_PIXELS`] allow.
    fn band(self, draws_done: u32, rows_done: u32) -> ReflectionBand {
        let [_, y, w, h] = self.rect;
        let done = rows_done.min(h);
        let (draw, rows) = if self.mirror && draws_done == 0 {
            (ReflectionDraw::Mirror, h - done)
        } else {
            let glossy = draws_done - u32::from(self.mirror);
            (ReflectionDraw::Glossy(glossy), (SETTLE_REFLECTION_PIXELS / w.max(1)).max(1).min(h - done))
        };
        let draw_complete = done + rows == h;
        ReflectionBand {
            draw,
            rows: [y + done, rows],
            draw_complete,
            last: draw_complete && draws_done + 1 >= self.count(),
        }
    }
}

impl Settle {
    /// Notes whether the frame being drawn moves, and if so whether it draws the cursor sphere's
    /// radiance map (`cursor_map`); with `enabled`, the first frame that does not move after one
    /// that did starts settling, the cursor sphere's shading too where the map holds it.
    pub(super) fn begin_frame(&self, moving: bool, enabled: bool, cursor_map: bool) {
        if moving {
            self.active.set(false);
            self.sphere.moving(cursor_map);
        } else if self.was_moving.get() && enabled {
            self.active.set(true);
            self.started.set(false);
            self.shadow_rows_done.set(0);
            self.maps_done.set(false);
            self.bounce_rows_done.set(0);
            self.reflection_draws_done.set(0);
            self.reflection_rows_done.set(0);
            self.reflections_done.set(false);
            self.transmission_done.set(false);
            self.rows_done.set(0);
            self.sphere.start();
        }
        self.was_moving.set(moving);
    }

    /// The step this frame draws, `None` when it is not settling, for a frame of `size` whose
    /// layered shadows are drawn within `shadow_scissor` (`None`: none are) and which shows the
    /// spheres in reflections with these draws (`reflections`: they read the backdrop after the
    /// exact shadows and bounce light at other pixels, so these settle before them, then the
    /// reflections, then the loss in the rows).
    pub(super) fn step(
        &self,
        (width, height): (u32, u32),
        shadow_scissor: Option<[u32; 4]>,
        reflections: Option<ReflectionDraws>,
    ) -> Option<SettleStep> {
        if !self.active.get() {
            return None;
        }
        let first = !self.started.get();
        let shadows_left = shadow_scissor.filter(|[_, _, _, h]| self.shadow_rows_done.get() < *h);
        let part = if let Some([x, y, w, h]) = shadows_left {
            let done = self.shadow_rows_done.get();
            let rows = (SETTLE_SHADOW_PIXELS / w.max(1)).max(1).min(h - done);
            SettlePart::Shadows([x, y + done, w, rows])
        } else if !self.maps_done.get() {
            SettlePart::Maps
        } else if reflections.is_some() && self.bounce_rows_done.get() < height {
            SettlePart::Bounce(rows_band(self.bounce_rows_done.get(), (width, height)))
        } else if let Some(draws) = reflections.filter(|d| d.count() > 0 && !self.reflections_done.get()) {
            SettlePart::Reflections(
                draws.band(self.reflection_draws_done.get(), self.reflection_rows_done.get()),
            )
        } else if reflections.is_some_and(|d| d.transmission) && !self.transmission_done.get() {
            SettlePart::Transmission
        } else {
            SettlePart::Rows(rows_band(self.rows_done.get(), (width, height)))
        };
        Some(SettleStep { first, part, reflections: reflections.is_some() })
    }

    /// Records `step` as drawn in a frame `height` rows high; whether the frame is now exact.
    pub(super) fn finish(&self, step: SettleStep, height: u32) -> bool {
        self.started.set(true);
        match step.part {
            SettlePart::Shadows([_, _, _, rows]) => {
                self.shadow_rows_done.set(self.shadow_rows_done.get() + rows)
            }
            SettlePart::Maps => self.maps_done.set(true),
            SettlePart::Bounce([top, rows]) => self.bounce_rows_done.set(top + rows),
            SettlePart::Reflections(band) => {
                if band.draw_complete {
                    self.reflection_draws_done.set(self.reflection_draws_done.get() + 1);
                    self.reflection_rows_done.set(0);
                } else {
                    self.reflection_rows_done.set(self.reflection_rows_done.get() + band.rows[1]);
                }
                self.reflections_done.set(band.last);
            }
            SettlePart::Transmission => self.transmission_done.set(true),
            SettlePart::Rows([top, rows]) => self.rows_done.set(top + rows),
        }
        let complete = self.rows_done.get() >= height && self.maps_done.get();
        if complete {
            self.active.set(false);
        }
        complete
    }

    /// The frame's rows whose backdrop is finished once `step` is drawn, from the top.
    pub(super) fn rows_finished(&self, step: SettleStep) -> u32 {
        step.rows().map_or(self.rows_done.get(), |[top, rows]| top + rows)
    }
}

/// The band of a frame of `size` a step of rows draws when `done` rows are drawn: as many rows
/// as [`SETTLE_PIXELS`] allow, one at least.
fn rows_band(done: u32, (width, height): (u32, u32)) -> [u32; 2] {
    let done = done.min(height);
    [done, (SETTLE_PIXELS / width.max(1)).max(1).min(height - done)]
}

/// The intersection of two rectangles, `None` when empty.
pub(super) fn intersect([ax, ay, aw, ah]: [u32; 4], [bx, by, bw, bh]: [u32; 4]) -> Option<[u32; 4]> {
    let (x0, y0) = (ax.max(bx), ay.max(by));
    let (x1, y1) = ((ax + aw).min(bx + bw), (ay + ah).min(by + bh));
    (x1 > x0 && y1 > y0).then_some([x0, y0, x1 - x0, y1 - y0])
}

impl Compositor {
    /// The texture the settling frames keep the backdrop in (made when first needed).
    pub(super) fn settle_kept(&self) -> wgpu::Texture {
        self.frame_sized_copy(&self.reduced.settle.kept, "settling backdrop")
    }

    /// The texture the settling frames keep the last moving frame's backdrop in (made when
    /// first needed).
    fn moving_backdrop(&self) -> wgpu::Texture {
        self.frame_sized_copy(&self.reduced.settle.moving_backdrop, "last moving frame's backdrop")
    }

    /// The frame-sized texture of the linear format held in `slot`, which frames copy into and
    /// out of (made when first needed).
    pub(super) fn frame_sized_copy(
        &self,
        slot: &std::cell::RefCell<Option<wgpu::Texture>>,
        label: &str,
    ) -> wgpu::Texture {
        let mut kept = slot.borrow_mut();
        kept.get_or_insert_with(|| {
            self.gpu.device.create_texture(&wgpu::TextureDescriptor {
                label: Some(label),
                size: wgpu::Extent3d { width: self.width, height: self.height, depth_or_array_layers: 1 },
                mip_level_count: 1,
                sample_count: 1,
                dimension: wgpu::TextureDimension::D2,
                format: self.linear_format,
                usage: wgpu::TextureUsages::COPY_SRC | wgpu::TextureUsages::COPY_DST,
                view_formats: &[],
            })
        })
        .clone()
    }

    /// Copies the frame's rows `[top, count]` from `from` into `to`.
    pub(super) fn copy_rows(
        &self,
        encoder: &mut wgpu::CommandEncoder,
        from: &wgpu::Texture,
        to: &wgpu::Texture,
        [top, count]: [u32; 2],
    ) {
        if count == 0 {
            return;
        }
        let origin = wgpu::Origin3d { x: 0, y: top, z: 0 };
        encoder.copy_texture_to_texture(
            wgpu::TexelCopyTextureInfo { origin, ..from.as_image_copy() },
            wgpu::TexelCopyTextureInfo { origin, ..to.as_image_copy() },
            wgpu::Extent3d { width: self.width, height: count, depth_or_array_layers: 1 },
        );
    }

    /// Begins a settling frame's backdrop after its own exact shadows: the first settling frame
    /// keeps the last moving frame's backdrop (still in the backdrop after shadows) and the
    /// frame's backdrop; a step of the layered shadows keeps the rows it drew, the others put
    /// the kept backdrop (the exact shadows, finished in the rows done) in the frame.
    pub(super) fn begin_settling(&self, encoder: &mut wgpu::CommandEncoder, step: SettleStep) {
        let kept = self.settle_kept();
        if step.first {
            self.copy_rows(encoder, &self.shadowed_texture, &self.moving_backdrop(), [0, self.height]);
            // The backdrop outside the shadows' scissor, and its shadows in this step's rows.
            self.copy_rows(encoder, &self.linear_texture, &kept, [0, self.height]);
        }
        match step.part {
            SettlePart::Shadows([_, top, _, rows]) => {
                self.copy_rows(encoder, &self.linear_texture, &kept, [top, rows])
            }
            _ => self.copy_rows(encoder, &kept, &self.linear_texture, [0, self.height]),
        }
    }

    /// The bounce light of a settling frame within `rect` (`Compositor::bounce_scissor`): exact
    /// in the rows `step` draws it in ([`SettleStep::bounce_rows`]), none elsewhere (the frame
    /// shows the last moving frame's there, [`Compositor::show_settling`]).
    pub(super) fn record_bounce_settling(
        &self,
        encoder: &mut wgpu::CommandEncoder,
        rect: [u32; 4],
        step: SettleStep,
    ) {
        if let Some([top, count]) = step.bounce_rows()
            && let Some(rows) = intersect(rect, [0, top, self.width, count])
        {
            self.record_bounce(encoder, rows);
        }
    }

    /// What a settling frame shows of the backdrop, after its passes: the rows `step` finishes
    /// kept (or those it drew the bounce light in, or the reflections once a draw is complete),
    /// then the rows finished so far from the kept backdrop and those below from the last
    /// moving frame's, copied into the backdrop after shadows too (which the live objects'
    /// shading and edges read).
    pub(super) fn show_settling(&self, encoder: &mut wgpu::CommandEncoder, step: SettleStep) {
        let kept = self.settle_kept();
        match step.part {
            SettlePart::Rows(rows) | SettlePart::Bounce(rows) => {
                self.copy_rows(encoder, &self.linear_texture, &kept, rows)
            }
            SettlePart::Transmission => self.copy_transmission_into(encoder, &kept),
            SettlePart::Reflections(band) if band.draw_complete => self.copy_reflections_into(encoder, &kept),
            _ => {}
        }
        let done = self.reduced.settle.rows_finished(step).min(self.height);
        self.copy_rows(encoder, &kept, &self.linear_texture, [0, done]);
        self.copy_rows(encoder, &self.moving_backdrop(), &self.linear_texture, [done, self.height - done]);
        self.copy_rows(encoder, &self.linear_texture, &self.shadowed_texture, [0, self.height]);
    }
}

#[cfg(test)]
mod tests {
    use super::{
        ReflectionBand, ReflectionDraw, ReflectionDraws, SETTLE_PIXELS, SETTLE_REFLECTION_PIXELS,
        SETTLE_SHADOW_PIXELS, Settle, SettlePart, SettleStep, intersect,
    };

    /// Settling draws the layered shadows a band of their scissor's rows a frame, then the maps,
    /// then the frame's rows from the top, each once and within the budgets, and the frame is
    /// exact after the last rows; it starts only after a move, with settling on.
    #[test]
    fn settling_draws_each_part_once_in_order() {
        let settle = Settle::default();
        settle.begin_frame(false, true, false);
        assert!(settle.step((512, 512), None, None).is_none(), "the first frame of all does not settle");
        settle.begin_frame(true, true, false);
        assert!(settle.step((512, 512), None, None).is_none(), "a moving frame does not settle");
        settle.begin_frame(false, true, false);
        let scissor = Some([10, 100, 300, 400]);
        let mut parts = Vec::new();
        loop {
            let step = settle.step((512, 512), scissor, None).expect("settling");
            assert_eq!(step.first, parts.is_empty());
            parts.push(step.part);
            let finished = settle.rows_finished(step);
            let exact = settle.finish(step, 512);
            assert_eq!(exact, finished == 512);
            settle.begin_frame(false, true, false);
            if exact {
                break;
            }
            assert!(parts.len() < 1000, "settling never ends");
        }
        let shadow_rows = SETTLE_SHADOW_PIXELS / 300;
        assert_eq!(parts[0], SettlePart::Shadows([10, 100, 300, shadow_rows]));
        assert_eq!(parts[1], SettlePart::Shadows([10, 100 + shadow_rows, 300, 400 - shadow_rows]));
        assert_eq!(parts[2], SettlePart::Maps);
        let rows = SETTLE_PIXELS / 512;
        assert_eq!(parts.len(), 3 + (512 / rows) as usize);
        for (k, part) in parts[3..].iter().enumerate() {
            assert_eq!(*part, SettlePart::Rows([k as u32 * rows, rows]), "rows' step {k}");
        }
        assert!(settle.step((512, 512), scissor, None).is_none(), "settled frames draw nothing more");
        // Without layered shadows the maps come first; a row wider than the budget is a step.
        settle.begin_frame(true, true, false);
        settle.begin_frame(false, true, false);
        let maps = settle.step((8192, 3), None, None).expect("settling");
        assert_eq!(maps.part, SettlePart::Maps);
        assert!(!settle.finish(maps, 3));
        for top in 0..3 {
            let step = settle.step((8192, 3), None, None).expect("settling");
            assert_eq!((step.first, step.part), (false, SettlePart::Rows([top, 1])));
            assert_eq!(settle.finish(step, 3), top == 2);
        }
        settle.begin_frame(true, true, false);
        settle.begin_frame(false, false, false);
        assert!(settle.step((512, 512), None, None).is_none(), "settling is off");
    }

    /// Settles a frame of `size` with `reflections` from the first frame at rest to the exact
    /// one, checking that it is exact after the last rows' step alone; the steps in order.
    fn settle_all(size: (u32, u32), reflections: Option<ReflectionDraws>) -> Vec<SettleStep> {
        let settle = Settle::default();
        settle.begin_frame(true, true, false);
        settle.begin_frame(false, true, false);
        let mut steps = Vec::new();
        loop {
            let step = settle.step(size, None, reflections).expect("settling");
            steps.push(step);
            let exact = settle.finish(step, size.1);
            assert_eq!(exact, step.rows().is_some_and(|[top, rows]| top + rows == size.1));
            if exact {
                break;
            }
            assert!(steps.len() < 1000, "settling never ends");
        }
        steps
    }

    /// With reflections, the bounce light settles in bands of rows before them, then the
    /// mirror's draw in one step, then each sphere's glossy draw in bands of the reflections'
    /// rows within the budget, each row once, from the top, the draws in order; the rows' steps
    /// after them draw neither; without, the rows' steps draw both.
    #[test]
    fn with_reflections_the_bounce_light_settles_before_them_and_they_in_bands() {
        let draws = ReflectionDraws { rect: [0, 300, 512, 42], mirror: true, glossy: 2, transmission: false };
        let steps = settle_all((512, 512), Some(draws));
        let bands = (512 / (SETTLE_PIXELS / 512)) as usize;
        let rows = SETTLE_PIXELS / 512;
        let glossy_rows = SETTLE_REFLECTION_PIXELS / 512;
        let glossy_bands = 42u32.div_ceil(glossy_rows) as usize;
        let reflection_steps = 1 + 2 * glossy_bands;
        assert_eq!(steps.len(), 1 + 2 * bands + reflection_steps);
        assert_eq!(steps[0].part, SettlePart::Maps);
        for k in 0..bands {
            let (bounce, loss) = (steps[1 + k], steps[1 + bands + reflection_steps + k]);
            assert_eq!(bounce.part, SettlePart::Bounce([k as u32 * rows, rows]));
            assert_eq!(bounce.bounce_rows(), Some([k as u32 * rows, rows]));
            assert!(!bounce.draws_reflections() && bounce.rows().is_none());
            assert!(bounce.reflection_band().is_none());
            assert_eq!(loss.part, SettlePart::Rows([k as u32 * rows, rows]));
            assert!(loss.bounce_rows().is_none() && !loss.draws_reflections());
            assert!(loss.reflection_band().is_none());
        }
        let reflections: Vec<ReflectionBand> = steps[1 + bands..1 + bands + reflection_steps]
            .iter()
            .map(|s| s.reflection_band().unwrap())
            .collect();
        assert!(steps[1 + bands..].iter().all(|s| s.bounce_rows().is_none() && !s.draws_reflections()));
        let mirror = ReflectionBand {
            draw: ReflectionDraw::Mirror,
            rows: [300, 42],
            draw_complete: true,
            last: false,
        };
        assert_eq!(reflections[0], mirror, "the mirror is drawn whole, first");
        for sphere in 0..2u32 {
            let glossy = &reflections[1 + sphere as usize * glossy_bands..][..glossy_bands];
            for (k, band) in glossy.iter().enumerate() {
                let top = k as u32 * glossy_rows;
                let final_band = k + 1 == glossy_bands;
                assert_eq!(band.draw, ReflectionDraw::Glossy(sphere));
                assert_eq!(band.rows, [300 + top, glossy_rows.min(42 - top)], "sphere {sphere}'s band {k}");
                assert!(band.rows[1] * 512 <= SETTLE_REFLECTION_PIXELS, "within the budget");
                assert_eq!(band.draw_complete, final_band);
                assert_eq!(band.last, final_band && sphere == 1);
            }
        }
        // Glossy lobes alone: the first sphere's bands come first; a row wider than the budget
        // is a band.
        let glossy = ReflectionDraws { rect: [5, 7, 8192, 3], mirror: false, glossy: 1, transmission: false };
        let steps = settle_all((8200, 10), Some(glossy));
        let bands: Vec<ReflectionBand> = steps.iter().filter_map(|s| s.reflection_band()).collect();
        let expected = (0..3).map(|k| ReflectionBand {
            draw: ReflectionDraw::Glossy(0),
            rows: [7 + k, 1],
            draw_complete: k == 2,
            last: k == 2,
        });
        assert_eq!(bands, expected.collect::<Vec<_>>());
        // A mirror alone is one step.
        let mirror = ReflectionDraws { rect: [0, 0, 512, 512], mirror: true, glossy: 0, transmission: false };
        let bands: Vec<ReflectionBand> =
            settle_all((512, 512), Some(mirror)).iter().filter_map(|s| s.reflection_band()).collect();
        let whole =
            ReflectionBand { draw: ReflectionDraw::Mirror, rows: [0, 512], draw_complete: true, last: true };
        assert_eq!(bands, vec![whole]);
        // Without reflections the rows' steps draw the bounce light and the reflections.
        let steps = settle_all((512, 512), None);
        assert_eq!(steps[1].bounce_rows(), Some([0, rows]));
        assert!(steps[1].draws_reflections(), "without reflections the rows' steps draw all");
        assert!(steps.iter().all(|s| s.reflection_band().is_none()));
        assert_eq!(steps.len(), 1 + bands_of(512));
    }

    /// The glass's draw comes once, whole, after the bounce light's rows and the reflections'
    /// bands and before the rows' steps, which then draw neither; with glass alone it follows
    /// the bounce light's rows.
    #[test]
    fn the_glass_settles_after_the_reflections_and_before_the_loss() {
        let parts =
            |draws| settle_all((512, 512), Some(draws)).into_iter().map(|s| s.part).collect::<Vec<_>>();
        let with_mirror =
            ReflectionDraws { rect: [0, 300, 512, 42], mirror: true, glossy: 0, transmission: true };
        let parts_with_mirror = parts(with_mirror);
        let glass = parts_with_mirror.iter().position(|p| *p == SettlePart::Transmission).expect("the glass");
        assert_eq!(parts_with_mirror.iter().filter(|p| **p == SettlePart::Transmission).count(), 1);
        assert!(matches!(parts_with_mirror[glass - 1], SettlePart::Reflections(band) if band.last));
        assert!(parts_with_mirror[glass + 1..].iter().all(|p| matches!(p, SettlePart::Rows(_))));
        assert_eq!(parts_with_mirror.len(), 1 + 2 * bands_of(512) + 2);
        let glass_alone = ReflectionDraws { rect: [0; 4], mirror: false, glossy: 0, transmission: true };
        let parts_alone = parts(glass_alone);
        let glass = parts_alone.iter().position(|p| *p == SettlePart::Transmission).expect("the glass");
        assert!(matches!(parts_alone[glass - 1], SettlePart::Bounce([top, rows]) if top + rows == 512));
        assert!(parts_alone.iter().all(|p| !matches!(p, SettlePart::Reflections(_))));
        let steps = settle_all((512, 512), Some(glass_alone));
        assert_eq!(steps.iter().filter(|s| s.draws_transmission()).count(), 1, "the glass is drawn once");
        let without = settle_all((512, 512), None);
        assert!(without.iter().filter(|s| s.rows().is_some()).all(|s| s.draws_transmission()));
        assert!(
            steps
                .iter()
                .filter(|s| s.rows().is_some())
                .all(|s| s.bounce_rows().is_none() && !s.draws_reflections())
        );
    }

    /// The rows' steps of a frame 512 wide and `height` high.
    fn bands_of(height: u32) -> usize {
        height.div_ceil(SETTLE_PIXELS / 512) as usize
    }

    /// A move while the reflections settle starts them again from the mirror's draw.
    #[test]
    fn a_move_while_the_reflections_settle_starts_them_again() {
        let draws = ReflectionDraws { rect: [0, 0, 512, 40], mirror: true, glossy: 1, transmission: false };
        let settle = Settle::default();
        settle.begin_frame(true, true, false);
        settle.begin_frame(false, true, false);
        let mut bands = 0;
        while bands < 3 {
            let step = settle.step((512, 64), None, Some(draws)).expect("settling");
            bands += usize::from(step.reflection_band().is_some());
            settle.finish(step, 64);
        }
        settle.begin_frame(true, true, false);
        settle.begin_frame(false, true, false);
        let first = loop {
            let step = settle.step((512, 64), None, Some(draws)).expect("settling");
            settle.finish(step, 64);
            if let Some(band) = step.reflection_band() {
                break band;
            }
        };
        assert_eq!(first.draw, ReflectionDraw::Mirror);
    }

    #[test]
    fn rectangles_intersect() {
        assert_eq!(intersect([0, 0, 10, 10], [5, 5, 10, 10]), Some([5, 5, 5, 5]));
        assert_eq!(intersect([0, 0, 10, 10], [10, 0, 5, 5]), None);
        assert_eq!(intersect([3, 4, 1, 1], [0, 0, 512, 512]), Some([3, 4, 1, 1]));
    }
}
