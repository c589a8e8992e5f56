//! Errors against frame index ([`ErrorOverTime`]): the figure's description, its checks and
//! thinning into a [`TimePlot`], and its drawing.

use crate::chart::{
    Curve, DrawResult, Glyph, MARKER, PALETTE, Panel, draw_panel, fmt_sig, left_out, legend_strip,
    sep, titled,
};
use crate::decimate::{MAX_TIME_BUCKETS, MEDIAN_BUCKETS, bucket_medians, envelope, quantile_range};
use crate::error::{ReportError, Result};
use crate::series::Series;
use plotters::coord::Shift;
use plotters::prelude::*;
use serde::{Deserialize, Serialize};

/// Per-frame position and rotation errors against frame index, two stacked panels, with optional
/// vertical markers (scene cuts).
///
/// Decimation: a series longer than 2 × 1200 frames is drawn as a light band through the minimum
/// and maximum of each of 1200 frame buckets (about one per pixel column, so every spike stays
/// visible) under a line through the medians of 300 buckets. When rare spikes exceed twice the
/// 99th percentile, the y axis stops at 1.3 × that percentile and the axis title says how many
/// frames lie above.
#[derive(Clone, Debug, Default, PartialEq, Serialize, Deserialize)]
pub struct ErrorOverTime {
    /// Figure title.
    pub title: String,
    /// Position errors per method, metres, indexed by frame (an empty list leaves out the panel).
    pub position_m: Vec<Series>,
    /// Rotation errors per method, degrees, indexed by frame.
    pub rotation_deg: Vec<Series>,
    /// Frame indices that get a vertical line (e.g. the first frame after each scene cut).
    pub markers: Vec<usize>,
    /// Legend text of the markers.
    pub marker_label: String,
}

pub(crate) struct TimePlot {
    pub(crate) title: String,
    /// How the longest series was thinned, for the legend; `None` when drawn in full.
    pub(crate) band_note: Option<String>,
    pub(crate) panels: Vec<Panel>,
    pub(crate) markers: Vec<f64>,
    pub(crate) marker_label: String,
}

pub(crate) fn prepare_time(f: &ErrorOverTime) -> Result<TimePlot> {
    if f.position_m.is_empty() && f.rotation_deg.is_empty() {
        return Err(ReportError::BadInput(format!(
            "error-over-time figure '{}': no series to plot",
            f.title
        )));
    }
    let frames = f
        .position_m
        .iter()
        .chain(&f.rotation_deg)
        .map(|s| s.values.len())
        .max()
        .unwrap_or(0);
    let x_range = (0.0, (frames.saturating_sub(1)).max(1) as f64);
    let mut panels = Vec::new();
    let kinds = [
        ("position error (m)", "position error", "m", &f.position_m),
        (
            "rotation error (deg)",
            "rotation error",
            "°",
            &f.rotation_deg,
        ),
    ];
    for (y_desc, what, unit, series) in kinds {
        if series.is_empty() {
            continue;
        }
        for s in series {
            if !s.values.iter().any(|v| v.is_finite()) {
                return Err(ReportError::BadInput(format!(
                    "{what} series '{}' has no finite values ({} values)",
                    s.name,
                    s.values.len()
                )));
            }
        }
        let all = || series.iter().flat_map(|s| s.values.iter().copied());
        let (y_min, _) = quantile_range(all(), 0.0, 0.0).unwrap_or((0.0, 0.0));
        let (p99, y_max) = quantile_range(all(), 0.99, 1.0).unwrap_or((0.0, 0.0));
        // rare gross failures would flatten everything else against the x axis: cut them off,
        // and say so
        let cut = p99 > 0.0 && y_max > 2.0 * p99;
        let top = if cut { 1.3 * p99 } else { y_max };
        let above = if cut {
            all().filter(|v| v.is_finite() && *v > top).count()
        } else {
            0
        };
        let curves = series
            .iter()
            .map(|s| {
                let finite = s.values.iter().filter(|v| v.is_finite()).count();
                let clamp = |segs: Vec<Vec<(f64, f64)>>| -> Vec<Vec<(f64, f64)>> {
                    segs.into_iter()
                        .map(|seg| seg.into_iter().map(|(x, y)| (x, y.min(top))).collect())
                        .collect()
                };
                let envelope = clamp(envelope(&s.values));
                let (segments, band) = match bucket_medians(&s.values) {
                    Some(medians) => (clamp(medians), envelope),
                    None => (envelope, Vec::new()),
                };
                Curve {
                    label: format!("{}{}", s.name, left_out(s.values.len() - finite)),
                    segments,
                    band,
                }
            })
            .collect();
        let low = y_min.min(0.0);
        let span = top - low;
        let pad = if span > 0.0 { 0.04 * span } else { 1.0 };
        let x_desc = if cut {
            format!(
                "frame  ({what} axis cut at {}{}{}: {above} frames above)",
                fmt_sig(top),
                sep(unit),
                unit
            )
        } else {
            "frame".to_string()
        };
        panels.push(Panel {
            x_desc,
            y_desc: y_desc.into(),
            x_range,
            y_range: (if low < 0.0 { low - pad } else { 0.0 }, top + pad),
            curves,
            thresholds: Vec::new(),
        });
    }
    // one line per pixel column is all that can show
    let mut markers: Vec<f64> = Vec::new();
    let px = (x_range.1 - x_range.0) / 1200.0;
    let mut sorted = f.markers.clone();
    sorted.sort_unstable();
    for m in sorted {
        let x = m as f64;
        if x > x_range.1 {
            continue;
        }
        if markers.last().is_none_or(|last| x - last >= px) {
            markers.push(x);
        }
    }
    let band_note = (frames > 2 * MAX_TIME_BUCKETS).then(|| {
        format!(
            "line: median of each {} frames, shade: their full range",
            frames.div_ceil(MEDIAN_BUCKETS)
        )
    });
    Ok(TimePlot {
        title: f.title.clone(),
        band_note,
        panels,
        markers,
        marker_label: if f.marker_label.is_empty() {
            "marker".into()
        } else {
            f.marker_label.clone()
        },
    })
}

pub(crate) fn draw_time<DB: DrawingBackend>(
    root: &DrawingArea<DB, Shift>,
    p: &TimePlot,
    bitmap: bool,
) -> DrawResult
where
    DB::ErrorType: 'static,
{
    let area = titled(root, &p.title)?;
    // one legend for both panels: series share their colour across panels
    let mut entries: Vec<(String, Glyph)> = Vec::new();
    if let Some(first) = p.panels.first() {
        for (i, c) in first.curves.iter().enumerate() {
            let color = PALETTE[i % PALETTE.len()].to_rgba();
            entries.push((c.label.clone(), Glyph::Line(color, 3)));
        }
    }
    if let Some(note) = &p.band_note {
        entries.push((note.clone(), Glyph::Band(PALETTE[0].mix(0.3))));
    }
    if !p.markers.is_empty() {
        entries.push((p.marker_label.clone(), Glyph::VLine(MARKER.mix(0.8))));
    }
    let area = legend_strip(&area, &entries)?;
    let cells = area.split_evenly((p.panels.len().max(1), 1));
    for (cell, panel) in cells.iter().zip(&p.panels) {
        let points: usize = panel
            .curves
            .iter()
            .flat_map(|c| c.segments.iter().map(Vec::len))
            .sum();
        // a long raw series reads better thin
        let width = if points > 1500 { 1 } else { 2 };
        draw_panel(cell, panel, None, &p.markers, (width, bitmap))?;
    }
    Ok(())
}
