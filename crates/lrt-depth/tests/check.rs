//! `lrt-depth --check` run as a program (CONTRACTS.md §4): the summary, diagnostics in
//! `PATH:LINE:COL` form with a caret, standard input, exit codes 0/1/2.

use std::io::Write;
use std::process::{Command, Output, Stdio};

const CORNELL: &str = concat!(env!("CARGO_MANIFEST_DIR"), "/../../../shared/reference/cornell/cornell.rib");

fn lrt_depth(args: &[&str], stdin: Option<&str>) -> Output {
    let mut child = Command::new(env!("CARGO_BIN_EXE_lrt-depth"))
        .args(args)
        .stdin(if stdin.is_some() { Stdio::piped() } else { Stdio::null() })
        .stdout(Stdio::piped())
        .stderr(Stdio::piped())
        .spawn()
        .unwrap();
    if let (Some(text), Some(mut pipe)) = (stdin, child.stdin.take()) {
        pipe.write_all(text.as_bytes()).unwrap();
    }
    child.wait_with_output().unwrap()
}

fn text(bytes: &[u8]) -> String {
    String::from_utf8_lossy(bytes).into_owned()
}

#[test]
fn the_cornell_box_checks_with_a_one_line_summary() {
    let out = lrt_depth(&["--check", CORNELL], None);
    assert_eq!(out.status.code(), Some(0), "{}", text(&out.stderr));
    let stdout = text(&out.stdout);
    assert_eq!(stdout.lines().count(), 1, "{stdout}");
    assert!(stdout.contains(": ok: 72 requests, 18 shapes, 1 lights, 36 triangles, 0 warnings"), "{stdout}");
    assert!(text(&out.stderr).is_empty());
}

#[test]
fn standard_input_and_stats() {
    let rib = "Option \"lrt\" \"depthfile\" [\"x.depth\"]\nWorldBegin\nSphere 1 -1 1 360\nBlobby 1 [1003 0 0] [0 0 0 0] [\"flat.zfile\"]\nWorldEnd\n";
    let out = lrt_depth(&["--check", "--stats", "-"], Some(rib));
    assert_eq!(out.status.code(), Some(0), "{}", text(&out.stderr));
    let stdout = text(&out.stdout);
    assert!(stdout.starts_with("-: ok: 5 requests, 2 shapes, 0 lights, "), "{stdout}");
    assert!(stdout.contains("1 warnings"), "{stdout}");
    assert!(stdout.contains("stats: depth table requested: x.depth (Option)"), "{stdout}");
    // A Blobby plane needs a depth map that is never read: a located warning, not an error.
    let stderr = text(&out.stderr);
    assert!(stderr.starts_with("-:4:1: warning: not tessellated: invalid Blobby: plane"), "{stderr}");
    // --depth overrides the request.
    let out = lrt_depth(&["--check", "--stats", "--depth", "cli.depth", "-"], Some(rib));
    assert!(text(&out.stdout).contains("stats: depth table requested: cli.depth (CommandLine)"));
}

#[test]
fn an_invalid_scene_exits_1_with_located_errors() {
    let out = lrt_depth(&["--check", "-"], Some("WorldBegin\n  Sphere 1 -1 one 360\nWorldEnd\n"));
    assert_eq!(out.status.code(), Some(1));
    assert!(out.stdout.is_empty());
    // The bad argument is reported where it is; the bare word then reads as a request name.
    assert_eq!(
        text(&out.stderr),
        "-:2:15: error: Sphere: expected 4 numbers for the quadric's 4 arguments, found 'one'\n\
         \x20     Sphere 1 -1 one 360\n\
         \x20                 ^\n\
         -:2:15: warning: unknown request 'one'; skipped with its arguments\n\
         \x20     Sphere 1 -1 one 360\n\
         \x20                 ^\n"
    );
}

#[test]
fn a_missing_file_exits_1_and_a_bad_command_line_exits_2() {
    let out = lrt_depth(&["--check", "/nonexistent/scene.rib"], None);
    assert_eq!(out.status.code(), Some(1));
    assert!(
        text(&out.stderr).starts_with("error: cannot read '/nonexistent/scene.rib':"),
        "{}",
        text(&out.stderr)
    );
    for bad in [&["--check"][..], &["--check", CORNELL, "--spp", "0"], &["--check", CORNELL, "--bogus"]] {
        let out = lrt_depth(bad, None);
        assert_eq!(out.status.code(), Some(2), "{bad:?}: {}", text(&out.stderr));
    }
    let out = lrt_depth(&["--help"], None);
    assert_eq!(out.status.code(), Some(0));
    assert!(text(&out.stdout).contains("--check"));
}
