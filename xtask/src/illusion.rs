//! `cargo xtask illusion [--spp N] [--size N] [--scenes a,b] [--reuse] [--viewer-arg ARG]... [--frame-sizes 512,2048] [--placements SCENE:X,Y,Z,R;...]`: how well a live object passes
//! for part of the ray-traced scene (issue 10).
//!
//! For each scene (the Cornell box, the caustics scene, the room), each placement and each
//! material of a sphere, `lrt-depth` renders the scene without the sphere (the image the viewer
//! shows) and the scene with `ReadArchive "live.rib"` before `WorldEnd` (the ground truth, the
//! same seed), both with photon mapping at `--size` pixels and `--spp` samples. `hybrid-view`
//! then composites the same `live.rib` over the first render (`--live`, `--screenshot OUT.exr`,
//! linear radiance as CONTRACTS §6 fixes it) and the composite is measured against the truth,
//! relMSE `(x - r)^2 / (r^2 + 0.01)` averaged over pixels and channels, in three regions:
//!
//! - inside: pixels of the viewer's `--mask` (where the live object is visible);
//! - changed: other pixels where the truth differs from the render without the object (shadow,
//!   bounce light, reflections) by more than 3% of the local brightness, both averaged over
//!   5x5 pixels so that noise alone does not select a pixel;
//! - elsewhere: all other pixels.
//!
//! Then the viewer's frame time at 512^2 and 2048^2 (`--headless --frames 20 --stats`; `--frame-sizes`
//! picks the sizes, an empty list none).
//! Writes `docs/illusion.md` and one picture per scene, `docs/illusion-SCENE.png` (truth,
//! composite, render without the object and 4x the absolute error, for each material at the
//! first placement). With `--placements SCENE:X,Y,Z,R;...` the given spheres replace the
//! scenes' own placements (scenes without one are left out) and the table goes to
//! `target/illusion/placements.md`, without pictures or frame times: a check on placements
//! nobody tuned for.

use crate::bench_error::{Rgb, load_average, read_exr};
use crate::measure::run_measured;
use crate::{cargo, run, workspace_root};
use std::fmt::Write as _;
use std::path::{Path, PathBuf};
use std::process::Command;

/// A sphere placed in a scene, in world coordinates.
#[derive(Debug)]
struct Placement {
    centre: [f64; 3],
    radius: f64,
    /// What the placement tests, for the table.
    what: String,
}

struct IllusionScene {
    name: &'static str,
    rib: PathBuf,
    placements: Vec<Placement>,
}

/// Materials of the live sphere, as `live.rib` lines.
const MATERIALS: &[(&str, &str)] = &[
    ("matte", "Color [0.2 0.3 0.8]\n  Surface \"matte\""),
    ("plastic", "Color [0.2 0.3 0.8]\n  Surface \"plastic\" \"Ks\" [0.5] \"roughness\" [0.1]"),
];

fn scenes(root: &Path) -> Vec<IllusionScene> {
    let p = |centre: [f64; 3], radius: f64, what: &str| Placement { centre, radius, what: what.to_string() };
    vec![
        IllusionScene {
            name: "cornell",
            rib: root.join("examples/cornell/cornell.rib"),
            placements: vec![
                p([-0.35, -0.55, 0.55], 0.3, "issue 10's placement, above the floor"),
                p([0.45, -0.7, -0.3], 0.3, "resting on the floor"),
                p([0.1, 0.35, 0.0], 0.2, "floating under the light"),
            ],
        },
        IllusionScene {
            name: "caustics",
            rib: root.join("examples/caustics/caustics.rib"),
            placements: vec![
                p([-0.3, -0.79, 0.5], 0.2, "on the floor, in front of the mirror sphere"),
                p([-0.6, 0.1, -0.4], 0.2, "floating by the red wall"),
                p([0.0, 0.2, 0.4], 0.2, "floating"),
            ],
        },
        IllusionScene {
            name: "room",
            rib: root.join("examples/room/room.rib"),
            placements: vec![
                p([0.3, 0.35, -1.3], 0.35, "on the floor, in front"),
                p([-0.4, 0.4, -0.5], 0.4, "on the floor, under the spot light"),
                p([1.0, 1.6, -0.6], 0.3, "floating"),
            ],
        },
    ]
}

/// The scene's RIB rendered by photon mapping at `size` pixels on its longer side: a
/// `SurfaceIntegrator "photonmap"` (with the defaults) goes before `WorldBegin` unless the scene
/// already uses one, `Format` is scaled, and `live` (if any) is read just before the last
/// `WorldEnd`. Depth and display requests are left to `lrt-depth`'s `-o` and `--depth`.
fn scene_rib(rib: &str, size: u32, live: Option<&Path>) -> Result<String, String> {
    let has_photonmap = rib.lines().any(|l| {
        let t = l.trim_start();
        t.starts_with("SurfaceIntegrator") && t.contains("\"photonmap\"")
    });
    let last_world_end = rib
        .lines()
        .enumerate()
        .filter(|(_, l)| l.trim_start().starts_with("WorldEnd"))
        .map(|(i, _)| i)
        .last()
        .ok_or("the scene has no WorldEnd")?;
    let mut out = String::with_capacity(rib.len() + 256);
    let mut placed = has_photonmap;
    for (i, line) in rib.lines().enumerate() {
        let t = line.trim_start();
        if t.starts_with("Option") && t.contains("depthfile") {
            continue;
        }
        if t.starts_with("Format") {
            let v: Vec<f64> = t.split_whitespace().skip(1).filter_map(|w| w.parse().ok()).collect();
            if let [w, h, ..] = v[..] {
                let scale = f64::from(size) / w.max(h);
                let aspect = v.get(2).copied().unwrap_or(1.0);
                let _ = writeln!(
                    out,
                    "Format {} {} {aspect}",
                    (w * scale).round().max(1.0),
                    (h * scale).round().max(1.0)
                );
                continue;
            }
        }
        if !placed && t.starts_with("WorldBegin") {
            out.push_str("SurfaceIntegrator \"photonmap\"\n");
            placed = true;
        }
        if i == last_world_end
            && let Some(live) = live
        {
            let _ = writeln!(out, "ReadArchive \"{}\"", live.display());
        }
        out.push_str(line);
        out.push('\n');
    }
    if !placed {
        return Err("the scene has no WorldBegin".into());
    }
    Ok(out)
}

fn live_rib(placement: &Placement, material: &str) -> String {
    let [x, y, z] = placement.centre;
    format!(
        "# A live sphere for cargo xtask illusion.\nAttributeBegin\n  {material}\n  Translate {x} {y} {z}\n  \
         Sphere {r} {mr} {r} 360\nAttributeEnd\n",
        r = placement.radius,
        mr = -placement.radius
    )
}

fn write(path: &Path, text: &str) -> Result<(), String> {
    std::fs::write(path, text).map_err(|e| format!("cannot write {}: {e}", path.display()))
}

/// What a render was made from besides its RIB text: the sample count and `made_from` (the
/// text of the live archive it reads, or the renderer's digest; empty for none). `--reuse`
/// takes a render made from the same RIB text, archive and sample count, trusting that the
/// renderer has not changed in between (use it to remeasure the viewer, not the renderer).
fn render_stamp(spp: u32, made_from: &str) -> String {
    format!("spp {spp}\n{made_from}")
}

/// A digest of the renderer's binary, so that the frame-time renders, which are always reused,
/// are made again when the renderer changes (a new sidecar layer must reach the viewer's
/// frame). `DefaultHasher::new()` has fixed keys, so the digest is the same run after run.
fn renderer_digest(lrt: &Path) -> Result<String, String> {
    use std::hash::Hasher;
    let bytes = std::fs::read(lrt).map_err(|e| format!("cannot read {}: {e}", lrt.display()))?;
    let mut hasher = std::collections::hash_map::DefaultHasher::new();
    hasher.write(&bytes);
    Ok(format!("renderer {:016x} ({} bytes)", hasher.finish(), bytes.len()))
}

/// Renders `rib_text` with `lrt-depth` into `dir/name.exr` and `dir/name.depth` (with its
/// light layers beside them); with `reuse`, a render already there from the same RIB text,
/// sample count and `made_from` is taken as it is.
fn render(
    lrt: &Path,
    dir: &Path,
    name: &str,
    rib_text: &str,
    spp: u32,
    reuse: bool,
    made_from: &str,
) -> Result<(PathBuf, PathBuf), String> {
    let rib = dir.join(format!("{name}.rib"));
    let (image, depth) = (dir.join(format!("{name}.exr")), dir.join(format!("{name}.depth")));
    let stamp_path = dir.join(format!("{name}.stamp"));
    let stamp = render_stamp(spp, made_from);
    if reuse
        && image.exists()
        && depth.exists()
        && std::fs::read_to_string(&rib).is_ok_and(|t| t == rib_text)
        && std::fs::read_to_string(&stamp_path).is_ok_and(|t| t == stamp)
    {
        eprintln!("illusion: reusing {}", image.display());
        return Ok((image, depth));
    }
    let _ = std::fs::remove_file(&stamp_path);
    write(&rib, rib_text)?;
    let mut cmd = Command::new(lrt);
    cmd.current_dir(dir).arg(&rib).arg("-o").arg(&image).arg("--depth").arg(&depth);
    cmd.args(["--spp", &spp.to_string()]);
    let r = run_measured(&mut cmd)?;
    if !r.success {
        return Err(format!("lrt-depth failed on {}:\n{}", rib.display(), r.stderr));
    }
    eprintln!("illusion: rendered {} in {:.1} s", image.display(), r.wall_s);
    write(&stamp_path, &stamp)?;
    Ok((image, depth))
}

/// The composite of `live` over `image`, as linear radiance, and the live object's mask.
fn composite(
    viewer: &Path,
    viewer_args: &[String],
    (image, depth): (&Path, &Path),
    scene_rib: &Path,
    live: &Path,
    out: &Path,
) -> Result<(Rgb, Vec<bool>), String> {
    let (shot, mask) = (out.with_extension("exr"), out.with_extension("mask.png"));
    let mut cmd = Command::new(viewer);
    cmd.arg(image).arg(depth).arg(scene_rib).arg("--live").arg(live).arg("--headless");
    cmd.arg("--screenshot").arg(&shot).arg("--mask").arg(&mask).args(viewer_args);
    let r = run_measured(&mut cmd)?;
    if !r.success {
        return Err(format!("hybrid-view failed:\n{}", r.stderr));
    }
    let magic = std::fs::read(&shot).map_err(|e| format!("{}: {e}", shot.display()))?;
    if !magic.starts_with(&[0x76, 0x2f, 0x31, 0x01]) {
        return Err(format!(
            "hybrid-view wrote {} but not as OpenEXR: this viewer has no linear `--screenshot OUT.exr` (CONTRACTS §6)",
            shot.display()
        ));
    }
    let rgb = read_exr(&shot)?;
    let mask_image = image::open(&mask).map_err(|e| format!("{}: {e}", mask.display()))?.to_luma8();
    if (mask_image.width() as usize, mask_image.height() as usize) != (rgb.width, rgb.height) {
        return Err("the mask and the screenshot differ in size".into());
    }
    Ok((rgb, mask_image.pixels().map(|p| p.0[0] > 127).collect()))
}

/// Mean over a `(2k+1)^2` window of each pixel's channel mean.
fn box_mean(values: &[f64], width: usize, height: usize, k: usize) -> Vec<f64> {
    let mut out = vec![0.0; values.len()];
    for y in 0..height {
        for x in 0..width {
            let (mut sum, mut n) = (0.0, 0.0);
            for yy in y.saturating_sub(k)..(y + k + 1).min(height) {
                for xx in x.saturating_sub(k)..(x + k + 1).min(width) {
                    sum += values[yy * width + xx];
                    n += 1.0;
                }
            }
            out[y * width + x] = sum / n;
        }
    }
    out
}

#[derive(Clone, Copy, PartialEq, Debug)]
enum Region {
    Inside,
    Changed,
    Elsewhere,
}

/// Each pixel's region (see the module documentation).
fn regions(mask: &[bool], truth: &Rgb, without: &Rgb) -> Vec<Region> {
    let (w, h) = (truth.width, truth.height);
    let mean = |p: &[f32; 3]| (f64::from(p[0]) + f64::from(p[1]) + f64::from(p[2])) / 3.0;
    let diff: Vec<f64> = truth
        .pixels
        .iter()
        .zip(&without.pixels)
        .map(|(a, b)| (0..3).map(|c| (f64::from(a[c]) - f64::from(b[c])).abs()).sum::<f64>() / 3.0)
        .collect();
    let level: Vec<f64> = without.pixels.iter().map(mean).collect();
    let (diff, level) = (box_mean(&diff, w, h, 2), box_mean(&level, w, h, 2));
    (0..w * h)
        .map(|i| {
            if mask[i] {
                Region::Inside
            } else if diff[i] > 0.03 * (level[i] + 0.01) {
                Region::Changed
            } else {
                Region::Elsewhere
            }
        })
        .collect()
}

/// relMSE of `image` against `truth` over the pixels of `region`, and their count.
fn region_error(image: &Rgb, truth: &Rgb, regions: &[Region], region: Region) -> (f64, usize) {
    let (mut sum, mut n) = (0.0, 0usize);
    for ((a, b), r) in image.pixels.iter().zip(&truth.pixels).zip(regions) {
        if *r != region {
            continue;
        }
        for c in 0..3 {
            let (x, t) = (f64::from(a[c]), f64::from(b[c]));
            sum += (x - t) * (x - t) / (t * t + 0.01);
        }
        n += 1;
    }
    (if n > 0 { sum / (3 * n) as f64 } else { f64::NAN }, n)
}

fn srgb8(v: f32) -> u8 {
    let v = v.clamp(0.0, 1.0);
    let s = if v <= 0.003_130_8 { 12.92 * v } else { 1.055 * v.powf(1.0 / 2.4) - 0.055 };
    (s * 255.0 + 0.5) as u8
}

/// Tiles of equal size side by side, rows top to bottom, display-encoded as sRGB.
fn contact_sheet(rows: &[Vec<Rgb>], path: &Path) -> Result<(), String> {
    let Some(first) = rows.first().and_then(|r| r.first()) else { return Ok(()) };
    let (w, h) = (first.width, first.height);
    let cols = rows.iter().map(Vec::len).max().unwrap_or(0);
    let gap = 4;
    let (sw, sh) = (cols * w + (cols - 1) * gap, rows.len() * h + (rows.len() - 1) * gap);
    let mut sheet = image::RgbImage::from_pixel(sw as u32, sh as u32, image::Rgb([255, 255, 255]));
    for (r, row) in rows.iter().enumerate() {
        for (c, tile) in row.iter().enumerate() {
            for y in 0..h.min(tile.height) {
                for x in 0..w.min(tile.width) {
                    let p = tile.pixels[y * tile.width + x];
                    let (px, py) = ((c * (w + gap) + x) as u32, (r * (h + gap) + y) as u32);
                    sheet.put_pixel(px, py, image::Rgb(p.map(srgb8)));
                }
            }
        }
    }
    let tmp = path.with_extension("tmp.png");
    sheet.save(&tmp).map_err(|e| format!("cannot write {}: {e}", tmp.display()))?;
    std::fs::rename(&tmp, path).map_err(|e| format!("cannot rename to {}: {e}", path.display()))
}

/// Median frame time in ms of the viewer over the image at `size`, from `--stats`.
fn frame_time(
    viewer: &Path,
    viewer_args: &[String],
    lrt: &Path,
    dir: &Path,
    scene: &IllusionScene,
    size: u32,
) -> Result<f64, String> {
    let text = std::fs::read_to_string(&scene.rib).map_err(|e| format!("{}: {e}", scene.rib.display()))?;
    let name = format!("{}-frames-{size}", scene.name);
    let digest = renderer_digest(lrt)?;
    let (image, depth) = render(lrt, dir, &name, &scene_rib(&text, size, None)?, 1, true, &digest)?;
    let live = dir.join(format!("{name}-live.rib"));
    write(&live, &live_rib(&scene.placements[0], MATERIALS[1].1))?;
    let mut cmd = Command::new(viewer);
    cmd.arg(&image).arg(&depth).arg(dir.join(format!("{name}.rib"))).arg("--live").arg(&live);
    // Every frame drawn: a still sphere's frames after the first are otherwise kept as drawn.
    cmd.args(["--headless", "--frames", "20", "--stats", "--redraw-at-rest"]).args(viewer_args);
    let r = run_measured(&mut cmd)?;
    if !r.success {
        return Err(format!("hybrid-view failed:\n{}", r.stderr));
    }
    // "frames: 20, frame time (render + wait) mean 1.234 ms, median 1.200 ms, min 1.100 ms"
    r.stderr
        .lines()
        .find_map(|l| {
            l.split("median ").nth(1).and_then(|s| s.split(" ms").next()).and_then(|s| s.parse().ok())
        })
        .ok_or_else(|| format!("no frame time in hybrid-view's --stats:\n{}", r.stderr))
}

/// `--placements SCENE:X,Y,Z,R;...`: spheres (centre and radius in the scene's world space)
/// to measure instead of the scenes' own placements, for placements nobody tuned for.
fn parse_placements(text: &str) -> Result<Vec<(String, Placement)>, String> {
    text.split(';')
        .filter(|s| !s.trim().is_empty())
        .map(|item| {
            let (scene, numbers) =
                item.split_once(':').ok_or_else(|| format!("--placements: '{item}' is not SCENE:X,Y,Z,R"))?;
            let v: Vec<f64> = numbers
                .split(',')
                .map(|n| n.trim().parse::<f64>().ok().filter(|v| v.is_finite()))
                .collect::<Option<_>>()
                .ok_or_else(|| format!("--placements: '{numbers}' is not four numbers X,Y,Z,R"))?;
            match v[..] {
                [x, y, z, r] if r > 0.0 => Ok((
                    scene.trim().to_string(),
                    Placement {
                        centre: [x, y, z],
                        radius: r,
                        what: format!("given: centre {x} {y} {z}, radius {r}"),
                    },
                )),
                _ => Err(format!("--placements: '{numbers}' is not X,Y,Z and a positive radius R")),
            }
        })
        .collect()
}

pub fn illusion(args: &[String]) -> Result<(), String> {
    let (mut spp, mut size, mut only): (u32, u32, Option<Vec<String>>) = (64, 256, None);
    let mut reuse = false;
    let mut viewer_args = Vec::new();
    let mut frame_sizes = vec![512u32, 2048];
    let mut given: Option<Vec<(String, Placement)>> = None;
    let mut given_text = String::new();
    let mut it = args.iter();
    while let Some(a) = it.next() {
        let mut value = || it.next().ok_or(format!("{a} needs a value"));
        match a.as_str() {
            "--spp" => spp = value()?.parse().map_err(|_| "--spp needs a count")?,
            "--size" => size = value()?.parse().map_err(|_| "--size needs a pixel count")?,
            "--scenes" => only = Some(value()?.split(',').map(str::to_string).collect()),
            "--reuse" => reuse = true,
            "--placements" => {
                given_text = value()?.clone();
                given = Some(parse_placements(&given_text)?);
            }
            "--viewer-arg" => viewer_args.push(value()?.clone()),
            "--frame-sizes" => {
                frame_sizes = value()?
                    .split(',')
                    .filter(|s| !s.is_empty())
                    .map(|s| s.parse().map_err(|_| format!("--frame-sizes: '{s}' is not a pixel count")))
                    .collect::<Result<_, _>>()?
            }
            other => return Err(format!("illusion: unknown argument {other}")),
        }
    }
    run(cargo().args(["build", "--release", "-p", "lrt-depth", "-p", "hybrid-view"]))?;
    let root = workspace_root();
    let target =
        std::env::var_os("CARGO_TARGET_DIR").map(PathBuf::from).unwrap_or_else(|| root.join("target"));
    let (lrt, viewer) = (target.join("release/lrt-depth"), target.join("release/hybrid-view"));
    let dir = target.join("illusion");
    std::fs::create_dir_all(&dir).map_err(|e| format!("{}: {e}", dir.display()))?;
    let load_start = load_average();

    let mut table = String::new();
    let mut pictures = Vec::new();
    let mut frames = String::new();
    let mut all = scenes(&root);
    if let Some(given) = given {
        // Given placements replace the scene's own; scenes without any are left out, and so
        // are the pictures and frame times, which belong to the table in docs/.
        for scene in &mut all {
            scene.placements.clear();
        }
        for (name, placement) in given {
            let scene = all
                .iter_mut()
                .find(|s| s.name == name)
                .ok_or_else(|| format!("--placements: no scene '{name}' (cornell, caustics, room)"))?;
            scene.placements.push(placement);
        }
        all.retain(|s| !s.placements.is_empty());
        frame_sizes.clear();
    }
    let custom = !given_text.is_empty();
    for scene in all {
        if only.as_ref().is_some_and(|o| !o.iter().any(|s| s == scene.name)) {
            continue;
        }
        let text =
            std::fs::read_to_string(&scene.rib).map_err(|e| format!("{}: {e}", scene.rib.display()))?;
        let base_name = format!("{}-without", scene.name);
        let (image, depth) = render(&lrt, &dir, &base_name, &scene_rib(&text, size, None)?, spp, reuse, "")?;
        let without = read_exr(&image)?;
        let base_rib = dir.join(format!("{base_name}.rib"));
        let mut rows = Vec::new();
        for (pi, placement) in scene.placements.iter().enumerate() {
            for (material, lines) in MATERIALS {
                let slug = if custom {
                    format!("{}-given{pi}-{material}", scene.name)
                } else {
                    format!("{}-p{pi}-{material}", scene.name)
                };
                let live = dir.join(format!("{slug}-live.rib"));
                let live_text = live_rib(placement, lines);
                write(&live, &live_text)?;
                let (truth_exr, _) = render(
                    &lrt,
                    &dir,
                    &format!("{slug}-truth"),
                    &scene_rib(&text, size, Some(&live))?,
                    spp,
                    reuse,
                    &live_text,
                )?;
                let truth = read_exr(&truth_exr)?;
                let (comp, mask) = composite(
                    &viewer,
                    &viewer_args,
                    (&image, &depth),
                    &base_rib,
                    &live,
                    &dir.join(format!("{slug}-composite")),
                )?;
                let reg = regions(&mask, &truth, &without);
                let cells: Vec<String> = [Region::Inside, Region::Changed, Region::Elsewhere]
                    .iter()
                    .map(|&r| {
                        let (e, n) = region_error(&comp, &truth, &reg, r);
                        // A region without pixels (a sphere hidden from the camera) has no error.
                        if n == 0 { "- (0)".to_string() } else { format!("{e:.2e} ({n})") }
                    })
                    .collect();
                let _ = writeln!(
                    table,
                    "| {} | {} ({}) | {material} | {} |",
                    scene.name,
                    pi,
                    placement.what,
                    cells.join(" | ")
                );
                eprintln!("illusion: {slug}: {}", cells.join(", "));
                if pi == 0 {
                    let error = Rgb {
                        width: comp.width,
                        height: comp.height,
                        pixels: comp
                            .pixels
                            .iter()
                            .zip(&truth.pixels)
                            .map(|(a, b)| std::array::from_fn(|c| 4.0 * (a[c] - b[c]).abs()))
                            .collect(),
                    };
                    let without_copy =
                        Rgb { width: without.width, height: without.height, pixels: without.pixels.clone() };
                    rows.push(vec![truth, comp, without_copy, error]);
                }
            }
        }
        if !custom {
            let picture = root.join(format!("docs/illusion-{}.png", scene.name));
            contact_sheet(&rows, &picture)?;
            pictures.push(scene.name);
        }
        for &frame_size in &frame_sizes {
            let ms = frame_time(&viewer, &viewer_args, &lrt, &dir, &scene, frame_size)?;
            let _ = writeln!(frames, "| {} | {frame_size} | {ms:.2} |", scene.name);
        }
    }

    let mut doc = String::new();
    let _ = writeln!(
        doc,
        "# The illusion, measured (`cargo xtask illusion`)\n\nMade by `cargo xtask illusion --spp {spp} --size {size}{}` \
         (load average {load_start} at the start, {} at the end). Each row: a sphere placed in the scene, \
         composited live by `hybrid-view --live` over `lrt-depth`'s render of the scene without it, against \
         `lrt-depth`'s render of the scene with it (photon mapping, {spp} spp, {size} px, the same seed). \
         relMSE `(x - r)^2 / (r^2 + 0.01)` per region, pixel count in brackets: inside the sphere (the \
         viewer's mask), the region the sphere changes (other pixels where the truth differs from the \
         render without it by more than 3% of the local level, 5x5 means) and everywhere else. \
         Issue 10's targets: inside <= 1e-2, changed <= 5e-3, elsewhere <= 1.5e-3.\n",
        viewer_args
            .iter()
            .map(|a| format!(" --viewer-arg {a}"))
            .chain(custom.then(|| format!(" --placements \"{given_text}\"")))
            .collect::<String>(),
        load_average()
    );
    doc.push_str(
        "| scene | placement | material | inside | changed | elsewhere |\n|---|---|---|---|---|---|\n",
    );
    doc.push_str(&table);
    if !frames.is_empty() {
        doc.push_str(
        "\nThe viewer's median frame time over 20 headless frames (render + wait, lavapipe on this \
         machine's CPU), the plastic sphere at the first placement:\n\n| scene | image size | frame ms |\n|---|---|---|\n",
    );
        doc.push_str(&frames);
    }
    if !pictures.is_empty() {
        doc.push_str("\nPictures (truth, composite, render without the sphere, 4x the absolute error; matte row, then plastic; sRGB):\n\n");
        for name in pictures {
            let _ = writeln!(doc, "![{name}](illusion-{name}.png)\n");
        }
    }
    // A table of given placements goes next to the renders, not over the one in docs/.
    let path = if custom { dir.join("placements.md") } else { root.join("docs/illusion.md") };
    let tmp = path.with_extension("md.tmp");
    write(&tmp, &doc)?;
    std::fs::rename(&tmp, &path).map_err(|e| format!("cannot rename to {}: {e}", path.display()))?;
    println!("{doc}");
    Ok(())
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn placements_are_parsed_or_refused_with_the_item() {
        let p = parse_placements("room:1,1.6,-0.6,0.3; cornell:-0.2,0,0.1,0.25;").unwrap();
        assert_eq!(p.len(), 2);
        assert_eq!((p[0].0.as_str(), p[0].1.centre, p[0].1.radius), ("room", [1.0, 1.6, -0.6], 0.3));
        assert_eq!((p[1].0.as_str(), p[1].1.centre, p[1].1.radius), ("cornell", [-0.2, 0.0, 0.1], 0.25));
        for bad in ["room", "room:1,2,3", "room:1,2,3,0", "room:1,2,x,1", "room:1,2,3,nan"] {
            assert!(parse_placements(bad).unwrap_err().contains("--placements"), "{bad}");
        }
    }

    #[test]
    fn a_changed_renderer_changes_the_frame_renders_stamp() {
        let dir = tempfile::tempdir().unwrap();
        let (a, b) = (dir.path().join("a"), dir.path().join("b"));
        std::fs::write(&a, b"renderer one").unwrap();
        std::fs::write(&b, b"renderer two").unwrap();
        let digest_a = renderer_digest(&a).unwrap();
        assert_eq!(digest_a, renderer_digest(&a).unwrap());
        assert_ne!(render_stamp(1, &digest_a), render_stamp(1, &renderer_digest(&b).unwrap()));
        assert!(renderer_digest(&dir.path().join("missing")).is_err());
    }

    #[test]
    fn the_rib_gets_photon_mapping_a_size_and_the_live_archive() {
        let rib = "Option \"lrt\" \"string depthfile\" [\"a.depth\"]\nFormat 512 256 1\nSurfaceIntegrator \"path\"\nWorldBegin\n  Sphere 1 -1 1 360\nWorldEnd\n";
        let out = scene_rib(rib, 128, Some(Path::new("/tmp/live.rib"))).unwrap();
        assert!(!out.contains("depthfile"));
        assert!(out.contains("Format 128 64 1\n"));
        assert!(out.contains("SurfaceIntegrator \"photonmap\"\nWorldBegin"));
        assert!(out.contains("ReadArchive \"/tmp/live.rib\"\nWorldEnd"));
        // A scene that already uses photon mapping keeps its own parameters.
        let pm = "SurfaceIntegrator \"photonmap\" \"integer causticphotons\" [5]\nWorldBegin\nWorldEnd\n";
        let out = scene_rib(pm, 64, None).unwrap();
        assert_eq!(out.matches("SurfaceIntegrator").count(), 1);
        assert!(scene_rib("WorldBegin\n", 64, None).is_err());
    }

    #[test]
    fn regions_split_the_mask_the_change_and_the_rest() {
        let flat = |v: f32| Rgb { width: 20, height: 20, pixels: vec![[v; 3]; 400] };
        let without = flat(0.5);
        let mut truth = flat(0.5);
        // A dark patch (a shadow) at the top left, the object at the bottom right.
        for y in 0..6 {
            for x in 0..6 {
                truth.pixels[y * 20 + x] = [0.1; 3];
            }
        }
        let mask: Vec<bool> = (0..400).map(|i| i % 20 >= 15 && i / 20 >= 15).collect();
        let r = regions(&mask, &truth, &without);
        assert_eq!(r[0], Region::Changed);
        assert_eq!(r[19 * 20 + 19], Region::Inside);
        assert_eq!(r[10 * 20 + 10], Region::Elsewhere);
        let (e, n) = region_error(&truth, &truth, &r, Region::Changed);
        assert!(e == 0.0 && n > 36);
    }
}
