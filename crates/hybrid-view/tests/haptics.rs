//! `hybrid-view` with a haptic device (CONTRACTS.md §5): deterministic headless replay with a
//! force log, the sphere drawn at the proxy, device listing and the haptic flags' errors. GPU
//! tests: they need an adapter (lavapipe in CI).

use std::path::{Path, PathBuf};
use std::process::{Command, Output};

fn repository() -> PathBuf {
    PathBuf::from(concat!(env!("CARGO_MANIFEST_DIR"), "/../.."))
}

fn cornell() -> PathBuf {
    PathBuf::from(concat!(env!("CARGO_MANIFEST_DIR"), "/../../../shared/reference/cornell"))
}

/// A scratch directory for one test, removed when the test ends.
fn scratch(name: &str) -> tempfile::TempDir {
    tempfile::Builder::new().prefix(&format!("hybrid-view-haptics-{name}-")).tempdir().unwrap()
}

fn hybrid_view(args: &[&str]) -> Output {
    let output =
        Command::new(env!("CARGO_BIN_EXE_hybrid-view")).args(args).output().expect("run hybrid-view");
    eprintln!("stderr: {}", String::from_utf8_lossy(&output.stderr));
    output
}

fn s(p: &Path) -> &str {
    p.to_str().unwrap()
}

/// The inputs of a Cornell box run: the reference image, its exact depth table, the scene.
fn inputs() -> [PathBuf; 3] {
    let c = cornell();
    [c.join("reference-path-11520spp.exr"), c.join("depth-analytic.depth"), c.join("cornell.rib")]
}

fn press() -> PathBuf {
    repository().join("examples/cornell/haptic-press.csv")
}

/// Rows of a force log as numbers.
fn rows(log: &Path) -> Vec<[f64; 10]> {
    let text = std::fs::read_to_string(log).unwrap();
    let mut lines = text.lines();
    assert_eq!(lines.next(), Some("t,device_x,device_y,device_z,proxy_x,proxy_y,proxy_z,fx,fy,fz"));
    lines
        .map(|l| {
            let v: Vec<f64> = l.split(',').map(|x| x.parse().unwrap()).collect();
            v.try_into().unwrap()
        })
        .collect()
}

#[test]
fn headless_replay_is_deterministic_and_renders_the_cornell_box_forces() {
    let scratch_dir = scratch("replay");
    let dir = scratch_dir.path();
    let [image, depth, rib] = inputs();
    let press = press();
    let mut logs = Vec::new();
    for run in 0..2 {
        let log = dir.join(format!("force-{run}.csv"));
        let out = hybrid_view(&[
            s(&image),
            s(&depth),
            s(&rib),
            "--headless",
            "--device",
            "sim",
            "--trajectory",
            s(&press),
            "--gain",
            "1",
            "--centre",
            "0,0,0",
            "--radius",
            "0.1",
            "--force-log",
            s(&log),
        ]);
        assert_eq!(out.status.code(), Some(0));
        logs.push(std::fs::read(&log).unwrap());
    }
    assert!(logs[0] == logs[1], "two replays gave different force logs");
    let rows = rows(&dir.join("force-0.csv"));
    // One row per tick at 1 kHz over the trajectory's 1.9 s.
    assert_eq!(rows.len(), 1901);
    for (k, r) in rows.iter().enumerate() {
        assert_eq!(r[0], k as f64 / 1000.0);
        // The proxy never goes into the floor or the red wall (radius 0.1, f32 geometry).
        assert!(r[5] >= -0.9 - 1e-6 && r[4] >= -0.9 - 1e-6, "t = {}: proxy {:?}", r[0], &r[4..7]);
        let f = (r[7] * r[7] + r[8] * r[8] + r[9] * r[9]).sqrt();
        assert!(f <= 8.0 + 1e-9, "t = {}: |F| = {f}", r[0]);
    }
    // Pressing 5 mm into the floor at the default 1000 N/m: 5 N up; in the crease with the
    // red wall, 5 N along +x as well.
    let close = |a: &[f64], b: [f64; 3]| a.iter().zip(b).all(|(x, y)| (x - y).abs() < 1e-6);
    assert!(close(&rows[700][7..10], [0.0, 5.0, 0.0]), "{:?}", rows[700]);
    assert!(close(&rows[1400][7..10], [5.0, 5.0, 0.0]), "{:?}", rows[1400]);
    assert!(close(&rows[1400][4..7], [-0.9, -0.9, 0.5]), "{:?}", rows[1400]);
}

#[test]
fn the_sphere_is_drawn_at_the_proxy() {
    // Frame 42 of a headless run happens at 42 / 60 = 0.7 s, when the proxy rests on the floor
    // at (-0.6, -0.9, 0.5) while the device is 5 mm below: the frame must be the one
    // `--sphere` gives at that point.
    let scratch_dir = scratch("proxy");
    let dir = scratch_dir.path();
    let [image, depth, rib] = inputs();
    let driven = dir.join("driven.png");
    let placed = dir.join("placed.png");
    let press = press();
    let common = [s(&image), s(&depth), s(&rib), "--headless", "--radius", "0.1"];
    let mut a = common.to_vec();
    a.extend(["--device", "sim", "--trajectory", s(&press), "--gain", "1", "--centre", "0,0,0"]);
    a.extend(["--frames", "43", "--screenshot", s(&driven)]);
    assert_eq!(hybrid_view(&a).status.code(), Some(0));
    let mut b = common.to_vec();
    b.extend(["--sphere", "-0.6,-0.9,0.5", "--screenshot", s(&placed)]);
    assert_eq!(hybrid_view(&b).status.code(), Some(0));
    let (x, y) = (std::fs::read(&driven).unwrap(), std::fs::read(&placed).unwrap());
    assert!(x == y, "the sphere is not drawn at the proxy");
    // And it is in view there (the comparison would be empty if the sphere were hidden).
    let bare = dir.join("bare.png");
    let mut c = common.to_vec();
    c.extend(["--screenshot", s(&bare)]);
    assert_eq!(hybrid_view(&c).status.code(), Some(0));
    assert!(std::fs::read(&bare).unwrap() != y, "the sphere is hidden at the proxy's position");
}

#[test]
fn list_devices_needs_no_inputs() {
    let out = hybrid_view(&["--list-devices"]);
    assert_eq!(out.status.code(), Some(0));
    let text = String::from_utf8_lossy(&out.stdout);
    assert!(text.lines().any(|l| l.starts_with("sim ")), "{text}");
}

#[test]
fn haptic_errors_and_exit_codes() {
    let scratch_dir = scratch("errors");
    let dir = scratch_dir.path();
    let [image, depth, rib] = inputs();
    let base = [s(&image), s(&depth), s(&rib), "--headless"];
    // Bad command lines: 2.
    for extra in [
        &["--force-log", "x.csv"][..],
        &["--device", "none", "--trajectory", "t.csv"],
        &["--device", "phantom"],
        &["--device", "sim", "--gain", "-1"],
    ] {
        let mut args = base.to_vec();
        args.extend_from_slice(extra);
        assert_eq!(hybrid_view(&args).status.code(), Some(2), "{extra:?}");
    }
    // A malformed trajectory: 1, with file:line:col.
    let bad = dir.join("bad.csv");
    std::fs::write(&bad, "t,x,y,z\n0,0,0,0\n0.1,0,oops,0\n").unwrap();
    let mut args = base.to_vec();
    args.extend(["--trajectory", s(&bad)]);
    let out = hybrid_view(&args);
    assert_eq!(out.status.code(), Some(1));
    let stderr = String::from_utf8_lossy(&out.stderr);
    assert!(stderr.contains("bad.csv:3:7: error: `oops` is not a number"), "{stderr}");
    // No SpaceMouse on this machine: 1, saying so (skipped where one is connected).
    let listed = hybrid_view(&["--list-devices"]);
    if !String::from_utf8_lossy(&listed.stdout).contains("spacemouse:") {
        let mut args = base.to_vec();
        args.extend(["--device", "spacemouse"]);
        let out = hybrid_view(&args);
        assert_eq!(out.status.code(), Some(1));
        assert!(String::from_utf8_lossy(&out.stderr).contains("no SpaceMouse connected"));
    }
}

#[test]
fn a_window_runs_the_real_time_haptic_thread() {
    assert!(std::env::var_os("DISPLAY").is_some(), "no X display: run `cargo xtask test`, which starts Xvfb");
    let scratch_dir = scratch("window");
    let dir = scratch_dir.path();
    let [image, depth, rib] = inputs();
    let press = press();
    let log = dir.join("force.csv");
    let out = hybrid_view(&[
        s(&image),
        s(&depth),
        s(&rib),
        "--device",
        "sim",
        "--trajectory",
        s(&press),
        "--gain",
        "1",
        "--centre",
        "0,0,0",
        "--radius",
        "0.1",
        "--frames",
        "30",
        "--force-log",
        s(&log),
        "--stats",
    ]);
    assert_eq!(out.status.code(), Some(0));
    let stderr = String::from_utf8_lossy(&out.stderr);
    assert!(stderr.contains("haptics: ") && stderr.contains(" ticks in "), "{stderr}");
    // The real-time loop logged its ticks: times increase, forces stay within the limit.
    let rows = rows(&log);
    assert!(rows.len() > 10, "{} rows", rows.len());
    for w in rows.windows(2) {
        assert!(w[1][0] > w[0][0]);
    }
    assert!(rows.iter().all(|r| (r[7] * r[7] + r[8] * r[8] + r[9] * r[9]).sqrt() <= 8.0 + 1e-9));
}
