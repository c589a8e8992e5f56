//! Chessboard (checkerboard) inner-corner detection.
//!
//! Written by hand rather than taken from the `calib-targets` crate: that crate is not in this
//! workspace's dependency set and could not be vetted offline against `image` 0.25, while the
//! detector below is small, has no further dependencies and its corners are then refined with
//! exactly OpenCV's `cornerSubPix` ([`crate::refine_corners`]), which is what decides the
//! final accuracy.
//!
//! # Algorithm
//! 1. Light `[1 2 1]²` blur, then the ChESS response (Bennett & Lawton 2013) on a 16-sample
//!    ring of radius 5 (radius 3 as a second try, for small squares): strongly positive at
//!    X-junctions, where opposite ring samples agree and perpendicular ones differ, and
//!    negative on edges, L-corners and blobs.
//! 2. Local maxima of the response above a threshold relative to the strongest one are the
//!    candidate corners.
//! 3. Seeds, strongest first: a candidate with candidates at `±u`, `±v` and `u + v` whose four
//!    surrounding squares alternate dark/light.
//! 4. Grid growing: each empty grid cell next to the grown grid is predicted by linear
//!    extrapolation along rows / columns (which follows perspective and lens distortion) or a
//!    parallelogram, and takes the nearest free candidate within 35 % of the local spacing.
//! 5. The grown grid must contain a fully filled `cols x rows` (or transposed) window whose
//!    squares alternate in colour; exactly one such window is accepted.
//! 6. Order: row-major, `cols` corners per row, right-handed (row direction × column direction
//!    points into the image, as OpenCV's boards), corner 0 the end nearer the image's top-left;
//!    then [`crate::refine_corners`] with a half window of half the smallest square side, at
//!    most 11 px (OpenCV's sample; the ChESS peaks can be a few pixels off under strong
//!    perspective, and a wide window pulls them back in).

use crate::subpix::{FloatImage, refine_corners_f};
use image::GrayImage;
use nalgebra::{Point2, Vector2};
use std::collections::{HashMap, VecDeque};

/// At most this many candidate corners are kept (strongest first).
const MAX_CANDIDATES: usize = 3000;
/// At most this many seeds are tried per ring radius.
const MAX_SEEDS: usize = 40;
/// Minimal colour difference between adjacent squares (gray levels).
const MIN_CONTRAST: f32 = 8.0;

/// Finds the `cols x rows` inner corners of a chessboard in `gray`.
///
/// Returns the corners row-major (`cols` per row, `rows` rows), sub-pixel refined, or `None`
/// when no such board is found. Never panics, whatever the image (blank, tiny, noise).
/// The board's object points for these corners are `(i % cols, i / cols, 0) * square`.
pub fn find_chessboard(gray: &GrayImage, cols: usize, rows: usize) -> Option<Vec<Point2<f64>>> {
    if cols < 2 || rows < 2 || cols * rows > 10_000 {
        return None;
    }
    if gray.width() < 16 || gray.height() < 16 {
        return None;
    }
    let raw = FloatImage::from_gray(gray);
    let blurred = blur121(&raw);
    for radius in [5usize, 3] {
        if let Some(grid) = detect_with_radius(&blurred, radius, cols, rows) {
            let mut corners = orient(grid, cols, rows);
            let spacing = min_spacing(&corners, cols, rows);
            // up to half a square, at most OpenCV's sample window (11)
            let half = ((spacing * 0.5).floor() as usize).clamp(2, 11);
            refine_corners_f(&raw, &mut corners, half);
            if corners.iter().all(|p| p.x.is_finite() && p.y.is_finite()) {
                return Some(corners);
            }
        }
    }
    None
}

/// Separable `[1 2 1] / 4` blur with replicated borders.
fn blur121(img: &FloatImage) -> FloatImage {
    let (w, h) = (img.width, img.height);
    let mut tmp = vec![0f32; w * h];
    for y in 0..h {
        let row = &img.data[y * w..(y + 1) * w];
        for x in 0..w {
            let l = row[x.saturating_sub(1)];
            let r = row[(x + 1).min(w - 1)];
            tmp[y * w + x] = 0.25 * (l + 2.0 * row[x] + r);
        }
    }
    let mut out = vec![0f32; w * h];
    for y in 0..h {
        let up = y.saturating_sub(1) * w;
        let down = (y + 1).min(h - 1) * w;
        let mid = y * w;
        for x in 0..w {
            out[mid + x] = 0.25 * (tmp[up + x] + 2.0 * tmp[mid + x] + tmp[down + x]);
        }
    }
    FloatImage {
        width: w,
        height: h,
        data: out,
    }
}

/// The ChESS response on a ring of `radius`; zero within `radius + 1` of the border.
fn chess_response(img: &FloatImage, radius: usize) -> Vec<f32> {
    let (w, h) = (img.width, img.height);
    let mut resp = vec![0f32; w * h];
    let m = radius + 1;
    if w <= 2 * m || h <= 2 * m {
        return resp;
    }
    let ring: Vec<isize> = (0..16)
        .map(|k| {
            let a = k as f64 * std::f64::consts::PI / 8.0;
            let dx = (radius as f64 * a.cos()).round() as isize;
            let dy = (radius as f64 * a.sin()).round() as isize;
            dy * w as isize + dx
        })
        .collect();
    let d = &img.data;
    let n = w - 2 * m;
    for y in m..h - m {
        // one slice per ring sample, all of length n, so the inner loop indexes without checks
        let base = (y * w + m) as isize;
        let s: [&[f32]; 16] =
            std::array::from_fn(|k| &d[(base + ring[k]) as usize..(base + ring[k]) as usize + n]);
        let centre = &d[y * w + m..y * w + m + n];
        let left = &d[y * w + m - 1..y * w + m - 1 + n];
        let right = &d[y * w + m + 1..y * w + m + 1 + n];
        let up = &d[(y - 1) * w + m..(y - 1) * w + m + n];
        let down = &d[(y + 1) * w + m..(y + 1) * w + m + n];
        let out = &mut resp[y * w + m..y * w + m + n];
        for x in 0..n {
            let v: [f32; 16] = std::array::from_fn(|k| s[k][x]);
            let mut sum_resp = 0.0;
            for k in 0..4 {
                sum_resp += (v[k] + v[k + 8] - v[k + 4] - v[k + 12]).abs();
            }
            let mut diff_resp = 0.0;
            let mut ring_sum = 0.0;
            for k in 0..8 {
                diff_resp += (v[k] - v[k + 8]).abs();
                ring_sum += v[k] + v[k + 8];
            }
            let local = (centre[x] + left[x] + right[x] + up[x] + down[x]) * 0.2;
            let mean_resp = (ring_sum * (1.0 / 16.0) - local).abs();
            out[x] = sum_resp - diff_resp - 16.0 * mean_resp;
        }
    }
    resp
}

/// A candidate corner: integer peak of the response.
#[derive(Clone, Copy, Debug)]
struct Candidate {
    p: Vector2<f64>,
    score: f32,
}

/// Local maxima (5x5) of the response above a threshold, strongest first.
fn candidates(resp: &[f32], w: usize, h: usize) -> Vec<Candidate> {
    let max = resp.iter().cloned().fold(0f32, f32::max);
    if max <= 0.0 {
        return Vec::new();
    }
    let thresh = (0.05 * max).max(1.0);
    let mut out = Vec::new();
    for y in 2..h.saturating_sub(2) {
        for x in 2..w.saturating_sub(2) {
            let v = resp[y * w + x];
            if v <= thresh {
                continue;
            }
            let mut is_max = true;
            'nb: for dy in -2isize..=2 {
                for dx in -2isize..=2 {
                    if dx == 0 && dy == 0 {
                        continue;
                    }
                    let q = resp[(y as isize + dy) as usize * w + (x as isize + dx) as usize];
                    // ties: keep the first in raster order
                    if q > v || (q == v && (dy < 0 || (dy == 0 && dx < 0))) {
                        is_max = false;
                        break 'nb;
                    }
                }
            }
            if is_max {
                out.push(Candidate {
                    p: Vector2::new(x as f64, y as f64),
                    score: v,
                });
            }
        }
    }
    out.sort_by(|a, b| b.score.total_cmp(&a.score));
    out.truncate(MAX_CANDIDATES);
    out
}

/// Bucketed candidate positions for nearest-neighbour queries.
struct Index {
    cell: f64,
    buckets: HashMap<(i64, i64), Vec<usize>>,
}

impl Index {
    fn new(cands: &[Candidate], cell: f64) -> Self {
        let mut buckets: HashMap<(i64, i64), Vec<usize>> = HashMap::new();
        for (i, c) in cands.iter().enumerate() {
            buckets
                .entry(((c.p.x / cell) as i64, (c.p.y / cell) as i64))
                .or_default()
                .push(i);
        }
        Self { cell, buckets }
    }

    /// Nearest candidate within `radius` of `q` for which `ok` holds.
    fn nearest(
        &self,
        cands: &[Candidate],
        q: Vector2<f64>,
        radius: f64,
        ok: impl Fn(usize) -> bool,
    ) -> Option<usize> {
        if !(q.x.is_finite() && q.y.is_finite() && radius.is_finite()) || radius > 1e5 {
            return None;
        }
        let x0 = ((q.x - radius) / self.cell).floor() as i64;
        let x1 = ((q.x + radius) / self.cell).floor() as i64;
        let y0 = ((q.y - radius) / self.cell).floor() as i64;
        let y1 = ((q.y + radius) / self.cell).floor() as i64;
        if (x1 - x0 + 1) * (y1 - y0 + 1) > 40_000 {
            return None;
        }
        let mut best: Option<(usize, f64)> = None;
        for by in y0..=y1 {
            for bx in x0..=x1 {
                let Some(list) = self.buckets.get(&(bx, by)) else {
                    continue;
                };
                for &i in list {
                    let d2 = (cands[i].p - q).norm_squared();
                    if d2 <= radius * radius && best.is_none_or(|(_, b)| d2 < b) && ok(i) {
                        best = Some((i, d2));
                    }
                }
            }
        }
        best.map(|(i, _)| i)
    }
}

/// Mean of the blurred image in a 3x3 box around `p` (bilinear at the centre sample).
fn sample(img: &FloatImage, p: Vector2<f64>) -> Option<f32> {
    let (w, h) = (img.width as f64, img.height as f64);
    if !(p.x >= 1.0 && p.y >= 1.0 && p.x < w - 2.0 && p.y < h - 2.0) {
        return None;
    }
    let mut acc = 0.0;
    for dy in -1..=1 {
        for dx in -1..=1 {
            let x = p.x + dx as f64;
            let y = p.y + dy as f64;
            let (ix, iy) = (x.floor() as usize, y.floor() as usize);
            let (ax, ay) = ((x - ix as f64) as f32, (y - iy as f64) as f32);
            let i = iy * img.width + ix;
            let d = &img.data;
            acc += (1.0 - ay) * ((1.0 - ax) * d[i] + ax * d[i + 1])
                + ay * ((1.0 - ax) * d[i + img.width] + ax * d[i + img.width + 1]);
        }
    }
    Some(acc / 9.0)
}

type Grid = HashMap<(i32, i32), usize>;

fn detect_with_radius(
    img: &FloatImage,
    radius: usize,
    cols: usize,
    rows: usize,
) -> Option<Vec<Vec<Vector2<f64>>>> {
    let resp = chess_response(img, radius);
    let cands = candidates(&resp, img.width, img.height);
    if cands.len() < cols * rows {
        return None;
    }
    let index = Index::new(&cands, 16.0);
    let mut tried = vec![false; cands.len()];
    let mut seeds = 0;
    for s in 0..cands.len() {
        if tried[s] {
            continue;
        }
        if seeds >= MAX_SEEDS {
            break;
        }
        seeds += 1;
        tried[s] = true;
        let Some(grid) = grow_from(img, &cands, &index, s) else {
            continue;
        };
        for &i in grid.values() {
            tried[i] = true;
        }
        if let Some(found) = extract_board(img, &cands, &grid, cols, rows) {
            return Some(found);
        }
    }
    None
}

/// Checks a seed and grows a grid from it.
fn grow_from(img: &FloatImage, cands: &[Candidate], index: &Index, s: usize) -> Option<Grid> {
    let sp = cands[s].p;
    // the 8 nearest candidates (by brute force over a bounded radius search)
    let mut near: Vec<(f64, usize)> = Vec::new();
    let mut r = 24.0;
    while near.len() < 8 && r <= 400.0 {
        near.clear();
        let x0 = ((sp.x - r) / index.cell).floor() as i64;
        let x1 = ((sp.x + r) / index.cell).floor() as i64;
        let y0 = ((sp.y - r) / index.cell).floor() as i64;
        let y1 = ((sp.y + r) / index.cell).floor() as i64;
        for by in y0..=y1 {
            for bx in x0..=x1 {
                if let Some(list) = index.buckets.get(&(bx, by)) {
                    for &i in list {
                        let d = (cands[i].p - sp).norm();
                        if i != s && d <= r && d >= 3.0 {
                            near.push((d, i));
                        }
                    }
                }
            }
        }
        r *= 2.0;
    }
    near.sort_by(|a, b| a.0.total_cmp(&b.0));
    near.truncate(8);
    let (du, ui) = *near.first()?;
    let u = cands[ui].p - sp;
    let tol = |len: f64| 0.35 * len;
    // -u
    index.nearest(cands, sp - u, tol(du), |i| i != s && i != ui)?;
    // v: closest neighbour roughly across u, of similar length
    let (dv, v) = near.iter().skip(1).find_map(|&(d, i)| {
        let v = cands[i].p - sp;
        let cos = u.dot(&v) / (du * d);
        (cos.abs() < 0.6 && d < 2.0 * du).then_some((d, v))
    })?;
    index.nearest(cands, sp - v, tol(dv), |i| i != s)?;
    index.nearest(cands, sp + u + v, tol(du.max(dv)), |i| i != s)?;
    // four squares around the seed alternate
    let a1 = sample(img, sp + (u + v) * 0.5)?;
    let a2 = sample(img, sp - (u + v) * 0.5)?;
    let b1 = sample(img, sp + (u - v) * 0.5)?;
    let b2 = sample(img, sp - (u - v) * 0.5)?;
    let contrast = ((a1 + a2) - (b1 + b2)).abs() * 0.5;
    if contrast < MIN_CONTRAST
        || (a1 - a2).abs() > 0.5 * contrast
        || (b1 - b2).abs() > 0.5 * contrast
    {
        return None;
    }

    let mut grid: Grid = HashMap::new();
    let mut used: HashMap<usize, (i32, i32)> = HashMap::new();
    grid.insert((0, 0), s);
    used.insert(s, (0, 0));
    let mut queue: VecDeque<(i32, i32)> = VecDeque::new();
    let mut pos: HashMap<(i32, i32), Vector2<f64>> = HashMap::new();
    pos.insert((0, 0), sp);
    // seed the neighbours from u, v
    for (key, p) in [((1, 0), sp + u), ((0, 1), sp + v)] {
        let i = index.nearest(cands, p, tol(du.min(dv)), |i| !used.contains_key(&i))?;
        grid.insert(key, i);
        used.insert(i, key);
        pos.insert(key, cands[i].p);
    }
    for key in [(0, 0), (1, 0), (0, 1)] {
        queue.push_back(key);
    }
    let limit = 4 * MAX_CANDIDATES;
    let mut steps = 0;
    while let Some((gi, gj)) = queue.pop_front() {
        steps += 1;
        if steps > limit || grid.len() > 2000 {
            break;
        }
        for (di, dj) in [(1, 0), (-1, 0), (0, 1), (0, -1)] {
            let key = (gi + di, gj + dj);
            if grid.contains_key(&key) {
                continue;
            }
            let Some((pred, spacing)) = predict(&pos, key) else {
                continue;
            };
            if spacing < 3.0 {
                continue;
            }
            let found = index.nearest(cands, pred, tol(spacing), |i| !used.contains_key(&i));
            if let Some(i) = found {
                grid.insert(key, i);
                used.insert(i, key);
                pos.insert(key, cands[i].p);
                queue.push_back(key);
            }
        }
    }
    Some(grid)
}

/// Predicted position of grid cell `key` from its grown neighbours, and the local spacing.
fn predict(
    pos: &HashMap<(i32, i32), Vector2<f64>>,
    key: (i32, i32),
) -> Option<(Vector2<f64>, f64)> {
    let (i, j) = key;
    let mut sum = Vector2::zeros();
    let mut spacing = 0.0;
    let mut n = 0.0;
    // linear extrapolation along the four directions
    for (di, dj) in [(1, 0), (-1, 0), (0, 1), (0, -1)] {
        if let (Some(a), Some(b)) = (
            pos.get(&(i - di, j - dj)),
            pos.get(&(i - 2 * di, j - 2 * dj)),
        ) {
            sum += 2.0 * a - b;
            spacing += (a - b).norm();
            n += 1.0;
        }
    }
    if n == 0.0 {
        // parallelograms
        for (di, dj) in [(1, 1), (1, -1), (-1, 1), (-1, -1)] {
            if let (Some(a), Some(b), Some(c)) = (
                pos.get(&(i - di, j)),
                pos.get(&(i, j - dj)),
                pos.get(&(i - di, j - dj)),
            ) {
                sum += a + b - c;
                spacing += 0.5 * ((a - c).norm() + (b - c).norm());
                n += 1.0;
            }
        }
    }
    (n > 0.0).then(|| (sum / n, spacing / n))
}

/// Finds exactly one fully grown, colour-consistent `cols x rows` window (or its transpose) in
/// the grid; returns it as `rows` of positions indexed `[row][col]` (grid i along a row).
fn extract_board(
    img: &FloatImage,
    cands: &[Candidate],
    grid: &Grid,
    cols: usize,
    rows: usize,
) -> Option<Vec<Vec<Vector2<f64>>>> {
    if grid.len() < cols * rows {
        return None;
    }
    let imin = grid.keys().map(|k| k.0).min()?;
    let imax = grid.keys().map(|k| k.0).max()?;
    let jmin = grid.keys().map(|k| k.1).min()?;
    let jmax = grid.keys().map(|k| k.1).max()?;
    let mut found: Vec<Vec<Vec<Vector2<f64>>>> = Vec::new();
    let shapes: &[(usize, usize, bool)] = if cols == rows {
        &[(cols, rows, false)]
    } else {
        &[(cols, rows, false), (rows, cols, true)]
    };
    for &(ni, nj, transposed) in shapes {
        let (ni, nj) = (ni as i32, nj as i32);
        for i0 in imin..=imax - ni + 1 {
            for j0 in jmin..=jmax - nj + 1 {
                let mut pts = vec![vec![Vector2::zeros(); ni as usize]; nj as usize];
                let mut full = true;
                'fill: for j in 0..nj {
                    for i in 0..ni {
                        match grid.get(&(i0 + i, j0 + j)) {
                            Some(&c) => pts[j as usize][i as usize] = cands[c].p,
                            None => {
                                full = false;
                                break 'fill;
                            }
                        }
                    }
                }
                if !full || !colours_alternate(img, &pts) {
                    continue;
                }
                let board = if transposed {
                    // grid j runs along the board's rows of `cols` corners
                    (0..ni as usize)
                        .map(|i| (0..nj as usize).map(|j| pts[j][i]).collect())
                        .collect()
                } else {
                    pts
                };
                found.push(board);
                if found.len() > 1 {
                    return None;
                }
            }
        }
    }
    found.pop()
}

/// True when the squares between the corners alternate dark / light with enough contrast.
fn colours_alternate(img: &FloatImage, pts: &[Vec<Vector2<f64>>]) -> bool {
    let nj = pts.len();
    let ni = pts[0].len();
    let mut cells = vec![vec![0f32; ni - 1]; nj - 1];
    for j in 0..nj - 1 {
        for i in 0..ni - 1 {
            let c = (pts[j][i] + pts[j][i + 1] + pts[j + 1][i] + pts[j + 1][i + 1]) * 0.25;
            match sample(img, c) {
                Some(v) => cells[j][i] = v,
                None => return false,
            }
        }
    }
    // sign of the (0,0) cell against its neighbours sets the phase
    let mut agree = 0usize;
    let mut total = 0usize;
    let mut phase = 0f32;
    for j in 0..nj - 1 {
        for i in 0..ni - 1 {
            let parity = if (i + j) % 2 == 0 { 1.0 } else { -1.0 };
            for (a, b) in [(i + 1, j), (i, j + 1)] {
                if a < ni - 1 && b < nj - 1 {
                    phase += parity * (cells[j][i] - cells[b][a]);
                }
            }
        }
    }
    let sign = if phase >= 0.0 { 1.0 } else { -1.0 };
    for j in 0..nj - 1 {
        for i in 0..ni - 1 {
            let parity = if (i + j) % 2 == 0 { sign } else { -sign };
            for (a, b) in [(i + 1, j), (i, j + 1)] {
                if a < ni - 1 && b < nj - 1 {
                    total += 1;
                    if parity * (cells[j][i] - cells[b][a]) > MIN_CONTRAST {
                        agree += 1;
                    }
                }
            }
        }
    }
    total == 0 || agree * 100 >= total * 95
}

/// Flattens `[row][col]` positions into OpenCV's order: row-major, right-handed, corner 0 at
/// the end nearer the image's top-left.
fn orient(mut board: Vec<Vec<Vector2<f64>>>, cols: usize, rows: usize) -> Vec<Point2<f64>> {
    let u = board[0][1] - board[0][0];
    let v = board[1][0] - board[0][0];
    if u.x * v.y - u.y * v.x < 0.0 {
        for row in board.iter_mut() {
            row.reverse();
        }
    }
    let first = board[0][0];
    let last = board[rows - 1][cols - 1];
    let mut flat: Vec<Point2<f64>> = board.into_iter().flatten().map(Point2::from).collect();
    if last.x + last.y < first.x + first.y {
        flat.reverse();
    }
    flat
}

/// Smallest distance between grid neighbours.
fn min_spacing(c: &[Point2<f64>], cols: usize, rows: usize) -> f64 {
    let mut m = f64::INFINITY;
    for j in 0..rows {
        for i in 0..cols {
            let p = c[j * cols + i];
            if i + 1 < cols {
                m = m.min((c[j * cols + i + 1] - p).norm());
            }
            if j + 1 < rows {
                m = m.min((c[(j + 1) * cols + i] - p).norm());
            }
        }
    }
    m
}

#[cfg(test)]
mod tests {
    use super::*;

    /// A synthetic board: `cols+1 x rows+1` squares of `sq` pixels, white margin.
    fn board(cols: usize, rows: usize, sq: usize, x0: usize, y0: usize) -> GrayImage {
        GrayImage::from_fn(320, 240, |x, y| {
            let (x, y) = (x as isize - x0 as isize, y as isize - y0 as isize);
            let (w, h) = (((cols + 1) * sq) as isize, ((rows + 1) * sq) as isize);
            if x < 0 || y < 0 || x >= w || y >= h {
                return image::Luma([230]);
            }
            let dark = ((x / sq as isize) + (y / sq as isize)) % 2 == 0;
            image::Luma([if dark { 20 } else { 230 }])
        })
    }

    #[test]
    fn synthetic_board_found_in_order() {
        let img = board(9, 6, 20, 40, 30);
        let c = find_chessboard(&img, 9, 6).expect("board");
        assert_eq!(c.len(), 54);
        // corner (i, j) lies at x0 + (i+1) sq - 0.5
        for j in 0..6 {
            for i in 0..9 {
                let p = c[j * 9 + i];
                let ex = 40.0 + (i + 1) as f64 * 20.0 - 0.5;
                let ey = 30.0 + (j + 1) as f64 * 20.0 - 0.5;
                assert!(
                    (p.x - ex).abs() < 0.1 && (p.y - ey).abs() < 0.1,
                    "{i},{j}: {p:?}"
                );
            }
        }
        // wrong size is not found
        assert!(find_chessboard(&img, 8, 6).is_none());
        assert!(find_chessboard(&img, 10, 6).is_none());
    }

    #[test]
    fn transposed_board_found() {
        let img = board(6, 9, 18, 60, 20);
        let c = find_chessboard(&img, 9, 6).expect("board");
        assert_eq!(c.len(), 54);
    }

    #[test]
    fn degenerate_inputs() {
        assert!(find_chessboard(&GrayImage::new(0, 0), 9, 6).is_none());
        assert!(find_chessboard(&GrayImage::new(5, 3), 9, 6).is_none());
        assert!(find_chessboard(&GrayImage::new(640, 480), 9, 6).is_none());
        assert!(find_chessboard(&board(9, 6, 20, 40, 30), 1, 6).is_none());
    }
}
