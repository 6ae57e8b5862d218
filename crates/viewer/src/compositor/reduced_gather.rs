//! A moving frame's layered shadows, bounce light and shadows' second bounce, gathered at
//! reduced resolution (`shaders/reduced_gather.wgsl`).
//!
//! Both are a receiver's albedo times a function of its surface point and normal that varies
//! smoothly along a surface (the light the spheres send it; what the shadowed surfaces no longer
//! send it), and gathering that function is what costs: 4 to 32 shadow rays into the spheres'
//! radiosity maps per pixel, or 256 clusters. With `CompositorSettings::amortise_while_moving`,
//! a frame whose inputs differ from the frame before gathers it at the centre pixel of each
//! block of [`BOUNCE_STRIDE`]^2 pixels (the bounce light, within its scissor) or
//! [`LOSS_STRIDE`]^2 (the second bounce's loss, over the whole frame: every moving frame draws
//! all of it, none is left from earlier frames), and every pixel interpolates the four samples
//! nearest it that lie on its own surface, times its own albedo; a pixel with none (a sliver
//! thinner than a block) takes the one of them whose normal is nearest its own. The first frame
//! that repeats its predecessor's inputs draws both at full resolution, so the frame at rest is
//! exact from its second frame on.

use super::Compositor;
use super::layers::NO_LAYER;
use super::lighting::FrameUniform;

/// The area light's kind in `GpuLight::position`'s w (composite.wgsl LIGHT_AREA).
const LIGHT_AREA: f32 = 4.0;
use super::overlay::{Overlay, fullscreen_vertex, offscreen_pipeline};
use super::sphere_atlas::DrawnAndRead;

/// Pixels along each side of a block whose centre gathers the bounce light while moving
/// (`reduced_gather.wgsl` REDUCED_BOUNCE_STRIDE): smooth along a surface, its samples cost 153
/// ms of CPU a moving frame at 4 in the Cornell sweep on lavapipe, 45 ms at 8.
pub const BOUNCE_STRIDE: u32 = 8;
/// The same for the shadows' second bounce (REDUCED_LOSS_STRIDE): a smaller term than the
/// bounce light, smooth, and gathered over the whole frame (256 clusters a sample: at 8, its
/// samples cost 130 ms of CPU a frame in the Cornell box on lavapipe, 53 ms at 16, 19 ms at 32).
pub const LOSS_STRIDE: u32 = 32;
/// The same for the layered shadows (REDUCED_SHADOW_STRIDE): the share of each area light they
/// hide, soft but with kinks where the penumbra meets the umbra (at 4 the moving frame's relMSE
/// over the pixels a sphere changes in `tests/moving_frames.rs` was 3.2e-3, at 2 1.1e-3; in the
/// Cornell sweep, with the bounce light at 8 and the loss at 32, 2.1e-4 against 1.2e-4 at 2, 4
/// and 16: docs/viewer-frame-time.md).
pub const SHADOW_STRIDE: u32 = 4;
/// The most area lights whose layered shadows a moving frame gathers at reduced resolution
/// (REDUCED_SHADOW_LIGHTS: a share each in the grid's colour, the occlusion of indirect light in
/// its alpha). With more, or with a light with a layer that is no area light (hard shadows,
/// whose edges a block would spread), or with layers that hold several lights, a moving frame
/// draws the shadows in full.
pub const SHADOW_LIGHTS: usize = 3;
/// The finest stride, which the grid is sized for.
const GRID_STRIDE: u32 = if SHADOW_STRIDE < BOUNCE_STRIDE { SHADOW_STRIDE } else { BOUNCE_STRIDE };
const _: () = assert!(GRID_STRIDE <= LOSS_STRIDE);

/// The format of the spreading weights: each in [0, 1], renormalised where they are read.
const WEIGHTS_FORMAT: wgpu::TextureFormat = wgpu::TextureFormat::Rgba8Unorm;

/// The spreading weights' layers, in the order of `reduced_gather.wgsl`'s REDUCED_SPREAD_*: the
/// layered shadows', the bounce light's and the second bounce's loss's (their fragment entry
/// points).
const WEIGHTS_ENTRIES: [&str; 3] =
    ["fs_spread_weights_shadows", "fs_spread_weights_bounce", "fs_spread_weights_loss"];

/// Each pixel's weights of its four nearest samples at each stride (binding 34, a layer per
/// stride): which samples lie on its own surface depends on the pre-rendered surfaces alone, so
/// they are drawn once, into `drawn` a layer at a time and copied into `read`, and a moving
/// frame's spreading passes read them instead of comparing each pixel's surface with four
/// samples' (which cost most of each spreading pass on lavapipe).
#[derive(Debug)]
pub(super) struct SpreadWeights {
    drawn: wgpu::Texture,
    drawn_view: wgpu::TextureView,
    read: wgpu::Texture,
    /// The view of every layer, for the frame bind group.
    pub(super) read_view: wgpu::TextureView,
}

impl SpreadWeights {
    /// The textures for a frame of `width` x `height`: made before the frame bind group.
    pub(super) fn new(device: &wgpu::Device, (width, height): (u32, u32)) -> Self {
        let texture = |label: &str, layers: u32, usage: wgpu::TextureUsages| {
            device.create_texture(&wgpu::TextureDescriptor {
                label: Some(label),
                size: wgpu::Extent3d { width, height, depth_or_array_layers: layers },
                mip_level_count: 1,
                sample_count: 1,
                dimension: wgpu::TextureDimension::D2,
                format: WEIGHTS_FORMAT,
                usage,
                view_formats: &[],
            })
        };
        use wgpu::TextureUsages as U;
        let layers = WEIGHTS_ENTRIES.len() as u32;
        let drawn = texture("spreading weights, drawn", 1, U::RENDER_ATTACHMENT | U::COPY_SRC);
        let read = texture("spreading weights", layers, U::TEXTURE_BINDING | U::COPY_DST);
        let read_view = read.create_view(&wgpu::TextureViewDescriptor {
            dimension: Some(wgpu::TextureViewDimension::D2Array),
            ..Default::default()
        });
        SpreadWeights { drawn_view: drawn.create_view(&Default::default()), drawn, read, read_view }
    }
}

/// The grid of samples (binding 22), sized for the finest stride, the spreading weights and
/// their pipelines.
#[derive(Debug)]
pub(super) struct ReducedGather {
    grid: DrawnAndRead,
    weights: SpreadWeights,
    /// The pipelines drawing each layer of the weights.
    weights_pipelines: Vec<wgpu::RenderPipeline>,
    /// What the weights were drawn from (the frame uniform's albedo and normal layers; none
    /// before they are first drawn): the depth and the layers stay for the compositor's life.
    weights_from: std::cell::Cell<Option<[u32; 3]>>,
    bounce_gather: wgpu::RenderPipeline,
    bounce_spread: wgpu::RenderPipeline,
    loss_gather: wgpu::RenderPipeline,
    loss_spread: wgpu::RenderPipeline,
    shadow_gather: wgpu::RenderPipeline,
    shadow_spread: wgpu::RenderPipeline,
    /// The inputs of the frame before (empty before the first): a frame with others moves.
    last_frame: std::cell::RefCell<Vec<u8>>,
    /// Whether the frame being drawn moves (and amortises): set by [`ReducedGather::begin_frame`].
    moving: std::cell::Cell<bool>,
    /// Whether the frame being drawn gathers the layered shadows at reduced resolution (then
    /// what reads the backdrop after shadows and is kept, such as the second bounce's clusters,
    /// is drawn again at rest).
    pub(super) shadows_reduced: std::cell::Cell<bool>,
    /// The first frames at rest after a move (settle.rs).
    pub(super) settle: super::settle::Settle,
}

/// The grid's textures for a frame of `width` x `height`: made before the frame bind group.
pub(super) fn grid_textures(
    device: &wgpu::Device,
    (width, height): (u32, u32),
    linear_format: wgpu::TextureFormat,
) -> DrawnAndRead {
    let size = (width.div_ceil(GRID_STRIDE), height.div_ceil(GRID_STRIDE));
    DrawnAndRead::new(device, "reduced gather", linear_format, size)
}

impl ReducedGather {
    /// The pipelines from the compositing shaders' `module` with the frame bind group alone
    /// (`frame_only`), for a frame in `linear_format` with a depth buffer in `depth_format`;
    /// the bounce light's spreading takes the light a sphere hides from behind it only with
    /// `occlusion_from_behind` (`CompositorSettings`).
    pub(super) fn new(
        device: &wgpu::Device,
        (grid, weights): (DrawnAndRead, SpreadWeights),
        (module, frame_only): (&wgpu::ShaderModule, &wgpu::PipelineLayout),
        (linear_format, depth_format): (wgpu::TextureFormat, wgpu::TextureFormat),
        occlusion_from_behind: bool,
    ) -> Self {
        let vertex = fullscreen_vertex(module);
        let alone = |label: &str, entry: &str, format: wgpu::TextureFormat| {
            offscreen_pipeline(device, module, frame_only, (label, entry), format)
        };
        let overlay = Overlay { module, linear_format, mask_format: super::MASK_FORMAT, depth_format };
        ReducedGather {
            bounce_gather: alone("bounce light, reduced", "fs_bounce_gather", linear_format),
            bounce_spread: overlay.pipeline(
                device,
                "bounce light, spread",
                frame_only,
                vertex.clone(),
                if occlusion_from_behind { "fs_bounce_spread_from_behind" } else { "fs_bounce_spread" },
            ),
            loss_gather: alone("shadow bounce taken, reduced", "fs_loss_gather", linear_format),
            loss_spread: alone(
                "shadow bounce taken, spread",
                "fs_loss_spread",
                super::shadow_bounce::TAKEN_FORMAT,
            ),
            shadow_gather: alone("layered shadows, reduced", "fs_shadow_gather", linear_format),
            shadow_spread: overlay.pipeline(
                device,
                "layered shadows, spread",
                frame_only,
                vertex.clone(),
                "fs_shadow_spread",
            ),
            weights_pipelines: WEIGHTS_ENTRIES
                .iter()
                .map(|&entry| alone("spreading weights", entry, WEIGHTS_FORMAT))
                .collect(),
            weights,
            weights_from: Default::default(),
            grid,
            last_frame: Default::default(),
            moving: Default::default(),
            shadows_reduced: Default::default(),
            settle: Default::default(),
        }
    }

    /// Notes the inputs of the frame being drawn (`key`: the frame's uniform, the mesh uniforms
    /// and meshes) and whether it moves and is reduced: with `reduce`, a frame whose inputs
    /// differ from the frame before's (not the first frame).
    pub(super) fn begin_frame(&self, key: Vec<u8>, reduce: bool) {
        let before = self.last_frame.replace(key);
        self.moving.set(reduce && !before.is_empty() && before != *self.last_frame.borrow());
    }

    /// Whether the frame being drawn moves: its bounce light and second bounce are gathered at
    /// reduced resolution.
    pub(super) fn moving(&self) -> bool {
        self.moving.get()
    }

    /// The grid of samples, for a reduced pass recorded elsewhere (the glossy lobes: specular.rs).
    pub(super) fn grid(&self) -> &DrawnAndRead {
        &self.grid
    }
}

/// The grid texels whose samples the pixels of `[x, y, w, h]` read at `stride`, within a grid
/// of `grid` texels, `[x, y, w, h]` (possibly empty).
pub(super) fn grid_rect([x, y, w, h]: [u32; 4], stride: u32, grid: (u32, u32)) -> [u32; 4] {
    let (x0, y0) = ((x / stride).saturating_sub(1), (y / stride).saturating_sub(1));
    let x1 = ((x + w) / stride + 2).min(grid.0);
    let y1 = ((y + h) / stride + 2).min(grid.1);
    [x0, y0, x1.saturating_sub(x0), y1.saturating_sub(y0)]
}

/// Whether a moving frame can gather the layered shadows of `uniform` at reduced resolution:
/// each layer holds one light, and the lights with a layer are one to [`SHADOW_LIGHTS`] area
/// lights.
pub(super) fn shadows_fit(uniform: &FrameUniform) -> bool {
    let lights = (uniform.counts[0] as usize).min(uniform.shadow_slots.len());
    let layered: Vec<usize> = (0..lights).filter(|&i| uniform.shadow_slots[i][0] != NO_LAYER).collect();
    uniform.shadow_params[2] < 0.5
        && (1..=SHADOW_LIGHTS).contains(&layered.len())
        && layered.iter().all(|&i| uniform.lights[i].position[3] == LIGHT_AREA)
}

impl Compositor {
    /// Draws the spreading weights (`SpreadWeights`) unless they were drawn from the same
    /// layers of `uniform` (the frame's): before a moving frame's spreading passes.
    pub(super) fn record_spread_weights(&self, encoder: &mut wgpu::CommandEncoder, uniform: &FrameUniform) {
        let reduced = &self.reduced;
        let from = [uniform.bounce[1], uniform.shadow_bounce[3], uniform.layer_info[2]];
        if reduced.weights_from.replace(Some(from)) == Some(from) {
            return;
        }
        let weights = &reduced.weights;
        for (layer, pipeline) in reduced.weights_pipelines.iter().enumerate() {
            {
                let clear = wgpu::LoadOp::Clear(wgpu::Color::TRANSPARENT);
                let mut pass = super::colour_pass(encoder, "spreading weights", &weights.drawn_view, clear);
                pass.set_pipeline(pipeline);
                pass.set_bind_group(0, &self.frame_bind_group, &[]);
                pass.draw(0..3, 0..1);
            }
            let mut to = weights.read.as_image_copy();
            to.origin.z = layer as u32;
            encoder.copy_texture_to_texture(weights.drawn.as_image_copy(), to, weights.drawn.size());
        }
        self.pass_timing.lap(&self.gpu.device, &self.gpu.queue, encoder, "spreading weights");
    }

    /// Gathers the grid of samples at `stride` with `pipeline` over the texels pixels of `rect`
    /// read, and copies it where the spreading pass reads it.
    fn record_grid(
        &self,
        encoder: &mut wgpu::CommandEncoder,
        (pipeline, what): (&wgpu::RenderPipeline, &'static str),
        stride: u32,
        rect: [u32; 4],
    ) {
        let grid = &self.reduced.grid;
        let size = (self.width.div_ceil(stride), self.height.div_ceil(stride));
        let [x, y, w, h] = grid_rect(rect, stride, size);
        if w == 0 || h == 0 {
            return;
        }
        {
            let clear = wgpu::LoadOp::Clear(wgpu::Color::TRANSPARENT);
            let mut pass = super::colour_pass(encoder, "reduced gather", &grid.drawn_view, clear);
            pass.set_pipeline(pipeline);
            pass.set_bind_group(0, &self.frame_bind_group, &[]);
            pass.set_scissor_rect(x, y, w, h);
            pass.draw(0..3, 0..1);
        }
        grid.copy_drawn_to_read(encoder);
        self.pass_timing.lap(&self.gpu.device, &self.gpu.queue, encoder, what);
    }

    /// The bounce light of a moving frame within `rect` (`Compositor::bounce_scissor`): gathered
    /// on the grid, spread over the frame after shadows, and that rectangle copied into the
    /// backdrop after shadows (as `record_bounce` does at full resolution).
    pub(super) fn record_bounce_reduced(&self, encoder: &mut wgpu::CommandEncoder, rect: [u32; 4]) {
        let reduced = &self.reduced;
        let gather = (&reduced.bounce_gather, "bounce light: samples (moving)");
        self.record_grid(encoder, gather, BOUNCE_STRIDE, rect);
        {
            let [x, y, w, h] = rect;
            let mut pass = self.begin_frame_pass(encoder, &self.linear_view, false);
            pass.set_scissor_rect(x, y, w, h);
            pass.set_pipeline(&reduced.bounce_spread);
            pass.draw(0..3, 0..1);
        }
        self.copy_to_shadowed(encoder, rect);
    }

    /// The layered shadows of a moving frame within `rect` (`Compositor::shadow_scissor_all`):
    /// the share of each light the live objects hide and their occlusion of indirect light
    /// gathered on the grid, then the backdrop (drawn before, in the frame) darkened by them
    /// through each pixel's own layers.
    pub(super) fn record_shadows_reduced(&self, encoder: &mut wgpu::CommandEncoder, rect: [u32; 4]) {
        let reduced = &self.reduced;
        let gather = (&reduced.shadow_gather, "layered shadows: samples (moving)");
        self.record_grid(encoder, gather, SHADOW_STRIDE, rect);
        let [x, y, w, h] = rect;
        let mut pass = self.begin_frame_pass(encoder, &self.linear_view, false);
        pass.set_scissor_rect(x, y, w, h);
        pass.set_pipeline(&reduced.shadow_spread);
        pass.draw(0..3, 0..1);
    }

    /// What each pixel of the whole frame loses to the second bounce, gathered on the grid and
    /// spread into `taken` (drawn, then copied where the removing pass reads it).
    pub(super) fn record_loss_reduced(&self, encoder: &mut wgpu::CommandEncoder, taken: &DrawnAndRead) {
        let reduced = &self.reduced;
        let gather = (&reduced.loss_gather, "second bounce: samples (moving)");
        self.record_grid(encoder, gather, LOSS_STRIDE, [0, 0, self.width, self.height]);
        {
            let clear = wgpu::LoadOp::Clear(wgpu::Color::TRANSPARENT);
            let mut pass =
                super::colour_pass(encoder, "shadow bounce taken, spread", &taken.drawn_view, clear);
            pass.set_pipeline(&reduced.loss_spread);
            pass.set_bind_group(0, &self.frame_bind_group, &[]);
            pass.draw(0..3, 0..1);
        }
        taken.copy_drawn_to_read(encoder);
    }
}

#[cfg(test)]
mod tests {
    use super::{BOUNCE_STRIDE, LOSS_STRIDE, SHADOW_LIGHTS, SHADOW_STRIDE, grid_rect};

    /// The shader's strides are the ones the grid's passes are sized and scissored for.
    #[test]
    fn the_shader_has_the_same_strides() {
        let wgsl = include_str!("../shaders/reduced_gather.wgsl");
        for line in [
            format!("const REDUCED_BOUNCE_STRIDE: i32 = {BOUNCE_STRIDE};"),
            format!("const REDUCED_LOSS_STRIDE: i32 = {LOSS_STRIDE};"),
            format!("const REDUCED_SHADOW_STRIDE: i32 = {SHADOW_STRIDE};"),
            format!("const REDUCED_SHADOW_LIGHTS: u32 = {SHADOW_LIGHTS}u;"),
            format!("const REDUCED_GLOSSY_STRIDE: i32 = {};", super::super::specular::GLOSSY_STRIDE),
        ] {
            assert!(wgsl.lines().any(|l| l == line), "reduced_gather.wgsl lacks `{line}`");
        }
    }

    /// The texels a rectangle's pixels read hold the two samples either side of every pixel
    /// (pixel `i` reads the texels `floor((i - stride / 2) / stride)` and the next).
    #[test]
    fn the_grid_rect_holds_every_sample_its_pixels_read() {
        for stride in [2u32, 4, 8] {
            let grid = (512u32.div_ceil(stride), 300u32.div_ceil(stride));
            for rect in [[0, 0, 512, 300], [37, 5, 100, 1], [511, 299, 1, 1], [3, 200, 7, 100]] {
                let [gx, gy, gw, gh] = grid_rect(rect, stride, grid);
                for (lo, n, g0, gn, size) in
                    [(rect[0], rect[2], gx, gw, grid.0), (rect[1], rect[3], gy, gh, grid.1)]
                {
                    for i in lo..lo + n {
                        let below = (i as i64 - i64::from(stride / 2)).div_euclid(i64::from(stride));
                        for q in [below, below + 1] {
                            if q >= 0 && q < i64::from(size) {
                                assert!(
                                    q >= i64::from(g0) && q < i64::from(g0 + gn),
                                    "stride {stride}, rect {rect:?}: pixel {i} reads texel {q} outside {g0}+{gn}"
                                );
                            }
                        }
                    }
                }
            }
        }
    }
}
