//! `cargo xtask bench-raytracer [--spp N] [--repeat N]`: the ray tracer's benchmark tables
//! (world build, primary rays against obvhs' own traversal, full renders) for
//! `docs/raytracer.md`; see `crates/raytracer/examples/bench.rs`.

use std::process::Command;

pub fn bench(cargo: Command, extra: &[String]) -> Result<(), String> {
    let mut cmd = cargo;
    cmd.args(["run", "--release", "-p", "raytracer", "--example", "bench", "--"]).args(extra);
    eprintln!("xtask: running {cmd:?}");
    let status = cmd.status().map_err(|e| format!("cannot start cargo: {e}"))?;
    if status.success() { Ok(()) } else { Err("the benchmark failed".into()) }
}
