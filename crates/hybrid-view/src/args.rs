//! The command line (CONTRACTS.md §5): raw flags first (clap), then checked settings.

use clap::{Parser, ValueEnum};
use glam::DVec3;
use std::path::PathBuf;
use viewer::wgpu::TextureFormat;
use viewer::{CompositeMode, DepthConvention, DepthSettings};

/// Shows a pre-rendered image with live objects co-located in it: each pixel's ray-traced depth
/// is converted to what the RIB camera's perspective projection writes into a depth buffer, so
/// the live sphere occludes and is occluded by the pre-rendered scene exactly.
#[derive(Debug, Parser)]
#[command(name = "hybrid-view", version, about, long_about = None)]
pub struct Args {
    /// The pre-rendered image (TIFF, PNG, JPEG or OpenEXR).
    pub image: PathBuf,
    /// Its depth table (`.depth` text, or OpenEXR with a `Z` channel).
    pub depth: PathBuf,
    /// The RIB scene it was rendered from (camera, lights, exposure).
    pub scene: PathBuf,

    /// Render offscreen (no display needed) instead of opening a window.
    #[arg(long)]
    pub headless: bool,
    /// Write the composited frame after the last frame: OUT.png as the window shows it, OUT.exr
    /// as linear float RGB in the image's own units, before any display encoding.
    #[arg(long, value_name = "OUT.png|OUT.exr")]
    pub screenshot: Option<PathBuf>,
    /// Write a black/white PNG, white exactly where a live object is visible.
    #[arg(long, value_name = "OUT.png")]
    pub mask: Option<PathBuf>,
    /// Place the cursor sphere at this scene (world) position.
    #[arg(long, value_name = "X,Y,Z", value_parser = parse_vec3, allow_hyphen_values = true)]
    pub sphere: Option<DVec3>,
    /// Live objects in world space from a RIB fragment (spheres, polygons, standard surface
    /// shaders): what `ReadArchive "LIVE.rib"` before `WorldEnd` means to the ray tracer.
    #[arg(long, value_name = "LIVE.rib")]
    pub live: Option<PathBuf>,
    /// The sphere's radius in scene units (default: 3% of its distance from the eye).
    #[arg(long, value_name = "R", allow_negative_numbers = true)]
    pub radius: Option<f64>,
    /// How the pre-rendered image enters the frame; both give identical frames.
    #[arg(long, value_enum, default_value_t = Mode::Fullscreen)]
    pub mode: Mode,
    /// Frames to render (headless default 1; in a window, close after N frames).
    #[arg(long, value_name = "N")]
    pub frames: Option<u64>,

    /// Colour of the sphere as linear RGB (default: blue plastic).
    #[arg(long, value_name = "R,G,B", value_parser = parse_vec3)]
    pub sphere_colour: Option<DVec3>,
    /// Show the sphere in its constant colour, unlit (for masks and ground-truth checks).
    #[arg(long)]
    pub unlit: bool,
    /// Do not darken the pre-rendered scene where the sphere shadows the dominant light.
    #[arg(long)]
    pub no_shadows: bool,
    /// Draw live objects at pixel centres only, without filtering their edges with the
    /// image's pixel filter.
    #[arg(long)]
    pub no_antialias: bool,
    /// Do not add the light live spheres reflect onto the pre-rendered scene.
    #[arg(long)]
    pub no_bounce_light: bool,
    /// Do not remove the light the live objects' shadows take from the rest of the scene (the
    /// shadowed surfaces no longer lighting what they see).
    #[arg(long)]
    pub no_shadow_bounce: bool,
    /// Take the light a live sphere hides from a surface as the light of what lies behind the
    /// sphere, not that surface's average indirect light.
    #[arg(long)]
    pub occlusion_from_behind: bool,
    /// Draw every frame exactly while the sphere moves. By default a moving sphere's frame
    /// redraws the shadows' second bounce in one sixteenth of the image (the rest is at most 15
    /// frames old), and the frame is exact again from the second frame the sphere rests.
    #[arg(long)]
    pub exact_while_moving: bool,
    /// While the sphere moves, draw the bounce light at full resolution and the shadows' second
    /// bounce in one of 16 bands a frame (the rest up to 15 frames old), instead of gathering
    /// both at one pixel in 4x4 and 16x16 blocks and spreading them along each surface.
    #[arg(long)]
    pub full_resolution_while_moving: bool,
    /// Draw the first frame at rest after a move exactly, all of it. By default the frames at
    /// rest draw the exact layered shadows a band of rows at a time, then the exact bounce light
    /// and shadows' second bounce a few rows at a time (about 70 frames at 512^2, each at most
    /// about twice a plain frame), then the cursor sphere's exact shading a few of its rows at a
    /// time, instead of one multi-second frame.
    #[arg(long)]
    pub settle_in_one_frame: bool,
    /// Draw every frame, also a frame at rest whose inputs are the last exact frame's. By
    /// default such a frame is kept as drawn (nothing changed); `--frames N --stats` then times
    /// the kept frames, and this flag times the frame drawn in full (`cargo xtask illusion`'s
    /// frame times).
    #[arg(long)]
    pub redraw_at_rest: bool,
    /// Accepted for compatibility: the near field and the glossy lobes traced through the scene
    /// are on by default (`--no-near-field` turns them off).
    #[arg(long, conflicts_with = "no_near_field")]
    pub near_field: bool,
    /// Live surfaces take the probes' light alone, not the light of the scene surfaces within a
    /// probe spacing from those surfaces' own materials, and glossy live surfaces read their
    /// lobes from the reflection probes' distance maps, not traced through the scene's
    /// triangles (docs/viewer-lighting.md, "Near a large scene surface").
    #[arg(long)]
    pub no_near_field: bool,
    /// Fraction of a pixel's value removed in the sphere's full shadow.
    #[arg(long, value_name = "S", default_value_t = 0.6)]
    pub shadow_strength: f32,
    /// Depth buffer (the default reversed-Z float buffer co-locates to float precision).
    #[arg(long, value_enum, default_value_t = DepthBuffer::Reversed32f)]
    pub depth_buffer: DepthBuffer,
    /// GPU backend (default: Vulkan, then GL; `WGPU_BACKEND` also works).
    #[arg(long, value_enum)]
    pub backend: Option<Backend>,
    /// Print the adapter, the depth range, the lights used, what was skipped, and frame times.
    #[arg(long)]
    pub stats: bool,
    /// Headless: submit and wait after each pass of every frame and print what each took (CPU
    /// time of the process's threads and wall time, per frame); the frames are slower, their
    /// pixels the same.
    #[arg(long)]
    pub pass_times: bool,

    /// Haptic device driving the sphere: none, sim (replays --trajectory; in a window without
    /// one, follows the keyboard and mouse), spacemouse or spacemouse:PATH (see --list-devices).
    /// Default: sim with --trajectory, else none.
    #[arg(long, value_name = "DEVICE")]
    pub device: Option<String>,
    /// Trajectory of the simulated device: CSV `t,x,y,z` (seconds; device coordinates in metres).
    #[arg(long, value_name = "TRAJ.csv")]
    pub trajectory: Option<PathBuf>,
    /// Write one row per haptic tick: `t,device_x,device_y,device_z,proxy_x,proxy_y,proxy_z,fx,fy,fz`.
    #[arg(long, value_name = "LOG.csv")]
    pub force_log: Option<PathBuf>,
    /// Scene units per metre of device travel, `scene = centre + gain * device` (default: the
    /// device's workspace covers the scene).
    #[arg(long, value_name = "G", allow_hyphen_values = true)]
    pub gain: Option<f64>,
    /// Scene position of the device's origin (default: the centre of the scene's bounds).
    #[arg(long, value_name = "X,Y,Z", value_parser = parse_vec3, allow_hyphen_values = true)]
    pub centre: Option<DVec3>,
    /// Stiffness in N/m of device travel for surfaces whose RIB gives no
    /// `Attribute "haptic" "float stiffness"` (default: half the device's maximum).
    #[arg(long, value_name = "K", allow_hyphen_values = true)]
    pub stiffness: Option<f64>,
    /// How the SpaceMouse cap drives the device: its deflection is a velocity or a position.
    #[arg(long, value_enum, default_value_t = SpaceMouseMode::Rate)]
    pub spacemouse_mode: SpaceMouseMode,
    /// Rate of the haptic loop (Hz).
    #[arg(long, value_name = "HZ", default_value_t = 1000.0)]
    pub haptic_rate: f64,
    /// List the haptic devices this build can drive and those connected, then exit.
    #[arg(long)]
    pub list_devices: bool,
}

#[derive(Clone, Copy, Debug, PartialEq, Eq, ValueEnum)]
pub enum SpaceMouseMode {
    Rate,
    Position,
}

/// Checked haptic settings: present when a device drives the sphere.
#[derive(Clone, Debug)]
pub struct HapticSettings {
    pub device: haptics::session::DeviceChoice,
    pub trajectory: Option<PathBuf>,
    pub force_log: Option<PathBuf>,
    pub gain: Option<f64>,
    pub centre: Option<DVec3>,
    pub stiffness: Option<f64>,
    pub spacemouse_mode: haptics::device::spacemouse::ControlMode,
    pub rate_hz: f64,
}

#[derive(Clone, Copy, Debug, PartialEq, Eq, ValueEnum)]
pub enum Mode {
    /// The paper's: one point per pixel.
    Points,
    /// Lawlor's: a full-screen pass writing fragment depth (faster).
    Fullscreen,
}

#[derive(Clone, Copy, Debug, PartialEq, Eq, ValueEnum)]
pub enum DepthBuffer {
    /// Reversed-Z, 32-bit float.
    Reversed32f,
    /// Conventional [0, 1], 32-bit float.
    Standard32f,
    /// Conventional [0, 1], 24-bit fixed point.
    Standard24,
}

#[derive(Clone, Copy, Debug, PartialEq, Eq, ValueEnum)]
pub enum Backend {
    Vulkan,
    Gl,
}

/// `X,Y,Z` (or `R,G,B`): three finite numbers separated by commas.
pub fn parse_vec3(text: &str) -> Result<DVec3, String> {
    let parts: Vec<&str> = text.split(',').map(str::trim).collect();
    if parts.len() != 3 {
        return Err(format!("expected three comma-separated numbers, got `{text}`"));
    }
    let mut v = [0.0; 3];
    for (slot, part) in v.iter_mut().zip(&parts) {
        *slot = part.parse::<f64>().map_err(|_| format!("`{part}` is not a number"))?;
        if !slot.is_finite() {
            return Err(format!("`{part}` is not finite"));
        }
    }
    Ok(DVec3::from_array(v))
}

/// Checked settings derived from [`Args`].
#[derive(Clone, Debug)]
pub struct Settings {
    pub image: PathBuf,
    pub depth: PathBuf,
    pub scene: PathBuf,
    pub headless: bool,
    pub screenshot: Option<PathBuf>,
    pub mask: Option<PathBuf>,
    pub sphere: Option<DVec3>,
    pub live: Option<PathBuf>,
    pub radius: Option<f64>,
    pub mode: CompositeMode,
    pub frames: Option<u64>,
    pub sphere_colour: Option<DVec3>,
    pub unlit: bool,
    pub shadows: Option<f32>,
    /// Live objects' edges filtered with the image's pixel filter (`--no-antialias` clears it).
    pub antialias: bool,
    /// The light live spheres reflect onto the scene (`--no-bounce-light` clears it).
    pub bounce_light: bool,
    /// The light a live sphere hides taken from behind it (`--occlusion-from-behind`).
    pub occlusion_from_behind: bool,
    /// The shadows' second bounce removed (`--no-shadow-bounce` clears it).
    pub shadow_bounce: bool,
    /// Costly passes amortised over frames while the sphere moves (`--exact-while-moving`
    /// clears it).
    pub amortise_while_moving: bool,
    /// A moving frame's bounce light and second bounce at reduced resolution
    /// (`--full-resolution-while-moving` clears it).
    pub reduce_while_moving: bool,
    /// The frames at rest after a move made exact over several frames (`--settle-in-one-frame`
    /// clears it).
    pub settle_at_rest: bool,
    /// A frame at rest with the last exact frame's inputs kept as drawn (`--redraw-at-rest`
    /// clears it).
    pub keep_frame_at_rest: bool,
    /// The near field from the scene surfaces' own materials (`--no-near-field` clears it).
    pub near_field: bool,
    pub depth_settings: DepthSettings,
    pub backends: viewer::Backends,
    pub stats: bool,
    /// Each pass's time printed (`--pass-times`).
    pub pass_times: bool,
    /// `None` with `--device none`.
    pub haptics: Option<HapticSettings>,
}

impl Args {
    /// Second stage: values that clap cannot check alone.
    pub fn settings(self) -> Result<Settings, String> {
        if let Some(r) = self.radius
            && !(r.is_finite() && r > 0.0)
        {
            return Err(format!("--radius must be a positive number, got {r}"));
        }
        if self.frames == Some(0) {
            return Err("--frames must be at least 1".into());
        }
        if !(0.0..=1.0).contains(&self.shadow_strength) {
            return Err(format!("--shadow-strength must be within [0, 1], got {}", self.shadow_strength));
        }
        if let Some(c) = self.sphere_colour
            && c.min_element() < 0.0
        {
            return Err("--sphere-colour components must not be negative".into());
        }
        let haptics = self.haptic_settings()?;
        let depth_settings = match self.depth_buffer {
            DepthBuffer::Reversed32f => DepthSettings::default(),
            DepthBuffer::Standard32f => {
                DepthSettings { format: TextureFormat::Depth32Float, convention: DepthConvention::Wgpu }
            }
            DepthBuffer::Standard24 => {
                DepthSettings { format: TextureFormat::Depth24Plus, convention: DepthConvention::Wgpu }
            }
        };
        let backends = match self.backend {
            None => viewer::Backends::default(),
            Some(Backend::Vulkan) => viewer::Backends(viewer::wgpu::Backends::VULKAN),
            Some(Backend::Gl) => viewer::Backends(viewer::wgpu::Backends::GL),
        };
        Ok(Settings {
            image: self.image,
            depth: self.depth,
            scene: self.scene,
            headless: self.headless,
            screenshot: self.screenshot,
            mask: self.mask,
            sphere: self.sphere,
            live: self.live,
            radius: self.radius,
            mode: match self.mode {
                Mode::Points => CompositeMode::Points,
                Mode::Fullscreen => CompositeMode::Fullscreen,
            },
            frames: self.frames,
            sphere_colour: self.sphere_colour,
            unlit: self.unlit,
            shadows: (!self.no_shadows).then_some(self.shadow_strength),
            antialias: !self.no_antialias,
            bounce_light: !self.no_bounce_light,
            occlusion_from_behind: self.occlusion_from_behind,
            shadow_bounce: !self.no_shadow_bounce,
            amortise_while_moving: !self.exact_while_moving,
            reduce_while_moving: !self.full_resolution_while_moving,
            settle_at_rest: !self.settle_in_one_frame,
            keep_frame_at_rest: !self.redraw_at_rest,
            near_field: !self.no_near_field,
            depth_settings,
            backends,
            stats: self.stats,
            pass_times: self.pass_times,
            haptics,
        })
    }

    /// The haptic flags, checked together.
    fn haptic_settings(&self) -> Result<Option<HapticSettings>, String> {
        let selector = match (&self.device, &self.trajectory) {
            (Some(d), _) => d.as_str(),
            (None, Some(_)) => "sim",
            (None, None) => "none",
        };
        if selector == "none" {
            let stray = [
                (self.trajectory.is_some(), "--trajectory"),
                (self.force_log.is_some(), "--force-log"),
                (self.gain.is_some(), "--gain"),
                (self.centre.is_some(), "--centre"),
                (self.stiffness.is_some(), "--stiffness"),
            ];
            if let Some((_, flag)) = stray.iter().find(|(given, _)| *given) {
                return Err(format!("{flag} needs a haptic device (--device sim or spacemouse)"));
            }
            return Ok(None);
        }
        let device = haptics::session::DeviceChoice::parse(selector).map_err(|e| e.to_string())?;
        if self.trajectory.is_some() && !matches!(device, haptics::session::DeviceChoice::Simulated) {
            return Err("--trajectory replays the simulated device: use --device sim".into());
        }
        if let Some(g) = self.gain
            && !(g.is_finite() && g > 0.0)
        {
            return Err(format!("--gain must be a positive number, got {g}"));
        }
        if let Some(k) = self.stiffness
            && !(k.is_finite() && k >= 0.0)
        {
            return Err(format!("--stiffness must be a non-negative number, got {k}"));
        }
        if !(self.haptic_rate.is_finite() && self.haptic_rate > 0.0 && self.haptic_rate <= 100_000.0) {
            return Err(format!("--haptic-rate must be within (0, 100000] Hz, got {}", self.haptic_rate));
        }
        Ok(Some(HapticSettings {
            device,
            trajectory: self.trajectory.clone(),
            force_log: self.force_log.clone(),
            gain: self.gain,
            centre: self.centre,
            stiffness: self.stiffness,
            spacemouse_mode: match self.spacemouse_mode {
                SpaceMouseMode::Rate => haptics::device::spacemouse::ControlMode::Rate,
                SpaceMouseMode::Position => haptics::device::spacemouse::ControlMode::Position,
            },
            rate_hz: self.haptic_rate,
        }))
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn vec3_parses_and_rejects() {
        assert_eq!(parse_vec3("1,-2.5, 3e-1").unwrap(), DVec3::new(1.0, -2.5, 0.3));
        assert!(parse_vec3("1,2").is_err());
        assert!(parse_vec3("1,2,x").is_err());
        assert!(parse_vec3("1,2,inf").is_err());
        assert!(parse_vec3("1,2,3,4").is_err());
    }

    #[test]
    fn negative_coordinates_parse_as_values() {
        let args = Args::try_parse_from(["hybrid-view", "a.png", "a.depth", "a.rib", "--sphere", "-1,-2,-3"])
            .unwrap();
        assert_eq!(args.sphere, Some(DVec3::new(-1.0, -2.0, -3.0)));
    }

    #[test]
    fn second_stage_rejects_bad_values() {
        let parse = |extra: &[&str]| {
            let mut v = vec!["hybrid-view", "a.png", "a.depth", "a.rib"];
            v.extend_from_slice(extra);
            Args::try_parse_from(v).unwrap().settings()
        };
        assert!(parse(&["--radius", "0"]).is_err());
        assert!(parse(&["--radius", "-1"]).is_err());
        assert!(parse(&["--frames", "0"]).is_err());
        assert!(parse(&["--shadow-strength", "2"]).is_err());
        assert!(parse(&["--force-log", "f.csv"]).is_err(), "a force log needs a device");
        assert!(parse(&["--device", "none", "--trajectory", "t.csv"]).is_err());
        assert!(parse(&["--device", "spacemouse", "--trajectory", "t.csv"]).is_err());
        assert!(parse(&["--device", "phantom"]).is_err());
        assert!(parse(&["--device", "sim", "--gain", "0"]).is_err());
        assert!(parse(&["--device", "sim", "--stiffness", "-1"]).is_err());
        assert!(parse(&["--trajectory", "t.csv"]).unwrap().haptics.is_some(), "--trajectory implies sim");
        assert!(parse(&[]).unwrap().haptics.is_none());
        let s = parse(&["--mode", "points", "--no-shadows"]).unwrap();
        assert_eq!(s.mode, CompositeMode::Points);
        assert_eq!(s.shadows, None);
        assert!(s.amortise_while_moving, "a moving sphere's frame is amortised by default");
        assert!(!parse(&["--exact-while-moving"]).unwrap().amortise_while_moving);
        assert!(s.reduce_while_moving, "a moving sphere's bounce light is gathered at reduced resolution");
        assert!(!parse(&["--full-resolution-while-moving"]).unwrap().reduce_while_moving);
        assert!(s.settle_at_rest, "the frames at rest after a move settle over several frames");
        assert!(!parse(&["--settle-in-one-frame"]).unwrap().settle_at_rest);
        assert!(s.keep_frame_at_rest, "a frame at rest with unchanged inputs is kept by default");
        assert!(!parse(&["--redraw-at-rest"]).unwrap().keep_frame_at_rest);
        assert!(s.near_field, "the near field is on by default");
        assert!(parse(&["--near-field"]).unwrap().near_field, "--near-field is still accepted");
        assert!(!parse(&["--no-near-field"]).unwrap().near_field);
        let both = ["hybrid-view", "a.png", "a.depth", "a.rib", "--near-field", "--no-near-field"];
        assert!(Args::try_parse_from(both).is_err(), "--near-field and --no-near-field conflict");
    }
}
