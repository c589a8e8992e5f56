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
    let mut flush = |current: &mut Vec<(f64, f64)>, segments: &mut Vec<Vec<(f64, f64)>>| {
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
    fn strides_keep_first_and_last() {
        let idx: Vec<usize> = stride_indices(10, 4).collect();
        assert_eq!(idx, vec![0, 3, 6, 9]);
        let idx: Vec<usize> = stride_indices(11, 4).collect();
        assert_eq!(idx, vec![0, 3, 6, 9, 10]);
        assert_eq!(stride_indices(0, 4).count(), 0);
        assert_eq!(stride_indices(3, 4).count(), 3);
    }
}
