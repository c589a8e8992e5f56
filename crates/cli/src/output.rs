//! Printing results: one JSON document on stdout with `--json`, a table for people otherwise.

use serde::Serialize;
use std::io::Write;

/// Prints `value` as one pretty JSON document on stdout.
pub fn print_json<T: Serialize>(value: &T) -> anyhow::Result<()> {
    let mut out = std::io::stdout().lock();
    serde_json::to_writer_pretty(&mut out, value)?;
    writeln!(out)?;
    Ok(())
}

/// Prints text for people on stdout.
pub fn print_text(text: &str) -> anyhow::Result<()> {
    let mut out = std::io::stdout().lock();
    out.write_all(text.as_bytes())?;
    Ok(())
}

/// Median of timings or other figures; NaN for none (shown as such rather than failing a run
/// whose every image was bad).
pub fn median(values: &[f64]) -> f64 {
    geom::metrics::Stats::of(values).map_or(f64::NAN, |s| s.median)
}
