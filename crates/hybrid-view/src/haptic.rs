//! The haptic device drives the cursor sphere (CONTRACTS.md §5): `--device`, `--trajectory`,
//! `--force-log`, `--gain`, `--centre`, `--stiffness`, `--list-devices`.
//!
//! - Headless with the simulated device: the haptic loop runs first, in simulated time at its
//!   nominal rate over the whole trajectory (deterministic, byte-identical force logs), and
//!   frame `k` shows the proxy at the trajectory's start time plus `k / 60` s.
//! - Otherwise (a window, or a SpaceMouse): the real-time haptic thread runs beside the viewer,
//!   and every frame shows the proxy's latest position, read without blocking. In a window the
//!   simulated device without a trajectory follows the keyboard and mouse: they move the device
//!   (its goal), and the sphere shows the proxy, which the scene's surfaces stop.
//! - A device that fails (unplugged) stops the haptic loop with zero force, closes the window,
//!   and `hybrid-view` exits with the error (code 1).
//!
//! The sphere is the proxy, so it never sinks into the pre-rendered scene; `--sphere` overrides
//! where it is drawn (the device still runs and logs).

use crate::args::{HapticSettings, Settings};
use crate::run::{self, Failure, HEADLESS_FRAME_RATE, Prepared};
use glam::{DMat3, DVec3};
use haptics::device::ManualInputWriter;
use haptics::scene::{scene_geometry_from_meshes, tessellation_tolerance};
use haptics::session::{DeviceChoice, ReplayOutcome, Session, SessionConfig};
use haptics::thread::ThreadStatus;
use haptics::{HapticError, HapticThread, ThreadConfig, Trajectory, WorkspaceMapping};
use std::cell::RefCell;
use std::process::ExitCode;
use std::rc::Rc;
use viewer::{FrameInfo, LiveObjects, LiveUpdate, Sphere};

/// `--list-devices`: what this build can drive, and what is connected.
pub fn list_devices() -> ExitCode {
    let (devices, errors) = haptics::device::list_devices();
    for d in &devices {
        println!("{:<24} {}", d.selector, d.description);
    }
    if !devices.iter().any(|d| d.selector.starts_with("spacemouse")) {
        println!("(no SpaceMouse connected)");
    }
    for e in &errors {
        eprintln!("hybrid-view: warning: cannot list devices: {e}");
    }
    ExitCode::SUCCESS
}

fn failure(e: HapticError) -> Failure {
    match e {
        HapticError::Device(d) => Failure(haptics::session::describe_device_error(&d)),
        other => Failure(other.to_string()),
    }
}

/// Runs the viewer with the haptic device driving the sphere.
pub fn run(settings: &Settings, haptic: &HapticSettings, mut prepared: Prepared) -> Result<(), Failure> {
    let trajectory = match &haptic.trajectory {
        Some(path) => Some(Trajectory::read(path).map_err(|e| Failure(e.to_string()))?),
        None => None,
    };
    let radius = cursor_radius(settings, &prepared);
    // One tessellation for the haptics and the viewer's shadow rays, at the haptics' tolerance:
    // the viewer's (1e-3 of each shape's size) further bounded by the proxy's radius.
    let meshes = prepared.tessellate_scene(&tessellation_tolerance(Some(radius)), settings.stats);
    let geometry = scene_geometry_from_meshes(&prepared.rib, &meshes);
    drop(meshes);
    let mut device = haptic.device.clone();
    if let DeviceChoice::SpaceMouse { settings: s, .. } = &mut device {
        // Push the cap away and the cursor goes into the screen, whatever the scene's axes.
        let m = prepared.scene.camera().world_from_camera();
        let linear = DMat3::from_cols(m.x_axis.truncate(), m.y_axis.truncate(), m.z_axis.truncate());
        s.device_from_cap = haptics::device::spacemouse::device_from_cap_for_camera(linear);
        s.mode = haptic.spacemouse_mode;
    }
    // Where the sphere starts in a window: in free space in front of the scene (the viewer's
    // default); the mapping centre (the scene's centre) may lie inside an object.
    let start_scene = prepared.live.sphere.as_ref().map(|s| s.centre);
    let config = SessionConfig {
        device,
        trajectory,
        gain: haptic.gain,
        centre: haptic.centre,
        default_stiffness: haptic.stiffness,
        proxy_radius: radius,
        rate_hz: haptic.rate_hz,
        start: start_scene,
    };
    let mut session = Session::new(geometry, config).map_err(failure)?;
    let start_device = start_scene.map_or(DVec3::ZERO, |c| session.mapping().device_from_scene(c));
    for w in &session.warnings {
        eprintln!("{w}");
    }
    if settings.stats {
        for i in &session.info {
            eprintln!("{i}");
        }
    }
    let material = run::cursor_material(settings);
    let fixed = settings.sphere;
    let replay = settings.headless && matches!(haptic.device, DeviceChoice::Simulated);
    if replay {
        let (start, end) = match session.trajectory_span() {
            Some(span) => span,
            // No trajectory: the device rests at its origin for as long as the frames last.
            None => (0.0, (settings.frames.unwrap_or(1).saturating_sub(1)) as f64 / HEADLESS_FRAME_RATE),
        };
        // The proxy at every frame's time (frames beyond the first million hold the last).
        let frames = settings.frames.unwrap_or(1).min(1 << 20);
        let times: Vec<f64> = (0..frames).map(|k| start + k as f64 / HEADLESS_FRAME_RATE).collect();
        let outcome = session.replay(start, end, haptic.force_log.as_deref(), &times).map_err(failure)?;
        if settings.stats {
            print_replay(&outcome, haptic.rate_hz);
        }
        let mut updater = ReplayUpdater { outcome, radius, material, fixed };
        return run::headless(settings, prepared, Some(&mut updater));
    }

    let manual = session.manual_input();
    let mapping = session.mapping();
    let thread = session.spawn(ThreadConfig::default(), haptic.force_log.as_deref()).map_err(failure)?;
    let thread = Rc::new(RefCell::new(thread));
    // In a window the sphere must exist from the first frame for the keyboard to move it.
    if prepared.live.sphere.is_none() {
        prepared.live.sphere = Some(Sphere { centre: mapping.centre, radius, material });
    }
    let updater = LiveUpdater {
        thread: Rc::clone(&thread),
        manual,
        mapping,
        device: start_device,
        drawn: None,
        radius,
        material,
        fixed,
        failed: false,
    };
    let shown = if settings.headless {
        let mut updater = updater;
        run::headless(settings, prepared, Some(&mut updater))
    } else {
        run::windowed(settings, prepared, Some(Box::new(updater)))
    };
    // The viewer is done (or failed): stop the loop, zero the force, and report.
    let thread = match Rc::try_unwrap(thread) {
        Ok(cell) => cell.into_inner(),
        Err(_) => return Err(Failure("internal error: the haptic thread is still shared".into())),
    };
    let stopped = thread.stop();
    shown?;
    let report = stopped.map_err(failure)?;
    if settings.stats {
        eprintln!("haptics: {report}");
        let s = report.safety;
        eprintln!(
            "haptics: safety: {} forces clamped, {} non-finite forces zeroed, {} ramp restarts, {} invalid readings",
            s.clamped_forces, s.non_finite_forces, s.ramp_restarts, s.invalid_samples
        );
    }
    Ok(())
}

/// The proxy's radius: `--radius`, else the viewer's own default for the sphere (3 % of its
/// distance from the eye, here measured at the scene's centre).
fn cursor_radius(settings: &Settings, prepared: &Prepared) -> f64 {
    if let Some(r) = settings.radius {
        return r;
    }
    if let Some(s) = &prepared.live.sphere {
        return s.radius;
    }
    let centre = prepared.bounds.map_or(DVec3::ZERO, |(lo, hi)| (lo + hi) * 0.5);
    let eye_distance = prepared.scene.camera().camera_from_world().transform_point3(centre).length();
    if eye_distance > 0.0 { 0.03 * eye_distance } else { 0.1 }
}

fn print_replay(outcome: &ReplayOutcome, rate_hz: f64) {
    let s = &outcome.summary;
    eprintln!(
        "haptics: replayed {} ticks at {rate_hz} Hz in simulated time; {} in contact, largest force {:.6} N",
        s.ticks, s.contact_ticks, s.max_force
    );
    if let Some(last) = &outcome.last {
        let p = last.proxy_scene;
        let f = last.force.get();
        eprintln!("haptics: final proxy {},{},{} force {},{},{} N", p.x, p.y, p.z, f.x, f.y, f.z);
    }
    eprintln!(
        "haptics: safety: {} forces clamped, {} non-finite forces zeroed, {} ramp restarts",
        s.safety.clamped_forces, s.safety.non_finite_forces, s.safety.ramp_restarts
    );
}

/// Headless replay: frame `k` shows the proxy at `start + k / 60` s (sampled by the replay).
struct ReplayUpdater {
    outcome: ReplayOutcome,
    radius: f64,
    material: viewer::Material,
    fixed: Option<DVec3>,
}

impl LiveUpdate for ReplayUpdater {
    fn update(&mut self, live: &mut LiveObjects, frame: &FrameInfo) {
        let samples = &self.outcome.samples;
        let at = (frame.index as usize).min(samples.len().saturating_sub(1));
        let centre = self.fixed.or_else(|| samples.get(at).copied());
        live.sphere = centre.map(|centre| Sphere { centre, radius: self.radius, material: self.material });
    }
}

/// Real time: every frame shows the latest proxy; in a window the keyboard and mouse move a
/// simulated device.
struct LiveUpdater {
    thread: Rc<RefCell<HapticThread>>,
    manual: Option<ManualInputWriter>,
    mapping: WorkspaceMapping,
    /// The simulated device's position (device frame) set from the keyboard and mouse.
    device: DVec3,
    /// Where this updater last drew the sphere: what the keyboard moved it from.
    drawn: Option<DVec3>,
    radius: f64,
    material: viewer::Material,
    fixed: Option<DVec3>,
    failed: bool,
}

impl LiveUpdate for LiveUpdater {
    fn update(&mut self, live: &mut LiveObjects, _frame: &FrameInfo) {
        if let (Some(writer), Some(drawn), Some(sphere)) =
            (self.manual.as_mut(), self.drawn, live.sphere.as_ref())
        {
            // The keyboard or mouse moved the sphere since the last frame: move the device by
            // as much (in device units), and let the proxy follow it.
            let moved = sphere.centre - drawn;
            if moved != DVec3::ZERO {
                self.device += moved / self.mapping.gain;
                writer.write(self.device);
            }
        }
        let state = self.thread.borrow_mut().state();
        if state.status == ThreadStatus::Failed {
            self.failed = true;
        }
        let centre = match (self.fixed, state.status) {
            (Some(c), _) => c,
            // Before the first tick the proxy is where the device maps to.
            (None, ThreadStatus::Starting) => self.mapping.scene_from_device(self.device),
            (None, _) => state.proxy_scene,
        };
        live.sphere = Some(Sphere { centre, radius: self.radius, material: self.material });
        self.drawn = Some(centre);
    }

    fn keyboard_moves_sphere(&self) -> bool {
        self.manual.is_some()
    }

    fn wants_exit(&self) -> bool {
        self.failed
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use haptics::geometry::{CollisionMesh, MaterialId};
    use haptics::material::MaterialSpec;
    use haptics::scene::SceneGeometry;
    use std::time::{Duration, Instant};

    /// A floor at y = 0 and the real-time thread with the simulated device on manual input.
    fn floor_session() -> (Rc<RefCell<HapticThread>>, ManualInputWriter, WorkspaceMapping) {
        let mut mesh = CollisionMesh::new(DVec3::ZERO);
        let p = [
            DVec3::new(-1.0, 0.0, -1.0),
            DVec3::new(1.0, 0.0, -1.0),
            DVec3::new(1.0, 0.0, 1.0),
            DVec3::new(-1.0, 0.0, 1.0),
        ];
        mesh.push_indexed(&p, &[[0, 2, 1], [0, 3, 2]], None, MaterialId(0)).unwrap();
        let geometry = SceneGeometry {
            mesh,
            materials: vec![MaterialSpec::default()],
            bounds: Some((DVec3::new(-1.0, 0.0, -1.0), DVec3::new(1.0, 0.0, 1.0))),
            untouchable_shapes: 0,
            warnings: Vec::new(),
        };
        let config = SessionConfig {
            device: DeviceChoice::Simulated,
            trajectory: None,
            gain: Some(10.0),
            centre: Some(DVec3::new(0.0, 0.5, 0.0)),
            default_stiffness: None,
            proxy_radius: 0.05,
            rate_hz: 1000.0,
            start: None,
        };
        let mut session = Session::new(geometry, config).unwrap();
        let manual = session.manual_input().unwrap();
        let mapping = session.mapping();
        let thread = session.spawn(ThreadConfig::default(), None).unwrap();
        (Rc::new(RefCell::new(thread)), manual, mapping)
    }

    #[test]
    fn the_keyboard_moves_the_device_and_the_sphere_shows_the_proxy() {
        let (thread, manual, mapping) = floor_session();
        let mut updater = LiveUpdater {
            thread: Rc::clone(&thread),
            manual: Some(manual),
            mapping,
            device: DVec3::ZERO,
            drawn: None,
            radius: 0.05,
            material: viewer::Material::default(),
            fixed: None,
            failed: false,
        };
        assert!(updater.keyboard_moves_sphere());
        let mut live = LiveObjects {
            sphere: Some(Sphere {
                centre: mapping.centre,
                radius: 0.05,
                material: viewer::Material::default(),
            }),
            meshes: Vec::new(),
        };
        let frame = FrameInfo { index: 0, time_s: 0.0 };
        // Frames until the proxy settles where `check` wants it.
        let mut settle = |live: &mut LiveObjects, check: &dyn Fn(DVec3) -> bool| {
            let deadline = Instant::now() + Duration::from_secs(10);
            loop {
                updater.update(live, &frame);
                let c = live.sphere.as_ref().unwrap().centre;
                if check(c) {
                    return c;
                }
                assert!(Instant::now() < deadline, "the sphere stayed at {c}");
                std::thread::sleep(Duration::from_millis(5));
            }
        };
        // Wait for the loop's first ticks (before them the sphere shows the device's mapping).
        let deadline = Instant::now() + Duration::from_secs(10);
        while thread.borrow_mut().state().status != ThreadStatus::Running {
            assert!(Instant::now() < deadline, "the haptic loop did not start");
            std::thread::sleep(Duration::from_millis(1));
        }
        settle(&mut live, &|c| (c - mapping.centre).length() < 1e-12);
        // The keyboard moves the sphere 0.3 down (0.03 m of device travel): it follows.
        live.sphere.as_mut().unwrap().centre.y -= 0.3;
        let c = settle(&mut live, &|c| (c.y - 0.2).abs() < 1e-9);
        assert!((c - DVec3::new(0.0, 0.2, 0.0)).length() < 1e-9);
        // Another 0.3 down would put it 0.1 under the floor: the proxy stops on it.
        live.sphere.as_mut().unwrap().centre.y -= 0.3;
        settle(&mut live, &|c| (c.y - 0.05).abs() < 1e-9);
        let state = thread.borrow_mut().state();
        // The device is 0.1 scene units (1 cm) below the proxy: 1000 N/m * 1 cm = 10 N, limited
        // to the simulated device's 8 N.
        assert!(state.contacts > 0 && state.force.y > 0.0, "{state:?}");
        drop(updater);
        let thread = Rc::try_unwrap(thread).unwrap().into_inner();
        thread.stop().unwrap();
    }
}
