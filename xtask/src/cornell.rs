//! `cargo xtask cornell-check [--spp N] [--threads N]`: the full Cornell-box check of the ray
//! tracer against Mitsuba 3's converged image and the analytic depth table (see
//! `crates/raytracer/examples/cornell_check.rs`). Takes about two and a half minutes of CPU on
//! two cores at the default 256 samples per pixel.

use std::process::Command;

pub fn cornell_check(cargo: Command, extra: &[String]) -> Result<(), String> {
    let mut cmd = cargo;
    cmd.args(["run", "--release", "-p", "raytracer", "--example", "cornell_check", "--"]).args(extra);
    eprintln!("xtask: running {cmd:?}");
    let status = cmd.status().map_err(|e| format!("cannot start cargo: {e}"))?;
    if status.success() { Ok(()) } else { Err("the Cornell check failed".into()) }
}
