//! Run time against error: `cargo xtask bench-error`.
//!
//! Renders fixed scenes at a ladder of settings for every integrator with the release
//! `lrt-depth` (one child process per render, so its wall time and peak memory are its own) and
//! compares each image with a reference:
//! - `cornell`: `../shared/reference/cornell/cornell.rib` at 512x512 against Mitsuba 3's
//!   11,520-spp path-traced image;
//! - `caustics`: `examples/caustics/caustics.rib` (glass and mirror spheres in a Cornell box);
//! - `room`: `examples/room/room.rib` (corpus-style: RenderMan quadrics, plastic, metal and
//!   matte shaders, point, spot, ambient and area lights).
//!
//! The last two are compared with a long path-traced render of our own, cached under
//! `target/bench-error/references/` and made on first use (or again with `--references`).
//!
//! Output: `target/bench-error/results.csv` (one row per render), `error-vs-time-<scene>.svg`
//! (relative MSE against CPU time, user + system, log-log, one line per integrator setting) and
//! `table.md` (the table that goes into `docs/performance.md`).
//!
//! Metrics over all pixels and RGB channels: `RMSE = sqrt(mean((x - ref)^2))` and
//! `relMSE = mean((x - ref)^2 / (ref^2 + 0.01))`.
//!
//! Options: `--scenes a,b`, `--threads N` (default 2), `--quick` (a short ladder),
//! `--references` (re-render the cached references), `--filter TEXT` (only rungs whose label
//! contains TEXT; `A|B` for either), `--fresh` (start the results over; by default a run's rows replace the rows
//! with the same scene and label in the existing `results.csv` and the others are kept),
//! `--mitsuba [scalar|llvm]` (also time Mitsuba 3's path tracer on the Cornell box in the same
//! run; `llvm` installs what it needs, see `mitsuba.rs`; never a dependency).
//!
//! Besides the SVG plots, a full run (not `--quick`) writes each scene's plot as
//! `docs/error-vs-time-<scene>.png` (converted by `rsvg-convert`, Debian `librsvg2-bin`,
//! installed with apt like the test packages).
//! `cargo xtask image-error A.exr B.exr` prints both metrics for two images.

use std::fmt::Write as _;
use std::path::{Path, PathBuf};
use std::process::Command;

/// A linear RGB float image.
pub struct Rgb {
    pub width: usize,
    pub height: usize,
    pub pixels: Vec<[f32; 3]>,
}

pub fn read_exr(path: &Path) -> Result<Rgb, String> {
    use exr::prelude::*;
    let image = read_first_rgba_layer_from_file(
        path,
        |resolution, _| Rgb {
            width: resolution.width(),
            height: resolution.height(),
            pixels: vec![[0.0; 3]; resolution.width() * resolution.height()],
        },
        |img: &mut Rgb, pos, (r, g, b, _a): (f32, f32, f32, f32)| {
            let w = img.width;
            img.pixels[pos.y() * w + pos.x()] = [r, g, b];
        },
    )
    .map_err(|e| format!("cannot read {}: {e}", path.display()))?;
    Ok(image.layer_data.channel_data.pixels)
}

/// `(RMSE, relMSE)` of `image` against `reference`.
pub fn errors(image: &Rgb, reference: &Rgb) -> Result<(f64, f64), String> {
    if (image.width, image.height) != (reference.width, reference.height) {
        return Err(format!(
            "image is {}x{}, reference {}x{}",
            image.width, image.height, reference.width, reference.height
        ));
    }
    let mut se = 0.0f64;
    let mut rel = 0.0f64;
    for (a, b) in image.pixels.iter().zip(&reference.pixels) {
        for c in 0..3 {
            let (x, r) = (f64::from(a[c]), f64::from(b[c]));
            let d2 = (x - r) * (x - r);
            se += d2;
            rel += d2 / (r * r + 0.01);
        }
    }
    let n = (image.pixels.len() * 3) as f64;
    Ok(((se / n).sqrt(), rel / n))
}

pub fn image_error(args: &[String]) -> Result<(), String> {
    let [a, b] = args else { return Err("usage: cargo xtask image-error IMAGE.exr REFERENCE.exr".into()) };
    let (rmse, rel) = errors(&read_exr(Path::new(a))?, &read_exr(Path::new(b))?)?;
    println!("RMSE {rmse:.4e}  relMSE {rel:.4e}");
    Ok(())
}

/// One render of the ladder.
#[derive(Clone, Debug)]
struct Rung {
    /// The line of the plot this point belongs to (e.g. `photonmap 200k fg8`: one photon count
    /// and gather count, with pixel samples along the line).
    series: String,
    /// A unique label (e.g. `photonmap 200k spp4 fg8`).
    label: String,
    spp: u32,
    /// The `SurfaceIntegrator` request inserted before `WorldBegin`.
    integrator: String,
}

fn path_rung(spp: u32) -> Rung {
    Rung {
        series: "path".into(),
        label: format!("path spp{spp}"),
        spp,
        integrator: "SurfaceIntegrator \"path\"".into(),
    }
}

fn direct_rung(spp: u32) -> Rung {
    Rung {
        series: "directlighting".into(),
        label: format!("directlighting spp{spp}"),
        spp,
        integrator: "SurfaceIntegrator \"directlighting\"".into(),
    }
}

fn photon_rung(photons: u32, spp: u32, gather: u32, extra: &str) -> Rung {
    let k = if photons >= 1000 { format!("{}k", photons / 1000) } else { photons.to_string() };
    let suffix = if extra.is_empty() { String::new() } else { format!(" {}", extra.replace('"', "")) };
    Rung {
        series: format!("photonmap {k} fg{gather}{suffix}"),
        label: format!("photonmap {k} spp{spp} fg{gather}{suffix}"),
        spp,
        integrator: format!(
            "SurfaceIntegrator \"photonmap\" \"integer indirectphotons\" [{photons}] \"integer causticphotons\" [{}] \"integer finalgathersamples\" [{gather}] {extra}",
            photons / 4
        ),
    }
}

/// Progressive photon mapping: `passes` passes of `spp` samples per pixel and `photons`
/// indirect photons each.
fn progressive_rung(photons: u32, spp: u32, passes: u32, gather: u32) -> Rung {
    let k = format!("{}k", photons / 1000);
    Rung {
        series: format!("photonmap progressive {k} spp{spp} fg{gather}"),
        label: format!("photonmap progressive {k} spp{spp}x{passes} fg{gather}"),
        spp,
        integrator: format!(
            "SurfaceIntegrator \"photonmap\" \"integer progressive\" [1] \"integer passes\" [{passes}] \"integer indirectphotons\" [{photons}] \"integer finalgathersamples\" [{gather}]"
        ),
    }
}

struct BenchScene {
    name: &'static str,
    rib: PathBuf,
    /// A given reference image, or the spp of our own path-traced one.
    reference: Result<PathBuf, u32>,
    ladder: Vec<Rung>,
}

fn scenes(root: &Path, quick: bool) -> Vec<BenchScene> {
    // `../shared` beside the checkout (or beside a directory above it, for a git worktree).
    let shared = root
        .ancestors()
        .skip(1)
        .map(|d| d.join("shared/reference/cornell"))
        .find(|d| d.join("cornell.rib").is_file())
        .unwrap_or_else(|| root.join("../shared/reference/cornell"));
    let pm = |counts: &[u32], pairs: &[(u32, u32)]| -> Vec<Rung> {
        let mut v = Vec::new();
        for &p in counts {
            for &(spp, g) in pairs {
                v.push(photon_rung(p, spp, g, ""));
            }
        }
        v
    };
    let mut cornell = Vec::new();
    let mut other = Vec::new();
    if quick {
        cornell.extend([direct_rung(4), path_rung(4), path_rung(16)]);
        cornell.extend(pm(&[100_000], &[(4, 4), (8, 8)]));
        other.extend([direct_rung(4), path_rung(4), path_rung(16)]);
        other.extend(pm(&[100_000], &[(4, 4), (8, 8)]));
    } else {
        cornell.extend([direct_rung(4), direct_rung(16)]);
        cornell.extend([4, 8, 16, 32, 64, 128, 256].map(path_rung));
        // The defaults (100k photons, 8 gather rays, the irradiance cache) and progressive
        // photon mapping; 256 spp shows the cache's bias floor.
        cornell.extend(pm(&[100_000], &[(2, 8), (4, 8), (8, 8), (16, 8), (64, 8), (256, 8)]));
        // Without the irradiance cache (the defaults before it), and with fewer rays per record.
        for (extra, spps) in [
            ("\"string irradiancecache\" [\"false\"]", &[4, 16, 64][..]),
            ("\"integer cachesamples\" [64]", &[4, 8, 16][..]),
        ] {
            cornell.extend(spps.iter().map(|&spp| photon_rung(100_000, spp, 8, extra)));
        }
        // Candidates for the defaults near relMSE 1e-3: gather rays against pixel samples.
        cornell.extend(pm(&[100_000], &[(16, 4), (8, 16), (32, 4)]));
        for (photons, gather) in [(100_000, 4), (25_000, 4)] {
            cornell.extend([4, 16, 48].map(|passes| progressive_rung(photons, 1, passes, gather)));
        }
        // Two gather rays per pass, far enough to show the trend toward relMSE 1e-4.
        cornell.extend([32, 128, 512].map(|passes| progressive_rung(25_000, 1, passes, 2)));
        cornell.extend(pm(&[50_000, 200_000, 800_000], &[(2, 4), (4, 4), (4, 8), (8, 8), (16, 8), (16, 16)]));
        // Fewer gather rays for more pixel samples (what pays near relMSE 1e-2), and the bias
        // floor: gather samples far past the point where pixel noise dominates.
        cornell
            .extend(pm(&[50_000, 200_000], &[(4, 2), (8, 2), (8, 4), (16, 2), (16, 4), (16, 32), (64, 16)]));
        // The other parameters, one at a time, at one setting.
        for extra in [
            "\"integer radiancephotons\" [0]",
            "\"integer nused\" [20]",
            "\"integer nused\" [200]",
            "\"string gathersampling\" [\"photons\"]",
        ] {
            cornell.push(photon_rung(200_000, 4, 8, extra));
        }
        other.extend([direct_rung(4), direct_rung(16)]);
        other.extend([4, 16, 64].map(path_rung));
        other.extend(pm(&[50_000, 200_000], &[(4, 4), (8, 8), (16, 16)]));
        other.extend([4, 16].map(|passes| progressive_rung(100_000, 1, passes, 4)));
    }
    vec![
        BenchScene {
            name: "cornell",
            rib: shared.join("cornell.rib"),
            reference: Ok(shared.join("reference-path-11520spp.exr")),
            ladder: cornell,
        },
        BenchScene {
            name: "caustics",
            rib: root.join("examples/caustics/caustics.rib"),
            reference: Err(4096),
            ladder: other.clone(),
        },
        BenchScene {
            name: "room",
            rib: root.join("examples/room/room.rib"),
            reference: Err(2048),
            ladder: other,
        },
    ]
}

/// The scene's RIB with `integrator` placed just before `WorldBegin` (a later
/// `SurfaceIntegrator` replaces an earlier one) and any depth-table request removed (the
/// benchmark times images only).
fn rib_with(rib: &str, integrator: &str) -> Result<String, String> {
    let mut out = String::with_capacity(rib.len() + integrator.len() + 1);
    let mut placed = false;
    for line in rib.lines() {
        let trimmed = line.trim_start();
        if trimmed.starts_with("Option") && trimmed.contains("depthfile") {
            continue;
        }
        if !placed && trimmed.starts_with("WorldBegin") {
            out.push_str(integrator);
            out.push('\n');
            placed = true;
        }
        out.push_str(line);
        out.push('\n');
    }
    if placed { Ok(out) } else { Err("the scene has no WorldBegin".into()) }
}

/// What one child render measured.
struct Measured {
    wall_s: f64,
    /// User plus system CPU time of the child (less sensitive to other load than wall time).
    cpu_s: f64,
    peak_rss_mib: f64,
    prepare_s: f64,
}

/// Runs `lrt-depth` on `rib_path` and waits for it, measuring wall time and peak resident
/// memory (the child's own `ru_maxrss`).
fn render_child(
    lrt: &Path,
    rib_path: &Path,
    out: &Path,
    spp: u32,
    threads: usize,
) -> Result<Measured, String> {
    let mut cmd = Command::new(lrt);
    cmd.arg(rib_path).arg("-o").arg(out).args([
        "--spp",
        &spp.to_string(),
        "--threads",
        &threads.to_string(),
        "--stats",
    ]);
    let run = crate::measure::run_measured(&mut cmd)?;
    if !run.success {
        return Err(format!("lrt-depth failed on {}:\n{}", rib_path.display(), run.stderr));
    }
    let (wall_s, cpu_s, peak_rss_mib, stdout) = (run.wall_s, run.cpu_s, run.peak_rss_mib, run.stdout);
    // "stats: time: parse 0.001 s, build 0.002 s, prepare 1.234 s, render ..."
    let prepare_s = stdout
        .lines()
        .find(|l| l.starts_with("stats: time:"))
        .and_then(|l| l.split(", ").find_map(|part| part.strip_prefix("prepare ")))
        .and_then(|s| s.trim_end_matches(" s").parse().ok())
        .unwrap_or(0.0);
    Ok(Measured { wall_s, cpu_s, peak_rss_mib, prepare_s })
}

pub fn load_average() -> String {
    std::fs::read_to_string("/proc/loadavg")
        .map(|s| s.split_whitespace().take(3).collect::<Vec<_>>().join(" "))
        .unwrap_or_else(|_| "unknown".into())
}

fn cpu_model() -> String {
    std::fs::read_to_string("/proc/cpuinfo")
        .ok()
        .and_then(|s| {
            s.lines()
                .find(|l| l.starts_with("model name"))
                .map(|l| l.split(':').nth(1).unwrap_or("").trim().to_string())
        })
        .unwrap_or_else(|| "unknown CPU".into())
}

/// One result row.
#[derive(Clone, Debug)]
pub struct Row {
    pub scene: String,
    pub series: String,
    pub label: String,
    pub spp: u32,
    pub wall_s: f64,
    pub cpu_s: f64,
    pub prepare_s: f64,
    pub peak_rss_mib: f64,
    pub rmse: f64,
    pub relmse: f64,
    pub load: String,
}

pub fn bench_error(args: &[String]) -> Result<(), String> {
    let mut threads = 2usize;
    let mut quick = false;
    let mut regenerate = false;
    let mut only_scenes: Option<Vec<String>> = None;
    let mut filter: Option<String> = None;
    let mut mitsuba: Option<crate::mitsuba::Variant> = None;
    let mut it = args.iter().peekable();
    let mut fresh = false;
    while let Some(a) = it.next() {
        match a.as_str() {
            "--threads" => {
                threads = it
                    .next()
                    .and_then(|v| v.parse().ok())
                    .filter(|&n| n > 0)
                    .ok_or("--threads needs a number")?
            }
            "--quick" => quick = true,
            "--references" => regenerate = true,
            "--mitsuba" => {
                // `--mitsuba` alone is the scalar variant (as before); `--mitsuba llvm` the vectorised one.
                let variant = it.peek().and_then(|v| crate::mitsuba::Variant::parse(v));
                if variant.is_some() {
                    it.next();
                }
                mitsuba = Some(variant.unwrap_or(crate::mitsuba::Variant::Scalar));
            }
            "--fresh" => fresh = true,
            "--scenes" => {
                only_scenes =
                    Some(it.next().ok_or("--scenes needs a list")?.split(',').map(str::to_string).collect())
            }
            "--filter" => filter = Some(it.next().ok_or("--filter needs a text")?.clone()),
            other => return Err(format!("bench-error: unknown argument {other}")),
        }
    }
    let root = crate::workspace_root();
    crate::run(crate::cargo().args(["build", "--release", "-p", "lrt-depth"]))?;
    let target =
        std::env::var_os("CARGO_TARGET_DIR").map(PathBuf::from).unwrap_or_else(|| root.join("target"));
    let lrt = target.join("release/lrt-depth");
    let out_dir = root.join("target/bench-error");
    let renders = out_dir.join("renders");
    let references = out_dir.join("references");
    for d in [&renders, &references] {
        std::fs::create_dir_all(d).map_err(|e| format!("cannot create {}: {e}", d.display()))?;
    }
    let machine = format!(
        "{} x{} ({} threads used)",
        cpu_model(),
        std::thread::available_parallelism().map(|n| n.get()).unwrap_or(1),
        threads
    );
    eprintln!("bench-error: {machine}, load average {}", load_average());

    let mut rows: Vec<Row> = Vec::new();
    for scene in scenes(&root, quick) {
        if only_scenes.as_ref().is_some_and(|s| !s.iter().any(|n| n == scene.name)) {
            continue;
        }
        let rib = std::fs::read_to_string(&scene.rib)
            .map_err(|e| format!("cannot read {}: {e}", scene.rib.display()))?;
        let reference_path = match &scene.reference {
            Ok(p) => p.clone(),
            Err(spp) => {
                let p = references.join(format!("{}-path-{spp}spp.exr", scene.name));
                if regenerate || !p.exists() {
                    eprintln!(
                        "bench-error: rendering the {} reference (path tracing, {spp} spp; cached in {})",
                        scene.name,
                        p.display()
                    );
                    let text = rib_with(&rib, "SurfaceIntegrator \"path\"")?;
                    let tmp = temp_rib(&out_dir, scene.name, "reference", &text)?;
                    let partial = p.with_extension("partial.exr");
                    let m = render_child(&lrt, &tmp, &partial, *spp, threads)?;
                    std::fs::rename(&partial, &p)
                        .map_err(|e| format!("cannot move the reference into place: {e}"))?;
                    eprintln!("bench-error: reference rendered in {:.1} s", m.wall_s);
                }
                p
            }
        };
        let reference = read_exr(&reference_path)?;
        for rung in &scene.ladder {
            if filter.as_ref().is_some_and(|f| !f.split('|').any(|f| rung.label.contains(f))) {
                continue;
            }
            let text = rib_with(&rib, &rung.integrator)?;
            let slug = rung.label.replace(' ', "-");
            let tmp = temp_rib(&out_dir, scene.name, &slug, &text)?;
            let image_path = renders.join(format!("{}-{slug}.exr", scene.name));
            let load = load_average();
            let m = render_child(&lrt, &tmp, &image_path, rung.spp, threads)?;
            let (rmse, relmse) = errors(&read_exr(&image_path)?, &reference)?;
            eprintln!(
                "bench-error: {:9} {:40} {:8.2} s (cpu {:7.2} s, photons {:6.2} s) {:7.1} MiB  RMSE {rmse:.3e}  relMSE {relmse:.3e}  load {load}",
                scene.name, rung.label, m.wall_s, m.cpu_s, m.prepare_s, m.peak_rss_mib
            );
            rows.push(Row {
                scene: scene.name.into(),
                series: rung.series.clone(),
                label: rung.label.clone(),
                spp: rung.spp,
                wall_s: m.wall_s,
                cpu_s: m.cpu_s,
                prepare_s: m.prepare_s,
                peak_rss_mib: m.peak_rss_mib,
                rmse,
                relmse,
                load,
            });
        }
        if let Some(variant) = mitsuba.filter(|_| scene.name == "cornell") {
            let spps: &[u32] = match (quick, variant) {
                (true, _) => &[16],
                (false, crate::mitsuba::Variant::Scalar) => &[16, 32, 64, 128],
                (false, crate::mitsuba::Variant::Llvm) => &[16, 64, 256],
            };
            rows.extend(crate::mitsuba::rows(&out_dir, &reference, spps, threads, variant)?);
        }
    }
    if !fresh {
        rows = merge_with_previous(&out_dir.join("results.csv"), rows);
    }
    write_outputs(&out_dir, &rows, &machine)?;
    if !quick {
        charts_to_docs(&root, &out_dir, &rows)?;
    }
    Ok(())
}

/// Converts each scene's SVG plot to `docs/error-vs-time-<scene>.png`.
fn charts_to_docs(root: &Path, out_dir: &Path, rows: &[Row]) -> Result<(), String> {
    crate::install_packages(&["librsvg2-bin"], "rsvg-convert (librsvg2-bin)")?;
    let mut scenes: Vec<&str> = rows.iter().map(|r| r.scene.as_str()).collect();
    scenes.dedup();
    for scene in scenes {
        let svg = out_dir.join(format!("error-vs-time-{scene}.svg"));
        let png = root.join(format!("docs/error-vs-time-{scene}.png"));
        let tmp = png.with_extension("png.tmp");
        crate::run(Command::new("rsvg-convert").arg("-f").arg("png").arg("-o").arg(&tmp).arg(&svg))?;
        std::fs::rename(&tmp, &png).map_err(|e| format!("cannot move {} into place: {e}", png.display()))?;
    }
    Ok(())
}

/// The rows of an earlier `results.csv` with this run's rows in place of those with the same
/// scene and label, and new ones appended (so `--filter` and `--scenes` runs add to one table).
fn merge_with_previous(csv: &Path, new_rows: Vec<Row>) -> Vec<Row> {
    let Ok(text) = std::fs::read_to_string(csv) else { return new_rows };
    let mut merged: Vec<Row> = text.lines().skip(1).filter_map(parse_row).collect();
    for row in new_rows {
        match merged.iter_mut().find(|r| r.scene == row.scene && r.label == row.label) {
            Some(old) => *old = row,
            None => merged.push(row),
        }
    }
    merged
}

/// One row as a line of `results.csv`.
fn csv_line(r: &Row) -> String {
    format!(
        "{},{},{},{},{:.3},{:.3},{:.3},{:.1},{:.5e},{:.5e},{}",
        r.scene,
        r.series,
        r.label,
        r.spp,
        r.wall_s,
        r.cpu_s,
        r.prepare_s,
        r.peak_rss_mib,
        r.rmse,
        r.relmse,
        r.load
    )
}

/// One line of `results.csv` (as [`csv_line`] writes it); `None` if it is not one.
fn parse_row(line: &str) -> Option<Row> {
    let f: Vec<&str> = line.split(',').collect();
    let [scene, series, label, spp, wall_s, cpu_s, prepare_s, peak_rss_mib, rmse, relmse, load] = f[..]
    else {
        return None;
    };
    Some(Row {
        scene: scene.into(),
        series: series.into(),
        label: label.into(),
        spp: spp.parse().ok()?,
        wall_s: wall_s.parse().ok()?,
        cpu_s: cpu_s.parse().ok()?,
        prepare_s: prepare_s.parse().ok()?,
        peak_rss_mib: peak_rss_mib.parse().ok()?,
        rmse: rmse.parse().ok()?,
        relmse: relmse.parse().ok()?,
        load: load.into(),
    })
}

/// Writes a modified scene under `target/bench-error/ribs` (the benchmark's scenes read no
/// archives, so they render the same from there).
fn temp_rib(out_dir: &Path, scene: &str, slug: &str, text: &str) -> Result<PathBuf, String> {
    let dir = out_dir.join("ribs");
    std::fs::create_dir_all(&dir).map_err(|e| format!("cannot create {}: {e}", dir.display()))?;
    let path = dir.join(format!("{scene}-{slug}.rib"));
    std::fs::write(&path, text).map_err(|e| format!("cannot write {}: {e}", path.display()))?;
    Ok(path)
}

fn write_outputs(out_dir: &Path, rows: &[Row], machine: &str) -> Result<(), String> {
    let mut csv =
        String::from("scene,series,label,spp,wall_s,cpu_s,prepare_s,peak_rss_mib,rmse,relmse,load_average\n");
    for r in rows {
        csv.push_str(&csv_line(r));
        csv.push('\n');
    }
    write_atomic(&out_dir.join("results.csv"), &csv)?;
    let mut table = format!(
        "Machine: {machine}.\n\n| scene | setting | wall s | CPU s | photons s | peak MiB | RMSE | relMSE | load |\n|---|---|---|---|---|---|---|---|---|\n"
    );
    for r in rows {
        let _ = writeln!(
            table,
            "| {} | {} | {:.2} | {:.2} | {:.2} | {:.0} | {:.2e} | {:.2e} | {} |",
            r.scene, r.label, r.wall_s, r.cpu_s, r.prepare_s, r.peak_rss_mib, r.rmse, r.relmse, r.load
        );
    }
    write_atomic(&out_dir.join("table.md"), &table)?;
    let mut scenes: Vec<&str> = rows.iter().map(|r| r.scene.as_str()).collect();
    scenes.dedup();
    for scene in scenes {
        let scene_rows: Vec<&Row> = rows.iter().filter(|r| r.scene == scene).collect();
        write_atomic(&out_dir.join(format!("error-vs-time-{scene}.svg")), &svg_plot(scene, &scene_rows))?;
    }
    eprintln!("bench-error: wrote {}/results.csv, table.md and error-vs-time-*.svg", out_dir.display());
    Ok(())
}

fn write_atomic(path: &Path, text: &str) -> Result<(), String> {
    let tmp = path.with_extension("tmp");
    std::fs::write(&tmp, text).map_err(|e| format!("cannot write {}: {e}", tmp.display()))?;
    std::fs::rename(&tmp, path).map_err(|e| format!("cannot rename to {}: {e}", path.display()))
}

/// A log-log plot of relative MSE against CPU time, one polyline per series (points in
/// increasing time), with the relMSE 1e-2 bar drawn.
fn svg_plot(scene: &str, rows: &[&Row]) -> String {
    let (w, h) = (960.0, 560.0);
    let (left, right, top, bottom) = (80.0, 300.0, 40.0, 60.0);
    // CPU time, not wall time: on a shared machine wall time carries the other users' load.
    let finite: Vec<&&Row> = rows.iter().filter(|r| r.cpu_s > 0.0 && r.relmse > 0.0).collect();
    let lx = |v: f64| v.log10();
    let (mut x0, mut x1, mut y0, mut y1) =
        (f64::INFINITY, f64::NEG_INFINITY, f64::INFINITY, f64::NEG_INFINITY);
    for r in &finite {
        x0 = x0.min(lx(r.cpu_s));
        x1 = x1.max(lx(r.cpu_s));
        y0 = y0.min(lx(r.relmse));
        y1 = y1.max(lx(r.relmse));
    }
    y0 = y0.min(-2.0);
    y1 = y1.max(-2.0);
    let (x0, x1, y0, y1) =
        (x0.floor(), x1.ceil().max(x0.floor() + 1.0), y0.floor(), y1.ceil().max(y0.floor() + 1.0));
    let px = |v: f64| left + (lx(v) - x0) / (x1 - x0) * (w - left - right);
    let py = |v: f64| top + (y1 - lx(v)) / (y1 - y0) * (h - top - bottom);
    let mut s = format!(
        "<svg xmlns=\"http://www.w3.org/2000/svg\" width=\"{w}\" height=\"{h}\" font-family=\"sans-serif\" font-size=\"12\">\n<rect width=\"100%\" height=\"100%\" fill=\"white\"/>\n<text x=\"{left}\" y=\"24\" font-size=\"16\">{scene}: relative MSE against CPU time (log-log)</text>\n"
    );
    // Grid and axes.
    for e in (x0 as i32)..=(x1 as i32) {
        let x = px(10f64.powi(e));
        let _ = writeln!(
            s,
            "<line x1=\"{x:.1}\" y1=\"{top}\" x2=\"{x:.1}\" y2=\"{:.1}\" stroke=\"#ddd\"/><text x=\"{x:.1}\" y=\"{:.1}\" text-anchor=\"middle\">{}</text>",
            h - bottom,
            h - bottom + 18.0,
            fmt_pow(e, "s")
        );
    }
    for e in (y0 as i32)..=(y1 as i32) {
        let y = py(10f64.powi(e));
        let _ = writeln!(
            s,
            "<line x1=\"{left}\" y1=\"{y:.1}\" x2=\"{:.1}\" y2=\"{y:.1}\" stroke=\"#ddd\"/><text x=\"{:.1}\" y=\"{:.1}\" text-anchor=\"end\">{}</text>",
            w - right,
            left - 6.0,
            y + 4.0,
            fmt_pow(e, "")
        );
    }
    // The bars of the issues' targets: 1e-2, then 5e-3, 1e-3 and 1e-4 (issue 12).
    for (value, name) in [(1e-2, "1e-2"), (5e-3, "5e-3"), (1e-3, "1e-3"), (1e-4, "1e-4")] {
        if lx(value) < y0 || lx(value) > y1 {
            continue;
        }
        let bar = py(value);
        let _ = writeln!(
            s,
            "<line x1=\"{left}\" y1=\"{bar:.1}\" x2=\"{:.1}\" y2=\"{bar:.1}\" stroke=\"#c00\" stroke-dasharray=\"6 4\"/><text x=\"{:.1}\" y=\"{:.1}\" fill=\"#c00\" text-anchor=\"end\">relMSE {name}</text>",
            w - right,
            w - right - 4.0,
            bar - 4.0
        );
    }
    let _ = writeln!(
        s,
        "<text x=\"{:.1}\" y=\"{:.1}\" text-anchor=\"middle\">CPU time, user + system (s)</text>",
        (left + w - right) / 2.0,
        h - 16.0
    );
    let _ = writeln!(
        s,
        "<text x=\"18\" y=\"{:.1}\" transform=\"rotate(-90 18 {:.1})\" text-anchor=\"middle\">relMSE</text>",
        (top + h - bottom) / 2.0,
        (top + h - bottom) / 2.0
    );
    let colours = [
        "#1f77b4", "#ff7f0e", "#2ca02c", "#d62728", "#9467bd", "#8c564b", "#e377c2", "#7f7f7f", "#bcbd22",
        "#17becf",
    ];
    let mut series: Vec<&str> = Vec::new();
    for r in &finite {
        if !series.contains(&r.series.as_str()) {
            series.push(&r.series);
        }
    }
    for (i, name) in series.iter().enumerate() {
        let c = colours[i % colours.len()];
        let mut pts: Vec<&&Row> = finite.iter().copied().filter(|r| r.series == *name).collect();
        pts.sort_by(|a, b| a.cpu_s.total_cmp(&b.cpu_s));
        let path: Vec<String> =
            pts.iter().map(|r| format!("{:.1},{:.1}", px(r.cpu_s), py(r.relmse))).collect();
        let _ = writeln!(
            s,
            "<polyline points=\"{}\" fill=\"none\" stroke=\"{c}\" stroke-width=\"1.5\"/>",
            path.join(" ")
        );
        for r in &pts {
            let _ = writeln!(
                s,
                "<circle cx=\"{:.1}\" cy=\"{:.1}\" r=\"3\" fill=\"{c}\"><title>{} {:.2} CPU s relMSE {:.3e}</title></circle>",
                px(r.cpu_s),
                py(r.relmse),
                r.label,
                r.cpu_s,
                r.relmse
            );
        }
        let ly = top + 10.0 + 18.0 * i as f64;
        let _ = writeln!(
            s,
            "<line x1=\"{:.1}\" y1=\"{ly:.1}\" x2=\"{:.1}\" y2=\"{ly:.1}\" stroke=\"{c}\" stroke-width=\"3\"/><text x=\"{:.1}\" y=\"{:.1}\">{}</text>",
            w - right + 12.0,
            w - right + 36.0,
            w - right + 42.0,
            ly + 4.0,
            name
        );
    }
    s.push_str("</svg>\n");
    s
}

fn fmt_pow(e: i32, unit: &str) -> String {
    let v = 10f64.powi(e);
    if (-2..=3).contains(&e) { format!("{}{unit}", v) } else { format!("1e{e}{unit}") }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn integrator_goes_before_world_begin_and_depth_requests_go() {
        let rib = "Option \"lrt\" \"string depthfile\" [\"x.depth\"]\nFormat 4 4 1\nWorldBegin\nWorldEnd\n";
        let out = rib_with(rib, "SurfaceIntegrator \"path\"").unwrap();
        assert_eq!(out, "Format 4 4 1\nSurfaceIntegrator \"path\"\nWorldBegin\nWorldEnd\n");
        assert!(rib_with("Format 4 4 1\n", "x").is_err());
    }

    #[test]
    fn metrics() {
        let a = Rgb { width: 1, height: 1, pixels: vec![[1.0, 0.0, 0.5]] };
        let b = Rgb { width: 1, height: 1, pixels: vec![[1.0, 0.1, 0.5]] };
        let (rmse, rel) = errors(&a, &b).unwrap();
        assert!((rmse - (0.01f64 / 3.0).sqrt()).abs() < 1e-7);
        assert!((rel - 0.01 / 0.02 / 3.0).abs() < 1e-6);
        let c = Rgb { width: 2, height: 1, pixels: vec![[0.0; 3]; 2] };
        assert!(errors(&a, &c).is_err());
    }

    #[test]
    fn results_merge_by_scene_and_label() {
        let row = |label: &str, wall_s: f64| Row {
            scene: "cornell".into(),
            series: "path".into(),
            label: label.into(),
            spp: 4,
            wall_s,
            cpu_s: 1.5,
            prepare_s: 0.0,
            peak_rss_mib: 17.0,
            rmse: 5.962e-2,
            relmse: 5.754e-2,
            load: "2.37 2.16 3.97".into(),
        };
        let parsed = parse_row(&csv_line(&row("path spp4", 2.5))).unwrap();
        assert_eq!((parsed.label.as_str(), parsed.wall_s, parsed.relmse), ("path spp4", 2.5, 5.754e-2));
        assert!(parse_row("scene,series,label").is_none());
        let dir = tempfile::Builder::new().prefix("bench-error-merge-").tempdir().unwrap();
        let csv = dir.path().join("results.csv");
        let old = [row("path spp4", 2.5), row("path spp8", 5.0)];
        let text: String = old.iter().map(|r| csv_line(r) + "\n").collect();
        std::fs::write(&csv, format!("header\n{text}")).unwrap();
        let merged = merge_with_previous(&csv, vec![row("path spp8", 4.0), row("path spp16", 9.0)]);
        let got: Vec<(&str, f64)> = merged.iter().map(|r| (r.label.as_str(), r.wall_s)).collect();
        assert_eq!(got, [("path spp4", 2.5), ("path spp8", 4.0), ("path spp16", 9.0)]);
    }
}
