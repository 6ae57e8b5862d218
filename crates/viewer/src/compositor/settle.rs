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

use super::Compositor;
use super::shadow_bounce::{TAKEN_BANDS, band_rect};
use std::cell::{Cell, RefCell};

/// The pixels a settling frame draws exactly, at most (one band at least): one band of 16 at
/// 512^2 (on lavapipe the loss costs about 26 us of CPU a pixel, so about 0.4 s a band there).
pub const SETTLE_PIXELS: u32 = 1 << 14;

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
}

/// What one settling frame draws: `bands` (bit k: band k) exactly, the first one also the
/// shadows, maps and clusters.
#[derive(Clone, Copy, Debug, PartialEq)]
pub(super) struct SettleStep {
    pub(super) first: bool,
    pub(super) bands: u32,
}

impl Settle {
    /// Notes whether the frame being drawn moves; with `enabled`, the first frame that does not
    /// after one that did starts settling.
    pub(super) fn begin_frame(&self, moving: bool, enabled: bool) {
        if moving {
            self.active.set(false);
            self.done.set(0);
        } else if self.was_moving.get() && enabled {
            self.active.set(true);
            self.done.set(0);
        }
        self.was_moving.set(moving);
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
        let mut kept = self.reduced.settle.kept.borrow_mut();
        kept.get_or_insert_with(|| {
            self.gpu.device.create_texture(&wgpu::TextureDescriptor {
                label: Some("settling backdrop"),
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
    use super::{ALL, Settle, TAKEN_BANDS, bands_per_frame, intersect, next_bands};

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
        settle.begin_frame(false, true);
        assert!(settle.step((512, 512)).is_none(), "the first frame of all does not settle");
        settle.begin_frame(true, true);
        assert!(settle.step((512, 512)).is_none(), "a moving frame does not settle");
        settle.begin_frame(false, true);
        let mut drawn = 0;
        for k in 0..TAKEN_BANDS {
            let step = settle.step((512, 512)).expect("settling");
            assert_eq!((step.first, step.bands), (k == 0, 1 << k), "frame {k} at rest");
            assert_eq!(settle.rows_left(step, (512, 512))[1], (k + 1) * 32);
            drawn |= step.bands;
            assert_eq!(settle.finish(step), k + 1 == TAKEN_BANDS);
            settle.begin_frame(false, true);
        }
        assert_eq!(drawn, ALL);
        assert!(settle.step((512, 512)).is_none(), "settled frames draw nothing more");
        settle.begin_frame(true, true);
        settle.begin_frame(false, false);
        assert!(settle.step((512, 512)).is_none(), "settling is off");
    }

    #[test]
    fn rectangles_intersect() {
        assert_eq!(intersect([0, 0, 10, 10], [5, 5, 10, 10]), Some([5, 5, 5, 5]));
        assert_eq!(intersect([0, 0, 10, 10], [10, 0, 5, 5]), None);
        assert_eq!(intersect([3, 4, 1, 1], [0, 0, 512, 512]), Some([3, 4, 1, 1]));
    }
}
