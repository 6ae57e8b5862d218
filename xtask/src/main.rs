//! Project automation, run as `cargo xtask <command>` (alias in `.cargo/config.toml`).
//!
//! - `cargo xtask test`: the whole test suite, exactly what CI runs (`cargo fmt --check`,
//!   `cargo clippy -D warnings` on every target, then `cargo test --workspace`). It first makes sure the
//!   system packages the GPU and window tests need are installed (a software Vulkan driver and a
//!   virtual X server), so the viewer's GPU code really runs on a machine without a GPU.
//! - `cargo xtask depth-exhaustive` / `depth-study`: see `depth.rs`.
//! - `cargo xtask update-fixtures`, `cargo xtask bench-parse`: see `rib.rs`; `cargo xtask bench-check`: see `check.rs`.
//! - `cargo xtask cornell-check`: see `cornell.rs`; `cargo xtask bench-raytracer`: see `raytracer.rs`.
//! - `cargo xtask colocation`: the viewer against `lrt-depth`'s renders; see `colocation.rs`.
//! - `cargo xtask illusion`: composites against ray traces with the live object; see `illusion.rs`.
//! - `cargo xtask bench-error`, `cargo xtask image-error`: see `bench_error.rs`.
//! - `cargo xtask corpus`: the RIB corpus rendered small, a contact sheet and warning table; see `corpus.rs`.
//! - `cargo xtask reflection-probes`: the reflection probes' bake cost and picture; see `reflections.rs`.
//! - `cargo xtask env-light`: a generated sky lighting a small scene (docs/environment-light.png); see `env_light.rs`.

mod bench_error;
mod check;
mod colocation;
mod cornell;
mod corpus;
mod depth;
mod env_light;
mod illusion;
mod measure;
mod mitsuba;
mod raytracer;
mod reflections;
mod rib;
mod scale_out;
mod xvfb;

use std::path::{Path, PathBuf};
use std::process::{Command, ExitCode};

/// Debian packages the test suite needs: lavapipe (software Vulkan) and its loader, so wgpu finds
/// a Vulkan adapter that can copy depth textures; Xvfb, so window tests have a display.
/// Debian's Slurm and munge, so the job scripts of examples/slurm run on a real one-node cluster.
const TEST_PACKAGES: &[&str] = &["mesa-vulkan-drivers", "libvulkan1", "xvfb", "slurm-wlm", "munge"];

fn main() -> ExitCode {
    let args: Vec<String> = std::env::args().skip(1).collect();
    let result = match args.first().map(String::as_str) {
        Some("test") => test(&args[1..]),
        Some("install-test-deps") => install_test_packages(),
        Some("depth-exhaustive") => depth::exhaustive(&args[1..]),
        Some("depth-study") => depth::study(),
        Some("update-fixtures") => rib::update_fixtures(),
        Some("bench-parse") => rib::bench_parse(&args[1..]),
        Some("bench-check") => check::bench_check(&args[1..]),
        Some("cornell-check") => cornell::cornell_check(cargo(), &args[1..]),
        Some("bench-raytracer") => raytracer::bench(cargo(), &args[1..]),
        Some("colocation") => colocation::colocation(),
        Some("illusion") => illusion::illusion(&args[1..]),
        Some("bench-error") => bench_error::bench_error(&args[1..]),
        Some("image-error") => bench_error::image_error(&args[1..]),
        Some("scale-out") => scale_out::scale_out(&args[1..]),
        Some("corpus") => corpus::corpus(&workspace_root(), &args[1..]),
        Some("reflection-probes") => reflections::reflection_probes(&args[1..]),
        Some("env-light") => env_light::env_light(&args[1..]),
        _ => {
            eprintln!(
                "usage: cargo xtask <command>\n\ncommands:\n  test [cargo test args]   run the whole test suite (installs its system packages first)\n  install-test-deps        only install the system packages the tests need\n  depth-exhaustive         every f32 through the depth-table writer and reader (minutes)\n  depth-study              print the figures of docs/depth-mapping.md\n  update-fixtures          rewrite the expected outputs of fixtures/rib (review the diff)\n  bench-parse              the RIB parse-throughput benchmark (release, one core)\n  bench-check              lrt-depth --check against wc -w on a generated 50 MB mesh\n  cornell-check            the ray tracer against Mitsuba's converged Cornell box (minutes)\n  bench-raytracer          ray-tracing benchmark tables for docs/raytracer.md\n  colocation               hybrid-view's sphere mask against lrt-depth renders at 512x512\n  illusion                 live objects against ray traces of the scene with them: docs/illusion.md (minutes)\n  bench-error              render time against error for every integrator (docs/performance.md)\n  image-error A.exr B.exr  RMSE and relative MSE of an image against a reference\n  scale-out                the Cornell box as 1, 4 and 16 tiles through a local Slurm (docs/scale-out.md)\n  corpus                   render ../shared/rib-corpus small: docs/corpus.md and its contact sheet (minutes)\n  reflection-probes        the reflection probes' bake cost against the render, and their picture (docs/sidecar.md)\n  env-light                a generated lat-long sky lighting spheres: docs/environment-light.png"
            );
            return ExitCode::from(2);
        }
    };
    match result {
        Ok(()) => ExitCode::SUCCESS,
        Err(message) => {
            eprintln!("xtask: error: {message}");
            ExitCode::FAILURE
        }
    }
}

fn workspace_root() -> PathBuf {
    Path::new(env!("CARGO_MANIFEST_DIR")).parent().expect("xtask lives in the workspace").to_path_buf()
}

fn cargo() -> Command {
    let mut cmd = Command::new(std::env::var("CARGO").unwrap_or_else(|_| "cargo".into()));
    cmd.current_dir(workspace_root());
    cmd
}

fn run(cmd: &mut Command) -> Result<(), String> {
    eprintln!("xtask: running {cmd:?}");
    let status = cmd.status().map_err(|e| format!("cannot start {cmd:?}: {e}"))?;
    if status.success() { Ok(()) } else { Err(format!("{cmd:?} failed with {status}")) }
}

fn have_program(name: &str) -> bool {
    std::env::var_os("PATH")
        .map(|paths| std::env::split_paths(&paths).any(|dir| dir.join(name).is_file()))
        .unwrap_or(false)
}

fn package_installed(name: &str) -> bool {
    Command::new("dpkg-query")
        .args(["-W", "-f=${Status}", name])
        .output()
        .map(|o| o.status.success() && String::from_utf8_lossy(&o.stdout).contains("install ok installed"))
        .unwrap_or(false)
}

/// Installs [`TEST_PACKAGES`] with apt when any is missing. Fails loudly rather than letting GPU
/// tests silently skip: a test must never pass because no adapter was found.
fn install_test_packages() -> Result<(), String> {
    install_packages(TEST_PACKAGES, "a Vulkan driver (lavapipe), Xvfb, Slurm and munge")
}

/// Installs the Debian `packages` that are missing with apt (as root, or through sudo);
/// `what` names them for the error on a machine without dpkg.
fn install_packages(packages: &[&str], what: &str) -> Result<(), String> {
    if !have_program("dpkg-query") {
        return Err(format!("this machine has no dpkg; install {what} by hand"));
    }
    let missing: Vec<&str> = packages.iter().copied().filter(|p| !package_installed(p)).collect();
    if missing.is_empty() {
        return Ok(());
    }
    let as_root = Command::new("id").arg("-u").output().map(|o| o.stdout.starts_with(b"0")).unwrap_or(false);
    let apt = |args: &[&str]| {
        let mut cmd = if as_root {
            Command::new("apt-get")
        } else {
            let mut c = Command::new("sudo");
            c.arg("apt-get");
            c
        };
        cmd.args(args).env("DEBIAN_FRONTEND", "noninteractive");
        cmd
    };
    run(&mut apt(&["update", "-q"]))?;
    let mut install = apt(&["install", "-y", "-q", "--no-install-recommends"]);
    install.args(&missing);
    run(&mut install)
}

fn test(extra: &[String]) -> Result<(), String> {
    install_test_packages()?;
    run(cargo().args(["fmt", "--all", "--", "--check"]))?;
    // Lints are a gate too: a warning in any target (tests and benches included) fails the run.
    let has_clippy = cargo().args(["clippy", "--version"]).output().is_ok_and(|o| o.status.success());
    if !has_clippy {
        run(Command::new("rustup").args(["component", "add", "clippy"]))?;
    }
    run(cargo().args(["clippy", "--workspace", "--all-targets", "--", "-D", "warnings"]))?;
    // Window tests need a display: run the suite against a private virtual X server that is
    // known to accept connections (see xvfb.rs for why not xvfb-run).
    let display = xvfb::VirtualDisplay::start()?;
    let mut cmd = cargo();
    cmd.args(["test", "--workspace"])
        .args(extra)
        .env("DISPLAY", display.display())
        .env_remove("XAUTHORITY")
        .env_remove("WAYLAND_DISPLAY");
    run(&mut cmd)
}
