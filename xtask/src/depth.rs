//! `cargo xtask depth-exhaustive`: the heavy checks of `depth-remap` that the normal suite runs
//! only on a sample: every positive finite `f32` through the depth-table writer and reader,
//! compared with std (minutes, in release mode).
//!
//! `cargo xtask depth-study`: prints the figures of `docs/depth-mapping.md` (paper check,
//! precision study).

use crate::{cargo, run};

pub fn exhaustive(extra: &[String]) -> Result<(), String> {
    run(cargo()
        .args([
            "test",
            "--release",
            "-p",
            "depth-remap",
            "--test",
            "exhaustive_float_text",
            "--",
            "--ignored",
        ])
        .args(extra))
}

pub fn study() -> Result<(), String> {
    run(cargo().args(["run", "--release", "-p", "depth-remap", "--example", "depth_study"]))
}
