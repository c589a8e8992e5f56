//! Top-down views of trajectories ([`TopDown`]): the figure's description, its view and
//! equal-aspect height, its checks and thinning into a [`TopDownPlot`], and its drawing.

use crate::chart::{
    Curve, DrawResult, GROUND_TRUTH, Glyph, LINK, PALETTE, TEXT, TOP_DOWN_CHROME, draw_curve,
    equal_aspect_height, legend_strip, map_chart, padded, titled, trajectory_view,
};
use crate::decimate::{MAX_LINKS, clip_polyline, stride_indices, track_segments};
use crate::error::{ReportError, Result};
use crate::series::Track;
use plotters::coord::Shift;
use plotters::prelude::*;
use serde::{Deserialize, Serialize};

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

/// First and last finite point of a track.
type Ends = ((f64, f64), (f64, f64));

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

/// The region a top-down figure shows, see [`trajectory_view`].
fn top_down_view(f: &TopDown) -> Option<[f64; 4]> {
    trajectory_view(
        &f.ground_truth,
        f.estimates.iter().map(|t| t.points.as_slice()),
    )
}

/// Height that gives a top-down figure's view an equal-aspect plot with little white space,
/// between 420 and 1100 pixels.
pub(crate) fn top_down_height(f: &TopDown) -> u32 {
    equal_aspect_height(top_down_view(f), TOP_DOWN_CHROME)
}

fn ends(points: &[[f64; 2]]) -> Option<Ends> {
    let finite = |p: &&[f64; 2]| p[0].is_finite() && p[1].is_finite();
    let first = points.iter().find(finite)?;
    let last = points.iter().rev().find(finite)?;
    Some(((first[0], first[1]), (last[0], last[1])))
}

pub(crate) fn prepare_top_down(f: &TopDown) -> Result<TopDownPlot> {
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

pub(crate) fn draw_top_down<DB: DrawingBackend>(
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

#[cfg(test)]
mod tests {
    use super::*;

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
