//! Helpers: run the binary, find test data.

use std::path::{Path, PathBuf};
use std::process::Output;

/// Result type of the tests.
pub type TestResult<T = ()> = Result<T, Box<dyn std::error::Error>>;

/// Runs `indoorloc` with `args`.
pub fn indoorloc(args: &[&str]) -> std::io::Result<Output> {
    std::process::Command::new(env!("CARGO_BIN_EXE_indoorloc"))
        .args(args)
        .output()
}

/// A file under `crates/cli/tests/data/`.
pub fn test_data(rel: &str) -> PathBuf {
    Path::new(env!("CARGO_MANIFEST_DIR"))
        .join("tests/data")
        .join(rel)
}

/// A path under `../shared/data/` (real data, read in place, never copied).
pub fn shared_data(rel: &str) -> PathBuf {
    Path::new(env!("CARGO_MANIFEST_DIR"))
        .join("../../../shared/data")
        .join(rel)
}

/// Stdout of a run that must succeed, as JSON.
pub fn json_of(out: &Output) -> Result<serde_json::Value, Box<dyn std::error::Error>> {
    if !out.status.success() {
        return Err(format!(
            "indoorloc failed ({}): {}",
            out.status,
            String::from_utf8_lossy(&out.stderr)
        )
        .into());
    }
    Ok(serde_json::from_slice(&out.stdout)?)
}

/// The demo's toy scale, as `demo_cli` runs it.
pub const TOY: [&str; 7] = [
    "--quick",
    "--train-frames",
    "48",
    "--test-frames",
    "24",
    "--epochs",
    "1",
];
