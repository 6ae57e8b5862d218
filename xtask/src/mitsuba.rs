//! Mitsuba 3 on the benchmark's Cornell box, side by side with our renders in one
//! `cargo xtask bench-error --mitsuba [scalar|llvm]` run. Mitsuba is a measuring stick, never a
//! dependency of the project:
//! - `scalar`: the `scalar_rgb` variant of a `python3` that already has `mitsuba`;
//! - `llvm`: the vectorised `llvm_ad_rgb` variant (how the reference was made). Its LLVM
//!   library comes from Debian's `libllvm19`, installed with apt the way the test packages are;
//!   Mitsuba itself is `pip install`ed into a virtual environment under
//!   `target/bench-error/mitsuba-venv` on first use. `DRJIT_LIBLLVM_PATH` points Dr.Jit at the
//!   library, and one render warms the JIT (kernel compilation and caching) before the timed
//!   ones.
//!
//! Each render is timed inside the Python process around `mi.render`, as wall time and as the
//! process's CPU time (all its threads), so start-up is not charged to Mitsuba and CPU seconds
//! compare with ours under load.

use crate::bench_error::{Rgb, Row, errors, load_average, read_exr};
use std::path::{Path, PathBuf};
use std::process::Command;
use std::time::Instant;

/// Which Mitsuba variant.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum Variant {
    Scalar,
    Llvm,
}

impl Variant {
    pub fn parse(name: &str) -> Option<Variant> {
        match name {
            "scalar" => Some(Variant::Scalar),
            "llvm" => Some(Variant::Llvm),
            _ => None,
        }
    }

    fn mitsuba_name(self) -> &'static str {
        match self {
            Variant::Scalar => "scalar_rgb",
            Variant::Llvm => "llvm_ad_rgb",
        }
    }

    fn short(self) -> &'static str {
        match self {
            Variant::Scalar => "scalar",
            Variant::Llvm => "llvm",
        }
    }
}

/// The LLVM library Dr.Jit loads for the llvm variant (Debian 12's `libllvm19`).
pub const LIBLLVM: &str = "/usr/lib/x86_64-linux-gnu/libLLVM.so.19.1";

fn can_import(python: &Path) -> bool {
    Command::new(python).args(["-c", "import mitsuba"]).output().is_ok_and(|o| o.status.success())
}

/// A Python that imports `mitsuba`: for `llvm`, the project's virtual environment (made and
/// filled with `pip install mitsuba` when missing) after installing `libllvm19`; for `scalar`,
/// `python3` as found (`None`: not installed, the run goes on without it).
fn python_for(variant: Variant, out_dir: &Path) -> Result<Option<PathBuf>, String> {
    match variant {
        Variant::Scalar => {
            let p = PathBuf::from("python3");
            Ok(can_import(&p).then_some(p))
        }
        Variant::Llvm => {
            crate::install_packages(&["libllvm19"], "libllvm19 (LLVM 19 for Mitsuba's llvm variant)")?;
            if !Path::new(LIBLLVM).is_file() {
                return Err(format!("libllvm19 is installed but {LIBLLVM} is missing"));
            }
            let venv = out_dir.join("mitsuba-venv");
            let python = venv.join("bin/python");
            if !can_import(&python) {
                crate::run(Command::new("python3").arg("-m").arg("venv").arg(&venv))?;
                crate::run(Command::new(&python).args(["-m", "pip", "install", "-q", "mitsuba"]))?;
            }
            Ok(Some(python))
        }
    }
}

/// Renders the Cornell box at each of `spps` with `variant` and measures each against
/// `reference`; the rows have the series `mitsuba <variant> path`.
pub fn rows(
    out_dir: &Path,
    reference: &Rgb,
    spps: &[u32],
    threads: usize,
    variant: Variant,
) -> Result<Vec<Row>, String> {
    let Some(python) = python_for(variant, out_dir)? else {
        eprintln!("bench-error: mitsuba is not installed (pip install mitsuba): skipping it");
        return Ok(Vec::new());
    };
    let renders = out_dir.join("renders");
    let outputs: Vec<String> = spps
        .iter()
        .map(|spp| {
            format!(
                "'{}'",
                renders.join(format!("cornell-mitsuba-{}-spp{spp}.exr", variant.short())).display()
            )
        })
        .collect();
    let spp_list: Vec<String> = spps.iter().map(u32::to_string).collect();
    // The scene as the reference was made: `mi.cornell_box()` at 512x512, box filter,
    // unbounded depth with Russian roulette from depth 5.
    let script = format!(
        r#"
import sys, time, mitsuba as mi, drjit as dr
mi.set_variant('{variant}')
dr.set_thread_count({threads})
d = mi.cornell_box()
d['sensor']['film']['width'] = 512
d['sensor']['film']['height'] = 512
d['sensor']['film']['rfilter'] = {{'type': 'box'}}
d['integrator'] = {{'type': 'path', 'max_depth': -1, 'rr_depth': 5}}
def render(spp, seed):
    d['sensor']['sampler'] = {{'type': 'independent', 'sample_count': spp}}
    scene = mi.load_dict(d)
    wall, cpu = time.perf_counter(), time.process_time()
    img = mi.render(scene, spp=spp, seed=seed)
    dr.eval(img)
    dr.sync_thread()
    return img, time.perf_counter() - wall, time.process_time() - cpu
# Warm-up: the first render compiles (and caches) the kernels.
_, w, c = render({warm}, 1000)
print('warmup', w, c, flush=True)
for spp, out in zip([{spps}], [{outputs}]):
    img, w, c = render(spp, 0)
    mi.Bitmap(img).write(out)
    print('render', spp, w, c, flush=True)
"#,
        variant = variant.mitsuba_name(),
        warm = spps.first().copied().unwrap_or(16),
        spps = spp_list.join(", "),
        outputs = outputs.join(", "),
    );
    let load = load_average();
    let start = Instant::now();
    let mut cmd = Command::new(&python);
    cmd.args(["-c", &script]);
    if variant == Variant::Llvm {
        cmd.env("DRJIT_LIBLLVM_PATH", LIBLLVM);
    }
    let output = cmd.output().map_err(|e| format!("{}: {e}", python.display()))?;
    let stdout = String::from_utf8_lossy(&output.stdout);
    if !output.status.success() {
        return Err(format!(
            "mitsuba {} failed:\n{stdout}{}",
            variant.short(),
            String::from_utf8_lossy(&output.stderr)
        ));
    }
    eprintln!(
        "bench-error: mitsuba {} ran in {:.1} s with start-up and warm-up",
        variant.short(),
        start.elapsed().as_secs_f64()
    );
    let mut rows = Vec::new();
    for line in stdout.lines() {
        let f: Vec<&str> = line.split_whitespace().collect();
        if let ["warmup", w, c] = f[..] {
            eprintln!("bench-error: cornell   mitsuba {} warm-up render {w} s (cpu {c} s)", variant.short());
        }
        let ["render", spp, wall, cpu] = f[..] else { continue };
        let (Ok(spp), Ok(wall_s), Ok(cpu_s)) = (spp.parse::<u32>(), wall.parse::<f64>(), cpu.parse::<f64>())
        else {
            continue;
        };
        let image = renders.join(format!("cornell-mitsuba-{}-spp{spp}.exr", variant.short()));
        let (rmse, relmse) = errors(&read_exr(&image)?, reference)?;
        let label = format!("mitsuba {} path spp{spp}", variant.short());
        eprintln!(
            "bench-error: cornell   {label:40} {wall_s:8.2} s (cpu {cpu_s:7.2} s, render only)  RMSE {rmse:.3e}  relMSE {relmse:.3e}  load {load}"
        );
        rows.push(Row {
            scene: "cornell".into(),
            series: format!("mitsuba {} path", variant.short()),
            label,
            spp,
            wall_s,
            cpu_s,
            prepare_s: 0.0,
            peak_rss_mib: f64::NAN,
            rmse,
            relmse,
            load: load.clone(),
        });
    }
    Ok(rows)
}
