//! The render path of `lrt-depth`, run as a program: outputs, exit codes, determinism.

use std::path::Path;
use std::process::{Command, Output};

const SCENE: &str = r#"
Option "lrt" "string depthfile" ["small.depth"]
Display "small.png" "png" "rgba"
Display "+small.exr" "openexr" "rgb"
Format 24 16 1
Projection "perspective" "fov" [40]
PixelFilter "gaussian" 2 2
PixelSamples 2 2
Translate 0 0 5
WorldBegin
  LightSource "pointlight" 1 "from" [2 3 -4] "intensity" [30]
  LightSource "ambientlight" 2 "intensity" [0.05]
  Surface "plastic"
  Color [0.8 0.3 0.2]
  Sphere 1 -1 1 360
  Surface "matte"
  Color [0.6 0.6 0.6]
  Polygon "P" [-3 -1 -3  3 -1 -3  3 -1 3  -3 -1 3]
WorldEnd
"#;

/// A scratch directory for one test, removed when the test ends.
fn temp_dir(name: &str) -> tempfile::TempDir {
    tempfile::Builder::new().prefix(&format!("lrt-depth-render-{name}-")).tempdir().unwrap()
}

fn run(dir: &Path, args: &[&str]) -> Output {
    Command::new(env!("CARGO_BIN_EXE_lrt-depth")).current_dir(dir).args(args).output().unwrap()
}

#[test]
fn renders_every_display_and_the_depth_table() {
    let scratch_dir = temp_dir("displays");
    let dir = scratch_dir.path();
    std::fs::write(dir.join("small.rib"), SCENE).unwrap();
    let out = run(dir, &["small.rib", "--threads", "2", "--stats"]);
    assert!(out.status.success(), "{}", String::from_utf8_lossy(&out.stderr));
    let png = image::open(dir.join("small.png")).unwrap();
    assert_eq!((png.width(), png.height()), (24, 16));
    assert!(png.color().has_alpha());
    let exr = image::open(dir.join("small.exr")).unwrap();
    assert_eq!((exr.width(), exr.height()), (24, 16));
    let table = depth_remap::DepthTable::read(dir.join("small.depth")).unwrap();
    assert_eq!((table.width(), table.height()), (24, 16));
    // The centre of the frame sees the sphere about 4 units away; a corner sees nothing.
    let centre = table.get(12, 8).unwrap();
    assert!((centre - 4.0).abs() < 0.05, "{centre}");
    let stdout = String::from_utf8_lossy(&out.stdout);
    assert!(stdout.contains("stats: integrator directlighting"), "{stdout}");
    assert!(stdout.contains("rays/s"), "{stdout}");
}

#[test]
fn the_sidecar_goes_with_the_depth_table_and_belongs_to_it() {
    let scratch_dir = temp_dir("sidecar");
    let dir = scratch_dir.path();
    std::fs::write(dir.join("small.rib"), SCENE).unwrap();
    let out = run(dir, &["small.rib", "--threads", "2"]);
    assert!(out.status.success(), "{}", String::from_utf8_lossy(&out.stderr));
    // Found by the depth table's name alone, and tied to the table exactly as the viewer reads it.
    let table = depth_remap::DepthTable::read(dir.join("small.depth")).unwrap();
    let paths = sidecar::SidecarPaths::for_depth(&dir.join("small.depth"));
    let expect = sidecar::LayerExpectation {
        width: 24,
        height: 16,
        depth_fingerprint: Some(sidecar::depth_fingerprint(table.values())),
    };
    let layers = sidecar::read_layers(&paths.layers, &expect, Default::default()).unwrap();
    assert_eq!(layers.light.len(), 2);
    let probes = sidecar::read_probes(&paths.probes, expect.depth_fingerprint).unwrap();
    assert!(probes.probe_count() > 0);
    let reflections = sidecar::read_reflections(&paths.reflections, expect.depth_fingerprint).unwrap();
    assert!(reflections.is_some_and(|r| r.probe_count() > 0));
    let stdout = String::from_utf8_lossy(&out.stdout);
    assert!(stdout.contains("small.reflections.exr (") && stdout.contains("reflection probes"), "{stdout}");
    // The float image equals the sum of the layers.
    let exr = image::open(dir.join("small.exr")).unwrap().into_rgb32f();
    for (sum, pixel) in layers.beauty().iter().zip(exr.pixels()) {
        for c in 0..3 {
            assert!((sum[c] - pixel[c]).abs() <= 1e-5 * (1.0 + pixel[c].abs()), "{sum:?} vs {pixel:?}");
        }
    }
}

#[test]
fn output_is_the_same_for_any_thread_count() {
    let scratch_dir = temp_dir("threads");
    let dir = scratch_dir.path();
    std::fs::write(dir.join("small.rib"), SCENE).unwrap();
    assert!(run(dir, &["small.rib", "-o", "one.exr", "--threads", "1", "-q"]).status.success());
    assert!(run(dir, &["small.rib", "-o", "two.exr", "--threads", "2", "-q"]).status.success());
    assert_eq!(std::fs::read(dir.join("one.exr")).unwrap(), std::fs::read(dir.join("two.exr")).unwrap());
}

#[test]
fn no_depth_table_without_a_request() {
    let scratch_dir = temp_dir("nodepth");
    let dir = scratch_dir.path();
    let scene = SCENE.replace("Option \"lrt\" \"string depthfile\" [\"small.depth\"]", "");
    std::fs::write(dir.join("small.rib"), scene).unwrap();
    let out = run(dir, &["small.rib", "--stats"]);
    assert!(out.status.success());
    assert!(!dir.join("small.depth").exists());
    let stdout = String::from_utf8_lossy(&out.stdout);
    assert!(stdout.contains("skipped: depth table"), "{stdout}");
    // --depth adds the request from the command line.
    assert!(run(dir, &["small.rib", "-q", "--depth", "cli.depth"]).status.success());
    assert!(dir.join("cli.depth").exists());
}

#[test]
fn exit_codes() {
    let scratch_dir = temp_dir("codes");
    let dir = scratch_dir.path();
    std::fs::write(dir.join("bad.rib"), "WorldBegin\nSphere 1 -1 1\nWorldEnd\n").unwrap();
    let out = run(dir, &["bad.rib"]);
    assert_eq!(out.status.code(), Some(1));
    let stderr = String::from_utf8_lossy(&out.stderr);
    assert!(stderr.contains("bad.rib:3:1: error:"), "{stderr}");
    assert_eq!(run(dir, &["bad.rib", "--spp", "0"]).status.code(), Some(2));
    assert_eq!(run(dir, &["missing.rib"]).status.code(), Some(1));
}
