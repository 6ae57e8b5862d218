//! Splitting a frame with `--crop` and joining the tiles with `lrt-merge`: the merged image and
//! depth table are the full-frame render's, bit for bit; bad tile sets are refused.

use std::path::Path;
use std::process::{Command, Output};

/// A frame of odd size with a wide filter (tiles must not change pixels near their edges),
/// a sphere seen against the background (misses in the depth table) and a floor.
const SCENE: &str = r#"
Display "full.exr" "openexr" "rgba"
Display "+full.png" "png" "rgb"
Option "lrt" "string depthfile" ["full.depth"]
Format 37 23 1
Projection "perspective" "fov" [45]
PixelFilter "gaussian" 3 3
PixelSamples 2 2
Translate 0 0 5
WorldBegin
  LightSource "pointlight" 1 "from" [2 3 -4] "intensity" [30]
  LightSource "ambientlight" 2 "intensity" [0.05]
  Surface "plastic"
  Color [0.8 0.3 0.2]
  Sphere 1 -1 1 360
  Surface "matte"
  Polygon "P" [-3 -1 -3  3 -1 -3  3 -1 3  -3 -1 3]
WorldEnd
"#;

/// Three tiles of unequal size that cover the frame exactly once.
const TILES: [&str; 3] = ["0,0.4,0,0.55", "0.4,1,0,0.55", "0,1,0.55,1"];

/// A scratch directory holding the scene, removed when the test ends.
fn temp_dir(name: &str) -> tempfile::TempDir {
    let dir = tempfile::Builder::new().prefix(&format!("lrt-merge-{name}-")).tempdir().unwrap();
    std::fs::write(dir.path().join("scene.rib"), SCENE).unwrap();
    dir
}

fn run(program: &str, dir: &Path, args: &[&str]) -> Output {
    Command::new(program).current_dir(dir).args(args).output().unwrap()
}

fn lrt_depth(dir: &Path, args: &[&str]) -> Output {
    let out = run(env!("CARGO_BIN_EXE_lrt-depth"), dir, args);
    assert!(out.status.success(), "lrt-depth {args:?}: {}", String::from_utf8_lossy(&out.stderr));
    out
}

fn lrt_merge(dir: &Path, args: &[&str]) -> Output {
    run(env!("CARGO_BIN_EXE_lrt-merge"), dir, args)
}

/// Renders tile `k` of [`TILES`] as `tile-k.exr`, `tile-k.png` and `tile-k.depth`.
fn render_tile(dir: &Path, k: usize, extra: &[&str]) {
    let (exr, depth) = (format!("tile-{k}.exr"), format!("tile-{k}.depth"));
    let mut args = vec!["scene.rib", "--quiet", "--crop", TILES[k], "-o", &exr, "--depth", &depth];
    args.extend(extra);
    lrt_depth(dir, &args);
    let png = format!("tile-{k}.png");
    lrt_depth(dir, &["scene.rib", "--quiet", "--crop", TILES[k], "-o", &png]);
}

fn merge_args(tiles: &[usize]) -> Vec<String> {
    merge_args_named(tiles, |k| (format!("tile-{k}.exr"), format!("tile-{k}.depth")))
}

/// `lrt-merge` arguments for `tiles`, each named `(image, depth table)` by `name`.
fn merge_args_named(tiles: &[usize], name: impl Fn(usize) -> (String, String)) -> Vec<String> {
    let mut args: Vec<String> =
        vec!["-o".into(), "merged.exr".into(), "--depth".into(), "merged.depth".into()];
    for &k in tiles {
        args.extend(["--tile-depth".into(), name(k).1]);
    }
    args.extend(tiles.iter().map(|&k| name(k).0));
    args
}

/// Every channel of the first layer of an EXR file, as bits, with the display and data windows.
fn exr_samples(path: &Path) -> (String, Vec<(String, Vec<u32>)>) {
    use exr::prelude::*;
    let image = read()
        .no_deep_data()
        .largest_resolution_level()
        .all_channels()
        .first_valid_layer()
        .all_attributes()
        .from_file(path)
        .unwrap();
    let windows = format!(
        "display {:?}+{:?}, data {:?}+{:?}",
        image.attributes.display_window.position,
        image.attributes.display_window.size,
        image.layer_data.attributes.layer_position,
        image.layer_data.size
    );
    let channels = image
        .layer_data
        .channel_data
        .list
        .iter()
        .map(|c| {
            let bits = match &c.sample_data {
                FlatSamples::F32(v) => v.iter().map(|s| s.to_bits()).collect(),
                other => panic!("expected f32 samples, got {other:?}"),
            };
            (c.name.to_string(), bits)
        })
        .collect();
    (windows, channels)
}

#[test]
fn merged_tiles_equal_the_full_frame_bit_for_bit() {
    let scratch_dir = temp_dir("exact");
    let dir = scratch_dir.path();
    for k in 0..TILES.len() {
        render_tile(dir, k, &[]);
    }
    // The full frame last: the tiles' PNG renders write the RIB's depth file too.
    lrt_depth(dir, &["scene.rib", "--quiet"]);
    // A tile records its place: the display window is the frame, the data window the tile.
    let (windows, _) = exr_samples(&dir.join("tile-1.exr"));
    assert_eq!(windows, "display Vec2(0, 0)+Vec2(37, 23), data Vec2(15, 0)+Vec2(22, 13)");

    let args = merge_args(&[0, 1, 2]);
    let out = lrt_merge(dir, &args.iter().map(String::as_str).collect::<Vec<_>>());
    assert!(out.status.success(), "{}", String::from_utf8_lossy(&out.stderr));
    assert_eq!(exr_samples(&dir.join("merged.exr")), exr_samples(&dir.join("full.exr")));
    let same_depth =
        std::fs::read(dir.join("merged.depth")).unwrap() == std::fs::read(dir.join("full.depth")).unwrap();
    assert!(same_depth, "the merged depth table differs from the full frame's");
    let depth = depth_remap::DepthTable::read(dir.join("merged.depth")).unwrap();
    assert!(depth.values().iter().any(|v| v.is_infinite()) && depth.values().iter().any(|v| v.is_finite()));

    // 8-bit tiles hold the full frame's bytes too (dither follows the full-frame pixel).
    let full = image::open(dir.join("full.png")).unwrap().to_rgb8();
    for (k, (x0, y0)) in [(0, (0, 0)), (1, (15, 0)), (2, (0, 13))] {
        let tile = image::open(dir.join(format!("tile-{k}.png"))).unwrap().to_rgb8();
        for (x, y, p) in tile.enumerate_pixels() {
            assert_eq!(p, full.get_pixel(x0 + x, y0 + y), "tile {k} pixel ({x}, {y})");
        }
    }
}

#[test]
fn overlapping_tiles_that_agree_merge_and_ones_that_disagree_do_not() {
    let scratch_dir = temp_dir("overlap");
    let dir = scratch_dir.path();
    for k in 0..TILES.len() {
        render_tile(dir, k, &[]);
    }
    // The whole frame as a fourth tile overlaps every other one and agrees with them.
    lrt_depth(dir, &["scene.rib", "--quiet", "-o", "tile-3.exr", "--depth", "tile-3.depth"]);
    let args = merge_args(&[0, 3, 1, 2]);
    let out = lrt_merge(dir, &args.iter().map(String::as_str).collect::<Vec<_>>());
    assert!(out.status.success(), "{}", String::from_utf8_lossy(&out.stderr));

    // A tile rendered with other settings disagrees where it overlaps.
    lrt_depth(dir, &["scene.rib", "--quiet", "--spp", "3", "-o", "tile-3.exr", "--depth", "tile-3.depth"]);
    let out = lrt_merge(dir, &args.iter().map(String::as_str).collect::<Vec<_>>());
    assert_eq!(out.status.code(), Some(1));
    let stderr = String::from_utf8_lossy(&out.stderr);
    assert!(stderr.contains("overlap at pixel (") && stderr.contains("tile-3.exr"), "{stderr}");
}

#[test]
fn bad_tile_sets_are_refused_with_the_reason() {
    let scratch_dir = temp_dir("errors");
    let dir = scratch_dir.path();
    for k in 0..TILES.len() {
        render_tile(dir, k, &[]);
    }
    let code_and_error = |args: &[String]| {
        let out = lrt_merge(dir, &args.iter().map(String::as_str).collect::<Vec<_>>());
        (out.status.code(), String::from_utf8_lossy(&out.stderr).into_owned())
    };

    // A missing tile: the gap is named and nothing is written.
    let (code, err) = code_and_error(&merge_args(&[0, 2]));
    assert_eq!(code, Some(1));
    assert!(err.contains("pixels of the 37x23 frame are in no tile (the first at (15, 0))"), "{err}");
    assert!(!dir.join("merged.exr").exists() && !dir.join("merged.depth").exists());

    // A tile of another frame.
    std::fs::write(dir.join("other.rib"), SCENE.replace("Format 37 23 1", "Format 40 23 1")).unwrap();
    lrt_depth(
        dir,
        &["other.rib", "--quiet", "--crop", TILES[2], "-o", "tile-2.exr", "--depth", "tile-2.depth"],
    );
    let (code, err) = code_and_error(&merge_args(&[0, 1, 2]));
    assert_eq!(code, Some(1));
    assert!(err.contains("not parts of one frame"), "{err}");

    // Not an EXR tile, a depth table of the wrong size, bad command lines.
    render_tile(dir, 2, &[]);
    let mut args = merge_args(&[0, 1, 2]);
    *args.last_mut().unwrap() = "tile-2.png".into();
    let (code, err) = code_and_error(&args);
    assert_eq!(code, Some(1));
    assert!(err.contains("tile-2.png: cannot read it as OpenEXR"), "{err}");
    let mut args = merge_args(&[0, 1, 2]);
    args[5] = "tile-1.depth".into();
    let (code, err) = code_and_error(&args);
    assert_eq!(code, Some(1));
    assert!(err.contains("tile-1.depth is 22x13 but its tile tile-0.exr is 15x13"), "{err}");
    let (code, _) = code_and_error(&[
        "-o".into(),
        "m.exr".into(),
        "--depth".into(),
        "m.depth".into(),
        "tile-0.exr".into(),
    ]);
    assert_eq!(code, Some(2));
    let (code, _) = code_and_error(&["-o".into(), "m.png".into(), "tile-0.exr".into()]);
    assert_eq!(code, Some(2));
    let (code, _) = code_and_error(&["-o".into(), "m.exr".into()]);
    assert_eq!(code, Some(2));
}

#[test]
fn bad_crop_flags_are_command_line_errors() {
    let scratch_dir = temp_dir("crop-flags");
    let dir = scratch_dir.path();
    for crop in ["0,1,0", "0,1,0,x", "0.5,0.5,0,1", "0,1.5,0,1", "-0.1,1,0,1"] {
        let out = run(env!("CARGO_BIN_EXE_lrt-depth"), dir, &["scene.rib", "--crop", crop]);
        assert_eq!(out.status.code(), Some(2), "--crop {crop}");
        assert!(String::from_utf8_lossy(&out.stderr).contains("--crop"), "--crop {crop}");
    }
}

/// Three frames of one RIB, each its own world (the sphere moves).
const ANIMATION: &str = include_str!("data/animation.rib");

fn tile_args(image: &str, depth: &str, tiles: &[usize]) -> Vec<String> {
    merge_args_named(tiles, |k| (format!("{image}.tile{k:03}.exr"), format!("{depth}.tile{k:03}.depth")))
}

/// `--tiles NX,NY` with `--tile K` or the Slurm array index renders tile K; the tiles merge into
/// the one-machine render byte for byte; a missing tile, a tile of another frame and a tile of
/// another scene are refused by name.
#[test]
fn tiles_from_the_array_index_merge_byte_for_byte_and_bad_sets_are_named() {
    let scratch = temp_dir("tiles");
    let dir = scratch.path();
    lrt_depth(dir, &["scene.rib", "-q"]);
    for k in 0..6 {
        let out = Command::new(env!("CARGO_BIN_EXE_lrt-depth"))
            .current_dir(dir)
            .args(["scene.rib", "-q", "--tiles", "3,2"])
            .env("SLURM_ARRAY_TASK_ID", k.to_string())
            .output()
            .unwrap();
        assert!(out.status.success(), "{}", String::from_utf8_lossy(&out.stderr));
    }
    // The PNG display is not written per tile: tiles are OpenEXR.
    assert!(dir.join("full.tile005.exr").is_file() && !dir.join("full.tile005.png").exists());
    let args = tile_args("full", "full", &[0, 1, 2, 3, 4, 5]);
    let out = lrt_merge(dir, &args.iter().map(String::as_str).collect::<Vec<_>>());
    assert!(out.status.success(), "{}", String::from_utf8_lossy(&out.stderr));
    let same = |a: &str, b: &str| std::fs::read(dir.join(a)).unwrap() == std::fs::read(dir.join(b)).unwrap();
    assert!(same("merged.exr", "full.exr") && same("merged.depth", "full.depth"));

    // A missing tile is named, with how to rerun it.
    let args = tile_args("full", "full", &[0, 1, 3, 4, 5]);
    let out = lrt_merge(dir, &args.iter().map(String::as_str).collect::<Vec<_>>());
    let err = String::from_utf8_lossy(&out.stderr);
    assert_eq!(out.status.code(), Some(1), "{err}");
    assert!(err.contains("tile 2 of the 3x2 tiles") && err.contains("rerun"), "{err}");

    // A tile of another scene (one more light) of the same size is refused.
    let other = SCENE.replace(
        "Surface \"matte\"",
        "LightSource \"ambientlight\" 3 \"intensity\" [0.1]\nSurface \"matte\"",
    );
    std::fs::write(dir.join("other.rib"), other).unwrap();
    lrt_depth(
        dir,
        &["other.rib", "-q", "--tiles", "3,2", "--tile", "2", "-o", "other.exr", "--depth", "other.depth"],
    );
    let mut args = tile_args("full", "full", &[0, 1, 3, 4, 5]);
    args.extend(["--tile-depth".into(), "other.tile002.depth".into(), "other.tile002.exr".into()]);
    let out = lrt_merge(dir, &args.iter().map(String::as_str).collect::<Vec<_>>());
    let err = String::from_utf8_lossy(&out.stderr);
    assert_eq!(out.status.code(), Some(1), "{err}");
    assert!(err.contains("another render"), "{err}");

    // The right image with a depth table of another render (same tile, same size) is refused:
    // the table carries its image's stamp.
    let mut args = tile_args("full", "full", &[0, 1, 3, 4, 5]);
    args.extend(["--tile-depth".into(), "other.tile002.depth".into(), "full.tile002.exr".into()]);
    let out = lrt_merge(dir, &args.iter().map(String::as_str).collect::<Vec<_>>());
    let err = String::from_utf8_lossy(&out.stderr);
    assert_eq!(out.status.code(), Some(1), "{err}");
    assert!(err.contains("other.tile002.depth") && err.contains("rerun tile 2"), "{err}");
    assert!(!dir.join("merged.exr").exists() || same("merged.exr", "full.exr"));

    // An index past the tiles is a command-line error.
    let out = Command::new(env!("CARGO_BIN_EXE_lrt-depth"))
        .current_dir(dir)
        .args(["scene.rib", "-q", "--tiles", "3,2"])
        .env("SLURM_ARRAY_TASK_ID", "6")
        .output()
        .unwrap();
    assert_eq!(out.status.code(), Some(2));
    assert!(String::from_utf8_lossy(&out.stderr).contains("numbered 0 to 5"));
}

/// `--frames A-B` renders each frame under its own name; as an array task only frame A + index;
/// tiles of two frames do not merge.
#[test]
fn frames_are_named_by_number_and_tiles_of_two_frames_do_not_merge() {
    let scratch = temp_dir("frames");
    let dir = scratch.path();
    std::fs::write(dir.join("anim.rib"), ANIMATION).unwrap();
    lrt_depth(dir, &["anim.rib", "-q", "--frames", "1-3"]);
    let frame = |n: u32| std::fs::read(dir.join(format!("anim.{n:04}.exr"))).unwrap();
    assert!(frame(1) != frame(2));
    // The array task's frame equals the same frame of the sequential run.
    let out = Command::new(env!("CARGO_BIN_EXE_lrt-depth"))
        .current_dir(dir)
        .args(["anim.rib", "-q", "--frames", "1-3", "-o", "task.#f.exr", "--depth", "task.#f.depth"])
        .env("SLURM_ARRAY_TASK_ID", "1")
        .output()
        .unwrap();
    assert!(out.status.success(), "{}", String::from_utf8_lossy(&out.stderr));
    assert!(std::fs::read(dir.join("task.0002.exr")).unwrap() == frame(2));
    assert!(!dir.join("task.0001.exr").exists() && !dir.join("task.0003.exr").exists());
    let depth = |name: &str| std::fs::read(dir.join(name)).unwrap();
    assert!(depth("task.0002.depth") == depth("anim.0002.depth"));

    // Frame 1's tile 0 with frame 2's tile 1 is refused.
    for (f, k) in [(1, 0), (2, 1)] {
        let frames = format!("{f}-{f}");
        lrt_depth(dir, &["anim.rib", "-q", "--frames", &frames, "--tiles", "2,1", "--tile", &k.to_string()]);
    }
    let out = lrt_merge(dir, &["-o", "m.exr", "anim.0001.tile000.exr", "anim.0002.tile001.exr"]);
    let err = String::from_utf8_lossy(&out.stderr);
    assert_eq!(out.status.code(), Some(1), "{err}");
    assert!(err.contains("frame 2") && err.contains("frame 1"), "{err}");
}
