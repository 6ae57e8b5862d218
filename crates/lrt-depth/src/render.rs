//! `lrt-depth SCENE.rib`: render the image(s) the RIB's `Display`s name and the depth table it
//! requests.
//!
//! Outputs: every `Display` whose mode holds colour (`rgb`, `rgba`) is written under its name, in
//! the format of its extension or driver (`-o` replaces them with one file). A name the format
//! cannot be told from (a `framebuffer` display, say) gets `.tif` appended. Without any
//! `Display`, the image goes to `<scene name>.tif` (`ri.tif` for standard input). The depth table
//! goes where `Option "lrt" "depthfile"`, a `depthtable` display or `--depth` says, as text or
//! as OpenEXR for a `.exr` name. Everything is written relative to the current directory.

use crate::args::Settings;
use crate::check;
use raytracer::render::{ProgressFn, RenderOptions, RenderOutput, RenderStats, render};
use rib_parser::scene::Scene;
use rib_parser::{Diagnostic, DiagnosticKind, Severity};
use std::io::IsTerminal;
use std::path::PathBuf;
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

pub fn run(settings: &Settings) -> ExitCode {
    let parse_start = Instant::now();
    let loaded = match check::load(settings) {
        Ok(l) => l,
        Err(code) => return code,
    };
    let time_parse = parse_start.elapsed();
    let scene = &loaded.scene;
    let (outputs, notes) = image_outputs(scene, settings);
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
    let code = write_outputs(scene, &out, &outputs, settings, &loaded.sources);
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
) -> ExitCode {
    for o in outputs {
        let output_settings = raytracer::output::OutputSettings {
            exposure: scene.render.exposure,
            quantize: scene.render.quantize,
            alpha: o.alpha,
        };
        match raytracer::output::write_image(&o.path, &o.driver, &out.image, &output_settings) {
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
    if let (Some(request), Some(depth)) = (&scene.depth_request, &out.depth) {
        let table = match depth.to_table() {
            Ok(t) => t,
            Err(e) => return fail(e),
        };
        if let Err(e) = table.write(&request.path) {
            return fail(e);
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
                    return fail(e);
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
                        return fail(e);
                    }
                    if !settings.quiet {
                        let [x, y, z] = probes.counts;
                        println!("wrote {} ({x}x{y}x{z} irradiance probes)", probes_path.display());
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
    ExitCode::SUCCESS
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
        "stats: time: parse {}, build {}, prepare {}, render {}, depth {}, probes {}, write {}",
        seconds(parse),
        seconds(s.time_build),
        seconds(s.time_prepare),
        seconds(s.time_render),
        seconds(s.time_depth),
        seconds(s.time_probes),
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
