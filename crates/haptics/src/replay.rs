//! Deterministic replay in simulated time, and the force log (CONTRACTS.md §5).
//!
//! Headless replay steps the haptic loop at its nominal rate in simulated time: tick `n` runs at
//! `t = start + n / rate`, whatever the frame rate or machine load, so two runs of the same
//! inputs produce byte-identical logs.

use crate::HapticError;
use crate::device::HapticDevice;
use crate::render::{HapticRenderer, SafetyCounters, TickOutput};
use std::fs::File;
use std::io::{BufWriter, Write};
use std::path::{Path, PathBuf};

/// The most ticks one replay may run (about 11.5 days at 1 kHz).
pub const MAX_REPLAY_TICKS: u64 = 1_000_000_000;

/// What to replay.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct ReplayConfig {
    /// Nominal loop rate (Hz).
    pub rate_hz: f64,
    /// First tick's time (s).
    pub start: f64,
    /// Last tick's time is the last multiple of the period not after `end` (s).
    pub end: f64,
}

impl ReplayConfig {
    /// Number of ticks the replay runs.
    pub fn tick_count(&self) -> Result<u64, HapticError> {
        if !(self.rate_hz.is_finite() && self.rate_hz > 0.0) {
            return Err(HapticError::Config(format!("replay rate {} Hz must be positive", self.rate_hz)));
        }
        if !(self.start.is_finite() && self.end.is_finite() && self.end >= self.start) {
            return Err(HapticError::Config(format!(
                "replay interval [{}, {}] is not a finite, non-empty interval",
                self.start, self.end
            )));
        }
        let ticks = ((self.end - self.start) * self.rate_hz + 1e-9).floor() + 1.0;
        if ticks > MAX_REPLAY_TICKS as f64 {
            return Err(HapticError::Config(format!(
                "replay of {} ticks exceeds the limit of {MAX_REPLAY_TICKS}",
                ticks
            )));
        }
        Ok(ticks as u64)
    }

    /// Time of tick `n`.
    pub fn time_of(&self, n: u64) -> f64 {
        self.start + n as f64 / self.rate_hz
    }
}

/// Figures of a finished replay.
#[derive(Clone, Copy, Debug, Default, PartialEq)]
pub struct ReplaySummary {
    pub ticks: u64,
    /// Ticks with the proxy in contact.
    pub contact_ticks: u64,
    /// Largest commanded force (N).
    pub max_force: f64,
    pub safety: SafetyCounters,
}

/// Runs the loop over `config`'s ticks in simulated time, calling `on_tick` after each.
/// A device error ends the replay with that error (after commanding zero force).
pub fn replay<D: HapticDevice + ?Sized>(
    device: &mut D,
    renderer: &mut HapticRenderer,
    config: &ReplayConfig,
    mut on_tick: impl FnMut(&TickOutput) -> Result<(), HapticError>,
) -> Result<ReplaySummary, HapticError> {
    let ticks = config.tick_count()?;
    let period = 1.0 / config.rate_hz;
    let mut summary = ReplaySummary::default();
    for n in 0..ticks {
        let time = config.time_of(n);
        let sample = match device.read(time) {
            Ok(s) => s,
            Err(e) => {
                let _ = device.apply_force(crate::SafeForce::ZERO, time);
                return Err(HapticError::Device(e));
            }
        };
        let out = renderer.tick(time, &sample, period);
        if let Err(e) = device.apply_force(out.force, time) {
            return Err(HapticError::Device(e));
        }
        summary.ticks += 1;
        summary.contact_ticks += (out.contacts > 0) as u64;
        summary.max_force = summary.max_force.max(out.force.get().length());
        on_tick(&out)?;
    }
    let _ = device.apply_force(crate::SafeForce::ZERO, config.time_of(ticks));
    summary.safety = renderer.counters();
    Ok(summary)
}

/// The force log's header line (CONTRACTS.md §5).
pub const FORCE_LOG_HEADER: &str = "t,device_x,device_y,device_z,proxy_x,proxy_y,proxy_z,fx,fy,fz";

/// Writes a force log atomically: rows go to a temporary file beside the target, which is
/// renamed over it by [`ForceLogWriter::finish`]. Dropped without finishing, it removes the
/// temporary file and leaves any existing log untouched.
#[derive(Debug)]
pub struct ForceLogWriter {
    target: PathBuf,
    temporary: PathBuf,
    out: Option<BufWriter<File>>,
    line: String,
}

impl ForceLogWriter {
    pub fn create(path: &Path) -> Result<ForceLogWriter, HapticError> {
        let name = path
            .file_name()
            .ok_or_else(|| HapticError::Io { path: path.to_path_buf(), detail: "not a file name".into() })?;
        let mut temp_name = std::ffi::OsString::from(".");
        temp_name.push(name);
        temp_name.push(format!(".tmp-{}", std::process::id()));
        let temporary = path.with_file_name(temp_name);
        let file = File::create(&temporary)
            .map_err(|e| HapticError::Io { path: temporary.clone(), detail: e.to_string() })?;
        let mut writer = ForceLogWriter {
            target: path.to_path_buf(),
            temporary,
            out: Some(BufWriter::new(file)),
            line: String::with_capacity(256),
        };
        writer.write_line(&format!("{FORCE_LOG_HEADER}\n"))?;
        Ok(writer)
    }

    fn write_line(&mut self, text: &str) -> Result<(), HapticError> {
        let out = self.out.as_mut().ok_or_else(|| HapticError::Io {
            path: self.target.clone(),
            detail: "the log is already finished".into(),
        })?;
        out.write_all(text.as_bytes())
            .map_err(|e| HapticError::Io { path: self.temporary.clone(), detail: e.to_string() })
    }

    /// Appends one tick's row.
    pub fn write(&mut self, out: &TickOutput) -> Result<(), HapticError> {
        let mut line = std::mem::take(&mut self.line);
        line.clear();
        let f = out.force.get();
        let values = [
            out.time,
            out.device.x,
            out.device.y,
            out.device.z,
            out.proxy_device.x,
            out.proxy_device.y,
            out.proxy_device.z,
            f.x,
            f.y,
            f.z,
        ];
        for (i, v) in values.iter().enumerate() {
            if i > 0 {
                line.push(',');
            }
            push_number(&mut line, *v);
        }
        line.push('\n');
        let result = self.write_line(&line);
        self.line = line;
        result
    }

    /// Flushes and moves the log into place.
    pub fn finish(mut self) -> Result<(), HapticError> {
        let out = self.out.take().ok_or_else(|| HapticError::Io {
            path: self.target.clone(),
            detail: "the log is already finished".into(),
        })?;
        let file = out
            .into_inner()
            .map_err(|e| HapticError::Io { path: self.temporary.clone(), detail: e.error().to_string() })?;
        file.sync_all()
            .map_err(|e| HapticError::Io { path: self.temporary.clone(), detail: e.to_string() })?;
        drop(file);
        std::fs::rename(&self.temporary, &self.target)
            .map_err(|e| HapticError::Io { path: self.target.clone(), detail: e.to_string() })
    }
}

impl Drop for ForceLogWriter {
    fn drop(&mut self) {
        if self.out.take().is_some() {
            let _ = std::fs::remove_file(&self.temporary);
        }
    }
}

/// Shortest round-trip decimal, in plain notation for ordinary magnitudes and exponent notation
/// for tiny or huge ones; `-0` is written `0`.
fn push_number(out: &mut String, v: f64) {
    use std::fmt::Write as _;
    if v == 0.0 {
        out.push('0');
    } else if (1e-4..1e15).contains(&v.abs()) {
        let _ = write!(out, "{v}");
    } else {
        let _ = write!(out, "{v:e}");
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn numbers_are_short_and_round_trip() {
        let mut s = String::new();
        for v in [0.0, -0.0, 0.001, -1.25, 1e-7, 3.0e20, 0.1 + 0.2] {
            s.clear();
            push_number(&mut s, v);
            assert_eq!(s.parse::<f64>().unwrap(), if v == 0.0 { 0.0 } else { v }, "{s}");
        }
        s.clear();
        push_number(&mut s, 1e-7);
        assert_eq!(s, "1e-7");
        s.clear();
        push_number(&mut s, -0.0);
        assert_eq!(s, "0");
    }

    #[test]
    fn tick_count_and_times() {
        let c = ReplayConfig { rate_hz: 1000.0, start: 0.0, end: 1.0 };
        assert_eq!(c.tick_count().unwrap(), 1001);
        assert_eq!(c.time_of(1000), 1.0);
        assert_eq!(c.time_of(3), 0.003);
        assert!(ReplayConfig { rate_hz: 0.0, start: 0.0, end: 1.0 }.tick_count().is_err());
        assert!(ReplayConfig { rate_hz: 1e3, start: 1.0, end: 0.0 }.tick_count().is_err());
        assert!(ReplayConfig { rate_hz: 1e9, start: 0.0, end: 1e9 }.tick_count().is_err());
    }
}
