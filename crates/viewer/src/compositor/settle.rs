//! The first frames at rest after a move, with `CompositorSettings::settle_at_rest`: the exact
//! frame's costliest full-resolution passes drawn over a few frames instead of in one.
//!
//! A moving frame gathers the bounce light and the second bounce's loss at reduced resolution
//! (`reduced_gather.rs`). The frame that first repeats its predecessor's inputs must draw them
//! exactly, and at full resolution the loss alone is most of a multi-second frame on a software
//! rasteriser (256 clusters a pixel over the whole frame): a hitch each time the user stops. So
//! a settling frame draws both exactly in a few of the [`TAKEN_BANDS`] horizontal bands of the
//! frame (as many as [`SETTLE_PIXELS`] pixels allow, one at least), in order from the top, and
//! keeps the rest as the moving frame drew it: the loss its reduced gather left (for these very
//! inputs), the bounce light gathered again at reduced resolution on the rows not yet exact. The
//! backdrop after the exact shadows and the exact bounce light of the bands drawn so far is kept
//! between the settling frames (`kept`), so each band is drawn once; the shadows, the maps and
//! the clusters are drawn exactly, in full, by the first settling frame. Every pass reads only
//! its own pixel of what the bands change, so when the last band is drawn the frame is, bit for
//! bit, the exact one, at most `TAKEN_BANDS` frames after the sphere stops; the frames after it
//! copy it as any frame at rest does.
//!
//! The cursor sphere's exact shading (with the scene's triangles bound, hundreds of shadow rays a
//! fragment toward each area light) settles the same way. While the backdrop settles, the sphere
//! is read from the radiance map the last moving frame drew for these very inputs
//! (`cursor_radiance_map.rs`: the moving frame's own sphere). Once the backdrop is exact (the
//! frames at rest that copy it), each frame shades a band of the sphere's rows exactly, as many as
//! [`SETTLE_SPHERE_PIXELS`] pixels of its bounds allow, and keeps the frame's rows drawn so far
//! (`sphere_kept`; their backdrop no longer changes), the rows below still from the map. A
//! fragment's shading depends on its own pixel alone, so the frame that shades the last band
//! (and its edges exactly) is, bit for bit, the exact frame.

use super::Compositor;
use super::shadow_bounce::{TAKEN_BANDS, band_rect};
use std::cell::{Cell, RefCell};

/// The pixels a settling frame draws exactly, at most (one band at least): one band of 16 at
/// 512^2 (on lavapipe the loss costs about 26 us of CPU a pixel, so about 0.4 s a band there).
pub const SETTLE_PIXELS: u32 = 1 << 14;

/// The pixels of the cursor sphere's bounds a frame at rest shades exactly while the sphere
/// settles, at most (one row at least): at 512^2 on lavapipe a band of the bench's sphere then
/// costs about a sixth of its exact shading.
pub const SETTLE_SPHERE_PIXELS: u32 = 1 << 11;

/// Every band.
const ALL: u32 = (1 << TAKEN_BANDS) - 1;

/// Where the frames since the last move stand.
#[derive(Debug, Default)]
pub(super) struct Settle {
    /// Whether the frame before moved.
    was_moving: Cell<bool>,
    /// Whether the frames since the last move are settling: from the first frame at rest after a
    /// move until its exact frame is complete.
    active: Cell<bool>,
    /// Bit k: band k was drawn exactly since the move.
    done: Cell<u32>,
    /// The backdrop after the exact shadows, and after the exact bounce light in the bands done.
    kept: RefCell<Option<wgpu::Texture>>,
    /// Whether the cursor sphere's radiance map holds the sphere of the frame being drawn: the
    /// last moving frame drew it, and the frames at rest since have its inputs.
    sphere_map_current: Cell<bool>,
    /// Rows of the cursor sphere's bounds shaded exactly since the move, from their top; `None`
    /// when its exact shading is not settling.
    sphere_rows_done: Cell<Option<u32>>,
    /// The frame's rows whose cursor sphere is exact, as the live objects' pass left them.
    sphere_kept: RefCell<Option<wgpu::Texture>>,
}

/// What one settling frame draws: `bands` (bit k: band k) exactly, the first one also the
/// shadows, maps and clusters.
#[derive(Clone, Copy, Debug, PartialEq)]
pub(super) struct SettleStep {
    pub(super) first: bool,
    pub(super) bands: u32,
}

impl Settle {
    /// Notes whether the frame being drawn moves, and if so whether it draws the cursor sphere's
    /// radiance map (`cursor_map`); with `enabled`, the first frame that does not move after one
    /// that did starts settling, the cursor sphere's shading too where the map holds it.
    pub(super) fn begin_frame(&self, moving: bool, enabled: bool, cursor_map: bool) {
        if moving {
            self.active.set(false);
            self.done.set(0);
            self.sphere_map_current.set(cursor_map);
            self.sphere_rows_done.set(None);
        } else if self.was_moving.get() && enabled {
            self.active.set(true);
            self.done.set(0);
            self.sphere_rows_done.set(self.sphere_map_current.get().then_some(0));
        }
        self.was_moving.set(moving);
    }

    /// Whether the cursor sphere's exact shading is settling: the frame shows the sphere from its
    /// radiance map but for the rows [`Settle::sphere_step`] gives.
    pub(super) fn sphere_settling(&self) -> bool {
        self.sphere_rows_done.get().is_some()
    }

    /// The rows of the cursor sphere's `bounds` (`[x, y, w, h]`) a frame at rest with the exact
    /// backdrop shades exactly, and those shaded before; `None` when its shading is not settling.
    pub(super) fn sphere_step(&self, [_, y, w, h]: [u32; 4]) -> Option<SphereStep> {
        let done = self.sphere_rows_done.get()?.min(h);
        let rows = (SETTLE_SPHERE_PIXELS / w.max(1)).max(1).min(h - done);
        Some(SphereStep { kept: [y, done], band: [y + done, rows], last: done + rows == h })
    }

    /// Records `step` as drawn; whether the sphere is now exact in every row.
    pub(super) fn sphere_finish(&self, step: SphereStep) -> bool {
        if step.last {
            self.sphere_rows_done.set(None);
        } else if let Some(done) = self.sphere_rows_done.get() {
            self.sphere_rows_done.set(Some(done + step.band[1]));
        }
        step.last
    }

    /// The step this frame draws, `None` when it is not settling, for a frame of `size`.
    pub(super) fn step(&self, size: (u32, u32)) -> Option<SettleStep> {
        if !self.active.get() {
            return None;
        }
        let done = self.done.get();
        Some(SettleStep { first: done == 0, bands: next_bands(done, bands_per_frame(size)) })
    }

    /// Records `step` as drawn; whether the frame is now exact.
    pub(super) fn finish(&self, step: SettleStep) -> bool {
        self.done.set(self.done.get() | step.bands);
        let complete = self.done.get() == ALL;
        if complete {
            self.active.set(false);
        }
        complete
    }

    /// The rows of the frame not drawn exactly after `step`: from the top of the first band
    /// left to the bottom, `[x, y, w, h]` (empty when none is left).
    pub(super) fn rows_left(&self, step: SettleStep, (width, height): (u32, u32)) -> [u32; 4] {
        let left = ALL & !(self.done.get() | step.bands);
        match (0..TAKEN_BANDS).find(|k| left & (1 << k) != 0) {
            Some(k) => {
                let top = band_rect(k, (width, height))[1];
                [0, top, width, height - top]
            }
            None => [0, height, width, 0],
        }
    }
}

/// The frame's rows a frame at rest draws the cursor sphere exactly in while it settles (`band`:
/// its first row and how many) and those it keeps from earlier frames (`kept`, likewise);
/// `last`: the band is the last, the sphere exact after it.
#[derive(Clone, Copy, Debug, PartialEq)]
pub(super) struct SphereStep {
    pub(super) kept: [u32; 2],
    pub(super) band: [u32; 2],
    pub(super) last: bool,
}

/// Bands a settling frame draws for a frame of `size`: as many as [`SETTLE_PIXELS`] allow, one
/// at least.
fn bands_per_frame((width, height): (u32, u32)) -> u32 {
    let band = (u64::from(width) * u64::from(height)).div_ceil(u64::from(TAKEN_BANDS)).max(1);
    (u64::from(SETTLE_PIXELS) / band).clamp(1, u64::from(TAKEN_BANDS)) as u32
}

/// The first `count` bands not in `done`, from the top.
fn next_bands(done: u32, count: u32) -> u32 {
    (0..TAKEN_BANDS).filter(|k| done & (1 << k) == 0).take(count as usize).fold(0, |m, k| m | 1 << k)
}

/// The intersection of two rectangles, `None` when empty.
pub(super) fn intersect([ax, ay, aw, ah]: [u32; 4], [bx, by, bw, bh]: [u32; 4]) -> Option<[u32; 4]> {
    let (x0, y0) = (ax.max(bx), ay.max(by));
    let (x1, y1) = ((ax + aw).min(bx + bw), (ay + ah).min(by + bh));
    (x1 > x0 && y1 > y0).then_some([x0, y0, x1 - x0, y1 - y0])
}

impl Compositor {
    /// The texture the settling frames keep the backdrop in (made when first needed).
    fn settle_kept(&self) -> wgpu::Texture {
        self.frame_sized_copy(&self.reduced.settle.kept, "settling backdrop")
    }

    /// The texture the frames at rest keep the cursor sphere's exact rows in (made when first
    /// needed).
    fn sphere_kept(&self) -> wgpu::Texture {
        self.frame_sized_copy(&self.reduced.settle.sphere_kept, "settling sphere rows")
    }

    /// The frame-sized texture of the linear format held in `slot`, which frames copy into and
    /// out of (made when first needed).
    fn frame_sized_copy(
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

    /// Draws the live meshes (`draws`) exactly and the cursor sphere of a frame at rest whose
    /// sphere settles: exactly in `step`'s band, from its radiance map elsewhere, then the rows
    /// shaded exactly before put back from the kept copy (colour only: the mask and depth are
    /// the same either way) and the band's rows kept.
    pub(super) fn record_live_settling(
        &self,
        encoder: &mut wgpu::CommandEncoder,
        draws: &[usize],
        step: SphereStep,
    ) {
        let [top, rows] = step.band;
        {
            let mut pass = self.begin_frame_pass(encoder, &self.linear_view, false);
            self.draw_live(&mut pass, (&self.mesh_pipeline, &self.sphere_pipeline), draws, false);
            let below = top + rows;
            for ([y, h], pipeline) in [
                ([0, top], &self.sphere_mapped_pipeline),
                ([top, rows], &self.sphere_pipeline),
                ([below, self.height - below], &self.sphere_mapped_pipeline),
            ] {
                if h > 0 {
                    pass.set_scissor_rect(0, y, self.width, h);
                    pass.set_pipeline(pipeline);
                    pass.draw(0..36, 0..1);
                }
            }
        }
        let kept = self.sphere_kept();
        for ([y, h], into_kept) in [(step.band, true), (step.kept, false)] {
            if h == 0 {
                continue;
            }
            let (from, to) =
                if into_kept { (&self.linear_texture, &kept) } else { (&kept, &self.linear_texture) };
            let origin = wgpu::Origin3d { x: 0, y, z: 0 };
            encoder.copy_texture_to_texture(
                wgpu::TexelCopyTextureInfo { origin, ..from.as_image_copy() },
                wgpu::TexelCopyTextureInfo { origin, ..to.as_image_copy() },
                wgpu::Extent3d { width: self.width, height: h, depth_or_array_layers: 1 },
            );
        }
    }

    /// Copies `[x, y, w, h]` of the frame into the kept backdrop (`into_kept`) or back.
    pub(super) fn copy_kept(
        &self,
        encoder: &mut wgpu::CommandEncoder,
        [x, y, w, h]: [u32; 4],
        into_kept: bool,
    ) {
        let kept = self.settle_kept();
        let (from, to) =
            if into_kept { (&self.linear_texture, &kept) } else { (&kept, &self.linear_texture) };
        let origin = wgpu::Origin3d { x, y, z: 0 };
        encoder.copy_texture_to_texture(
            wgpu::TexelCopyTextureInfo { origin, ..from.as_image_copy() },
            wgpu::TexelCopyTextureInfo { origin, ..to.as_image_copy() },
            wgpu::Extent3d { width: w, height: h, depth_or_array_layers: 1 },
        );
    }

    /// The bounce light of a settling frame within `rect` (`Compositor::bounce_scissor`): exact
    /// in the rows of `step`'s bands (kept), gathered at reduced resolution in the rows left.
    pub(super) fn record_bounce_settling(
        &self,
        encoder: &mut wgpu::CommandEncoder,
        rect: [u32; 4],
        step: SettleStep,
    ) {
        let size = (self.width, self.height);
        for k in (0..TAKEN_BANDS).filter(|k| step.bands & (1 << k) != 0) {
            if let Some(rows) = intersect(rect, band_rect(k, size)) {
                self.record_bounce(encoder, rows);
                self.copy_kept(encoder, rows, true);
            }
        }
        if let Some(rows) = intersect(rect, self.reduced.settle.rows_left(step, size)) {
            self.record_bounce_reduced(encoder, rows);
        }
    }
}

#[cfg(test)]
mod tests {
    use super::{ALL, SETTLE_SPHERE_PIXELS, Settle, TAKEN_BANDS, bands_per_frame, intersect, next_bands};

    /// A settling frame draws one band at least and no more than the budget allows, and the
    /// bands are drawn in order from the top, each once.
    #[test]
    fn settling_draws_each_band_once_in_order() {
        assert_eq!(bands_per_frame((512, 512)), 1);
        assert_eq!(bands_per_frame((2048, 2048)), 1);
        assert_eq!(bands_per_frame((256, 256)), 4);
        assert_eq!(bands_per_frame((1, 1)), TAKEN_BANDS);
        assert_eq!(next_bands(0, 2), 0b11);
        assert_eq!(next_bands(0b1011, 2), 0b1_0100);
        assert_eq!(next_bands(ALL, 3), 0);
        let settle = Settle::default();
        settle.begin_frame(false, true, false);
        assert!(settle.step((512, 512)).is_none(), "the first frame of all does not settle");
        settle.begin_frame(true, true, false);
        assert!(settle.step((512, 512)).is_none(), "a moving frame does not settle");
        settle.begin_frame(false, true, false);
        let mut drawn = 0;
        for k in 0..TAKEN_BANDS {
            let step = settle.step((512, 512)).expect("settling");
            assert_eq!((step.first, step.bands), (k == 0, 1 << k), "frame {k} at rest");
            assert_eq!(settle.rows_left(step, (512, 512))[1], (k + 1) * 32);
            drawn |= step.bands;
            assert_eq!(settle.finish(step), k + 1 == TAKEN_BANDS);
            settle.begin_frame(false, true, false);
        }
        assert_eq!(drawn, ALL);
        assert!(settle.step((512, 512)).is_none(), "settled frames draw nothing more");
        settle.begin_frame(true, true, false);
        settle.begin_frame(false, false, false);
        assert!(settle.step((512, 512)).is_none(), "settling is off");
    }

    /// The cursor sphere settles only after a move whose last frame drew its radiance map, a
    /// band of its rows a frame, each row once, from the top, the last band flagged.
    #[test]
    fn the_sphere_settles_row_band_by_row_band() {
        let settle = Settle::default();
        settle.begin_frame(true, true, false);
        settle.begin_frame(false, true, false);
        assert!(!settle.sphere_settling(), "no radiance map was drawn");
        settle.begin_frame(true, true, true);
        assert!(!settle.sphere_settling(), "a moving frame does not settle");
        settle.begin_frame(false, true, false);
        assert!(settle.sphere_settling());
        let bounds = [100, 300, 128, 100];
        let per_band = SETTLE_SPHERE_PIXELS / 128;
        let (mut next, mut frames) = (300, 0);
        loop {
            let step = settle.sphere_step(bounds).expect("settling");
            assert_eq!(step.kept, [300, next - 300]);
            assert_eq!(step.band, [next, per_band.min(400 - next)]);
            next += step.band[1];
            frames += 1;
            assert_eq!(settle.sphere_finish(step), next == 400);
            if step.last {
                break;
            }
        }
        assert_eq!(frames, 100u32.div_ceil(per_band));
        assert!(!settle.sphere_settling() && settle.sphere_step(bounds).is_none());
        settle.begin_frame(true, true, true);
        settle.begin_frame(false, true, false);
        let off_screen = settle.sphere_step([0; 4]).expect("settling");
        assert!(off_screen.last && off_screen.band[1] == 0, "no rows: the first step is the last");
    }

    #[test]
    fn rectangles_intersect() {
        assert_eq!(intersect([0, 0, 10, 10], [5, 5, 10, 10]), Some([5, 5, 5, 5]));
        assert_eq!(intersect([0, 0, 10, 10], [10, 0, 5, 5]), None);
        assert_eq!(intersect([3, 4, 1, 1], [0, 0, 512, 512]), Some([3, 4, 1, 1]));
    }
}
