//! The binary's progress reporter: indicatif bars on stderr (hidden when stderr is not a
//! terminal) and notes as lines on stderr (kept in logs too).

use indicatif::{ProgressBar, ProgressStyle};
use lab::progress::{BarView, Reporter};

/// Draws the pipelines' progress on stderr.
pub struct Terminal;

impl Reporter for Terminal {
    fn bar(&self, len: u64, what: &str) -> Box<dyn BarView> {
        let pb = ProgressBar::new(len);
        let style = ProgressStyle::with_template(
            "{msg:>10} [{bar:40.cyan/blue}] {pos}/{len} ({per_sec}, {eta} left)",
        )
        .unwrap_or_else(|_| ProgressStyle::default_bar())
        .progress_chars("=> ");
        pb.set_style(style);
        pb.set_message(what.to_string());
        Box::new(Bar(pb))
    }

    fn note(&self, text: &str) {
        eprintln!("{text}");
    }
}

/// One indicatif bar.
struct Bar(ProgressBar);

impl BarView for Bar {
    fn set_position(&self, pos: u64) {
        self.0.set_position(pos);
    }
    fn inc(&self, delta: u64) {
        self.0.inc(delta);
    }
    fn position(&self) -> u64 {
        self.0.position()
    }
    fn set_length(&self, len: u64) {
        self.0.set_length(len);
    }
    fn set_message(&self, msg: String) {
        self.0.set_message(msg);
    }
    fn finish_and_clear(&self) {
        self.0.finish_and_clear();
    }
}
