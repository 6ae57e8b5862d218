//! `cargo xtask reflection-probes`: what baking the sidecar's reflection probes costs against
//! the render itself, on the Cornell box and the caustics scene at 256x256 (the table of
//! docs/sidecar.md), and a picture of the Cornell box's middle probe at every roughness level
//! (`docs/reflection-probes-cornell.png`).

use crate::bench_error::load_average;
use crate::measure::run_measured;
use std::path::{Path, PathBuf};
use std::process::Command;

/// Pixels per side of one level's octahedral map in the picture.
const TILE: u32 = 128;
const GAP: u32 = 4;

pub fn reflection_probes(args: &[String]) -> Result<(), String> {
    if let Some(other) = args.first() {
        return Err(format!("reflection-probes: unknown argument {other}"));
    }
    let root = crate::workspace_root();
    crate::run(crate::cargo().args(["build", "--release", "-p", "lrt-depth"]))?;
    let target =
        std::env::var_os("CARGO_TARGET_DIR").map(PathBuf::from).unwrap_or_else(|| root.join("target"));
    let lrt = target.join("release/lrt-depth");
    let out_dir = root.join("target/reflection-probes");
    std::fs::create_dir_all(&out_dir).map_err(|e| format!("cannot create {}: {e}", out_dir.display()))?;
    println!(
        "| scene (256x256) | integrator, samples | render | irradiance probes | reflection probes | share of render | user CPU of the run | load average |"
    );
    println!("|---|---|---|---|---|---|---|---|");
    let scenes: [(&str, &str, &[&str]); 2] = [
        ("cornell", "examples/cornell/cornell.rib", &["--max-size", "256"]),
        ("caustics", "examples/caustics/caustics.rib", &[]),
    ];
    for (name, rib, extra) in scenes {
        let depth = out_dir.join(format!("{name}.depth"));
        let mut cmd = Command::new(&lrt);
        cmd.arg(root.join(rib))
            .arg("-o")
            .arg(out_dir.join(format!("{name}.exr")))
            .arg("--depth")
            .arg(&depth)
            .args(["--threads", "2", "--stats"])
            .args(extra);
        let run = run_measured(&mut cmd)?;
        if !run.success {
            return Err(format!("lrt-depth failed on {rib}:\n{}", run.stderr));
        }
        let load = load_average();
        let times = stats_times(&run.stdout).ok_or_else(|| format!("no `stats: time:` line for {rib}"))?;
        let integrator = run
            .stdout
            .lines()
            .find_map(|l| l.strip_prefix("stats: integrator "))
            .map(|l| l.split(", ").take(2).collect::<Vec<_>>().join(", "))
            .unwrap_or_default();
        let time = |key: &str| times.iter().find(|(k, _)| k == key).map_or(0.0, |(_, v)| *v);
        let render = time("render");
        println!(
            "| `{rib}{}` | {integrator} | {render:.2} s | {:.2} s | {:.2} s | {:.1} % | {:.1} s | {load} |",
            if extra.is_empty() { String::new() } else { format!(" {}", extra.join(" ")) },
            time("probes"),
            time("reflections"),
            100.0 * time("reflections") / render.max(1e-9),
            run.cpu_s,
        );
    }
    let reflections = sidecar::SidecarPaths::for_depth(&out_dir.join("cornell.depth")).reflections;
    let picture = root.join("docs/reflection-probes-cornell.png");
    draw_middle_probe(&reflections, &picture)?;
    println!("wrote {}", picture.display());
    Ok(())
}

/// The `(phase, seconds)` pairs of `lrt-depth --stats`'s `stats: time:` line.
fn stats_times(stdout: &str) -> Option<Vec<(String, f64)>> {
    let line = stdout.lines().find_map(|l| l.strip_prefix("stats: time: "))?;
    Some(
        line.split(", ")
            .filter_map(|part| {
                let (key, value) = part.split_once(' ')?;
                Some((key.to_string(), value.trim_end_matches(" s").parse().ok()?))
            })
            .collect(),
    )
}

/// The probe in the middle of the grid, one octahedral map per roughness level side by side
/// (each level looked up at its own roughness, so bilinear within that level), tone mapped
/// `x / (1 + x)` and sRGB encoded.
fn draw_middle_probe(reflections: &Path, picture: &Path) -> Result<(), String> {
    let probes = sidecar::read_reflections(reflections, None)
        .map_err(|e| e.to_string())?
        .ok_or_else(|| format!("{}: not written", reflections.display()))?;
    let probe = probes.probe_index(probes.counts.map(|c| c / 2));
    let levels = sidecar::REFLECTION_LEVELS as u32;
    let mut image =
        image::RgbImage::from_pixel(levels * TILE + (levels - 1) * GAP, TILE, image::Rgb([255; 3]));
    for k in 0..levels {
        let roughness = sidecar::reflection_level_roughness(k as usize);
        for y in 0..TILE {
            for x in 0..TILE {
                let uv = [(x as f32 + 0.5) / TILE as f32, (y as f32 + 0.5) / TILE as f32];
                let rgb = probes.sample(probe, sidecar::octahedral_direction(uv), roughness);
                let encode = |v: f32| {
                    let t = (v.max(0.0) / (1.0 + v.max(0.0))).min(1.0);
                    let s = if t <= 0.003_130_8 { 12.92 * t } else { 1.055 * t.powf(1.0 / 2.4) - 0.055 };
                    (s * 255.0 + 0.5) as u8
                };
                image.put_pixel(k * (TILE + GAP) + x, y, image::Rgb(rgb.map(encode)));
            }
        }
    }
    image.save(picture).map_err(|e| format!("cannot write {}: {e}", picture.display()))
}

#[cfg(test)]
mod tests {
    #[test]
    fn stats_times_reads_every_phase() {
        let out = "wrote x\nstats: time: parse 0.001 s, build 0.000 s, prepare 2.086 s, render 18.813 s, depth 0.012 s, probes 0.414 s, reflections 0.408 s, write 0.109 s\n";
        let t = super::stats_times(out).unwrap();
        assert_eq!(t.len(), 8);
        assert_eq!(t[3], ("render".to_string(), 18.813));
        assert_eq!(t[6], ("reflections".to_string(), 0.408));
    }
}
