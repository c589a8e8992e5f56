//! `indoorloc study NAME`: reproducible experiments, each a table like a paper's, written as
//! `DIR/report.html` with `--json` rows.

pub(crate) mod cuts;

use anyhow::Result;
use clap::{Args, Subcommand};

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
}

/// Runs `indoorloc study`.
pub fn run(args: &StudyArgs) -> Result<()> {
    match &args.study {
        Study::Cuts(a) => cuts::run(a),
    }
}
