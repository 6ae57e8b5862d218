//! `cargo xtask corpus`: renders every full scene of `../shared/rib-corpus` small and fast with
//! the release `lrt-depth`, then writes a contact sheet (`docs/corpus-contact-sheet.png`) and a
//! table of warning classes with outcome counts (`docs/corpus.md`).
//!
//! The corpus stores `<repo>/a/b/c.rib` as `<repo>/a__b__c.rib` (see its SOURCES.md), which
//! breaks relative `ReadArchive` names. The scenes are therefore rendered from a scratch tree
//! that restores the original directories (symbolic links to the corpus files), so archives
//! resolve as they did in their repositories, through the same search rules a user gets.
//!
//! A scene is a corpus file with a world block (`WorldBegin`, found in the text after gunzip;
//! binary RIB keeps request names as strings too), or a top-level file that builds its world
//! from archives (it reads archives and no corpus file reads it, e.g. lucille's
//! `Scene_DEFAULT_Set0.rib`, which sets the archive search path). Other archive fragments are
//! rendered as part of the scenes that read them.

use image::{Rgb, RgbImage};
use std::collections::BTreeMap;
use std::io::Read;
use std::path::{Path, PathBuf};
use std::process::{Command, Stdio};
use std::time::{Duration, Instant};

/// Longest side of each render, in pixels.
const MAX_SIZE: u32 = 128;
/// Per-file wall-clock limit; the render is killed beyond it.
const TIME_LIMIT: Duration = Duration::from_secs(20);
/// Contact-sheet cell: thumbnail area plus border, then two label lines.
const CELL_W: u32 = 2 * BORDER + MAX_SIZE + 2 * 32;
const BORDER: u32 = 3;
const LABEL_LINES: u32 = 2;
const COLUMNS: u32 = 8;

#[derive(Clone, Copy, Debug, PartialEq, Eq, PartialOrd, Ord)]
enum Outcome {
    Clean,
    Warnings,
    Failed,
    TimedOut,
}

impl Outcome {
    fn name(self) -> &'static str {
        match self {
            Outcome::Clean => "rendered clean",
            Outcome::Warnings => "rendered with warnings",
            Outcome::Failed => "failed",
            Outcome::TimedOut => "timed out",
        }
    }
    fn colour(self) -> Rgb<u8> {
        match self {
            Outcome::Clean => Rgb([40, 170, 60]),
            Outcome::Warnings => Rgb([230, 180, 20]),
            Outcome::Failed => Rgb([210, 30, 30]),
            Outcome::TimedOut => Rgb([150, 60, 200]),
        }
    }
    fn colour_name(self) -> &'static str {
        match self {
            Outcome::Clean => "green",
            Outcome::Warnings => "yellow",
            Outcome::Failed => "red",
            Outcome::TimedOut => "purple",
        }
    }
}

struct FileResult {
    /// Path relative to the corpus directory.
    name: String,
    outcome: Outcome,
    seconds: f64,
    /// Normalised warning (and non-fatal error) classes, once per file.
    classes: Vec<String>,
    /// First error line, for failures.
    error: Option<String>,
    image: Option<RgbImage>,
}

pub fn corpus(root: &Path, args: &[String]) -> Result<(), String> {
    if let Some(a) = args.first() {
        return Err(format!("corpus takes no arguments, not '{a}'"));
    }
    let corpus = root
        .ancestors()
        .skip(1)
        .map(|d| d.join("shared/rib-corpus"))
        .find(|d| d.join("SOURCES.md").is_file())
        .ok_or("no ../shared/rib-corpus beside the checkout")?;
    let status = crate::cargo()
        .args(["build", "--release", "-p", "lrt-depth"])
        .current_dir(root)
        .status()
        .map_err(|e| format!("cargo build: {e}"))?;
    if !status.success() {
        return Err("cargo build --release -p lrt-depth failed".into());
    }
    let lrt = root.join("target/release/lrt-depth");
    let scratch = std::env::temp_dir().join(format!("xtask-corpus-{}", std::process::id()));
    std::fs::create_dir_all(&scratch).map_err(|e| format!("{}: {e}", scratch.display()))?;
    let mut files = Vec::new();
    collect_files(&corpus, &mut files)?;
    files.sort();
    let tree = scratch.join("tree");
    let texts: Vec<Vec<u8>> = files.iter().map(|f| rib_text(f)).collect();
    let read_by_others: std::collections::HashSet<String> =
        texts.iter().flat_map(|t| archive_names(t)).filter_map(|n| base_name(&n)).collect();
    let mut scenes = Vec::new();
    for (file, text) in files.iter().zip(&texts) {
        let restored = restore_layout(&corpus, file, &tree)?;
        let has_world = contains(text, b"WorldBegin");
        let top_level_chain = !archive_names(text).is_empty()
            && !file
                .file_name()
                .and_then(|n| n.to_str())
                .and_then(original_base)
                .is_some_and(|b| read_by_others.contains(&b));
        if has_world || top_level_chain {
            scenes.push((file.clone(), restored));
        }
    }
    let start = Instant::now();
    let mut results = Vec::new();
    for (i, (scene, restored)) in scenes.iter().enumerate() {
        let name = scene.strip_prefix(&corpus).unwrap_or(scene).to_string_lossy().into_owned();
        let r = render_one(&lrt, restored, name, &scratch.join(format!("{i}.png")), &scratch)?;
        eprintln!("[{}/{}] {:5.1} s  {:24} {}", i + 1, scenes.len(), r.seconds, r.outcome.name(), r.name);
        results.push(r);
    }
    let total = start.elapsed().as_secs_f64();
    let _ = std::fs::remove_dir_all(&scratch);
    let sheet = contact_sheet(&results);
    let png = root.join("docs/corpus-contact-sheet.png");
    let tmp = png.with_extension("png.tmp");
    sheet.save_with_format(&tmp, image::ImageFormat::Png).map_err(|e| format!("{}: {e}", tmp.display()))?;
    std::fs::rename(&tmp, &png).map_err(|e| format!("{}: {e}", png.display()))?;
    let md = root.join("docs/corpus.md");
    let tmp = md.with_extension("md.tmp");
    std::fs::write(&tmp, report(&results, total)).map_err(|e| format!("{}: {e}", tmp.display()))?;
    std::fs::rename(&tmp, &md).map_err(|e| format!("{}: {e}", md.display()))?;
    println!("wrote {} and {} ({total:.0} s)", png.display(), md.display());
    Ok(())
}

fn collect_files(dir: &Path, out: &mut Vec<PathBuf>) -> Result<(), String> {
    for entry in std::fs::read_dir(dir).map_err(|e| format!("{}: {e}", dir.display()))? {
        let path = entry.map_err(|e| format!("{}: {e}", dir.display()))?.path();
        if path.is_dir() {
            collect_files(&path, out)?;
        } else if path.to_string_lossy().ends_with(".rib") || path.to_string_lossy().ends_with(".rib.gz") {
            out.push(path);
        }
    }
    Ok(())
}

/// A corpus file's bytes, looking through gzip compression (empty when unreadable).
fn rib_text(path: &Path) -> Vec<u8> {
    let Ok(bytes) = std::fs::read(path) else { return Vec::new() };
    if bytes.starts_with(&[0x1f, 0x8b]) {
        let mut out = Vec::new();
        match flate2::read::MultiGzDecoder::new(&bytes[..]).read_to_end(&mut out) {
            Ok(_) => out,
            Err(_) => Vec::new(),
        }
    } else {
        bytes
    }
}

fn contains(text: &[u8], word: &[u8]) -> bool {
    text.windows(word.len()).any(|w| w == word)
}

/// The names a file reads as archives: the first string after each `ReadArchive` and
/// `"DelayedReadArchive"` (a textual scan, enough to tell top-level files from fragments).
fn archive_names(text: &[u8]) -> Vec<String> {
    let mut out = Vec::new();
    let mut i = 0;
    while i < text.len() {
        let rest = &text[i..];
        let key = if rest.starts_with(b"DelayedReadArchive\"") {
            b"DelayedReadArchive\"".len()
        } else if rest.starts_with(b"ReadArchive") {
            b"ReadArchive".len()
        } else {
            i += 1;
            continue;
        };
        i += key;
        let Some(open) = text[i..].iter().position(|&b| b == b'"') else { break };
        let start = i + open + 1;
        let Some(len) = text[start..].iter().position(|&b| b == b'"') else { break };
        out.push(String::from_utf8_lossy(&text[start..start + len]).into_owned());
        i = start + len + 1;
    }
    out
}

/// The last path component of an archive name (`/` or `\\` separated).
fn base_name(name: &str) -> Option<String> {
    name.rsplit(['/', '\\']).next().filter(|b| !b.is_empty()).map(str::to_string)
}

/// The original file name of a flattened corpus name (`a__b__c.rib` -> `c.rib`).
fn original_base(flat: &str) -> Option<String> {
    flat.rsplit("__").next().map(str::to_string)
}

/// Links `corpus/<repo>/a__b__c.rib` at `tree/<repo>/a/b/c.rib` and returns that path.
fn restore_layout(corpus: &Path, file: &Path, tree: &Path) -> Result<PathBuf, String> {
    let relative =
        file.strip_prefix(corpus).map_err(|_| format!("{} is outside the corpus", file.display()))?;
    let mut components = relative.components();
    // The repository directory (`owner__repo`) keeps its name; the file name is unflattened.
    let mut restored = tree.join(components.next().ok_or("empty corpus path")?);
    for component in components {
        for part in component.as_os_str().to_string_lossy().split("__") {
            restored.push(part);
        }
    }
    if let Some(dir) = restored.parent() {
        std::fs::create_dir_all(dir).map_err(|e| format!("{}: {e}", dir.display()))?;
    }
    if !restored.exists() {
        std::os::unix::fs::symlink(file, &restored).map_err(|e| format!("{}: {e}", restored.display()))?;
    }
    Ok(restored)
}

fn render_one(
    lrt: &Path,
    scene: &Path,
    name: String,
    out: &Path,
    scratch: &Path,
) -> Result<FileResult, String> {
    let stderr_path = out.with_extension("stderr");
    let stderr =
        std::fs::File::create(&stderr_path).map_err(|e| format!("{}: {e}", stderr_path.display()))?;
    let start = Instant::now();
    // `nice` execs lrt-depth, so killing the child kills the render. The scratch directory is the
    // working directory so that depth tables and shadow maps a scene asks for land there.
    let mut child = Command::new("nice")
        .args(["-n", "10"])
        .arg(lrt)
        .arg(scene)
        .arg("-o")
        .arg(out)
        .args(["--spp", "4", "--threads", "2", "--max-size", &MAX_SIZE.to_string()])
        .current_dir(scratch)
        .stdin(Stdio::null())
        .stdout(Stdio::null())
        .stderr(stderr)
        .spawn()
        .map_err(|e| format!("nice {}: {e}", lrt.display()))?;
    let status = loop {
        if let Some(status) = child.try_wait().map_err(|e| e.to_string())? {
            break Some(status);
        }
        if start.elapsed() > TIME_LIMIT {
            let _ = child.kill();
            let _ = child.wait();
            break None;
        }
        std::thread::sleep(Duration::from_millis(20));
    };
    let seconds = start.elapsed().as_secs_f64();
    let log = std::fs::read_to_string(&stderr_path).unwrap_or_default();
    let mut classes: Vec<String> = log.lines().filter_map(warning_class).collect();
    classes.sort();
    classes.dedup();
    let image = image::open(out).ok().map(|i| i.to_rgb8());
    let error = log.lines().find(|l| l.contains("error:")).map(|l| strip_location(l).to_string());
    let outcome = match status {
        None => Outcome::TimedOut,
        Some(s) if !s.success() || image.is_none() => Outcome::Failed,
        Some(_) if classes.is_empty() => Outcome::Clean,
        Some(_) => Outcome::Warnings,
    };
    Ok(FileResult { name, outcome, seconds, classes, error, image })
}

/// The message of a diagnostic line, without its `file:line:col: ` prefix.
fn strip_location(line: &str) -> &str {
    for key in ["warning: ", "error: "] {
        if let Some(at) = line.find(key) {
            return &line[at..];
        }
    }
    line
}

/// The class of a `warning:` or `error:` diagnostic line: the message with its location, file
/// names, numbers and quoted identifiers replaced by placeholders. `None` for other lines
/// (source excerpts, carets, summaries).
fn warning_class(line: &str) -> Option<String> {
    let message = strip_location(line);
    if !(message.starts_with("warning: ") || message.starts_with("error: ")) {
        return None;
    }
    let mut out = String::new();
    let mut chars = message.chars().peekable();
    while let Some(c) = chars.next() {
        if c == '"' || (c == '\'' && !out.ends_with(|p: char| p.is_alphanumeric())) {
            // A quoted identifier, file name or command.
            for d in chars.by_ref() {
                if d == c {
                    break;
                }
            }
            out.push(c);
            out.push('_');
            out.push(c);
        } else if c.is_ascii_digit() && !out.ends_with(|p: char| p.is_ascii_alphanumeric() || p == '_') {
            while chars.peek().is_some_and(|d| d.is_ascii_digit() || *d == '.' || *d == 'e' || *d == '-') {
                chars.next();
            }
            out.push('N');
        } else {
            out.push(c);
        }
    }
    // Unquoted paths and file names (`/a/b.tif`, `x.rib`) become FILE.
    let words: Vec<String> = out
        .split(' ')
        .map(|w| {
            let core = w.trim_matches(|c: char| matches!(c, ',' | ':' | ';' | '(' | ')' | '\'' | '`'));
            let is_file = core.contains('/')
                || [
                    ".rib", ".tif", ".tiff", ".tx", ".tex", ".sl", ".slx", ".sdl", ".png", ".exr", ".shd",
                    ".gz", ".z",
                ]
                .iter()
                .any(|ext| core.to_ascii_lowercase().ends_with(ext) && core.len() > ext.len());
            if is_file && !core.is_empty() { w.replace(core, "FILE") } else { w.to_string() }
        })
        .collect();
    Some(words.join(" "))
}

fn label_of(name: &str) -> String {
    // The repository directory is dropped; the end of the path names the scene.
    let file = name.rsplit('/').next().unwrap_or(name);
    file.trim_end_matches(".gz").trim_end_matches(".rib").to_string()
}

fn contact_sheet(results: &[FileResult]) -> RgbImage {
    let chars_per_line = (CELL_W - 4) / 6;
    let cell_h = 2 * BORDER + MAX_SIZE + LABEL_LINES * 9 + 6;
    let rows = (results.len() as u32).div_ceil(COLUMNS).max(1);
    let legend_h = 14;
    let mut sheet = RgbImage::from_pixel(COLUMNS * CELL_W, rows * cell_h + legend_h, Rgb([255, 255, 255]));
    let mut x = 4;
    for outcome in [Outcome::Clean, Outcome::Warnings, Outcome::Failed, Outcome::TimedOut] {
        fill(&mut sheet, x, 3, 8, 8, outcome.colour());
        x += 12;
        x = draw_text(&mut sheet, x, 4, outcome.name(), Rgb([0, 0, 0])) + 14;
    }
    for (i, r) in results.iter().enumerate() {
        let (cx, cy) = ((i as u32 % COLUMNS) * CELL_W, (i as u32 / COLUMNS) * cell_h + legend_h);
        let box_w = MAX_SIZE + 2 * BORDER;
        let bx = cx + (CELL_W - box_w) / 2;
        fill(&mut sheet, bx, cy + 2, box_w, box_w, r.outcome.colour());
        fill(&mut sheet, bx + BORDER, cy + 2 + BORDER, MAX_SIZE, MAX_SIZE, Rgb([60, 60, 60]));
        if let Some(img) = &r.image {
            let (w, h) = (img.width().min(MAX_SIZE), img.height().min(MAX_SIZE));
            let (ox, oy) = (bx + BORDER + (MAX_SIZE - w) / 2, cy + 2 + BORDER + (MAX_SIZE - h) / 2);
            for y in 0..h {
                for x in 0..w {
                    sheet.put_pixel(ox + x, oy + y, *img.get_pixel(x, y));
                }
            }
        }
        let label = format!("{} {}", i + 1, label_of(&r.name));
        let label: Vec<char> = label.chars().collect();
        let n = chars_per_line as usize;
        // Two lines; a longer name keeps its end, which tells scenes apart.
        let text: Vec<char> = if label.len() > 2 * n {
            let mut t: Vec<char> = label[..n].to_vec();
            t.push('+');
            t.extend_from_slice(&label[label.len() - (n - 1)..]);
            t
        } else {
            label
        };
        for (line, chunk) in text.chunks(n).enumerate().take(LABEL_LINES as usize) {
            let s: String = chunk.iter().collect();
            draw_text(&mut sheet, cx + 2, cy + box_w + 6 + line as u32 * 9, &s, Rgb([0, 0, 0]));
        }
    }
    sheet
}

fn fill(img: &mut RgbImage, x: u32, y: u32, w: u32, h: u32, c: Rgb<u8>) {
    for yy in y..(y + h).min(img.height()) {
        for xx in x..(x + w).min(img.width()) {
            img.put_pixel(xx, yy, c);
        }
    }
}

/// Draws `text` in the built-in 5x7 font (letters in upper case); returns the x after it.
fn draw_text(img: &mut RgbImage, x: u32, y: u32, text: &str, c: Rgb<u8>) -> u32 {
    let mut x = x;
    for ch in text.chars() {
        let rows = glyph(ch);
        for (dy, bits) in rows.iter().enumerate() {
            for dx in 0..5 {
                if bits & (0x10 >> dx) != 0 && x + dx < img.width() && y + (dy as u32) < img.height() {
                    img.put_pixel(x + dx, y + dy as u32, c);
                }
            }
        }
        x += 6;
    }
    x
}

/// Rows of a 5x7 glyph, top first, bit 4 leftmost (the HD44780 character shapes).
fn glyph(c: char) -> [u8; 7] {
    match c.to_ascii_uppercase() {
        '0' => [0x0E, 0x11, 0x13, 0x15, 0x19, 0x11, 0x0E],
        '1' => [0x04, 0x0C, 0x04, 0x04, 0x04, 0x04, 0x0E],
        '2' => [0x0E, 0x11, 0x01, 0x02, 0x04, 0x08, 0x1F],
        '3' => [0x1F, 0x02, 0x04, 0x02, 0x01, 0x11, 0x0E],
        '4' => [0x02, 0x06, 0x0A, 0x12, 0x1F, 0x02, 0x02],
        '5' => [0x1F, 0x10, 0x1E, 0x01, 0x01, 0x11, 0x0E],
        '6' => [0x06, 0x08, 0x10, 0x1E, 0x11, 0x11, 0x0E],
        '7' => [0x1F, 0x01, 0x02, 0x04, 0x08, 0x08, 0x08],
        '8' => [0x0E, 0x11, 0x11, 0x0E, 0x11, 0x11, 0x0E],
        '9' => [0x0E, 0x11, 0x11, 0x0F, 0x01, 0x02, 0x0C],
        'A' => [0x0E, 0x11, 0x11, 0x11, 0x1F, 0x11, 0x11],
        'B' => [0x1E, 0x11, 0x11, 0x1E, 0x11, 0x11, 0x1E],
        'C' => [0x0E, 0x11, 0x10, 0x10, 0x10, 0x11, 0x0E],
        'D' => [0x1C, 0x12, 0x11, 0x11, 0x11, 0x12, 0x1C],
        'E' => [0x1F, 0x10, 0x10, 0x1E, 0x10, 0x10, 0x1F],
        'F' => [0x1F, 0x10, 0x10, 0x1E, 0x10, 0x10, 0x10],
        'G' => [0x0E, 0x11, 0x10, 0x17, 0x11, 0x11, 0x0F],
        'H' => [0x11, 0x11, 0x11, 0x1F, 0x11, 0x11, 0x11],
        'I' => [0x0E, 0x04, 0x04, 0x04, 0x04, 0x04, 0x0E],
        'J' => [0x07, 0x02, 0x02, 0x02, 0x02, 0x12, 0x0C],
        'K' => [0x11, 0x12, 0x14, 0x18, 0x14, 0x12, 0x11],
        'L' => [0x10, 0x10, 0x10, 0x10, 0x10, 0x10, 0x1F],
        'M' => [0x11, 0x1B, 0x15, 0x15, 0x11, 0x11, 0x11],
        'N' => [0x11, 0x11, 0x19, 0x15, 0x13, 0x11, 0x11],
        'O' => [0x0E, 0x11, 0x11, 0x11, 0x11, 0x11, 0x0E],
        'P' => [0x1E, 0x11, 0x11, 0x1E, 0x10, 0x10, 0x10],
        'Q' => [0x0E, 0x11, 0x11, 0x11, 0x15, 0x12, 0x0D],
        'R' => [0x1E, 0x11, 0x11, 0x1E, 0x14, 0x12, 0x11],
        'S' => [0x0F, 0x10, 0x10, 0x0E, 0x01, 0x01, 0x1E],
        'T' => [0x1F, 0x04, 0x04, 0x04, 0x04, 0x04, 0x04],
        'U' => [0x11, 0x11, 0x11, 0x11, 0x11, 0x11, 0x0E],
        'V' => [0x11, 0x11, 0x11, 0x11, 0x11, 0x0A, 0x04],
        'W' => [0x11, 0x11, 0x11, 0x15, 0x15, 0x15, 0x0A],
        'X' => [0x11, 0x11, 0x0A, 0x04, 0x0A, 0x11, 0x11],
        'Y' => [0x11, 0x11, 0x11, 0x0A, 0x04, 0x04, 0x04],
        'Z' => [0x1F, 0x01, 0x02, 0x04, 0x08, 0x10, 0x1F],
        '.' => [0x00, 0x00, 0x00, 0x00, 0x00, 0x0C, 0x0C],
        '_' => [0x00, 0x00, 0x00, 0x00, 0x00, 0x00, 0x1F],
        '-' => [0x00, 0x00, 0x00, 0x1F, 0x00, 0x00, 0x00],
        '+' => [0x00, 0x04, 0x04, 0x1F, 0x04, 0x04, 0x00],
        '/' => [0x00, 0x01, 0x02, 0x04, 0x08, 0x10, 0x00],
        ':' => [0x00, 0x0C, 0x0C, 0x00, 0x0C, 0x0C, 0x00],
        '(' => [0x02, 0x04, 0x08, 0x08, 0x08, 0x04, 0x02],
        ')' => [0x08, 0x04, 0x02, 0x02, 0x02, 0x04, 0x08],
        ' ' => [0; 7],
        _ => [0x0E, 0x11, 0x01, 0x02, 0x04, 0x00, 0x04],
    }
}

/// What each known warning class means: a substring of the class, and the paragraph for it.
const EXPLANATIONS: &[(&str, &str)] = &[
    (
        "cannot find archive",
        "The right answer, not a loader gap: the archive is not where the scene says. cgkit's `include.rib` is not in the corpus; Blender-to-Renderman names absolute paths on its author's machine (`/home/frigge/...`, and its `Lamp.001_Beauty0001.rib` is not in the corpus either); lucille's `F1SB0Scene.rib` rendered on its own lacks the search path its parent `Scene_DEFAULT_Set0.rib` sets (the parent renders). Each error names every place looked.",
    ),
    (
        "unknown surface shader",
        "A custom shader written in the RenderMan Shading Language: a ray tracer without an RSL compiler cannot know what it computes, so the surface is rendered with the named standard stand-in. Stays.",
    ),
    (
        "beyond its displacementbound",
        "Informational, about the scene: a standard displacement shader (`dented`, `bumpy`, run by the renderer, docs/tessellation.md) moves the surface farther than the scene's `Attribute \"displacementbound\"` says. PRMan's documentation: a bound too small shows clipping or missing pieces (where the diced surface leaves the primitive's grown bounds), and RenderMan prints a warning for it; neither is the surface the shader describes. The ray tracer needs no bound (its BVH is built over the displaced triangles) and draws the displacement in full, which is what the scene's author meant; the warning says the bound is wrong for a REYES renderer. Stays as information.",
    ),
    (
        "coarser",
        "A displaced shape's `ShadingRate` asks for more micropolygons than the per-shape budget (`MAX_DISPLACED_TRIANGLES`) allows: diced as finely as the budget allows, reported (a hostile file costs bounded memory and time).",
    ),
    (
        "is a custom shader (RenderMan Shading Language)",
        "A custom displacement shader written in the RenderMan Shading Language (the standard `null`, `dented` and `bumpy` are run: docs/raytracer.md): a renderer without an RSL compiler cannot know what it computes, so the surface is not displaced. Stays (the parser's warning and the ray tracer's are two lines for one cause).",
    ),
    (
        "drawn at shutter open",
        "Gap, narrowed: deformation blur is rendered for every shape whose keys can be interpolated (quadrics, points, polygons, curves, and patches, NURBS, subdivision surfaces and Blobby tessellated alike at every key; see docs/raytracer.md). The warning says why this one is not: a Blobby whose blobs split or merge between keys, a deforming shape inside `SolidBegin` or an area light.",
    ),
    (
        "deformation motion blur inside ObjectBegin",
        "Gap: deformation inside an object definition keeps its first key (move the `ObjectInstance` instead).",
    ),
    (
        "without deformation blur",
        "The keys of a motion block are not one request with one topology (another shape type, other counts): a scene error RenderMan refuses too; the first key is used, reported.",
    ),
    (
        "motion blur of lights and attributes",
        "Gap: lights and attributes inside `MotionBegin` keep their first sample (geometry and transformations are blurred).",
    ),
    (
        "camera's motion block",
        "A moving camera whose keys are not cameras (projective or singular): the camera at shutter open is used, reported.",
    ),
    (
        "moving area light",
        "Gap: an area light that moves is placed at shutter open (its emission and shadows would need time-dependent light sampling).",
    ),
    (
        "Geometry",
        "Gap: `Geometry` with an implementation-specific name other than \"teapot\" (e.g. \"bunny\") is not built; the teapot is.",
    ),
    (
        "SolidBegin",
        "CSG is exact in the ray tracer and the haptics; this warning is for an unknown operation or a solid inside `ObjectBegin` (instanced), read as a union as it says.",
    ),
    (
        "not a standard light",
        "A custom light shader (RSL): cannot be known; it is kept but may be skipped by consumers.",
    ),
    ("light shader", "A custom light shader (RSL): cannot be known, skipped."),
    (
        "later RenderMan versions",
        "Gap: a request of later RenderMan versions (RenderMan 19 and later's Bxdf, Pattern, Integrator, ...) that is not built.",
    ),
    ("DepthOfField", "Gap: a thin-lens camera is not built; the camera stays a pinhole."),
    (
        "Illuminate",
        "The scene refers to a light handle that was never declared (or was declared by a custom light that was skipped): a scene error or a consequence of an RSL light, not a gap.",
    ),
    (
        "MakeLatLongEnvironment",
        "Gap: texture-making requests are not run (no environment maps are made), so scenes that make their own maps render without them.",
    ),
    ("MakeTexture", "Gap: texture-making requests are not run (no texture files are made)."),
    (
        "MakeCubeFaceEnvironment",
        "Gap: texture-making requests are not run (no cube-face environments are made).",
    ),
    (
        "would run",
        "A program the scene asks to run (`RunProgram`/`DynamicLoad`): refused by design (scenes never execute programs), stays.",
    ),
    ("System would run", "A shell command the scene asks to run: refused by design, stays."),
    (
        "Resource",
        "The scene's `Resource` call names an operation or subset PRMan's `RiResource` does not have (save, restore, ricpp's load; all, shading, geometrymodification, geometrydefinition, hiding, transform): a scene error, reported and ignored.",
    ),
    (
        "shadow-map parameters",
        "Not a gap: shadows are ray traced exactly, so shadow-map parameters have nothing to do. Informational.",
    ),
    (
        "cannot be read",
        "A texture file the scene names is not in the corpus (or was to be made by a texture-making request): a gap in the corpus, not in the renderer.",
    ),
    (
        "is not a number",
        "A malformed file (uteapot has a stray shell line): a clear scene error, as it should be.",
    ),
    (
        "shader networks connect shaders",
        "A shader network of RenderMan 3.3 and later (`ShaderLayer`, `ConnectShaderLayers`): its layers are shaders written in the RenderMan Shading Language, connected output to input; a ray tracer without an RSL compiler cannot know what they compute. Stays.",
    ),
    (
        "hierarchical edit",
        "A hierarchical edit of a `HierarchicalSubdivisionMesh` that the tessellator cannot apply: a value edit of a primitive variable other than `P` (not carried through the subdivision levels) or a `faceedit` of attributes (a shape has one attribute state), skipped with the reason. `P` value, sharpness and hole edits are applied (docs/tessellation.md).",
    ),
    (
        "ClippingPlane",
        "A `ClippingPlane` the scene gives where options are fixed (inside the world block), or beyond 64 planes: ignored, reported. Clipping planes themselves are rendered.",
    ),
    (
        "Display inside",
        "The scene puts Display inside the world block, where RenderMan ignores it too: a scene error, reported.",
    ),
    ("pixel aspect ratio", "A scene error (negative pixel aspect ratio), repaired and reported."),
    ("Imager", "A custom imager shader (RSL): cannot be known, ignored."),
    ("no area", "Degenerate input in a parser test file: reported and skipped, as it should be."),
    (
        "transformation is projective",
        "A moving or deforming shape (or object instance) whose transformation is projective (`Perspective` inside the world): drawn at shutter open, without motion blur, since moving BLASes map rays affinely. Shapes under projective transformations are otherwise drawn exactly by every consumer (docs/tessellation.md).",
    ),
    ("unknown request", "Not RIB: a stray shell line in the file; reported and skipped."),
];

fn report(results: &[FileResult], total: f64) -> String {
    use std::fmt::Write;
    let date = Command::new("date")
        .args(["-u", "+%Y-%m-%d %H:%M UTC"])
        .output()
        .map(|o| String::from_utf8_lossy(&o.stdout).trim().to_string())
        .unwrap_or_default();
    let load = std::fs::read_to_string("/proc/loadavg").unwrap_or_default();
    let load: Vec<&str> = load.split_whitespace().take(3).collect();
    let mut s = String::new();
    let _ = writeln!(s, "# The RIB corpus, rendered\n");
    let _ = writeln!(
        s,
        "Made by `cargo xtask corpus` ({date}, load average {} at the end, 2-core machine shared by \
         several engineers, {total:.0} s in all): every scene (a file with a world block, or a \
         top-level file that reads its world from archives; other archive fragments render \
         inside the scenes that read them) of `../shared/rib-corpus`, from a scratch tree that \
         restores the corpus's original directories so that archives resolve as in their \
         repositories, rendered by the release `lrt-depth --spp 4 --threads 2 --max-size {MAX_SIZE}` under \
         `nice`, killed after {} s.\n",
        load.join(" "),
        TIME_LIMIT.as_secs()
    );
    let _ = writeln!(s, "![contact sheet](corpus-contact-sheet.png)\n");
    let mut counts: BTreeMap<Outcome, usize> = BTreeMap::new();
    for r in results {
        *counts.entry(r.outcome).or_default() += 1;
    }
    let _ = writeln!(s, "## Outcomes\n\n| outcome | border | files |\n|---|---|---|");
    for o in [Outcome::Clean, Outcome::Warnings, Outcome::Failed, Outcome::TimedOut] {
        let _ =
            writeln!(s, "| {} | {} | {} |", o.name(), o.colour_name(), counts.get(&o).copied().unwrap_or(0));
    }
    let _ = writeln!(s, "| total | | {} |\n", results.len());
    let mut classes: BTreeMap<&str, Vec<&str>> = BTreeMap::new();
    for r in results {
        for c in &r.classes {
            classes.entry(c).or_default().push(&r.name);
        }
    }
    let mut by_count: Vec<(&str, Vec<&str>)> = classes.into_iter().collect();
    by_count.sort_by(|a, b| b.1.len().cmp(&a.1.len()).then(a.0.cmp(b.0)));
    let _ = writeln!(
        s,
        "## Warning classes\n\nEvery `warning:` (and non-fatal `error:`) line of `lrt-depth`'s \
         standard error, with its location, file names, numbers and quoted identifiers replaced \
         by `FILE`, `N` and `\"_\"`.\n\n| # | class | files | example |\n|---|---|---|---|"
    );
    for (i, (class, files)) in by_count.iter().enumerate() {
        let _ =
            writeln!(s, "| {} | `{}` | {} | {} |", i + 1, class.replace('|', "\\|"), files.len(), files[0]);
    }
    let _ = writeln!(s, "\n## What each class is\n");
    for (i, (class, _)) in by_count.iter().enumerate() {
        let text = EXPLANATIONS
            .iter()
            .find(|(key, _)| class.contains(key))
            .map(|(_, t)| *t)
            .unwrap_or("Not yet looked into: a gap until someone shows otherwise.");
        let _ = writeln!(s, "{}. `{}`: {text}\n", i + 1, class.replace('|', "\\|"));
    }
    let _ =
        writeln!(s, "## Every file\n\n| # | file | outcome | seconds | first error |\n|---|---|---|---|---|");
    for (i, r) in results.iter().enumerate() {
        let _ = writeln!(
            s,
            "| {} | {} | {} | {:.1} | {} |",
            i + 1,
            r.name,
            r.outcome.name(),
            r.seconds,
            r.error.as_deref().map(|e| format!("`{}`", e.replace('|', "\\|"))).unwrap_or_default()
        );
    }
    s
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn archive_names_and_original_names() {
        let text = b"ReadArchive \"a/b.rib\" Procedural \"DelayedReadArchive\" [ \"c.rib\" ] [0 1 0 1 0 1]";
        assert_eq!(archive_names(text), vec!["a/b.rib".to_string(), "c.rib".to_string()]);
        assert_eq!(base_name("/home/x/Lights/L.rib").as_deref(), Some("L.rib"));
        assert_eq!(original_base("examples__scenes__fisheye__lights.rib").as_deref(), Some("lights.rib"));
    }

    #[test]
    fn restored_layout_links_the_original_path() {
        let dir = tempfile::TempDir::new().unwrap();
        let corpus = dir.path().join("corpus");
        std::fs::create_dir_all(corpus.join("o__r")).unwrap();
        let flat = corpus.join("o__r/a__b__c.rib");
        std::fs::write(&flat, "WorldBegin WorldEnd").unwrap();
        let restored = restore_layout(&corpus, &flat, &dir.path().join("tree")).unwrap();
        assert_eq!(restored, dir.path().join("tree/o__r/a/b/c.rib"));
        assert_eq!(std::fs::read_to_string(restored).unwrap(), "WorldBegin WorldEnd");
    }

    #[test]
    fn warning_class_strips_location_names_and_numbers() {
        let line = "/c/aqsis/vase.rib:410:1: warning: Displacement \"dented\" is kept but ignored: 3 surfaces, 2.5e-3 at /tmp/x.tif";
        assert_eq!(
            warning_class(line).as_deref(),
            Some("warning: Displacement \"_\" is kept but ignored: N surfaces, N at FILE")
        );
        // Same class from another file and name.
        let other =
            "b.rib:3:7: warning: Displacement \"bumpy\" is kept but ignored: 12 surfaces, 0.5 at y.tif";
        assert_eq!(warning_class(line), warning_class(other));
        // Source excerpts and carets are not diagnostics.
        assert_eq!(warning_class("    Displacement \"dented\" \"Km\" 2"), None);
        assert_eq!(warning_class("    ^"), None);
        // Digits inside a word stay (`u32`, `Bug1030593`).
        assert_eq!(warning_class("x.rib:1:1: error: bad u32").as_deref(), Some("error: bad u32"));
        // Single-quoted commands and names go too; apostrophes inside words stay.
        assert_eq!(
            warning_class("a.rib:1:1: warning: would run 'menger 3'; the shape's missing").as_deref(),
            Some("warning: would run '_'; the shape's missing")
        );
    }
}
