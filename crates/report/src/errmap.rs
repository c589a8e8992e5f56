//! Error maps: where along a walk the estimates went wrong, as a top-down view of the ground
//! truth with every estimate coloured by its position error. The figure's description, its view
//! and equal-aspect height, its checks and thinning into an [`ErrorMapPlot`], and its drawing
//! (with the colour bar).

use crate::chart::{
    AXIS, AXIS_DESC_PX, DrawResult, FLOOR_EDGE, FLOOR_FILL, Glyph, LINK, PATH, TEXT, TICK_PX,
    TOP_DOWN_CHROME, equal_aspect_height, fmt_sig, left_out, legend_strip, map_chart, padded, tick,
    titled, trajectory_view,
};
use crate::decimate::{
    MAX_LINKS, MAX_TRACK_POINTS, clip_polyline, quantile_range, stride_indices, track_segments,
};
use crate::error::{ReportError, Result};
use crate::font::FONT;
use plotters::coord::Shift;
use plotters::prelude::*;
use serde::{Deserialize, Serialize};

/// Top-down (x, y) map of one estimated trajectory: the ground truth as a thin grey line, each
/// estimate as a dot coloured by its position error (viridis, with a colour bar in metres),
/// equal aspect ratio, optional error links and an optional floor plan underneath.
///
/// `ground_truth`, `estimates` and `errors_m` hold one entry per frame, in the same order. The
/// errors are given rather than recomputed from the planar points because the report shows the
/// full 3-D position error. Frames whose estimate or error is not finite are left out (the
/// legend says how many). The view fits the trajectories as [`TopDown`](crate::TopDown) does;
/// floor-plan rectangles are clipped to it rather than widening it, so the rooms of a whole
/// building can be passed as context for a walk through one corridor.
///
/// Decimation: at most 4000 dots (uniform stride, the last frame always kept), drawn in order of
/// increasing error so that the worst stay on top, and at most 600 links. The colour scale uses
/// every error.
#[derive(Clone, Debug, Default, PartialEq, Serialize, Deserialize)]
pub struct ErrorMap {
    /// Figure title.
    pub title: String,
    /// Ground-truth camera centres, metres, one per frame.
    pub ground_truth: Vec<[f64; 2]>,
    /// Estimated camera centres, metres, one per frame.
    pub estimates: Vec<[f64; 2]>,
    /// Position error of each frame, metres.
    pub errors_m: Vec<f64>,
    /// The error at the top of the colour scale, metres; larger errors get its colour. `None`
    /// takes the 95th percentile, so that a few gross failures do not squeeze every other error
    /// into the dark end of the scale.
    pub color_max_m: Option<f64>,
    /// Draw a thin line from each ground-truth point to its estimate.
    pub links: bool,
    /// Rectangles `[min_x, min_y, max_x, max_y]`, metres (e.g. rooms or building regions),
    /// drawn as light outlines under the trajectories.
    pub floor_plan: Vec<[f64; 4]>,
}

/// An error map's data after checks, clipping to the view and decimation.
pub(crate) struct ErrorMapPlot {
    pub(crate) title: String,
    pub(crate) ground_truth: Vec<Vec<(f64, f64)>>,
    /// Estimates inside the view with their errors, by increasing error.
    pub(crate) dots: Vec<((f64, f64), f64)>,
    /// Legend text of the dots (clipping of the scale, frames left out).
    pub(crate) dots_label: String,
    pub(crate) links: Vec<[(f64, f64); 2]>,
    /// Floor-plan rectangles cut to the view, `[x0, x1, y0, y1]`, for the fill.
    pub(crate) rooms: Vec<[f64; 4]>,
    /// The visible pieces of the rooms' outlines.
    pub(crate) walls: Vec<Vec<(f64, f64)>>,
    /// The padded view, `[x0, x1, y0, y1]`.
    pub(crate) bounds: [f64; 4],
    /// The error at the top of the colour scale, metres.
    pub(crate) color_max: f64,
    /// Finite estimates outside the view.
    pub(crate) outside: usize,
}

/// The region an error map shows before padding (`None` without a finite point).
fn error_map_view(f: &ErrorMap) -> Option<[f64; 4]> {
    trajectory_view(&f.ground_truth, [f.estimates.as_slice()])
}

pub(crate) fn prepare_error_map(f: &ErrorMap) -> Result<ErrorMapPlot> {
    let n = f.estimates.len();
    if f.ground_truth.len() != n || f.errors_m.len() != n {
        return Err(ReportError::BadInput(format!(
            "error map '{}': {} ground-truth points, {} estimates and {} errors (one of each per \
             frame)",
            f.title,
            f.ground_truth.len(),
            n,
            f.errors_m.len()
        )));
    }
    let finite = |i: usize| {
        let e = f.estimates[i];
        e[0].is_finite() && e[1].is_finite() && f.errors_m[i].is_finite()
    };
    let usable = (0..n).filter(|&i| finite(i)).count();
    if usable == 0 {
        return Err(ReportError::BadInput(format!(
            "error map '{}': no frame with a finite estimate and error ({n} frames)",
            f.title
        )));
    }
    let errors = || (0..n).filter(|&i| finite(i)).map(|i| f.errors_m[i]);
    let color_max = match f.color_max_m {
        Some(m) if m.is_finite() && m > 0.0 => m,
        Some(m) => {
            return Err(ReportError::BadInput(format!(
                "error map '{}': colour scale maximum {m} m is not a positive number",
                f.title
            )));
        }
        None => match quantile_range(errors(), 0.95, 1.0) {
            Some((p95, _)) if p95 > 0.0 => p95,
            Some((_, max)) if max > 0.0 => max,
            // every error is zero: any scale shows that
            _ => 1.0,
        },
    };
    let view = error_map_view(f).ok_or_else(|| {
        ReportError::BadInput(format!("error map '{}': no finite points", f.title))
    })?;
    let rect = padded(view);
    let inside =
        |p: &(f64, f64)| p.0 >= rect[0] && p.0 <= rect[1] && p.1 >= rect[2] && p.1 <= rect[3];
    let at = |i: usize| (f.estimates[i][0], f.estimates[i][1]);
    let outside = (0..n).filter(|&i| finite(i) && !inside(&at(i))).count();
    let mut dots: Vec<((f64, f64), f64)> = stride_indices(n, MAX_TRACK_POINTS)
        .filter(|&i| finite(i) && inside(&at(i)))
        .map(|i| (at(i), f.errors_m[i]))
        .collect();
    dots.sort_by(|a, b| a.1.total_cmp(&b.1));

    let mut links = Vec::new();
    if f.links {
        for i in stride_indices(n, MAX_LINKS) {
            let g = f.ground_truth[i];
            if finite(i) && g[0].is_finite() && g[1].is_finite() {
                for piece in clip_polyline(&[(g[0], g[1]), at(i)], rect) {
                    if let [a, b] = piece[..] {
                        links.push([a, b]);
                    }
                }
            }
        }
    }

    let mut rooms = Vec::new();
    let mut walls = Vec::new();
    for r in f
        .floor_plan
        .iter()
        .filter(|r| r.iter().all(|v| v.is_finite()))
    {
        let (x0, x1) = (r[0].min(r[2]), r[0].max(r[2]));
        let (y0, y1) = (r[1].min(r[3]), r[1].max(r[3]));
        let cut = [
            x0.max(rect[0]),
            x1.min(rect[1]),
            y0.max(rect[2]),
            y1.min(rect[3]),
        ];
        if cut[0] >= cut[1] || cut[2] >= cut[3] {
            continue;
        }
        rooms.push(cut);
        let outline = [(x0, y0), (x1, y0), (x1, y1), (x0, y1), (x0, y0)];
        walls.extend(clip_polyline(&outline, rect));
    }

    let above = errors().filter(|e| *e > color_max).count();
    let scale = match (above, f.color_max_m) {
        (0, _) => String::new(),
        (_, None) => format!(
            "; scale ends at the 95th percentile, {} m",
            fmt_sig(color_max)
        ),
        (_, Some(_)) => format!("; scale ends at {} m", fmt_sig(color_max)),
    };
    Ok(ErrorMapPlot {
        title: f.title.clone(),
        ground_truth: track_segments(&f.ground_truth)
            .iter()
            .flat_map(|s| clip_polyline(s, rect))
            .collect(),
        dots,
        dots_label: format!(
            "estimate, coloured by position error{scale}{}",
            left_out(n - usable)
        ),
        links,
        rooms,
        walls,
        bounds: rect,
        color_max,
        outside,
    })
}

/// Width of an error map's colour bar strip (bar, ticks and axis title), pixels.
const COLOR_BAR_W: i32 = 120;

/// Height of an error map: as a top-down figure's, with the colour bar taking width from the
/// map.
pub(crate) fn error_map_height(f: &ErrorMap) -> u32 {
    let chrome = (
        TOP_DOWN_CHROME.0 + f64::from(COLOR_BAR_W),
        TOP_DOWN_CHROME.1,
    );
    equal_aspect_height(error_map_view(f), chrome)
}

/// The colour of an error on the error map's scale, which ends at `max`.
fn error_color(e: f64, max: f64) -> RGBColor {
    ViridisRGB::get_color_normalized(e.clamp(0.0, max), 0.0, max)
}

pub(crate) fn draw_error_map<DB: DrawingBackend>(
    root: &DrawingArea<DB, Shift>,
    p: &ErrorMapPlot,
) -> DrawResult
where
    DB::ErrorType: 'static,
{
    let area = titled(root, &p.title)?;
    let mut entries = vec![
        ("ground truth".to_string(), Glyph::Line(PATH.to_rgba(), 2)),
        (p.dots_label.clone(), Glyph::Circle(error_color(0.6, 1.0))),
    ];
    if !p.links.is_empty() {
        let label = "error (ground truth → estimate)";
        entries.push((label.into(), Glyph::Line(LINK.mix(0.6), 2)));
    }
    if !p.rooms.is_empty() {
        entries.push(("floor plan".into(), Glyph::Band(FLOOR_EDGE.to_rgba())));
    }
    let area = legend_strip(&area, &entries)?;
    let (w, _) = area.dim_in_pixel();
    let (map_area, bar_area) = area.split_horizontally(w as i32 - COLOR_BAR_W);
    let mut chart = map_chart(&map_area, p.bounds, p.outside)?;

    chart.draw_series(
        p.rooms
            .iter()
            .map(|r| Rectangle::new([(r[0], r[2]), (r[1], r[3])], FLOOR_FILL.filled())),
    )?;
    chart.draw_series(
        p.walls
            .iter()
            .map(|w| PathElement::new(w.clone(), FLOOR_EDGE.stroke_width(1))),
    )?;
    chart.draw_series(
        p.links
            .iter()
            .map(|l| PathElement::new(l.to_vec(), LINK.mix(0.35).stroke_width(1))),
    )?;
    for seg in &p.ground_truth {
        chart.draw_series(LineSeries::new(seg.iter().copied(), PATH.stroke_width(1)))?;
    }
    // a darker rim keeps the light end of the scale visible on white
    let radius = if p.dots.len() > 1500 { 2 } else { 3 };
    chart.draw_series(p.dots.iter().map(|&(at, e)| {
        let c = error_color(e, p.color_max);
        let rim = RGBColor(
            (f64::from(c.0) * 0.7) as u8,
            (f64::from(c.1) * 0.7) as u8,
            (f64::from(c.2) * 0.7) as u8,
        );
        EmptyElement::at(at)
            + Circle::new((0, 0), radius, rim.filled())
            + Circle::new((0, 0), radius - 1, c.filled())
    }))?;
    draw_color_bar(&bar_area, p.color_max)
}

/// A vertical colour bar from 0 to `max` metres, level with the map's plotting area.
fn draw_color_bar<DB: DrawingBackend>(area: &DrawingArea<DB, Shift>, max: f64) -> DrawResult
where
    DB::ErrorType: 'static,
{
    const STEPS: usize = 128;
    let mut chart = ChartBuilder::on(area)
        .margin(10)
        .margin_left(6)
        .x_label_area_size(48)
        .right_y_label_area_size(74)
        .build_cartesian_2d(0.0..1.0, 0.0..max)?;
    chart
        .configure_mesh()
        .disable_mesh()
        .disable_x_axis()
        .axis_style(AXIS)
        .y_desc("position error (m)")
        .axis_desc_style((FONT, AXIS_DESC_PX).into_font().color(&TEXT))
        .label_style((FONT, TICK_PX).into_font().color(&TEXT))
        .y_labels(7)
        .y_label_formatter(&|v: &f64| tick(*v, max))
        .draw()?;
    chart.draw_series((0..STEPS).map(|i| {
        let (lo, hi) = (i as f64 / STEPS as f64, (i + 1) as f64 / STEPS as f64);
        let c = error_color((lo + hi) / 2.0 * max, max);
        Rectangle::new([(0.0, lo * max), (1.0, hi * max)], c.filled())
    }))?;
    chart.draw_series(std::iter::once(Rectangle::new(
        [(0.0, 0.0), (1.0, max)],
        AXIS.stroke_width(1),
    )))?;
    Ok(())
}
