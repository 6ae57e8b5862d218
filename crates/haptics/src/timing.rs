//! Tick-time statistics: a fixed-size histogram (no allocation in the loop) with percentiles.

use std::time::Duration;

/// Histogram of durations with 0.5 us buckets up to 20 ms; longer ones land in the last bucket
/// and are still counted in `max`.
#[derive(Clone, Debug)]
pub struct DurationHistogram {
    buckets: Box<[u32]>,
    count: u64,
    max: Duration,
    sum_nanos: u128,
}

const BUCKET_NANOS: u64 = 500;
const BUCKETS: usize = 40_000;

impl Default for DurationHistogram {
    fn default() -> DurationHistogram {
        DurationHistogram {
            buckets: vec![0; BUCKETS].into_boxed_slice(),
            count: 0,
            max: Duration::ZERO,
            sum_nanos: 0,
        }
    }
}

impl DurationHistogram {
    pub fn record(&mut self, d: Duration) {
        let nanos = d.as_nanos().min(u64::MAX as u128) as u64;
        let bucket = ((nanos / BUCKET_NANOS) as usize).min(BUCKETS - 1);
        self.buckets[bucket] = self.buckets[bucket].saturating_add(1);
        self.count += 1;
        self.max = self.max.max(d);
        self.sum_nanos += nanos as u128;
    }

    pub fn count(&self) -> u64 {
        self.count
    }

    pub fn max(&self) -> Duration {
        self.max
    }

    pub fn mean(&self) -> Duration {
        if self.count == 0 {
            return Duration::ZERO;
        }
        Duration::from_nanos((self.sum_nanos / self.count as u128) as u64)
    }

    /// The `q`-quantile (0..=1), to the bucket's upper edge (0.5 us resolution).
    pub fn quantile(&self, q: f64) -> Duration {
        if self.count == 0 {
            return Duration::ZERO;
        }
        let rank = ((q.clamp(0.0, 1.0) * self.count as f64).ceil() as u64).max(1);
        let mut seen = 0u64;
        for (i, &n) in self.buckets.iter().enumerate() {
            seen += n as u64;
            if seen >= rank {
                if i == BUCKETS - 1 {
                    return self.max;
                }
                let edge = Duration::from_nanos((i as u64 + 1) * BUCKET_NANOS);
                return edge.min(self.max);
            }
        }
        self.max
    }
}

/// Summary of a set of durations.
#[derive(Clone, Copy, Debug, Default, PartialEq)]
pub struct DurationSummary {
    pub p50: Duration,
    pub p99: Duration,
    pub p999: Duration,
    pub max: Duration,
    pub mean: Duration,
}

impl DurationHistogram {
    pub fn summary(&self) -> DurationSummary {
        DurationSummary {
            p50: self.quantile(0.5),
            p99: self.quantile(0.99),
            p999: self.quantile(0.999),
            max: self.max,
            mean: self.mean(),
        }
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn quantiles() {
        let mut h = DurationHistogram::default();
        for us in 1..=100u64 {
            h.record(Duration::from_micros(us));
        }
        // Quantiles are reported to the upper edge of their 0.5 us bucket.
        assert_eq!(h.quantile(0.5), Duration::from_nanos(50_500));
        assert_eq!(h.quantile(0.99), Duration::from_nanos(99_500));
        assert_eq!(h.max(), Duration::from_micros(100));
        h.record(Duration::from_secs(1));
        assert_eq!(h.quantile(1.0), Duration::from_secs(1));
    }
}
