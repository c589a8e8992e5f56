//! Polygon helpers ported from OpenCV so that candidates keep OpenCV's exact corners:
//! `approxPolyDP` on a closed integer contour (`imgproc/src/approx.cpp`: the same three passes
//! to find two far points, the same explicit stack and the same final clean-up),
//! `isContourConvex` and `pointPolygonTest` (without distance).

/// Douglas-Peucker approximation of the closed contour `src` with tolerance `eps`, written into
/// `dst` (cleared first), as `cv::approxPolyDP(src, dst, eps, true)`. `stack` is scratch.
pub(crate) fn approx_poly_dp_closed(
    src: &[(i32, i32)],
    eps: f64,
    dst: &mut Vec<(i32, i32)>,
    stack: &mut Vec<(usize, usize)>,
) {
    dst.clear();
    stack.clear();
    let count = src.len();
    if count == 0 {
        return;
    }
    let eps2 = eps * eps;
    let f = |p: (i32, i32)| (f64::from(p.0), f64::from(p.1));
    // `(i + 1) % count` without a division (this runs for every contour point).
    let next = |i: usize| if i + 1 == count { 0 } else { i + 1 };

    // 1. Two approximately farthest points (three passes).
    let mut right_start = 0usize;
    let mut pos = 0usize;
    let mut start_pt = src[0];
    let mut le_eps = false;
    for _ in 0..3 {
        let mut max_dist = 0.0;
        pos = (pos + right_start) % count;
        start_pt = src[pos];
        pos = next(pos);
        for j in 1..count {
            let pt = src[pos];
            pos = next(pos);
            let dx = f64::from(pt.0 - start_pt.0);
            let dy = f64::from(pt.1 - start_pt.1);
            let dist = dx * dx + dy * dy;
            if dist > max_dist {
                max_dist = dist;
                right_start = j;
            }
        }
        le_eps = max_dist <= eps2;
    }
    // 2. Initialise the stack with both halves.
    if le_eps {
        dst.push(start_pt);
    } else {
        let slice_start = pos % count;
        let far = (right_start + slice_start) % count;
        stack.push((far, slice_start));
        stack.push((slice_start, far));
    }
    // 3. Split until every piece is within eps.
    while let Some((s_start, s_end)) = stack.pop() {
        let end_pt = src[s_end];
        let mut pos = s_start;
        let start_pt = src[pos];
        pos = next(pos);
        let le_eps;
        let mut split = 0usize;
        if pos != s_end {
            let (sx, sy) = f(start_pt);
            let (ex, ey) = f(end_pt);
            let (dx, dy) = (ex - sx, ey - sy);
            let seg2 = dx * dx + dy * dy;
            let mut max_d = 0.0;
            while pos != s_end {
                let (px, py) = f(src[pos]);
                pos = next(pos);
                let projection = (px - sx) * dx + (py - sy) * dy;
                let d = if projection < 0.0 {
                    ((px - sx) * (px - sx) + (py - sy) * (py - sy)) * seg2
                } else if projection > seg2 {
                    ((px - ex) * (px - ex) + (py - ey) * (py - ey)) * seg2
                } else {
                    let c = (py - sy) * dx - (px - sx) * dy;
                    c * c
                };
                if d > max_d {
                    max_d = d;
                    split = if pos == 0 { count - 1 } else { pos - 1 };
                }
            }
            le_eps = max_d <= eps2 * seg2;
        } else {
            le_eps = true;
        }
        if le_eps {
            dst.push(start_pt);
        } else {
            stack.push((split, s_end));
            stack.push((s_start, split));
        }
    }
    // 4. Clean-up: drop points on almost straight stretches.
    let count = dst.len();
    let mut new_count = count;
    let mut pos = count - 1;
    let read = |pos: &mut usize, dst: &Vec<(i32, i32)>| {
        let p = dst[*pos];
        *pos += 1;
        if *pos >= count {
            *pos = 0;
        }
        p
    };
    let mut start_pt = read(&mut pos, dst);
    let mut wpos = pos;
    let mut pt = read(&mut pos, dst);
    let mut i = 0;
    while i < count && new_count > 2 {
        let end_pt = read(&mut pos, dst);
        let dx = f64::from(end_pt.0 - start_pt.0);
        let dy = f64::from(end_pt.1 - start_pt.1);
        let dist = (f64::from(pt.0 - start_pt.0) * dy - f64::from(pt.1 - start_pt.1) * dx).abs();
        let inner = f64::from(pt.0 - start_pt.0) * f64::from(end_pt.0 - pt.0)
            + f64::from(pt.1 - start_pt.1) * f64::from(end_pt.1 - pt.1);
        if dist * dist <= 0.5 * eps2 * (dx * dx + dy * dy) && dx != 0.0 && dy != 0.0 && inner >= 0.0
        {
            new_count -= 1;
            start_pt = end_pt;
            dst[wpos] = end_pt;
            wpos += 1;
            if wpos >= count {
                wpos = 0;
            }
            pt = read(&mut pos, dst);
            i += 2;
            continue;
        }
        start_pt = pt;
        dst[wpos] = pt;
        wpos += 1;
        if wpos >= count {
            wpos = 0;
        }
        pt = end_pt;
        i += 1;
    }
    dst.truncate(new_count);
}

/// OpenCV's `isContourConvex` for integer points: every turn the same way, none straight.
pub(crate) fn is_convex(p: &[(i32, i32)]) -> bool {
    let n = p.len();
    if n < 3 {
        return false;
    }
    let mut prev = p[n - 2];
    let mut cur = p[n - 1];
    let (mut dx0, mut dy0) = (i64::from(cur.0 - prev.0), i64::from(cur.1 - prev.1));
    let mut orientation = 0u8;
    for &q in p {
        prev = cur;
        cur = q;
        let (dx, dy) = (i64::from(cur.0 - prev.0), i64::from(cur.1 - prev.1));
        let dxdy0 = dx * dy0;
        let dydx0 = dy * dx0;
        orientation |= if dydx0 > dxdy0 {
            1
        } else if dydx0 < dxdy0 {
            2
        } else {
            3
        };
        if orientation == 3 {
            return false;
        }
        dx0 = dx;
        dy0 = dy;
    }
    orientation != 0
}

/// OpenCV's `pointPolygonTest(contour, pt, false) >= 0` for a float polygon: inside or on an
/// edge.
pub(crate) fn inside_or_on(poly: &[[f32; 2]; 4], pt: [f32; 2]) -> bool {
    let mut counter = 0;
    let mut v = poly[3];
    for &vi in poly {
        let v0 = v;
        v = vi;
        if (v0[1] <= pt[1] && v[1] <= pt[1])
            || (v0[1] > pt[1] && v[1] > pt[1])
            || (v0[0] < pt[0] && v[0] < pt[0])
        {
            if pt[1] == v[1]
                && (pt[0] == v[0]
                    || (pt[1] == v0[1]
                        && ((v0[0] <= pt[0] && pt[0] <= v[0])
                            || (v[0] <= pt[0] && pt[0] <= v0[0]))))
            {
                return true;
            }
            continue;
        }
        let mut dist = f64::from(pt[1] - v0[1]) * f64::from(v[0] - v0[0])
            - f64::from(pt[0] - v0[0]) * f64::from(v[1] - v0[1]);
        if dist == 0.0 {
            return true;
        }
        if v[1] < v0[1] {
            dist = -dist;
        }
        counter += i32::from(dist > 0.0);
    }
    counter % 2 != 0
}

#[cfg(test)]
mod tests {
    use super::*;

    fn square_contour(x0: i32, y0: i32, side: i32) -> Vec<(i32, i32)> {
        // Counter-clockwise in image coordinates from the top-left, as the tracer gives it.
        let mut c = Vec::new();
        for y in y0..y0 + side {
            c.push((x0, y));
        }
        for x in x0..x0 + side {
            c.push((x, y0 + side));
        }
        for y in (y0 + 1..=y0 + side).rev() {
            c.push((x0 + side, y));
        }
        for x in (x0 + 1..=x0 + side).rev() {
            c.push((x, y0));
        }
        c
    }

    #[test]
    fn a_square_contour_becomes_its_four_corners() {
        let c = square_contour(10, 20, 30);
        let (mut out, mut stack) = (Vec::new(), Vec::new());
        approx_poly_dp_closed(&c, c.len() as f64 * 0.03, &mut out, &mut stack);
        let mut sorted = out.clone();
        sorted.sort();
        assert_eq!(sorted, vec![(10, 20), (10, 50), (40, 20), (40, 50)]);
        assert!(is_convex(&out));
    }

    #[test]
    fn convexity_and_inside_tests() {
        assert!(is_convex(&[(0, 0), (4, 0), (4, 4), (0, 4)]));
        assert!(!is_convex(&[(0, 0), (4, 0), (1, 1), (0, 4)]));
        assert!(!is_convex(&[(0, 0), (2, 0), (4, 0), (0, 4)]));
        let q = [[0.0, 0.0], [4.0, 0.0], [4.0, 4.0], [0.0, 4.0]];
        assert!(inside_or_on(&q, [2.0, 2.0]));
        assert!(inside_or_on(&q, [4.0, 2.0]));
        assert!(inside_or_on(&q, [0.0, 0.0]));
        assert!(!inside_or_on(&q, [5.0, 2.0]));
    }
}
