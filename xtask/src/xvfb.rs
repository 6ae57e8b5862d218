//! A private virtual X server for the window tests.
//!
//! `xvfb-run` proved unreliable in CI: once its server was up, the first client was refused
//! ("Failed to open connection to X server"), which points at its cookie set-up through `xauth`
//! or the server resetting between clients. This module starts `Xvfb` itself, without cookies
//! (`-ac`, local connections only with `-nolisten tcp`) and without resets (`-noreset`), and
//! waits until an X connection handshake really succeeds before any test runs. When the server
//! cannot be reached, the error carries the server's own log.

use std::io::{Read, Write};
use std::os::unix::net::UnixStream;
use std::path::{Path, PathBuf};
use std::process::{Child, Command, Stdio};
use std::time::{Duration, Instant};

/// How long a starting server may take before the handshake must succeed.
const START_TIMEOUT: Duration = Duration::from_secs(30);

/// A running `Xvfb`, killed when dropped.
pub struct VirtualDisplay {
    child: Child,
    number: u32,
    log: PathBuf,
}

impl VirtualDisplay {
    /// Starts `Xvfb` on the first free display number from 90 and waits until it accepts a
    /// connection.
    pub fn start() -> Result<VirtualDisplay, String> {
        let mut last_error = String::from("no free display number in :90..:189");
        for number in 90..190 {
            if display_is_taken(number) {
                continue;
            }
            let log = std::env::temp_dir().join(format!("xtask-xvfb-{number}.log"));
            let log_file =
                std::fs::File::create(&log).map_err(|e| format!("cannot create {}: {e}", log.display()))?;
            let child = Command::new("Xvfb")
                .arg(format!(":{number}"))
                .args(["-screen", "0", "1280x1024x24", "-nolisten", "tcp", "-noreset", "-ac"])
                .stdin(Stdio::null())
                .stdout(Stdio::null())
                .stderr(log_file)
                .spawn()
                .map_err(|e| format!("cannot start Xvfb: {e}"))?;
            let mut display = VirtualDisplay { child, number, log };
            match display.wait_until_ready() {
                Ok(()) => {
                    eprintln!("xtask: Xvfb is up on DISPLAY=:{number}");
                    return Ok(display);
                }
                // Another server took this number between the lock check and our start.
                Err(e) => last_error = e,
            }
        }
        Err(last_error)
    }

    /// The value of `DISPLAY` for clients.
    pub fn display(&self) -> String {
        format!(":{}", self.number)
    }

    fn wait_until_ready(&mut self) -> Result<(), String> {
        let deadline = Instant::now() + START_TIMEOUT;
        loop {
            if let Ok(Some(status)) = self.child.try_wait() {
                return Err(format!("Xvfb :{} exited with {status}: {}", self.number, self.log_text()));
            }
            match handshake(self.number) {
                Ok(()) => return Ok(()),
                Err(e) if Instant::now() >= deadline => {
                    return Err(format!(
                        "Xvfb :{} did not accept a connection within {:?} ({e}): {}",
                        self.number,
                        START_TIMEOUT,
                        self.log_text()
                    ));
                }
                Err(_) => std::thread::sleep(Duration::from_millis(50)),
            }
        }
    }

    fn log_text(&self) -> String {
        std::fs::read_to_string(&self.log).unwrap_or_default()
    }
}

impl Drop for VirtualDisplay {
    fn drop(&mut self) {
        // SIGTERM first: the server then removes its lock file and socket.
        if let Ok(pid) = libc::pid_t::try_from(self.child.id()) {
            // SAFETY: kill(2) on our own child's pid has no memory-safety preconditions.
            unsafe { libc::kill(pid, libc::SIGTERM) };
            let deadline = Instant::now() + Duration::from_secs(5);
            while Instant::now() < deadline && matches!(self.child.try_wait(), Ok(None)) {
                std::thread::sleep(Duration::from_millis(20));
            }
        }
        let _ = self.child.kill();
        let _ = self.child.wait();
        let _ = std::fs::remove_file(&self.log);
    }
}

/// Whether display `number` belongs to a running X server (see [`lock_names_live_process`]).
fn display_is_taken(number: u32) -> bool {
    lock_names_live_process(Path::new(&format!("/tmp/.X{number}-lock")))
}

/// Whether the X lock file at `lock` names a running process. A lock left by a server that was
/// killed (a run interrupted with SIGKILL) does not count: Xvfb itself removes such a stale lock
/// when it starts on that number, so the display is free.
fn lock_names_live_process(lock: &Path) -> bool {
    let Ok(text) = std::fs::read_to_string(lock) else {
        return false;
    };
    match text.trim().parse::<u32>() {
        Ok(pid) => Path::new(&format!("/proc/{pid}")).exists(),
        // A lock not yet written in full may be a server starting: leave that number alone.
        Err(_) => true,
    }
}

/// Connects to display `number` the way Xlib does (the abstract socket first, then the file
/// socket) and performs the X11 connection setup without authorisation.
fn handshake(number: u32) -> Result<(), String> {
    let path = format!("/tmp/.X11-unix/X{number}");
    let mut stream = connect_abstract(&path)
        .or_else(|_| UnixStream::connect(&path))
        .map_err(|e| format!("cannot connect to {path}: {e}"))?;
    stream.set_read_timeout(Some(Duration::from_secs(5))).map_err(|e| e.to_string())?;
    // Byte order 'l' (little endian), protocol 11.0, empty authorisation name and data.
    let setup: [u8; 12] = [b'l', 0, 11, 0, 0, 0, 0, 0, 0, 0, 0, 0];
    stream.write_all(&setup).map_err(|e| format!("cannot send the X setup request: {e}"))?;
    let mut header = [0u8; 8];
    stream.read_exact(&mut header).map_err(|e| format!("no X setup reply: {e}"))?;
    match header[0] {
        1 => Ok(()),
        status => {
            let reason_len = usize::from(header[1]);
            let mut reason = vec![0u8; reason_len];
            let _ = stream.read_exact(&mut reason);
            Err(format!(
                "X server refused the connection (status {status}): {}",
                String::from_utf8_lossy(&reason)
            ))
        }
    }
}

#[cfg(target_os = "linux")]
fn connect_abstract(path: &str) -> std::io::Result<UnixStream> {
    use std::os::linux::net::SocketAddrExt;
    let address = std::os::unix::net::SocketAddr::from_abstract_name(path.as_bytes())?;
    UnixStream::connect_addr(&address)
}

#[cfg(not(target_os = "linux"))]
fn connect_abstract(_path: &str) -> std::io::Result<UnixStream> {
    Err(std::io::Error::new(std::io::ErrorKind::Unsupported, "no abstract sockets"))
}

#[cfg(test)]
mod tests {
    use super::lock_names_live_process;

    #[test]
    fn a_lock_counts_only_while_its_process_runs() {
        let dir = tempfile::tempdir().unwrap();
        let lock = dir.path().join(".X90-lock");
        assert!(!lock_names_live_process(&lock), "no lock file: the display is free");
        // X writes the pid right-aligned in ten characters and a newline.
        std::fs::write(&lock, format!("{:>10}\n", std::process::id())).unwrap();
        assert!(lock_names_live_process(&lock), "our own pid is alive");
        std::fs::write(&lock, format!("{:>10}\n", u32::MAX)).unwrap();
        assert!(!lock_names_live_process(&lock), "no process has this pid: a stale lock");
        std::fs::write(&lock, "").unwrap();
        assert!(lock_names_live_process(&lock), "a lock still being written is left alone");
    }
}
