//! `indoorloc serve`: live localization. Frames from a source go through the pose network (and
//! the marker map, when given) and the temporal filter; the fused poses go out over HTTP and
//! WebSocket with a live dashboard (`serve` crate), or as JSON lines on stdout (`--jsonl`).
//!
//! `--demo` serves the default building's held-out walk in real time through the quick demo's
//! model (trained first when `--demo-dir` has none), looping, with the storey's floor map.

use crate::demo::{self, scene};
use crate::localize::Split;
use crate::{Context, Result, bail};
use clap::Args;
use data::native::SplitName;
use serve::{FloorMap, Hub, ServerConfig};
use std::io::Write;
use std::path::{Path, PathBuf};
use std::sync::Arc;
use std::sync::atomic::Ordering;
use track::{
    Event, MapEstimator, MarkerEstimator, Metrics, NetworkEstimator, Pipeline, PipelineConfig,
};

/// Arguments of `indoorloc serve`.
#[derive(Args, Debug, Clone)]
pub struct ServeConfig {
    /// Model folder (from `indoorloc train` or `demo`).
    #[arg(long, value_name = "DIR")]
    model: Option<PathBuf>,
    /// Frames: an image folder, an image, a video, a camera (`/dev/video0`), a native dataset
    /// folder (its `--split`, with ground truth), or raw frames on stdin
    /// (`stdin:WIDTHxHEIGHT[:rgb|gray]`).
    #[arg(long, value_name = "INPUT")]
    source: Option<String>,
    /// Address to listen on.
    #[arg(long, default_value = "127.0.0.1")]
    host: String,
    /// Port to listen on (0: any free port, printed at start).
    #[arg(long, default_value_t = 8080)]
    port: u16,
    /// An origin besides the server's own whose web pages may read the pose stream (`/ws`,
    /// `/pose`) and whose host name may reach the server, e.g. `https://robot.example`
    /// (repeatable); pages of other origins get 403.
    #[arg(long, value_name = "ORIGIN")]
    allow_origin: Vec<String>,
    /// Monte-Carlo-dropout passes per frame (0: one deterministic pass; the network's own
    /// error scale still gives the uncertainty). The covariance is calibrated for 16 passes
    /// with --tta, `localize`'s defaults; other settings publish it uncalibrated.
    #[arg(long, default_value_t = learn::calibrate::CALIBRATION_MC)]
    mc: usize,
    /// Test-time augmentation: each frame is also seen as four slightly shifted copies (five
    /// times the backbone's cost); their spread joins the covariance.
    #[arg(long, default_value_t = true, action = clap::ArgAction::Set, value_name = "BOOL")]
    tta: bool,
    /// Marker map (TOML, `indoorloc markers locate`'s): metric fixes from mapped ArUco
    /// markers in view, fused with the network's poses. Needs `--camera`.
    #[arg(long, value_name = "FILE")]
    markers: Option<PathBuf>,
    /// Camera intrinsics (OpenCV YAML from `indoorloc calibrate`) for the marker fixes.
    #[arg(long, value_name = "FILE")]
    camera: Option<PathBuf>,
    /// ArUco dictionary of the markers (default: the map's, else 4x4_50).
    #[arg(long)]
    dict: Option<String>,
    /// Keyframe map (`indoorloc map build`): each frame refined against it from the network's
    /// pose (or the filter's prediction), centimetre fixes fused with the rest; frames it cannot
    /// refine add nothing.
    #[arg(long = "map", value_name = "MAP")]
    keyframes: Option<PathBuf>,
    /// Play a file source at its recorded pace, as if live (a busy pipeline then drops stale
    /// frames). Camera and stdin sources are always live.
    #[arg(long)]
    realtime: bool,
    /// Frame rate of sources without timestamps (image folders, stdin).
    #[arg(long)]
    fps: Option<f64>,
    /// Frames of a native dataset source.
    #[arg(long, value_enum, default_value_t = Split::Test)]
    split: Split,
    /// Start the source over when it ends (for demos).
    #[arg(long = "loop")]
    loop_source: bool,
    /// Stop after this many frames (per pass of the source).
    #[arg(long)]
    max_frames: Option<u64>,
    /// Do not detect scene cuts (the filter then only starts over after repeated refusals).
    #[arg(long)]
    no_cuts: bool,
    /// No server: write every event as a JSON line to stdout and exit at the end of the source.
    #[arg(long)]
    jsonl: bool,
    /// Serve the default building's held-out walk in real time through the quick demo's model.
    #[arg(long)]
    demo: bool,
    /// Folder of the demo (`indoorloc demo --quick --out DIR`) that `--demo` uses, trained
    /// first when it holds no model.
    #[arg(long, value_name = "DIR", default_value = "indoorloc-demo")]
    demo_dir: PathBuf,
    /// Publish the fused poses on ROS 2 as `geometry_msgs/PoseWithCovarianceStamped` on this
    /// topic (needs indoorloc built with the `ros2` feature).
    #[arg(long, value_name = "TOPIC")]
    ros2: Option<String>,
}

/// What `serve` runs: the parts resolved from the arguments.
struct Plan {
    model: Option<PathBuf>,
    source: String,
    split: Option<SplitName>,
    realtime: bool,
    loop_source: bool,
    map: FloorMap,
}

/// Runs `indoorloc serve`.
pub fn run(args: &ServeConfig, sink: &mut dyn crate::Output) -> Result<()> {
    let resolved = plan(args)?;
    // Open everything once up front, so a bad model, map or source fails before serving.
    let first = build_pipeline(args, &resolved)?;
    if args.jsonl {
        return run_jsonl(first, sink.stream());
    }
    #[cfg(not(feature = "ros2"))]
    if args.ros2.is_some() {
        bail!("--ros2 needs indoorloc built with the `ros2` feature (cargo build --features ros2)");
    }
    let metrics = first.metrics();
    let hub = Hub::new(Arc::clone(&metrics), resolved.map.clone());
    #[cfg(feature = "ros2")]
    let _ros = match &args.ros2 {
        Some(topic) => {
            Some(serve::ros2::Publisher::start(&hub, topic).map_err(crate::LabError::msg)?)
        }
        None => None,
    };

    let runtime = tokio::runtime::Builder::new_multi_thread()
        .worker_threads(2)
        .enable_all()
        .build()
        .context("cannot start the server's runtime")?;
    let addr = format!("{}:{}", args.host, args.port);
    let listener = runtime
        .block_on(tokio::net::TcpListener::bind(&addr))
        .with_context(|| format!("cannot listen on {addr}"))?;
    let local = listener.local_addr()?;
    crate::progress::note(&format!(
        "indoorloc serve: dashboard at http://{local}/  (pose stream: ws://{local}/ws)"
    ));

    let stop = first.stop_flag();
    let feeder = {
        let (hub, args) = (Arc::clone(&hub), args.clone());
        // Later passes of a looping source rebuild the pipeline from the same arguments (the
        // demo is prepared by then; planning again only reads its files).
        let rebuild = move || build_pipeline(&args, &plan(&args)?);
        let looping = resolved.loop_source;
        std::thread::spawn(move || feed(first, rebuild, &hub, looping, metrics))
    };
    let shutdown = async {
        let _ = tokio::signal::ctrl_c().await;
    };
    runtime
        .block_on(serve::serve(
            listener,
            hub,
            ServerConfig {
                allow_origins: args.allow_origin.clone(),
                ..ServerConfig::default()
            },
            shutdown,
        ))
        .context("server failed")?;
    // The pipeline stops after the frame in hand; a live source that sends nothing more
    // would keep it waiting, so the process ends without joining it.
    stop.store(true, Ordering::Relaxed);
    drop(feeder);
    Ok(())
}

/// Runs `first` into the hub, and for a looping source one pipeline after another, with one
/// set of figures.
fn feed(
    first: Pipeline,
    rebuild: impl Fn() -> Result<Pipeline>,
    hub: &Hub,
    looping: bool,
    metrics: Arc<Metrics>,
) {
    let mut pipeline = first;
    loop {
        let stop = pipeline.stop_flag();
        let end = pipeline.run(|event, frame| {
            // A looping source's own end is not the stream's end.
            if !(looping && matches!(event, Event::End { .. })) {
                hub.publish(event, frame);
            }
        });
        if !looping || !matches!(end, Event::End { .. }) || stop.load(Ordering::Relaxed) {
            return;
        }
        pipeline = match rebuild() {
            Ok(p) => p.with_metrics(Arc::clone(&metrics)),
            Err(e) => {
                let message = format!("{e:#}");
                hub.publish(
                    &Event::Error {
                        frame: None,
                        message,
                    },
                    None,
                );
                return;
            }
        };
    }
}

/// Resolves the model, source and map from the arguments (preparing the demo for `--demo`).
fn plan(args: &ServeConfig) -> Result<Plan> {
    let split = match args.split {
        Split::All => None,
        Split::Train => Some(SplitName::Train),
        Split::Val => Some(SplitName::Val),
        Split::Test => Some(SplitName::Test),
    };
    if args.demo {
        let (model, data, scene) = prepare_demo(&args.demo_dir)?;
        let map = demo_map(&scene, &data)?;
        return Ok(Plan {
            model: Some(args.model.clone().unwrap_or(model)),
            source: args
                .source
                .clone()
                .unwrap_or_else(|| data.to_string_lossy().into_owned()),
            split: Some(SplitName::Test),
            realtime: true,
            loop_source: true,
            map,
        });
    }
    let Some(source) = args.source.clone() else {
        bail!("serve needs --source INPUT (or --demo)");
    };
    if args.model.is_none() && args.markers.is_none() && args.keyframes.is_none() {
        bail!("serve needs --model DIR, --markers FILE --camera FILE, --map MAP, or several");
    }
    let map = dataset_map(Path::new(&source), split)?;
    Ok(Plan {
        model: args.model.clone(),
        source,
        split,
        realtime: args.realtime,
        loop_source: args.loop_source,
        map,
    })
}

/// The estimators and source of `plan`, joined into a pipeline.
fn build_pipeline(args: &ServeConfig, plan: &Plan) -> Result<Pipeline> {
    let source = track::source::open(&plan.source, plan.split, args.fps)?;
    let mut estimators: Vec<track::BoxedEstimator> = Vec::new();
    let mut filter = track::FilterConfig::default();
    if let Some(dir) = &plan.model {
        let net = NetworkEstimator::load(dir, args.mc)?.with_tta(args.tta);
        match net.fused_cov_scale() {
            Some(scale) => filter.cov_scale = scale,
            None => crate::progress::note(&format!(
                "indoorloc: note: the fused covariance is not calibrated for this model at \
                 --mc {} --tta {} (it is for --mc {} --tta true once trained by this version)",
                args.mc,
                args.tta,
                learn::calibrate::CALIBRATION_MC
            )),
        }
        estimators.push(Box::new(net));
    }
    match (&args.markers, &args.camera) {
        (Some(map), Some(cam)) => {
            let map = markers::MarkerMap::read(map)?;
            let camera = crate::markers::read_camera(cam)?;
            estimators.push(Box::new(MarkerEstimator::new(
                map,
                camera,
                args.dict.as_deref(),
            )?));
        }
        (Some(_), None) => bail!("--markers needs --camera FILE (the camera's intrinsics)"),
        (None, Some(_)) => bail!("--camera is only used with --markers"),
        (None, None) => {}
    }
    if let Some(path) = &args.keyframes {
        estimators.push(Box::new(MapEstimator::load(path)?));
    }
    let cfg = PipelineConfig {
        filter,
        realtime: plan.realtime,
        detect_cuts: !args.no_cuts,
        max_frames: args.max_frames,
        ..PipelineConfig::default()
    };
    Ok(Pipeline::new(source, estimators, cfg)?)
}

/// `--jsonl`: every event as a line on stdout; a failed source is an error (exit 2) after its
/// error line.
fn run_jsonl(pipeline: Pipeline, out: &mut dyn Write) -> Result<()> {
    let stop = pipeline.stop_flag();
    let mut write_failed = None;
    let end = pipeline.run(|event, _| {
        if write_failed.is_some() {
            return;
        }
        let line = serde_json::to_string(event).map_err(std::io::Error::other);
        if let Err(e) = line.and_then(|l| writeln!(out, "{l}").and_then(|()| out.flush())) {
            // A closed pipe ends the run quietly; the reader has what it wanted.
            write_failed = Some(e);
            stop.store(true, Ordering::Relaxed);
        }
    });
    match (end, write_failed) {
        (_, Some(e)) if e.kind() == std::io::ErrorKind::BrokenPipe => Ok(()),
        (_, Some(e)) => Err(e).context("cannot write to stdout"),
        (Event::Error { message, .. }, None) => bail!("the stream failed: {message}"),
        _ => Ok(()),
    }
}

/// The demo folder's model, dataset and plan, rendering and training the quick demo first
/// when the folder has no model.
fn prepare_demo(dir: &Path) -> Result<(PathBuf, PathBuf, scene::ScenePlan)> {
    let (model, data) = (dir.join("model"), dir.join("data"));
    let plan_file = data.join(scene::PLAN_TOML);
    if model.join("model.toml").is_file() && plan_file.is_file() {
        let text = std::fs::read_to_string(&plan_file)
            .with_context(|| format!("{}: cannot read", plan_file.display()))?;
        let plan: scene::ScenePlan = toml::from_str(&text)
            .with_context(|| format!("{}: not a demo plan", plan_file.display()))?;
        return Ok((model, data, plan));
    }
    crate::progress::note(&format!(
        "indoorloc serve --demo: {} holds no trained demo; running `indoorloc demo --quick --out {}` first (a few minutes)",
        dir.display(),
        dir.display()
    ));
    let args = demo::DemoConfig::quick(dir);
    let prepared = demo::render_and_train(&args, &|t| crate::progress::note(t))?;
    Ok((
        prepared.model_dir.clone(),
        prepared.data_dir.clone(),
        prepared.scene().clone(),
    ))
}

/// The demo storey's rooms and the test walk's path.
fn demo_map(plan: &scene::ScenePlan, data: &Path) -> Result<FloorMap> {
    let mut map = dataset_map(data, Some(SplitName::Test))?;
    map.rects = scene::floor_plan(plan)?;
    map.title = format!(
        "default building {}, storey {}: held-out walk",
        plan.building, plan.storey
    );
    Ok(map)
}

/// For a posed dataset source (any layout `data::posed` opens), its frames' path (the ground
/// truth) as the map; else an empty map (the dashboard then frames the trail itself).
fn dataset_map(source: &Path, split: Option<SplitName>) -> Result<FloorMap> {
    if !data::posed::is_dataset(source) {
        return Ok(FloorMap::default());
    }
    let ds = data::posed::open(source)?;
    let parts = ds.parts(data::posed::SplitPlan::Auto);
    Ok(FloorMap {
        title: source.display().to_string(),
        rects: Vec::new(),
        path: ds
            .images
            .iter()
            .zip(parts)
            .filter(|(_, p)| split.is_none() || *p == split)
            .map(|(img, _)| {
                let p = img.frame.pose.position();
                [p[0], p[1]]
            })
            .collect(),
    })
}
