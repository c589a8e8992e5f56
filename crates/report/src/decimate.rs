//! Thinning of long inputs before drawing, so that a figure of 100 000 frames renders in
//! milliseconds and its SVG stays small, while looking the same as the full plot at its size.

/// At most this many points draw a cumulative distribution (evenly spaced ranks); below it every
/// value makes its own step.
pub(crate) const MAX_CDF_POINTS: usize = 2000;
/// Longer time series are cut into this many buckets (about one per pixel column) and each
/// bucket keeps its minimum and maximum, in frame order.
pub(crate) const MAX_TIME_BUCKETS: usize = 1200;
/// At most this many points per trajectory (uniform stride, the last point always kept).
pub(crate) const MAX_TRACK_POINTS: usize = 4000;
/// At most this many points in a scatter plot (uniform stride); more only darken the cloud.
pub(crate) const MAX_SCATTER_POINTS: usize = 5000;
/// At most this many error links (ground truth → estimate) in a top-down plot.
pub(crate) const MAX_LINKS: usize = 600;

/// Points of the empirical CDF of ascending, finite `sorted` values, `y` as a fraction 0–1.
/// Exact steps for up to [`MAX_CDF_POINTS`] values, otherwise that many evenly spaced quantiles.
pub(crate) fn cdf_points(sorted: &[f64]) -> Vec<(f64, f64)> {
    let n = sorted.len();
    if n == 0 {
        return Vec::new();
    }
    let nf = n as f64;
    if n <= MAX_CDF_POINTS {
        let mut pts = Vec::with_capacity(2 * n);
        for (i, &v) in sorted.iter().enumerate() {
            pts.push((v, i as f64 / nf));
            pts.push((v, (i + 1) as f64 / nf));
        }
        return pts;
    }
    let k = MAX_CDF_POINTS;
    let mut pts = Vec::with_capacity(k + 2);
    pts.push((sorted[0], 0.0));
    for j in 0..=k {
        // rank j/k of the way through, rounded to the nearest sample
        let r = ((j as f64 / k as f64) * (n - 1) as f64).round() as usize;
        pts.push((sorted[r], (r + 1) as f64 / nf));
    }
    pts
}

/// Cuts a polyline at `x_max`, interpolating the crossing point (the curve is monotone in x).
pub(crate) fn clip_x(points: &[(f64, f64)], x_max: f64) -> Vec<(f64, f64)> {
    let mut out = Vec::with_capacity(points.len() + 1);
    for (i, &(x, y)) in points.iter().enumerate() {
        if x <= x_max {
            out.push((x, y));
            continue;
        }
        if let Some(&(x0, y0)) = i.checked_sub(1).and_then(|j| points.get(j)) {
            let t = if x > x0 { (x_max - x0) / (x - x0) } else { 0.0 };
            out.push((x_max, y0 + (y - y0) * t));
        }
        return out;
    }
    // the curve ended inside the axis: carry its last level to the right edge
    if let Some(&(x, y)) = out.last()
        && x < x_max
    {
        out.push((x_max, y));
    }
    out
}

/// `(frame, value)` polylines of a time series: the raw values when short, else the min and max
/// of each of [`MAX_TIME_BUCKETS`] buckets in the order they occur (which draws like the full
/// series at one bucket per pixel). Non-finite values break the line.
pub(crate) fn envelope(values: &[f64]) -> Vec<Vec<(f64, f64)>> {
    let n = values.len();
    let mut segments = Vec::new();
    let mut current: Vec<(f64, f64)> = Vec::new();
    let flush = |current: &mut Vec<(f64, f64)>, segments: &mut Vec<Vec<(f64, f64)>>| {
        if !current.is_empty() {
            segments.push(std::mem::take(current));
        }
    };
    if n <= 2 * MAX_TIME_BUCKETS {
        for (i, &v) in values.iter().enumerate() {
            if v.is_finite() {
                current.push((i as f64, v));
            } else {
                flush(&mut current, &mut segments);
            }
        }
        flush(&mut current, &mut segments);
        return segments;
    }
    let b = MAX_TIME_BUCKETS;
    for k in 0..b {
        let (lo, hi) = (k * n / b, (k + 1) * n / b);
        let mut min: Option<(usize, f64)> = None;
        let mut max: Option<(usize, f64)> = None;
        for (i, &v) in values.iter().enumerate().take(hi).skip(lo) {
            if !v.is_finite() {
                continue;
            }
            if min.is_none_or(|(_, m)| v < m) {
                min = Some((i, v));
            }
            if max.is_none_or(|(_, m)| v > m) {
                max = Some((i, v));
            }
        }
        match (min, max) {
            (Some(a), Some(z)) => {
                let (first, second) = if a.0 <= z.0 { (a, z) } else { (z, a) };
                current.push((first.0 as f64, first.1));
                if second.0 != first.0 {
                    current.push((second.0 as f64, second.1));
                }
            }
            _ => flush(&mut current, &mut segments),
        }
    }
    flush(&mut current, &mut segments);
    segments
}

/// A decimated time series gets a trend line through the medians of this many frame buckets
/// (about one per 4 pixels), over the min–max band of [`envelope`].
pub(crate) const MEDIAN_BUCKETS: usize = 300;

/// The median of each of [`MEDIAN_BUCKETS`] frame buckets, at the bucket's middle frame, when
/// the series is long enough for [`envelope`] to decimate it (`None` otherwise). Buckets without a
/// finite value break the line.
pub(crate) fn bucket_medians(values: &[f64]) -> Option<Vec<Vec<(f64, f64)>>> {
    let n = values.len();
    if n <= 2 * MAX_TIME_BUCKETS {
        return None;
    }
    let b = MEDIAN_BUCKETS;
    let mut segments = Vec::new();
    let mut current = Vec::new();
    let mut scratch = Vec::with_capacity(n / b + 1);
    for k in 0..b {
        let (lo, hi) = (k * n / b, (k + 1) * n / b);
        scratch.clear();
        scratch.extend(values[lo..hi].iter().copied().filter(|v| v.is_finite()));
        if scratch.is_empty() {
            if !current.is_empty() {
                segments.push(std::mem::take(&mut current));
            }
            continue;
        }
        let mid = scratch.len() / 2;
        let median = *scratch.select_nth_unstable_by(mid, f64::total_cmp).1;
        current.push(((lo + hi - 1) as f64 / 2.0, median));
    }
    if !current.is_empty() {
        segments.push(current);
    }
    Some(segments)
}

/// Indices `0, s, 2s, …` and the last one, with the stride `s` chosen so that at most about
/// `max` indices come out.
pub(crate) fn stride_indices(n: usize, max: usize) -> impl Iterator<Item = usize> {
    let stride = n.div_ceil(max.max(1)).max(1);
    let last = n.checked_sub(1);
    (0..n)
        .step_by(stride)
        .chain(last.filter(|l| l % stride != 0))
}

/// Polylines through the finite points among every `stride`-th point of `points`; a
/// non-finite point breaks the line.
pub(crate) fn track_segments(points: &[[f64; 2]]) -> Vec<Vec<(f64, f64)>> {
    let mut segments = Vec::new();
    let mut current = Vec::new();
    for i in stride_indices(points.len(), MAX_TRACK_POINTS) {
        let [x, y] = points[i];
        if x.is_finite() && y.is_finite() {
            current.push((x, y));
        } else if !current.is_empty() {
            segments.push(std::mem::take(&mut current));
        }
    }
    if !current.is_empty() {
        segments.push(current);
    }
    segments
}

/// The part of segment `a → b` inside `rect` = `[x0, x1, y0, y1]` (Liang–Barsky).
fn clip_segment(a: (f64, f64), b: (f64, f64), rect: [f64; 4]) -> Option<((f64, f64), (f64, f64))> {
    let (dx, dy) = (b.0 - a.0, b.1 - a.1);
    let (mut t0, mut t1) = (0.0f64, 1.0f64);
    for (p, q) in [
        (-dx, a.0 - rect[0]),
        (dx, rect[1] - a.0),
        (-dy, a.1 - rect[2]),
        (dy, rect[3] - a.1),
    ] {
        if p == 0.0 {
            if q < 0.0 {
                return None;
            }
        } else {
            let t = q / p;
            if p < 0.0 {
                t0 = t0.max(t);
            } else {
                t1 = t1.min(t);
            }
        }
    }
    (t0 <= t1).then_some((
        (a.0 + t0 * dx, a.1 + t0 * dy),
        (a.0 + t1 * dx, a.1 + t1 * dy),
    ))
}

/// The pieces of a polyline inside `rect` = `[x0, x1, y0, y1]` (plotters does not clip lines
/// to the plotting area, so everything that may leave it is clipped here).
pub(crate) fn clip_polyline(points: &[(f64, f64)], rect: [f64; 4]) -> Vec<Vec<(f64, f64)>> {
    let inside =
        |p: &(f64, f64)| p.0 >= rect[0] && p.0 <= rect[1] && p.1 >= rect[2] && p.1 <= rect[3];
    if points.len() == 1 {
        return if inside(&points[0]) {
            vec![points.to_vec()]
        } else {
            Vec::new()
        };
    }
    let mut pieces = Vec::new();
    let mut current: Vec<(f64, f64)> = Vec::new();
    for w in points.windows(2) {
        match clip_segment(w[0], w[1], rect) {
            Some((a, b)) => {
                if current.last() != Some(&a) {
                    if current.len() > 1 {
                        pieces.push(std::mem::take(&mut current));
                    }
                    current.clear();
                    current.push(a);
                }
                current.push(b);
            }
            None => {
                if current.len() > 1 {
                    pieces.push(std::mem::take(&mut current));
                }
                current.clear();
            }
        }
    }
    if current.len() > 1 {
        pieces.push(current);
    }
    pieces
}

/// Low and high quantiles (fractions 0–1) of the finite values, `None` when there are none.
pub(crate) fn quantile_range(
    values: impl Iterator<Item = f64>,
    lo: f64,
    hi: f64,
) -> Option<(f64, f64)> {
    let mut v: Vec<f64> = values.filter(|x| x.is_finite()).collect();
    if v.is_empty() {
        return None;
    }
    let n = v.len();
    let rank = |q: f64| ((q.clamp(0.0, 1.0) * (n - 1) as f64).round() as usize).min(n - 1);
    let (rl, rh) = (rank(lo), rank(hi));
    let low = *v.select_nth_unstable_by(rl, f64::total_cmp).1;
    let high = *v.select_nth_unstable_by(rh, f64::total_cmp).1;
    Some((low, high))
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn small_cdf_is_exact_steps() {
        let pts = cdf_points(&[1.0, 2.0]);
        assert_eq!(pts, vec![(1.0, 0.0), (1.0, 0.5), (2.0, 0.5), (2.0, 1.0)]);
        assert!(cdf_points(&[]).is_empty());
    }

    #[test]
    fn large_cdf_is_bounded_and_ends_at_one() {
        let v: Vec<f64> = (0..100_000).map(f64::from).collect();
        let pts = cdf_points(&v);
        assert!(pts.len() <= MAX_CDF_POINTS + 2);
        assert_eq!(pts.last(), Some(&(99_999.0, 1.0)));
        assert!(pts.windows(2).all(|w| w[0].0 <= w[1].0 && w[0].1 <= w[1].1));
    }

    #[test]
    fn clipping_interpolates_and_extends() {
        let pts = [(0.0, 0.0), (2.0, 1.0)];
        assert_eq!(clip_x(&pts, 1.0), vec![(0.0, 0.0), (1.0, 0.5)]);
        assert_eq!(clip_x(&pts, 3.0), vec![(0.0, 0.0), (2.0, 1.0), (3.0, 1.0)]);
    }

    #[test]
    fn envelope_keeps_extremes_and_breaks_at_nan() {
        let mut v = vec![1.0; 100_000];
        v[54_321] = 9.0;
        v[70_000..80_000].iter_mut().for_each(|x| *x = f64::NAN);
        let segs = envelope(&v);
        assert_eq!(segs.len(), 2);
        let pts: usize = segs.iter().map(Vec::len).sum();
        assert!(pts <= 2 * MAX_TIME_BUCKETS);
        assert!(segs[0].contains(&(54_321.0, 9.0)));
        assert_eq!(envelope(&[1.0, f64::NAN, 2.0]).len(), 2);
    }

    #[test]
    fn polylines_are_clipped_to_the_rectangle() {
        let rect = [0.0, 10.0, 0.0, 10.0];
        let pts = [(5.0, 5.0), (15.0, 5.0), (15.0, 6.0), (5.0, 6.0), (6.0, 7.0)];
        let pieces = clip_polyline(&pts, rect);
        assert_eq!(
            pieces,
            vec![
                vec![(5.0, 5.0), (10.0, 5.0)],
                vec![(10.0, 6.0), (5.0, 6.0), (6.0, 7.0)]
            ]
        );
        assert!(clip_polyline(&[(20.0, 20.0), (30.0, 30.0)], rect).is_empty());
        assert_eq!(clip_polyline(&[(1.0, 1.0)], rect).len(), 1);
        assert!(clip_polyline(&[(11.0, 1.0)], rect).is_empty());
    }

    #[test]
    fn quantiles_ignore_nan() {
        let v = [3.0, f64::NAN, 1.0, 2.0, 100.0];
        assert_eq!(quantile_range(v.into_iter(), 0.0, 1.0), Some((1.0, 100.0)));
        assert_eq!(quantile_range(v.into_iter(), 0.0, 0.6), Some((1.0, 3.0)));
        assert_eq!(quantile_range([f64::NAN].into_iter(), 0.0, 1.0), None);
    }

    #[test]
    fn medians_only_for_long_series() {
        assert!(bucket_medians(&[1.0; 100]).is_none());
        let v: Vec<f64> = (0..10_000)
            .map(|i| if i % 10 == 0 { 50.0 } else { 1.0 })
            .collect();
        let m = bucket_medians(&v).unwrap_or_default();
        assert_eq!(m.len(), 1);
        assert_eq!(m[0].len(), MEDIAN_BUCKETS);
        assert!(m[0].iter().all(|&(_, y)| y == 1.0));
    }

    #[test]
    fn strides_keep_first_and_last() {
        let idx: Vec<usize> = stride_indices(10, 4).collect();
        assert_eq!(idx, vec![0, 3, 6, 9]);
        let idx: Vec<usize> = stride_indices(11, 4).collect();
        assert_eq!(idx, vec![0, 3, 6, 9, 10]);
        assert_eq!(stride_indices(0, 4).count(), 0);
        assert_eq!(stride_indices(3, 4).count(), 3);
    }
}
