//! `lrt-depth SCENE.rib`: render the image(s) the RIB's `Display`s name and the depth table it
//! requests.
//!
//! Outputs: every `Display` whose mode holds colour (`rgb`, `rgba`) is written under its name, in
//! the format of its extension or driver (`-o` replaces them with one file). A name the format
//! cannot be told from (a `framebuffer` display, say) gets `.tif` appended. Without any
//! `Display`, the image goes to `<scene name>.tif` (`ri.tif` for standard input). The depth table
//! goes where `Option "lrt" "depthfile"`, a `depthtable` display or `--depth` says, as text or
//! as OpenEXR for a `.exr` name. Everything is written relative to the current directory.

use crate::args::{Settings, Tiling};
use crate::check;
use depth_remap::DepthTable;
use raytracer::render::{ProgressFn, RenderOptions, RenderOutput, RenderStats, render};
use rib_parser::scene::Scene;
use rib_parser::{Diagnostic, DiagnosticKind, Severity};
use std::io::{IsTerminal, Write};
use std::path::{Path, PathBuf};
use std::process::ExitCode;
use std::sync::Arc;
use std::time::{Duration, Instant};

/// One image file to write.
#[derive(Clone, Debug, PartialEq)]
pub struct ImageOutput {
    pub path: PathBuf,
    pub driver: String,
    pub alpha: bool,
}

/// The image files a run writes, and notes about displays left out.
pub fn image_outputs(
    scene: &Scene,
    settings: &Settings,
) -> (Vec<ImageOutput>, Vec<(Option<rib_parser::scene::FileLoc>, String)>) {
    let mut notes = Vec::new();
    let primary_alpha = scene.displays.iter().find(|d| !d.secondary).is_some_and(|d| d.mode.contains('a'));
    if let Some(path) = &settings.output {
        return (
            vec![ImageOutput { path: path.clone(), driver: "file".into(), alpha: primary_alpha }],
            notes,
        );
    }
    let mut outputs = Vec::new();
    for d in &scene.displays {
        if d.driver.eq_ignore_ascii_case("depthtable") {
            continue;
        }
        let mode = d.mode.to_ascii_lowercase();
        if !mode.contains("rgb") {
            notes.push((
                Some(d.loc.clone()),
                format!(
                    "display \"{}\" of mode \"{}\" is not written (only rgb and rgba images are)",
                    d.name, d.mode
                ),
            ));
            continue;
        }
        let mut path = PathBuf::from(&d.name);
        if raytracer::output::Format::for_output(&path, &d.driver).is_none() {
            let renamed = PathBuf::from(format!("{}.tif", d.name));
            notes.push((
                Some(d.loc.clone()),
                format!(
                    "display \"{}\" (driver \"{}\") is written as the TIFF file {}",
                    d.name,
                    d.driver,
                    renamed.display()
                ),
            ));
            path = renamed;
        }
        outputs.push(ImageOutput { path, driver: d.driver.clone(), alpha: mode.contains('a') });
    }
    if outputs.is_empty() {
        let stem = if settings.scene.as_os_str() == "-" {
            "ri".to_string()
        } else {
            settings
                .scene
                .file_stem()
                .map(|s| s.to_string_lossy().into_owned())
                .unwrap_or_else(|| "ri".into())
        };
        let path = PathBuf::from(format!("{stem}.tif"));
        notes.push((None, format!("the scene names no image display: writing {}", path.display())));
        outputs.push(ImageOutput { path, driver: "file".into(), alpha: true });
    }
    (outputs, notes)
}

fn warn(loc: Option<rib_parser::scene::FileLoc>, message: String, sources: &rib_parser::SourceMap) {
    let d = Diagnostic::new(Severity::Warning, DiagnosticKind::Unsupported, loc, message);
    eprint!("{}", d.render(sources));
    if !d.render(sources).ends_with('\n') {
        eprintln!();
    }
}

fn fail(message: impl std::fmt::Display) -> ExitCode {
    eprintln!("lrt-depth: error: {message}");
    ExitCode::from(1)
}

/// A progress bar on standard error when it is a terminal.
fn progress(settings: &Settings) -> Option<(indicatif::ProgressBar, ProgressFn)> {
    if settings.quiet || !std::io::stderr().is_terminal() {
        return None;
    }
    let bar = indicatif::ProgressBar::new(1);
    bar.set_style(
        indicatif::ProgressStyle::with_template(
            "{spinner} rendering [{bar:40}] {percent:>3}% {elapsed_precise} (eta {eta})",
        )
        .unwrap_or_else(|_| indicatif::ProgressStyle::default_bar())
        .progress_chars("=> "),
    );
    let b = bar.clone();
    let f: ProgressFn = Arc::new(move |done, total| {
        b.set_length(total);
        b.set_position(done);
    });
    Some((bar, f))
}

/// Renders the frames and tile the settings' work share names (`--frames`, `--tiles`, the
/// Slurm array index), one after another; stops at the first that fails.
pub fn run(settings: &Settings) -> ExitCode {
    let Some(frames) = &settings.share.frames else { return run_one(settings) };
    for &frame in frames {
        let one = Settings { frame: Some(frame), ..settings.clone() };
        let code = run_one(&one);
        if code != ExitCode::SUCCESS {
            return code;
        }
    }
    ExitCode::SUCCESS
}

/// Text attributes of a tile's OpenEXR file, so that `lrt-merge` joins only the tiles of one
/// render: a fingerprint of everything read (every RIB source, with its name) and of the
/// flags that change pixels, the frame, and the tiling with this tile's index.
pub fn tile_stamp(
    sources: &rib_parser::SourceMap,
    settings: &Settings,
    tiling: Tiling,
    tile: u32,
) -> Vec<(String, String)> {
    // FNV-1a, 64 bits: the same on every machine and every build of this version.
    let mut hash = 0xcbf2_9ce4_8422_2325u64;
    let mut feed = |bytes: &[u8]| {
        for &b in bytes {
            hash = (hash ^ u64::from(b)).wrapping_mul(0x0000_0100_0000_01b3);
        }
        // A separator, so that ("ab", "c") and ("a", "bc") differ.
        hash = (hash ^ 0xff).wrapping_mul(0x0000_0100_0000_01b3);
    };
    feed(env!("CARGO_PKG_VERSION").as_bytes());
    for file in sources.files() {
        feed(file.name.as_bytes());
        feed(&file.bytes);
    }
    let flags = format!(
        "spp {:?} time {:?} target {:?}",
        settings.spp.map(|n| n.get()),
        settings.time_budget,
        settings.target_error
    );
    feed(flags.as_bytes());
    vec![
        (STAMP_RENDER.into(), format!("{hash:016x}")),
        (STAMP_FRAME.into(), settings.frame.map_or_else(|| "-".into(), |f| f.to_string())),
        (STAMP_TILES.into(), format!("{},{}", tiling.nx, tiling.ny)),
        (STAMP_TILE.into(), tile.to_string()),
    ]
}

/// The comment line a tile's text depth table carries after its header (docs/scale-out.md),
/// so that `lrt-merge` can tell a table of another render, frame or tile from its image's:
/// `# lrt-tile render=H frame=F tiles=NX,NY tile=K`. Readers skip it as a comment.
pub const DEPTH_STAMP_PREFIX: &str = "# lrt-tile";

/// The tile stamp as the depth table's comment line (without the newline).
pub fn depth_stamp_line(stamp: &[(String, String)]) -> String {
    let mut line = DEPTH_STAMP_PREFIX.to_string();
    for (key, value) in stamp {
        line.push(' ');
        line.push_str(key.strip_prefix("lrt.").unwrap_or(key));
        line.push('=');
        line.push_str(value);
    }
    line
}

fn is_exr_name(path: &Path) -> bool {
    path.extension().is_some_and(|e| e.eq_ignore_ascii_case("exr"))
}

/// Writes a tile's text depth table with its stamp line after the header, atomically.
fn write_stamped_table(table: &DepthTable, path: &Path, stamp: &[(String, String)]) -> Result<(), String> {
    let text = table.to_text(0);
    let header_end = text.iter().position(|&b| b == b'\n').map_or(0, |n| n + 1);
    let line = depth_stamp_line(stamp);
    depth_remap::table::write_atomically(path, |file| {
        file.write_all(&text[..header_end])?;
        file.write_all(line.as_bytes())?;
        file.write_all(b"\n")?;
        file.write_all(&text[header_end..])
    })
    .map_err(|e| format!("{}: {e}", path.display()))
}

/// Names of the tile stamp's attributes (docs/scale-out.md); `lrt-merge` reads them.
pub const STAMP_RENDER: &str = "lrt.render";
pub const STAMP_FRAME: &str = "lrt.frame";
pub const STAMP_TILES: &str = "lrt.tiles";
pub const STAMP_TILE: &str = "lrt.tile";

/// An output name with the frame and tile of this run in it (docs/scale-out.md): `#f` becomes
/// the frame number (at least 4 digits), `#t` the tile index (at least 3 digits); a name
/// without the token gets `.NNNN` or `.tileKKK` before its extension. `exr` gives the name
/// the `.exr` extension (tiles are OpenEXR, which records their place in the frame).
pub fn name_for(path: &Path, frame: Option<i32>, tile: Option<u32>, exr: bool) -> PathBuf {
    let text = path.to_string_lossy().into_owned();
    let (dir, file) = match text.rfind('/') {
        Some(i) => (&text[..=i], &text[i + 1..]),
        None => ("", text.as_str()),
    };
    let (mut stem, mut ext) = match file.rfind('.') {
        Some(i) if i > 0 => (file[..i].to_string(), file[i..].to_string()),
        _ => (file.to_string(), String::new()),
    };
    if let Some(f) = frame {
        let number = format!("{f:04}");
        if stem.contains("#f") || ext.contains("#f") {
            stem = stem.replace("#f", &number);
            ext = ext.replace("#f", &number);
        } else {
            stem = format!("{stem}.{number}");
        }
    }
    if let Some(t) = tile {
        let number = format!("{t:03}");
        if stem.contains("#t") || ext.contains("#t") {
            stem = stem.replace("#t", &number);
            ext = ext.replace("#t", &number);
        } else {
            stem = format!("{stem}.tile{number}");
        }
    }
    if exr && !ext.eq_ignore_ascii_case(".exr") {
        ext = ".exr".into();
    }
    PathBuf::from(format!("{dir}{stem}{ext}"))
}

fn run_one(settings: &Settings) -> ExitCode {
    let parse_start = Instant::now();
    let tiled = settings.share.tile;
    let settings = &Settings { crop: tiled.map(|(t, k)| t.crop(k)).or(settings.crop), ..settings.clone() };
    let mut loaded = match check::load(settings) {
        Ok(l) => l,
        Err(code) => return code,
    };
    let time_parse = parse_start.elapsed();
    // This run's frame and tile go into every output name.
    let frame = settings.share.frames.as_ref().and(settings.frame);
    let tile = tiled.map(|(_, k)| k);
    if let Some(request) = &mut loaded.scene.depth_request {
        request.path = name_for(&request.path, frame, tile, false);
    }
    let scene = &loaded.scene;
    let (mut outputs, notes) = image_outputs(scene, settings);
    if tile.is_some() {
        // Tiles are OpenEXR: the displays that are, or else the first display as OpenEXR.
        let is_exr = |o: &ImageOutput| {
            raytracer::output::Format::for_output(&o.path, &o.driver) == Some(raytracer::output::Format::Exr)
        };
        if outputs.iter().any(is_exr) {
            outputs.retain(is_exr);
        } else {
            outputs.truncate(1);
        }
    }
    if frame.is_some() || tile.is_some() {
        for o in &mut outputs {
            o.path = name_for(&o.path, frame, tile, tile.is_some());
        }
    }
    let stamp = tiled.map(|(t, k)| tile_stamp(&loaded.sources, settings, t, k));
    if !settings.quiet {
        for (loc, message) in notes {
            warn(loc, message, &loaded.sources);
        }
    }
    let bar = progress(settings);
    let options = RenderOptions {
        threads: Some(settings.threads.get()),
        spp: settings.spp.map(|n| n.get()),
        seed: 0,
        integrator: None,
        depth: scene.depth_request.is_some(),
        // The sidecar's light layers go with every depth table (docs/sidecar.md).
        layers: scene.depth_request.is_some(),
        progress: bar.as_ref().map(|(_, f)| f.clone()),
        time_budget: settings.time_budget,
        target_error: settings.target_error,
        wavefront: settings.wavefront,
    };
    let out = match render(scene, &options) {
        Ok(out) => out,
        Err(e) => {
            if let Some((bar, _)) = &bar {
                bar.finish_and_clear();
            }
            return fail(format!("{}: {e}", scene.source));
        }
    };
    if let Some((bar, _)) = &bar {
        bar.finish_and_clear();
    }
    if !settings.quiet {
        for w in &out.warnings {
            warn(w.loc.clone(), w.message.clone(), &loaded.sources);
        }
    }
    let write_start = Instant::now();
    let code = write_outputs(scene, &out, &outputs, settings, &loaded.sources, stamp.as_deref());
    if settings.stats {
        print_stats(&out.stats, time_parse, write_start.elapsed(), scene);
        check::print_superseded(&loaded);
    }
    code
}

fn write_outputs(
    scene: &Scene,
    out: &RenderOutput,
    outputs: &[ImageOutput],
    settings: &Settings,
    sources: &rib_parser::SourceMap,
    stamp: Option<&[(String, String)]>,
) -> ExitCode {
    // The depth table first: a tile's image is what marks it done (a task killed in between
    // leaves no image under its final name, and its rerun rewrites both).
    if let Some(code) = write_depth(scene, out, settings, sources, stamp) {
        return code;
    }
    for o in outputs {
        let output_settings = raytracer::output::OutputSettings {
            exposure: scene.render.exposure,
            quantize: scene.render.quantize,
            alpha: o.alpha,
        };
        let written = match stamp {
            Some(stamp) => raytracer::output::write_stamped_exr(&o.path, &out.image, &output_settings, stamp)
                .map(|()| raytracer::output::OutputNotes::default()),
            None => raytracer::output::write_image(&o.path, &o.driver, &out.image, &output_settings),
        };
        match written {
            Ok(notes) => {
                if !settings.quiet {
                    for n in notes.notes {
                        warn(None, format!("{}: {n}", o.path.display()), sources);
                    }
                    println!("wrote {} ({}x{})", o.path.display(), out.image.width, out.image.height);
                }
            }
            Err(e) => return fail(e),
        }
    }
    ExitCode::SUCCESS
}

/// Writes the depth table and its sidecar; `Some(exit code)` on failure.
fn write_depth(
    scene: &Scene,
    out: &RenderOutput,
    settings: &Settings,
    sources: &rib_parser::SourceMap,
    stamp: Option<&[(String, String)]>,
) -> Option<ExitCode> {
    let fail = |e: &dyn std::fmt::Display| Some(fail(e));
    if let (Some(request), Some(depth)) = (&scene.depth_request, &out.depth) {
        let table = match depth.to_table() {
            Ok(t) => t,
            Err(e) => return fail(&e),
        };
        let written = match stamp {
            Some(stamp) if !is_exr_name(&request.path) => write_stamped_table(&table, &request.path, stamp),
            _ => table.write(&request.path).map_err(|e| e.to_string()),
        };
        if let Err(e) = written {
            return fail(&e);
        }
        if !settings.quiet {
            println!("wrote {} ({}x{} depth table)", request.path.display(), depth.width, depth.height);
        }
        let layers_path = sidecar::SidecarPaths::for_depth(&request.path).layers;
        match &out.layers {
            Some(layers) => {
                // The fingerprint of exactly the values written, as the viewer will read them.
                let layers = sidecar::LightLayers {
                    depth_fingerprint: sidecar::depth_fingerprint(table.values()),
                    ..layers.clone()
                };
                if let Err(e) = sidecar::write_layers(&layers, &layers_path) {
                    return fail(&e);
                }
                if !settings.quiet {
                    println!(
                        "wrote {} ({} light layers for {} lights)",
                        layers_path.display(),
                        layers.light.len(),
                        layers.lights.len()
                    );
                }
                if let Some(probes) = &out.probes {
                    let probes_path = sidecar::SidecarPaths::for_depth(&request.path).probes;
                    let probes =
                        sidecar::ProbeGrid { depth_fingerprint: layers.depth_fingerprint, ..probes.clone() };
                    if let Err(e) = sidecar::write_probes(&probes, &probes_path) {
                        return fail(&e);
                    }
                    if !settings.quiet {
                        let [x, y, z] = probes.counts;
                        println!("wrote {} ({x}x{y}x{z} irradiance probes)", probes_path.display());
                    }
                }
                if let Some(reflections) = &out.reflections {
                    let path = sidecar::SidecarPaths::for_depth(&request.path).reflections;
                    let reflections = sidecar::ReflectionProbes {
                        depth_fingerprint: layers.depth_fingerprint,
                        ..reflections.clone()
                    };
                    if let Err(e) = sidecar::write_reflections(&reflections, &path) {
                        return fail(&e);
                    }
                    if !settings.quiet {
                        let [x, y, z] = reflections.counts;
                        let t = sidecar::REFLECTION_TEXELS;
                        println!(
                            "wrote {} ({x}x{y}x{z} reflection probes, {t}x{t} texels, {} roughness levels)",
                            path.display(),
                            sidecar::REFLECTION_LEVELS
                        );
                    }
                }
                let caustics_path = sidecar::SidecarPaths::for_depth(&request.path).caustics;
                match &out.caustics {
                    Some(caustics) => {
                        let caustics = sidecar::CausticPhotons {
                            depth_fingerprint: layers.depth_fingerprint,
                            ..caustics.clone()
                        };
                        if let Err(e) = sidecar::write_caustics(&caustics, &caustics_path) {
                            return fail(&e);
                        }
                        if !settings.quiet {
                            println!(
                                "wrote {} ({} caustic photons, {} path segments)",
                                caustics_path.display(),
                                caustics.photons.len(),
                                caustics.segments.len()
                            );
                        }
                    }
                    // A render without caustics leaves no caustics file of an earlier one behind.
                    None => {
                        if caustics_path.exists()
                            && let Err(e) = std::fs::remove_file(&caustics_path)
                        {
                            return fail(&format!("{}: {e}", caustics_path.display()));
                        }
                    }
                }
            }
            None => {
                if !settings.quiet {
                    warn(
                        None,
                        format!(
                            "{}: not written: light layers cover full frames rendered in one pass (no --crop, --time, --target-error or progressive passes)",
                            layers_path.display()
                        ),
                        sources,
                    );
                }
            }
        }
    }
    None
}

fn seconds(d: Duration) -> String {
    format!("{:.3} s", d.as_secs_f64())
}

fn print_stats(s: &RenderStats, parse: Duration, write: Duration, scene: &Scene) {
    let w = &s.world;
    println!(
        "stats: integrator {}, {} samples per pixel, {}x{} pixels, {} threads",
        s.integrator, s.samples_per_pixel, s.width, s.height, s.threads
    );
    println!(
        "stats: geometry: {} triangles, {} exact quadrics, {} bottom-level BVHs, {} instances{}",
        w.triangles,
        w.quadrics,
        w.blases,
        w.instances,
        if w.top_level { " (two-level)" } else { " (one level: no top-level BVH needed)" }
    );
    println!(
        "stats: BVH: {} nodes, {:.2} MiB with triangles, built in {}",
        w.bvh_nodes,
        w.bvh_bytes as f64 / (1024.0 * 1024.0),
        seconds(w.bvh_build_time)
    );
    println!("stats: lights: {} ({} area)", w.lights, w.area_lights);
    for line in &s.integrator_stats {
        println!("stats: {}: {line}", s.integrator);
    }
    println!(
        "stats: time: parse {}, build {}, prepare {}, render {}, depth {}, probes {}, reflections {}, write {}",
        seconds(parse),
        seconds(s.time_build),
        seconds(s.time_prepare),
        seconds(s.time_render),
        seconds(s.time_depth),
        seconds(s.time_probes),
        seconds(s.time_reflections),
        seconds(write)
    );
    println!(
        "stats: rays: {} camera, {} bounce, {} shadow, {} total; {:.3} M rays/s",
        s.rays.camera,
        s.rays.bounce,
        s.rays.shadow,
        s.rays.total(),
        s.rays_per_second() / 1e6
    );
    match &scene.depth_request {
        Some(d) => println!("stats: depth table: {} rays for {}", s.depth_rays, d.path.display()),
        None => println!("stats: skipped: depth table (none requested: no depth rays traced)"),
    }
    for (what, n) in &s.skipped {
        println!("stats: skipped: {n} x {what}");
    }
}
