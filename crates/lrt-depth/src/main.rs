//! `lrt-depth`: render a RIB scene to an image and a depth table (CONTRACTS.md §4).
//!
//! Exit codes: 0 success, 1 invalid scene or failed render, 2 bad command line.

mod args;
mod check;
mod render;

use clap::Parser;
use std::process::ExitCode;

fn main() -> ExitCode {
    let cli = match args::Cli::try_parse() {
        Ok(cli) => cli,
        Err(e) => {
            let code = if e.use_stderr() { 2 } else { 0 };
            let _ = e.print();
            return ExitCode::from(code);
        }
    };
    let settings = match args::Settings::from_cli(cli) {
        Ok(s) => s,
        Err(message) => {
            eprintln!("lrt-depth: error: {message}");
            return ExitCode::from(2);
        }
    };
    match settings.mode {
        args::Mode::Check => check::run(&settings),
        args::Mode::Render => render::run(&settings),
    }
}
