//! Each pass's share of a frame, for profiling (`Compositor::set_pass_timing`): with timing on,
//! a frame submits and waits for the GPU after each of its passes, and counts the time each took
//! (wall time, and on Unix the CPU time of every thread of the process, which on a software
//! rasteriser such as lavapipe is the GPU's work and is steadier than wall time on a shared
//! machine). The waits serialise the frame, so a timed frame is slower than an untimed one; the
//! pixels are the same.

use std::cell::RefCell;
use std::time::{Duration, Instant};

/// What one pass cost over the frames timed.
#[derive(Clone, Debug, PartialEq)]
pub struct PassTime {
    /// The pass, in words.
    pub pass: &'static str,
    /// Frames in which it was recorded.
    pub frames: u32,
    /// Wall time, summed over those frames.
    pub wall: Duration,
    /// CPU time of the process's threads, summed over those frames (`None` where the platform
    /// does not say).
    pub cpu: Option<Duration>,
}

/// Whether frames are timed, and what their passes took so far.
#[derive(Debug, Default)]
pub(super) struct PassTiming {
    pub(super) on: bool,
    /// Frames timed.
    pub(super) frames: std::cell::Cell<u32>,
    totals: RefCell<Vec<PassTime>>,
}

impl PassTiming {
    /// With timing on, submits what `encoder` holds (the pass `pass` and nothing before it that
    /// was not timed), waits for it and counts its time against `pass`; `encoder` is left a new,
    /// empty one. Without, does nothing.
    pub(super) fn lap(
        &self,
        device: &wgpu::Device,
        queue: &wgpu::Queue,
        encoder: &mut wgpu::CommandEncoder,
        pass: &'static str,
    ) {
        if !self.on {
            return;
        }
        let fresh = device.create_command_encoder(&wgpu::CommandEncoderDescriptor { label: Some("frame") });
        let recorded = std::mem::replace(encoder, fresh);
        let (wall_start, cpu_start) = (Instant::now(), process_cpu_time());
        queue.submit([recorded.finish()]);
        // An error here shows in the frame's own wait; the time is still counted.
        let _ = device.poll(wgpu::PollType::wait_indefinitely());
        let wall = wall_start.elapsed();
        let cpu = cpu_start.zip(process_cpu_time()).map(|(a, b)| b.saturating_sub(a));
        let mut totals = self.totals.borrow_mut();
        match totals.iter_mut().find(|t| t.pass == pass) {
            Some(t) => {
                t.frames += 1;
                t.wall += wall;
                t.cpu = t.cpu.zip(cpu).map(|(a, b)| a + b);
            }
            None => totals.push(PassTime { pass, frames: 1, wall, cpu }),
        }
    }

    /// What each pass took, in the order first met.
    pub(super) fn totals(&self) -> Vec<PassTime> {
        self.totals.borrow().clone()
    }
}

/// The CPU time of this process, every thread counted, ended ones too (`getrusage`, user and
/// system), `None` where the platform does not say.
#[cfg(unix)]
pub fn process_cpu_time() -> Option<Duration> {
    // SAFETY: getrusage only writes the struct it is given, which is plain data.
    let mut usage: libc::rusage = unsafe { std::mem::zeroed() };
    // SAFETY: `usage` is a valid, writable rusage.
    if unsafe { libc::getrusage(libc::RUSAGE_SELF, &mut usage) } != 0 {
        return None;
    }
    let time = |t: libc::timeval| {
        Duration::from_secs(u64::try_from(t.tv_sec).ok()?)
            .checked_add(Duration::from_micros(u64::try_from(t.tv_usec).ok()?))
    };
    time(usage.ru_utime)?.checked_add(time(usage.ru_stime)?)
}

/// The CPU time of this process: not known on this platform.
#[cfg(not(unix))]
pub fn process_cpu_time() -> Option<Duration> {
    None
}

#[cfg(test)]
mod tests {
    use super::process_cpu_time;

    /// Where the platform says (Unix), the process's CPU time grows with work done, also while
    /// other threads end (the tests of this binary run in threads of their own).
    #[test]
    fn cpu_time_grows_with_work() {
        let unix = cfg!(unix);
        let Some(before) = process_cpu_time() else {
            assert!(!unix, "Unix gives the process's CPU time");
            return;
        };
        let mut x = 0u64;
        for k in 0..20_000_000u64 {
            x = x.wrapping_mul(6364136223846793005).wrapping_add(k);
        }
        std::hint::black_box(x);
        let after = process_cpu_time().expect("read twice");
        assert!(after > before, "{after:?} after work, {before:?} before");
    }
}
