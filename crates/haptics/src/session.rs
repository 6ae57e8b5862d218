//! Everything a front end (the `hybrid-view` CLI) needs to run haptics on a scene: pick and open
//! the device, resolve the mapping and the materials against it, then either start the real-time
//! [`HapticThread`] or replay deterministically in simulated time.
//!
//! Defaults, as a CHAI3D user expects them:
//! - mapping centre: the centre of the scene's bounds (CONTRACTS.md §5);
//! - gain: the scene's radius over the device's workspace radius, so the device's workspace
//!   covers the scene (CHAI3D's workspace scale factor);
//! - stiffness of surfaces that give none: half the device's maximum (or `default_stiffness`),
//!   frictionless;
//! - proxy radius: whatever the front end draws as the cursor sphere.

use crate::device::{DeviceError, HapticDevice, SimulatedDevice};
use crate::material::{MaterialDefaults, MaterialTable};
use crate::proxy::CollisionWorld;
use crate::render::{HapticRenderer, RenderSettings, TickOutput, WorkspaceMapping};
use crate::replay::{ForceLogWriter, ReplayConfig, ReplaySummary, replay};
use crate::scene::SceneGeometry;
use crate::thread::{HapticThread, ThreadConfig};
use crate::trajectory::Trajectory;
use crate::{DeviceSpecs, HapticError};
use glam::DVec3;
use std::path::Path;
use std::sync::Arc;

/// Which device drives the proxy.
#[derive(Clone, Debug, PartialEq)]
pub enum DeviceChoice {
    /// The simulated device: replaying a trajectory when one is given, else held at the
    /// device origin (or driven through [`Session::manual_input`]).
    Simulated,
    /// A SpaceMouse: the one at `path`, or the first one found.
    #[cfg(feature = "spacemouse")]
    SpaceMouse { path: Option<String>, settings: crate::device::spacemouse::SpaceMouseSettings },
}

impl DeviceChoice {
    /// Parses a command-line selector: `sim`, `spacemouse`, `spacemouse:PATH` (`none` is the
    /// front end's business: no session at all).
    pub fn parse(selector: &str) -> Result<DeviceChoice, HapticError> {
        match selector {
            "sim" => Ok(DeviceChoice::Simulated),
            #[cfg(feature = "spacemouse")]
            "spacemouse" => Ok(DeviceChoice::SpaceMouse { path: None, settings: Default::default() }),
            #[cfg(feature = "spacemouse")]
            s if s.starts_with("spacemouse:") => Ok(DeviceChoice::SpaceMouse {
                path: Some(s["spacemouse:".len()..].to_string()),
                settings: Default::default(),
            }),
            other => Err(HapticError::Config(format!(
                "unknown device `{other}` (expected none, sim or spacemouse; see --list-devices)"
            ))),
        }
    }
}

/// What to run.
#[derive(Clone, Debug)]
pub struct SessionConfig {
    pub device: DeviceChoice,
    /// For the simulated device: the trajectory to replay.
    pub trajectory: Option<Trajectory>,
    /// Scene units per metre of device travel; `None`: fit the workspace to the scene.
    pub gain: Option<f64>,
    /// Scene position of the device origin; `None`: the centre of the scene's bounds.
    pub centre: Option<DVec3>,
    /// Stiffness (N/m) of surfaces that give none; `None`: half the device's maximum.
    pub default_stiffness: Option<f64>,
    /// Radius of the proxy (the drawn cursor sphere), in scene units.
    pub proxy_radius: f64,
    /// Loop rate (Hz), real-time and simulated.
    pub rate_hz: f64,
    /// Scene position where a freely moving device starts (the simulated device on manual input,
    /// a SpaceMouse in rate mode), e.g. a point in free space in view; `None`: the mapping's
    /// centre, which may lie inside an object.
    pub start: Option<DVec3>,
}

/// A device and a renderer ready to run, with what was decided on the way.
#[derive(Debug)]
pub struct Session {
    device: Box<dyn HapticDevice>,
    renderer: HapticRenderer,
    manual: Option<crate::device::ManualInputWriter>,
    rate_hz: f64,
    trajectory_span: Option<(f64, f64)>,
    /// Problems the user should hear about: shapes that cannot be touched, materials
    /// corrected, a stiffness above the device's limit.
    pub warnings: Vec<String>,
    /// What was decided: the gain chosen, the triangle count and BVH build time.
    pub info: Vec<String>,
}

impl Session {
    /// Opens the device and prepares the renderer for `geometry` (the BVH is built here).
    pub fn new(geometry: SceneGeometry, config: SessionConfig) -> Result<Session, HapticError> {
        if !(config.proxy_radius.is_finite() && config.proxy_radius > 0.0) {
            return Err(HapticError::Config(format!(
                "the cursor radius {} must be a finite positive number",
                config.proxy_radius
            )));
        }
        let mut warnings: Vec<String> = geometry.warnings.clone();
        let mut info: Vec<String> = Vec::new();
        if geometry.untouchable_shapes > 0 {
            info.push(format!(
                "haptics: {} surfaces with stiffness 0 cannot be felt",
                geometry.untouchable_shapes
            ));
        }
        // The mapping comes first: a free device starts where the front end wants it.
        let workspace_radius = match &config.device {
            DeviceChoice::Simulated => SimulatedDevice::default_specs().workspace_radius,
            #[cfg(feature = "spacemouse")]
            DeviceChoice::SpaceMouse { settings, .. } => settings.workspace_radius,
        };
        let centre = config.centre.unwrap_or_else(|| geometry.centre());
        let gain = match config.gain {
            Some(g) => g,
            None => {
                let radius = geometry.radius();
                let gain =
                    if radius > 0.0 && workspace_radius > 0.0 { radius / workspace_radius } else { 1.0 };
                info.push(format!(
                    "haptics: gain {gain} scene units per metre (the {workspace_radius} m workspace covers the scene's radius {radius})"
                ));
                gain
            }
        };
        let mapping = WorkspaceMapping::new(centre, gain)?;
        let start =
            config.start.filter(|p| p.is_finite()).map_or(DVec3::ZERO, |p| mapping.device_from_scene(p));
        let mut manual = None;
        let mut trajectory_span = None;
        let device: Box<dyn HapticDevice> = match &config.device {
            DeviceChoice::Simulated => match &config.trajectory {
                Some(t) => {
                    trajectory_span = Some((t.start_time(), t.end_time()));
                    Box::new(SimulatedDevice::replay(t.clone()))
                }
                None => {
                    let (device, writer) = SimulatedDevice::manual(start);
                    manual = Some(writer);
                    Box::new(device)
                }
            },
            #[cfg(feature = "spacemouse")]
            DeviceChoice::SpaceMouse { path, settings } => {
                if config.trajectory.is_some() {
                    return Err(HapticError::Config(
                        "--trajectory replays the simulated device (use --device sim)".into(),
                    ));
                }
                let settings =
                    crate::device::spacemouse::SpaceMouseSettings { rate_start: start, ..*settings };
                Box::new(crate::device::spacemouse::SpaceMouse::open(path.as_deref(), settings)?)
            }
        };
        let specs: DeviceSpecs = device.specs().clone();
        let mut defaults = MaterialDefaults::for_device(&specs);
        if let Some(k) = config.default_stiffness {
            if !(k.is_finite() && k >= 0.0) {
                return Err(HapticError::Config(format!(
                    "stiffness {k} must be a finite non-negative number"
                )));
            }
            if k > specs.max_stiffness {
                warnings.push(format!(
                    "haptics: stiffness {k} N/m exceeds the {}'s maximum; using {} N/m",
                    specs.name, specs.max_stiffness
                ));
            }
            defaults.stiffness = k.min(specs.max_stiffness);
        }
        let (materials, corrections) =
            MaterialTable::resolve(&geometry.materials, defaults, specs.max_stiffness);
        warnings.extend(corrections.iter().map(|w| format!("haptics: {w}")));
        let world = Arc::new(CollisionWorld::new(geometry.mesh));
        info.push(format!(
            "haptics: {} ({}), mapping centre {centre}, gain {gain}; stiffness {} N/m where none is given",
            specs.name,
            if specs.has_force_output { "force output" } else { "input only" },
            defaults.stiffness
        ));
        info.push(format!(
            "haptics: {} triangles, BVH built in {:.1} ms",
            world.mesh().triangle_count(),
            world.build_time().as_secs_f64() * 1e3
        ));
        let renderer =
            HapticRenderer::new(world, materials, &specs, mapping, RenderSettings::new(config.proxy_radius));
        Ok(Session { device, renderer, manual, rate_hz: config.rate_hz, trajectory_span, warnings, info })
    }

    /// The device-to-scene mapping in effect.
    pub fn mapping(&self) -> WorkspaceMapping {
        self.renderer.mapping()
    }

    pub fn device_specs(&self) -> &DeviceSpecs {
        self.device.specs()
    }

    /// The writer that drives a simulated device without a trajectory (keyboard or mouse);
    /// `None` for other devices. Positions are in the device frame (metres).
    pub fn manual_input(&mut self) -> Option<crate::device::ManualInputWriter> {
        self.manual.take()
    }

    /// The replayed trajectory's time span, when the device replays one.
    pub fn trajectory_span(&self) -> Option<(f64, f64)> {
        self.trajectory_span
    }

    /// Starts the real-time loop, writing every tick to `force_log` when given.
    pub fn spawn(
        self,
        mut config: ThreadConfig,
        force_log: Option<&Path>,
    ) -> Result<HapticThread, HapticError> {
        config.rate_hz = self.rate_hz;
        let log = force_log.map(ForceLogWriter::create).transpose()?;
        HapticThread::spawn_logged(self.device, self.renderer, config, log)
    }

    /// Runs the loop in simulated time from `start` to `end` (seconds), writing the force log
    /// when asked, and returns where the proxy was at each of `sample_times` (ascending; the
    /// last tick at or before each, held before the first tick and after the last). Memory is
    /// bounded by the samples asked for, not by the replay's length.
    pub fn replay(
        mut self,
        start: f64,
        end: f64,
        force_log: Option<&Path>,
        sample_times: &[f64],
    ) -> Result<ReplayOutcome, HapticError> {
        let config = ReplayConfig { rate_hz: self.rate_hz, start, end };
        let ticks = config.tick_count()?;
        // The tick whose proxy each sample shows.
        let tick_of = |t: f64| {
            let k = ((t - start) * self.rate_hz + 1e-9).floor();
            if k.is_finite() { k.clamp(0.0, (ticks - 1) as f64) as u64 } else { 0 }
        };
        let wanted: Vec<u64> = sample_times.iter().map(|&t| tick_of(t)).collect();
        if wanted.windows(2).any(|w| w[1] < w[0]) {
            return Err(HapticError::Config("replay sample times must be ascending".into()));
        }
        let mut log = force_log.map(ForceLogWriter::create).transpose()?;
        let mut samples = Vec::with_capacity(wanted.len());
        let mut tick = 0u64;
        let mut last: Option<TickOutput> = None;
        let summary = replay(self.device.as_mut(), &mut self.renderer, &config, |out| {
            while samples.len() < wanted.len() && wanted[samples.len()] == tick {
                samples.push(out.proxy_scene);
            }
            tick += 1;
            last = Some(*out);
            match log.as_mut() {
                Some(log) => log.write(out),
                None => Ok(()),
            }
        })?;
        if let Some(log) = log {
            log.finish()?;
        }
        Ok(ReplayOutcome { samples, last, summary })
    }
}

/// The result of [`Session::replay`].
#[derive(Clone, Debug)]
pub struct ReplayOutcome {
    /// Proxy position (scene) at each requested sample time.
    pub samples: Vec<DVec3>,
    pub last: Option<TickOutput>,
    pub summary: ReplaySummary,
}

/// A device error as the front end reports it (the caller adds `hybrid-view: error: `).
pub fn describe_device_error(error: &DeviceError) -> String {
    match error {
        DeviceError::Disconnected { .. } => format!("{error}; the haptic loop stopped (forces zeroed)"),
        DeviceError::NotAnswering { .. } => format!("{error}; the haptic loop stopped (forces zeroed)"),
        _ => error.to_string(),
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::geometry::{CollisionMesh, MaterialId};
    use crate::material::MaterialSpec;

    fn floor_geometry() -> SceneGeometry {
        let mut mesh = CollisionMesh::new(DVec3::new(0.0, 0.0, 0.0));
        let p = [
            DVec3::new(-1.0, -1.0, 0.0),
            DVec3::new(1.0, -1.0, 0.0),
            DVec3::new(1.0, 1.0, 0.0),
            DVec3::new(-1.0, 1.0, 0.0),
        ];
        mesh.push_indexed(&p, &[[0, 1, 2], [0, 2, 3]], None, MaterialId(0)).unwrap();
        SceneGeometry {
            mesh,
            materials: vec![MaterialSpec { stiffness: Some(5000.0), ..MaterialSpec::default() }],
            bounds: Some((DVec3::new(-1.0, -1.0, 0.0), DVec3::new(1.0, 1.0, 0.0))),
            untouchable_shapes: 0,
            warnings: Vec::new(),
        }
    }

    #[test]
    fn defaults_fit_the_workspace_and_clamp_materials() {
        let config = SessionConfig {
            device: DeviceChoice::Simulated,
            trajectory: None,
            gain: None,
            centre: None,
            default_stiffness: None,
            proxy_radius: 0.05,
            rate_hz: 1000.0,
            start: None,
        };
        let mut session = Session::new(floor_geometry(), config).unwrap();
        let radius = 2f64.sqrt();
        assert!((session.mapping().gain - radius / 0.08).abs() < 1e-12);
        assert_eq!(session.mapping().centre, DVec3::ZERO);
        assert!(
            session.warnings.iter().any(|n| n.contains("exceeds the device's maximum")),
            "{:?}",
            session.warnings
        );
        assert!(session.manual_input().is_some());
    }

    #[test]
    fn replay_tracks_the_proxy_and_writes_the_log() {
        let trajectory = Trajectory::parse("t,x,y,z\n0,0,0,0.01\n0.1,0,0,-0.01\n", "t.csv").unwrap();
        let config = SessionConfig {
            device: DeviceChoice::Simulated,
            trajectory: Some(trajectory),
            gain: Some(1.0),
            centre: Some(DVec3::ZERO),
            default_stiffness: Some(1000.0),
            proxy_radius: 0.005,
            rate_hz: 1000.0,
            start: None,
        };
        let session = Session::new(floor_geometry(), config).unwrap();
        let (start, end) = session.trajectory_span().unwrap();
        let dir = tempfile::Builder::new().prefix("haptics-session-").tempdir().unwrap();
        let log = dir.path().join("force.csv");
        let outcome = session.replay(start, end, Some(&log), &[-1.0, 0.0, 0.1, 5.0]).unwrap();
        assert_eq!(outcome.summary.ticks, 101);
        assert_eq!(outcome.samples[0], DVec3::new(0.0, 0.0, 0.01));
        assert_eq!(outcome.samples[1], DVec3::new(0.0, 0.0, 0.01));
        assert!((outcome.samples[2].z - 0.005).abs() < 1e-12);
        assert_eq!(outcome.samples[3], outcome.samples[2]);
        let text = std::fs::read_to_string(&log).unwrap();
        assert_eq!(text.lines().count(), 102);
    }

    #[test]
    fn device_selectors() {
        assert_eq!(DeviceChoice::parse("sim").unwrap(), DeviceChoice::Simulated);
        assert!(DeviceChoice::parse("phantom").is_err());
        #[cfg(feature = "spacemouse")]
        assert!(
            matches!(DeviceChoice::parse("spacemouse:/dev/hidraw3").unwrap(), DeviceChoice::SpaceMouse { path: Some(p), .. } if p == "/dev/hidraw3")
        );
    }
}
