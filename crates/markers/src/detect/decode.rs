//! Reading a candidate's cells, as OpenCV's `_extractCellPixelRatio` and
//! `_identifyOneCandidate`: the quad is sampled (nearest neighbour) onto a square of
//! `pixels_per_cell` per cell, Otsu splits it into black and white (unless it is too uniform),
//! each cell gets its share of white pixels, the border cells must be black and the inner cells
//! are looked up in the dictionary.

use super::DetectParams;
use crate::dictionary::{Dictionary, Identified};
use image::GrayImage;

/// Scratch buffers reused across candidates.
#[derive(Default)]
pub(crate) struct Scratch {
    warped: Vec<u8>,
    ratios: Vec<f32>,
}

/// Where a candidate's corners lie, which decides where they land in the sampled square.
#[derive(Clone, Copy, Debug, PartialEq)]
pub(crate) enum CornerKind {
    /// OpenCV's contour pixels, half a pixel inside the black square: they become the centres
    /// of the sampled square's corner pixels, as in OpenCV.
    ContourPixels,
    /// Sub-pixel points on the black square's outer edges ([`super::refine`]): they become the
    /// outer corners of the sampled square's corner pixels, half a pixel further out.
    Edges,
}

/// Why a candidate was not read as a marker.
#[derive(Clone, Copy, Debug, PartialEq)]
pub(crate) enum Rejected {
    /// A degenerate quad, or an inside too uniform to hold bits.
    Blank,
    /// This many border cells were not black (more than the parameters allow).
    Border(usize),
    /// The border held; the inner cells (masks as [`Dictionary::identify_cells`] takes them)
    /// are no code of the dictionary.
    Code { not_black: u64, not_white: u64 },
}

/// Identifies the candidate with corners `corners` (clockwise), or says why it is none.
pub(crate) fn identify_candidate(
    gray: &GrayImage,
    corners: &[[f32; 2]; 4],
    kind: CornerKind,
    dict: &Dictionary,
    params: &DetectParams,
    scratch: &mut Scratch,
) -> Result<Identified, Rejected> {
    let n = dict.marker_size() as usize;
    let border = params.marker_border_bits.max(1) as usize;
    let cells = n + 2 * border;
    let cell_px = params.perspective_remove_pixel_per_cell.max(1) as usize;
    let side = cells * cell_px;
    warp_nearest(gray, corners, kind, side, &mut scratch.warped).ok_or(Rejected::Blank)?;
    let uniform = cell_ratios(
        &scratch.warped,
        side,
        cells,
        cell_px,
        params,
        &mut scratch.ratios,
    );
    let ratios = &mut scratch.ratios;

    // Border: black cells have a low white ratio.
    let thr = params.valid_bit_id_threshold;
    let inv_thr = 1.0 - thr;
    let (mut errors, mut inv_errors) = (0usize, 0usize);
    let mut count = |r: f32| {
        errors += usize::from(r > thr);
        inv_errors += usize::from(r < inv_thr);
    };
    for y in 0..cells {
        for k in 0..border {
            count(ratios[y * cells + k]);
            count(ratios[y * cells + cells - 1 - k]);
        }
    }
    for x in border..cells - border {
        for k in 0..border {
            count(ratios[k * cells + x]);
            count(ratios[(cells - 1 - k) * cells + x]);
        }
    }
    if params.detect_inverted_marker && inv_errors < errors {
        errors = inv_errors;
        for r in ratios.iter_mut() {
            *r = 1.0 - *r;
        }
    }
    let max_border_errors = ((n * n) as f64 * params.max_erroneous_bits_in_border_rate) as usize;
    if errors > max_border_errors {
        return Err(if uniform {
            Rejected::Blank
        } else {
            Rejected::Border(errors)
        });
    }
    let (mut not_black, mut not_white) = (0u64, 0u64);
    for y in border..border + n {
        for x in border..border + n {
            let r = ratios[y * cells + x];
            not_black = (not_black << 1) | u64::from(r > thr);
            not_white = (not_white << 1) | u64::from(r < inv_thr);
        }
    }
    dict.identify_cells(
        not_black,
        not_white,
        dict.correction_limit(params.error_correction_rate),
    )
    .ok_or(if uniform {
        Rejected::Blank
    } else {
        Rejected::Code {
            not_black,
            not_white,
        }
    })
}

/// `getPerspectiveTransform` + `warpPerspective(INTER_NEAREST, BORDER_CONSTANT 0)` onto a
/// `side x side` square whose corners are the candidate's (where `kind` says). `None` for a
/// degenerate quad.
fn warp_nearest(
    gray: &GrayImage,
    corners: &[[f32; 2]; 4],
    kind: CornerKind,
    side: usize,
    out: &mut Vec<u8>,
) -> Option<()> {
    let (lo, hi) = match kind {
        CornerKind::ContourPixels => (0.0, side as f64 - 1.0),
        CornerKind::Edges => (-0.5, side as f64 - 0.5),
    };
    let dst = [[lo, lo], [hi, lo], [hi, hi], [lo, hi]];
    let src = corners.map(|c| [f64::from(c[0]), f64::from(c[1])]);
    let m = perspective_transform(&src, &dst)?;
    let m = invert3(&m)?;
    let (w, h) = (gray.width() as i64, gray.height() as i64);
    let data = gray.as_raw();
    out.clear();
    out.resize(side * side, 0);
    for y in 0..side {
        let yf = y as f64;
        let x0 = m[1] * yf + m[2];
        let y0 = m[4] * yf + m[5];
        let w0 = m[7] * yf + m[8];
        let row = &mut out[y * side..(y + 1) * side];
        for (x, o) in row.iter_mut().enumerate() {
            let xf = x as f64;
            let mut ww = w0 + m[6] * xf;
            ww = if ww != 0.0 { 1.0 / ww } else { 0.0 };
            let fx = ((x0 + m[0] * xf) * ww).clamp(i32::MIN as f64, i32::MAX as f64);
            let fy = ((y0 + m[3] * xf) * ww).clamp(i32::MIN as f64, i32::MAX as f64);
            let (sx, sy) = (fx.round_ties_even() as i64, fy.round_ties_even() as i64);
            *o = if sx >= 0 && sy >= 0 && sx < w && sy < h {
                data[(sy * w + sx) as usize]
            } else {
                0
            };
        }
    }
    Some(())
}

/// OpenCV's `getPerspectiveTransform` (the 8x8 system solved by its LU with partial pivoting).
fn perspective_transform(src: &[[f64; 2]; 4], dst: &[[f64; 2]; 4]) -> Option<[f64; 9]> {
    let mut a = [[0.0f64; 8]; 8];
    let mut b = [0.0f64; 8];
    for i in 0..4 {
        a[i][0] = src[i][0];
        a[i + 4][3] = src[i][0];
        a[i][1] = src[i][1];
        a[i + 4][4] = src[i][1];
        a[i][2] = 1.0;
        a[i + 4][5] = 1.0;
        a[i][6] = -src[i][0] * dst[i][0];
        a[i][7] = -src[i][1] * dst[i][0];
        a[i + 4][6] = -src[i][0] * dst[i][1];
        a[i + 4][7] = -src[i][1] * dst[i][1];
        b[i] = dst[i][0];
        b[i + 4] = dst[i][1];
    }
    let m = 8;
    for i in 0..m {
        let mut k = i;
        for j in i + 1..m {
            if a[j][i].abs() > a[k][i].abs() {
                k = j;
            }
        }
        if a[k][i].abs() < f64::EPSILON * 10.0 {
            return None;
        }
        if k != i {
            a.swap(i, k);
            b.swap(i, k);
        }
        let d = -1.0 / a[i][i];
        for j in i + 1..m {
            let alpha = a[j][i] * d;
            let (upper, lower) = a.split_at_mut(j);
            for (x, &y) in lower[0][i + 1..].iter_mut().zip(&upper[i][i + 1..]) {
                *x += alpha * y;
            }
            b[j] += alpha * b[i];
        }
    }
    for i in (0..m).rev() {
        let mut s = b[i];
        for k in i + 1..m {
            s -= a[i][k] * b[k];
        }
        b[i] = s / a[i][i];
    }
    let mut out = [0.0; 9];
    out[..8].copy_from_slice(&b);
    out[8] = 1.0;
    out.iter().all(|v| v.is_finite()).then_some(out)
}

/// OpenCV's 3x3 `invert` (cofactors over the determinant).
fn invert3(s: &[f64; 9]) -> Option<[f64; 9]> {
    let e = |r: usize, c: usize| s[r * 3 + c];
    let det = e(0, 0) * (e(1, 1) * e(2, 2) - e(1, 2) * e(2, 1))
        - e(0, 1) * (e(1, 0) * e(2, 2) - e(1, 2) * e(2, 0))
        + e(0, 2) * (e(1, 0) * e(2, 1) - e(1, 1) * e(2, 0));
    if det == 0.0 || !det.is_finite() {
        return None;
    }
    let d = 1.0 / det;
    Some([
        (e(1, 1) * e(2, 2) - e(1, 2) * e(2, 1)) * d,
        (e(0, 2) * e(2, 1) - e(0, 1) * e(2, 2)) * d,
        (e(0, 1) * e(1, 2) - e(0, 2) * e(1, 1)) * d,
        (e(1, 2) * e(2, 0) - e(1, 0) * e(2, 2)) * d,
        (e(0, 0) * e(2, 2) - e(0, 2) * e(2, 0)) * d,
        (e(0, 2) * e(1, 0) - e(0, 0) * e(1, 2)) * d,
        (e(1, 0) * e(2, 1) - e(1, 1) * e(2, 0)) * d,
        (e(0, 1) * e(2, 0) - e(0, 0) * e(2, 1)) * d,
        (e(0, 0) * e(1, 1) - e(0, 1) * e(1, 0)) * d,
    ])
}

/// White share of every cell: Otsu on the warped square, or all 0 / all 1 when the inside is too
/// uniform (standard deviation below `min_otsu_std_dev`; then it returns true).
fn cell_ratios(
    warped: &[u8],
    side: usize,
    cells: usize,
    cell_px: usize,
    params: &DetectParams,
    out: &mut Vec<f32>,
) -> bool {
    out.clear();
    out.resize(cells * cells, 0.0);
    // Mean and standard deviation of the inside (half a cell trimmed on every side).
    let trim = cell_px / 2;
    let (mut sum, mut sq, mut n) = (0u64, 0u64, 0u64);
    for y in trim..side - trim {
        for &v in &warped[y * side + trim..y * side + side - trim] {
            sum += u64::from(v);
            sq += u64::from(v) * u64::from(v);
            n += 1;
        }
    }
    if n > 0 {
        let mean = sum as f64 / n as f64;
        let var = (sq as f64 / n as f64 - mean * mean).max(0.0);
        if var.sqrt() < params.min_otsu_std_dev {
            out.fill(if mean > 127.0 { 1.0 } else { 0.0 });
            return true;
        }
    }
    let t = otsu(warped);
    let margin = (params.perspective_remove_ignored_margin_per_cell * cell_px as f64) as usize;
    let inner = cell_px.saturating_sub(2 * margin).max(1);
    let total = (inner * inner) as f32;
    for cy in 0..cells {
        for cx in 0..cells {
            let (x0, y0) = (cx * cell_px + margin, cy * cell_px + margin);
            let mut white = 0u32;
            for y in y0..(y0 + inner).min(side) {
                for &v in &warped[y * side + x0..y * side + (x0 + inner).min(side)] {
                    white += u32::from(v > t);
                }
            }
            out[cy * cells + cx] = white as f32 / total;
        }
    }
    false
}

/// OpenCV's `getThreshVal_Otsu_8u`.
fn otsu(pixels: &[u8]) -> u8 {
    let mut hist = [0u32; 256];
    for &v in pixels {
        hist[v as usize] += 1;
    }
    let scale = 1.0 / pixels.len() as f64;
    let mu = hist
        .iter()
        .enumerate()
        .map(|(i, &h)| i as f64 * f64::from(h))
        .sum::<f64>()
        * scale;
    let (mut mu1, mut q1) = (0.0f64, 0.0f64);
    let (mut max_sigma, mut max_val) = (0.0f64, 0u8);
    let eps = f64::from(f32::EPSILON);
    for (i, &h) in hist.iter().enumerate() {
        let p_i = f64::from(h) * scale;
        mu1 *= q1;
        q1 += p_i;
        let q2 = 1.0 - q1;
        if q1.min(q2) < eps || q1.max(q2) > 1.0 - eps {
            continue;
        }
        mu1 = (mu1 + i as f64 * p_i) / q1;
        let mu2 = (mu - q1 * mu1) / q2;
        let sigma = q1 * q2 * (mu1 - mu2) * (mu1 - mu2);
        if sigma > max_sigma {
            max_sigma = sigma;
            max_val = i as u8;
        }
    }
    max_val
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn otsu_splits_two_levels() {
        let mut px = vec![20u8; 500];
        px.extend(vec![200u8; 524]);
        let t = otsu(&px);
        assert!((20..200).contains(&t), "{t}");
    }

    #[test]
    fn identity_warp_samples_the_square() {
        let img = GrayImage::from_fn(40, 40, |x, y| image::Luma([(x + 40 * y) as u8]));
        let corners = [[3.0, 5.0], [34.0, 5.0], [34.0, 36.0], [3.0, 36.0]];
        let mut out = Vec::new();
        warp_nearest(&img, &corners, CornerKind::ContourPixels, 32, &mut out).unwrap();
        for y in 0..32u32 {
            for x in 0..32u32 {
                assert_eq!(out[(y * 32 + x) as usize], img.get_pixel(x + 3, y + 5)[0]);
            }
        }
    }
}
