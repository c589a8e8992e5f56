//! Error maps: where along a walk the estimates went wrong, as a top-down view of the ground
//! truth with every estimate coloured by its position error.

use crate::decimate::{
    MAX_LINKS, MAX_TRACK_POINTS, clip_polyline, quantile_range, stride_indices, track_segments,
};
use crate::error::{ReportError, Result};
use crate::figure::{Figure, fmt_sig, left_out, padded, trajectory_view};
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
pub(crate) fn error_map_view(f: &ErrorMap) -> Option<[f64; 4]> {
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

#[cfg(test)]
mod tests {
    use super::*;
    use crate::font::SVG_FONT_STACK;

    type TestResult = std::result::Result<(), Box<dyn std::error::Error>>;

    /// A loop walk with estimates off by a growing amount, and its errors.
    fn walk(n: usize) -> (Vec<[f64; 2]>, Vec<[f64; 2]>, Vec<f64>) {
        let gt: Vec<[f64; 2]> = (0..n)
            .map(|i| {
                let t = i as f64 / n as f64 * std::f64::consts::TAU;
                [12.0 * t.cos(), 5.0 * t.sin()]
            })
            .collect();
        let off: Vec<f64> = (0..n).map(|i| 0.05 + (i % 97) as f64 * 0.01).collect();
        let est = gt.iter().zip(&off).map(|(p, d)| [p[0] + d, p[1]]).collect();
        (gt, est, off)
    }

    fn full_map() -> ErrorMap {
        let (ground_truth, estimates, errors_m) = walk(500);
        ErrorMap {
            title: "Held-out walk".into(),
            ground_truth,
            estimates,
            errors_m,
            links: true,
            floor_plan: vec![[-14.0, -6.0, 0.0, 6.0], [0.0, -6.0, 14.0, 6.0]],
            color_max_m: None,
        }
    }

    #[test]
    fn png_and_svg_are_drawn_at_the_figure_size() -> TestResult {
        let fig = Figure::from(full_map());
        let dir = tempfile::tempdir()?;
        let (svg, png, _) = fig.save_both(dir.path(), "map")?;
        let img = image::open(&png)?;
        assert_eq!((img.width(), img.height()), fig.size());
        assert!(svg.starts_with("<svg") && svg.contains(SVG_FONT_STACK));
        assert!(svg.contains("Held-out walk") && svg.contains("ground truth"));
        // the colour bar and its scale
        assert!(svg.contains("position error (m)"));
        assert!(svg.contains("scale ends at the 95th percentile"));
        assert!(svg.contains("floor plan") && svg.contains("ground truth → estimate"));
        Ok(())
    }

    #[test]
    fn colour_scale_is_clipped_at_the_95th_percentile_or_as_asked() -> TestResult {
        let mut f = full_map();
        let plot = prepare_error_map(&f)?;
        let (p95, _) = quantile_range(f.errors_m.iter().copied(), 0.95, 1.0).unwrap_or_default();
        assert_eq!(plot.color_max, p95);
        // dots run from the smallest to the largest error, worst drawn last
        assert!(plot.dots.windows(2).all(|w| w[0].1 <= w[1].1));
        f.color_max_m = Some(10.0);
        let plot = prepare_error_map(&f)?;
        assert_eq!(plot.color_max, 10.0);
        assert!(!plot.dots_label.contains("scale ends"));
        f.color_max_m = Some(0.0);
        assert!(matches!(
            prepare_error_map(&f),
            Err(ReportError::BadInput(_))
        ));
        Ok(())
    }

    #[test]
    fn floor_plan_is_clipped_to_the_view_not_widening_it() -> TestResult {
        let mut f = full_map();
        let view = prepare_error_map(&f)?.bounds;
        f.floor_plan = vec![[-500.0, -500.0, 500.0, 500.0], [900.0, 900.0, 901.0, 901.0]];
        let plot = prepare_error_map(&f)?;
        assert_eq!(plot.bounds, view);
        assert_eq!(plot.rooms, vec![view]);
        assert!(plot.walls.is_empty());
        Ok(())
    }

    #[test]
    fn long_walks_are_decimated() -> TestResult {
        let (gt, est, err) = walk(100_000);
        let fig = error_map("long", &gt, &est, &err);
        let Figure::ErrorMap(f) = &fig else {
            return Err("not an error map".into());
        };
        let plot = prepare_error_map(f)?;
        assert!(plot.dots.len() <= MAX_TRACK_POINTS + 1);
        fig.to_png()?;
        Ok(())
    }

    #[test]
    fn non_finite_frames_are_left_out() -> TestResult {
        let (gt, mut est, mut err) = walk(50);
        est[3] = [f64::NAN, 0.0];
        err[7] = f64::INFINITY;
        let fig = error_map("t", &gt, &est, &err);
        assert!(fig.to_svg()?.contains("2 non-finite left out"));
        fig.to_png()?;
        Ok(())
    }

    #[test]
    fn bad_input_is_an_error() {
        let (gt, est, err) = walk(10);
        let bad = [
            error_map("t", &[], &[], &[]),
            error_map("t", &gt, &est, &err[1..]),
            error_map("t", &gt[1..], &est, &err),
            error_map("t", &gt, &est, &[f64::NAN; 10]),
            error_map(
                "t",
                &[[0.0, 0.0], [f64::MAX, -f64::MAX]],
                &[[0.0; 2]; 2],
                &[1.0; 2],
            ),
        ];
        for fig in bad {
            crate::figure::assert_rejected(&fig);
        }
    }

    #[test]
    fn single_frames_and_zero_errors_draw() -> TestResult {
        error_map("t", &[[1.0, 1.0]], &[[1.0, 1.0]], &[0.0]).to_png()?;
        let (gt, _, _) = walk(20);
        error_map("t", &gt, &gt, &[0.0; 20]).to_svg()?;
        Ok(())
    }
}
