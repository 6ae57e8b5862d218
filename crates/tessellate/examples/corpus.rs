//! Tessellates every scene of the shared RIB corpus and prints, per file, the meshes,
//! triangles, open edges and time, then the totals (the figures in docs/tessellation.md).
//!
//! ```text
//! cargo run --release -p tessellate --example corpus -- [RELATIVE_TOLERANCE]
//! ```
//! The tolerance is relative to each shape's size (default 1e-3).

#[path = "../../rib-parser/tests/support/corpus_fs.rs"]
mod corpus_fs;

use corpus_fs::{CorpusFs, corpus_files};
use rib_parser::{LoadOptions, ReadOptions};
use std::sync::Arc;
use std::time::Instant;
use tessellate::{Tolerance, tessellate_scene};

fn main() {
    let relative: f64 = std::env::args().nth(1).and_then(|a| a.parse().ok()).unwrap_or(1e-3);
    let tol = Tolerance::relative(relative);
    let options = LoadOptions {
        read: ReadOptions { file_system: Arc::new(CorpusFs::new()), ..Default::default() },
        frame: None,
    };
    println!("tolerance: {relative} of each shape's size");
    println!("{:<70} {:>7} {:>7} {:>10} {:>9} {:>9}", "file", "meshes", "skipped", "triangles", "open", "ms");
    let (mut files, mut meshes, mut skipped, mut triangles, mut seconds) = (0, 0, 0, 0u64, 0.0);
    for (repo, file) in corpus_files() {
        let Ok(loaded) = rib_parser::load_scene(&CorpusFs::virtual_path(&repo, &file), &options) else {
            continue;
        };
        let start = Instant::now();
        let out = tessellate_scene(&loaded.scene, &tol);
        let elapsed = start.elapsed().as_secs_f64();
        if out.meshes.is_empty() && out.skipped.is_empty() {
            continue;
        }
        // Open edges after welding by position: 0 for a closed model.
        let open: usize = out.meshes.iter().map(|m| m.mesh.welded().boundary_edge_count()).sum();
        files += 1;
        meshes += out.meshes.len();
        skipped += out.skipped.len();
        triangles += out.triangle_count();
        seconds += elapsed;
        let name = format!("{repo}/{file}");
        let name = if name.len() > 70 { format!("...{}", &name[name.len() - 67..]) } else { name };
        println!(
            "{name:<70} {:>7} {:>7} {:>10} {:>9} {:>9.1}",
            out.meshes.len(),
            out.skipped.len(),
            out.triangle_count(),
            open,
            elapsed * 1e3
        );
        for s in out.skipped.iter().filter(|s| !s.error.is_not_a_surface()) {
            println!("    {}: {}", s.loc, s.error);
        }
    }
    println!(
        "{files} scenes, {meshes} meshes, {skipped} skipped, {triangles} triangles in {:.2} s ({:.2} M triangles/s)",
        seconds,
        triangles as f64 / seconds / 1e6
    );
}
