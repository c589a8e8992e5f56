//! `indoorloc bench`: speed figures of each stage, beside the reference peer where one is
//! installed, as a ratio measured in the same run.

mod learn;
mod markers;
mod peer;
mod preprocess;
mod refine;
mod scenecut;
mod serve;

pub(crate) use peer::shared_data;
pub use peer::{Peer, VsPeer};

use crate::eval::{EvalConfig, evaluate};
use crate::output::{print_json, print_text};
use crate::{Context, Result, bail};
use clap::{Args, ValueEnum};
use data::{PoseFrame, Trajectory};
use geom::Pose;
use rand::{Rng, SeedableRng};
use rand_chacha::ChaCha8Rng;
use serde::Serialize;
use std::path::{Path, PathBuf};
use std::process::Command;
use std::time::Instant;

/// Stages with a benchmark.
#[derive(Clone, Copy, Debug, PartialEq, Eq, ValueEnum)]
pub enum Stage {
    /// `eval` on a long TUM trajectory pair, against NumPy/SciPy's metrics.py.
    Eval,
    /// The synthetic renderer: frames/s per mode at 160x120 and 320x240, 1 thread and all.
    Render,
    /// Image views on one thread (160x120 gray + CLAHE, 256x256 [-1, 1]), against OpenCV.
    Preprocess,
    /// ms per training step of a network (`--arch`, small by default; batch 32, 1x120x160 and
    /// 3x256x256) on the process's device (`--device`), against PyTorch (torch_apr.py).
    Train,
    /// ms per single-image inference of a network (`--arch`), 1 thread and all (once on a
    /// GPU), against PyTorch; and ms per frame as `localize` runs it, plain and with TTA + 16
    /// MC passes.
    Infer,
    /// Scene-cut detection frames/s on a 320x240 video, against PySceneDetect and decoding
    /// alone; hard-cut F1 on the shared clips beside PySceneDetect's.
    Scenecut,
    /// ArUco detection ms per photo (DICT_6X6_250 photos of ../shared/data/aruco_real), one
    /// thread and all, against OpenCV's ArucoDetector (aruco.py).
    Markers,
    /// Centimetre refinement (keyframe map, local features, PnP) on the shared kitchen frames:
    /// accuracy and ms per 640x480 query on one thread, against OpenCV SIFT + PnP
    /// (sift_pnp.py), on the README's split and on shorter blocks; the map's build time.
    Refine,
    /// The live pipeline's frames/s and p99 latency on the demo's held-out walk (MC off and
    /// on), and the server under many WebSocket clients (not in the default run: it needs a
    /// trained demo, `--demo-dir`).
    Serve,
}

/// Arguments of `indoorloc bench`.
#[derive(Args, Debug)]
pub struct BenchConfig {
    /// The stage to measure (all when omitted).
    stage: Option<Stage>,
    /// Frames in the synthetic trajectory of the eval benchmark.
    #[arg(long, default_value_t = 100_000)]
    frames: usize,
    /// Frames rendered per mode, size and thread count in the render benchmark.
    #[arg(long, default_value_t = 2000)]
    render_frames: usize,
    /// Timed repetitions; the median is reported.
    #[arg(long, default_value_t = 3)]
    repeat: usize,
    /// Photo for the preprocess benchmark (default: ../shared/data/aruco_real/img_00.jpg, else a
    /// 640x480 render of the default building).
    #[arg(long, value_name = "FILE")]
    image: Option<PathBuf>,
    /// Folder of the peer scripts (default: ../shared/tools/peers or shared/tools/peers from the
    /// current folder, or $INDOORLOC_PEERS).
    #[arg(long, value_name = "DIR")]
    peers: Option<PathBuf>,
    /// Video for the scenecut benchmark (default:
    /// ../shared/data/scenecut_real/opencv_samples_cuts.mp4).
    #[arg(long, value_name = "FILE")]
    video: Option<PathBuf>,
    /// Network of the train and infer benchmarks (small, resnet18, resnet34, googlenet,
    /// mobilenetv2; PyTorch's figures for small and resnet18).
    #[arg(long, default_value = "small")]
    arch: ::learn::Arch,
    /// Timed training steps per input size in the train benchmark.
    #[arg(long, default_value_t = 10)]
    train_steps: usize,
    /// Timed single-image inferences per input size and thread count in the infer benchmark.
    #[arg(long, default_value_t = 30)]
    infer_runs: usize,
    /// Demo folder (`indoorloc demo --quick --out DIR`) whose model and held-out walk the
    /// serve benchmark runs.
    #[arg(long, value_name = "DIR", default_value = "indoorloc-demo")]
    demo_dir: PathBuf,
    /// MC-dropout passes of the serve benchmark's second throughput run.
    #[arg(long, default_value_t = 16)]
    mc: usize,
    /// WebSocket clients of the serve benchmark's load test.
    #[arg(long, default_value_t = 50)]
    clients: usize,
    /// Seconds of the serve benchmark's load test.
    #[arg(long, default_value_t = 60.0)]
    seconds: f64,
    /// Frames per second the load test plays the walk at.
    #[arg(long, default_value_t = 30.0)]
    load_fps: f64,
    /// Posed RGB-D dataset of the refine benchmark (default:
    /// ../shared/data/7scenes_redkitchen_seq01).
    #[arg(long, value_name = "DATASET")]
    refine_data: Option<PathBuf>,
    /// Block splits of the refine benchmark, BLOCK:EVERY[:OFFSET] (repeatable; default 100:5
    /// and 40:4).
    #[arg(long, value_name = "BLOCK:EVERY[:OFFSET]")]
    refine_blocks: Vec<data::blocks::BlockSplit>,
    /// Print one JSON document instead of a table.
    #[arg(long)]
    json: bool,
}

/// Figures of one stage.
#[derive(Debug, Serialize)]
struct StageFigures {
    stage: &'static str,
    frames: usize,
    /// indoorloc, read + match + metrics, milliseconds (median of the repeats).
    ms: f64,
    /// indoorloc with the HTML report and its plots, milliseconds.
    ms_with_report: f64,
    /// The peer's figures beside ours.
    #[serde(flatten)]
    vs: VsPeer,
}

/// Renderer speed for one mode and size.
#[derive(Debug, Serialize)]
struct RenderFigures {
    mode: String,
    width: u32,
    height: u32,
    threads: usize,
    frames: usize,
    fps: f64,
    ms_per_frame: f64,
}

#[derive(Debug, Serialize)]
struct BenchOutput {
    stages: Vec<StageFigures>,
    #[serde(skip_serializing_if = "Vec::is_empty")]
    render: Vec<RenderFigures>,
    #[serde(skip_serializing_if = "Vec::is_empty")]
    preprocess: Vec<preprocess::ViewFigures>,
    #[serde(skip_serializing_if = "Vec::is_empty")]
    learn: Vec<learn::LearnFigures>,
    #[serde(skip_serializing_if = "Option::is_none")]
    scenecut: Option<scenecut::ScenecutFigures>,
    #[serde(skip_serializing_if = "Vec::is_empty")]
    markers: Vec<markers::MarkerFigures>,
    #[serde(skip_serializing_if = "Option::is_none")]
    serve: Option<serve::ServeFigures>,
    #[serde(skip_serializing_if = "Vec::is_empty")]
    refine: Vec<refine::RefineFigures>,
}

/// Runs `indoorloc bench`.
pub fn run(args: &BenchConfig, sink: &mut dyn crate::Output) -> Result<()> {
    if args.repeat == 0 || args.frames < 2 || args.render_frames == 0 {
        bail!("--repeat and --render-frames must be at least 1, --frames at least 2");
    }
    let stages = match args.stage {
        Some(s) => vec![s],
        None => vec![
            Stage::Eval,
            Stage::Preprocess,
            Stage::Render,
            Stage::Train,
            Stage::Infer,
            Stage::Scenecut,
            Stage::Markers,
            Stage::Refine,
        ],
    };
    let mut out = BenchOutput {
        stages: Vec::new(),
        render: Vec::new(),
        preprocess: Vec::new(),
        learn: Vec::new(),
        scenecut: None,
        markers: Vec::new(),
        serve: None,
        refine: Vec::new(),
    };
    let (train, infer) = (
        stages.contains(&Stage::Train),
        stages.contains(&Stage::Infer),
    );
    if args.train_steps == 0 || args.infer_runs == 0 {
        bail!("--train-steps and --infer-runs must be at least 1");
    }
    for stage in stages {
        match stage {
            Stage::Eval => out.stages.push(bench_eval(args)?),
            Stage::Render => out.render = bench_render(args)?,
            Stage::Preprocess => {
                out.preprocess = preprocess::bench(args.image.as_deref(), peer_python(args))?
            }
            // Both learn stages are measured together, sharing PyTorch's runs.
            Stage::Train | Stage::Infer if out.learn.is_empty() => {
                out.learn = learn::bench(
                    args.arch,
                    train,
                    infer,
                    args.train_steps,
                    args.infer_runs,
                    peer_python(args),
                )?
            }
            Stage::Train | Stage::Infer => {}
            Stage::Markers => out.markers = markers::bench(peer_python(args))?,
            Stage::Refine => {
                out.refine = refine::bench(
                    args.refine_data.as_deref(),
                    &args.refine_blocks,
                    peer_python(args),
                )?
            }
            Stage::Serve => {
                out.serve = Some(serve::bench(
                    &args.demo_dir,
                    args.mc,
                    args.clients,
                    args.seconds,
                    args.load_fps,
                )?)
            }
            Stage::Scenecut => {
                out.scenecut = Some(scenecut::bench(
                    args.video.as_deref(),
                    args.repeat,
                    peer_python(args),
                )?)
            }
        }
    }
    if args.json {
        print_json(sink, &out)
    } else {
        let mut text = preprocess::table(&out.preprocess);
        text.push_str(&learn::table(&out.learn));
        if let Some(s) = &out.scenecut {
            text.push_str(&scenecut::table(s));
        }
        text.push_str(&markers::table(&out.markers));
        text.push_str(&refine::table(&out.refine));
        if let Some(s) = &out.serve {
            text.push_str(&serve::table(s));
        }
        if !out.render.is_empty() {
            text.push_str(&format!(
                "{:<10}{:>10}{:>9}{:>10}{:>12}\n",
                "render", "size", "threads", "frames/s", "ms/frame"
            ));
            for r in &out.render {
                text.push_str(&format!(
                    "{:<10}{:>10}{:>9}{:>10.0}{:>12.3}\n",
                    r.mode,
                    format!("{}x{}", r.width, r.height),
                    r.threads,
                    r.fps,
                    r.ms_per_frame
                ));
            }
        }
        if out.stages.is_empty() {
            return print_text(sink, &text);
        }
        text.push_str(&format!(
            "{:<8}{:>9}{:>12}{:>16}{:>12}{:>10}\n",
            "stage", "frames", "ms", "ms +report", "peer ms", "ratio"
        ));
        for s in &out.stages {
            let opt =
                |v: Option<f64>, digits: usize| v.map_or("-".into(), |v| format!("{v:.digits$}"));
            text.push_str(&format!(
                "{:<8}{:>9}{:>12.1}{:>16.1}{:>12}{:>10}\n",
                s.stage,
                s.frames,
                s.ms,
                s.ms_with_report,
                opt(s.vs.peer_ms, 1),
                opt(s.vs.ratio_vs_peer, 2)
            ));
            if let Some(note) = &s.vs.peer_note {
                text.push_str(&format!("  {}: {note}\n", s.vs.peer));
            }
        }
        print_text(sink, &text)
    }
}

/// Renders a walk through the default building in every mode at two sizes, on one thread and on
/// all of rayon's threads.
fn bench_render(args: &BenchConfig) -> Result<Vec<RenderFigures>> {
    use rayon::prelude::*;
    use synth::render::{RenderMode, RenderOptions, RenderScene, Renderer};
    let frames = args.render_frames;
    let cfg = synth::dataset::SynthConfig::default();
    let (world, _) = synth::dataset::build_world(&cfg)?;
    let scene = RenderScene::new(&world)?;
    let rig = synth::dataset::rig_of(cfg.camera);
    let walk_cfg = synth::trajectory::WalkConfig::for_rig(rig.clone());
    let walk = synth::trajectory::walk(&world, &walk_cfg, frames, cfg.seed)?;
    let all = rayon::current_num_threads();
    let mut figures = Vec::new();
    for (w, h) in [(160u32, 120u32), (320, 240)] {
        let camera = synth::trajectory::camera_for(&rig, w, h, cfg.seed)?;
        for mode in [
            RenderMode::Shaded,
            RenderMode::Textured,
            RenderMode::Edges,
            RenderMode::Gradmag,
        ] {
            let opts = RenderOptions {
                mode,
                ..RenderOptions::default()
            };
            for threads in [1, all] {
                let pool = rayon::ThreadPoolBuilder::new()
                    .num_threads(threads)
                    .build()
                    .context("building a thread pool")?;
                // Warm-up frame: first-use costs (distortion maps, buffers) are not the rate.
                Renderer::new().render(&scene, &camera, &walk[0].pose, &opts, &[])?;
                let start = Instant::now();
                pool.install(|| {
                    walk.par_iter().try_for_each_init(Renderer::new, |r, f| {
                        r.render(&scene, &camera, &f.pose, &opts, &[]).map(|_| ())
                    })
                })?;
                let secs = start.elapsed().as_secs_f64();
                figures.push(RenderFigures {
                    mode: mode.to_string(),
                    width: w,
                    height: h,
                    threads,
                    frames,
                    fps: frames as f64 / secs,
                    ms_per_frame: secs * 1e3 / frames as f64,
                });
                if all == 1 {
                    break;
                }
            }
        }
    }
    Ok(figures)
}

fn bench_eval(args: &BenchConfig) -> Result<StageFigures> {
    let dir = tempfile::tempdir().context("creating a temporary folder")?;
    let (gt_path, est_path) = (dir.path().join("gt.tum"), dir.path().join("est.tum"));
    let (gt, est) = noisy_walk(args.frames);
    data::tum::write(&gt, &gt_path)?;
    data::tum::write(&est, &est_path)?;

    let time = |with_report: bool| -> Result<f64> {
        let mut ms = Vec::with_capacity(args.repeat);
        for _ in 0..args.repeat {
            let mut eval_args = EvalConfig::new(gt_path.clone(), est_path.clone());
            if with_report {
                eval_args = eval_args.with_report(dir.path().join("report"));
            }
            let t = Instant::now();
            evaluate(&eval_args)?; // figures discarded: only the time counts
            ms.push(t.elapsed().as_secs_f64() * 1e3);
        }
        Ok(crate::output::median(&ms))
    };
    let ms = time(false)?;
    let ms_with_report = time(true)?;
    let (peer_ms, peer_note) = match run_metrics_peer(args, &gt_path, &est_path) {
        Ok(v) => (Some(v), None),
        Err(e) => (None, Some(format!("{e:#}"))),
    };
    Ok(StageFigures {
        stage: "eval",
        frames: args.frames,
        ms,
        ms_with_report,
        vs: VsPeer::new("numpy/scipy metrics.py", ms, peer_ms, peer_note),
    })
}

/// A walk of `n` frames at 10 Hz and an estimate with noise and jittered time stamps.
fn noisy_walk(n: usize) -> (Trajectory, Trajectory) {
    let mut rng = ChaCha8Rng::seed_from_u64(7);
    let (mut gt, mut est) = (Vec::with_capacity(n), Vec::with_capacity(n));
    for i in 0..n {
        let t = 0.1 * i as f64;
        let a = i as f64 * 1e-3;
        let pose =
            Pose::from_euler_ypr(a, 0.1 * a.sin(), 0.0, [10.0 * a.cos(), 6.0 * a.sin(), 1.5])
                .unwrap_or_default();
        let mut noise = || rng.random_range(-1.0..1.0);
        let noisy = Pose::from_euler_ypr(
            a + 0.05 * noise(),
            0.1 * a.sin() + 0.05 * noise(),
            0.05 * noise(),
            [
                10.0 * a.cos() + 0.3 * noise(),
                6.0 * a.sin() + 0.3 * noise(),
                1.5 + 0.1 * noise(),
            ],
        )
        .unwrap_or_default();
        let jitter = 0.004 * noise();
        gt.push(frame(t, pose));
        est.push(frame(t + jitter, noisy));
    }
    (Trajectory::new(gt), Trajectory::new(est))
}

fn frame(t: f64, pose: Pose) -> PoseFrame {
    PoseFrame {
        name: format!("{t}"),
        seq: String::new(),
        t: Some(t),
        pose,
    }
}

/// Runs `metrics.py` on the same files and returns its own `compute_ms` (reading, association
/// and statistics, without interpreter start-up: the same work `ms` measures).
fn run_metrics_peer(args: &BenchConfig, gt: &Path, est: &Path) -> Result<f64> {
    let peer = peer_python(args)?;
    let out = Command::new(&peer.python)
        .arg(peer.dir.join("metrics.py"))
        .args([
            "--gt",
            &gt.to_string_lossy(),
            "--est",
            &est.to_string_lossy(),
            "--no-evo",
        ])
        .output()
        .context("running metrics.py")?;
    if !out.status.success() {
        bail!(
            "metrics.py failed: {}",
            String::from_utf8_lossy(&out.stderr).trim()
        );
    }
    let v: serde_json::Value = serde_json::from_slice(&out.stdout).context("metrics.py output")?;
    v["compute_ms"]
        .as_f64()
        .context("metrics.py printed no compute_ms")
}

/// Finds the peer scripts and their venv (`$PEERS_VENV`, default `~/.cache/indoorloc-peers`, as
/// `setup.sh` makes it); the error says what is missing.
fn peer_python(args: &BenchConfig) -> Result<Peer> {
    let dir = peers_dir(args).context("peer scripts not found (pass --peers DIR)")?;
    let venv = std::env::var_os("PEERS_VENV")
        .map(PathBuf::from)
        .or_else(|| std::env::var_os("HOME").map(|h| Path::new(&h).join(".cache/indoorloc-peers")))
        .context("no PEERS_VENV or HOME")?;
    let python = venv.join("bin/python");
    if !python.is_file() {
        bail!(
            "peer venv missing at {} (run {}/setup.sh)",
            venv.display(),
            dir.display()
        );
    }
    Ok(Peer { dir, python })
}

fn peers_dir(args: &BenchConfig) -> Option<PathBuf> {
    let candidates = [
        args.peers.clone(),
        std::env::var_os("INDOORLOC_PEERS").map(PathBuf::from),
        Some(PathBuf::from("../shared/tools/peers")),
        Some(PathBuf::from("shared/tools/peers")),
    ];
    candidates
        .into_iter()
        .flatten()
        .find(|d| d.join("metrics.py").is_file())
}
