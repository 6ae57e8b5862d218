//! `cargo xtask colocation`: the viewer's co-location check against `lrt-depth` itself at the
//! Cornell scene's full 512x512. Builds `lrt-depth` (release), then runs the ignored
//! ground-truth test of `hybrid-view` with `LRT_DEPTH` pointing at it (docs/viewer.md).

use crate::{cargo, run, workspace_root};
use std::path::PathBuf;

pub fn colocation() -> Result<(), String> {
    run(cargo().args(["build", "--release", "-p", "lrt-depth"]))?;
    let target = std::env::var_os("CARGO_TARGET_DIR")
        .map(PathBuf::from)
        .unwrap_or_else(|| workspace_root().join("target"));
    let lrt_depth = target.join("release").join("lrt-depth");
    if !lrt_depth.is_file() {
        return Err(format!("{} was not built", lrt_depth.display()));
    }
    run(cargo()
        .args(["test", "--release", "-p", "hybrid-view", "--test", "ground_truth", "--"])
        .args(["--ignored", "--nocapture", "lrt_depth_renders_agree_at_full_resolution"])
        .env("LRT_DEPTH", &lrt_depth))
}
