//! `indoorloc study NAME`: reproducible experiments, each a table like a paper's, written as
//! `DIR/report.html` with `--json` rows.

pub(crate) mod cuts;
mod sequence;

use crate::cmd::demo::DemoArgs;
use anyhow::Result;
use clap::{Args, Parser, Subcommand};
use std::path::Path;

/// Arguments of `indoorloc study`.
#[derive(Args, Debug)]
pub struct StudyArgs {
    #[command(subcommand)]
    study: Study,
}

/// The studies.
#[derive(Subcommand, Debug)]
enum Study {
    /// Scene cuts and a temporal filter: errors just after a cut and elsewhere, with cuts not
    /// handled, reset at the gold cuts, and reset at the cuts `scenecut` detects.
    Cuts(cuts::CutsArgs),
    /// Single-frame network against the CNN+LSTM sequence model on its features: median
    /// errors, frame-to-frame jitter and live latency on the held-out walk.
    Sequence(sequence::SequenceArgs),
}

/// Runs `indoorloc study`.
pub fn run(args: &StudyArgs) -> Result<()> {
    match &args.study {
        Study::Cuts(a) => cuts::run(a),
        Study::Sequence(a) => sequence::run(a),
    }
}

/// The demo arguments a study trains with: the demo's own defaults, quick or not, in `out`.
pub(crate) fn demo_args(out: &Path, quick: bool) -> Result<DemoArgs> {
    #[derive(Parser)]
    struct Wrap {
        #[command(flatten)]
        demo: DemoArgs,
    }
    let out = out.to_string_lossy().into_owned();
    let mut argv = vec!["demo", "--out", out.as_str()];
    if quick {
        argv.push("--quick");
    }
    Ok(Wrap::try_parse_from(argv)?.demo)
}
