//! `indoorloc study NAME`: reproducible experiments, each a table like a paper's, written as
//! `DIR/report.html` with `--json` rows.

mod all;
mod common;
pub(crate) mod cuts;
mod markers_distance;
mod place_split;
mod real;
mod render_types;
mod robustness;
mod sequence;
mod synth_to_real;
mod track;
mod uncertainty;

pub use common::Scale;

use crate::Result;
use clap::{Args, Subcommand};

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
    /// A network trained only on renders of a scan of the room (fused from the training
    /// frames' RGB-D), tested on the real held-out photos, per render type, beside the same
    /// recipe on the real photos and refined against a map of renders.
    SynthToReal(synth_to_real::SynthToRealConfig),
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
        Study::SynthToReal(a) => synth_to_real::run(a, sink),
        Study::Uncertainty(a) => uncertainty::run(a, sink),
        Study::All(a) => all::run(a, sink),
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::demo::DemoConfig;
    use clap::Parser;
    use std::path::Path;

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
