//! Every RIB file of the corpus (`../shared/rib-corpus`) that parses renders without a panic and
//! without a non-finite value in the image or the depth table, small and at one sample per pixel.
//! Files above 64 KiB are left to `cargo run --release -p raytracer --example corpus_smoke`.

use raytracer::render::{RenderOptions, render};
use std::path::PathBuf;

#[test]
fn corpus_scenes_render_without_invalid_values() {
    let root = PathBuf::from(concat!(env!("CARGO_MANIFEST_DIR"), "/../../../shared/rib-corpus"));
    let mut files: Vec<PathBuf> = std::fs::read_dir(&root)
        .unwrap()
        .filter_map(|d| d.ok())
        .flat_map(|d| std::fs::read_dir(d.path()).into_iter().flatten().filter_map(|f| f.ok()))
        .map(|f| f.path())
        .filter(|p| p.extension().is_some_and(|e| e == "rib" || e == "gz"))
        .filter(|p| std::fs::metadata(p).map(|m| m.len() <= 64 * 1024).unwrap_or(false))
        .collect();
    files.sort();
    let mut rendered = 0;
    for path in &files {
        let Ok(loaded) = rib_parser::load_scene(path, &Default::default()) else { continue };
        let mut scene = loaded.scene;
        let (w, h) = (scene.camera.x_resolution, scene.camera.y_resolution);
        let k = (f64::from(w.max(h)) / 32.0).max(1.0);
        scene.camera.x_resolution = ((f64::from(w) / k).round() as u32).max(1);
        scene.camera.y_resolution = ((f64::from(h) / k).round() as u32).max(1);
        let out = render(
            &scene,
            &RenderOptions { spp: Some(1), depth: true, threads: Some(2), ..Default::default() },
        )
        .unwrap_or_else(|e| panic!("{}: {e}", path.display()));
        assert!(out.image.pixels.iter().flatten().all(|v| v.is_finite()), "{}", path.display());
        assert!(out.depth.unwrap().values.iter().all(|v| *v >= 0.0), "{}", path.display());
        rendered += 1;
    }
    assert!(rendered >= 40, "only {rendered} corpus files rendered");
}
