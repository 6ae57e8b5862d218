//! How the compositor is set up: output formats, composite mode, depth buffer and shadows.

use depth_remap::{DepthConvention, NearFar};

/// Format of the displayed frame: 8-bit unorm, not sRGB, so display bytes pass through untouched
/// (the encode pass applies the display transfer itself, `crate::display`).
pub const FRAME_FORMAT: wgpu::TextureFormat = wgpu::TextureFormat::Rgba8Unorm;
/// Format of the composited frame before display encoding: linear values in the image's own
/// units, 32-bit float so an unchanged pre-rendered pixel keeps its input value bit for bit.
/// Adapters that cannot render to it (GL's downlevel rules) get [`LINEAR_FORMAT_FALLBACK`].
pub const LINEAR_FORMAT: wgpu::TextureFormat = wgpu::TextureFormat::Rgba32Float;
/// The linear frame's format where 32-bit float is not renderable: half floats, with the
/// backdrop rounded to half precision first so unchanged pixels still compare equal.
pub const LINEAR_FORMAT_FALLBACK: wgpu::TextureFormat = wgpu::TextureFormat::Rgba16Float;

/// The linear frame's format on `adapter`: [`LINEAR_FORMAT`] where it can be rendered to, else
/// [`LINEAR_FORMAT_FALLBACK`], else none.
pub fn linear_format(adapter: &wgpu::Adapter) -> Option<wgpu::TextureFormat> {
    [LINEAR_FORMAT, LINEAR_FORMAT_FALLBACK].into_iter().find(|&f| {
        adapter.get_texture_format_features(f).allowed_usages.contains(wgpu::TextureUsages::RENDER_ATTACHMENT)
    })
}
/// Format of the live-object mask.
pub const MASK_FORMAT: wgpu::TextureFormat = wgpu::TextureFormat::R8Unorm;
/// Most lights passed to the shaders; further lights are dropped (the brightest are kept).
pub const MAX_LIGHTS: usize = 16;

/// How the pre-rendered image and its depth get into the frame. Both give identical colour and
/// depth buffers (the test suite checks it bit for bit).
#[derive(Clone, Copy, Debug, PartialEq, Eq, Hash)]
pub enum CompositeMode {
    /// The paper's: one point per pixel at `(i + 0.5, j + 0.5, window depth)` through the
    /// orthographic matrix that passes depth through.
    Points,
    /// Lawlor's: one full-screen triangle whose fragment shader reads the pixel's colour and
    /// writes its fragment depth from textures.
    Fullscreen,
}

impl CompositeMode {
    pub fn name(self) -> &'static str {
        match self {
            CompositeMode::Points => "points",
            CompositeMode::Fullscreen => "fullscreen",
        }
    }
}

/// The depth buffer: its format and which way it runs.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub struct DepthSettings {
    pub format: wgpu::TextureFormat,
    pub convention: DepthConvention,
}

impl Default for DepthSettings {
    /// Reversed-Z in a 32-bit float buffer: nearly constant relative precision in eye depth.
    fn default() -> Self {
        DepthSettings { format: wgpu::TextureFormat::Depth32Float, convention: DepthConvention::WgpuReversed }
    }
}

/// Shadows of the live sphere on the pre-rendered scene.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct ShadowSettings {
    /// The fraction of a pixel's value removed where the sphere hides the whole shadow light
    /// (the share of the pre-rendered radiance that light's direct illumination is taken to be).
    pub strength: f32,
    /// Index into the scene's lights; `None` picks the dominant light.
    pub light: Option<usize>,
}

impl Default for ShadowSettings {
    fn default() -> Self {
        ShadowSettings { strength: 0.6, light: None }
    }
}

/// How the compositor is set up.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct CompositorSettings {
    pub mode: CompositeMode,
    pub depth: DepthSettings,
    /// Near/far planes; `None` derives them from the depth table
    /// ([`crate::projection::near_far_policy`]).
    pub depth_range: Option<NearFar>,
    /// `None` disables shadows.
    pub shadows: Option<ShadowSettings>,
    /// Live objects' edges covered at four samples per pixel and filtered with the image's
    /// pixel filter (`compositor/antialias.rs`), as the ray tracer filters its own objects'
    /// edges; `false` shows each pixel's centre sample alone.
    pub antialias: bool,
    /// Live spheres read what their own shadows took from their light from a map per sphere
    /// (`compositor/loss_map.rs`); `false` gathers it per fragment (the reference the maps are
    /// tested against).
    pub own_shadow_maps: bool,
    /// Live spheres read the near field and their glossy lobes traced through the scene's
    /// triangles from a map per sphere (`compositor/near_field_map.rs`), drawn when their
    /// inputs change; `false` traces them per fragment every frame (the reference the maps are
    /// tested against). Both need the scene's materials bound.
    pub near_field_maps: bool,
    /// With light layers that hold the diffuse albedo, live spheres add the light they reflect
    /// onto the pre-rendered scene (`compositor/bounce.rs`); `false` leaves it out.
    pub bounce_light: bool,
    /// With the bounce light, the spheres' occlusion of indirect light takes the light from
    /// behind them (the image where a march through each sphere meets the scene) instead of
    /// the surface's average indirect light (`shaders/bounce.wgsl`, `occlusion_correction`).
    /// Off by default: in `cargo xtask illusion` it helped some rows as much as it hurt others
    /// (docs/viewer-bounce.md, "Live spheres light the scene").
    pub occlusion_from_behind: bool,
    /// With light layers that hold the diffuse albedo, the light the live objects' shadows
    /// take from the rest of the scene (the shadowed surfaces no longer light what they see) is
    /// removed too (`compositor/shadow_bounce.rs`); `false` leaves it.
    pub shadow_bounce: bool,
    /// While the live objects, the lights or the camera move, the costliest passes that depend
    /// only on them are drawn approximately (`reduce_while_moving` says how): a moving sphere's
    /// frame is then approximate, and the second frame at rest exact. `false` (the default)
    /// draws every frame exactly: a frame after a move equals a fresh compositor's.
    pub amortise_while_moving: bool,
    /// With `amortise_while_moving`, a moving frame gathers the bounce light and the second
    /// bounce at one pixel per block and spreads them along each surface
    /// (`compositor/reduced_gather.rs`: all of the frame fresh, smoothed); `false` draws the
    /// bounce light at full resolution and the second bounce in bands (exact, but up to
    /// `SHADOW_BOUNCE_BANDS - 1` frames old). Either way the second frame at rest is exact.
    pub reduce_while_moving: bool,
    /// With `amortise_while_moving` and `reduce_while_moving`, the first frames at rest after a
    /// move draw the exact layered shadows a band of their rows at a time
    /// (`SETTLE_SHADOW_PIXELS` a frame), then the maps, then the exact bounce light and second
    /// bounce a band of the frame's rows at a time (`SETTLE_PIXELS` a frame;
    /// `compositor/settle.rs`: exact, bit for bit, once the last rows are drawn, the rows not
    /// yet drawn shown as the last moving frame drew them) instead of all in the first, and then
    /// the cursor sphere's exact shading a band of its rows a frame (`SETTLE_SPHERE_PIXELS`;
    /// until then it is the last moving frame's, from its radiance map); `false` (the default)
    /// draws the first frame at rest exactly.
    pub settle_at_rest: bool,
    /// With `amortise_while_moving`, a moving frame shades the cursor sphere once per texel of
    /// a map of its radiance over its half facing the eye and its fragments read it
    /// (`compositor/cursor_radiance_map.rs`); `false` shades each fragment as the map's texels
    /// are shaded (the reference the map is tested against). The frame at rest is exact either
    /// way.
    pub cursor_map_while_moving: bool,
    /// A frame at rest with the inputs of the last exact frame draws nothing: the frame's
    /// targets still hold that frame (`compositor/frame.rs`); `false` draws every frame (the
    /// frame bench's plain frame, the baseline issue 10's ratio is taken against).
    pub keep_frame_at_rest: bool,
}

impl Default for CompositorSettings {
    fn default() -> Self {
        CompositorSettings {
            mode: CompositeMode::Fullscreen,
            depth: DepthSettings::default(),
            depth_range: None,
            shadows: Some(ShadowSettings::default()),
            antialias: true,
            own_shadow_maps: true,
            near_field_maps: true,
            bounce_light: true,
            occlusion_from_behind: false,
            shadow_bounce: true,
            amortise_while_moving: false,
            reduce_while_moving: true,
            settle_at_rest: false,
            cursor_map_while_moving: true,
            keep_frame_at_rest: true,
        }
    }
}
