//! The cut walk's experiment, shared by `demo` (its report's cut table) and `study cuts`: a
//! held-out walk joined by hard cuts, localized, cuts detected by `scenecut`, and the temporal
//! filter (and a sequence model, when the folder has one) run with cuts not handled, reset at
//! the gold cuts and reset at the detected ones.
use super::evaluate::{self, FrameResult};
use super::scene;
use crate::Result;
use crate::progress::bar;
use data::native::NativeDataset;
use geom::Pose;
use learn::Task;
use learn::checkpoint::ModelMeta;
use learn::seq::{SeqLocalizer, SeqMeta};
use report::{HtmlReport, Series, Table};
use serde::Serialize;
use std::path::{Path, PathBuf};
use track::{FilterConfig, Measurement, PoseFilter};

/// One row of the table.
#[derive(Debug, Serialize)]
pub(crate) struct Row {
    /// `none`, `gold`, `detected` (the filter or the sequence model), or `network` (no temporal
    /// state).
    handling: &'static str,
    /// What produced the poses.
    model: &'static str,
    median_pos_m: f64,
    median_pos_m_after_cut: f64,
    median_pos_m_elsewhere: f64,
    mean_pos_m_after_cut: f64,
    median_rot_deg: f64,
    /// Times the filter or the sequence model started over (first frame, resets, the filter's
    /// give-ups after refusals).
    starts: usize,
}

/// What `study cuts` prints.
#[derive(Debug, Serialize)]
pub(crate) struct StudyOutput {
    pub(crate) rows: Vec<Row>,
    pub(crate) frames: usize,
    pub(crate) gold_cuts: Vec<u64>,
    pub(crate) detected_cuts: Vec<u64>,
    pub(crate) detection: scenecut::Score,
    pub(crate) frames_after_cut: usize,
    pub(crate) report: PathBuf,
}

/// Everything the cut experiment measured.
#[derive(Debug)]
pub(crate) struct CutFigures {
    pub(crate) rows: Vec<Row>,
    pub(crate) curves: Vec<Series>,
    pub(crate) frames: usize,
    pub(crate) frames_after_cut: usize,
    pub(crate) gold: Vec<u64>,
    pub(crate) detected: Vec<u64>,
    pub(crate) score: scenecut::Score,
    pub(crate) cut_window: u64,
}

impl CutFigures {
    /// Median position error after a cut of the filter with this handling.
    pub fn after_cut(&self, handling: &str) -> Option<f64> {
        self.rows
            .iter()
            .find(|r| r.handling == handling)
            .map(|r| r.median_pos_m_after_cut)
    }
}

/// Renders the cut walk of `plan` into `dir` (reused when there), localizes it with the model in
/// `model_dir`, detects its cuts and runs the filter the three ways plus the network alone.
pub(crate) fn measure(
    plan: &scene::ScenePlan,
    model_dir: &Path,
    dir: &Path,
    segments: usize,
    cut_window: u64,
    mc: usize,
) -> Result<CutFigures> {
    let pb = bar((segments * 50) as u64, "render");
    let gold = scene::render_cut_walk(plan, dir, segments, [40, 60], &|n| {
        pb.set_position(n as u64)
    })?;
    pb.finish_and_clear();
    let ds = NativeDataset::open(dir)?;
    let results = evaluate::localize_test(&ds, model_dir, mc, true, plan.train_mode()?)?;
    let detection = scenecut::detect_input(
        dir,
        &scenecut::Config::default(),
        Default::default(),
        &mut |_, _| {},
    )?;
    let detected = detection.cut_frames();
    let errors = Errors {
        ds: &ds,
        pose3: ModelMeta::read(model_dir)?.coding.task == Task::Pose3,
    };
    let near: Vec<bool> = results
        .iter()
        .map(|r| after_cut(r.index as u64, &gold, cut_window))
        .collect();
    let network: Vec<(f64, f64)> = results
        .iter()
        .map(|r| (r.pos_err_m, r.rot_err_deg))
        .collect();
    let mut rows = vec![row("network", "single-frame network", &network, &near, 0)];
    let mut curves = vec![Series::new(
        "network",
        network.iter().map(|e| e.0).collect::<Vec<_>>(),
    )];
    for (handling, resets) in [
        ("none", &[][..]),
        ("gold", &gold[..]),
        ("detected", &detected[..]),
    ] {
        let (errs, starts) = filtered(&results, &errors, resets);
        curves.push(Series::new(
            format!("filter, cuts {handling}"),
            errs.iter().map(|e| e.0).collect::<Vec<_>>(),
        ));
        rows.push(row(handling, "network + filter", &errs, &near, starts));
    }
    if SeqMeta::exists(model_dir) {
        let seq = SeqLocalizer::load(model_dir)?;
        let index: Vec<usize> = results.iter().map(|r| r.index).collect();
        let views = evaluate::views_of(&ds, &index, seq.base(), plan.train_mode()?)?;
        let keys: Vec<(&str, u64)> = index
            .iter()
            .map(|&i| (ds.trajectory.frames[i].seq.as_str(), i as u64))
            .collect();
        let task = seq.base().meta().coding.task;
        for (handling, resets) in [
            ("none", &[][..]),
            ("gold", &gold[..]),
            ("detected", &detected[..]),
        ] {
            let runs = learn::window::runs(&keys, resets);
            let estimates = seq.predict_runs(&views, &runs, mc)?;
            let errs: Vec<(f64, f64)> = evaluate::frame_results(&ds, &index, estimates, task)
                .iter()
                .map(|r| (r.pos_err_m, r.rot_err_deg))
                .collect();
            curves.push(Series::new(
                format!("sequence, cuts {handling}"),
                errs.iter().map(|e| e.0).collect::<Vec<_>>(),
            ));
            rows.push(row(handling, "sequence model", &errs, &near, runs.len()));
        }
    }
    let score = scenecut::score_hard(
        &detected,
        &scenecut::Gold {
            hard_cuts: gold.clone(),
            gradual: Vec::new(),
        },
        2,
    );
    Ok(CutFigures {
        rows,
        curves,
        frames: results.len(),
        frames_after_cut: near.iter().filter(|&&n| n).count(),
        gold,
        detected,
        score,
        cut_window,
    })
}

/// Whether `frame` is a cut frame or at most `window` frames after one.
fn after_cut(frame: u64, cuts: &[u64], window: u64) -> bool {
    cuts.iter().any(|&c| frame >= c && frame <= c + window)
}

/// The dataset's frame times and the error measure of the model's task.
struct Errors<'a> {
    ds: &'a NativeDataset,
    pose3: bool,
}

impl Errors<'_> {
    /// Errors of `pose` against frame `r`'s ground truth, as the demo measures them.
    fn of(&self, r: &FrameResult, pose: &Pose) -> (f64, f64) {
        evaluate::pose_errors(&r.truth, pose, self.pose3, self.ds.info.mount)
    }
}

/// The frames through the filter, reset at `resets`; per-frame errors and the number of starts.
fn filtered(
    results: &[FrameResult],
    errors: &Errors<'_>,
    resets: &[u64],
) -> (Vec<(f64, f64)>, usize) {
    let mut filter = PoseFilter::new(FilterConfig::default());
    let mut starts = 0;
    let mut out = Vec::with_capacity(results.len());
    for r in results {
        if resets.binary_search(&(r.index as u64)).is_ok() {
            filter.reset();
        }
        let t = errors.ds.trajectory.frames[r.index]
            .t
            .unwrap_or(r.index as f64 / errors.ds.info.frame_rate.max(1.0));
        let fused = filter.push(&Measurement {
            t,
            pose: r.estimate.pose,
            cov_pos_m2: r.estimate.cov_pos_m2,
            sigma_rot_rad: r.estimate.sigma_rot_deg.to_radians(),
        });
        if fused.update == track::Update::Started {
            starts += 1;
        }
        out.push(errors.of(r, &fused.pose));
    }
    (out, starts)
}

fn median(v: impl Iterator<Item = f64>) -> f64 {
    crate::output::median(&v.collect::<Vec<_>>())
}

fn row(
    handling: &'static str,
    model: &'static str,
    errs: &[(f64, f64)],
    near: &[bool],
    starts: usize,
) -> Row {
    let after: Vec<f64> = errs
        .iter()
        .zip(near)
        .filter(|(_, n)| **n)
        .map(|(e, _)| e.0)
        .collect();
    Row {
        handling,
        model,
        median_pos_m: median(errs.iter().map(|e| e.0)),
        median_pos_m_after_cut: median(after.iter().copied()),
        median_pos_m_elsewhere: median(
            errs.iter()
                .zip(near)
                .filter(|(_, n)| !**n)
                .map(|(e, _)| e.0),
        ),
        mean_pos_m_after_cut: after.iter().sum::<f64>() / after.len().max(1) as f64,
        median_rot_deg: median(errs.iter().map(|e| e.1)),
        starts,
    }
}

fn table(rows: &[Row]) -> Table {
    let mut t = Table::new(
        "Scene cuts and the temporal filter",
        [
            "handling",
            "poses from",
            "median (m)",
            "median after cut (m)",
            "mean after cut (m)",
            "median elsewhere (m)",
            "median rot (°)",
            "starts",
        ],
    );
    for r in rows {
        t.push_row([
            r.handling.to_string(),
            r.model.to_string(),
            format!("{:.3}", r.median_pos_m),
            format!("{:.3}", r.median_pos_m_after_cut),
            format!("{:.3}", r.mean_pos_m_after_cut),
            format!("{:.3}", r.median_pos_m_elsewhere),
            format!("{:.2}", r.median_rot_deg),
            r.starts.to_string(),
        ]);
    }
    t
}

pub(crate) fn text(o: &StudyOutput) -> String {
    format!(
        "{}\n{} frames, {} within the cut window; gold cuts {:?}\ndetected cuts {:?} (P {:.2} R {:.2} F1 {:.2})\nreport: {}\n",
        table(&o.rows).to_text(),
        o.frames,
        o.frames_after_cut,
        o.gold_cuts,
        o.detected_cuts,
        o.detection.precision,
        o.detection.recall,
        o.detection.f1,
        o.report.display()
    )
}

/// The experiment as a report section: the table, the detection score and the errors along
/// the walk with the gold cuts marked.
pub(crate) fn section(page: &mut HtmlReport, f: &CutFigures) -> Result<()> {
    page.section("Scene cuts: errors just after a cut and elsewhere");
    page.paragraph(format!(
        "A held-out walk through the same zone, joined by hard cuts to other places ({} frames, \
         {} of them a cut frame or within {} frames after one). The network localizes every \
         frame; a constant-velocity filter with outlier gating smooths them, with cuts not \
         handled, reset at the gold cuts, and reset at the cuts scenecut detects.",
        f.frames, f.frames_after_cut, f.cut_window
    ));
    page.table(&table(&f.rows));
    page.paragraph(format!(
        "Gold cuts {:?}; detected {:?}: precision {:.2}, recall {:.2}, F1 {:.2} (±2 frames).",
        f.gold, f.detected, f.score.precision, f.score.recall, f.score.f1
    ));
    let markers: Vec<usize> = f.gold.iter().map(|&c| c as usize).collect();
    let fig = report::error_over_time("Position error per frame", &f.curves, &[], Some(&markers));
    page.figure(&fig, "Vertical lines: gold cuts.")?;
    Ok(())
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn the_cut_window_counts_the_cut_frame_and_the_next_ones() {
        let cuts = [10, 50];
        let near: Vec<u64> = (0..70).filter(|&f| after_cut(f, &cuts, 3)).collect();
        assert_eq!(near, vec![10, 11, 12, 13, 50, 51, 52, 53]);
        assert!(!after_cut(5, &[], 10));
    }

    #[test]
    fn rows_split_errors_after_cuts_from_the_rest() {
        let errs = [(1.0, 1.0), (9.0, 2.0), (8.0, 3.0), (2.0, 4.0), (3.0, 5.0)];
        let near = [false, true, true, false, false];
        let r = row("gold", "network + filter", &errs, &near, 2);
        assert_eq!(r.median_pos_m_after_cut, 8.5);
        assert_eq!(r.mean_pos_m_after_cut, 8.5);
        assert_eq!(r.median_pos_m_elsewhere, 2.0);
        assert_eq!(r.median_pos_m, 3.0);
        assert_eq!(r.median_rot_deg, 3.0);
        assert_eq!(r.starts, 2);
    }
}
