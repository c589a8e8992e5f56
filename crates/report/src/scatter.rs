//! Scatter plots of one quantity against another, with their correlation: e.g. the uncertainty a
//! network predicts against the error it actually makes. The figure's description, its checks and
//! thinning into a [`ScatterPlot`], and its drawing.

use crate::chart::{
    DrawResult, Glyph, PALETTE, draw_mesh, fmt_sig, left_out, legend_strip, titled,
};
use crate::decimate::{MAX_SCATTER_POINTS, clip_polyline, quantile_range, stride_indices};
use crate::error::{ReportError, Result};
use plotters::coord::Shift;
use plotters::prelude::*;
use serde::{Deserialize, Serialize};

/// Points `[x, y]` with their Pearson correlation in the legend and, optionally, the
/// least-squares line `y = a + b x`.
///
/// Non-finite points are left out (the legend says how many); the correlation and the line use
/// every other point. When an axis's largest value is more than twice its 99th percentile, that
/// axis stops at 1.3 × the percentile, so a few gross failures do not squeeze the cloud into a
/// corner, and the legend says how many points lie beyond. Decimation: at most 5000 points are
/// drawn (uniform stride).
#[derive(Clone, Debug, Default, PartialEq, Serialize, Deserialize)]
pub struct Scatter {
    /// Figure title.
    pub title: String,
    /// Title of the x axis, with its unit.
    pub x_label: String,
    /// Title of the y axis, with its unit.
    pub y_label: String,
    /// The points.
    pub points: Vec<[f64; 2]>,
    /// Draw the least-squares line through the points.
    pub fit_line: bool,
}

/// A scatter plot's data after checks and decimation.
pub(crate) struct ScatterPlot {
    pub(crate) title: String,
    pub(crate) x_desc: String,
    pub(crate) y_desc: String,
    pub(crate) x_range: (f64, f64),
    pub(crate) y_range: (f64, f64),
    /// The points drawn: decimated, inside the axes.
    pub(crate) points: Vec<(f64, f64)>,
    /// Legend text of the points: count, correlation, what was left out.
    pub(crate) points_label: String,
    /// Legend text of the least-squares line, when there is one.
    pub(crate) fit_label: Option<String>,
    /// The part of the least-squares line inside the axes.
    pub(crate) fit_segment: Option<[(f64, f64); 2]>,
}

/// An axis from zero (or the smallest value, when negative) to the largest value, cut at 1.3 ×
/// the 99th percentile when rare outliers lie beyond twice it; padded by 4 %.
fn axis(values: impl Iterator<Item = f64> + Clone) -> (f64, f64) {
    let (lo, _) = quantile_range(values.clone(), 0.0, 0.0).unwrap_or((0.0, 0.0));
    let (p99, max) = quantile_range(values, 0.99, 1.0).unwrap_or((0.0, 0.0));
    let top = if p99 > 0.0 && max > 2.0 * p99 {
        1.3 * p99
    } else {
        max
    };
    let low = lo.min(0.0);
    let span = top - low;
    let pad = if span > 0.0 { 0.04 * span } else { 1.0 };
    (if low < 0.0 { low - pad } else { 0.0 }, top + pad)
}

/// Slope and intercept of the least-squares line `y = a + b x`; `None` when x is constant.
fn least_squares(points: &[(f64, f64)]) -> Option<(f64, f64)> {
    let n = points.len() as f64;
    let mx = points.iter().map(|p| p.0).sum::<f64>() / n;
    let my = points.iter().map(|p| p.1).sum::<f64>() / n;
    let (mut sxx, mut sxy) = (0.0, 0.0);
    for (x, y) in points {
        sxx += (x - mx) * (x - mx);
        sxy += (x - mx) * (y - my);
    }
    let b = sxy / sxx;
    let a = my - b * mx;
    (sxx > 0.0 && a.is_finite() && b.is_finite()).then_some((b, a))
}

pub(crate) fn prepare_scatter(f: &Scatter) -> Result<ScatterPlot> {
    let finite: Vec<(f64, f64)> = f
        .points
        .iter()
        .filter(|p| p[0].is_finite() && p[1].is_finite())
        .map(|p| (p[0], p[1]))
        .collect();
    if finite.is_empty() {
        return Err(ReportError::BadInput(format!(
            "scatter plot '{}': no finite points ({} points)",
            f.title,
            f.points.len()
        )));
    }
    let x_range = axis(finite.iter().map(|p| p.0));
    let y_range = axis(finite.iter().map(|p| p.1));
    let inside = |p: &(f64, f64)| {
        p.0 >= x_range.0 && p.0 <= x_range.1 && p.1 >= y_range.0 && p.1 <= y_range.1
    };
    let beyond = finite.iter().filter(|p| !inside(p)).count();
    let points: Vec<(f64, f64)> = stride_indices(finite.len(), MAX_SCATTER_POINTS)
        .map(|i| finite[i])
        .filter(inside)
        .collect();

    let xs: Vec<f64> = finite.iter().map(|p| p.0).collect();
    let ys: Vec<f64> = finite.iter().map(|p| p.1).collect();
    let r = match geom::metrics::pearson(&xs, &ys) {
        Ok(r) => format!("Pearson r = {r:.2}"),
        Err(_) => "Pearson r undefined".to_string(),
    };
    let n = finite.len();
    let mut label = format!("{n} point{}, {r}", if n == 1 { "" } else { "s" });
    if points.len() + beyond < n {
        label.push_str(&format!(", {} drawn", points.len()));
    }
    if beyond > 0 {
        label.push_str(&format!(", {beyond} beyond the axes"));
    }
    label.push_str(&left_out(f.points.len() - n));

    let rect = [x_range.0, x_range.1, y_range.0, y_range.1];
    let fit = least_squares(&finite).filter(|_| f.fit_line);
    let fit_label = fit.map(|(b, a)| {
        let sign = if a < 0.0 { "−" } else { "+" };
        format!(
            "least squares: y = {} x {sign} {}",
            fmt_sig(b),
            fmt_sig(a.abs())
        )
    });
    let fit_segment = fit.and_then(|(b, a)| {
        let line = [
            (x_range.0, a + b * x_range.0),
            (x_range.1, a + b * x_range.1),
        ];
        match clip_polyline(&line, rect).first().map(Vec::as_slice) {
            Some(&[p, q]) => Some([p, q]),
            _ => None,
        }
    });
    Ok(ScatterPlot {
        title: f.title.clone(),
        x_desc: f.x_label.clone(),
        y_desc: f.y_label.clone(),
        x_range,
        y_range,
        points,
        points_label: label,
        fit_label,
        fit_segment,
    })
}

pub(crate) fn draw_scatter<DB: DrawingBackend>(
    root: &DrawingArea<DB, Shift>,
    p: &ScatterPlot,
) -> DrawResult
where
    DB::ErrorType: 'static,
{
    let area = titled(root, &p.title)?;
    let dot = PALETTE[0];
    let fit = PALETTE[3];
    let mut entries = vec![(p.points_label.clone(), Glyph::Circle(dot))];
    if let Some(label) = &p.fit_label {
        entries.push((label.clone(), Glyph::Line(fit.to_rgba(), 2)));
    }
    let area = legend_strip(&area, &entries)?;
    let ((x0, x1), (y0, y1)) = (p.x_range, p.y_range);
    let mut chart = ChartBuilder::on(&area)
        .margin(8)
        .margin_right(24)
        .x_label_area_size(48)
        .y_label_area_size(68)
        .build_cartesian_2d(x0..x1, y0..y1)?;
    let descs = (p.x_desc.as_str(), p.y_desc.as_str());
    draw_mesh(&mut chart, descs, (9, 7), (x1 - x0, y1 - y0))?;
    // translucent, so dense parts of the cloud read darker
    let (radius, alpha) = if p.points.len() > 1500 {
        (2, 0.35)
    } else {
        (3, 0.55)
    };
    chart.draw_series(
        p.points
            .iter()
            .map(|&at| Circle::new(at, radius, dot.mix(alpha).filled())),
    )?;
    if let Some(line) = p.fit_segment {
        chart.draw_series(std::iter::once(PathElement::new(
            line.to_vec(),
            fit.stroke_width(2),
        )))?;
    }
    Ok(())
}
