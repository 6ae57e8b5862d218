//! RIB reader automation.
//!
//! - `cargo xtask update-fixtures`: rewrites the expected outputs of `fixtures/rib/{ok,err}`
//!   (`.dump`, `.err`) from the current parser; review the diff before committing.
//! - `cargo xtask bench-parse [criterion args]`: the parse-throughput benchmark (a generated
//!   50 MB `PointsPolygons` mesh and the corpus's largest files), release build, one core.

use std::process::Command;

pub fn update_fixtures() -> Result<(), String> {
    crate::run(
        crate::cargo().args(["test", "-p", "rib-parser", "--test", "fixtures"]).env("UPDATE_FIXTURES", "1"),
    )?;
    // Check that the rewritten files now pass as they are.
    crate::run(crate::cargo().args(["test", "-p", "rib-parser", "--test", "fixtures"]))
}

pub fn bench_parse(extra: &[String]) -> Result<(), String> {
    let mut cmd: Command = crate::cargo();
    cmd.args(["bench", "-p", "rib-parser", "--bench", "parse", "--"]).args(extra);
    crate::run(&mut cmd)
}
