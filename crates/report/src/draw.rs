//! The drawing code shared by the PNG and SVG backends.

use crate::errmap::{ErrorMap, ErrorMapPlot, error_map_view};
use crate::figure::{
    CdfPlot, Curve, Ends, Panel, Plot, TimePlot, TopDown, TopDownPlot, padded, top_down_view,
};
use crate::font::FONT;
use crate::reliability::ReliabilityPlot;
use crate::scatter::ScatterPlot;
use plotters::coord::Shift;
use plotters::coord::types::RangedCoordf64;
use plotters::prelude::*;
use plotters::style::text_anchor::{HPos, Pos, VPos};

/// What drawing returns: plotters' errors boxed (their type depends on the backend).
pub(crate) type DrawResult<T = ()> = std::result::Result<T, Box<dyn std::error::Error>>;

// Type sizes in pixels at the figure's native size.
const TITLE_PX: f64 = 22.0;
const AXIS_DESC_PX: f64 = 15.0;
const TICK_PX: f64 = 13.0;
const LEGEND_PX: f64 = 13.0;

const TEXT: RGBColor = RGBColor(33, 37, 41);
const AXIS: RGBColor = RGBColor(120, 124, 130);
const GRID: RGBColor = RGBColor(228, 231, 235);
const LEGEND_BORDER: RGBColor = RGBColor(205, 208, 214);
const THRESHOLD: RGBColor = RGBColor(140, 144, 150);
const GROUND_TRUTH: RGBColor = RGBColor(45, 45, 45);
const MARKER: RGBColor = RGBColor(170, 30, 140);
const LINK: RGBColor = RGBColor(214, 39, 40);
/// The ground truth under an error map: thin and grey, so the coloured dots carry the figure.
const PATH: RGBColor = RGBColor(150, 150, 150);
const FLOOR_FILL: RGBColor = RGBColor(246, 246, 243);
const FLOOR_EDGE: RGBColor = RGBColor(196, 198, 202);

/// Tableau 10: distinct, colour-blind-friendlier than the plotters defaults.
const PALETTE: [RGBColor; 10] = [
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
const TOP_DOWN_CHROME: (f64, f64) = (110.0, 155.0);
/// Width of an error map's colour bar strip (bar, ticks and axis title), pixels.
const COLOR_BAR_W: i32 = 120;

/// Height that gives a top-down figure's view an equal-aspect plot with little white space,
/// between 420 and 1100 pixels.
pub(crate) fn top_down_height(f: &TopDown) -> u32 {
    equal_aspect_height(top_down_view(f), TOP_DOWN_CHROME)
}

/// Height of an error map: as a top-down figure's, with the colour bar taking width from the
/// map.
pub(crate) fn error_map_height(f: &ErrorMap) -> u32 {
    let chrome = (
        TOP_DOWN_CHROME.0 + f64::from(COLOR_BAR_W),
        TOP_DOWN_CHROME.1,
    );
    equal_aspect_height(error_map_view(f), chrome)
}

/// Height at [`TOP_DOWN_WIDTH`] that fits `view` (before padding) with equal metres per pixel,
/// given the pixels outside the plotting area, between 420 and 1100 pixels.
fn equal_aspect_height(view: Option<[f64; 4]>, chrome: (f64, f64)) -> u32 {
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

/// Draws a prepared plot on any backend.
///
/// `bitmap` says the backend is plotters' bitmap one, whose wide polylines need care.
pub(crate) fn draw<DB: DrawingBackend>(
    root: &DrawingArea<DB, Shift>,
    plot: &Plot,
    bitmap: bool,
) -> DrawResult
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

fn titled<DB: DrawingBackend>(
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

fn draw_cdf<DB: DrawingBackend>(
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

/// What a legend entry shows before its text.
enum Glyph {
    Line(RGBAColor, u32),
    Band(RGBAColor),
    VLine(RGBAColor),
    Circle(RGBColor),
    Square(RGBColor),
}

/// Draws a centred row (or rows) of legend entries at the top of `area`; returns the rest.
fn legend_strip<DB: DrawingBackend>(
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

fn draw_time<DB: DrawingBackend>(
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

/// Tick text with as many decimals as the tick spacing needs.
fn tick(v: f64, span: f64) -> String {
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

fn draw_panel<DB: DrawingBackend>(
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

type Chart<'a, DB> = ChartContext<'a, DB, Cartesian2d<RangedCoordf64, RangedCoordf64>>;

/// Grid, axes and their titles in the report's style; `labels` ticks on (x, y), each axis's
/// ticks with the decimals its `spans` (x, y) need.
fn draw_mesh<'a, DB: DrawingBackend + 'a>(
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
fn draw_curve<'a, DB: DrawingBackend + 'a>(
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
fn map_chart<'a, DB: DrawingBackend>(
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

fn draw_top_down<DB: DrawingBackend>(
    root: &DrawingArea<DB, Shift>,
    p: &TopDownPlot,
    bitmap: bool,
) -> DrawResult
where
    DB::ErrorType: 'static,
{
    let area = titled(root, &p.title)?;
    // the legend goes above the plot: a trajectory can fill every corner of it
    let mut entries = vec![(
        "ground truth".to_string(),
        Glyph::Line(GROUND_TRUTH.to_rgba(), 3),
    )];
    for (i, (c, _)) in p.estimates.iter().enumerate() {
        let color = PALETTE[i % PALETTE.len()].to_rgba();
        entries.push((c.label.clone(), Glyph::Line(color, 3)));
    }
    if !p.links.is_empty() {
        let label = "error (ground truth → estimate)";
        entries.push((label.into(), Glyph::Line(LINK.mix(0.6), 2)));
    }
    if p.gt_ends.is_some() || p.estimates.iter().any(|(_, e)| e.is_some()) {
        entries.push(("start".into(), Glyph::Circle(TEXT)));
        entries.push(("end".into(), Glyph::Square(TEXT)));
    }
    let area = legend_strip(&area, &entries)?;
    let mut chart = map_chart(&area, p.bounds, p.outside)?;

    if !p.links.is_empty() {
        chart.draw_series(
            p.links
                .iter()
                .map(|l| PathElement::new(l.to_vec(), LINK.mix(0.3).stroke_width(1))),
        )?;
    }
    // estimates under the ground truth: where they agree the dark line covers them, where
    // they part the colour shows
    for (i, (curve, _)) in p.estimates.iter().enumerate() {
        let points: usize = curve.segments.iter().map(Vec::len).sum();
        let width = if points > 1500 { 1 } else { 2 };
        draw_curve(&mut chart, curve, PALETTE[i % PALETTE.len()], width, bitmap)?;
    }
    let gt = Curve {
        label: "ground truth".into(),
        segments: p.ground_truth.clone(),
        band: Vec::new(),
    };
    draw_curve(&mut chart, &gt, GROUND_TRUTH, 2, bitmap)?;

    // ground-truth markers last, on top of estimates that start at the same place
    let ends: Vec<(Ends, RGBColor)> = p
        .estimates
        .iter()
        .enumerate()
        .filter_map(|(i, (_, e))| e.map(|e| (e, PALETTE[i % PALETTE.len()])))
        .chain(p.gt_ends.map(|e| (e, GROUND_TRUTH)))
        .collect();
    if !ends.is_empty() {
        chart.draw_series(ends.iter().map(|&((s, _), c)| {
            EmptyElement::at(s)
                + Circle::new((0, 0), 8, WHITE.filled())
                + Circle::new((0, 0), 6, c.filled())
        }))?;
        chart.draw_series(ends.iter().map(|&((_, e), c)| {
            EmptyElement::at(e)
                + Rectangle::new([(-7, -7), (7, 7)], WHITE.filled())
                + Rectangle::new([(-5, -5), (5, 5)], c.filled())
        }))?;
    }
    Ok(())
}

/// The colour of an error on the error map's scale, which ends at `max`.
fn error_color(e: f64, max: f64) -> RGBColor {
    ViridisRGB::get_color_normalized(e.clamp(0.0, max), 0.0, max)
}

fn draw_error_map<DB: DrawingBackend>(root: &DrawingArea<DB, Shift>, p: &ErrorMapPlot) -> DrawResult
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

fn draw_scatter<DB: DrawingBackend>(root: &DrawingArea<DB, Shift>, p: &ScatterPlot) -> DrawResult
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

fn draw_reliability<DB: DrawingBackend>(
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
    fn top_down_height_follows_aspect() {
        let wide = TopDown {
            ground_truth: vec![[0.0, 0.0], [100.0, 10.0]],
            ..TopDown::default()
        };
        let tall = TopDown {
            ground_truth: vec![[0.0, 0.0], [10.0, 100.0]],
            ..TopDown::default()
        };
        assert_eq!(top_down_height(&wide), 420);
        assert_eq!(top_down_height(&tall), 1100);
        assert!((420..=1100).contains(&top_down_height(&TopDown::default())));
    }
}
