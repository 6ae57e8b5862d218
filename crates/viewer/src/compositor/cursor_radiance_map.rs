//! The moving cursor sphere's radiance from one map (`shaders/cursor_radiance.wgsl`).
//!
//! A moving frame shades the cursor sphere from its radiosity map (`bounce.rs`) but still
//! integrates its lights' highlights over every area sample and the reflection probes' lobe per
//! fragment: the costliest pass of a moving frame. With the camera fixed, what the eye receives
//! from a point of the sphere depends on the point alone, so with
//! `CompositorSettings::cursor_map_while_moving` a moving frame shades it once per texel of a
//! [`CURSOR_RADIANCE_TEXELS`]^2 map over the sphere's half facing the eye (the loss maps'
//! layout), after the radiosity maps it reads, and the sphere's fragments and edge samples read
//! the map bilinearly. The frame at rest shades every fragment exactly, as before.

use super::Compositor;
use super::overlay::offscreen_pipeline;
use super::sphere_atlas::{DrawnAndRead, colour_pass};

/// Texels along each side of the map (`cursor_radiance.wgsl` CURSOR_RADIANCE_TEXELS).
pub const CURSOR_RADIANCE_TEXELS: u32 = 64;
/// The map the pass draws and the copy the sphere's fragments read (binding 33), in the frame's
/// linear format (`linear_format`): full floats where the adapter can render them, so that the
/// fragments read the radiance as they would have computed it, less the interpolation; half
/// floats where it cannot (GL's downlevel limits), as the frame itself.
pub(super) fn cursor_radiance_textures(device: &wgpu::Device, format: wgpu::TextureFormat) -> DrawnAndRead {
    DrawnAndRead::new(device, "cursor radiance map", format, (CURSOR_RADIANCE_TEXELS, CURSOR_RADIANCE_TEXELS))
}

/// The map's textures and the pass that draws it.
#[derive(Debug)]
pub(super) struct CursorRadianceMap {
    map: DrawnAndRead,
    pipeline: wgpu::RenderPipeline,
}

impl CursorRadianceMap {
    /// The pass over `map` (of `format`, as [`cursor_radiance_textures`] made it), with the
    /// compositing shaders' `module` and the frame bind group's pipeline `layout`.
    pub(super) fn new(
        device: &wgpu::Device,
        (map, format): (DrawnAndRead, wgpu::TextureFormat),
        module: &wgpu::ShaderModule,
        layout: &wgpu::PipelineLayout,
    ) -> CursorRadianceMap {
        let pipeline = offscreen_pipeline(
            device,
            module,
            layout,
            ("cursor radiance map", "fs_cursor_radiance_map"),
            format,
        );
        CursorRadianceMap { map, pipeline }
    }
}

impl Compositor {
    /// Draws the cursor sphere's radiance map of a moving frame, after its radiosity map, and
    /// copies it where the sphere's fragments read it.
    pub(super) fn record_cursor_radiance_map(&self, encoder: &mut wgpu::CommandEncoder) {
        let cursor = &self.cursor_radiance;
        {
            let clear = wgpu::LoadOp::Clear(wgpu::Color::TRANSPARENT);
            let mut pass = colour_pass(encoder, "cursor radiance map", &cursor.map.drawn_view, clear);
            pass.set_pipeline(&cursor.pipeline);
            pass.set_bind_group(0, &self.frame_bind_group, &[]);
            pass.draw(0..3, 0..1);
        }
        cursor.map.copy_drawn_to_read(encoder);
    }
}
