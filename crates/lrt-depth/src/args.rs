//! Command-line arguments (CONTRACTS.md §4) and the checked settings derived from them.
//!
//! Parsing happens in two stages, as in ripgrep: clap reads the raw flags into [`Cli`], then
//! [`Settings::from_cli`] checks them and resolves defaults. Both stages fail with exit code 2.

use clap::Parser;
use depth_remap::CropWindow;
use std::num::{NonZeroU32, NonZeroUsize};
use std::path::PathBuf;

/// Render a RenderMan RIB scene into an image and a depth table.
#[derive(Debug, Parser)]
#[command(name = "lrt-depth", version, about, long_about = None)]
pub struct Cli {
    /// The RIB scene to render (`-` reads it from standard input).
    #[arg(value_name = "SCENE.rib")]
    pub scene: PathBuf,

    /// Parse and build the scene (archives included) without rendering, print a summary.
    #[arg(long)]
    pub check: bool,

    /// Write the image here instead of the name the RIB's Display gives (format from the
    /// extension: .tif/.tiff, .png, .jpg, .exr).
    #[arg(short = 'o', long = "output", value_name = "IMAGE")]
    pub output: Option<PathBuf>,

    /// Write the depth table here (overrides or adds the RIB's depth request).
    #[arg(long, value_name = "PATH")]
    pub depth: Option<PathBuf>,

    /// Samples per pixel (overrides the RIB's PixelSamples).
    #[arg(long, value_name = "N")]
    pub spp: Option<u32>,

    /// Render in passes until this many seconds have gone by (at least one pass; the image is
    /// the average of the passes done, written as always).
    #[arg(long = "time", value_name = "SECONDS")]
    pub time: Option<f64>,

    /// Stop sampling each pixel once its estimated relative error (relative standard error,
    /// the square root of the estimated relMSE) is at most E.
    #[arg(long = "target-error", value_name = "E")]
    pub target_error: Option<f64>,

    /// Worker threads (default: all cores).
    #[arg(long, value_name = "N")]
    pub threads: Option<usize>,

    /// Print nothing but errors.
    #[arg(short, long)]
    pub quiet: bool,

    /// Print statistics: what was read, built, skipped and why.
    #[arg(long)]
    pub stats: bool,

    /// Render only this part of the frame (replaces the RIB's CropWindow): `XMIN,XMAX,YMIN,YMAX`
    /// in [0, 1], as CropWindow takes them. Abutting windows tile the frame exactly; EXR tiles
    /// record their place, and `lrt-merge` joins them.
    #[arg(long, value_name = "XMIN,XMAX,YMIN,YMAX", allow_hyphen_values = true)]
    pub crop: Option<String>,

    /// Use the world of `FrameBegin N` (default: the first world of the file that is not a shadow-map pass).
    #[arg(long, value_name = "N", allow_negative_numbers = true)]
    pub frame: Option<i32>,
}

/// What to do.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum Mode {
    Check,
    Render,
}

/// Checked settings for one run.
#[derive(Clone, Debug)]
pub struct Settings {
    pub scene: PathBuf,
    pub mode: Mode,
    pub output: Option<PathBuf>,
    pub depth: Option<PathBuf>,
    pub spp: Option<NonZeroU32>,
    pub threads: NonZeroUsize,
    pub quiet: bool,
    pub stats: bool,
    pub frame: Option<i32>,
    pub crop: Option<CropWindow>,
    pub time_budget: Option<std::time::Duration>,
    pub target_error: Option<f32>,
}

/// The longest `--time` accepted: a week.
const MAX_TIME_SECONDS: f64 = 7.0 * 24.0 * 3600.0;

/// Parses `--crop`: four numbers that make a valid [`CropWindow`] (`0 <= min < max <= 1`).
fn parse_crop(text: &str) -> Result<CropWindow, String> {
    let values: Vec<f64> = text
        .split(',')
        .map(|v| v.trim().parse::<f64>().map_err(|_| format!("--crop: '{}' is not a number", v.trim())))
        .collect::<Result<_, _>>()?;
    let [xmin, xmax, ymin, ymax] = values[..] else {
        return Err(format!("--crop takes four numbers XMIN,XMAX,YMIN,YMAX, not {}", values.len()));
    };
    let crop = CropWindow { xmin, xmax, ymin, ymax };
    if !crop.is_valid() {
        return Err(format!("--crop {text}: must satisfy 0 <= min < max <= 1 on both axes"));
    }
    Ok(crop)
}

impl Settings {
    /// Checks the raw flags. The error message is meant for `lrt-depth: error: ...`.
    pub fn from_cli(cli: Cli) -> Result<Settings, String> {
        let spp = match cli.spp {
            Some(n) => Some(NonZeroU32::new(n).ok_or("--spp must be at least 1")?),
            None => None,
        };
        let threads = match cli.threads {
            Some(n) => NonZeroUsize::new(n).ok_or("--threads must be at least 1")?,
            None => std::thread::available_parallelism().unwrap_or(NonZeroUsize::MIN),
        };
        if cli.quiet && cli.stats {
            return Err("--quiet and --stats contradict each other".into());
        }
        for (flag, path) in [("-o", &cli.output), ("--depth", &cli.depth)] {
            if path.as_ref().is_some_and(|p| p.as_os_str().is_empty()) {
                return Err(format!("{flag} needs a file name"));
            }
        }
        let crop = cli.crop.as_deref().map(parse_crop).transpose()?;
        let time_budget = match cli.time {
            None => None,
            Some(t) if t.is_finite() && t > 0.0 && t <= MAX_TIME_SECONDS => {
                Some(std::time::Duration::from_secs_f64(t))
            }
            Some(t) => {
                return Err(format!(
                    "--time {t}: must be a positive number of seconds, at most {MAX_TIME_SECONDS}"
                ));
            }
        };
        let target_error = match cli.target_error {
            None => None,
            Some(e) if e.is_finite() && e > 0.0 && e < 1e3 => Some(e as f32),
            Some(e) => return Err(format!("--target-error {e}: must be a positive relative error")),
        };
        Ok(Settings {
            crop,
            scene: cli.scene,
            mode: if cli.check { Mode::Check } else { Mode::Render },
            output: cli.output,
            depth: cli.depth,
            spp,
            threads,
            quiet: cli.quiet,
            stats: cli.stats,
            frame: cli.frame,
            time_budget,
            target_error,
        })
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    fn parse(args: &[&str]) -> Result<Settings, String> {
        let cli = Cli::try_parse_from(std::iter::once("lrt-depth").chain(args.iter().copied()))
            .map_err(|e| e.to_string())?;
        Settings::from_cli(cli)
    }

    #[test]
    fn every_contract_flag_parses() {
        let s = parse(&[
            "scene.rib",
            "--check",
            "-o",
            "x.exr",
            "--depth",
            "d.depth",
            "--spp",
            "4",
            "--threads",
            "2",
            "--stats",
            "--frame",
            "-3",
        ])
        .unwrap();
        assert_eq!(s.mode, Mode::Check);
        assert_eq!(s.output.as_deref(), Some(std::path::Path::new("x.exr")));
        assert_eq!(s.depth.as_deref(), Some(std::path::Path::new("d.depth")));
        assert_eq!(s.spp.map(|n| n.get()), Some(4));
        assert_eq!(s.threads.get(), 2);
        assert_eq!(s.frame, Some(-3));
        assert!(s.stats && !s.quiet);
        assert_eq!(parse(&["-"]).unwrap().scene, PathBuf::from("-"));
    }

    #[test]
    fn time_and_target_error_parse_and_are_checked() {
        let s = parse(&["s.rib", "--time", "2.5", "--target-error", "0.02"]).unwrap();
        assert_eq!(s.time_budget, Some(std::time::Duration::from_millis(2500)));
        assert_eq!(s.target_error, Some(0.02));
        for bad in [
            ["--time", "0"],
            ["--time", "-1"],
            ["--time", "inf"],
            ["--target-error", "0"],
            ["--target-error", "nan"],
        ] {
            assert!(parse(&["s.rib", bad[0], bad[1]]).is_err(), "{bad:?}");
        }
    }

    #[test]
    fn bad_values_are_rejected() {
        assert!(parse(&["s.rib", "--spp", "0"]).is_err());
        assert!(parse(&["s.rib", "--threads", "0"]).is_err());
        assert!(parse(&["s.rib", "--quiet", "--stats"]).is_err());
        assert!(parse(&["s.rib", "--spp", "many"]).is_err());
        assert!(parse(&[]).is_err());
    }
}
