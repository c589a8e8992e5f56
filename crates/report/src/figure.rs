//! Figures: the [`Figure`] enum over every kind, the functions that make one, and rendering to
//! PNG or SVG (checks and thinning by the kind's module, then the same drawing code for both
//! formats).
//!
//! This is the top of the figure modules: each kind's module (`cdf`, `over_time`, `top_down`,
//! `errmap`, `scatter`, `reliability`) holds its description, preparation and drawing on the shared
//! `chart` helpers, and none of them refers back here. Tests that draw through [`Figure`] live in
//! `figure/tests.rs` for the same reason.

use crate::cdf::{CdfPlot, ErrorCdf, draw_cdf, prepare_cdf};
use crate::chart::{DrawResult, TOP_DOWN_WIDTH, encode_png};
use crate::errmap::{ErrorMap, ErrorMapPlot, draw_error_map, error_map_height, prepare_error_map};
use crate::error::{ReportError, Result};
use crate::font::{FONT, SVG_FONT_STACK, ensure_font};
use crate::io::write_atomic;
use crate::over_time::{ErrorOverTime, TimePlot, draw_time, prepare_time};
use crate::reliability::{
    Reliability, ReliabilityCurve, ReliabilityPlot, draw_reliability, prepare_reliability,
};
use crate::scatter::{Scatter, ScatterPlot, draw_scatter, prepare_scatter};
use crate::series::{Series, Track};
use crate::top_down::{TopDown, TopDownPlot, draw_top_down, prepare_top_down, top_down_height};
use plotters::coord::Shift;
use plotters::prelude::*;
use serde::{Deserialize, Serialize};
use std::path::{Path, PathBuf};

/// A figure that renders to PNG or SVG.
#[derive(Clone, Debug, PartialEq, Serialize, Deserialize)]
pub enum Figure {
    /// See [`ErrorCdf`].
    ErrorCdf(ErrorCdf),
    /// See [`ErrorOverTime`].
    ErrorOverTime(ErrorOverTime),
    /// See [`TopDown`].
    TopDown(TopDown),
    /// See [`ErrorMap`].
    ErrorMap(ErrorMap),
    /// See [`Scatter`].
    Scatter(Scatter),
    /// See [`Reliability`].
    Reliability(Reliability),
}

impl From<ErrorCdf> for Figure {
    fn from(f: ErrorCdf) -> Figure {
        Figure::ErrorCdf(f)
    }
}

impl From<ErrorOverTime> for Figure {
    fn from(f: ErrorOverTime) -> Figure {
        Figure::ErrorOverTime(f)
    }
}

impl From<TopDown> for Figure {
    fn from(f: TopDown) -> Figure {
        Figure::TopDown(f)
    }
}

impl From<ErrorMap> for Figure {
    fn from(f: ErrorMap) -> Figure {
        Figure::ErrorMap(f)
    }
}

impl From<Scatter> for Figure {
    fn from(f: Scatter) -> Figure {
        Figure::Scatter(f)
    }
}

/// Cumulative distributions of position (m) and rotation (°) errors, one curve per series.
pub fn error_cdf(title: &str, position_m: &[Series], rotation_deg: &[Series]) -> Figure {
    Figure::ErrorCdf(ErrorCdf {
        title: title.into(),
        position_m: position_m.to_vec(),
        rotation_deg: rotation_deg.to_vec(),
        ..ErrorCdf::default()
    })
}

/// Position (m) and rotation (°) errors against frame index, with vertical lines at `markers`
/// (labelled "scene cut").
pub fn error_over_time(
    title: &str,
    position_m: &[Series],
    rotation_deg: &[Series],
    markers: Option<&[usize]>,
) -> Figure {
    Figure::ErrorOverTime(ErrorOverTime {
        title: title.into(),
        position_m: position_m.to_vec(),
        rotation_deg: rotation_deg.to_vec(),
        markers: markers.map(<[usize]>::to_vec).unwrap_or_default(),
        marker_label: "scene cut".into(),
    })
}

/// Top-down view of `ground_truth` and `estimates`, with error links when `links`.
pub fn trajectory_top_down(
    title: &str,
    ground_truth: &[[f64; 2]],
    estimates: &[Track],
    links: bool,
) -> Figure {
    Figure::TopDown(TopDown {
        title: title.into(),
        ground_truth: ground_truth.to_vec(),
        estimates: estimates.to_vec(),
        links,
    })
}

/// Map of `estimates` coloured by `errors_m` over the `ground_truth` path, with the colour scale
/// ending at the 95th percentile, no links and no floor plan (set the fields of [`ErrorMap`] for
/// those).
pub fn error_map(
    title: &str,
    ground_truth: &[[f64; 2]],
    estimates: &[[f64; 2]],
    errors_m: &[f64],
) -> Figure {
    Figure::ErrorMap(ErrorMap {
        title: title.into(),
        ground_truth: ground_truth.to_vec(),
        estimates: estimates.to_vec(),
        errors_m: errors_m.to_vec(),
        ..ErrorMap::default()
    })
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

/// A reliability diagram of `curves`.
pub fn reliability(title: &str, curves: Vec<ReliabilityCurve>) -> Figure {
    Figure::Reliability(Reliability {
        title: title.into(),
        curves,
    })
}

/// The name used in errors about figures rendered to memory.
const IN_MEMORY: &str = "<memory>";

impl Figure {
    /// Width and height in pixels (PNG) or user units (SVG). The height of a top-down figure or
    /// an error map follows the aspect ratio of its trajectories.
    pub fn size(&self) -> (u32, u32) {
        match self {
            Figure::ErrorCdf(f) => {
                let panels = [!f.position_m.is_empty(), !f.rotation_deg.is_empty()];
                if panels.iter().filter(|p| **p).count() > 1 {
                    (1200, 520)
                } else {
                    (760, 520)
                }
            }
            Figure::ErrorOverTime(f) => {
                if !f.position_m.is_empty() && !f.rotation_deg.is_empty() {
                    (1200, 700)
                } else {
                    (1200, 400)
                }
            }
            Figure::TopDown(f) => (TOP_DOWN_WIDTH, top_down_height(f)),
            Figure::ErrorMap(f) => (TOP_DOWN_WIDTH, error_map_height(f)),
            Figure::Scatter(_) => (760, 580),
            Figure::Reliability(_) => (760, 620),
        }
    }

    /// The figure as an SVG document.
    pub fn to_svg(&self) -> Result<String> {
        self.prepare(Path::new(IN_MEMORY))?
            .svg(Path::new(IN_MEMORY))
    }

    /// The figure as PNG file bytes.
    pub fn to_png(&self) -> Result<Vec<u8>> {
        self.prepare(Path::new(IN_MEMORY))?
            .png(Path::new(IN_MEMORY))
    }

    /// Writes the figure as SVG to `path`, atomically.
    pub fn save_svg(&self, path: &Path) -> Result<()> {
        let svg = self.prepare(path)?.svg(path)?;
        write_atomic(path, svg.as_bytes())
    }

    /// Writes the figure as PNG to `path`, atomically.
    pub fn save_png(&self, path: &Path) -> Result<()> {
        let png = self.prepare(path)?.png(path)?;
        write_atomic(path, &png)
    }

    /// Writes `dir/stem.png` and `dir/stem.svg` (decimating the data once for both) and returns
    /// the SVG text, ready to inline in an HTML report, with the two paths.
    pub fn save_both(&self, dir: &Path, stem: &str) -> Result<(String, PathBuf, PathBuf)> {
        let png_path = dir.join(format!("{stem}.png"));
        let svg_path = dir.join(format!("{stem}.svg"));
        let prepared = self.prepare(&svg_path)?;
        let svg = prepared.svg(&svg_path)?;
        let png = prepared.png(&png_path)?;
        write_atomic(&svg_path, svg.as_bytes())?;
        write_atomic(&png_path, &png)?;
        Ok((svg, png_path, svg_path))
    }

    /// Checks the input and thins it to what the figure draws.
    fn prepare(&self, path: &Path) -> Result<Prepared> {
        ensure_font(path)?;
        let plot = match self {
            Figure::ErrorCdf(f) => Plot::Cdf(prepare_cdf(f)?),
            Figure::ErrorOverTime(f) => Plot::Time(prepare_time(f)?),
            Figure::TopDown(f) => Plot::TopDown(prepare_top_down(f)?),
            Figure::ErrorMap(f) => Plot::ErrorMap(prepare_error_map(f)?),
            Figure::Scatter(f) => Plot::Scatter(prepare_scatter(f)?),
            Figure::Reliability(f) => Plot::Reliability(prepare_reliability(f)?),
        };
        // values near f64::MAX overflow the padded axes; plotters cannot lay out such an axis
        let axes: Vec<(f64, f64)> = match &plot {
            Plot::Cdf(p) => p
                .panels
                .iter()
                .flat_map(|q| [q.x_range, q.y_range])
                .collect(),
            Plot::Time(p) => p
                .panels
                .iter()
                .flat_map(|q| [q.x_range, q.y_range])
                .collect(),
            Plot::TopDown(p) => vec![(p.bounds[0], p.bounds[1]), (p.bounds[2], p.bounds[3])],
            Plot::ErrorMap(p) => vec![
                (p.bounds[0], p.bounds[1]),
                (p.bounds[2], p.bounds[3]),
                (0.0, p.color_max),
            ],
            Plot::Scatter(p) => vec![p.x_range, p.y_range],
            Plot::Reliability(_) => vec![(0.0, 1.0), (0.0, 1.0)],
        };
        if !axes
            .iter()
            .all(|(a, b)| a.is_finite() && b.is_finite() && a < b)
        {
            return Err(ReportError::BadInput(format!(
                "{}: values too large to plot",
                path.display()
            )));
        }
        Ok(Prepared {
            size: self.size(),
            plot,
        })
    }
}

/// A figure's data after checks and decimation.
struct Prepared {
    size: (u32, u32),
    plot: Plot,
}

/// What each kind of figure draws.
enum Plot {
    Cdf(CdfPlot),
    Time(TimePlot),
    TopDown(TopDownPlot),
    ErrorMap(ErrorMapPlot),
    Scatter(ScatterPlot),
    Reliability(ReliabilityPlot),
}

/// Draws a prepared plot on any backend.
///
/// `bitmap` says the backend is plotters' bitmap one, whose wide polylines need care.
fn draw<DB: DrawingBackend>(root: &DrawingArea<DB, Shift>, plot: &Plot, bitmap: bool) -> DrawResult
where
    DB::ErrorType: 'static,
{
    root.fill(&WHITE)?;
    match plot {
        Plot::Cdf(p) => draw_cdf(root, p, bitmap),
        Plot::Time(p) => draw_time(root, p, bitmap),
        Plot::TopDown(p) => draw_top_down(root, p, bitmap),
        Plot::ErrorMap(p) => draw_error_map(root, p),
        Plot::Scatter(p) => draw_scatter(root, p),
        Plot::Reliability(p) => draw_reliability(root, p),
    }
}

impl Prepared {
    /// Renders to an SVG document.
    fn svg(&self, path: &Path) -> Result<String> {
        let mut out = String::new();
        {
            let root = SVGBackend::with_string(&mut out, self.size).into_drawing_area();
            draw(&root, &self.plot, false).map_err(|e| plot_err(path, e))?;
            root.present().map_err(|e| plot_err(path, e))?;
        }
        // give viewers without DejaVu a similar face instead of their default serif
        Ok(out.replace(
            &format!("font-family=\"{FONT}\""),
            &format!("font-family=\"{SVG_FONT_STACK}\""),
        ))
    }

    /// Renders to PNG file bytes.
    fn png(&self, path: &Path) -> Result<Vec<u8>> {
        let (w, h) = self.size;
        let mut rgb = vec![255u8; w as usize * h as usize * 3];
        {
            let root = BitMapBackend::with_buffer(&mut rgb, self.size).into_drawing_area();
            draw(&root, &self.plot, true).map_err(|e| plot_err(path, e))?;
            root.present().map_err(|e| plot_err(path, e))?;
        }
        encode_png(&rgb, w, h).map_err(|e| plot_err(path, e))
    }
}

fn plot_err(path: &Path, e: impl std::fmt::Display) -> ReportError {
    ReportError::Plot {
        path: path.to_path_buf(),
        msg: e.to_string(),
    }
}

#[cfg(test)]
mod tests;
