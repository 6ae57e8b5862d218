//! `lrt-merge`: join the tiles of a frame rendered in parts (`lrt-depth --crop`, or a RIB's
//! `CropWindow`, one per worker of a render farm) into the full image and depth table.
//!
//! ```text
//! lrt-merge -o FULL.exr [--depth FULL.depth --tile-depth T1.depth --tile-depth T2.depth ...] T1.exr T2.exr ...
//! ```
//!
//! Tiles are OpenEXR files as `lrt-depth` writes crops: the display window is the full frame and
//! the data window the tile. Samples are copied bit for bit, so the merged files equal a
//! full-frame render's (the ray tracer makes every pixel a function of the seed and the pixel
//! alone). Tiles may overlap only where they agree bit for bit; every pixel of the frame must be
//! in some tile. Depth tables (text or EXR, one per tile, in the tiles' order) are placed where
//! their tile is. Exit codes: 0 merged, 1 a tile is unreadable or the tiles do not make a frame,
//! 2 bad command line.

use clap::Parser;
use depth_remap::DepthTable;
use exr::prelude::{
    AnyChannel, AnyChannels, Encoding, FlatSamples, Image, IntegerBounds, Layer, LayerAttributes,
    ReadChannels, ReadLayers, SmallVec, Text, Vec2, WritableImage, read,
};
use std::path::{Path, PathBuf};
use std::process::ExitCode;

/// The largest frame merged, in pixels: 8192 x 8192, about 1.5 GiB for four channels, their
/// ownership map and a depth table (a bound on memory for any input).
const MAX_PIXELS: usize = 1 << 26;

/// Join crop-window tiles of one frame into the full image and depth table.
#[derive(Debug, Parser)]
#[command(name = "lrt-merge", version, about, long_about = None)]
struct Cli {
    /// The tiles: OpenEXR images whose display window is the full frame.
    #[arg(value_name = "TILE.exr", required = true)]
    tiles: Vec<PathBuf>,

    /// The merged image (OpenEXR).
    #[arg(short = 'o', long = "output", value_name = "FULL.exr")]
    output: PathBuf,

    /// The merged depth table (text, or OpenEXR when the name ends in .exr).
    #[arg(long, value_name = "FULL.depth", requires = "tile_depth")]
    depth: Option<PathBuf>,

    /// One tile's depth table, given once per tile in the order of the tiles.
    #[arg(long = "tile-depth", value_name = "TILE.depth", requires = "depth")]
    tile_depth: Vec<PathBuf>,
}

fn main() -> ExitCode {
    let cli = match Cli::try_parse() {
        Ok(cli) => cli,
        Err(e) => {
            let code = if e.use_stderr() { 2 } else { 0 };
            let _ = e.print();
            return ExitCode::from(code);
        }
    };
    if !cli.tile_depth.is_empty() && cli.tile_depth.len() != cli.tiles.len() {
        eprintln!(
            "lrt-merge: error: {} tiles but {} --tile-depth tables: give one per tile, in the same order",
            cli.tiles.len(),
            cli.tile_depth.len()
        );
        return ExitCode::from(2);
    }
    if !has_exr_extension(&cli.output) {
        eprintln!(
            "lrt-merge: error: -o {}: the merged image is written as OpenEXR (.exr)",
            cli.output.display()
        );
        return ExitCode::from(2);
    }
    match merge(&cli) {
        Ok(summary) => {
            println!("{summary}");
            ExitCode::SUCCESS
        }
        Err(message) => {
            eprintln!("lrt-merge: error: {message}");
            ExitCode::from(1)
        }
    }
}

fn has_exr_extension(path: &Path) -> bool {
    path.extension().is_some_and(|e| e.eq_ignore_ascii_case("exr"))
}

/// How a channel stores its samples; merged samples are kept as bit patterns.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
enum SampleType {
    F16,
    F32,
    U32,
}

/// One tile: where it sits in the frame and its channels' samples as bits.
struct Tile {
    path: PathBuf,
    /// The full frame (display window).
    frame: IntegerBounds,
    /// The tile's top-left pixel relative to the frame's, and its size.
    x: usize,
    y: usize,
    width: usize,
    height: usize,
    channels: Vec<(Text, SampleType, Vec<u32>)>,
    /// What `lrt-depth --tiles` recorded: render fingerprint, frame, tiling and tile index.
    stamp: Option<Stamp>,
}

/// A tile's stamp (docs/scale-out.md): the `lrt.*` text attributes of its layer.
#[derive(Clone, Debug, PartialEq, Eq)]
struct Stamp {
    render: String,
    frame: String,
    tiles: (u32, u32),
    tile: u32,
}

fn read_stamp(path: &Path, attributes: &exr::meta::header::LayerAttributes) -> Result<Option<Stamp>, String> {
    parse_stamp(path, |key: &str| match attributes.other.get(&Text::from(format!("lrt.{key}").as_str())) {
        Some(exr::meta::attribute::AttributeValue::Text(t)) => Some(t.to_string()),
        _ => None,
    })
}

/// A stamp from its values by key (`render`, `frame`, `tiles`, `tile`); `None` without `render`.
fn parse_stamp(path: &Path, text: impl Fn(&str) -> Option<String>) -> Result<Option<Stamp>, String> {
    let Some(render) = text("render") else { return Ok(None) };
    let bad = |what: &str| format!("{}: its tile stamp has no valid {what}", path.display());
    let tiles = text("tiles")
        .and_then(|t| {
            let (x, y) = t.split_once(',')?;
            Some((x.parse::<u32>().ok()?, y.parse::<u32>().ok()?))
        })
        .filter(|&(x, y)| x >= 1 && y >= 1 && u64::from(x) * u64::from(y) <= 1 << 16)
        .ok_or_else(|| bad("tiles"))?;
    let tile = text("tile")
        .and_then(|t| t.parse::<u32>().ok())
        .filter(|&k| k < tiles.0 * tiles.1)
        .ok_or_else(|| bad("tile"))?;
    Ok(Some(Stamp { render, frame: text("frame").unwrap_or_else(|| "-".into()), tiles, tile }))
}

/// The stamp line (`# lrt-tile render=H frame=F tiles=NX,NY tile=K`) among the leading
/// comment lines of a tile's text depth table; only those few lines are read.
fn read_depth_stamp(path: &Path) -> Result<Option<Stamp>, String> {
    use std::io::{BufRead, Read};
    let io_error = |e: std::io::Error| format!("{}: {e}", path.display());
    let mut reader = std::io::BufReader::new(std::fs::File::open(path).map_err(io_error)?);
    for _ in 0..8 {
        let mut line = Vec::new();
        let n = (&mut reader).take(4096).read_until(b'\n', &mut line).map_err(io_error)?;
        if n == 0 || line.first() != Some(&b'#') {
            break;
        }
        let line = String::from_utf8_lossy(&line);
        let Some(fields) = line.trim_end().strip_prefix("# lrt-tile ") else { continue };
        let pairs: Vec<(&str, &str)> = fields.split(' ').filter_map(|w| w.split_once('=')).collect();
        return parse_stamp(path, |key: &str| {
            pairs.iter().find(|(k, _)| *k == key).map(|(_, v)| (*v).to_string())
        })?
        .map(Some)
        .ok_or_else(|| format!("{}: its tile stamp has no render", path.display()));
    }
    Ok(None)
}

/// A stamped tile's text depth table must carry the same stamp as its image, so that a table
/// left from another render, frame or tile is never joined with the wrong image.
fn check_depth_stamps(tiles: &[Tile], tables: &[PathBuf]) -> Result<(), String> {
    for (t, path) in tiles.iter().zip(tables) {
        let Some(stamp) = &t.stamp else { continue };
        if has_exr_extension(path) {
            continue; // OpenEXR depth tiles carry no stamp (docs/scale-out.md); checked by size.
        }
        match read_depth_stamp(path)? {
            None => {
                return Err(format!(
                    "{} has no tile stamp but its image {} has: it is not the table lrt-depth --tiles wrote with that tile; rerun tile {}",
                    path.display(),
                    t.path.display(),
                    stamp.tile
                ));
            }
            Some(d) if d != *stamp => {
                return Err(format!(
                    "{} is tile {} of {}x{} of frame {} of render {}, but its image {} is tile {} of {}x{} of frame {} of render {}: rerun tile {}",
                    path.display(),
                    d.tile,
                    d.tiles.0,
                    d.tiles.1,
                    d.frame,
                    d.render,
                    t.path.display(),
                    stamp.tile,
                    stamp.tiles.0,
                    stamp.tiles.1,
                    stamp.frame,
                    stamp.render,
                    stamp.tile
                ));
            }
            Some(_) => {}
        }
    }
    Ok(())
}

/// Tiles of `lrt-depth --tiles` must all be of one render, one frame and one tiling, each
/// index once and none missing; a missing one is named so that its task is rerun.
fn check_stamps(tiles: &[Tile]) -> Result<(), String> {
    let Some(first) = tiles.iter().find_map(|t| t.stamp.as_ref().map(|s| (t, s))) else { return Ok(()) };
    let (first_tile, stamp) = first;
    let mut seen: Vec<Option<&Path>> = vec![None; (stamp.tiles.0 * stamp.tiles.1) as usize];
    for t in tiles {
        let Some(s) = &t.stamp else {
            return Err(format!(
                "{} has no tile stamp but {} has: mix no plain crops with tiles of lrt-depth --tiles",
                t.path.display(),
                first_tile.path.display()
            ));
        };
        if s.render != stamp.render {
            return Err(format!(
                "{} is of another render than {} (render {} against {}): the scene, an archive or a setting differs",
                t.path.display(),
                first_tile.path.display(),
                s.render,
                stamp.render
            ));
        }
        if s.frame != stamp.frame {
            return Err(format!(
                "{} is a tile of frame {}, {} of frame {}: merge one frame at a time",
                t.path.display(),
                s.frame,
                first_tile.path.display(),
                stamp.frame
            ));
        }
        if s.tiles != stamp.tiles {
            return Err(format!(
                "{} is one of {}x{} tiles, {} one of {}x{}: one tiling per frame",
                t.path.display(),
                s.tiles.0,
                s.tiles.1,
                first_tile.path.display(),
                stamp.tiles.0,
                stamp.tiles.1
            ));
        }
        if let Some(other) = seen[s.tile as usize].replace(&t.path) {
            return Err(format!("{} and {} are both tile {}", other.display(), t.path.display(), s.tile));
        }
    }
    let missing: Vec<String> =
        seen.iter().enumerate().filter(|(_, p)| p.is_none()).map(|(k, _)| k.to_string()).collect();
    if !missing.is_empty() {
        return Err(format!(
            "tile{} {} of the {}x{} tiles of frame {} {} missing: rerun {} (lrt-depth --tile K, or sbatch --array with {})",
            if missing.len() > 1 { "s" } else { "" },
            missing.join(", "),
            stamp.tiles.0,
            stamp.tiles.1,
            stamp.frame,
            if missing.len() > 1 { "are" } else { "is" },
            if missing.len() > 1 { "them" } else { "it" },
            if missing.len() > 1 { "their array indices" } else { "its array index" },
        ));
    }
    Ok(())
}

fn read_tile(path: &Path) -> Result<Tile, String> {
    let image = read()
        .no_deep_data()
        .largest_resolution_level()
        .all_channels()
        .first_valid_layer()
        .all_attributes()
        .from_file(path)
        .map_err(|e| format!("{}: cannot read it as OpenEXR: {e}", path.display()))?;
    let frame = image.attributes.display_window;
    let layer = &image.layer_data;
    let data = IntegerBounds::new(layer.attributes.layer_position, layer.size);
    // Window arithmetic in i64: a hostile header cannot overflow it.
    let window = |b: &IntegerBounds| {
        let (x, y) = (i64::from(b.position.x()), i64::from(b.position.y()));
        (x, y, x + b.size.width() as i64, y + b.size.height() as i64)
    };
    let (fx0, fy0, fx1, fy1) = window(&frame);
    let (dx0, dy0, dx1, dy1) = window(&data);
    if dx0 < fx0 || dy0 < fy0 || dx1 > fx1 || dy1 > fy1 {
        return Err(format!(
            "{}: its data window {:?}+{:?} is not inside its display window {:?}+{:?}",
            path.display(),
            data.position,
            data.size,
            frame.position,
            frame.size
        ));
    }
    let pixels = frame.size.width().checked_mul(frame.size.height()).filter(|&n| n <= MAX_PIXELS);
    if pixels.is_none() {
        return Err(format!(
            "{}: a {}x{} frame is more than the {MAX_PIXELS} pixels lrt-merge handles",
            path.display(),
            frame.size.width(),
            frame.size.height()
        ));
    }
    let mut channels = Vec::new();
    for channel in &layer.channel_data.list {
        if channel.sampling != Vec2(1, 1) {
            return Err(format!(
                "{}: channel {} is subsampled; tiles have full-resolution channels",
                path.display(),
                channel.name
            ));
        }
        let (kind, bits) = match &channel.sample_data {
            FlatSamples::F16(v) => (SampleType::F16, v.iter().map(|s| u32::from(s.to_bits())).collect()),
            FlatSamples::F32(v) => (SampleType::F32, v.iter().map(|s| s.to_bits()).collect()),
            FlatSamples::U32(v) => (SampleType::U32, v.clone()),
        };
        channels.push((channel.name.clone(), kind, bits));
    }
    Ok(Tile {
        path: path.to_path_buf(),
        frame,
        x: (dx0 - fx0) as usize,
        y: (dy0 - fy0) as usize,
        width: layer.size.width(),
        height: layer.size.height(),
        channels,
        stamp: read_stamp(path, &layer.attributes)?,
    })
}

/// Which tile owns each frame pixel: the first tile (in command-line order) that covers it.
fn owners(tiles: &[Tile], width: usize, height: usize) -> Vec<Option<u32>> {
    let mut owner = vec![None; width * height];
    for (i, t) in tiles.iter().enumerate() {
        for y in t.y..t.y + t.height {
            for slot in &mut owner[y * width + t.x..y * width + t.x + t.width] {
                slot.get_or_insert(i as u32);
            }
        }
    }
    owner
}

/// Writes tile `index`'s `values` (one per tile pixel) where it owns the frame pixel, and checks
/// that they equal the owner's where another tile owns it (tiles come in order, so the owner's
/// value is already there). `describe(owner, x, y)` names a disagreement.
fn place(
    full: &mut [u32],
    owner: &[Option<u32>],
    frame_width: usize,
    tile: &Tile,
    index: u32,
    values: &[u32],
    describe: impl Fn(u32, usize, usize) -> String,
) -> Result<(), String> {
    for ty in 0..tile.height {
        for tx in 0..tile.width {
            let (x, y) = (tile.x + tx, tile.y + ty);
            let at = y * frame_width + x;
            let value = values[ty * tile.width + tx];
            match owner[at] {
                Some(o) if o == index => full[at] = value,
                Some(o) if full[at] != value => return Err(describe(o, x, y)),
                _ => {}
            }
        }
    }
    Ok(())
}

fn merge(cli: &Cli) -> Result<String, String> {
    let tiles: Vec<Tile> = cli.tiles.iter().map(|p| read_tile(p)).collect::<Result<_, _>>()?;
    check_stamps(&tiles)?;
    check_depth_stamps(&tiles, &cli.tile_depth)?;
    let first = &tiles[0];
    let frame = first.frame;
    let (width, height) = (frame.size.width(), frame.size.height());
    let names: Vec<(&Text, SampleType)> = first.channels.iter().map(|(n, k, _)| (n, *k)).collect();
    for t in &tiles[1..] {
        if t.frame != frame {
            return Err(format!(
                "{} is a tile of a {}x{} frame at {:?}, {} of a {}x{} frame at {:?}: they are not parts of one frame",
                first.path.display(),
                width,
                height,
                frame.position,
                t.path.display(),
                t.frame.size.width(),
                t.frame.size.height(),
                t.frame.position
            ));
        }
        let these: Vec<(&Text, SampleType)> = t.channels.iter().map(|(n, k, _)| (n, *k)).collect();
        if these != names {
            return Err(format!(
                "{} has channels {:?}, {} has {:?}: tiles of one frame have the same channels",
                first.path.display(),
                names,
                t.path.display(),
                these
            ));
        }
    }

    // Coverage first: a missing tile is the likeliest mistake, so it is reported before any
    // disagreement between overlapping tiles.
    let pixels = width * height;
    let owner = owners(&tiles, width, height);
    if let Some(first_gap) = owner.iter().position(Option::is_none) {
        let count = owner.iter().filter(|o| o.is_none()).count();
        let (x, y) = (first_gap % width, first_gap / width);
        return Err(format!(
            "{count} pixels of the {width}x{height} frame are in no tile (the first at ({x}, {y})): a tile is missing"
        ));
    }

    // The image, channel by channel, as bit patterns.
    let mut merged: Vec<Vec<u32>> = vec![vec![0; pixels]; names.len()];
    for (c, (name, _)) in names.iter().enumerate() {
        for (i, t) in tiles.iter().enumerate() {
            let describe = |o: u32, x: usize, y: usize| {
                format!(
                    "{} and {} overlap at pixel ({x}, {y}) with different {name} values: they are not tiles of one render",
                    tiles[o as usize].path.display(),
                    t.path.display()
                )
            };
            place(&mut merged[c], &owner, width, t, i as u32, &t.channels[c].2, describe)?;
        }
    }

    // The depth table, when asked for (written only once the image is encoded too).
    let mut merged_depth = None;
    if let Some(depth_path) = &cli.depth {
        let mut bits = vec![f32::INFINITY.to_bits(); pixels];
        for (i, (t, path)) in tiles.iter().zip(&cli.tile_depth).enumerate() {
            let table = DepthTable::read(path).map_err(|e| e.to_string())?;
            if (table.width() as usize, table.height() as usize) != (t.width, t.height) {
                return Err(format!(
                    "{} is {}x{} but its tile {} is {}x{}",
                    path.display(),
                    table.width(),
                    table.height(),
                    t.path.display(),
                    t.width,
                    t.height
                ));
            }
            let tile_bits: Vec<u32> = table.values().iter().map(|v| v.to_bits()).collect();
            let describe = |o: u32, x: usize, y: usize| {
                format!(
                    "{} and {} overlap at pixel ({x}, {y}) with different depths",
                    cli.tile_depth[o as usize].display(),
                    path.display()
                )
            };
            place(&mut bits, &owner, width, t, i as u32, &tile_bits, describe)?;
        }
        let values: Vec<f32> = bits.into_iter().map(f32::from_bits).collect();
        let w = u32::try_from(width).map_err(|_| "the frame is too wide for a depth table")?;
        let h = u32::try_from(height).map_err(|_| "the frame is too tall for a depth table")?;
        merged_depth = Some((depth_path, DepthTable::new(w, h, values).map_err(|e| e.to_string())?));
    }

    // The image: the whole frame as the data window.
    let channels: Vec<AnyChannel<FlatSamples>> = names
        .iter()
        .zip(merged)
        .map(|((name, kind), bits)| {
            let samples = match kind {
                SampleType::F16 => FlatSamples::F16(
                    bits.into_iter().map(|b| exr::prelude::f16::from_bits(b as u16)).collect(),
                ),
                SampleType::F32 => FlatSamples::F32(bits.into_iter().map(f32::from_bits).collect()),
                SampleType::U32 => FlatSamples::U32(bits),
            };
            AnyChannel::new((*name).clone(), samples)
        })
        .collect();
    let layer = Layer::new(
        frame.size,
        LayerAttributes { layer_position: frame.position, ..LayerAttributes::default() },
        Encoding::SMALL_LOSSLESS,
        AnyChannels::sort(SmallVec::from_vec(channels)),
    );
    let mut image = Image::from_layer(layer);
    image.attributes.display_window = frame;
    let mut bytes = std::io::Cursor::new(Vec::new());
    image.write().to_buffered(&mut bytes).map_err(|e| format!("{}: {e}", cli.output.display()))?;
    // In name order, as lrt-depth writes its images, so the merge is the full render byte for byte.
    let mut bytes = bytes.into_inner();
    sidecar::sort_exr_header_attributes(&mut bytes);
    let mut depth_summary = String::new();
    if let Some((depth_path, table)) = merged_depth {
        table.write(depth_path).map_err(|e| e.to_string())?;
        depth_summary = format!(", {}", depth_path.display());
    }
    raytracer::output::write_atomically(&cli.output, &bytes).map_err(|e| e.to_string())?;
    Ok(format!(
        "merged {} tiles into {} ({width}x{height}){depth_summary}",
        tiles.len(),
        cli.output.display()
    ))
}
