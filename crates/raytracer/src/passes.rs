//! Rendering in passes: progressive photon mapping ([`crate::photon::progressive`]), a time
//! budget (`--time`) and adaptive sampling toward a target error (`--target-error`).
//!
//! Pass `i` renders samples `i * spp .. (i + 1) * spp` of every pixel still sampling (so the
//! passes continue one stratified sequence per pixel), with the integrator of that pass (a new
//! photon map in progressive mode, the same integrator otherwise). A pixel's value is the
//! average of its passes.
//!
//! The error of a pixel is estimated from the spread of its pass values: with `n` passes of
//! mean `m` and sample variance `s^2` per channel, the estimated relative MSE of the mean is
//! the average over channels of `s^2 / n / (m^2 + 0.01)` (the `relMSE` of
//! `docs/performance.md`, with the estimate in place of the reference). `--target-error E`
//! stops a pixel once the square root of that (its relative standard error) is at most `E`,
//! after at least [`MIN_PASSES`] passes. The estimate sees noise, not bias; progressive photon
//! mapping's bias falls with its radius, and the default photon map's floor is not seen.
//!
//! Determinism: which pixels sample in a pass depends only on earlier passes, and each pass is
//! deterministic, so an image depends on the seed and the number of passes, never on the
//! threads. A time budget decides the number of passes, which `--stats` reports (the same
//! image again: `passes` or `--target-error` without `--time`).

use crate::integrators::{Integrator, RayCounters};
use crate::render::{Frame, RenderOptions};
use std::time::{Duration, Instant};

/// Passes a pixel takes before its error estimate may stop it.
pub const MIN_PASSES: u32 = 4;
/// The most passes of a render that a time budget or a target error leaves open.
pub const MAX_PASSES: u32 = 1 << 16;

/// How many passes, and what stops them.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct PassPlan {
    pub max_passes: u32,
    pub time_budget: Option<Duration>,
    pub target_error: Option<f32>,
    pub spp: u32,
}

impl PassPlan {
    /// The plan for `integrator` under `options`; `None` for a plain one-pass render.
    pub fn new(integrator: &dyn Integrator, options: &RenderOptions, spp: u32) -> Option<PassPlan> {
        let open = options.time_budget.is_some() || options.target_error.is_some();
        let max_passes = if open { MAX_PASSES } else { integrator.default_passes()? };
        // Sample indices stay below 2^32.
        let max_passes = max_passes.min(u32::MAX / spp.max(1)).max(1);
        Some(PassPlan {
            max_passes,
            time_budget: options.time_budget,
            target_error: options.target_error,
            spp,
        })
    }
}

/// Why the passes stopped.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum StopReason {
    /// The pass count (the integrator's `passes`, or [`MAX_PASSES`]).
    Passes,
    /// The next pass would have ended after the time budget.
    TimeBudget,
    /// Every pixel reached the target error.
    TargetError,
}

/// What a render in passes did, for `--stats`.
#[derive(Clone, Debug, PartialEq)]
pub struct PassStats {
    pub passes: u32,
    pub spp_per_pass: u32,
    pub stopped: StopReason,
    pub time_budget: Option<Duration>,
    pub target_error: Option<f32>,
    pub pixels: u64,
    /// Pixel passes rendered, out of `pixels * passes`.
    pub pixel_passes: u64,
    /// Pixels whose estimated error is at or below the target (all pixels with more than one
    /// pass are estimated; without a target, this counts none).
    pub pixels_at_target: u64,
    /// The estimated relative MSE over the image (mean over pixels), when at least two passes
    /// ran.
    pub estimated_rel_mse: Option<f64>,
    /// Wall time of the passes (photon shooting included).
    pub time: Duration,
}

impl PassStats {
    /// Lines for `--stats`.
    pub fn lines(&self) -> Vec<String> {
        let why = match self.stopped {
            StopReason::Passes => "pass count reached".to_string(),
            StopReason::TimeBudget => {
                format!("time budget of {:.2} s", self.time_budget.unwrap_or_default().as_secs_f64())
            }
            StopReason::TargetError => "every pixel at the target error".to_string(),
        };
        let full = self.pixels * u64::from(self.passes);
        let mut out = vec![format!(
            "passes: {} of {} spp each in {:.3} s (stopped: {why}); {} pixel passes of {} ({:.1}% skipped)",
            self.passes,
            self.spp_per_pass,
            self.time.as_secs_f64(),
            self.pixel_passes,
            full,
            if full > 0 { 100.0 * (full - self.pixel_passes) as f64 / full as f64 } else { 0.0 }
        )];
        if let Some(e) = self.estimated_rel_mse {
            out.push(format!(
                "estimated error: relMSE {e:.3e} (relative error {:.3e}) over {} pixels",
                e.sqrt(),
                self.pixels
            ));
        }
        if let Some(t) = self.target_error {
            out.push(format!(
                "target error {t}: {} of {} pixels reached it (relMSE {:.3e} each)",
                self.pixels_at_target,
                self.pixels,
                f64::from(t) * f64::from(t)
            ));
        }
        out
    }
}

/// Running sums of a pixel's pass values.
#[derive(Clone, Copy, Debug, Default)]
struct PixelSums {
    sum: [f64; 4],
    sum_sq: [f64; 3],
    passes: u32,
}

impl PixelSums {
    fn add(&mut self, v: [f32; 4]) {
        for (s, x) in self.sum.iter_mut().zip(v) {
            *s += f64::from(x);
        }
        for (s, x) in self.sum_sq.iter_mut().zip(v) {
            *s += f64::from(x) * f64::from(x);
        }
        self.passes += 1;
    }

    fn mean(&self) -> [f32; 4] {
        let n = f64::from(self.passes.max(1));
        self.sum.map(|s| (s / n) as f32)
    }

    /// The estimated relative MSE of the mean (`None` before two passes).
    fn rel_mse(&self) -> Option<f64> {
        if self.passes < 2 {
            return None;
        }
        let n = f64::from(self.passes);
        let mut e = 0.0;
        for c in 0..3 {
            let m = self.sum[c] / n;
            let var = ((self.sum_sq[c] / n - m * m) * n / (n - 1.0)).max(0.0);
            e += var / n / (m * m + 0.01);
        }
        Some(e / 3.0)
    }
}

/// The image and what it took.
pub(crate) struct PassResult {
    pub pixels: Vec<[f32; 4]>,
    pub counters: RayCounters,
    pub stats: PassStats,
    /// The integrator of the last pass (for its statistics).
    pub last: Box<dyn Integrator>,
    /// Preparation of the integrators after the first (photon shooting).
    pub time_prepare: Duration,
}

/// Renders `frame` in passes as `plan` says; `start` is when the render started (the time
/// budget counts from there).
pub(crate) fn render_passes(
    frame: &Frame,
    first: Box<dyn Integrator>,
    plan: &PassPlan,
    start: Instant,
) -> PassResult {
    let passes_start = Instant::now();
    let n_pixels = (frame.width() * frame.height()) as usize;
    let mut sums = vec![PixelSums::default(); n_pixels];
    let mut active = vec![true; n_pixels];
    let mut counters = RayCounters::default();
    let mut integrator = first;
    let mut time_prepare = Duration::ZERO;
    let mut pixel_passes = 0u64;
    let target_mse = plan.target_error.map(|e| f64::from(e) * f64::from(e));
    let mut pass = 0u32;
    // Preparing the integrator of the pass just rendered (its photons), part of its cost.
    let mut last_prepare = Duration::ZERO;
    let stopped = loop {
        let pass_start = Instant::now();
        let mask = (target_mse.is_some() && pass >= MIN_PASSES).then_some(active.as_slice());
        let (values, c) = frame.render(integrator.as_ref(), pass.wrapping_mul(plan.spp), mask);
        counters.add(&c);
        for ((s, v), on) in sums.iter_mut().zip(&values).zip(&active) {
            if *on {
                s.add(*v);
                pixel_passes += 1;
            }
        }
        pass += 1;
        if let Some(t) = target_mse
            && pass >= MIN_PASSES
        {
            for (s, on) in sums.iter().zip(active.iter_mut()) {
                if *on && s.rel_mse().is_some_and(|e| e <= t) {
                    *on = false;
                }
            }
            if !active.contains(&true) {
                break StopReason::TargetError;
            }
        }
        if pass >= plan.max_passes {
            break StopReason::Passes;
        }
        if let Some(budget) = plan.time_budget {
            // The next pass is assumed to take as long as this one (its photons included).
            let elapsed = start.elapsed();
            if elapsed + pass_start.elapsed() + last_prepare > budget {
                break StopReason::TimeBudget;
            }
        }
        let prepare_start = Instant::now();
        if let Some(next) = integrator.next_pass(frame.world) {
            integrator = next;
        }
        last_prepare = prepare_start.elapsed();
        time_prepare += last_prepare;
    };
    let pixels: Vec<[f32; 4]> = sums.iter().map(PixelSums::mean).collect();
    let estimates: Vec<f64> = sums.iter().filter_map(PixelSums::rel_mse).collect();
    let estimated_rel_mse =
        (!estimates.is_empty()).then(|| estimates.iter().sum::<f64>() / estimates.len() as f64);
    let pixels_at_target = match target_mse {
        Some(t) => sums.iter().filter(|s| s.rel_mse().is_some_and(|e| e <= t)).count() as u64,
        None => 0,
    };
    let stats = PassStats {
        passes: pass,
        spp_per_pass: plan.spp,
        stopped,
        time_budget: plan.time_budget,
        target_error: plan.target_error,
        pixels: n_pixels as u64,
        pixel_passes,
        pixels_at_target,
        estimated_rel_mse,
        time: passes_start.elapsed(),
    };
    PassResult { pixels, counters, stats, last: integrator, time_prepare }
}
