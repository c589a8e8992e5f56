//! `indoorloc study track`: what the live pipeline's temporal filter adds to the network.
//!
//! The demo's network (rendered and trained as `demo` does, reused when `--out` holds it)
//! localizes the held-out test walk through `track::Pipeline`, exactly as `indoorloc serve`
//! runs it (frame source, network estimator, cut detector, filter), once without and once with
//! Monte-Carlo dropout. Each frame's raw network estimate and fused pose are scored against
//! the ground truth: median and mean errors, accuracy, and jitter (the mean change of the
//! position error from one frame to the next, as `study sequence` measures it).

use crate::demo;
use crate::output::{print_json, print_text};
use crate::{Result, bail};
use clap::Args;
use data::native::SplitName;
use geom::Pose;
use geom::metrics::{Stats, jitter, position_error, rotation_error_deg};
use report::{HtmlReport, Series, Table};
use serde::Serialize;
use std::path::PathBuf;
use track::{Event, NetworkEstimator, Pipeline, PipelineConfig, PoseEvent, Stage};

/// Arguments of `indoorloc study track`.
#[derive(Args, Debug)]
pub struct TrackConfig {
    /// Folder for the data, the model and `report.html` (a demo folder is reused as it is).
    #[arg(long, value_name = "DIR", default_value = "indoorloc-study-track")]
    out: PathBuf,
    #[command(flatten)]
    scale: super::common::Scale,
    /// Monte-Carlo-dropout passes of the second run.
    #[arg(long, default_value_t = 16)]
    mc: usize,
    /// Print one JSON document instead of a table.
    #[arg(long)]
    json: bool,
}

/// One row: the raw network or the fused track, at one MC setting.
#[derive(Debug, Serialize)]
struct Row {
    /// `network` (raw per-frame estimates) or `fused` (the filter's output).
    model: &'static str,
    /// MC-dropout passes.
    mc: usize,
    median_pos_m: f64,
    mean_pos_m: f64,
    median_rot_deg: f64,
    /// Mean absolute change of the position error between consecutive frames.
    jitter_m: f64,
    /// Share of frames within (0.25 m, 2°), (0.5 m, 5°), (5 m, 10°).
    accuracy: [f64; 3],
    /// Pipeline throughput over the walk (frames read from disk, decoded, localized, fused).
    frames_per_s: f64,
    /// 99th percentile of the end-to-end latency per frame.
    p99_ms: f64,
}

#[derive(Debug, Serialize)]
struct StudyOutput {
    rows: Vec<Row>,
    frames: usize,
    /// Per MC setting: how much lower the fused jitter is than the raw one, percent.
    jitter_reduction_pct: Vec<f64>,
    report: PathBuf,
}

/// Errors of one pose stream against the truth.
struct Scored {
    pos: Vec<f64>,
    rot: Vec<f64>,
}

impl Scored {
    fn of(pairs: impl Iterator<Item = (Pose, Pose)>) -> Scored {
        let (pos, rot) = pairs
            .map(|(truth, est)| {
                (
                    position_error(&truth, &est),
                    rotation_error_deg(&truth, &est),
                )
            })
            .unzip();
        Scored { pos, rot }
    }
}

/// Runs `indoorloc study track`.
pub fn run(args: &TrackConfig, sink: &mut dyn crate::Output) -> Result<()> {
    let say = |text: &str| {
        if !args.json {
            crate::progress::note(text);
        }
    };
    let demo_args = args.scale.demo(&args.out);
    let prepared = demo::render_and_train(&demo_args, &say)?;
    let mut rows = Vec::new();
    let mut curves = Vec::new();
    let mut frames = 0;
    for (k, mc) in [0, args.mc].into_iter().enumerate() {
        say(&format!(
            "{}/4 the held-out walk through the live pipeline, {mc} MC passes",
            k + 3
        ));
        let source = track::source::open(
            &prepared.data_dir.to_string_lossy(),
            Some(SplitName::Test),
            None,
        )?;
        let net = NetworkEstimator::load(&prepared.model_dir, mc)?;
        let pipeline = Pipeline::new(source, vec![Box::new(net)], PipelineConfig::default())?;
        let metrics = pipeline.metrics();
        let mut poses: Vec<PoseEvent> = Vec::new();
        let started = std::time::Instant::now();
        let end = pipeline.run(|e, _| {
            if let Event::Pose(p) = e {
                poses.push(PoseEvent::clone(p));
            }
        });
        let seconds = started.elapsed().as_secs_f64();
        if let Event::Error { message, .. } = end {
            bail!("the pipeline failed: {message}");
        }
        let snap = metrics.snapshot();
        let total = snap.stage(Stage::Total);
        let truth = |p: &PoseEvent| p.truth_pose();
        let raw = Scored::of(
            poses
                .iter()
                .filter_map(|p| Some((truth(p)?, p.raw_pose()?))),
        );
        let fused = Scored::of(poses.iter().filter_map(|p| Some((truth(p)?, p.pose()?))));
        if raw.pos.len() != poses.len() || fused.pos.len() != poses.len() || poses.is_empty() {
            bail!(
                "the test walk gave {} poses, {} with a raw estimate",
                poses.len(),
                raw.pos.len()
            );
        }
        frames = poses.len();
        let fps = frames as f64 / seconds;
        for (model, s) in [("network", &raw), ("fused", &fused)] {
            rows.push(row(
                model,
                mc,
                s,
                fps,
                total.map_or(f64::NAN, |t| t.p99_ms),
            )?);
            curves.push((format!("{model}, MC {mc}"), s.pos.clone(), s.rot.clone()));
        }
    }
    let reduction: Vec<f64> = rows
        .chunks(2)
        .map(|r| 100.0 * (1.0 - r[1].jitter_m / r[0].jitter_m))
        .collect();
    let report = args.out.join("report.html");
    write_report(&report, &rows, &curves)?;
    let out = StudyOutput {
        rows,
        frames,
        jitter_reduction_pct: reduction,
        report,
    };
    if args.json {
        print_json(sink, &out)
    } else {
        print_text(
            sink,
            &format!(
                "{}\n{} test frames; fused jitter {} lower\nreport: {}\n",
                table(&out.rows).to_text(),
                out.frames,
                out.jitter_reduction_pct
                    .iter()
                    .map(|r| format!("{r:.0} %"))
                    .collect::<Vec<_>>()
                    .join(" / "),
                out.report.display()
            ),
        )
    }
}

fn row(model: &'static str, mc: usize, s: &Scored, fps: f64, p99_ms: f64) -> Result<Row> {
    let (pos, rot) = (Stats::of(&s.pos)?, Stats::of(&s.rot)?);
    let within = |m: f64, d: f64| {
        s.pos
            .iter()
            .zip(&s.rot)
            .filter(|(p, r)| **p <= m && **r <= d)
            .count() as f64
            / s.pos.len() as f64
    };
    Ok(Row {
        model,
        mc,
        median_pos_m: pos.median,
        mean_pos_m: pos.mean,
        median_rot_deg: rot.median,
        jitter_m: jitter(&s.pos),
        accuracy: [within(0.25, 2.0), within(0.5, 5.0), within(5.0, 10.0)],
        frames_per_s: fps,
        p99_ms,
    })
}

fn table(rows: &[Row]) -> Table {
    let mut t = Table::new(
        "Raw network against the fused live track",
        [
            "poses",
            "MC",
            "median (m)",
            "median (°)",
            "mean (m)",
            "jitter (m)",
            "(0.5 m, 5°)",
            "frames/s",
            "p99 ms",
        ],
    );
    for r in rows {
        t.push_row([
            r.model.to_string(),
            r.mc.to_string(),
            format!("{:.3}", r.median_pos_m),
            format!("{:.2}", r.median_rot_deg),
            format!("{:.3}", r.mean_pos_m),
            format!("{:.3}", r.jitter_m),
            format!("{:.1} %", 100.0 * r.accuracy[1]),
            format!("{:.0}", r.frames_per_s),
            format!("{:.1}", r.p99_ms),
        ]);
    }
    t
}

fn write_report(
    path: &std::path::Path,
    rows: &[Row],
    curves: &[(String, Vec<f64>, Vec<f64>)],
) -> Result<()> {
    let mut page = HtmlReport::new("Raw network against the fused live track");
    page.paragraph(
        "The demo's network localizes the held-out test walk through the live pipeline of \
         `indoorloc serve` (frames read from disk, scene-cut detector, network, constant-velocity \
         filter with outlier gating). \"network\" is each frame's own estimate, \"fused\" the \
         filter's output for the same frame. Jitter is the mean change of the position error \
         between consecutive frames."
            .to_string(),
    );
    page.table(&table(rows));
    let pos: Vec<Series> = curves
        .iter()
        .map(|(n, p, _)| Series::new(n, p.clone()))
        .collect();
    let rot: Vec<Series> = curves
        .iter()
        .map(|(n, _, r)| Series::new(n, r.clone()))
        .collect();
    page.figure(
        &report::error_cdf("Error CDF", &pos, &rot),
        "Cumulative distribution of position and rotation errors.",
    )?;
    page.figure(
        &report::error_over_time("Position error along the walk", &pos, &[], None),
        "Position error per frame of the test walk.",
    )?;
    page.write(path)?;
    Ok(())
}
