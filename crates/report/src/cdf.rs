//! Cumulative distributions of position and rotation errors ([`ErrorCdf`]): the figure's
//! description, its checks and thinning into a [`CdfPlot`], and its drawing.

use crate::chart::{Curve, DrawResult, Panel, draw_panel, fmt_sig, left_out, sep, titled};
use crate::decimate::{cdf_points, clip_x};
use crate::error::{ReportError, Result};
use crate::series::Series;
use geom::metrics::percentile_sorted;
use plotters::coord::Shift;
use plotters::prelude::*;
use serde::{Deserialize, Serialize};

/// Cumulative distributions of position and rotation errors, side by side, one curve per series.
///
/// Decimation: each curve is drawn through at most 2000 evenly spaced quantiles
/// (exact steps below that). When the largest error is far beyond the 99th percentile, the x axis
/// stops a little past the 99th percentile (the axis title says so) so the bulk stays readable.
#[derive(Clone, Debug, Default, PartialEq, Serialize, Deserialize)]
pub struct ErrorCdf {
    /// Figure title.
    pub title: String,
    /// Position errors per method, metres (an empty list leaves out the panel).
    pub position_m: Vec<Series>,
    /// Rotation errors per method, degrees (an empty list leaves out the panel).
    pub rotation_deg: Vec<Series>,
    /// Dashed reference lines on the position panel, metres (e.g. accuracy thresholds).
    pub thresholds_m: Vec<f64>,
    /// Dashed reference lines on the rotation panel, degrees.
    pub thresholds_deg: Vec<f64>,
}

pub(crate) struct CdfPlot {
    pub(crate) title: String,
    pub(crate) panels: Vec<Panel>,
}

/// Sorted finite values of a series and how many were left out; an error when none is finite.
fn finite_sorted(s: &Series, what: &str) -> Result<(Vec<f64>, usize)> {
    let mut v: Vec<f64> = s.values.iter().copied().filter(|x| x.is_finite()).collect();
    if v.is_empty() {
        return Err(ReportError::BadInput(format!(
            "{what} series '{}' has no finite values ({} values)",
            s.name,
            s.values.len()
        )));
    }
    let dropped = s.values.len() - v.len();
    v.sort_unstable_by(f64::total_cmp);
    Ok((v, dropped))
}

pub(crate) fn prepare_cdf(f: &ErrorCdf) -> Result<CdfPlot> {
    if f.position_m.is_empty() && f.rotation_deg.is_empty() {
        return Err(ReportError::BadInput(format!(
            "error CDF '{}': no series to plot",
            f.title
        )));
    }
    let mut panels = Vec::new();
    let kinds = [
        ("position error", "m", &f.position_m, &f.thresholds_m),
        ("rotation error", "°", &f.rotation_deg, &f.thresholds_deg),
    ];
    for (what, unit, series, thresholds) in kinds {
        if series.is_empty() {
            continue;
        }
        let sorted: Vec<(Vec<f64>, usize)> = series
            .iter()
            .map(|s| finite_sorted(s, what))
            .collect::<Result<_>>()?;
        let p99 = sorted
            .iter()
            .map(|(v, _)| percentile_sorted(v, 99.0))
            .fold(0.0, f64::max);
        let max = sorted
            .iter()
            .map(|(v, _)| v[v.len() - 1])
            .fold(0.0, f64::max);
        // a few huge outliers would squeeze the interesting part into the left edge
        let clipped = p99 > 0.0 && max > 1.5 * p99;
        let mut x_max = if clipped { 1.15 * p99 } else { 1.03 * max };
        if x_max.partial_cmp(&0.0) != Some(std::cmp::Ordering::Greater) {
            x_max = 1.0;
        }
        let unit_label = if unit == "°" { "deg" } else { unit };
        let curves = series
            .iter()
            .zip(&sorted)
            .map(|(s, (v, dropped))| {
                let pts: Vec<(f64, f64)> = cdf_points(v)
                    .into_iter()
                    .map(|(x, y)| (x, 100.0 * y))
                    .collect();
                Curve {
                    label: format!(
                        "{}  (median {}{}{}{})",
                        s.name,
                        fmt_sig(percentile_sorted(v, 50.0)),
                        sep(unit),
                        unit,
                        left_out(*dropped)
                    ),
                    segments: vec![clip_x(&pts, x_max)],
                    band: Vec::new(),
                }
            })
            .collect();
        let x_desc = if clipped {
            format!("{what} ({unit_label}), axis cut past the 99th percentile")
        } else {
            format!("{what} ({unit_label})")
        };
        panels.push(Panel {
            x_desc,
            y_desc: "frames within error (%)".into(),
            x_range: (0.0, x_max),
            y_range: (0.0, 100.0),
            curves,
            thresholds: thresholds
                .iter()
                .filter(|t| t.is_finite() && **t > 0.0 && **t < x_max)
                .map(|t| (*t, format!("{}{}{}", fmt_sig(*t), sep(unit), unit)))
                .collect(),
        });
    }
    Ok(CdfPlot {
        title: f.title.clone(),
        panels,
    })
}

pub(crate) fn draw_cdf<DB: DrawingBackend>(
    root: &DrawingArea<DB, Shift>,
    p: &CdfPlot,
    bitmap: bool,
) -> DrawResult
where
    DB::ErrorType: 'static,
{
    let area = titled(root, &p.title)?;
    let cells = area.split_evenly((1, p.panels.len().max(1)));
    for (cell, panel) in cells.iter().zip(&p.panels) {
        // curves climb to the upper left: the lower right is free for the legend
        let legend_at = Some(SeriesLabelPosition::LowerRight);
        draw_panel(cell, panel, legend_at, &[], (2, bitmap))?;
    }
    Ok(())
}
