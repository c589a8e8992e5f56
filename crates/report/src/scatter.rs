//! Scatter plots of one quantity against another, with their correlation: e.g. the uncertainty a
//! network predicts against the error it actually makes.

use crate::decimate::{MAX_SCATTER_POINTS, clip_polyline, quantile_range, stride_indices};
use crate::error::{ReportError, Result};
use crate::figure::{Figure, fmt_sig, left_out};
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

/// Scatter plot of `points` with the least-squares line, axes titled `x_label` and `y_label`.
pub fn scatter(title: &str, x_label: &str, y_label: &str, points: &[[f64; 2]]) -> Figure {
    Figure::Scatter(Scatter {
        title: title.into(),
        x_label: x_label.into(),
        y_label: y_label.into(),
        points: points.to_vec(),
        fit_line: true,
    })
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

#[cfg(test)]
mod tests {
    use super::*;
    use crate::font::SVG_FONT_STACK;

    type TestResult = std::result::Result<(), Box<dyn std::error::Error>>;

    /// Errors that grow with the predicted sigma, with deterministic scatter.
    fn sigma_vs_error(n: usize) -> Vec<[f64; 2]> {
        (0..n)
            .map(|i| {
                let s = 0.1 + (i % 50) as f64 * 0.02;
                let u = (i as f64 * 0.618_034) % 1.0;
                [s, s * (0.5 + u)]
            })
            .collect()
    }

    #[test]
    fn png_and_svg_are_drawn_at_the_figure_size() -> TestResult {
        let fig = scatter(
            "Uncertainty",
            "predicted sigma (m)",
            "position error (m)",
            &sigma_vs_error(800),
        );
        let dir = tempfile::tempdir()?;
        let (svg, png, _) = fig.save_both(dir.path(), "scatter")?;
        let img = image::open(&png)?;
        assert_eq!((img.width(), img.height()), fig.size());
        assert!(svg.starts_with("<svg") && svg.contains(SVG_FONT_STACK));
        assert!(svg.contains("Uncertainty") && svg.contains("predicted sigma (m)"));
        assert!(svg.contains("position error (m)") && svg.contains("least squares: y = "));
        assert!(svg.contains("800 points, Pearson r = 0."));
        Ok(())
    }

    #[test]
    fn correlation_and_line_use_every_point() -> TestResult {
        let pts: Vec<[f64; 2]> = (0..20_000)
            .map(|i| [f64::from(i), 2.0 * f64::from(i) + 1.0])
            .collect();
        let fig = Scatter {
            points: pts,
            fit_line: true,
            ..Scatter::default()
        };
        let plot = prepare_scatter(&fig)?;
        assert!(plot.points.len() <= MAX_SCATTER_POINTS + 1);
        assert!(
            plot.points_label
                .starts_with("20000 points, Pearson r = 1.00, ")
        );
        assert_eq!(
            plot.fit_label.as_deref(),
            Some("least squares: y = 2 x + 1")
        );
        assert!(plot.fit_segment.is_some());
        let no_line = prepare_scatter(&Scatter {
            fit_line: false,
            ..fig
        })?;
        assert!(no_line.fit_label.is_none() && no_line.fit_segment.is_none());
        Ok(())
    }

    #[test]
    fn outliers_cut_the_axis_and_are_counted() -> TestResult {
        let mut pts = sigma_vs_error(1000);
        pts[10] = [0.5, 1000.0];
        let plot = prepare_scatter(&Scatter {
            points: pts,
            ..Scatter::default()
        })?;
        assert!(plot.y_range.1 < 10.0);
        assert!(plot.points_label.contains("1 beyond the axes"));
        Ok(())
    }

    #[test]
    fn non_finite_points_are_left_out() -> TestResult {
        let mut pts = sigma_vs_error(30);
        pts[2] = [f64::NAN, 1.0];
        pts[5] = [0.3, f64::INFINITY];
        let fig = scatter("t", "x", "y", &pts);
        let svg = fig.to_svg()?;
        assert!(svg.contains("28 points") && svg.contains("2 non-finite left out"));
        fig.to_png()?;
        Ok(())
    }

    #[test]
    fn bad_input_is_an_error() {
        let bad = [
            scatter("t", "x", "y", &[]),
            scatter("t", "x", "y", &[[f64::NAN, 1.0]]),
            scatter("t", "x", "y", &[[0.0, 0.0], [f64::MAX, 1.0]]),
        ];
        for fig in bad {
            crate::figure::assert_rejected(&fig);
        }
    }

    #[test]
    fn single_and_constant_points_draw_without_a_line() -> TestResult {
        let one = scatter("t", "x", "y", &[[1.0, 2.0]]);
        assert!(one.to_svg()?.contains("1 point, Pearson r undefined"));
        let Figure::Scatter(same_x) = scatter("t", "x", "y", &[[1.0, 2.0], [1.0, 3.0]]) else {
            return Err("not a scatter plot".into());
        };
        assert!(prepare_scatter(&same_x)?.fit_label.is_none());
        Figure::from(same_x).to_png()?;
        scatter("t", "x", "y", &[[-1.0, -2.0], [0.0, 0.0]]).to_png()?;
        Ok(())
    }
}
