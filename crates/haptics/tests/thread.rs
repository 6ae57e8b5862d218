//! The real-time haptic thread: it runs, publishes state without blocking, obeys run-time
//! controls, and stops cleanly (forces zeroed) on request, on an unplug and on a stall.

mod common;

use common::*;
use glam::DVec3;
use haptics::device::{SimulatedDevice, SimulatedFault};
use haptics::thread::ThreadStatus;
use haptics::*;
use std::time::{Duration, Instant};

fn renderer_for(device: &SimulatedDevice) -> HapticRenderer {
    let world = world(&floor(0.1, 0.0), DVec3::ZERO);
    let mapping = WorkspaceMapping::new(DVec3::ZERO, 1.0).unwrap();
    HapticRenderer::new(world, frictionless(STIFFNESS), device.specs(), mapping, settings(RADIUS))
}

/// A generous configuration: the test machine is shared, so timing is not what is tested here.
fn config() -> ThreadConfig {
    ThreadConfig {
        watchdog_timeout: Duration::from_millis(50),
        device_timeout: Duration::from_millis(500),
        ..ThreadConfig::default()
    }
}

fn wait_for(thread: &mut HapticThread, what: impl Fn(&HapticState) -> bool) -> HapticState {
    let deadline = Instant::now() + Duration::from_secs(10);
    loop {
        let s = thread.state();
        if what(&s) {
            return s;
        }
        assert!(Instant::now() < deadline, "timed out; last state {s:?}");
        std::thread::sleep(Duration::from_millis(2));
    }
}

#[test]
fn runs_publishes_and_stops_with_zero_force() {
    let (device, mut hand) = SimulatedDevice::manual(DVec3::new(0.0, 0.0, 0.02));
    let renderer = renderer_for(&device);
    let mut thread = HapticThread::spawn(Box::new(device), renderer, config()).unwrap();
    let s = wait_for(&mut thread, |s| s.tick > 20);
    assert_eq!(s.status, ThreadStatus::Running);
    assert_eq!(s.proxy_scene, DVec3::new(0.0, 0.0, 0.02));
    // Press into the floor through the manual input: the proxy stays on the surface and the
    // force pushes back.
    hand.write(DVec3::new(0.0, 0.0, 0.002));
    let s = wait_for(&mut thread, |s| s.contacts > 0 && s.force.z > 2.9);
    assert!((s.proxy_scene.z - RADIUS).abs() < 1e-12);
    assert!((s.force.z - STIFFNESS * 0.003).abs() < 1e-9);
    // A new mapping reaches the thread (the goal moves up 1 cm, clear of the floor).
    thread.set_mapping(WorkspaceMapping::new(DVec3::new(0.0, 0.0, 0.01), 1.0).unwrap());
    let s = wait_for(&mut thread, |s| s.contacts == 0);
    assert!((s.proxy_scene.z - 0.012).abs() < 1e-12);
    let report = thread.stop().unwrap();
    assert!(report.ticks > 20);
    assert!(report.rate_hz > 0.0);
    assert_eq!(report.safety.non_finite_forces, 0);
}

#[test]
fn an_unplugged_device_stops_the_loop_with_its_error() {
    let device = SimulatedDevice::fixed(DVec3::new(0.0, 0.0, 0.001))
        .with_fault(SimulatedFault::Disconnect { at: 0.05 });
    let renderer = renderer_for(&device);
    let mut thread = HapticThread::spawn(Box::new(device), renderer, config()).unwrap();
    let s = wait_for(&mut thread, |s| s.status == ThreadStatus::Failed);
    assert_eq!(s.force, DVec3::ZERO);
    assert!(
        thread.is_finished() || {
            std::thread::sleep(Duration::from_millis(100));
            thread.is_finished()
        }
    );
    match thread.stop() {
        Err(HapticError::Device(DeviceError::Disconnected { .. })) => {}
        other => panic!("expected a disconnection error, got {other:?}"),
    }
}

#[test]
fn a_device_that_stops_answering_stops_the_loop() {
    let device = SimulatedDevice::fixed(DVec3::new(0.0, 0.0, 0.02))
        .with_fault(SimulatedFault::Stall { at: 0.02, duration: Duration::from_millis(300) });
    let renderer = renderer_for(&device);
    let cfg = ThreadConfig { device_timeout: Duration::from_millis(100), ..config() };
    let thread = HapticThread::spawn(Box::new(device), renderer, cfg).unwrap();
    let started = Instant::now();
    while !thread.is_finished() {
        assert!(started.elapsed() < Duration::from_secs(10));
        std::thread::sleep(Duration::from_millis(5));
    }
    match thread.stop() {
        Err(HapticError::Device(DeviceError::NotAnswering { waited, .. })) => {
            assert!(waited >= Duration::from_millis(100))
        }
        other => panic!("expected a not-answering error, got {other:?}"),
    }
}

#[test]
fn a_stalled_tick_trips_the_watchdog_and_the_force_ramps_in_again() {
    // In contact (3 mm: 3 N at full force), the force ramping in over 0.5 s; at 0.3 s (1.8 N)
    // one read stalls 30 ms: longer than the 10 ms watchdog, shorter than the device timeout.
    let device = SimulatedDevice::fixed(DVec3::new(0.0, 0.0, 0.002))
        .with_fault(SimulatedFault::Stall { at: 0.3, duration: Duration::from_millis(30) });
    let world = world(&floor(0.1, 0.0), DVec3::ZERO);
    let mapping = WorkspaceMapping::new(DVec3::ZERO, 1.0).unwrap();
    let renderer = HapticRenderer::new(
        world,
        frictionless(STIFFNESS),
        device.specs(),
        mapping,
        RenderSettings::new(RADIUS),
    );
    let cfg = ThreadConfig {
        watchdog_timeout: Duration::from_millis(10),
        device_timeout: Duration::from_millis(500),
        ..config()
    };
    let mut thread = HapticThread::spawn(Box::new(device), renderer, cfg).unwrap();
    let s = wait_for(&mut thread, |s| s.watchdog_trips > 0);
    // Unbroken, the ramp would give at least 1.8 N from 0.3 s on; restarted from zero it stays
    // below 0.9 N for 150 ms, far more than the polling lag.
    assert!(s.force.z < 0.9, "force {} N after the trip at t = {} s", s.force.z, s.time);
    let report = thread.stop().unwrap();
    assert!(report.watchdog_trips >= 1);
    assert!(report.safety.ramp_restarts >= 2);
}

#[test]
fn the_viewer_side_never_blocks() {
    // Reading the state a million times while the loop runs takes well under a second: the
    // reader never waits for the writer.
    let device = SimulatedDevice::fixed(DVec3::new(0.0, 0.0, 0.02));
    let renderer = renderer_for(&device);
    let mut thread = HapticThread::spawn(Box::new(device), renderer, config()).unwrap();
    let start = Instant::now();
    let mut last = 0;
    for _ in 0..1_000_000 {
        let s = thread.state();
        assert!(s.tick >= last);
        last = s.tick;
    }
    assert!(start.elapsed() < Duration::from_secs(5));
    thread.stop().unwrap();
}

#[test]
fn the_force_log_gets_every_tick_without_blocking_the_loop() {
    let dir = tempfile::Builder::new().prefix("haptics-thread-log-").tempdir().unwrap();
    let path = dir.path().join("force.csv");
    let device = SimulatedDevice::fixed(DVec3::new(0.0, 0.0, 0.002));
    let renderer = renderer_for(&device);
    let log = ForceLogWriter::create(&path).unwrap();
    let mut thread = HapticThread::spawn_logged(Box::new(device), renderer, config(), Some(log)).unwrap();
    wait_for(&mut thread, |s| s.tick > 100);
    assert!(!path.exists(), "the log must appear only when finished");
    let report = thread.stop().unwrap();
    let text = std::fs::read_to_string(&path).unwrap();
    let rows = text.lines().count() as u64 - 1;
    assert_eq!(rows, report.log_rows);
    assert_eq!(report.log_rows + report.log_dropped, report.ticks);
    // In contact 3 mm deep: every logged force is k * 3 mm up (no ramp in these settings).
    let last = text.lines().last().unwrap();
    let fz: f64 = last.rsplit(',').next().unwrap().parse().unwrap();
    assert!((fz - STIFFNESS * 0.003).abs() < 1e-9, "{last}");
}
