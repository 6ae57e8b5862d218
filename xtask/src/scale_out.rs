//! `cargo xtask scale-out`: the Cornell box rendered as 1, 4 and 16 tiles through a one-node
//! Slurm cluster of this machine (`examples/slurm/local-cluster.sh`), timed from submission to
//! the merged image, with each tile's render time and the merge's time and memory
//! (docs/scale-out.md).
//!
//! ```text
//! cargo xtask scale-out [--size 2048] [--spp 1] [--tilings 1,2,4]
//! ```
//!
//! Every merged image is compared byte for byte with a one-machine render of the same settings.

use crate::{cargo, run, workspace_root};
use std::path::{Path, PathBuf};
use std::process::Command;
use std::time::{Duration, Instant};

struct Options {
    size: u32,
    spp: u32,
    tilings: Vec<u32>,
}

fn parse(args: &[String]) -> Result<Options, String> {
    let mut o = Options { size: 2048, spp: 1, tilings: vec![1, 2, 4] };
    let mut it = args.iter();
    while let Some(a) = it.next() {
        let mut value = |name: &str| it.next().ok_or(format!("{name} needs a value")).cloned();
        match a.as_str() {
            "--size" => o.size = value("--size")?.parse().map_err(|_| "--size: a whole number")?,
            "--spp" => o.spp = value("--spp")?.parse().map_err(|_| "--spp: a whole number")?,
            "--tilings" => {
                o.tilings = value("--tilings")?
                    .split(',')
                    .map(|v| v.trim().parse::<u32>().map_err(|_| format!("--tilings: '{v}' is not a number")))
                    .collect::<Result<_, _>>()?
            }
            other => return Err(format!("scale-out: unknown argument {other}")),
        }
    }
    if o.size == 0 || o.spp == 0 || o.tilings.iter().any(|&n| n == 0 || n > 64) {
        return Err("scale-out: --size and --spp at least 1, tilings 1 to 64 per axis".into());
    }
    Ok(o)
}

fn load_average() -> String {
    std::fs::read_to_string("/proc/loadavg")
        .map(|s| s.split_whitespace().take(3).collect::<Vec<_>>().join(" "))
        .unwrap_or_else(|_| "?".into())
}

fn output(cmd: &mut Command) -> Result<String, String> {
    let out = cmd.output().map_err(|e| format!("cannot start {cmd:?}: {e}"))?;
    if !out.status.success() {
        return Err(format!(
            "{cmd:?} failed: {}{}",
            String::from_utf8_lossy(&out.stdout),
            String::from_utf8_lossy(&out.stderr)
        ));
    }
    Ok(String::from_utf8_lossy(&out.stdout).into_owned())
}

/// The shared Cornell box at `size`^2 with its depth table.
fn scene(size: u32) -> Result<String, String> {
    let root = workspace_root();
    let path = root
        .ancestors()
        .skip(1)
        .map(|d| d.join("shared/reference/cornell/cornell.rib"))
        .find(|p| p.is_file())
        .ok_or("scale-out: ../shared/reference/cornell/cornell.rib not found")?;
    let rib = std::fs::read_to_string(&path).map_err(|e| format!("{}: {e}", path.display()))?;
    let mut out = String::new();
    for line in rib.lines() {
        if line.starts_with("Display ") {
            out += "Display \"cornell.exr\" \"openexr\" \"rgb\"\nOption \"lrt\" \"string depthfile\" [\"cornell.depth\"]\n";
        } else if line.starts_with("Format ") {
            out += &format!("Format {size} {size} 1\n");
        } else {
            out += line;
            out.push('\n');
        }
    }
    Ok(out)
}

/// Seconds of `stats: time: ... render X s` in a tile task's output.
fn render_seconds(text: &str) -> Option<f64> {
    let line = text.lines().find(|l| l.starts_with("stats: time:"))?;
    let after = line.split("render ").nth(1)?;
    after.split(' ').next()?.parse().ok()
}

struct Cluster {
    dir: PathBuf,
    script: PathBuf,
}

impl Drop for Cluster {
    fn drop(&mut self) {
        let _ = Command::new("bash").arg(&self.script).arg("stop").arg(&self.dir).status();
        let _ = std::fs::remove_dir_all(&self.dir);
    }
}

pub fn scale_out(args: &[String]) -> Result<(), String> {
    let o = parse(args)?;
    crate::install_packages(crate::TEST_PACKAGES, "Slurm and munge")?;
    run(cargo().args(["build", "--release", "-p", "lrt-depth"]))?;
    let root = workspace_root();
    let bin = root.join("target/release");
    let examples = root.join("examples/slurm");
    let work = root.join("target/scale-out");
    let _ = std::fs::remove_dir_all(&work);
    std::fs::create_dir_all(&work).map_err(|e| e.to_string())?;
    let cluster = Cluster { dir: work.join("cluster"), script: examples.join("local-cluster.sh") };
    let started = Command::new("bash").arg(&cluster.script).arg("start").arg(&cluster.dir).status();
    if !started.is_ok_and(|s| s.success()) {
        let logs = output(Command::new("bash").arg(&cluster.script).arg("logs").arg(&cluster.dir));
        return Err(format!("the local Slurm cluster did not start\n{}", logs.unwrap_or_default()));
    }
    let conf = cluster.dir.join("slurm.conf");
    let cpus = std::thread::available_parallelism().map_or(1, |n| n.get());
    let spp = o.spp.to_string();

    // The one-machine render every merge must equal.
    let one = work.join("one-machine");
    std::fs::create_dir_all(&one).map_err(|e| e.to_string())?;
    std::fs::write(one.join("cornell.rib"), scene(o.size)?).map_err(|e| e.to_string())?;
    let start = Instant::now();
    output(Command::new(bin.join("lrt-depth")).current_dir(&one).args([
        "cornell.rib",
        "-q",
        "--spp",
        &spp,
        "--threads",
        &cpus.to_string(),
    ]))?;
    let one_seconds = start.elapsed().as_secs_f64();

    let mut rows =
        vec![format!("| one machine, no Slurm | 1 | {one_seconds:.1} | - | - | - | {} |", load_average())];
    for &n in &o.tilings {
        let dir = work.join(format!("tiles-{n}x{n}"));
        std::fs::create_dir_all(&dir).map_err(|e| e.to_string())?;
        std::fs::write(dir.join("cornell.rib"), scene(o.size)?).map_err(|e| e.to_string())?;
        let tiling = format!("{n},{n}");
        // One tile gets every CPU; more tiles get one CPU each and share the node.
        let sbatch_args = if n == 1 { format!("--cpus-per-task={cpus}") } else { String::new() };
        let start = Instant::now();
        let ids = output(
            Command::new("bash")
                .arg(examples.join("submit-tiles.sh"))
                .args(["cornell.rib", &tiling, "cornell.exr", "cornell.depth", "--stats", "--spp", &spp])
                .current_dir(&dir)
                .env("SLURM_CONF", &conf)
                .env("LRT_DEPTH", bin.join("lrt-depth"))
                .env("LRT_MERGE", bin.join("lrt-merge"))
                .env("LRT_SBATCH_ARGS", sbatch_args),
        )?;
        let ids: Vec<&str> = ids.split_whitespace().collect();
        loop {
            let queued = output(
                Command::new("squeue")
                    .args(["-h", "-j", &ids.join(","), "-o", "%i %r"])
                    .env("SLURM_CONF", &conf),
            )?;
            if queued.trim().is_empty() {
                break;
            }
            if queued.contains("DependencyNeverSatisfied") {
                return Err(format!(
                    "{n}x{n} tiles: a tile task failed (see {}/lrt-tiles-*.out)",
                    dir.display()
                ));
            }
            if start.elapsed() > Duration::from_secs(3600) {
                return Err(format!("{n}x{n} tiles: not done after an hour"));
            }
            std::thread::sleep(Duration::from_millis(200));
        }
        let wall = start.elapsed().as_secs_f64();
        for name in ["cornell.exr", "cornell.depth"] {
            let same = std::fs::read(dir.join(name)).ok() == std::fs::read(one.join(name)).ok();
            if !same {
                return Err(format!(
                    "{n}x{n} tiles: {name} is missing or differs from the one-machine render"
                ));
            }
        }
        // Each tile's render time, from its task's --stats.
        let mut tile_seconds = Vec::new();
        for entry in std::fs::read_dir(&dir).map_err(|e| e.to_string())?.flatten() {
            let name = entry.file_name().to_string_lossy().into_owned();
            if name.starts_with("lrt-tiles-") {
                let text = std::fs::read_to_string(entry.path()).unwrap_or_default();
                tile_seconds.extend(render_seconds(&text));
            }
        }
        let count = (n * n) as usize;
        if tile_seconds.len() != count {
            return Err(format!(
                "{n}x{n} tiles: {} of {count} tasks reported their time",
                tile_seconds.len()
            ));
        }
        let total: f64 = tile_seconds.iter().sum();
        let max = tile_seconds.iter().copied().fold(0.0, f64::max);
        rows.push(format!(
            "| {n}x{n} tiles through Slurm | {count} | {wall:.1} | {total:.1} | {max:.1} | {} | {} |",
            merge_figures(&dir, &bin, count)?,
            load_average()
        ));
    }
    let table = format!(
        "Cornell box {size}x{size}, photon mapping, {spp} spp, {cpus} CPUs (`cargo xtask scale-out --size {size} --spp {spp}`):\n\n\
         | run | tasks | submit to merged image, s | sum of tile render times, s | slowest tile render, s | merge s / peak MiB | load |\n\
         |---|---|---|---|---|---|---|\n{}\n",
        rows.join("\n"),
        size = o.size,
    );
    println!("{table}");
    std::fs::write(work.join("table.md"), &table).map_err(|e| e.to_string())?;
    drop(cluster);
    Ok(())
}

/// Runs `lrt-merge` on a finished tiling by hand: its wall time and peak resident memory.
fn merge_figures(dir: &Path, bin: &Path, count: usize) -> Result<String, String> {
    let mut cmd = Command::new("/usr/bin/time");
    cmd.args(["-f", "%e %M"]).arg(bin.join("lrt-merge")).args(["-o", "timed.exr", "--depth", "timed.depth"]);
    for k in 0..count {
        cmd.arg("--tile-depth").arg(format!("cornell.tile{k:03}.depth"));
    }
    for k in 0..count {
        cmd.arg(format!("cornell.tile{k:03}.exr"));
    }
    let out = cmd.current_dir(dir).output().map_err(|e| format!("/usr/bin/time: {e}"))?;
    if !out.status.success() {
        return Err(format!("lrt-merge: {}", String::from_utf8_lossy(&out.stderr)));
    }
    let stderr = String::from_utf8_lossy(&out.stderr);
    let last = stderr.lines().last().unwrap_or("");
    let mut parts = last.split_whitespace();
    let seconds: f64 = parts.next().and_then(|v| v.parse().ok()).ok_or("cannot read /usr/bin/time")?;
    let kib: f64 = parts.next().and_then(|v| v.parse().ok()).ok_or("cannot read /usr/bin/time")?;
    Ok(format!("{seconds:.2} / {:.0}", kib / 1024.0))
}
