//! Data-driven trajectory CSV tests: `fixtures/trajectory/{ok,err}/NNNN_name.csv`, each with
//! the expected outcome beside it in `NNNN_name.expected` (a summary for `ok`, the exact error
//! message for `err`). Adding a case is adding two files; `UPDATE_FIXTURES=1 cargo test -p
//! haptics --test trajectory_fixtures` rewrites the expectations from the current behaviour.

use haptics::Trajectory;
use std::path::{Path, PathBuf};

fn fixtures() -> PathBuf {
    Path::new(env!("CARGO_MANIFEST_DIR")).join("../../fixtures/trajectory")
}

fn outcome(path: &Path) -> Result<String, String> {
    let name = path.file_name().unwrap().to_string_lossy().into_owned();
    let text = std::fs::read_to_string(path).map_err(|e| format!("cannot read {}: {e}", path.display()))?;
    match Trajectory::parse(&text, &name) {
        Ok(t) => Ok(format!("{} samples, {} .. {} s", t.len(), t.start_time(), t.end_time())),
        Err(e) => Err(e.to_string()),
    }
}

fn check(kind: &str) -> usize {
    let dir = fixtures().join(kind);
    let update = std::env::var_os("UPDATE_FIXTURES").is_some();
    let mut cases: Vec<PathBuf> = std::fs::read_dir(&dir)
        .unwrap_or_else(|e| panic!("{}: {e}", dir.display()))
        .map(|e| e.unwrap().path())
        .filter(|p| p.extension().is_some_and(|x| x == "csv"))
        .collect();
    cases.sort();
    for case in &cases {
        let got = match (kind, outcome(case)) {
            ("ok", Ok(summary)) => summary,
            ("err", Err(message)) => message,
            (_, other) => panic!("{}: expected {kind}, got {other:?}", case.display()),
        };
        let expected_path = case.with_extension("expected");
        if update {
            std::fs::write(&expected_path, format!("{got}\n")).unwrap();
            continue;
        }
        let expected = std::fs::read_to_string(&expected_path)
            .unwrap_or_else(|e| panic!("{}: {e}", expected_path.display()));
        assert_eq!(got, expected.trim_end(), "{}", case.display());
    }
    cases.len()
}

#[test]
fn good_trajectories_parse() {
    assert!(check("ok") >= 3);
}

#[test]
fn bad_trajectories_give_located_errors() {
    assert!(check("err") >= 8);
}
