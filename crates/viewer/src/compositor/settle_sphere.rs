//! The cursor sphere's exact shading in the first frames at rest after a move, with
//! `CompositorSettings::settle_at_rest`: a band of its rows a frame, after the backdrop
//! (`settle.rs`).
//!
//! The sphere's exact shading (with the scene's triangles bound, hundreds of shadow rays a
//! fragment toward each area light) would make the first frame at rest a hitch on a software
//! rasteriser. While the backdrop settles, the sphere is read from the radiance map the last
//! moving frame drew for these very inputs (`cursor_radiance_map.rs`: the moving frame's own
//! sphere). Once the backdrop is exact (the frames at rest that copy it), each frame shades a
//! band of the sphere's rows exactly, as many as [`SETTLE_SPHERE_PIXELS`] pixels of its bounds
//! allow, and keeps the frame's rows drawn so far (`kept`; their backdrop no longer changes), the
//! rows below still from the map. A fragment's shading depends on its own pixel alone, so the
//! frame that shades the last band (and its edges exactly) is, bit for bit, the exact frame.

use super::Compositor;
use std::cell::{Cell, RefCell};

/// The pixels of the cursor sphere's bounds a frame at rest shades exactly while the sphere
/// settles, at most (one row at least): at 512^2 on lavapipe a band of the bench's sphere then
/// costs about a sixth of its exact shading.
pub const SETTLE_SPHERE_PIXELS: u32 = 1 << 11;

/// Where the cursor sphere's exact shading stands since the last move.
#[derive(Debug, Default)]
pub(super) struct SphereSettle {
    /// Whether the cursor sphere's radiance map holds the sphere of the frame being drawn: the
    /// last moving frame drew it, and the frames at rest since have its inputs.
    map_current: Cell<bool>,
    /// Rows of the cursor sphere's bounds shaded exactly since the move, from their top; `None`
    /// when its exact shading is not settling.
    rows_done: Cell<Option<u32>>,
    /// The frame's rows whose cursor sphere is exact, as the live objects' pass left them.
    kept: RefCell<Option<wgpu::Texture>>,
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

impl SphereSettle {
    /// Notes a moving frame, and whether it draws the cursor sphere's radiance map
    /// (`cursor_map`).
    pub(super) fn moving(&self, cursor_map: bool) {
        self.map_current.set(cursor_map);
        self.rows_done.set(None);
    }

    /// Notes the first frame at rest after a move, which starts the sphere's settling where the
    /// map holds it.
    pub(super) fn start(&self) {
        self.rows_done.set(self.map_current.get().then_some(0));
    }

    /// Whether the cursor sphere's exact shading is settling: the frame shows the sphere from its
    /// radiance map but for the rows [`SphereSettle::step`] gives.
    pub(super) fn settling(&self) -> bool {
        self.rows_done.get().is_some()
    }

    /// The rows of the cursor sphere's `bounds` (`[x, y, w, h]`) a frame at rest with the exact
    /// backdrop shades exactly, and those shaded before; `None` when its shading is not settling.
    pub(super) fn step(&self, [_, y, w, h]: [u32; 4]) -> Option<SphereStep> {
        let done = self.rows_done.get()?.min(h);
        let rows = (SETTLE_SPHERE_PIXELS / w.max(1)).max(1).min(h - done);
        Some(SphereStep { kept: [y, done], band: [y + done, rows], last: done + rows == h })
    }

    /// Records `step` as drawn; whether the sphere is now exact in every row.
    pub(super) fn finish(&self, step: SphereStep) -> bool {
        if step.last {
            self.rows_done.set(None);
        } else if let Some(done) = self.rows_done.get() {
            self.rows_done.set(Some(done + step.band[1]));
        }
        step.last
    }
}

impl Compositor {
    /// The texture the frames at rest keep the cursor sphere's exact rows in (made when first
    /// needed).
    fn sphere_kept(&self) -> wgpu::Texture {
        self.frame_sized_copy(&self.reduced.settle.sphere.kept, "settling sphere rows")
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
        self.copy_rows(encoder, &self.linear_texture, &kept, step.band);
        self.copy_rows(encoder, &kept, &self.linear_texture, step.kept);
    }
}

#[cfg(test)]
mod tests {
    use super::super::settle::Settle;
    use super::SETTLE_SPHERE_PIXELS;

    /// The cursor sphere settles only after a move whose last frame drew its radiance map, a
    /// band of its rows a frame, each row once, from the top, the last band flagged.
    #[test]
    fn the_sphere_settles_row_band_by_row_band() {
        let settle = Settle::default();
        let sphere = &settle.sphere;
        settle.begin_frame(true, true, false);
        settle.begin_frame(false, true, false);
        assert!(!sphere.settling(), "no radiance map was drawn");
        settle.begin_frame(true, true, true);
        assert!(!sphere.settling(), "a moving frame does not settle");
        settle.begin_frame(false, true, false);
        assert!(sphere.settling());
        let bounds = [100, 300, 128, 100];
        let per_band = SETTLE_SPHERE_PIXELS / 128;
        let (mut next, mut frames) = (300, 0);
        loop {
            let step = sphere.step(bounds).expect("settling");
            assert_eq!(step.kept, [300, next - 300]);
            assert_eq!(step.band, [next, per_band.min(400 - next)]);
            next += step.band[1];
            frames += 1;
            assert_eq!(sphere.finish(step), next == 400);
            if step.last {
                break;
            }
        }
        assert_eq!(frames, 100u32.div_ceil(per_band));
        assert!(!sphere.settling() && sphere.step(bounds).is_none());
        settle.begin_frame(true, true, true);
        settle.begin_frame(false, true, false);
        let off_screen = sphere.step([0; 4]).expect("settling");
        assert!(off_screen.last && off_screen.band[1] == 0, "no rows: the first step is the last");
    }
}
