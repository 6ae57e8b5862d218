//! Data-driven fixtures: `fixtures/rib/ok/NNNN_name.rib` must build a scene whose dump (and
//! warnings) equal `NNNN_name.dump`; `fixtures/rib/err/NNNN_name.rib` must fail with exactly
//! the diagnostics in `NNNN_name.err`. Files in subdirectories are archives the cases read.
//!
//! Adding a case is adding a `.rib` file; to (re)write the expected files, run
//! `cargo xtask update-fixtures` (or this test with `UPDATE_FIXTURES=1`) and review the diff.

use rib_parser::{FileSystem, LoadOptions, ReadOptions};
use std::io;
use std::path::{Path, PathBuf};
use std::sync::Arc;

fn workspace_root() -> PathBuf {
    Path::new(env!("CARGO_MANIFEST_DIR")).join("../..")
}

/// Serves relative paths from the workspace root, so locations in the expected outputs read
/// `fixtures/rib/ok/0001_x.rib:3:1` on every machine.
#[derive(Debug)]
struct RootedFs(PathBuf);

impl FileSystem for RootedFs {
    fn read(&self, path: &Path) -> io::Result<Vec<u8>> {
        std::fs::read(self.0.join(path))
    }

    fn is_file(&self, path: &Path) -> bool {
        self.0.join(path).is_file()
    }
}

fn cases(kind: &str) -> Vec<PathBuf> {
    let dir = workspace_root().join("fixtures/rib").join(kind);
    let mut out: Vec<PathBuf> = std::fs::read_dir(&dir)
        .unwrap_or_else(|e| panic!("{}: {e}", dir.display()))
        .filter_map(|e| e.ok().map(|e| e.path()))
        .filter(|p| p.is_file() && p.extension().is_some_and(|e| e == "rib"))
        .map(|p| Path::new("fixtures/rib").join(kind).join(p.file_name().unwrap_or_default()))
        .collect();
    out.sort();
    out
}

fn run(case: &Path) -> Result<String, String> {
    let options = LoadOptions {
        read: ReadOptions { file_system: Arc::new(RootedFs(workspace_root())), ..Default::default() },
        frame: None,
    };
    match rib_parser::load_scene(case, &options) {
        Ok(loaded) => {
            let mut out = rib_parser::summary::dump(&loaded.scene);
            let warnings = loaded.render_warnings();
            if !warnings.is_empty() {
                out.push_str("--- warnings\n");
                out.push_str(&warnings);
            }
            Ok(out)
        }
        Err(e) => Err(e.render()),
    }
}

/// Writes `text` to `path` atomically (a temporary file, then a rename).
fn write_atomically(path: &Path, text: &str) {
    let tmp = path.with_extension("tmp");
    std::fs::write(&tmp, text).unwrap_or_else(|e| panic!("{}: {e}", tmp.display()));
    std::fs::rename(&tmp, path).unwrap_or_else(|e| panic!("{}: {e}", path.display()));
}

fn check(kind: &str, expected_ext: &str) {
    let update = std::env::var_os("UPDATE_FIXTURES").is_some();
    let cases = cases(kind);
    assert!(!cases.is_empty(), "no fixtures in fixtures/rib/{kind}");
    let mut failures = Vec::new();
    for case in &cases {
        let got = match (kind, run(case)) {
            ("ok", Ok(text)) | ("err", Err(text)) => text,
            ("ok", Err(e)) => {
                failures.push(format!("{}: expected a scene, got:\n{e}", case.display()));
                continue;
            }
            (_, Ok(_)) => {
                failures.push(format!("{}: expected an error, but a scene was built", case.display()));
                continue;
            }
            _ => unreachable!("kind is ok or err"),
        };
        let expected_path = workspace_root().join(case.with_extension(expected_ext));
        if update {
            write_atomically(&expected_path, &got);
            continue;
        }
        match std::fs::read_to_string(&expected_path) {
            Ok(expected) if expected == got => {}
            Ok(expected) => failures.push(format!(
                "{}: output differs from {}\n--- expected\n{expected}--- got\n{got}",
                case.display(),
                expected_path.display()
            )),
            Err(_) => failures.push(format!(
                "{}: no {} (run `cargo xtask update-fixtures`)\n--- got\n{got}",
                case.display(),
                expected_path.display()
            )),
        }
    }
    assert!(failures.is_empty(), "{}", failures.join("\n\n"));
}

#[test]
fn ok_fixtures_build_the_expected_scenes() {
    check("ok", "dump");
}

#[test]
fn err_fixtures_fail_with_the_expected_diagnostics() {
    check("err", "err");
}
