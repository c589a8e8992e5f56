//! The drawing kit every figure shares: the report's plot style (type sizes, colours, the
//! palette), the prepared shapes the shared helpers draw ([`Curve`], [`Panel`]), number formatting
//! for labels and legends, the view and equal-aspect height of a map of trajectories, the plotters
//! helpers (titles, legend strips, axes, panels of curves, map charts) and PNG encoding.
//!
//! It sits below the figure kinds (`cdf`, `over_time`, `top_down`, `errmap`, `scatter`,
//! `reliability`) and the pictures (`confusion`, `rhythm`, `sheet`), which import from it; it
//! imports none of them, so the kinds share it without depending on each other or on `figure`.

use crate::decimate::quantile_range;
use crate::font::FONT;
use plotters::coord::Shift;
use plotters::coord::types::RangedCoordf64;
use plotters::prelude::*;
use plotters::style::text_anchor::{HPos, Pos, VPos};

/// What drawing returns: plotters' errors boxed (their type depends on the backend).
pub(crate) type DrawResult<T = ()> = std::result::Result<T, Box<dyn std::error::Error>>;

// Type sizes in pixels at the figure's native size.
const TITLE_PX: f64 = 22.0;
pub(crate) const AXIS_DESC_PX: f64 = 15.0;
pub(crate) const TICK_PX: f64 = 13.0;
const LEGEND_PX: f64 = 13.0;

pub(crate) const TEXT: RGBColor = RGBColor(33, 37, 41);
pub(crate) const AXIS: RGBColor = RGBColor(120, 124, 130);
const GRID: RGBColor = RGBColor(228, 231, 235);
const LEGEND_BORDER: RGBColor = RGBColor(205, 208, 214);
const THRESHOLD: RGBColor = RGBColor(140, 144, 150);
pub(crate) const GROUND_TRUTH: RGBColor = RGBColor(45, 45, 45);
pub(crate) const MARKER: RGBColor = RGBColor(170, 30, 140);
pub(crate) const LINK: RGBColor = RGBColor(214, 39, 40);
/// The ground truth under an error map: thin and grey, so the coloured dots carry the figure.
pub(crate) const PATH: RGBColor = RGBColor(150, 150, 150);
pub(crate) const FLOOR_FILL: RGBColor = RGBColor(246, 246, 243);
pub(crate) const FLOOR_EDGE: RGBColor = RGBColor(196, 198, 202);

/// Tableau 10: distinct, colour-blind-friendlier than the plotters defaults.
pub(crate) const PALETTE: [RGBColor; 10] = [
    RGBColor(31, 119, 180),
    RGBColor(255, 127, 14),
    RGBColor(44, 160, 44),
    RGBColor(214, 39, 40),
    RGBColor(148, 103, 189),
    RGBColor(140, 86, 75),
    RGBColor(227, 119, 194),
    RGBColor(127, 127, 127),
    RGBColor(188, 189, 34),
    RGBColor(23, 190, 207),
];

/// Width of top-down figures, pixels.
pub(crate) const TOP_DOWN_WIDTH: u32 = 1000;
/// Pixels of a top-down figure outside its plotting area: (horizontal, vertical).
pub(crate) const TOP_DOWN_CHROME: (f64, f64) = (110.0, 155.0);

// The prepared shapes the helpers draw.

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

// Numbers and notes in labels and legends.

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

/// The legend note for `dropped` non-finite values left out of a plot (empty when none).
pub(crate) fn left_out(dropped: usize) -> String {
    match dropped {
        0 => String::new(),
        n => format!(", {n} non-finite left out"),
    }
}

/// A space between a number and its unit, none before a degree sign.
pub(crate) fn sep(unit: &str) -> &'static str {
    if unit == "°" { "" } else { " " }
}

// The view of a map of trajectories.

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

/// Height at [`TOP_DOWN_WIDTH`] that fits `view` (before padding) with equal metres per pixel,
/// given the pixels outside the plotting area, between 420 and 1100 pixels.
pub(crate) fn equal_aspect_height(view: Option<[f64; 4]>, chrome: (f64, f64)) -> u32 {
    let Some(b) = view.map(padded) else {
        return TOP_DOWN_WIDTH;
    };
    let plot_w = f64::from(TOP_DOWN_WIDTH) - chrome.0;
    let h = plot_w * (b[3] - b[2]) / (b[1] - b[0]) + chrome.1;
    if h.is_finite() {
        h.clamp(420.0, 1100.0) as u32
    } else {
        TOP_DOWN_WIDTH
    }
}

// Drawing on any plotters backend.

/// `root` with the figure's outer margins, under `title` (none when it is empty).
pub(crate) fn titled<DB: DrawingBackend>(
    root: &DrawingArea<DB, Shift>,
    title: &str,
) -> DrawResult<DrawingArea<DB, Shift>>
where
    DB::ErrorType: 'static,
{
    let area = root.margin(12, 6, 6, 6);
    if title.is_empty() {
        return Ok(area);
    }
    Ok(area.titled(
        title,
        (FONT, TITLE_PX, FontStyle::Bold).into_font().color(&TEXT),
    )?)
}

/// What a legend entry shows before its text.
pub(crate) enum Glyph {
    Line(RGBAColor, u32),
    Band(RGBAColor),
    VLine(RGBAColor),
    Circle(RGBColor),
    Square(RGBColor),
}

/// Draws a centred row (or rows) of legend entries at the top of `area`; returns the rest.
pub(crate) fn legend_strip<DB: DrawingBackend>(
    area: &DrawingArea<DB, Shift>,
    entries: &[(String, Glyph)],
) -> DrawResult<DrawingArea<DB, Shift>>
where
    DB::ErrorType: 'static,
{
    const GLYPH_W: i32 = 22;
    const TEXT_GAP: i32 = 6;
    const ENTRY_GAP: i32 = 26;
    const ROW_H: i32 = 22;
    if entries.is_empty() {
        return Ok(area.clone());
    }
    let font = (FONT, LEGEND_PX).into_font().color(&TEXT);
    let (width, _) = area.dim_in_pixel();
    let max_w = width as i32 - 40;
    // greedy rows of (entry index, entry width)
    let mut rows: Vec<Vec<(usize, i32)>> = vec![Vec::new()];
    let mut row_w = 0;
    for (i, (label, _)) in entries.iter().enumerate() {
        let (tw, _) = area.estimate_text_size(label, &font)?;
        let w = GLYPH_W + TEXT_GAP + tw as i32;
        let extra = if row_w == 0 { w } else { ENTRY_GAP + w };
        if row_w > 0 && row_w + extra > max_w {
            rows.push(Vec::new());
            row_w = 0;
        }
        row_w += if row_w == 0 { w } else { ENTRY_GAP + w };
        if let Some(row) = rows.last_mut() {
            row.push((i, w));
        }
    }
    let (strip, rest) = area.split_vertically(ROW_H * rows.len() as i32 + 8);
    let style = font.pos(Pos::new(HPos::Left, VPos::Center));
    for (r, row) in rows.iter().enumerate() {
        let total: i32 =
            row.iter().map(|(_, w)| w).sum::<i32>() + ENTRY_GAP * (row.len() as i32 - 1);
        let mut x = (width as i32 - total) / 2;
        let y = ROW_H * r as i32 + ROW_H / 2 + 2;
        for &(i, w) in row {
            let (label, glyph) = &entries[i];
            let (a, b) = ((x, y), (x + GLYPH_W, y));
            let mid = x + GLYPH_W / 2;
            match glyph {
                Glyph::Line(c, w) => {
                    strip.draw(&PathElement::new(vec![a, b], c.stroke_width(*w)))?
                }
                Glyph::Band(c) => strip.draw(&Rectangle::new(
                    [(x, y - 6), (x + GLYPH_W, y + 6)],
                    c.filled(),
                ))?,
                Glyph::VLine(c) => strip.draw(&PathElement::new(
                    vec![(mid, y - 8), (mid, y + 8)],
                    c.stroke_width(2),
                ))?,
                Glyph::Circle(c) => strip.draw(&Circle::new((mid, y), 6, c.filled()))?,
                Glyph::Square(c) => strip.draw(&Rectangle::new(
                    [(mid - 5, y - 5), (mid + 5, y + 5)],
                    c.filled(),
                ))?,
            }
            strip.draw_text(label, &style, (x + GLYPH_W + TEXT_GAP, y))?;
            x += w + ENTRY_GAP;
        }
    }
    Ok(rest)
}

/// Tick text with as many decimals as the tick spacing needs.
pub(crate) fn tick(v: f64, span: f64) -> String {
    let step = span / 8.0;
    let decimals = if step > 0.0 && step.is_finite() {
        (-step.log10().floor()).clamp(0.0, 6.0) as usize
    } else {
        2
    };
    let s = format!("{v:.decimals$}");
    // "-0" and "-0.0" read as noise
    if s.trim_start_matches('-')
        .chars()
        .all(|c| c == '0' || c == '.')
    {
        s.trim_start_matches('-').to_string()
    } else {
        s
    }
}

/// Draws a panel of curves on `area`: axes, dashed thresholds labelled above the plot, the
/// curves in palette order, vertical `markers` on top, and a legend at `legend_at` when a curve
/// has a label. `width` is the line width; `bitmap` says the backend is plotters' bitmap one,
/// whose wide polylines are drawn segment by segment.
pub(crate) fn draw_panel<DB: DrawingBackend>(
    area: &DrawingArea<DB, Shift>,
    p: &Panel,
    legend_at: Option<SeriesLabelPosition>,
    markers: &[f64],
    (width, bitmap): (u32, bool),
) -> DrawResult
where
    DB::ErrorType: 'static,
{
    let mut builder = ChartBuilder::on(area);
    builder
        .margin(8)
        .margin_right(24)
        .x_label_area_size(48)
        .y_label_area_size(68);
    let (x0, x1) = p.x_range;
    // threshold labels sit above the plot, in as many rows as they need not to overlap
    let label_font = (FONT, TICK_PX).into_font().color(&THRESHOLD);
    let (area_w, _) = area.dim_in_pixel();
    let plot_w = f64::from(area_w) - (8.0 + 24.0 + 68.0);
    let mut dys: Vec<i32> = Vec::new();
    let mut row_ends: Vec<i32> = Vec::new();
    for (t, label) in &p.thresholds {
        let (w, _) = area.estimate_text_size(label, &label_font)?;
        let centre = ((t - x0) / (x1 - x0) * plot_w) as i32;
        let (left, right) = (centre - w as i32 / 2, centre + w as i32 / 2);
        let row = match row_ends.iter().position(|&end| left > end + 6) {
            Some(r) => r,
            None => {
                row_ends.push(i32::MIN);
                row_ends.len() - 1
            }
        };
        row_ends[row] = right;
        dys.push(-5 - 15 * row as i32);
    }
    if !row_ends.is_empty() {
        // at least two rows, so that side-by-side panels keep the same height
        builder.margin_top(11 + 15 * row_ends.len().max(2) as u32);
    }
    let (y0, y1) = p.y_range;
    let mut chart = builder.build_cartesian_2d(x0..x1, y0..y1)?;
    let descs = (p.x_desc.as_str(), p.y_desc.as_str());
    draw_mesh(&mut chart, descs, (9, 7), (x1 - x0, y1 - y0))?;

    let mut labelled = false;
    for ((t, label), dy) in p.thresholds.iter().zip(&dys) {
        chart.draw_series(DashedLineSeries::new(
            vec![(*t, y0), (*t, y1)],
            6,
            4,
            THRESHOLD.stroke_width(1),
        ))?;
        let style = label_font.pos(Pos::new(HPos::Center, VPos::Bottom));
        chart.draw_series(std::iter::once(
            EmptyElement::at((*t, y1)) + Text::new(label.clone(), (0, *dy), style),
        ))?;
    }
    for (i, curve) in p.curves.iter().enumerate() {
        let color = PALETTE[i % PALETTE.len()];
        labelled |= draw_curve(&mut chart, curve, color, width, bitmap)?;
    }
    // scene cuts on top of the data, or dense data would hide them
    if !markers.is_empty() {
        let style = MARKER.mix(0.7).stroke_width(1);
        chart.draw_series(
            markers
                .iter()
                .map(|&m| PathElement::new(vec![(m, y0), (m, y1)], style)),
        )?;
    }
    if let (true, Some(at)) = (labelled, legend_at) {
        legend(&mut chart, at)?;
    }
    Ok(())
}

pub(crate) type Chart<'a, DB> = ChartContext<'a, DB, Cartesian2d<RangedCoordf64, RangedCoordf64>>;

/// Grid, axes and their titles in the report's style; `labels` ticks on (x, y), each axis's
/// ticks with the decimals its `spans` (x, y) need.
pub(crate) fn draw_mesh<'a, DB: DrawingBackend + 'a>(
    chart: &mut Chart<'a, DB>,
    (x_desc, y_desc): (&str, &str),
    labels: (usize, usize),
    spans: (f64, f64),
) -> DrawResult
where
    DB::ErrorType: 'static,
{
    let fx = |v: &f64| tick(*v, spans.0);
    let fy = |v: &f64| tick(*v, spans.1);
    chart
        .configure_mesh()
        .light_line_style(TRANSPARENT)
        .bold_line_style(GRID)
        .axis_style(AXIS)
        .x_desc(x_desc)
        .y_desc(y_desc)
        .axis_desc_style((FONT, AXIS_DESC_PX).into_font().color(&TEXT))
        .label_style((FONT, TICK_PX).into_font().color(&TEXT))
        .x_labels(labels.0)
        .y_labels(labels.1)
        .x_label_formatter(&fx)
        .y_label_formatter(&fy)
        .draw()?;
    Ok(())
}

/// Draws every segment of a curve, labelling the first; true when it added a legend entry.
pub(crate) fn draw_curve<'a, DB: DrawingBackend + 'a>(
    chart: &mut Chart<'a, DB>,
    curve: &Curve,
    color: RGBColor,
    width: u32,
    bitmap: bool,
) -> DrawResult<bool>
where
    DB::ErrorType: 'static,
{
    let style = color.stroke_width(width);
    let band = color.mix(0.3).stroke_width(1);
    for seg in &curve.band {
        chart.draw_series(LineSeries::new(seg.iter().copied(), band))?;
    }
    let style = if curve.band.is_empty() {
        style
    } else {
        color.stroke_width(2)
    };
    let width = style.stroke_width;
    let mut labelled = false;
    for (k, seg) in curve.segments.iter().enumerate() {
        let drawn = if bitmap && width > 1 {
            // plotters' bitmap backend joins wide polylines with unbounded miters, so a sharp
            // turn shoots a spike across the image: draw such lines segment by segment
            chart.draw_series(
                seg.windows(2)
                    .map(|w| PathElement::new(vec![w[0], w[1]], style)),
            )?
        } else {
            chart.draw_series(LineSeries::new(seg.iter().copied(), style))?
        };
        if k == 0 && !curve.label.is_empty() {
            drawn.label(curve.label.as_str()).legend(move |(x, y)| {
                PathElement::new(vec![(x, y), (x + 18, y)], color.stroke_width(3))
            });
            labelled = true;
        }
    }
    Ok(labelled)
}

fn legend<'a, DB: DrawingBackend + 'a>(
    chart: &mut Chart<'a, DB>,
    at: SeriesLabelPosition,
) -> DrawResult
where
    DB::ErrorType: 'static,
{
    chart
        .configure_series_labels()
        .position(at)
        .margin(12)
        .legend_area_size(26)
        .background_style(WHITE.mix(0.92))
        .border_style(LEGEND_BORDER)
        .label_font((FONT, LEGEND_PX).into_font().color(&TEXT))
        .draw()?;
    Ok(())
}

fn top_down_builder<'a, 'b, DB: DrawingBackend>(
    area: &'a DrawingArea<DB, Shift>,
) -> ChartBuilder<'a, 'b, DB> {
    let mut builder = ChartBuilder::on(area);
    builder
        .margin(10)
        .margin_right(28)
        .x_label_area_size(48)
        .y_label_area_size(68);
    builder
}

/// A chart on `area` that shows at least `b` = `[x0, x1, y0, y1]` with equal metres per pixel
/// on x and y, with its grid and axes drawn; the x axis title says how many of the estimates
/// lie `outside` the view.
pub(crate) fn map_chart<'a, DB: DrawingBackend>(
    area: &'a DrawingArea<DB, Shift>,
    b: [f64; 4],
    outside: usize,
) -> DrawResult<Chart<'a, DB>>
where
    DB::ErrorType: 'static,
{
    // build once to measure the plotting area, then again with the view widened to its aspect
    let (w, h) = top_down_builder(area)
        .build_cartesian_2d(0.0..1.0, 0.0..1.0)?
        .plotting_area()
        .dim_in_pixel();
    let (sx, sy) = (b[1] - b[0], b[3] - b[2]);
    let (w, h) = (f64::from(w.max(1)), f64::from(h.max(1)));
    let metres_per_px = (sx / w).max(sy / h);
    let (cx, cy) = ((b[0] + b[1]) / 2.0, (b[2] + b[3]) / 2.0);
    let (hx, hy) = (metres_per_px * w / 2.0, metres_per_px * h / 2.0);
    let (x0, x1, y0, y1) = (cx - hx, cx + hx, cy - hy, cy + hy);
    let mut chart = top_down_builder(area).build_cartesian_2d(x0..x1, y0..y1)?;
    let span = (x1 - x0).max(y1 - y0);
    let x_desc = match outside {
        0 => "x (m)".to_string(),
        1 => "x (m)   (1 estimated position lies outside the view)".to_string(),
        n => format!("x (m)   ({n} estimated positions lie outside the view)"),
    };
    draw_mesh(&mut chart, (&x_desc, "y (m)"), (10, 10), (span, span))?;
    Ok(chart)
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

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn ticks_follow_spacing() {
        assert_eq!(tick(0.5, 1.0), "0.5");
        assert_eq!(tick(20000.0, 100_000.0), "20000");
        assert_eq!(tick(-0.0001, 1.0), "0.0");
        assert_eq!(tick(0.25, 0.5), "0.25");
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
