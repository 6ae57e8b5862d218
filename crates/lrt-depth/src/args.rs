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

    /// How the path integrator runs: `wavefront` (batches of paths, where the scene qualifies;
    /// the same image) or `scalar` (one path at a time). Default: the renderer's choice.
    #[arg(long, value_name = "scalar|wavefront")]
    pub paths: Option<String>,

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

    /// Shrink the RIB's Format so its longest side is at most N pixels, keeping the frame's
    /// aspect ratio (for previews and contact sheets; a smaller Format is left as it is).
    #[arg(long = "max-size", value_name = "N")]
    pub max_size: Option<u32>,

    /// Use the world of `FrameBegin N` (default: the first world of the file that is not a
    /// shadow-map pass).
    #[arg(long, value_name = "N", allow_negative_numbers = true, conflicts_with = "frames")]
    pub frame: Option<i32>,

    /// Split the frame into NX x NY tiles and render one of them (`--tile`, or the Slurm array
    /// index): tiles are numbered row by row from the top left, from 0, written as OpenEXR
    /// with `.tileK` (or the `#t` of the name) in their names, and joined by `lrt-merge`.
    #[arg(long, value_name = "NX,NY", conflicts_with = "crop")]
    pub tiles: Option<String>,

    /// The tile to render, in 0..NX*NY (default: `SLURM_ARRAY_TASK_ID`).
    #[arg(long, value_name = "K", requires = "tiles")]
    pub tile: Option<u32>,

    /// Render the frames A to B of a multi-frame RIB (`FrameBegin N`), each named with its
    /// number (`.NNNN`, or the `#f` of the name). In a Slurm array task, only the one frame of
    /// the array index: frame A + index (with `--tiles`, frame A + index / tiles and tile
    /// index % tiles).
    #[arg(long, value_name = "A-B", allow_hyphen_values = true)]
    pub frames: Option<String>,
}

/// The environment variable Slurm sets in each task of a job array.
pub const ARRAY_TASK_ENV: &str = "SLURM_ARRAY_TASK_ID";

/// The most tiles one frame may be split into.
pub const MAX_TILES: u32 = 1 << 16;

/// The most frames one `--frames` range may hold.
pub const MAX_FRAMES: i64 = 1 << 20;

/// A frame split into `nx` x `ny` tiles.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub struct Tiling {
    pub nx: u32,
    pub ny: u32,
}

impl Tiling {
    pub fn count(&self) -> u32 {
        self.nx * self.ny
    }

    /// The crop window of tile `k` (row by row from the top left). Neighbours compute their
    /// shared edge from the same integers, so the windows abut exactly.
    pub fn crop(&self, k: u32) -> CropWindow {
        let (tx, ty) = (k % self.nx, k / self.nx);
        let edge = |i: u32, n: u32| f64::from(i) / f64::from(n);
        CropWindow {
            xmin: edge(tx, self.nx),
            xmax: edge(tx + 1, self.nx),
            ymin: edge(ty, self.ny),
            ymax: edge(ty + 1, self.ny),
        }
    }
}

/// What part of the work this run does: which frames, and which tile of each.
#[derive(Clone, Debug, PartialEq, Eq)]
pub struct WorkShare {
    /// The frames to render in order (`None`: the one `--frame` or the first world).
    pub frames: Option<Vec<i32>>,
    /// The tiling and the tile rendered.
    pub tile: Option<(Tiling, u32)>,
}

fn parse_tiling(text: &str) -> Result<Tiling, String> {
    let parts: Vec<&str> = text.split(',').map(str::trim).collect();
    let [x, y] = parts[..] else { return Err(format!("--tiles {text}: give NX,NY (for example 4,4)")) };
    let count = |v: &str| v.parse::<u32>().ok().filter(|&n| n >= 1);
    match (count(x), count(y)) {
        (Some(nx), Some(ny)) if u64::from(nx) * u64::from(ny) <= u64::from(MAX_TILES) => {
            Ok(Tiling { nx, ny })
        }
        (Some(_), Some(_)) => Err(format!("--tiles {text}: at most {MAX_TILES} tiles")),
        _ => Err(format!("--tiles {text}: NX and NY are whole numbers of at least 1")),
    }
}

fn parse_frames(text: &str) -> Result<(i32, i32), String> {
    // `A-B`, where A and B may be negative (`-3--1`): split at a '-' that follows a digit.
    let bytes = text.as_bytes();
    let split = (1..bytes.len()).find(|&i| bytes[i] == b'-' && bytes[i - 1].is_ascii_digit());
    let (a, b) = match split {
        Some(i) => (&text[..i], &text[i + 1..]),
        None => (text, text),
    };
    let number = |v: &str| {
        v.trim().parse::<i32>().map_err(|_| format!("--frames {text}: '{v}' is not a frame number"))
    };
    let (a, b) = (number(a)?, number(b)?);
    if a > b {
        return Err(format!("--frames {text}: the first frame is after the last"));
    }
    if i64::from(b) - i64::from(a) >= MAX_FRAMES {
        return Err(format!("--frames {text}: at most {MAX_FRAMES} frames"));
    }
    Ok((a, b))
}

/// Resolves `--tiles`, `--tile` and `--frames` against the Slurm array index `array_task`
/// (the value of [`ARRAY_TASK_ENV`], if set).
pub fn work_share(
    tiles: Option<&str>,
    tile: Option<u32>,
    frames: Option<&str>,
    array_task: Option<&str>,
) -> Result<WorkShare, String> {
    let tiling = tiles.map(parse_tiling).transpose()?;
    let frames = frames.map(parse_frames).transpose()?;
    let per_frame = tiling.map_or(1, |t| t.count());
    // The array index matters only where a flag leaves the choice to it.
    let needs_index = (tiling.is_some() && tile.is_none()) || frames.is_some();
    let index = match array_task.filter(|_| needs_index) {
        Some(v) => Some(
            v.trim()
                .parse::<u64>()
                .map_err(|_| format!("{ARRAY_TASK_ENV}={v}: not an array index (whole number from 0)"))?,
        ),
        None => None,
    };
    let frame_list = match (frames, index) {
        (None, _) => None,
        (Some((a, b)), None) => Some((a..=b).collect()),
        (Some((a, b)), Some(k)) => {
            let frame = i64::from(a) + (k / u64::from(per_frame)) as i64;
            if frame > i64::from(b) {
                return Err(format!(
                    "{ARRAY_TASK_ENV}={k} is past the last of frames {a}-{b}{}: submit --array=0-{}",
                    if per_frame > 1 { format!(" x {per_frame} tiles") } else { String::new() },
                    (i64::from(b) - i64::from(a) + 1) * i64::from(per_frame) - 1
                ));
            }
            Some(vec![frame as i32])
        }
    };
    let tile = match tiling {
        None => None,
        Some(t) => {
            let k = match (tile, index) {
                (Some(k), _) => u64::from(k),
                // Past the tiles is an error unless the index also counts frames.
                (None, Some(k)) if frames.is_some() => k % u64::from(t.count()),
                (None, Some(k)) => k,
                (None, None) => {
                    return Err(format!(
                        "--tiles {},{} needs --tile K (0 to {}) or {ARRAY_TASK_ENV} from a Slurm job array",
                        t.nx,
                        t.ny,
                        t.count() - 1
                    ));
                }
            };
            if k >= u64::from(t.count()) {
                return Err(format!(
                    "tile {k} of {}x{} tiles: tiles are numbered 0 to {}",
                    t.nx,
                    t.ny,
                    t.count() - 1
                ));
            }
            Some((t, k as u32))
        }
    };
    Ok(WorkShare { frames: frame_list, tile })
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
    pub max_size: Option<NonZeroU32>,
    pub time_budget: Option<std::time::Duration>,
    pub target_error: Option<f32>,
    /// `--paths`: `Some(true)` for the wavefront, `Some(false)` for the scalar integrator.
    pub wavefront: Option<bool>,
    /// Frames and tile of this run (`--frames`, `--tiles`, the Slurm array index).
    pub share: WorkShare,
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
        let array_task = std::env::var(ARRAY_TASK_ENV).ok();
        let share = work_share(cli.tiles.as_deref(), cli.tile, cli.frames.as_deref(), array_task.as_deref())?;
        let max_size = match cli.max_size {
            Some(n) => Some(NonZeroU32::new(n).ok_or("--max-size must be at least 1")?),
            None => None,
        };
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
        let wavefront = match cli.paths.as_deref() {
            None => None,
            Some("wavefront") => Some(true),
            Some("scalar") => Some(false),
            Some(other) => return Err(format!("--paths {other}: must be scalar or wavefront")),
        };
        Ok(Settings {
            crop,
            wavefront,
            max_size,
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
            share,
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
    fn tiles_and_frames_come_from_flags_or_the_array_index() {
        let t = Tiling { nx: 2, ny: 2 };
        let share = work_share(Some("2,2"), Some(3), None, Some("1")).unwrap();
        assert_eq!(share, WorkShare { frames: None, tile: Some((t, 3)) });
        assert_eq!(work_share(Some("2,2"), None, None, Some("2")).unwrap().tile, Some((t, 2)));
        assert!(work_share(Some("2,2"), None, None, None).unwrap_err().contains("SLURM_ARRAY_TASK_ID"));
        assert!(work_share(Some("2,2"), Some(4), None, None).unwrap_err().contains("0 to 3"));
        assert!(work_share(Some("2,2"), None, None, Some("x")).is_err());
        assert_eq!(work_share(None, None, Some("1-3"), None).unwrap().frames, Some(vec![1, 2, 3]));
        assert_eq!(work_share(None, None, Some("1-3"), Some("2")).unwrap().frames, Some(vec![3]));
        assert!(work_share(None, None, Some("1-3"), Some("3")).unwrap_err().contains("--array=0-2"));
        assert_eq!(work_share(None, None, Some("-3--2"), None).unwrap().frames, Some(vec![-3, -2]));
        assert_eq!(work_share(None, None, Some("5"), None).unwrap().frames, Some(vec![5]));
        // Frames and tiles: index 5 of 2 frames x 4 tiles is frame 2's tile 1.
        let both = work_share(Some("2,2"), None, Some("1-2"), Some("5")).unwrap();
        assert_eq!(both, WorkShare { frames: Some(vec![2]), tile: Some((t, 1)) });
        for bad in ["0,2", "2", "2,2,2", "a,b", "65537,1"] {
            assert!(work_share(Some(bad), Some(0), None, None).is_err(), "{bad}");
        }
        assert!(work_share(None, None, Some("3-1"), None).is_err());
        // The crops of a 3x2 tiling cover the unit square, row by row from the top left.
        let t = Tiling { nx: 3, ny: 2 };
        assert_eq!(t.crop(0), CropWindow { xmin: 0.0, xmax: 1.0 / 3.0, ymin: 0.0, ymax: 0.5 });
        assert_eq!(t.crop(5), CropWindow { xmin: 2.0 / 3.0, xmax: 1.0, ymin: 0.5, ymax: 1.0 });
        assert_eq!(t.crop(0).xmax, t.crop(1).xmin);
        assert!(parse(&["s.rib", "--tiles", "2,2", "--crop", "0,1,0,1", "--tile", "0"]).is_err());
        assert!(parse(&["s.rib", "--frames", "1-2", "--frame", "1"]).is_err());
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
