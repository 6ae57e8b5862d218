//! The dedicated haptic thread: reads the device, renders, commands the force, at a fixed rate
//! (1 kHz by default), and exchanges state with the viewer through triple buffers so that
//! neither side ever waits for the other (see [`crate::triple_buffer`] for why).
//!
//! Safety, per tick:
//! - the force goes through [`SafeForce`]: finite and within the device's limit;
//! - the force ramps in at start and after anything that may make it jump (see
//!   [`crate::RenderSettings::ramp_time`]);
//! - a software watchdog: if more than `watchdog_timeout` passed since the last force was
//!   commanded (a tick overran: the machine stalled, the thread was descheduled), this tick
//!   commands zero and the force ramps in again; a device whose hardware has a watchdog gets it
//!   armed with the same timeout;
//! - a device that fails, or whose read takes longer than `device_timeout`, stops the loop
//!   cleanly: zero force is commanded (if the device still listens) and the error is returned
//!   from [`HapticThread::stop`] and flagged in the published state.

use crate::HapticError;
use crate::device::{DeviceError, HapticDevice, SafeForce};
use crate::render::{HapticRenderer, SafetyCounters, TickOutput, WorkspaceMapping};
use crate::replay::ForceLogWriter;
use crate::timing::{DurationHistogram, DurationSummary};
use crate::triple_buffer::{self, Reader, Writer};
use glam::DVec3;
use std::sync::Arc;
use std::sync::atomic::{AtomicBool, Ordering};
use std::sync::mpsc::{Receiver, SyncSender, TryRecvError, TrySendError};
use std::thread::JoinHandle;
use std::time::{Duration, Instant};

/// Settings of the haptic thread.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct ThreadConfig {
    /// Loop rate (Hz).
    pub rate_hz: f64,
    /// Longest time between two force commands before the force is zeroed for a tick.
    pub watchdog_timeout: Duration,
    /// Longest a device read may take before the device counts as not answering.
    pub device_timeout: Duration,
    /// The loop sleeps until this long before each deadline, then spins: sleeping alone wakes
    /// tens of microseconds late, spinning alone burns a core.
    pub spin: Duration,
    /// Ask for real-time scheduling (Linux `SCHED_FIFO`), as haptic SDKs do, so other work
    /// cannot delay ticks. Without the privilege the loop runs at normal priority and the
    /// report says so.
    pub realtime: bool,
}

impl Default for ThreadConfig {
    fn default() -> ThreadConfig {
        ThreadConfig {
            rate_hz: 1000.0,
            watchdog_timeout: Duration::from_millis(5),
            device_timeout: Duration::from_millis(100),
            spin: Duration::from_micros(50),
            realtime: true,
        }
    }
}

/// Where the thread is.
#[derive(Clone, Copy, Debug, Default, PartialEq, Eq)]
pub enum ThreadStatus {
    #[default]
    Starting,
    Running,
    /// Stopped on request.
    Stopped,
    /// Stopped by a device error; [`HapticThread::stop`] returns it.
    Failed,
}

/// The state the haptic thread publishes every tick.
#[derive(Clone, Copy, Debug, Default, PartialEq)]
pub struct HapticState {
    pub tick: u64,
    /// Seconds since the loop started.
    pub time: f64,
    /// Device position (device frame, m).
    pub device: DVec3,
    /// Proxy (the drawn sphere's centre) in the scene.
    pub proxy_scene: DVec3,
    /// The proxy's goal (the device mapped into the scene).
    pub goal_scene: DVec3,
    /// Commanded force (device frame, N).
    pub force: DVec3,
    pub contacts: u32,
    pub buttons: u32,
    pub status: ThreadStatus,
    pub watchdog_trips: u64,
}

/// Run-time settings the viewer may change.
#[derive(Clone, Copy, Debug, PartialEq)]
struct Controls {
    mapping: WorkspaceMapping,
    stiffness_scale: f64,
}

/// Timing and safety figures of a finished run.
#[derive(Clone, Copy, Debug, Default, PartialEq)]
pub struct ThreadReport {
    pub ticks: u64,
    pub elapsed: Duration,
    /// Ticks per second over the run.
    pub rate_hz: f64,
    /// Time from one tick's start to the next's (jitter shows in its spread).
    pub period: DurationSummary,
    /// Time spent in one tick's work (read, render, command).
    pub compute: DurationSummary,
    /// Ticks that started more than half a period late.
    pub late_ticks: u64,
    pub watchdog_trips: u64,
    /// Whether the device's own hardware watchdog was armed.
    pub hardware_watchdog: bool,
    /// The real-time priority the loop ran at, when it got one.
    pub realtime_priority: Option<i32>,
    /// Force-log rows written, and rows dropped because the logger fell behind (the loop never
    /// waits for the disk).
    pub log_rows: u64,
    pub log_dropped: u64,
    pub safety: SafetyCounters,
}

impl std::fmt::Display for ThreadReport {
    fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
        let us = |d: Duration| d.as_secs_f64() * 1e6;
        write!(
            f,
            "{} ticks in {:.3} s ({:.1} Hz); period p50 {:.1} us, p99 {:.1} us, max {:.1} us; \
             tick work p50 {:.1} us, p99 {:.1} us, max {:.1} us; late ticks {}, watchdog trips {}; {}{}",
            self.ticks,
            self.elapsed.as_secs_f64(),
            self.rate_hz,
            us(self.period.p50),
            us(self.period.p99),
            us(self.period.max),
            us(self.compute.p50),
            us(self.compute.p99),
            us(self.compute.max),
            self.late_ticks,
            self.watchdog_trips,
            match self.realtime_priority {
                Some(p) => format!("real-time priority {p}"),
                None => "normal priority".to_string(),
            },
            if self.log_rows + self.log_dropped > 0 {
                format!("; force log {} rows, {} dropped", self.log_rows, self.log_dropped)
            } else {
                String::new()
            }
        )
    }
}

/// A running haptic thread. Dropping it stops the thread (forces zeroed).
#[derive(Debug)]
pub struct HapticThread {
    state: Reader<HapticState>,
    controls: Writer<Controls>,
    current: Controls,
    stop: Arc<AtomicBool>,
    handle: Option<JoinHandle<Result<ThreadReport, HapticError>>>,
    logger: Option<JoinHandle<Result<u64, HapticError>>>,
}

/// Rows the force log may queue before the loop starts dropping them (16 s at 1 kHz).
const LOG_QUEUE: usize = 16_384;

impl HapticThread {
    /// Starts the loop on a new thread named `haptics`.
    pub fn spawn(
        device: Box<dyn HapticDevice>,
        renderer: HapticRenderer,
        config: ThreadConfig,
    ) -> Result<HapticThread, HapticError> {
        HapticThread::spawn_logged(device, renderer, config, None)
    }

    /// Starts the loop and writes every tick to `log` (CONTRACTS.md §5's force log). The rows
    /// go through a bounded queue to a logger thread that polls it, so the loop never blocks
    /// on the disk; the log is finished (atomically moved into place) by [`HapticThread::stop`].
    pub fn spawn_logged(
        device: Box<dyn HapticDevice>,
        renderer: HapticRenderer,
        config: ThreadConfig,
        log: Option<ForceLogWriter>,
    ) -> Result<HapticThread, HapticError> {
        if !(config.rate_hz.is_finite() && config.rate_hz > 0.0 && config.rate_hz <= 100_000.0) {
            return Err(HapticError::Config(format!(
                "haptic rate {} Hz is not in (0, 100000]",
                config.rate_hz
            )));
        }
        let (state_writer, state_reader) = triple_buffer::triple_buffer(HapticState::default());
        let current = Controls { mapping: renderer.mapping(), stiffness_scale: 1.0 };
        let (controls_writer, controls_reader) = triple_buffer::triple_buffer(current);
        let stop = Arc::new(AtomicBool::new(false));
        let stop_flag = Arc::clone(&stop);
        let (log_sender, logger) = match log {
            Some(writer) => {
                let (sender, receiver) = std::sync::mpsc::sync_channel(LOG_QUEUE);
                let logger = std::thread::Builder::new()
                    .name("haptics-log".into())
                    .spawn(move || write_log(writer, receiver))
                    .map_err(|e| HapticError::Config(format!("cannot start the force logger: {e}")))?;
                (Some(sender), Some(logger))
            }
            None => (None, None),
        };
        let handle = std::thread::Builder::new()
            .name("haptics".into())
            .spawn(move || {
                run_loop(device, renderer, config, state_writer, controls_reader, &stop_flag, log_sender)
            })
            .map_err(|e| HapticError::Config(format!("cannot start the haptic thread: {e}")))?;
        Ok(HapticThread {
            state: state_reader,
            controls: controls_writer,
            current,
            stop,
            handle: Some(handle),
            logger,
        })
    }

    /// The latest published state. Never blocks.
    pub fn state(&mut self) -> HapticState {
        self.state.read()
    }

    /// Changes the device-to-scene mapping; the haptic thread picks it up on its next tick.
    pub fn set_mapping(&mut self, mapping: WorkspaceMapping) {
        self.current.mapping = mapping;
        self.controls.write(self.current);
    }

    /// Scales the stiffness of every material (1 = as given).
    pub fn set_stiffness_scale(&mut self, scale: f64) {
        self.current.stiffness_scale = scale;
        self.controls.write(self.current);
    }

    /// True once the thread has ended (on request or by an error).
    pub fn is_finished(&self) -> bool {
        self.handle.as_ref().is_none_or(|h| h.is_finished())
    }

    /// Stops the loop (forces zeroed) and returns its report, or the error that stopped it.
    pub fn stop(mut self) -> Result<ThreadReport, HapticError> {
        self.join()
    }

    fn join(&mut self) -> Result<ThreadReport, HapticError> {
        self.stop.store(true, Ordering::Release);
        let result = match self.handle.take() {
            Some(handle) => handle.join().unwrap_or(Err(HapticError::ThreadPanicked)),
            None => Err(HapticError::Config("the haptic thread was already stopped".into())),
        };
        // The loop has ended and dropped its end of the queue: the logger drains and finishes.
        let logged = self.logger.take().map(|l| l.join().unwrap_or(Err(HapticError::ThreadPanicked)));
        let mut report = result?;
        if let Some(logged) = logged {
            report.log_rows = logged?;
        }
        Ok(report)
    }
}

impl Drop for HapticThread {
    fn drop(&mut self) {
        if self.handle.is_some() {
            let _ = self.join();
        }
    }
}

fn run_loop(
    mut device: Box<dyn HapticDevice>,
    mut renderer: HapticRenderer,
    config: ThreadConfig,
    mut state: Writer<HapticState>,
    mut controls: Reader<Controls>,
    stop: &AtomicBool,
    log: Option<SyncSender<TickOutput>>,
) -> Result<ThreadReport, HapticError> {
    let period = Duration::from_secs_f64(1.0 / config.rate_hz);
    let mut report = ThreadReport::default();
    let mut period_hist = DurationHistogram::default();
    let mut compute_hist = DurationHistogram::default();
    let mut published = HapticState { status: ThreadStatus::Running, ..HapticState::default() };

    let fail = |device: &mut Box<dyn HapticDevice>,
                state: &mut Writer<HapticState>,
                mut published: HapticState,
                error: DeviceError| {
        // Zero the force if the device still listens; the error is what matters.
        let _ = device.apply_force(SafeForce::ZERO, published.time);
        published.status = ThreadStatus::Failed;
        published.force = DVec3::ZERO;
        state.write(published);
        Err(HapticError::Device(error))
    };

    if config.realtime {
        report.realtime_priority = raise_priority();
    }
    report.hardware_watchdog = match device.arm_watchdog(config.watchdog_timeout) {
        Ok(armed) => armed,
        Err(e) => return fail(&mut device, &mut state, published, e),
    };
    let start = Instant::now();
    let mut next_deadline = start;
    let mut previous_start: Option<Instant> = None;
    let mut last_command = start;
    let mut tick: u64 = 0;
    while !stop.load(Ordering::Acquire) {
        let tick_start = Instant::now();
        if tick_start > next_deadline + period / 2 {
            report.late_ticks += 1;
        }
        let dt = match previous_start {
            Some(p) => {
                let d = tick_start - p;
                period_hist.record(d);
                d.as_secs_f64()
            }
            None => period.as_secs_f64(),
        };
        previous_start = Some(tick_start);
        if controls.has_update() {
            let c = controls.read();
            renderer.set_mapping(c.mapping);
            renderer.set_stiffness_scale(c.stiffness_scale);
        }
        let time = (tick_start - start).as_secs_f64();
        published.time = time;
        let sample = match device.read(time) {
            Ok(s) => s,
            Err(e) => return fail(&mut device, &mut state, published, e),
        };
        let read_took = tick_start.elapsed();
        if read_took > config.device_timeout {
            let error = DeviceError::NotAnswering { device: device.specs().name.clone(), waited: read_took };
            return fail(&mut device, &mut state, published, error);
        }
        let out = renderer.tick(time, &sample, dt);
        // Software watchdog: a stale force has been on the device for too long.
        let now = Instant::now();
        let force = if tick > 0 && now - last_command > config.watchdog_timeout {
            report.watchdog_trips += 1;
            renderer.restart_ramp();
            SafeForce::ZERO
        } else {
            out.force
        };
        if let Err(e) = device.apply_force(force, time) {
            return fail(&mut device, &mut state, published, e);
        }
        last_command = Instant::now();
        compute_hist.record(last_command - tick_start);
        if let Some(log) = &log {
            // Never wait for the logger: a full queue drops the row (and counts it).
            match log.try_send(TickOutput { force, ..out }) {
                Ok(()) => {}
                Err(TrySendError::Full(_)) | Err(TrySendError::Disconnected(_)) => report.log_dropped += 1,
            }
        }

        published = HapticState {
            tick,
            time,
            device: out.device,
            proxy_scene: out.proxy_scene,
            goal_scene: out.goal_scene,
            force: force.get(),
            contacts: out.contacts,
            buttons: out.buttons,
            status: ThreadStatus::Running,
            watchdog_trips: report.watchdog_trips,
        };
        state.write(published);
        tick += 1;

        next_deadline += period;
        let now = Instant::now();
        if now > next_deadline + period {
            // Far behind (a stall): start afresh rather than run a burst of catch-up ticks.
            next_deadline = now;
        }
        wait_until(next_deadline, config.spin);
    }
    let _ = device.apply_force(SafeForce::ZERO, published.time);
    published.status = ThreadStatus::Stopped;
    published.force = DVec3::ZERO;
    state.write(published);

    report.ticks = tick;
    report.elapsed = start.elapsed();
    report.rate_hz =
        if report.elapsed > Duration::ZERO { tick as f64 / report.elapsed.as_secs_f64() } else { 0.0 };
    report.period = period_hist.summary();
    report.compute = compute_hist.summary();
    report.safety = renderer.counters();
    Ok(report)
}

/// Real-time priority for the calling thread (the haptic loop): `SCHED_FIFO` at 80, below the
/// kernel's own threads. `None` when not permitted or not on Linux.
#[cfg(target_os = "linux")]
fn raise_priority() -> Option<i32> {
    const PRIORITY: i32 = 80;
    let param = libc::sched_param { sched_priority: PRIORITY };
    // SAFETY: `sched_setscheduler` with pid 0 changes only the calling thread and reads only
    // the valid `param` passed by reference.
    let rc = unsafe { libc::sched_setscheduler(0, libc::SCHED_FIFO, &param) };
    (rc == 0).then_some(PRIORITY)
}

#[cfg(not(target_os = "linux"))]
fn raise_priority() -> Option<i32> {
    None
}

/// The logger thread: polls the queue (so the loop never has to wake it), writes every row, and
/// finishes the log when the loop has gone.
fn write_log(mut writer: ForceLogWriter, rows: Receiver<TickOutput>) -> Result<u64, HapticError> {
    let mut written = 0u64;
    loop {
        match rows.try_recv() {
            Ok(row) => {
                writer.write(&row)?;
                written += 1;
            }
            Err(TryRecvError::Empty) => std::thread::sleep(Duration::from_millis(2)),
            Err(TryRecvError::Disconnected) => break,
        }
    }
    writer.finish()?;
    Ok(written)
}

fn wait_until(deadline: Instant, spin: Duration) {
    let now = Instant::now();
    if deadline <= now {
        return;
    }
    let remaining = deadline - now;
    if remaining > spin {
        std::thread::sleep(remaining - spin);
    }
    while Instant::now() < deadline {
        std::hint::spin_loop();
    }
}
