//! Running a child process and measuring it: wall time, the child's own CPU time (user plus
//! system, which moves less with other load than wall time) and its peak resident memory.

use std::process::{Command, Stdio};
use std::time::Instant;

/// What one measured run of a child gave.
pub struct ChildRun {
    pub wall_s: f64,
    pub cpu_s: f64,
    pub peak_rss_mib: f64,
    pub success: bool,
    pub stdout: String,
    pub stderr: String,
}

/// Runs `cmd` with its output captured and waits for it with `wait4`, so that the CPU time
/// and `ru_maxrss` are the child's alone.
pub fn run_measured(cmd: &mut Command) -> Result<ChildRun, String> {
    cmd.stdin(Stdio::null()).stdout(Stdio::piped()).stderr(Stdio::piped());
    let start = Instant::now();
    let mut child = cmd.spawn().map_err(|e| format!("cannot start {:?}: {e}", cmd.get_program()))?;
    let pid = child.id() as libc::pid_t;
    // Read the pipes on threads so the child never blocks on a full pipe.
    let read = |pipe: Option<Box<dyn std::io::Read + Send>>| {
        std::thread::spawn(move || {
            let mut s = String::new();
            if let Some(mut p) = pipe {
                let _ = p.read_to_string(&mut s);
            }
            s
        })
    };
    let out_thread = read(child.stdout.take().map(|p| Box::new(p) as _));
    let err_thread = read(child.stderr.take().map(|p| Box::new(p) as _));
    let mut status = 0;
    // SAFETY: `rusage` is plain data; wait4 fills it for the child we started and reaped here.
    let mut usage: libc::rusage = unsafe { std::mem::zeroed() };
    let r = unsafe { libc::wait4(pid, &mut status, 0, &mut usage) };
    let wall_s = start.elapsed().as_secs_f64();
    let stdout = out_thread.join().unwrap_or_default();
    let stderr = err_thread.join().unwrap_or_default();
    if r != pid {
        return Err(format!(
            "waiting for {:?} failed: {}",
            cmd.get_program(),
            std::io::Error::last_os_error()
        ));
    }
    let seconds = |t: libc::timeval| t.tv_sec as f64 + t.tv_usec as f64 * 1e-6;
    Ok(ChildRun {
        wall_s,
        cpu_s: seconds(usage.ru_utime) + seconds(usage.ru_stime),
        // ru_maxrss is in KiB on Linux.
        peak_rss_mib: usage.ru_maxrss as f64 / 1024.0,
        success: libc::WIFEXITED(status) && libc::WEXITSTATUS(status) == 0,
        stdout,
        stderr,
    })
}
