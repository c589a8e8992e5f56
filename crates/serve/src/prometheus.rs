//! `/metrics` in the Prometheus text exposition format (version 0.0.4).
//!
//! Written by hand: the latency figures live in `track`'s HDR histograms (exact percentiles for
//! `bench`), which a Prometheus client crate cannot take as its own metric types; the format
//! itself is a handful of line shapes.

use crate::hub::Hub;
use std::fmt::Write;
use std::sync::atomic::Ordering;
use track::BUCKETS_S;

/// The metrics page.
pub fn render(hub: &Hub) -> String {
    let m = hub.metrics().snapshot();
    let mut out = String::new();
    let mut scalar = |name: &str, kind: &str, help: &str, value: f64| {
        let _ = writeln!(out, "# HELP indoorloc_{name} {help}");
        let _ = writeln!(out, "# TYPE indoorloc_{name} {kind}");
        let _ = writeln!(out, "indoorloc_{name} {value}");
    };
    scalar(
        "frames_read_total",
        "counter",
        "Frames read from the source.",
        m.frames_read as f64,
    );
    scalar(
        "frames_dropped_total",
        "counter",
        "Frames dropped because the estimators were busy.",
        m.frames_dropped as f64,
    );
    scalar(
        "poses_total",
        "counter",
        "Fused poses sent out.",
        m.poses as f64,
    );
    scalar(
        "measurements_rejected_total",
        "counter",
        "Measurements refused by the filter's outlier gate.",
        m.rejected as f64,
    );
    scalar(
        "cuts_total",
        "counter",
        "Scene cuts detected.",
        m.cuts as f64,
    );
    scalar(
        "ws_clients",
        "gauge",
        "WebSocket clients connected.",
        hub.clients.load(Ordering::Relaxed) as f64,
    );
    scalar(
        "ws_clients_dropped_total",
        "counter",
        "WebSocket clients dropped for falling behind or not answering.",
        hub.clients_dropped.load(Ordering::Relaxed) as f64,
    );
    scalar(
        "uptime_seconds",
        "gauge",
        "Seconds since the server started.",
        hub.uptime_s(),
    );

    let name = "indoorloc_stage_latency_seconds";
    let _ = writeln!(
        out,
        "# HELP {name} Time a frame spends in each stage of the pipeline."
    );
    let _ = writeln!(out, "# TYPE {name} histogram");
    for s in &m.stages {
        let stage = s.stage.name();
        for (le, n) in BUCKETS_S.iter().zip(&s.buckets) {
            let _ = writeln!(out, "{name}_bucket{{stage=\"{stage}\",le=\"{le}\"}} {n}");
        }
        let _ = writeln!(
            out,
            "{name}_bucket{{stage=\"{stage}\",le=\"+Inf\"}} {}",
            s.count
        );
        let _ = writeln!(out, "{name}_sum{{stage=\"{stage}\"}} {}", s.sum_s);
        let _ = writeln!(out, "{name}_count{{stage=\"{stage}\"}} {}", s.count);
    }
    out
}
