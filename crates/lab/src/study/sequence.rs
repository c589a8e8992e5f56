//! `indoorloc study sequence`: the single-frame network against the CNN+LSTM sequence model on
//! its features, same data, same CNN: median errors, frame-to-frame jitter and live latency.
//!
//! 1. The demo's network (rendered and trained as `demo` does, reused when `--out` holds it).
//! 2. The sequence part trained on its frozen features over windows of `--window` frames
//!    (`train --window`; reused when trained before with the same settings), on walks of their
//!    own at the camera's frame rate (`DIR/seq-data`, [`demo::scene::ScenePlan::for_sequence_model`]):
//!    the network's training walks run at 1 Hz, and an LSTM learns the motion between frames.
//! 3. The held-out test walk localized both ways: every frame alone, and as one recording with
//!    the LSTM state carried from frame to frame (reset at the walk's start and at any cut).
//! 4. Live latency: one frame at a time, the single-frame model's `predict` against the
//!    stateful tracker's `step`, on the same frames, with and without MC dropout.

use crate::Result;
use crate::demo::{self, FrameResult};
use crate::output::{print_json, print_text};
use crate::train::train_sequence_with_progress;
use clap::Args;
use data::native::{NativeDataset, SplitName};
use learn::seq::{SeqConfig, SeqLocalizer, SeqMeta};
use report::{HtmlReport, Series, Table};
use serde::Serialize;
use std::path::PathBuf;
use std::time::Instant;

/// Arguments of `indoorloc study sequence`.
#[derive(Args, Debug)]
pub struct SequenceConfig {
    /// Folder for the data, the models and `report.html` (a demo folder is reused as it is; its
    /// `report.html` is then this study's).
    #[arg(long, value_name = "DIR", default_value = "indoorloc-study-sequence")]
    out: PathBuf,
    #[command(flatten)]
    scale: super::common::Scale,
    /// Frames per training window of the sequence model.
    #[arg(long, default_value_t = 20)]
    window: usize,
    /// LSTM units.
    #[arg(long, default_value_t = 256)]
    lstm_units: usize,
    /// Epochs of the sequence model.
    #[arg(long, default_value_t = 10)]
    seq_epochs: usize,
    /// Monte-Carlo-dropout passes per frame.
    #[arg(long, default_value_t = 16)]
    mc: usize,
    /// Frames timed one at a time for the live latency.
    #[arg(long, default_value_t = 100)]
    latency_frames: usize,
    /// Print one JSON document instead of a table.
    #[arg(long)]
    json: bool,
}

/// One row of the table.
#[derive(Debug, Serialize)]
struct Row {
    /// `single` (each frame alone) or `sequence` (CNN+LSTM, state carried).
    model: &'static str,
    median_pos_m: f64,
    median_rot_deg: f64,
    mean_pos_m: f64,
    /// Mean |Δ position error| between consecutive frames, metres.
    jitter_m: f64,
    /// Live latency per frame without MC dropout, milliseconds (median).
    latency_ms: f64,
    /// Live latency per frame with `mc` MC-dropout passes, milliseconds (median).
    latency_mc_ms: f64,
    /// Pearson R between sigma_pos_m and the position error.
    uncertainty_r: f64,
}

/// What `study sequence` prints.
#[derive(Debug, Serialize)]
struct StudyOutput {
    rows: Vec<Row>,
    frames: usize,
    window: usize,
    /// Jitter of the sequence model relative to the single-frame one's, in per cent less.
    jitter_reduction_pct: f64,
    /// Live latency of the sequence model over the single-frame one's (no MC).
    latency_ratio: f64,
    mc: usize,
    report: PathBuf,
}

/// Runs `indoorloc study sequence`.
pub fn run(args: &SequenceConfig, sink: &mut dyn crate::Output) -> Result<()> {
    let say = |text: &str| {
        if !args.json {
            crate::progress::note(text);
        }
    };
    let demo_args = args.scale.demo(&args.out);
    let prepared = demo::render_and_train(&demo_args, &say)?;
    say(&format!(
        "3/5 the sequence model: windows of {} frames of walks at the camera's rate, on the \
         network's features",
        args.window
    ));
    let seq_data = prepared.render_sequence_data(args.window)?;
    let mut cfg = SeqConfig::new(&seq_data, &prepared.model_dir);
    cfg.window = args.window;
    cfg.hidden = args.lstm_units;
    cfg.epochs = args.seq_epochs;
    // a sequence part this build cannot read (an older layout) is the study's own to replace
    let unreadable =
        SeqMeta::exists(&prepared.model_dir) && SeqMeta::read(&prepared.model_dir).is_err();
    cfg.resume = !unreadable;
    cfg.force = unreadable;
    train_sequence_with_progress(&cfg, !args.json)?;

    say("4/5 localizing the held-out test walk frame by frame and as a sequence");
    let ds = NativeDataset::open(&prepared.data_dir)?;
    let seq = SeqLocalizer::load(&prepared.model_dir)?;
    let base = seq.base();
    let task = base.meta().coding.task;
    let index = ds.split_frames(SplitName::Test);
    let views = demo::views_of(&ds, &index, base, prepared.scene().train_mode()?)?;
    let single = demo::frame_results(&ds, &index, base.predict_batch(&views, args.mc)?, task);
    let keys: Vec<(String, u64)> = index
        .iter()
        .map(|&i| {
            let f = &ds.trajectory.frames[i];
            (f.seq.clone(), ds.frame_number(i).unwrap_or(i as u64))
        })
        .collect();
    let runs = learn::window::runs(&keys, ds.cuts.as_deref().unwrap_or_default());
    let sequence =
        demo::frame_results(&ds, &index, seq.predict_runs(&views, &runs, args.mc)?, task);

    say("5/5 live latency, one frame at a time");
    let timed = &views[..args
        .latency_frames
        .clamp(1, views.len().max(1))
        .min(views.len())];
    let latency = |mc: usize| -> Result<(f64, f64)> {
        let single = time_each(timed, |v| base.predict_view(v, mc).map(drop))?;
        let mut tracker = seq.tracker(mc);
        let stepped = time_each(timed, |v| tracker.step(v).map(drop))?;
        Ok((single, stepped))
    };
    let (single_ms, seq_ms) = latency(0)?;
    let (single_mc_ms, seq_mc_ms) = latency(args.mc)?;
    let rows = vec![
        row("single", &single, single_ms, single_mc_ms)?,
        row("sequence", &sequence, seq_ms, seq_mc_ms)?,
    ];
    let report = args.out.join("report.html");
    write_report(&report, &rows, &single, &sequence, args)?;
    let out = StudyOutput {
        frames: index.len(),
        window: args.window,
        jitter_reduction_pct: 100.0 * (1.0 - rows[1].jitter_m / rows[0].jitter_m),
        latency_ratio: rows[1].latency_ms / rows[0].latency_ms,
        mc: args.mc,
        rows,
        report,
    };
    if args.json {
        print_json(sink, &out)
    } else {
        print_text(
            sink,
            &format!(
                "{}\n{} test frames; jitter {:.0} % lower; live latency ratio {:.2} (no MC)\nreport: {}\n",
                table(&out.rows).to_text(),
                out.frames,
                out.jitter_reduction_pct,
                out.latency_ratio,
                out.report.display()
            ),
        )
    }
}

/// Median milliseconds of `f` on each view, after one untimed call (allocations, caches).
fn time_each(
    views: &[imgproc::view::View],
    mut f: impl FnMut(&imgproc::view::View) -> learn::Result<()>,
) -> Result<f64> {
    if let Some(first) = views.first() {
        f(first)?;
    }
    let mut ms = Vec::with_capacity(views.len());
    for v in views {
        let t = Instant::now();
        f(v)?;
        ms.push(t.elapsed().as_secs_f64() * 1e3);
    }
    Ok(crate::output::median(&ms))
}

fn row(
    model: &'static str,
    results: &[FrameResult],
    latency_ms: f64,
    latency_mc_ms: f64,
) -> Result<Row> {
    let pos: Vec<f64> = results.iter().map(|r| r.pos_err_m).collect();
    let rot: Vec<f64> = results.iter().map(|r| r.rot_err_deg).collect();
    let sigma: Vec<f64> = results.iter().map(|r| r.estimate.sigma_pos_m).collect();
    let stats = |v: &[f64]| geom::metrics::Stats::of(v);
    Ok(Row {
        model,
        median_pos_m: stats(&pos)?.median,
        median_rot_deg: stats(&rot)?.median,
        mean_pos_m: stats(&pos)?.mean,
        jitter_m: geom::metrics::jitter(&pos),
        latency_ms,
        latency_mc_ms,
        uncertainty_r: geom::metrics::pearson(&sigma, &pos).unwrap_or(f64::NAN),
    })
}

fn table(rows: &[Row]) -> Table {
    let mut t = Table::new(
        "Single frame against sequence (CNN+LSTM)",
        [
            "model",
            "median (m)",
            "median (°)",
            "mean (m)",
            "jitter (m)",
            "live ms",
            "live ms, MC",
            "R(σ, err)",
        ],
    );
    for r in rows {
        t.push_row([
            r.model.to_string(),
            format!("{:.3}", r.median_pos_m),
            format!("{:.2}", r.median_rot_deg),
            format!("{:.3}", r.mean_pos_m),
            format!("{:.3}", r.jitter_m),
            format!("{:.2}", r.latency_ms),
            format!("{:.2}", r.latency_mc_ms),
            format!("{:.2}", r.uncertainty_r),
        ]);
    }
    t
}

fn write_report(
    path: &std::path::Path,
    rows: &[Row],
    single: &[FrameResult],
    sequence: &[FrameResult],
    args: &SequenceConfig,
) -> Result<()> {
    let mut page = HtmlReport::new("Single frame against sequence (CNN+LSTM)");
    page.paragraph(format!(
        "The demo's network localizes each frame of the held-out test walk alone; the sequence \
         model runs an LSTM ({} units, trained on windows of {} frames of the same network's \
         features) over the walk with its state carried from frame to frame, as live. Jitter is \
         the mean change of the position error between consecutive frames; live latency is the \
         median time per frame, one frame at a time, without and with {} MC-dropout passes.",
        args.lstm_units, args.window, args.mc
    ));
    page.table(&table(rows));
    let curve = |name: &str, r: &[FrameResult], f: fn(&FrameResult) -> f64| {
        Series::new(name, r.iter().map(f).collect::<Vec<_>>())
    };
    let cdf = report::error_cdf(
        "Error CDF",
        &[
            curve("single", single, |r| r.pos_err_m),
            curve("sequence", sequence, |r| r.pos_err_m),
        ],
        &[
            curve("single", single, |r| r.rot_err_deg),
            curve("sequence", sequence, |r| r.rot_err_deg),
        ],
    );
    page.figure(
        &cdf,
        "Cumulative distribution of position and rotation errors.",
    )?;
    let over_time = report::error_over_time(
        "Position error along the walk",
        &[
            curve("single", single, |r| r.pos_err_m),
            curve("sequence", sequence, |r| r.pos_err_m),
        ],
        &[],
        None,
    );
    page.figure(&over_time, "Position error per frame of the test walk.")?;
    page.write(path)?;
    Ok(())
}
