//! `indoorloc eval`: errors of estimated poses against ground truth.

use crate::output::{print_json, print_text};
use crate::{Context, Result};
use clap::Args;
use data::formats::{self, Format};
use data::matching::{MatchedBy, match_frames};
use geom::metrics::{ACCURACY_THRESHOLDS, PoseEvaluation, Smoothness};
use geom::uncertainty::{Standardised, UncertaintyFigures};
use serde::Serialize;
use std::path::{Path, PathBuf};
use std::time::Instant;

/// Arguments of `indoorloc eval`.
#[derive(Args, Debug)]
pub struct EvalConfig {
    /// Ground-truth poses: a TUM file, localize JSON lines, a native dataset, a 7-Scenes scene or
    /// sequence folder, a Cambridge list, a COLMAP model folder, a NeRF transforms.json or a
    /// robot log CSV; the format is told from the content.
    #[arg(long)]
    gt: PathBuf,
    /// Estimated poses, in any format --gt accepts.
    #[arg(long)]
    est: PathBuf,
    /// Format of --gt when detection guesses wrong (native, 7scenes, cambridge, tum, colmap,
    /// nerf, robotlog, jsonl).
    #[arg(long, value_name = "FORMAT")]
    gt_format: Option<Format>,
    /// Format of --est when detection guesses wrong.
    #[arg(long, value_name = "FORMAT")]
    est_format: Option<Format>,
    /// Largest timestamp difference, seconds, when frames are paired by time (TUM, robot logs).
    #[arg(long, default_value_t = 0.01, value_name = "SECONDS")]
    max_dt: f64,
    /// Scene cuts (cuts.csv, a list of frame numbers, or `scenecut --json` output): statistics
    /// are also split into frames just after a cut and the others.
    #[arg(long, value_name = "FILE")]
    cuts: Option<PathBuf>,
    /// With --cuts: a frame counts as "near a cut" when it is at most this many frames after one.
    #[arg(long, default_value_t = 10, value_name = "FRAMES")]
    cut_window: u64,
    /// Write an HTML report with plots (error CDF, errors over time, top-down trajectory) here.
    #[arg(long, value_name = "DIR")]
    report: Option<PathBuf>,
    /// Write every matched frame's errors here as CSV (`frame,pos_err_m,rot_err_deg`).
    #[arg(long, value_name = "CSV")]
    per_frame: Option<PathBuf>,
    /// Print one JSON document instead of a table.
    #[arg(long)]
    json: bool,
}

/// The `--json` document.
#[derive(Debug, Serialize)]
pub struct EvalOutput {
    /// Matched frames.
    pub frames: usize,
    /// Median position error, metres.
    pub median_pos_m: f64,
    /// Median rotation error, degrees.
    pub median_rot_deg: f64,
    mean_pos_m: f64,
    mean_rot_deg: f64,
    rmse_pos_m: f64,
    rmse_rot_deg: f64,
    max_pos_m: f64,
    max_rot_deg: f64,
    acc_25cm_2deg: f64,
    acc_50cm_5deg: f64,
    acc_5m_10deg: f64,
    mae_xyz_m: Vec<f64>,
    mse_xyz_m2: Vec<f64>,
    rmse_xyz_m: Vec<f64>,
    jitter_m: f64,
    smoothness_est: Option<Smoothness>,
    smoothness_gt: Option<Smoothness>,
    /// Estimate minus ground truth: positive means the estimate steps more, or more unevenly.
    smoothness_diff: Option<Smoothness>,
    matched_by: MatchedBy,
    gt_frames: usize,
    est_frames: usize,
    unmatched_est: usize,
    #[serde(skip_serializing_if = "Option::is_none")]
    near_cuts: Option<Subset>,
    #[serde(skip_serializing_if = "Option::is_none")]
    away_from_cuts: Option<Subset>,
    /// How the estimates' `cov_pos_m2` (localize JSON lines) reads their errors, when they
    /// carry one.
    #[serde(skip_serializing_if = "Option::is_none")]
    coverage: Option<UncertaintyFigures>,
    #[serde(skip_serializing_if = "Option::is_none")]
    report: Option<PathBuf>,
    seconds: f64,
}

/// Statistics of a subset of frames (near cuts, away from cuts).
#[derive(Debug, Serialize)]
struct Subset {
    frames: usize,
    median_pos_m: Option<f64>,
    median_rot_deg: Option<f64>,
    mean_pos_m: Option<f64>,
    acc_25cm_2deg: Option<f64>,
    acc_50cm_5deg: Option<f64>,
    acc_5m_10deg: Option<f64>,
}

impl EvalConfig {
    /// Arguments for comparing two files with default options (used by `bench`).
    pub fn new(gt: PathBuf, est: PathBuf) -> Self {
        Self {
            gt,
            est,
            gt_format: None,
            est_format: None,
            max_dt: 0.01,
            cuts: None,
            cut_window: 10,
            report: None,
            per_frame: None,
            json: true,
        }
    }

    /// Also write the HTML report into `dir`.
    pub fn with_report(mut self, dir: PathBuf) -> Self {
        self.report = Some(dir);
        self
    }
}

/// Runs `indoorloc eval`.
pub fn run(args: &EvalConfig, sink: &mut dyn crate::Output) -> Result<()> {
    let (out, ev) = evaluate(args)?;
    if args.json {
        print_json(sink, &out)
    } else {
        print_text(sink, &human_text(&out, &ev, args.cut_window))
    }
}

/// Reads, pairs and compares the poses, writes the optional outputs, and returns the figures
/// with the per-frame evaluation behind them.
pub fn evaluate(args: &EvalConfig) -> Result<(EvalOutput, PoseEvaluation)> {
    let start = Instant::now();
    let (gt_format, gt) = read_poses(&args.gt, args.gt_format)?;
    let (est_format, est) = read_poses(&args.est, args.est_format)?;
    let time_keyed = |f: Format| matches!(f, Format::Tum | Format::RobotLog);
    let matching = match_frames(
        &gt,
        &args.gt,
        &est,
        &args.est,
        time_keyed(gt_format) || time_keyed(est_format),
        args.max_dt,
    )?;
    let gt_poses: Vec<_> = matching
        .pairs
        .iter()
        .map(|&(g, _)| gt.frames[g].pose)
        .collect();
    let est_poses: Vec<_> = matching
        .pairs
        .iter()
        .map(|&(_, e)| est.frames[e].pose)
        .collect();
    let ev = PoseEvaluation::of(&gt_poses, &est_poses)?;
    let coverage = if est_format == Format::Jsonl {
        let (_, cov) = data::jsonl::read_with_covariance(&args.est)?;
        let cov: Vec<_> = matching.pairs.iter().map(|&(_, e)| cov[e]).collect();
        coverage_of(&gt_poses, &est_poses, &cov)
    } else {
        None
    };

    if let Some(path) = &args.per_frame {
        write_per_frame(path, &matching.pairs, &est, &ev)?;
    }
    let gt_index: Vec<usize> = matching.pairs.iter().map(|&(g, _)| g).collect();
    let cuts = args.cuts.as_deref().map(data::cuts::read).transpose()?;
    let cut_split = cuts
        .as_deref()
        .map(|cuts| split_near_cuts(&ev, &gt_index, cuts, args.cut_window));

    let acc = |i: usize| ev.accuracy[i].fraction;
    let mut out = EvalOutput {
        frames: ev.pos_err_m.len(),
        median_pos_m: ev.position.median,
        median_rot_deg: ev.rotation_deg.median,
        mean_pos_m: ev.position.mean,
        mean_rot_deg: ev.rotation_deg.mean,
        rmse_pos_m: ev.position.rmse,
        rmse_rot_deg: ev.rotation_deg.rmse,
        max_pos_m: ev.position.max,
        max_rot_deg: ev.rotation_deg.max,
        acc_25cm_2deg: acc(0),
        acc_50cm_5deg: acc(1),
        acc_5m_10deg: acc(2),
        mae_xyz_m: ev.axes.mae.clone(),
        mse_xyz_m2: ev.axes.mse.clone(),
        rmse_xyz_m: ev.axes.rmse.clone(),
        jitter_m: ev.jitter_m,
        smoothness_est: ev.smoothness_est,
        smoothness_gt: ev.smoothness_gt,
        smoothness_diff: ev
            .smoothness_est
            .zip(ev.smoothness_gt)
            .map(|(e, g)| e.minus(&g)),
        matched_by: matching.by,
        gt_frames: gt.len(),
        est_frames: est.len(),
        unmatched_est: matching.unmatched_est,
        near_cuts: None,
        away_from_cuts: None,
        coverage,
        report: None,
        seconds: 0.0,
    };
    if let Some((near, away)) = cut_split {
        out.near_cuts = Some(near);
        out.away_from_cuts = Some(away);
    }
    if let Some(dir) = &args.report {
        let xy = |poses: &[geom::Pose]| -> Vec<[f64; 2]> {
            poses
                .iter()
                .map(|p| [p.translation.x, p.translation.y])
                .collect()
        };
        // Cuts are ground-truth frame numbers; the plots index matched frames.
        let cut_marks: Option<Vec<usize>> = cuts.as_deref().map(|cuts| {
            cuts.iter()
                .map(|&c| gt_index.partition_point(|&g| (g as u64) < c))
                .collect()
        });
        let mut extra = Vec::new();
        if let (Some(near), Some(away)) = (&out.near_cuts, &out.away_from_cuts) {
            extra.push(cut_table(near, away, args.cut_window));
        }
        let title = format!("{} vs {}", args.est.display(), args.gt.display());
        let path = report::pose_eval_report(
            dir,
            &title,
            &ev,
            &xy(&gt_poses),
            &xy(&est_poses),
            cut_marks.as_deref(),
            &extra,
        )
        .with_context(|| format!("writing the report into {}", dir.display()))?;
        out.report = Some(path);
    }
    out.seconds = start.elapsed().as_secs_f64();
    Ok((out, ev))
}

/// Coverage of the estimates' covariance regions, read as Gaussian, over the frames that carry
/// a covariance (`None` when none does). A covariance with no z variance is a floor position's
/// (a 3-DoF model's): its x, y block is read.
fn coverage_of(
    gt: &[geom::Pose],
    est: &[geom::Pose],
    cov: &[Option<[f64; 9]>],
) -> Option<UncertaintyFigures> {
    let (frames, sigma): (Vec<Standardised>, Vec<f64>) = gt
        .iter()
        .zip(est)
        .zip(cov)
        .filter_map(|((g, e), c)| {
            let c = nalgebra::Matrix3::from_row_slice(c.as_ref()?);
            let dims = if c[(2, 2)] > 0.0 { 3 } else { 2 };
            let s = Standardised::of(&(e.translation - g.translation), &c, dims)?;
            Some((s, c.trace().sqrt()))
        })
        .unzip();
    UncertaintyFigures::of(&frames, &sigma, None)
}

fn cut_table(near: &Subset, away: &Subset, window: u64) -> report::Table {
    let mut t = report::Table::new(
        format!("Frames within {window} frames after a scene cut, and the others"),
        [
            "frames",
            "count",
            "median position m",
            "median rotation °",
            "within 0.5 m, 5°",
        ],
    );
    let opt = |v: Option<f64>, digits: usize| v.map_or("-".into(), |v| format!("{v:.digits$}"));
    for (name, s) in [("near cuts", near), ("away from cuts", away)] {
        t.push_row([
            name.to_string(),
            s.frames.to_string(),
            opt(s.median_pos_m, 3),
            opt(s.median_rot_deg, 2),
            opt(s.acc_50cm_5deg.map(|a| a * 100.0), 1) + " %",
        ]);
    }
    t
}

fn write_per_frame(
    path: &Path,
    pairs: &[(usize, usize)],
    est: &data::Trajectory,
    ev: &PoseEvaluation,
) -> Result<()> {
    data::io::write_atomic(path, |w| {
        writeln!(w, "frame,pos_err_m,rot_err_deg")?;
        for (k, &(_, e)) in pairs.iter().enumerate() {
            writeln!(
                w,
                "{},{},{}",
                est.frames[e].name, ev.pos_err_m[k], ev.rot_err_deg[k]
            )?;
        }
        Ok(())
    })?;
    Ok(())
}

fn read_poses(path: &Path, format: Option<Format>) -> Result<(Format, data::Trajectory)> {
    let format = match format {
        Some(f) => f,
        None => formats::detect(path)?,
    };
    let traj =
        formats::read(path, Some(format)).with_context(|| format!("reading {format} poses"))?;
    Ok((format, traj))
}

/// Splits per-frame errors into frames at most `window` frames after a cut (by ground-truth
/// frame index) and the others.
fn split_near_cuts(
    ev: &PoseEvaluation,
    gt_index: &[usize],
    cuts: &[u64],
    window: u64,
) -> (Subset, Subset) {
    let near = |i: usize| {
        let i = i as u64;
        // cuts are sorted: the last cut at or before i decides.
        let k = cuts.partition_point(|&c| c <= i);
        k > 0 && i - cuts[k - 1] <= window
    };
    let (mut near_idx, mut away_idx) = (Vec::new(), Vec::new());
    for (k, &g) in gt_index.iter().enumerate() {
        if near(g) {
            near_idx.push(k)
        } else {
            away_idx.push(k)
        }
    }
    (subset(ev, &near_idx), subset(ev, &away_idx))
}

fn subset(ev: &PoseEvaluation, idx: &[usize]) -> Subset {
    let pos: Vec<f64> = idx.iter().map(|&i| ev.pos_err_m[i]).collect();
    let rot: Vec<f64> = idx.iter().map(|&i| ev.rot_err_deg[i]).collect();
    let p = geom::metrics::Stats::of(&pos).ok();
    let r = geom::metrics::Stats::of(&rot).ok();
    let acc = |k: usize| {
        (!pos.is_empty()).then(|| {
            let (m, d) = ACCURACY_THRESHOLDS[k];
            geom::metrics::accuracy(&pos, &rot, m, d)
        })
    };
    Subset {
        frames: idx.len(),
        median_pos_m: p.map(|s| s.median),
        median_rot_deg: r.map(|s| s.median),
        mean_pos_m: p.map(|s| s.mean),
        acc_25cm_2deg: acc(0),
        acc_50cm_5deg: acc(1),
        acc_5m_10deg: acc(2),
    }
}

fn human_text(o: &EvalOutput, ev: &PoseEvaluation, cut_window: u64) -> String {
    let mut text = format!(
        "{} frames paired by {} ({} ground truth, {} estimates, {} unpaired)\n\n",
        o.frames,
        match o.matched_by {
            MatchedBy::Name => "name",
            MatchedBy::Time => "time",
        },
        o.gt_frames,
        o.est_frames,
        o.unmatched_est
    );
    text.push_str(&report::pose_summary_table(ev).to_text());
    if let (Some(near), Some(away)) = (&o.near_cuts, &o.away_from_cuts) {
        text.push('\n');
        text.push_str(&cut_table(near, away, cut_window).to_text());
    }
    if let Some(c) = &o.coverage {
        text.push_str(&format!(
            "\ncovariance of {} frames: coverage of the 50 / 90 / 95 / 99 % regions {:.1} / \
             {:.1} / {:.1} / {:.1} %, NLL {:.2}, calibration error {:.3}, median sigma {:.3} m\n",
            c.frames,
            100.0 * c.coverage[0],
            100.0 * c.coverage[1],
            100.0 * c.coverage[2],
            100.0 * c.coverage[3],
            c.nll,
            c.ece,
            c.median_sigma_m
        ));
    }
    if let Some(path) = &o.report {
        text.push_str(&format!("\nreport: {}\n", path.display()));
    }
    text
}
