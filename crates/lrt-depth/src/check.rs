//! `lrt-depth --check`: parse and build the scene, print a one-line summary.

use crate::args::Settings;
use rib_parser::scene::{DepthRequest, DepthRequestSource};
use rib_parser::summary::SceneCounts;
use rib_parser::{Diagnostic, DiagnosticKind, Severity};
use std::process::ExitCode;
use tessellate::{SceneMeshes, Tolerance, tessellate_scene};

/// The tessellation `--check` counts triangles at: the default of
/// [`tessellate::Tolerance`] (0.1 % of each shape's size).
fn check_tolerance() -> Tolerance {
    Tolerance::default()
}

/// Loads the scene named by the settings. Prints diagnostics (warnings unless `--quiet`) to
/// standard error; on failure returns exit code 1.
pub fn load(settings: &Settings) -> Result<rib_parser::Loaded, ExitCode> {
    let options = rib_parser::LoadOptions { frame: settings.frame, ..Default::default() };
    match rib_parser::load_scene(&settings.scene, &options) {
        Ok(mut loaded) => {
            if !settings.quiet {
                eprint!("{}", loaded.render_warnings());
            }
            if let Some(path) = &settings.depth {
                loaded.scene.depth_request = Some(DepthRequest {
                    path: path.clone(),
                    source: DepthRequestSource::CommandLine,
                    loc: None,
                });
            }
            if let Some(crop) = settings.crop {
                loaded.scene.camera.crop_window = crop;
            }
            if let Some(max_size) = settings.max_size {
                shrink_format(&mut loaded.scene.camera, max_size.get());
            }
            Ok(loaded)
        }
        Err(e) => {
            eprint!("{}", e.render());
            Err(ExitCode::from(1))
        }
    }
}

/// Scales the Format down so its longest side is at most `max_size`, pinning the frame aspect
/// ratio first so that rounding the resolution does not change what the camera sees.
fn shrink_format(camera: &mut depth_remap::CameraSettings, max_size: u32) {
    let longest = camera.x_resolution.max(camera.y_resolution);
    if longest <= max_size {
        return;
    }
    if camera.frame_aspect_ratio.is_none() {
        camera.frame_aspect_ratio =
            Some(f64::from(camera.x_resolution) * camera.pixel_aspect_ratio / f64::from(camera.y_resolution));
    }
    let scale = f64::from(max_size) / f64::from(longest);
    let shrink = |n: u32| ((f64::from(n) * scale).round() as u32).clamp(1, max_size);
    camera.x_resolution = shrink(camera.x_resolution);
    camera.y_resolution = shrink(camera.y_resolution);
}

/// The one-line summary: requests, shapes, lights, triangles after tessellation, warnings
/// (the parser's and the tessellation's).
pub fn summary_line(loaded: &rib_parser::Loaded, meshes: &SceneMeshes) -> String {
    let counts = SceneCounts::of(&loaded.scene);
    format!(
        "{}: ok: {} requests, {} shapes, {} lights, {} triangles, {} warnings",
        loaded.scene.source,
        loaded.requests,
        counts.total_shapes(),
        counts.lights,
        meshes.triangle_count(),
        loaded.diagnostics.warning_count() + meshes.skipped.len()
    )
}

pub fn run(settings: &Settings) -> ExitCode {
    let loaded = match load(settings) {
        Ok(l) => l,
        Err(code) => return code,
    };
    let meshes = tessellate_scene(&loaded.scene, &check_tolerance());
    if !settings.quiet {
        for skipped in &meshes.skipped {
            let d = Diagnostic::new(
                Severity::Warning,
                DiagnosticKind::Unsupported,
                Some(skipped.loc.clone()),
                format!("not tessellated: {}", skipped.error),
            );
            eprintln!("{}", d.render(&loaded.sources));
        }
        println!("{}", summary_line(&loaded, &meshes));
    }
    if settings.stats {
        print_stats(&loaded);
        println!(
            "stats: {} meshes, {} triangles at a tolerance of 0.1% of each shape's size",
            meshes.meshes.len(),
            meshes.triangle_count()
        );
    }
    ExitCode::SUCCESS
}

fn print_stats(loaded: &rib_parser::Loaded) {
    let scene = &loaded.scene;
    let counts = SceneCounts::of(scene);
    println!(
        "stats: {} bytes of RIB read from {} source(s)",
        loaded.bytes_read,
        loaded.sources.files().len()
    );
    if !loaded.frames.is_empty() {
        let list: Vec<String> = loaded.frames.iter().map(|f| f.number.to_string()).collect();
        println!(
            "stats: frames {} (using {})",
            list.join(" "),
            scene.frame.map_or("-".into(), |f| f.to_string())
        );
    }
    let mut kinds: std::collections::BTreeMap<&str, usize> = Default::default();
    for s in &scene.shapes {
        *kinds.entry(rib_parser::summary::shape_kind(&s.shape)).or_default() += 1;
    }
    for (k, v) in kinds {
        println!("stats: {v} {k}");
    }
    println!(
        "stats: {} objects, {} instances ({} instanced shapes), {} attribute states, {} area lights",
        counts.objects,
        counts.instances,
        counts.instanced_shapes,
        counts.attribute_states,
        counts.area_lights
    );
    match &scene.depth_request {
        Some(d) => println!("stats: depth table requested: {} ({:?})", d.path.display(), d.source),
        None => println!("stats: no depth table requested: no depth work will be done"),
    }
    print_superseded(loaded);
}

/// What ray-traced shadows make unnecessary: `MakeShadow` requests and the shadow-map frames
/// that render their depth images (skipped when no frame is asked for).
pub fn print_superseded(loaded: &rib_parser::Loaded) {
    let passes: Vec<String> =
        loaded.frames.iter().filter(|f| f.shadow_pass).map(|f| f.number.to_string()).collect();
    let made = loaded.superseded_shadow_maps.len();
    if made == 0 && passes.is_empty() {
        return;
    }
    println!(
        "stats: superseded by ray-traced shadows: {made} MakeShadow request(s), no maps made; shadow-map frames: {}",
        if passes.is_empty() { "none".to_string() } else { passes.join(" ") }
    );
}
