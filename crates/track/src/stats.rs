//! Counters and per-stage latency histograms of a running pipeline, shared between the
//! pipeline's threads and whoever reports them (`serve`'s `/metrics`, `bench serve`).
//!
//! Latencies go into HDR histograms (microseconds, 3 significant digits), so p50 / p99 are
//! exact to 0.1 % whatever the run's length, in a fixed few kilobytes of memory.

use hdrhistogram::Histogram;
use serde::Serialize;
use std::sync::Mutex;
use std::sync::atomic::{AtomicU64, Ordering};

/// A stage of the pipeline whose time is measured per frame.
#[derive(Clone, Copy, Debug, PartialEq, Eq, Serialize)]
#[serde(rename_all = "snake_case")]
pub enum Stage {
    /// Reading and decoding the frame.
    Read,
    /// Waiting in the queue for the estimators.
    Queue,
    /// All estimators (network, markers) and the cut detector.
    Estimate,
    /// The temporal filter.
    Filter,
    /// From the frame being read to its fused pose going out.
    Total,
}

impl Stage {
    /// Every stage, in pipeline order.
    pub const ALL: [Stage; 5] = [
        Stage::Read,
        Stage::Queue,
        Stage::Estimate,
        Stage::Filter,
        Stage::Total,
    ];

    /// The stage's name in metrics.
    pub fn name(self) -> &'static str {
        match self {
            Stage::Read => "read",
            Stage::Queue => "queue",
            Stage::Estimate => "estimate",
            Stage::Filter => "filter",
            Stage::Total => "total",
        }
    }
}

/// Upper bounds (seconds) of the cumulative buckets that `/metrics` exports.
pub const BUCKETS_S: [f64; 12] = [
    0.0005, 0.001, 0.002, 0.005, 0.01, 0.02, 0.033, 0.05, 0.1, 0.2, 0.5, 1.0,
];

struct StageTimes {
    hist: Histogram<u64>,
    sum_s: f64,
}

/// Counters and latency histograms; every method takes `&self` (shared behind an `Arc`).
pub struct Metrics {
    stages: Mutex<Vec<StageTimes>>,
    /// Frames read from the source.
    pub frames_read: AtomicU64,
    /// Frames dropped because the estimators were busy (live sources).
    pub frames_dropped: AtomicU64,
    /// Fused poses sent out.
    pub poses: AtomicU64,
    /// Measurements the filter's gate refused.
    pub rejected: AtomicU64,
    /// Scene cuts detected (each resets the filter).
    pub cuts: AtomicU64,
}

impl Default for Metrics {
    fn default() -> Self {
        let stage = || StageTimes {
            hist: Histogram::new_with_bounds(1, 3_600_000_000, 3)
                .expect("1 µs to 1 h at 3 significant digits are valid bounds"),
            sum_s: 0.0,
        };
        Metrics {
            stages: Mutex::new(Stage::ALL.iter().map(|_| stage()).collect()),
            frames_read: AtomicU64::new(0),
            frames_dropped: AtomicU64::new(0),
            poses: AtomicU64::new(0),
            rejected: AtomicU64::new(0),
            cuts: AtomicU64::new(0),
        }
    }
}

/// One stage's figures at a moment.
#[derive(Clone, Debug, Serialize)]
pub struct StageSnapshot {
    /// The stage.
    pub stage: Stage,
    /// Frames timed.
    pub count: u64,
    /// Total time, seconds.
    pub sum_s: f64,
    /// Median, milliseconds.
    pub p50_ms: f64,
    /// 99th percentile, milliseconds.
    pub p99_ms: f64,
    /// Longest, milliseconds.
    pub max_ms: f64,
    /// Frames at or under each bound of [`BUCKETS_S`], cumulative.
    pub buckets: Vec<u64>,
}

/// All counters and stages at a moment.
#[derive(Clone, Debug, Serialize)]
pub struct MetricsSnapshot {
    /// Frames read.
    pub frames_read: u64,
    /// Frames dropped under load.
    pub frames_dropped: u64,
    /// Poses sent out.
    pub poses: u64,
    /// Measurements refused by the gate.
    pub rejected: u64,
    /// Scene cuts detected.
    pub cuts: u64,
    /// Per-stage latency.
    pub stages: Vec<StageSnapshot>,
}

impl MetricsSnapshot {
    /// The figures of `stage`.
    pub fn stage(&self, stage: Stage) -> Option<&StageSnapshot> {
        self.stages.iter().find(|s| s.stage == stage)
    }
}

impl Metrics {
    /// Records `seconds` spent in `stage` by one frame.
    pub fn record(&self, stage: Stage, seconds: f64) {
        let us = (seconds * 1e6).round().clamp(1.0, 3.6e9) as u64;
        let mut g = self.stages.lock().unwrap_or_else(|p| p.into_inner());
        let s = &mut g[stage as usize];
        s.hist.saturating_record(us);
        s.sum_s += seconds;
    }

    /// Adds one to `counter`.
    pub fn count(counter: &AtomicU64) {
        counter.fetch_add(1, Ordering::Relaxed);
    }

    /// A consistent copy of every figure.
    pub fn snapshot(&self) -> MetricsSnapshot {
        let g = self.stages.lock().unwrap_or_else(|p| p.into_inner());
        let ms = |us: u64| us as f64 / 1e3;
        let stages = Stage::ALL
            .iter()
            .zip(g.iter())
            .map(|(&stage, s)| StageSnapshot {
                stage,
                count: s.hist.len(),
                sum_s: s.sum_s,
                p50_ms: ms(s.hist.value_at_quantile(0.5)),
                p99_ms: ms(s.hist.value_at_quantile(0.99)),
                max_ms: ms(s.hist.max()),
                buckets: BUCKETS_S
                    .iter()
                    .map(|b| s.hist.count_between(0, (b * 1e6) as u64))
                    .collect(),
            })
            .collect();
        let get = |c: &AtomicU64| c.load(Ordering::Relaxed);
        MetricsSnapshot {
            frames_read: get(&self.frames_read),
            frames_dropped: get(&self.frames_dropped),
            poses: get(&self.poses),
            rejected: get(&self.rejected),
            cuts: get(&self.cuts),
            stages,
        }
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn percentiles_and_buckets_follow_the_recorded_times() {
        let m = Metrics::default();
        for i in 1..=100 {
            m.record(Stage::Estimate, i as f64 * 1e-4); // 0.1 ms .. 10 ms
        }
        let s = m.snapshot();
        let e = s.stage(Stage::Estimate).expect("stage");
        assert_eq!(e.count, 100);
        assert!((e.p50_ms - 5.0).abs() < 0.01, "{}", e.p50_ms);
        assert!((e.p99_ms - 9.9).abs() < 0.02, "{}", e.p99_ms);
        assert!((e.sum_s - 0.505).abs() < 1e-9);
        // 5 frames at or under 0.5 ms, 100 at or under 10 ms.
        assert_eq!(e.buckets[0], 5);
        assert_eq!(e.buckets[4], 100);
        assert_eq!(s.stage(Stage::Read).map(|r| r.count), Some(0));
    }
}
