//! The held-out walk's results: each test frame's estimate and errors, the headline figures
//! (medians, accuracy, the summary table) and what sigma says about the errors; shared by the
//! demo, its report, its cut walk and the studies.

use super::scene;
use crate::{Context, Result};
use data::native::{NativeDataset, SplitName};
use geom::metrics::{Pose3Evaluation, PoseEvaluation, pearson};
use geom::{Mount, Pose, Pose3};
use learn::{Estimate, Localizer, Task};
use rayon::prelude::*;
use serde::Serialize;
use std::path::Path;
use synth::render::RenderMode;

/// One test frame's result.
#[derive(Clone, Debug)]
pub struct FrameResult {
    /// Index into the dataset's frames.
    pub index: usize,
    /// Ground truth.
    pub truth: Pose,
    /// The estimate with its uncertainty.
    pub estimate: Estimate,
    /// Position error, metres (planar for the ceiling camera).
    pub pos_err_m: f64,
    /// Rotation error, degrees (heading error for the ceiling camera).
    pub rot_err_deg: f64,
}

/// What uncertainty says about error.
#[derive(Clone, Copy, Debug, Serialize)]
pub struct UncertaintyFigures {
    /// Pearson R between `sigma_pos_m` and the position error.
    pub pearson_r: f64,
    /// Median error of the 10 % of frames with the largest sigma, metres.
    pub top10_median_m: f64,
    /// Median error of the other 90 %, metres.
    pub rest_median_m: f64,
}

impl UncertaintyFigures {
    pub(crate) fn of(results: &[FrameResult]) -> Result<UncertaintyFigures> {
        let sigma: Vec<f64> = results.iter().map(|r| r.estimate.sigma_pos_m).collect();
        let err: Vec<f64> = results.iter().map(|r| r.pos_err_m).collect();
        let mut order: Vec<usize> = (0..results.len()).collect();
        order.sort_by(|&a, &b| sigma[b].total_cmp(&sigma[a]));
        let top = (results.len() / 10).max(1);
        let pick =
            |idx: &[usize]| crate::output::median(&idx.iter().map(|&i| err[i]).collect::<Vec<_>>());
        Ok(UncertaintyFigures {
            pearson_r: pearson(&sigma, &err).context("uncertainty against error")?,
            top10_median_m: pick(&order[..top]),
            rest_median_m: pick(&order[top..]),
        })
    }
}

/// The test walk's frames through the model, with errors.
/// `photo_as`: the render mode the model was trained on (see [`scene::photo_as`]).
pub(crate) fn localize_test(
    ds: &NativeDataset,
    model_dir: &Path,
    mc: usize,
    tta: bool,
    photo_as: RenderMode,
) -> Result<Vec<FrameResult>> {
    let loc = Localizer::load(model_dir)?.with_tta(tta);
    let index = ds.split_frames(SplitName::Test);
    let views = views_of(ds, &index, &loc, photo_as)?;
    let estimates = loc.predict_batch(&views, mc)?;
    Ok(frame_results(ds, &index, estimates, loc.meta().coding.task))
}

/// The model's views of the dataset's frames `index` (decoded in parallel), each frame first
/// turned into what a model trained on `photo_as` renders sees ([`scene::photo_as`]).
pub(crate) fn views_of(
    ds: &NativeDataset,
    index: &[usize],
    loc: &Localizer,
    photo_as: RenderMode,
) -> Result<Vec<imgproc::view::View>> {
    index
        .par_iter()
        .map(|&i| {
            let path = ds.frame_path(ds.frame_number(i).unwrap_or(i as u64));
            let img = scene::photo_as(data::frames::decode_image(&path)?, photo_as)?;
            loc.view(&img)
                .with_context(|| format!("{}: cannot make the view", path.display()))
        })
        .collect()
}

/// Estimates of the dataset's frames `index` with their errors, measured for `task`.
pub(crate) fn frame_results(
    ds: &NativeDataset,
    index: &[usize],
    estimates: Vec<Estimate>,
    task: Task,
) -> Vec<FrameResult> {
    let pose3 = task == Task::Pose3;
    let mount = ds.info.mount;
    index
        .iter()
        .zip(estimates)
        .map(|(&i, estimate)| {
            let truth = ds.trajectory.frames[i].pose;
            let (pos_err_m, rot_err_deg) = pose_errors(&truth, &estimate.pose, pose3, mount);
            FrameResult {
                index: i,
                truth,
                estimate,
                pos_err_m,
                rot_err_deg,
            }
        })
        .collect()
}

/// Position (m) and rotation (°) error of `estimate` against `truth`; for a 3-DoF model
/// (`pose3`) the planar position error and the heading error.
pub(crate) fn pose_errors(truth: &Pose, estimate: &Pose, pose3: bool, mount: Mount) -> (f64, f64) {
    if pose3 {
        let (g, e): (Pose3, Pose3) = (truth.to_pose3(mount), estimate.to_pose3(mount));
        (
            (g.x - e.x).hypot(g.y - e.y),
            geom::metrics::heading_error(g.heading, e.heading).to_degrees(),
        )
    } else {
        (
            geom::metrics::position_error(truth, estimate),
            geom::metrics::rotation_error_deg(truth, estimate),
        )
    }
}

/// The headline figures of the test walk, for either task.
pub struct Evaluation {
    /// Median position error, metres.
    pub pos_median: f64,
    /// Mean position error, metres.
    pub pos_mean: f64,
    /// Median rotation (heading) error, degrees.
    pub rot_median: f64,
    /// `(max_m, max_deg, fraction)` per accuracy threshold.
    pub accuracy: Vec<(f64, f64, f64)>,
    /// The summary table.
    pub table: report::Table,
}

impl Evaluation {
    pub(crate) fn of(results: &[FrameResult], task: Task) -> Result<Evaluation> {
        let truth: Vec<Pose> = results.iter().map(|r| r.truth).collect();
        let est: Vec<Pose> = results.iter().map(|r| r.estimate.pose).collect();
        if task == Task::Pose3 {
            let mount = geom::Mount::Ceiling;
            let g: Vec<Pose3> = truth.iter().map(|p| p.to_pose3(mount)).collect();
            let e: Vec<Pose3> = est.iter().map(|p| p.to_pose3(mount)).collect();
            let ev = Pose3Evaluation::of(&g, &e)?;
            let mut table = report::Table::new("Test walk (x, y, heading)", ["metric", "value"]);
            table.push_row(["frames".to_string(), ev.position.count.to_string()]);
            table.push_row([
                "median position error".into(),
                format!("{:.3} m", ev.position.median),
            ]);
            table.push_row([
                "mean position error".into(),
                format!("{:.3} m", ev.position.mean),
            ]);
            table.push_row([
                "RMSE position error".into(),
                format!("{:.3} m", ev.position.rmse),
            ]);
            table.push_row([
                "median heading error".into(),
                format!(
                    "{:.2}° ({:.3} rad)",
                    ev.heading_deg.median,
                    ev.heading_deg.median.to_radians()
                ),
            ]);
            table.push_row([
                "mean heading error".into(),
                format!("{:.2}°", ev.heading_deg.mean),
            ]);
            for a in &ev.accuracy {
                table.push_row([
                    format!("accuracy ({} m, {}°)", a.max_m, a.max_deg),
                    format!("{:.1} %", 100.0 * a.fraction),
                ]);
            }
            Ok(Evaluation {
                pos_median: ev.position.median,
                pos_mean: ev.position.mean,
                rot_median: ev.heading_deg.median,
                accuracy: ev
                    .accuracy
                    .iter()
                    .map(|a| (a.max_m, a.max_deg, a.fraction))
                    .collect(),
                table,
            })
        } else {
            let ev = PoseEvaluation::of(&truth, &est)?;
            Ok(Evaluation {
                pos_median: ev.position.median,
                pos_mean: ev.position.mean,
                rot_median: ev.rotation_deg.median,
                accuracy: ev
                    .accuracy
                    .iter()
                    .map(|a| (a.max_m, a.max_deg, a.fraction))
                    .collect(),
                table: report::pose_summary_table(&ev),
            })
        }
    }
}
