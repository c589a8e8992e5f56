//! Figures: typed descriptions of the plots, rendered to PNG or SVG by the same drawing code.

use crate::decimate::{
    MAX_LINKS, MAX_TIME_BUCKETS, MEDIAN_BUCKETS, bucket_medians, cdf_points, clip_polyline, clip_x,
    envelope, quantile_range, stride_indices, track_segments,
};
use crate::draw;
use crate::errmap::{ErrorMap, ErrorMapPlot, prepare_error_map};
use crate::error::{ReportError, Result};
use crate::font::{FONT, SVG_FONT_STACK, ensure_font};
use crate::io::write_atomic;
use crate::reliability::{Reliability, ReliabilityPlot, prepare_reliability};
use crate::scatter::{Scatter, ScatterPlot, prepare_scatter};
use geom::metrics::percentile_sorted;
use plotters::prelude::*;
use serde::{Deserialize, Serialize};
use std::path::{Path, PathBuf};

/// A named list of values: per-frame errors of one method, one curve in a figure.
#[derive(Clone, Debug, Default, PartialEq, Serialize, Deserialize)]
pub struct Series {
    /// Legend text.
    pub name: String,
    /// The values, one per frame (non-finite ones are left out of plots).
    pub values: Vec<f64>,
}

impl Series {
    /// A series from a name and values.
    pub fn new(name: impl Into<String>, values: impl Into<Vec<f64>>) -> Series {
        Series {
            name: name.into(),
            values: values.into(),
        }
    }
}

/// A named top-down path: camera centres `[x, y]` in metres.
#[derive(Clone, Debug, Default, PartialEq, Serialize, Deserialize)]
pub struct Track {
    /// Legend text.
    pub name: String,
    /// Camera centres, metres, in frame order.
    pub points: Vec<[f64; 2]>,
}

impl Track {
    /// A track from a name and points.
    pub fn new(name: impl Into<String>, points: impl Into<Vec<[f64; 2]>>) -> Track {
        Track {
            name: name.into(),
            points: points.into(),
        }
    }
}

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

/// Top-down (x, y) view of the ground truth and estimated trajectories, equal aspect ratio,
/// with start (circle) and end (square) markers.
///
/// Decimation: each trajectory is drawn through at most 4000 points (uniform stride, the last
/// point always kept) and at most 600 error links.
#[derive(Clone, Debug, Default, PartialEq, Serialize, Deserialize)]
pub struct TopDown {
    /// Figure title.
    pub title: String,
    /// Ground-truth camera centres, metres (may be empty when only estimates are known).
    pub ground_truth: Vec<[f64; 2]>,
    /// Estimated trajectories.
    pub estimates: Vec<Track>,
    /// Draw a line from each ground-truth point to its estimate (for estimates as long as the
    /// ground truth).
    pub links: bool,
}

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
            Figure::TopDown(f) => (draw::TOP_DOWN_WIDTH, draw::top_down_height(f)),
            Figure::ErrorMap(f) => (draw::TOP_DOWN_WIDTH, draw::error_map_height(f)),
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
pub(crate) struct Prepared {
    pub(crate) size: (u32, u32),
    pub(crate) plot: Plot,
}

/// What each kind of figure draws.
pub(crate) enum Plot {
    Cdf(CdfPlot),
    Time(TimePlot),
    TopDown(TopDownPlot),
    ErrorMap(ErrorMapPlot),
    Scatter(ScatterPlot),
    Reliability(ReliabilityPlot),
}

/// First and last finite point of a track.
pub(crate) type Ends = ((f64, f64), (f64, f64));

/// One curve, already in plot coordinates.
pub(crate) struct Curve {
    pub(crate) label: String,
    /// The line.
    pub(crate) segments: Vec<Vec<(f64, f64)>>,
    /// A light min–max band drawn under the line (decimated time series), else empty.
    pub(crate) band: Vec<Vec<(f64, f64)>>,
}

/// One panel of curves with its axes.
pub(crate) struct Panel {
    pub(crate) x_desc: String,
    pub(crate) y_desc: String,
    pub(crate) x_range: (f64, f64),
    pub(crate) y_range: (f64, f64),
    pub(crate) curves: Vec<Curve>,
    /// Dashed vertical reference lines with their labels.
    pub(crate) thresholds: Vec<(f64, String)>,
}

pub(crate) struct CdfPlot {
    pub(crate) title: String,
    pub(crate) panels: Vec<Panel>,
}

pub(crate) struct TimePlot {
    pub(crate) title: String,
    /// How the longest series was thinned, for the legend; `None` when drawn in full.
    pub(crate) band_note: Option<String>,
    pub(crate) panels: Vec<Panel>,
    pub(crate) markers: Vec<f64>,
    pub(crate) marker_label: String,
}

pub(crate) struct TopDownPlot {
    pub(crate) title: String,
    pub(crate) ground_truth: Vec<Vec<(f64, f64)>>,
    pub(crate) gt_ends: Option<Ends>,
    pub(crate) estimates: Vec<(Curve, Option<Ends>)>,
    pub(crate) links: Vec<[(f64, f64); 2]>,
    /// The padded view, `[x0, x1, y0, y1]`.
    pub(crate) bounds: [f64; 4],
    /// Estimated positions outside the view.
    pub(crate) outside: usize,
}

impl Prepared {
    /// Renders to an SVG document.
    pub(crate) fn svg(&self, path: &Path) -> Result<String> {
        let mut out = String::new();
        {
            let root = SVGBackend::with_string(&mut out, self.size).into_drawing_area();
            draw::draw(&root, &self.plot, false).map_err(|e| plot_err(path, e))?;
            root.present().map_err(|e| plot_err(path, e))?;
        }
        // give viewers without DejaVu a similar face instead of their default serif
        Ok(out.replace(
            &format!("font-family=\"{FONT}\""),
            &format!("font-family=\"{SVG_FONT_STACK}\""),
        ))
    }

    /// Renders to PNG file bytes.
    pub(crate) fn png(&self, path: &Path) -> Result<Vec<u8>> {
        let (w, h) = self.size;
        let mut rgb = vec![255u8; w as usize * h as usize * 3];
        {
            let root = BitMapBackend::with_buffer(&mut rgb, self.size).into_drawing_area();
            draw::draw(&root, &self.plot, true).map_err(|e| plot_err(path, e))?;
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

/// PNG bytes of an 8-bit RGB buffer, with fast compression (plots compress well anyway).
pub(crate) fn encode_png(
    rgb: &[u8],
    w: u32,
    h: u32,
) -> std::result::Result<Vec<u8>, image::ImageError> {
    use image::ImageEncoder;
    use image::codecs::png::{CompressionType, FilterType, PngEncoder};
    let mut out = Vec::new();
    PngEncoder::new_with_quality(&mut out, CompressionType::Fast, FilterType::Adaptive)
        .write_image(rgb, w, h, image::ExtendedColorType::Rgb8)?;
    Ok(out)
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

pub(crate) fn left_out(dropped: usize) -> String {
    match dropped {
        0 => String::new(),
        n => format!(", {n} non-finite left out"),
    }
}

fn prepare_cdf(f: &ErrorCdf) -> Result<CdfPlot> {
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

/// A space between a number and its unit, none before a degree sign.
fn sep(unit: &str) -> &'static str {
    if unit == "°" { "" } else { " " }
}

fn prepare_time(f: &ErrorOverTime) -> Result<TimePlot> {
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

fn ends(points: &[[f64; 2]]) -> Option<Ends> {
    let finite = |p: &&[f64; 2]| p[0].is_finite() && p[1].is_finite();
    let first = points.iter().find(finite)?;
    let last = points.iter().rev().find(finite)?;
    Some(((first[0], first[1]), (last[0], last[1])))
}

/// The region a top-down figure shows, see [`trajectory_view`].
pub(crate) fn top_down_view(f: &TopDown) -> Option<[f64; 4]> {
    trajectory_view(
        &f.ground_truth,
        f.estimates.iter().map(|t| t.points.as_slice()),
    )
}

/// The region a map of trajectories shows, `[x0, x1, y0, y1]` before padding: all of the ground
/// truth, and the central 99 % (0.5th to 99.5th percentile per axis) of each estimate, so that a
/// few wild estimates do not shrink the building to a corner. `None` without a finite point.
pub(crate) fn trajectory_view<'a>(
    ground_truth: &[[f64; 2]],
    estimates: impl IntoIterator<Item = &'a [[f64; 2]]>,
) -> Option<[f64; 4]> {
    let mut b = [
        f64::INFINITY,
        f64::NEG_INFINITY,
        f64::INFINITY,
        f64::NEG_INFINITY,
    ];
    let mut grow = |x: (f64, f64), y: (f64, f64)| {
        b = [b[0].min(x.0), b[1].max(x.1), b[2].min(y.0), b[3].max(y.1)];
    };
    let gt = ground_truth
        .iter()
        .filter(|p| p[0].is_finite() && p[1].is_finite());
    let xs = quantile_range(gt.clone().map(|p| p[0]), 0.0, 1.0);
    let ys = quantile_range(gt.map(|p| p[1]), 0.0, 1.0);
    if let (Some(x), Some(y)) = (xs, ys) {
        grow(x, y);
    }
    for points in estimates {
        let pts = points
            .iter()
            .filter(|p| p[0].is_finite() && p[1].is_finite());
        let (lo, hi) = if points.len() >= 200 {
            (0.005, 0.995)
        } else {
            (0.0, 1.0)
        };
        let xs = quantile_range(pts.clone().map(|p| p[0]), lo, hi);
        let ys = quantile_range(pts.map(|p| p[1]), lo, hi);
        if let (Some(x), Some(y)) = (xs, ys) {
            grow(x, y);
        }
    }
    b.iter().all(|v| v.is_finite()).then_some(b)
}

/// `[x0, x1, y0, y1]` grown by 6 % of the larger extent, and to at least 1 m each way.
pub(crate) fn padded(b: [f64; 4]) -> [f64; 4] {
    let pad = 0.06 * (b[1] - b[0]).max(b[3] - b[2]);
    let (cx, cy) = ((b[0] + b[1]) / 2.0, (b[2] + b[3]) / 2.0);
    let hx = ((b[1] - b[0]) / 2.0 + pad).max(0.5);
    let hy = ((b[3] - b[2]) / 2.0 + pad).max(0.5);
    [cx - hx, cx + hx, cy - hy, cy + hy]
}

fn prepare_top_down(f: &TopDown) -> Result<TopDownPlot> {
    let view = top_down_view(f).ok_or_else(|| {
        ReportError::BadInput(format!("top-down figure '{}': no finite points", f.title))
    })?;
    let rect = padded(view);
    let inside =
        |p: &(f64, f64)| p.0 >= rect[0] && p.0 <= rect[1] && p.1 >= rect[2] && p.1 <= rect[3];
    let clip = |segments: Vec<Vec<(f64, f64)>>| -> Vec<Vec<(f64, f64)>> {
        segments
            .iter()
            .flat_map(|s| clip_polyline(s, rect))
            .collect()
    };
    let clip_ends = |e: Option<Ends>| e.filter(|(s, e)| inside(s) && inside(e));
    let outside: usize = f
        .estimates
        .iter()
        .flat_map(|t| t.points.iter())
        .filter(|p| p[0].is_finite() && p[1].is_finite() && !inside(&(p[0], p[1])))
        .count();
    let estimates: Vec<(Curve, _)> = f
        .estimates
        .iter()
        .map(|t| {
            (
                Curve {
                    label: t.name.clone(),
                    segments: clip(track_segments(&t.points)),
                    band: Vec::new(),
                },
                clip_ends(ends(&t.points)),
            )
        })
        .collect();
    let mut links = Vec::new();
    if f.links {
        for t in &f.estimates {
            if t.points.len() != f.ground_truth.len() {
                continue;
            }
            for i in stride_indices(t.points.len(), MAX_LINKS) {
                let (g, e) = (f.ground_truth[i], t.points[i]);
                if g.iter().chain(&e).all(|v| v.is_finite()) {
                    for piece in clip_polyline(&[(g[0], g[1]), (e[0], e[1])], rect) {
                        if let [a, b] = piece[..] {
                            links.push([a, b]);
                        }
                    }
                }
            }
        }
    }
    Ok(TopDownPlot {
        title: f.title.clone(),
        gt_ends: clip_ends(ends(&f.ground_truth)),
        ground_truth: clip(track_segments(&f.ground_truth)),
        estimates,
        links,
        bounds: rect,
        outside,
    })
}

/// A number with about three significant digits, without trailing zeros: 0.0123, 1.23, 12.3, 123.
pub(crate) fn fmt_sig(v: f64) -> String {
    if !v.is_finite() {
        return format!("{v}");
    }
    let a = v.abs();
    let decimals = if a == 0.0 || a >= 100.0 {
        0
    } else {
        (2 - a.log10().floor() as i32).clamp(0, 6) as usize
    };
    let s = format!("{v:.decimals$}");
    if s.contains('.') {
        s.trim_end_matches('0').trim_end_matches('.').to_string()
    } else {
        s
    }
}

/// Test helper: `fig` is refused as bad input in both output formats.
#[cfg(test)]
pub(crate) fn assert_rejected(fig: &Figure) {
    assert!(
        matches!(fig.to_png(), Err(ReportError::BadInput(_))),
        "{fig:?}"
    );
    assert!(
        matches!(fig.to_svg(), Err(ReportError::BadInput(_))),
        "{fig:?}"
    );
}

#[cfg(test)]
mod tests {
    use super::*;

    type TestResult = std::result::Result<(), Box<dyn std::error::Error>>;

    fn noisy(n: usize, scale: f64) -> Vec<f64> {
        // deterministic, skewed "errors": mostly small, a long tail
        (0..n)
            .map(|i| {
                let u = ((i as f64 * 0.618_034) % 1.0).max(1e-6);
                scale * (-u.ln()) * (1.0 + 0.3 * (i as f64 * 0.01).sin())
            })
            .collect()
    }

    fn figures() -> Vec<Figure> {
        let a = noisy(3000, 0.3);
        let b: Vec<f64> = noisy(3000, 0.5).iter().map(|v| v * 1.4).collect();
        let xy: Vec<[f64; 2]> = (0..800)
            .map(|i| {
                let t = i as f64 * 0.01;
                [20.0 * t.cos(), 8.0 * (2.0 * t).sin()]
            })
            .collect();
        let est: Vec<[f64; 2]> = xy.iter().map(|p| [p[0] + 0.4, p[1] - 0.3]).collect();
        vec![
            error_cdf(
                "CDF",
                &[
                    Series::new("cuts handled", a.clone()),
                    Series::new("cuts ignored", b.clone()),
                ],
                &[Series::new("cuts handled", b.clone())],
            ),
            error_over_time(
                "Over time",
                &[Series::new("net", a)],
                &[Series::new("net", b)],
                Some(&[10, 2000]),
            ),
            trajectory_top_down("Top", &xy, &[Track::new("net", est)], true),
        ]
    }

    #[test]
    fn png_and_svg_files_are_written_at_the_figure_size() -> TestResult {
        let dir = tempfile::tempdir()?;
        for (i, fig) in figures().iter().enumerate() {
            let png = dir.path().join(format!("f{i}.png"));
            let svg = dir.path().join(format!("f{i}.svg"));
            fig.save_png(&png)?;
            fig.save_svg(&svg)?;
            let img = image::open(&png)?;
            assert_eq!((img.width(), img.height()), fig.size());
            let text = std::fs::read_to_string(&svg)?;
            assert!(text.starts_with("<svg") && text.contains(SVG_FONT_STACK));
        }
        Ok(())
    }

    #[test]
    fn svg_names_every_series() -> TestResult {
        let figs = figures();
        let cdf = figs[0].to_svg()?;
        assert!(cdf.contains("cuts handled") && cdf.contains("cuts ignored"));
        assert!(cdf.contains("position error (m)") && cdf.contains("rotation error (deg)"));
        let time = figs[1].to_svg()?;
        assert!(time.contains("net") && time.contains("scene cut"));
        let top = figs[2].to_svg()?;
        assert!(top.contains("ground truth") && top.contains("net") && top.contains("x (m)"));
        Ok(())
    }

    #[test]
    fn empty_input_is_an_error() {
        let empty = [Series::new("e", Vec::new())];
        let bad = [
            error_cdf("t", &[], &[]),
            error_cdf("t", &empty, &[]),
            error_over_time("t", &[], &[], None),
            error_over_time("t", &empty, &empty, None),
            trajectory_top_down("t", &[], &[], true),
        ];
        for fig in bad {
            assert_rejected(&fig);
        }
    }

    #[test]
    fn nan_values_are_left_out_not_fatal() -> TestResult {
        let v = vec![0.1, f64::NAN, 0.3, f64::INFINITY, 0.2];
        let s = [Series::new("n", v)];
        let svg = error_cdf("t", &s, &s).to_svg()?;
        assert!(svg.contains("2 non-finite left out"));
        error_over_time("t", &s, &s, Some(&[1, 99])).to_png()?;
        let xy = [[0.0, 0.0], [f64::NAN, 1.0], [1.0, 1.0]];
        trajectory_top_down("t", &xy, &[Track::new("e", xy.to_vec())], true).to_png()?;
        let all_nan = [Series::new("n", vec![f64::NAN; 3])];
        assert!(error_cdf("t", &all_nan, &[]).to_png().is_err());
        Ok(())
    }

    #[test]
    fn huge_values_are_an_error_not_a_hang() {
        let huge = [Series::new("h", vec![0.0, f64::MAX])];
        assert!(error_over_time("t", &huge, &[], None).to_png().is_err());
        let far = [[0.0, 0.0], [f64::MAX, -f64::MAX]];
        assert!(trajectory_top_down("t", &far, &[], false).to_png().is_err());
    }

    #[test]
    fn single_values_and_zero_errors_draw() -> TestResult {
        let zero = [Series::new("z", vec![0.0])];
        error_cdf("t", &zero, &zero).to_png()?;
        error_over_time("t", &zero, &[], None).to_png()?;
        trajectory_top_down("t", &[[1.0, 1.0]], &[], false).to_png()?;
        Ok(())
    }

    #[test]
    fn significant_digits() {
        assert_eq!(fmt_sig(0.012345), "0.0123");
        assert_eq!(fmt_sig(1.5), "1.5");
        assert_eq!(fmt_sig(12.345), "12.3");
        assert_eq!(fmt_sig(1234.4), "1234");
        assert_eq!(fmt_sig(0.0), "0");
        assert_eq!(fmt_sig(0.25), "0.25");
    }
}
