//! `examples/slurm` against a real Slurm: a one-node cluster of this machine
//! (`examples/slurm/local-cluster.sh`: munged, slurmctld and slurmd with their configuration,
//! state and logs in a temporary directory, addresses on the loopback only) renders the Cornell box as 4 tiles with a dependent merge job, and a
//! 3-frame RIB as a job array; the results are byte for byte the one-machine renders.
//!
//! Debian's `slurm-wlm` and `munge` are installed by `cargo xtask test` (and by this test, as
//! root, if they are missing). The test fails, never skips, when Slurm cannot start, and prints
//! the daemons' logs. It runs the daemons as root, as the issue's measurements did.

use std::path::{Path, PathBuf};
use std::process::{Command, Output, Stdio};
use std::time::{Duration, Instant};

/// Three frames of one RIB, each its own world (as `tests/merge.rs` uses).
const ANIMATION: &str = include_str!("data/animation.rib");

const PACKAGES: &[&str] = &["slurm-wlm", "munge"];

fn have(program: &str) -> bool {
    ["/usr/sbin", "/usr/bin", "/sbin", "/bin"].iter().any(|d| Path::new(d).join(program).is_file())
}

/// Installs the packages with apt when a daemon is missing (as `cargo xtask test` does).
fn ensure_slurm_installed() {
    if ["slurmctld", "slurmd", "munged", "sbatch"].iter().all(|p| have(p)) {
        return;
    }
    let status = Command::new("apt-get")
        .args(["install", "-y", "-q", "--no-install-recommends"])
        .args(PACKAGES)
        .env("DEBIAN_FRONTEND", "noninteractive")
        .status();
    assert!(
        status.is_ok_and(|s| s.success()),
        "Slurm is not installed and apt-get could not install {PACKAGES:?}: run `cargo xtask test`, which installs them"
    );
}

/// The daemons of a one-node cluster started by `examples/slurm/local-cluster.sh`; dropping it
/// stops them and (with the temporary directory) removes every file they wrote.
struct Cluster {
    dir: tempfile::TempDir,
    conf: PathBuf,
}

impl Cluster {
    fn start() -> Cluster {
        ensure_slurm_installed();
        let dir = tempfile::Builder::new().prefix("lrt-slurm-").tempdir().unwrap();
        let conf = dir.path().join("slurm.conf");
        let cluster = Cluster { dir, conf };
        let out = Command::new("bash")
            .arg(examples_dir().join("local-cluster.sh"))
            .arg("start")
            .arg(cluster.dir.path())
            .stdin(Stdio::null())
            .output()
            .expect("bash");
        if !out.status.success() {
            cluster.fail(&format!(
                "the local Slurm cluster did not start: {}{}",
                String::from_utf8_lossy(&out.stdout),
                String::from_utf8_lossy(&out.stderr)
            ));
        }
        cluster
    }

    /// A Slurm client command talking to this cluster.
    fn command(&self, program: &str, args: &[&str]) -> Command {
        let mut c = Command::new(program);
        c.args(args).env("SLURM_CONF", &self.conf).stdin(Stdio::null());
        c
    }

    fn logs(&self) -> String {
        let out = Command::new("bash")
            .arg(examples_dir().join("local-cluster.sh"))
            .arg("logs")
            .arg(self.dir.path())
            .output()
            .expect("bash");
        String::from_utf8_lossy(&out.stdout).into_owned()
    }

    fn fail(&self, message: &str) -> ! {
        panic!("{message}\n{}", self.logs());
    }

    /// Waits until none of `jobs` is queued or running; fails after `limit`.
    fn wait(&self, jobs: &[String], limit: Duration) {
        let start = Instant::now();
        loop {
            let out =
                self.command("squeue", &["-h", "-j", &jobs.join(","), "-o", "%i %T %r"]).output().unwrap();
            let text = String::from_utf8_lossy(&out.stdout).trim().to_string();
            if out.status.success() && text.is_empty() {
                return;
            }
            // A job whose dependency failed would wait forever: its state tells the caller.
            if text.contains("DependencyNeverSatisfied") {
                return;
            }
            if start.elapsed() > limit {
                self.fail(&format!("jobs {jobs:?} still queued after {limit:?}:\n{text}"));
            }
            std::thread::sleep(Duration::from_millis(250));
        }
    }

    /// The final state of a job (from `scontrol show job`, kept for a while after it ends).
    fn job_state(&self, job: &str) -> String {
        let out = self.command("scontrol", &["show", "job", job]).output().unwrap();
        let text = String::from_utf8_lossy(&out.stdout);
        text.split_whitespace().find_map(|w| w.strip_prefix("JobState=")).unwrap_or("?").to_string()
    }
}

impl Drop for Cluster {
    fn drop(&mut self) {
        let _ = Command::new("bash")
            .arg(examples_dir().join("local-cluster.sh"))
            .arg("stop")
            .arg(self.dir.path())
            .status();
    }
}

fn examples_dir() -> PathBuf {
    Path::new(env!("CARGO_MANIFEST_DIR")).join("../../examples/slurm")
}

fn run_ok(mut command: Command) -> Output {
    let out = command.output().unwrap();
    assert!(
        out.status.success(),
        "{command:?}: {}{}",
        String::from_utf8_lossy(&out.stdout),
        String::from_utf8_lossy(&out.stderr)
    );
    out
}

/// The Cornell box, small, with its depth table.
fn cornell_scene() -> String {
    let rib = std::fs::read_to_string(
        Path::new(env!("CARGO_MANIFEST_DIR")).join("../../../shared/reference/cornell/cornell.rib"),
    )
    .expect("../shared/reference/cornell/cornell.rib");
    let mut out = String::new();
    for line in rib.lines() {
        if line.starts_with("Display ") {
            out += "Display \"cornell.exr\" \"openexr\" \"rgb\"\nOption \"lrt\" \"string depthfile\" [\"cornell.depth\"]\n";
        } else if line.starts_with("Format ") {
            out += "Format 40 30 1\n";
        } else if line.starts_with("PixelSamples ") {
            out += "PixelSamples 2 2\n";
        } else {
            out += line;
            out.push('\n');
        }
    }
    out
}

#[test]
fn tiles_and_frames_through_a_real_slurm_equal_one_machine_renders() {
    let cluster = Cluster::start();
    let work = tempfile::Builder::new().prefix("lrt-slurm-work-").tempdir().unwrap();
    let w = work.path();
    std::fs::write(w.join("cornell.rib"), cornell_scene()).unwrap();
    std::fs::write(w.join("anim.rib"), ANIMATION).unwrap();
    let lrt_depth = env!("CARGO_BIN_EXE_lrt-depth");

    // One-machine renders to compare with, in a directory of their own.
    let reference = w.join("one-machine");
    std::fs::create_dir(&reference).unwrap();
    for (scene, extra) in [("cornell.rib", &[][..]), ("anim.rib", &["--frames", "1-3"][..])] {
        let mut c = Command::new(lrt_depth);
        c.current_dir(&reference).arg(w.join(scene)).arg("-q").args(extra);
        run_ok(c);
    }

    // The tiles and their merge, as a user submits them.
    let env = |c: &mut Command| {
        c.current_dir(w).env("LRT_DEPTH", lrt_depth).env("LRT_MERGE", env!("CARGO_BIN_EXE_lrt-merge"));
    };
    let submit = examples_dir().join("submit-tiles.sh");
    let mut c = cluster.command("bash", &[]);
    c.arg(&submit).args(["cornell.rib", "2,2", "cornell.exr", "cornell.depth", "-q"]);
    env(&mut c);
    let out = run_ok(c);
    let ids: Vec<String> =
        String::from_utf8_lossy(&out.stdout).split_whitespace().map(str::to_string).collect();
    assert_eq!(ids.len(), 2, "submit-tiles.sh printed {ids:?}");

    // The animation: frame 1 + K per task K.
    let anim = examples_dir().join("animation.sbatch");
    let mut c = cluster.command("sbatch", &["--parsable", "--array=0-2"]);
    c.arg(&anim).args(["anim.rib", "1-3", "-q"]);
    env(&mut c);
    let out = run_ok(c);
    let anim_job = String::from_utf8_lossy(&out.stdout).trim().split(';').next().unwrap().to_string();

    let mut jobs = ids.clone();
    jobs.push(anim_job.clone());
    cluster.wait(&jobs, Duration::from_secs(300));
    let merge_state = cluster.job_state(&ids[1]);
    if merge_state != "COMPLETED" {
        let outputs: Vec<String> = std::fs::read_dir(w)
            .unwrap()
            .flatten()
            .filter(|e| e.file_name().to_string_lossy().ends_with(".out"))
            .map(|e| {
                format!("{}:\n{}", e.path().display(), std::fs::read_to_string(e.path()).unwrap_or_default())
            })
            .collect();
        cluster.fail(&format!("the merge job ended {merge_state}\n{}", outputs.join("\n")));
    }

    let same = |a: &Path, b: &Path| {
        let (x, y) = (std::fs::read(a), std::fs::read(b));
        assert!(x.is_ok() && y.is_ok(), "{} or {} is missing", a.display(), b.display());
        assert!(x.unwrap() == y.unwrap(), "{} differs from {}", a.display(), b.display());
    };
    same(&w.join("cornell.exr"), &reference.join("cornell.exr"));
    same(&w.join("cornell.depth"), &reference.join("cornell.depth"));
    for f in 1..=3 {
        for ext in ["exr", "depth"] {
            let name = format!("anim.{f:04}.{ext}");
            same(&w.join(&name), &reference.join(&name));
        }
    }
    drop(cluster);
}
