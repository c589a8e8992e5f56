//! Reliability diagrams: for uncertainty that claims probabilities, the share of errors that
//! fell inside each claimed region against the region's nominal probability. A calibrated
//! source lies on the diagonal; below it, the regions are too small (overconfident). The
//! figure's description, its checks into a [`ReliabilityPlot`], and its drawing.

use crate::chart::{AXIS, DrawResult, Glyph, PALETTE, draw_mesh, legend_strip, titled};
use crate::error::{ReportError, Result};
use plotters::coord::Shift;
use plotters::prelude::*;
use serde::{Deserialize, Serialize};

/// One curve: nominal levels against observed coverage, both in [0, 1].
#[derive(Clone, Debug, Default, PartialEq, Serialize, Deserialize)]
pub struct ReliabilityCurve {
    /// Legend text.
    pub name: String,
    /// `[nominal, observed]` pairs, nominal ascending.
    pub points: Vec<[f64; 2]>,
}

/// Observed against nominal coverage, one curve per source, with the diagonal.
#[derive(Clone, Debug, Default, PartialEq, Serialize, Deserialize)]
pub struct Reliability {
    /// Figure title.
    pub title: String,
    /// The curves.
    pub curves: Vec<ReliabilityCurve>,
}

/// The checked curves, ready to draw.
pub(crate) struct ReliabilityPlot {
    pub(crate) title: String,
    pub(crate) curves: Vec<(String, Vec<(f64, f64)>)>,
}

pub(crate) fn prepare_reliability(f: &Reliability) -> Result<ReliabilityPlot> {
    let ok = |p: &[f64; 2]| p.iter().all(|v| v.is_finite() && (0.0..=1.0).contains(v));
    if f.curves.is_empty() || f.curves.iter().any(|c| c.points.is_empty()) {
        return Err(ReportError::BadInput(format!(
            "reliability diagram '{}': no curve, or a curve without points",
            f.title
        )));
    }
    if let Some(c) = f.curves.iter().find(|c| !c.points.iter().all(ok)) {
        return Err(ReportError::BadInput(format!(
            "reliability diagram '{}': curve '{}' has a value outside [0, 1]",
            f.title, c.name
        )));
    }
    Ok(ReliabilityPlot {
        title: f.title.clone(),
        curves: f
            .curves
            .iter()
            .map(|c| {
                (
                    c.name.clone(),
                    c.points.iter().map(|p| (p[0], p[1])).collect(),
                )
            })
            .collect(),
    })
}

pub(crate) fn draw_reliability<DB: DrawingBackend>(
    root: &DrawingArea<DB, Shift>,
    p: &ReliabilityPlot,
) -> DrawResult
where
    DB::ErrorType: 'static,
{
    let area = titled(root, &p.title)?;
    let mut entries = vec![("ideal".to_string(), Glyph::Line(AXIS.to_rgba(), 1))];
    for (k, (name, _)) in p.curves.iter().enumerate() {
        let color = PALETTE[k % PALETTE.len()];
        entries.push((name.clone(), Glyph::Line(color.to_rgba(), 3)));
    }
    let area = legend_strip(&area, &entries)?;
    let mut chart = ChartBuilder::on(&area)
        .margin(8)
        .margin_right(24)
        .x_label_area_size(48)
        .y_label_area_size(68)
        .build_cartesian_2d(0.0..1.0, 0.0..1.0)?;
    let descs = (
        "nominal probability of the region",
        "share of errors inside",
    );
    draw_mesh(&mut chart, descs, (11, 11), (1.0, 1.0))?;
    chart.draw_series(std::iter::once(PathElement::new(
        vec![(0.0, 0.0), (1.0, 1.0)],
        AXIS.stroke_width(1),
    )))?;
    for (k, (_, points)) in p.curves.iter().enumerate() {
        let color = PALETTE[k % PALETTE.len()];
        chart.draw_series(std::iter::once(PathElement::new(
            points.clone(),
            color.stroke_width(3),
        )))?;
        chart.draw_series(points.iter().map(|&at| Circle::new(at, 3, color.filled())))?;
    }
    Ok(())
}
