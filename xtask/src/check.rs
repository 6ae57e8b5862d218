//! `cargo xtask bench-check [--repeat N]`: `lrt-depth --check` on a generated 50 MB
//! `PointsPolygons` mesh against `wc -w` on the same file (issue 12's disk-speed target:
//! at least 0.7x the speed of `wc -w`, peak memory at most 3x the file). Both read the file
//! from the page cache; runs alternate so that other load hits both alike. Prints a Markdown
//! table for docs/rib-parser.md.

use crate::measure::{ChildRun, run_measured};
use crate::{cargo, run, workspace_root};
use std::process::Command;

pub fn bench_check(args: &[String]) -> Result<(), String> {
    let mut repeat = 5usize;
    let mut it = args.iter();
    while let Some(a) = it.next() {
        match a.as_str() {
            "--repeat" => {
                repeat = it
                    .next()
                    .and_then(|v| v.parse().ok())
                    .filter(|&n| n > 0)
                    .ok_or("--repeat needs a positive count")?
            }
            other => return Err(format!("bench-check: unknown argument {other}")),
        }
    }
    run(cargo().args(["build", "--release", "-p", "lrt-depth"]))?;
    let target = std::env::var_os("CARGO_TARGET_DIR")
        .map(std::path::PathBuf::from)
        .unwrap_or_else(|| workspace_root().join("target"));
    let lrt = target.join("release").join("lrt-depth");
    let dir = target.join("bench-check");
    std::fs::create_dir_all(&dir).map_err(|e| format!("{}: {e}", dir.display()))?;
    let mesh = dir.join("mesh-50MB.rib");
    let bytes = rib_parser::generated::mesh_rib(50 << 20);
    std::fs::write(&mesh, &bytes).map_err(|e| format!("{}: {e}", mesh.display()))?;
    let file_mib = bytes.len() as f64 / (1 << 20) as f64;

    let load = crate::bench_error::load_average();
    // One unmeasured run of each puts the file in the page cache.
    let (mut wc, mut check): (Vec<ChildRun>, Vec<ChildRun>) = (Vec::new(), Vec::new());
    for round in 0..=repeat {
        let w = run_measured(Command::new("wc").arg("-w").arg(&mesh))?;
        let c = run_measured(Command::new(&lrt).arg("--check").arg(&mesh))?;
        if !w.success || !c.success {
            return Err(format!("wc -w or lrt-depth --check failed:\n{}{}", w.stderr, c.stderr));
        }
        if round > 0 {
            wc.push(w);
            check.push(c);
        }
    }
    let median = |runs: &[ChildRun], f: fn(&ChildRun) -> f64| {
        let mut v: Vec<f64> = runs.iter().map(f).collect();
        v.sort_by(f64::total_cmp);
        v[v.len() / 2]
    };
    let (wc_wall, wc_cpu) = (median(&wc, |r| r.wall_s), median(&wc, |r| r.cpu_s));
    let (check_wall, check_cpu) = (median(&check, |r| r.wall_s), median(&check, |r| r.cpu_s));
    let check_rss = check.iter().map(|r| r.peak_rss_mib).fold(0.0, f64::max);
    println!(
        "Generated ASCII `PointsPolygons` mesh, {file_mib:.1} MiB; median of {repeat} runs each; load {load} at the start.\n"
    );
    println!("| command | wall s | CPU s | MB/s (wall) | peak MiB |");
    println!("|---|---|---|---|---|");
    let mbs = |s: f64| bytes.len() as f64 / 1e6 / s;
    println!("| `wc -w` | {wc_wall:.3} | {wc_cpu:.3} | {:.0} | |", mbs(wc_wall));
    println!(
        "| `lrt-depth --check` | {check_wall:.3} | {check_cpu:.3} | {:.0} | {check_rss:.0} |",
        mbs(check_wall)
    );
    println!(
        "\n`--check` speed against `wc -w`: {:.2}x (wall), {:.2}x (CPU); peak memory {:.2}x the file.",
        wc_wall / check_wall,
        wc_cpu / check_cpu,
        check_rss / file_mib
    );
    std::fs::remove_file(&mesh).map_err(|e| format!("{}: {e}", mesh.display()))?;
    Ok(())
}
