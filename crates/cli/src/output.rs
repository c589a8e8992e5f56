//! Results on stdout: one JSON document with `--json`, text for people otherwise.

use lab::{LabError, Output};
use std::io::Write;

/// Writes results to stdout.
pub struct Stdout(pub std::io::Stdout);

impl Output for Stdout {
    fn json(&mut self, document: &str) -> Result<(), LabError> {
        let mut out = std::io::stdout().lock();
        writeln!(out, "{document}")?;
        Ok(())
    }

    fn text(&mut self, text: &str) -> Result<(), LabError> {
        let mut out = std::io::stdout().lock();
        out.write_all(text.as_bytes())?;
        Ok(())
    }

    fn stream(&mut self) -> &mut dyn Write {
        &mut self.0
    }
}
