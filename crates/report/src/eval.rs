//! The report of `indoorloc eval`: summary table, figures and one HTML page.

use crate::cdf::ErrorCdf;
use crate::chart::fmt_sig;
use crate::error::{ReportError, Result};
use crate::figure::Figure;
use crate::html::HtmlReport;
use crate::over_time::ErrorOverTime;
use crate::series::{Series, Track};
use crate::table::Table;
use crate::top_down::TopDown;
use geom::metrics::{PoseEvaluation, Smoothness};
use std::path::{Path, PathBuf};

fn metres(v: f64) -> String {
    format!("{v:.3} m")
}

fn degrees(v: f64) -> String {
    format!("{v:.2}°")
}

fn percent(fraction: f64) -> String {
    format!("{:.1} %", 100.0 * fraction)
}

fn steps(s: Option<&Smoothness>) -> (String, String) {
    match s {
        Some(s) => (
            format!("{:.3} ± {:.3} m", s.mean_step_m, s.std_step_m),
            format!("{:.2} ± {:.2}°", s.mean_step_deg, s.std_step_deg),
        ),
        None => ("–".into(), "–".into()),
    }
}

/// The headline figures of a pose evaluation as a two-column table (metric, value): frame
/// count, position and rotation error statistics, accuracy at each threshold pair (percent),
/// per-axis MAE and RMSE, and the frame-to-frame steps of ground truth and estimate. The same
/// table serves the terminal ([`Table::to_text`]) and the HTML report.
pub fn pose_summary_table(ev: &PoseEvaluation) -> Table {
    let (p, r) = (&ev.position, &ev.rotation_deg);
    let mut t = Table::new("Summary", ["metric", "value"]);
    t.push_row(["frames".to_string(), p.count.to_string()]);
    t.push_row(["median position error".into(), metres(p.median)]);
    t.push_row(["mean position error".into(), metres(p.mean)]);
    t.push_row(["RMSE position error".into(), metres(p.rmse)]);
    t.push_row(["90th percentile position error".into(), metres(p.p90)]);
    t.push_row(["max position error".into(), metres(p.max)]);
    t.push_row(["median rotation error".into(), degrees(r.median)]);
    t.push_row(["mean rotation error".into(), degrees(r.mean)]);
    t.push_row(["90th percentile rotation error".into(), degrees(r.p90)]);
    for a in &ev.accuracy {
        t.push_row([
            format!("accuracy ({} m, {}°)", fmt_sig(a.max_m), fmt_sig(a.max_deg)),
            percent(a.fraction),
        ]);
    }
    let axes = |v: &[f64]| {
        let parts: Vec<String> = v.iter().map(|x| format!("{x:.3}")).collect();
        format!("{} m", parts.join(" / "))
    };
    let names = ["x", "y", "z"];
    let axis_names = names[..ev.axes.mae.len().min(3)].join(" / ");
    t.push_row([format!("MAE {axis_names}"), axes(&ev.axes.mae)]);
    t.push_row([format!("RMSE {axis_names}"), axes(&ev.axes.rmse)]);
    let (gt_m, gt_deg) = steps(ev.smoothness_gt.as_ref());
    let (est_m, est_deg) = steps(ev.smoothness_est.as_ref());
    t.push_row(["step length, ground truth".into(), gt_m]);
    t.push_row(["step length, estimate".into(), est_m]);
    t.push_row(["step rotation, ground truth".into(), gt_deg]);
    t.push_row(["step rotation, estimate".into(), est_deg]);
    t.push_row(["position error jitter".into(), metres(ev.jitter_m)]);
    t
}

/// Writes the report of one pose evaluation into `dir` (created if missing) and returns the path
/// of `report.html`.
///
/// Files written: `report.html` (self-contained, figures inline), `cdf.png`/`cdf.svg`,
/// `errors_over_time.png`/`errors_over_time.svg`, `trajectory.png`/`trajectory.svg`.
/// `gt_xy` and `est_xy` are the matched camera centres (`gt_xy[i]` belongs with `est_xy[i]` and
/// with `ev.pos_err_m[i]`); `cuts` are frame indices into the same lists (first frame of each new
/// scene), drawn as vertical lines; `extra_tables` go into a "Details" section.
///
/// Long inputs are decimated for drawing (see [`ErrorCdf`], [`ErrorOverTime`], [`TopDown`]); the
/// statistics come from `ev` and use every frame.
pub fn pose_eval_report(
    dir: &Path,
    title: &str,
    ev: &PoseEvaluation,
    gt_xy: &[[f64; 2]],
    est_xy: &[[f64; 2]],
    cuts: Option<&[usize]>,
    extra_tables: &[Table],
) -> Result<PathBuf> {
    let n = ev.pos_err_m.len();
    if n == 0 {
        return Err(ReportError::BadInput(
            "evaluation report: no matched frames".into(),
        ));
    }
    if gt_xy.len() != est_xy.len() || gt_xy.len() != n {
        return Err(ReportError::BadInput(format!(
            "evaluation report: {} errors, {} ground-truth and {} estimated positions",
            n,
            gt_xy.len(),
            est_xy.len()
        )));
    }
    std::fs::create_dir_all(dir).map_err(|source| ReportError::Io {
        path: dir.to_path_buf(),
        source,
    })?;

    let mut thresholds_m: Vec<f64> = ev.accuracy.iter().map(|a| a.max_m).collect();
    let mut thresholds_deg: Vec<f64> = ev.accuracy.iter().map(|a| a.max_deg).collect();
    thresholds_m.dedup();
    thresholds_deg.dedup();
    let pos = vec![Series::new("estimate", ev.pos_err_m.clone())];
    let rot = vec![Series::new("estimate", ev.rot_err_deg.clone())];
    let cuts = cuts.unwrap_or(&[]);
    let figures: [(&str, Figure, String); 3] = [
        (
            "cdf",
            ErrorCdf {
                title: "Cumulative error distribution".into(),
                position_m: pos.clone(),
                rotation_deg: rot.clone(),
                thresholds_m,
                thresholds_deg,
            }
            .into(),
            "Share of frames whose error is at most the value on the x axis; dashed lines mark \
             the accuracy thresholds."
                .into(),
        ),
        (
            "errors_over_time",
            ErrorOverTime {
                title: "Errors over time".into(),
                position_m: pos,
                rotation_deg: rot,
                markers: cuts.to_vec(),
                marker_label: "scene cut".into(),
            }
            .into(),
            if cuts.is_empty() {
                "Per-frame errors against frame index.".to_string()
            } else {
                format!(
                    "Per-frame errors against frame index; vertical lines mark the {} scene cuts.",
                    cuts.len()
                )
            },
        ),
        (
            "trajectory",
            TopDown {
                title: "Trajectory, top view".into(),
                ground_truth: gt_xy.to_vec(),
                estimates: vec![Track::new("estimate", est_xy.to_vec())],
                links: true,
            }
            .into(),
            "Camera centres seen from above, same scale on both axes; thin red lines join \
             ground-truth positions to their estimates."
                .into(),
        ),
    ];
    // the three figures are independent: draw them at once
    let rendered: Vec<Result<(String, PathBuf, PathBuf)>> = std::thread::scope(|s| {
        let handles: Vec<_> = figures
            .iter()
            .map(|(stem, fig, _)| s.spawn(move || fig.save_both(dir, stem)))
            .collect();
        handles
            .into_iter()
            .map(|h| {
                h.join().unwrap_or_else(|_| {
                    Err(ReportError::BadInput("a figure thread panicked".into()))
                })
            })
            .collect()
    });

    let summary = pose_summary_table(ev);
    let mut report = HtmlReport::new(title);
    report.subtitle(format!(
        "Pose evaluation of {n} matched frames{}",
        if cuts.is_empty() {
            String::new()
        } else {
            format!(", {} scene cuts", cuts.len())
        }
    ));
    let acc = ev
        .accuracy
        .iter()
        .find(|a| a.max_m == 0.5 && a.max_deg == 5.0)
        .or(ev.accuracy.first());
    let mut cards = vec![
        ("frames".to_string(), n.to_string()),
        ("median position error".into(), metres(ev.position.median)),
        (
            "median rotation error".into(),
            degrees(ev.rotation_deg.median),
        ),
    ];
    if let Some(a) = acc {
        cards.push((
            format!("within {} m and {}°", fmt_sig(a.max_m), fmt_sig(a.max_deg)),
            percent(a.fraction),
        ));
    }
    report.section("Summary").highlights(cards).table(&summary);
    let headings = [
        "Error distribution",
        "Errors over time",
        "Trajectory, top view",
    ];
    let mut files = vec!["report.html".to_string()];
    for ((heading, (_, _, caption)), r) in headings.iter().zip(&figures).zip(rendered) {
        let (svg, png_path, svg_path) = r?;
        report.section(*heading).svg(svg, caption.as_str());
        for p in [png_path, svg_path] {
            if let Some(name) = p.file_name() {
                files.push(name.to_string_lossy().into_owned());
            }
        }
    }
    if !extra_tables.is_empty() {
        report.section("Details");
        for t in extra_tables {
            report.table(t);
        }
    }
    report
        .section("Files")
        .paragraph("Written next to this page (figures as PNG and SVG):")
        .preformatted(files.join("\n"));
    let path = dir.join("report.html");
    report.write(&path)?;
    Ok(path)
}

#[cfg(test)]
mod tests {
    use super::*;
    use geom::Pose;

    type Walk = (PoseEvaluation, Vec<[f64; 2]>, Vec<[f64; 2]>);

    fn walk(n: usize) -> Result<Walk, geom::GeomError> {
        let mut gt = Vec::with_capacity(n);
        let mut est = Vec::with_capacity(n);
        for i in 0..n {
            let t = i as f64 * 0.05;
            let (x, y) = (5.0 * t.cos() + 0.3 * t, 3.0 * (0.7 * t).sin());
            gt.push(Pose::from_euler_ypr(0.1 * t, 0.0, 0.0, [x, y, 1.5])?);
            let e = 0.2 * (1.3 * t).sin();
            est.push(Pose::from_euler_ypr(
                0.1 * t + 0.02 * e,
                0.0,
                0.0,
                [x + e, y - 0.5 * e, 1.5],
            )?);
        }
        let ev = PoseEvaluation::of(&gt, &est)?;
        let xy = |p: &[Pose]| {
            p.iter()
                .map(|p| [p.translation.x, p.translation.y])
                .collect()
        };
        Ok((ev, xy(&gt), xy(&est)))
    }

    #[test]
    fn summary_table_has_the_headline_rows() -> Result<(), Box<dyn std::error::Error>> {
        let (ev, _, _) = walk(50)?;
        let text = pose_summary_table(&ev).to_text();
        for key in [
            "frames",
            "median position error",
            "RMSE position error",
            "accuracy (0.25 m, 2°)",
            "accuracy (0.5 m, 5°)",
            "accuracy (5 m, 10°)",
            "MAE x / y / z",
            "step length, ground truth",
        ] {
            assert!(text.contains(key), "missing {key} in\n{text}");
        }
        Ok(())
    }

    #[test]
    fn writes_every_file() -> Result<(), Box<dyn std::error::Error>> {
        let (ev, gt, est) = walk(500)?;
        let dir = tempfile::tempdir()?;
        let out = dir.path().join("nested/report");
        let extra = Table::new("Inputs", ["gt", "est"]);
        let path = pose_eval_report(&out, "Eval", &ev, &gt, &est, Some(&[100, 300]), &[extra])?;
        assert_eq!(path, out.join("report.html"));
        for f in ["cdf", "errors_over_time", "trajectory"] {
            let png = image::open(out.join(format!("{f}.png")))?;
            assert!(png.width() >= 760 && png.height() >= 400);
            let svg = std::fs::read_to_string(out.join(format!("{f}.svg")))?;
            assert!(svg.contains("estimate"));
        }
        let html = std::fs::read_to_string(&path)?;
        assert_eq!(html.matches("<svg").count(), 3);
        assert!(html.contains("scene cut") && html.contains("Inputs"));
        Ok(())
    }

    #[test]
    fn bad_input_is_an_error() -> Result<(), Box<dyn std::error::Error>> {
        let (ev, gt, est) = walk(10)?;
        let dir = tempfile::tempdir()?;
        let r = pose_eval_report(dir.path(), "t", &ev, &gt[..5], &est, None, &[]);
        assert!(matches!(r, Err(ReportError::BadInput(_))));
        let mut empty = ev.clone();
        empty.pos_err_m.clear();
        let r = pose_eval_report(dir.path(), "t", &empty, &[], &[], None, &[]);
        assert!(matches!(r, Err(ReportError::BadInput(_))));
        Ok(())
    }
}
