//! Where a command's results go: one JSON document (`--json`) or text for people, written to a
//! sink the caller gives (the binary's is stdout; a program can keep them).

use crate::Result;
use serde::Serialize;

/// Receives a command's results.
pub trait Output {
    /// One JSON document, pretty-printed, without the final newline.
    fn json(&mut self, document: &str) -> Result<()>;
    /// Text for people.
    fn text(&mut self, text: &str) -> Result<()>;
    /// Where a command streams lines as they come (`localize`'s and `serve --jsonl`'s JSON
    /// lines), flushed by the command after each line.
    fn stream(&mut self) -> &mut dyn std::io::Write;
}

/// Results kept in memory: each JSON document and each piece of text in order.
#[derive(Debug, Default)]
pub struct Collected {
    /// The JSON documents.
    pub json: Vec<String>,
    /// The text.
    pub text: String,
    /// The streamed lines.
    pub stream: Vec<u8>,
}

impl Output for Collected {
    fn json(&mut self, document: &str) -> Result<()> {
        self.json.push(document.to_string());
        Ok(())
    }

    fn text(&mut self, text: &str) -> Result<()> {
        self.text.push_str(text);
        Ok(())
    }

    fn stream(&mut self) -> &mut dyn std::io::Write {
        &mut self.stream
    }
}

/// Sends `value` to `out` as one pretty JSON document.
pub fn print_json<T: Serialize>(out: &mut dyn Output, value: &T) -> Result<()> {
    out.json(&serde_json::to_string_pretty(value)?)
}

/// Sends text for people to `out`.
pub fn print_text(out: &mut dyn Output, text: &str) -> Result<()> {
    out.text(text)
}

/// Median of timings or other figures; NaN for none (shown as such rather than failing a run
/// whose every image was bad).
pub fn median(values: &[f64]) -> f64 {
    geom::metrics::Stats::of(values).map_or(f64::NAN, |s| s.median)
}
