//! Where `ReadArchive "name"` looks, in order: the including file's directory, the top-level
//! file's directory, then `Option "searchpath" "archive"` and `"resource"` (`&` the previous
//! value, `@` the default, `:`-separated), and the located error naming every place it looked.

use rib_parser::scene::Shape;
use rib_parser::{LoadOptions, load_scene};
use std::path::Path;

/// Writes `files` (relative path, text) under `dir`.
fn write(dir: &Path, files: &[(&str, &str)]) {
    for (name, text) in files {
        let path = dir.join(name);
        std::fs::create_dir_all(path.parent().unwrap()).unwrap();
        std::fs::write(path, text).unwrap();
    }
}

/// A sphere whose radius tells which file was read.
fn sphere(radius: u32) -> String {
    format!("Sphere {radius} -{radius} {radius} 360\n")
}

/// The sphere radii of the scene read from `dir/main.rib`, in order.
fn radii(dir: &Path) -> Vec<f32> {
    let loaded = load_scene(&dir.join("main.rib"), &LoadOptions::default())
        .unwrap_or_else(|e| panic!("{}", e.render()));
    loaded
        .scene
        .shapes
        .iter()
        .map(|s| match *s.shape {
            Shape::Sphere { radius, .. } => radius,
            ref other => panic!("not a sphere: {other:?}"),
        })
        .collect()
}

#[test]
fn the_including_files_directory_comes_first_then_the_top_level_files() {
    let dir = tempfile::TempDir::new().unwrap();
    write(
        dir.path(),
        &[
            ("main.rib", "WorldBegin\nReadArchive \"sub/inc.rib\"\nWorldEnd\n"),
            ("sub/inc.rib", "ReadArchive \"leaf.rib\"\nReadArchive \"top_only.rib\"\n"),
            ("sub/leaf.rib", &sphere(2)),
            ("leaf.rib", &sphere(1)),
            ("top_only.rib", &sphere(3)),
        ],
    );
    assert_eq!(radii(dir.path()), vec![2.0, 3.0]);
}

#[test]
fn search_paths_expand_previous_and_default_and_archive_comes_before_resource() {
    let dir = tempfile::TempDir::new().unwrap();
    let main = "Option \"searchpath\" \"string archive\" [\"lib1\"]\n\
                Option \"searchpath\" \"string archive\" [\"lib2:&\"]\n\
                Option \"searchpath\" \"string resource\" [\"res:@\"]\n\
                WorldBegin\n\
                ReadArchive \"both.rib\"\n\
                ReadArchive \"one.rib\"\n\
                ReadArchive \"res.rib\"\n\
                ReadArchive \"inc.rib\"\n\
                WorldEnd\n";
    write(
        dir.path(),
        &[
            ("main.rib", main),
            ("lib1/both.rib", &sphere(1)),
            ("lib2/both.rib", &sphere(2)),
            ("lib1/one.rib", &sphere(3)),
            ("lib1/res.rib", &sphere(4)),
            ("res/res.rib", &sphere(5)),
            // Read through "archive", it finds `top.rib` through "resource"'s `@`.
            ("lib2/inc.rib", "ReadArchive \"top.rib\"\n"),
            ("elsewhere/top.rib", &sphere(9)),
        ],
    );
    // `top.rib` is missing: the error names the including file's place and every place tried.
    let err = load_scene(&dir.path().join("main.rib"), &LoadOptions::default()).unwrap_err().render();
    let inc = dir.path().join("lib2/inc.rib");
    assert!(err.contains(&format!("{}:1:1: error: cannot find archive 'top.rib'", inc.display())), "{err}");
    for tried in ["lib2/top.rib", "top.rib", "lib1/top.rib", "res/top.rib"] {
        assert!(err.contains(&dir.path().join(tried).display().to_string()), "{tried} not in {err}");
    }
    // With it at the top level (`@`), everything resolves: lib2 before lib1 (`&` appended the
    // old value), "archive" before "resource".
    write(dir.path(), &[("top.rib", &sphere(6))]);
    assert_eq!(radii(dir.path()), vec![2.0, 3.0, 4.0, 6.0]);
}

#[test]
fn an_archive_found_nowhere_is_a_located_error() {
    let dir = tempfile::TempDir::new().unwrap();
    write(dir.path(), &[("main.rib", "WorldBegin\n  ReadArchive \"gone.rib\"\nWorldEnd\n")]);
    let err = load_scene(&dir.path().join("main.rib"), &LoadOptions::default()).unwrap_err().render();
    let main = dir.path().join("main.rib");
    assert!(
        err.contains(&format!(
            "{}:2:3: error: cannot find archive 'gone.rib' (looked for {})",
            main.display(),
            dir.path().join("gone.rib").display()
        )),
        "{err}"
    );
}
