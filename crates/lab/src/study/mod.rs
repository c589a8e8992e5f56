//! `indoorloc study NAME`: reproducible experiments, each a table like a paper's, written as
//! `DIR/report.html` with `--json` rows.

mod all;
pub(crate) mod cuts;
mod markers_distance;
mod place_split;
mod real;
mod render_types;
mod robustness;
mod sequence;
mod track;
mod uncertainty;

use crate::Result;
use crate::demo::{DemoConfig, Evaluation};
use clap::{Args, Subcommand};
use serde::Serialize;
use std::path::Path;

/// Arguments of `indoorloc study`.
#[derive(Args, Debug)]
pub struct StudyConfig {
    #[command(subcommand)]
    study: Study,
}

/// The studies.
#[derive(Subcommand, Debug)]
enum Study {
    /// Scene cuts and a temporal filter: errors just after a cut and elsewhere, with cuts not
    /// handled, reset at the gold cuts, and reset at the cuts `scenecut` detects.
    Cuts(cuts::CutsConfig),
    /// Single-frame network against the CNN+LSTM sequence model on its features: median
    /// errors, frame-to-frame jitter and live latency on the held-out walk.
    Sequence(sequence::SequenceConfig),
    /// The live pipeline's fused track against the raw network on the held-out walk.
    Track(track::TrackConfig),
    /// Train on each synthetic render mode (shaded, textured, edges, gradmag), test on a
    /// differently textured photo-like walk: synthetic-to-real transfer, as BIM-PoseNet.
    RenderTypes(render_types::RenderTypesConfig),
    /// Robustness to appearance change: baseline, shape-biased and shape-biased + planes
    /// networks trained under normal conditions, tested on one walk under every appearance
    /// variant (lights off, dim, people, furniture, posters, disaster, texture swap).
    Robustness(robustness::RobustnessConfig),
    /// Place recognition (building, floor, corridor and direction): a random frame split
    /// against a split by recording session, with held-out walks under another appearance,
    /// per-class precision / recall and confusion matrices.
    PlaceSplit(place_split::PlaceSplitConfig),
    /// A real posed dataset end to end: mean training pose, image retrieval, the network
    /// (real-photo recipe) and the network + sequence model on the held-out frames.
    Real(real::RealConfig),
    /// Marker pose error against distance and viewing angle, for two camera resolutions, on
    /// a marker rendered on a wall.
    MarkersDistance(markers_distance::MarkersDistanceConfig),
    /// Coverage of the position covariance (50 / 90 / 95 / 99 % regions), NLL, calibration
    /// error and sharpness on held-out walks (forward, an unseen appearance, ceiling) and a
    /// real dataset (`--data`), for the network and the fused track, before and after
    /// calibration, with reliability diagrams.
    Uncertainty(uncertainty::UncertaintyConfig),
    /// Every study in turn (each in its own process), headline figures beside those the docs
    /// record; exits 2 when a study fails or a figure drifted past its tolerance.
    All(all::AllConfig),
}

/// Runs `indoorloc study`.
pub fn run(args: &StudyConfig, sink: &mut dyn crate::Output) -> Result<()> {
    match &args.study {
        Study::Cuts(a) => cuts::run(a, sink),
        Study::Sequence(a) => sequence::run(a, sink),
        Study::Track(a) => track::run(a, sink),
        Study::RenderTypes(a) => render_types::run(a, sink),
        Study::Robustness(a) => robustness::run(a, sink),
        Study::PlaceSplit(a) => place_split::run(a, sink),
        Study::MarkersDistance(a) => markers_distance::run(a, sink),
        Study::Real(a) => real::run(a, sink),
        Study::Uncertainty(a) => uncertainty::run(a, sink),
        Study::All(a) => all::run(a, sink),
    }
}

/// The error columns the studies' tables share, after their own leading columns: median
/// position and rotation error, mean position error, and the share of frames within each
/// accuracy threshold. Flattened into a row's JSON, so the keys are the row's own.
#[derive(Debug, Serialize)]
pub(crate) struct ErrorColumns {
    pub median_pos_m: f64,
    pub median_rot_deg: f64,
    pub mean_pos_m: f64,
    /// `(max m, max °, share)` per threshold: (0.25 m, 2°), (0.5 m, 5°) and (5 m, 10°).
    pub accuracy: Vec<(f64, f64, f64)>,
}

impl ErrorColumns {
    /// The columns of an evaluation.
    pub(crate) fn of(ev: &Evaluation) -> ErrorColumns {
        ErrorColumns {
            median_pos_m: ev.pos_median,
            median_rot_deg: ev.rot_median,
            mean_pos_m: ev.pos_mean,
            accuracy: ev.accuracy.clone(),
        }
    }

    /// `lead` then the headers of these columns (the thresholds of the first row's accuracy).
    pub(crate) fn headers<'a>(
        lead: &[&str],
        first: impl IntoIterator<Item = &'a ErrorColumns>,
    ) -> Vec<String> {
        let mut header: Vec<String> = lead.iter().map(|s| s.to_string()).collect();
        header.extend(["median (m)".into(), "median (°)".into(), "mean (m)".into()]);
        if let Some(first) = first.into_iter().next() {
            header.extend(
                first
                    .accuracy
                    .iter()
                    .map(|(m, d, _)| format!("≤ {m} m, {d}°")),
            );
        }
        header
    }

    /// `lead` then the cells of these columns.
    pub(crate) fn cells(&self, lead: Vec<String>) -> Vec<String> {
        let mut cells = lead;
        cells.extend([
            format!("{:.3}", self.median_pos_m),
            format!("{:.2}", self.median_rot_deg),
            format!("{:.3}", self.mean_pos_m),
        ]);
        cells.extend(
            self.accuracy
                .iter()
                .map(|(_, _, f)| format!("{:.1} %", 100.0 * f)),
        );
        cells
    }
}

/// How much a study renders and trains: the demo's quick or full setup, with overrides (small
/// values make a study a smoke test).
#[derive(Args, Debug, Clone, Default, PartialEq)]
pub struct Scale {
    /// The demo's quick setup (minutes) instead of the full one.
    #[arg(long)]
    pub quick: bool,
    /// Override the number of training frames.
    #[arg(long)]
    pub train_frames: Option<usize>,
    /// Override the length of the held-out test walk, frames.
    #[arg(long)]
    pub test_frames: Option<usize>,
    /// Override the number of training epochs of the network.
    #[arg(long)]
    pub epochs: Option<usize>,
}

impl Scale {
    /// The demo's quick setup, nothing overridden.
    pub fn quick() -> Scale {
        Scale {
            quick: true,
            ..Scale::default()
        }
    }
}

impl Scale {
    /// The demo a study trains with: the demo's own defaults at this scale, in `out`.
    pub fn demo(&self, out: &Path) -> DemoConfig {
        DemoConfig {
            out: out.to_path_buf(),
            quick: self.quick,
            train_frames: self.train_frames,
            test_frames: self.test_frames,
            epochs: self.epochs,
            ..DemoConfig::default()
        }
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use clap::Parser;

    #[derive(Parser)]
    struct Wrap {
        #[command(flatten)]
        demo: DemoConfig,
    }

    /// The typed defaults a study starts from are the command's: a default config and an empty
    /// command line agree, and each scale override lands where its option would.
    #[test]
    fn demo_defaults_are_the_command_lines() {
        assert_eq!(DemoConfig::default(), Wrap::parse_from(["demo"]).demo);
        let scale = Scale {
            quick: true,
            train_frames: Some(40),
            test_frames: Some(20),
            epochs: Some(2),
        };
        let parsed = Wrap::parse_from([
            "demo",
            "--out",
            "x",
            "--quick",
            "--train-frames",
            "40",
            "--test-frames",
            "20",
            "--epochs",
            "2",
        ])
        .demo;
        assert_eq!(scale.demo(Path::new("x")), parsed);
    }
}
