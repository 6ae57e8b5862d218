//! `hybrid-view IMAGE DEPTH SCENE.rib`: the real-time half of hybrid rendering (CONTRACTS.md §5).
//!
//! The pre-rendered image is shown pixel for pixel; live objects (the cursor sphere) are drawn
//! with the RIB camera's projection and lit by its lights, and occlude and are occluded by the
//! pre-rendered scene through its converted depth table. `--headless` renders offscreen and
//! writes exactly what the window would show. With `--device`, a haptic device drives the
//! sphere through the haptics crate's proxy (see `haptic.rs`).
//!
//! Exit codes: 0 success, 1 invalid input or failed rendering, 2 bad command line.

mod args;
mod convert;
mod haptic;
mod live_rib;
mod run;
mod scene_occluders;

use clap::Parser;
use std::process::ExitCode;

fn main() -> ExitCode {
    // `--list-devices` needs no image, depth table or scene.
    if std::env::args_os().skip(1).any(|a| a == "--list-devices") {
        return haptic::list_devices();
    }
    let args = match args::Args::try_parse() {
        Ok(a) => a,
        Err(e) => {
            // Help and version go to stdout with status 0; usage errors exit with 2.
            let code = if e.use_stderr() { 2 } else { 0 };
            let _ = e.print();
            return ExitCode::from(code);
        }
    };
    let settings = match args.settings() {
        Ok(s) => s,
        Err(message) => {
            eprintln!("hybrid-view: error: {message}");
            return ExitCode::from(2);
        }
    };
    let result = run::prepare(&settings).and_then(|mut prepared| match &settings.haptics {
        // The haptics tessellate the scene for themselves and the viewer's shadow rays.
        Some(haptics) => haptic::run(&settings, haptics, prepared),
        None => {
            prepared.tessellate_scene(&scene_occluders::viewer_tolerance(), settings.stats);
            if settings.headless {
                run::headless(&settings, prepared, None)
            } else {
                run::windowed(&settings, prepared, None)
            }
        }
    });
    match result {
        Ok(()) => ExitCode::SUCCESS,
        Err(run::Failure(message)) => {
            eprintln!("hybrid-view: error: {message}");
            ExitCode::from(1)
        }
    }
}
