//! CLAHE (contrast-limited adaptive histogram equalisation), bit-identical to OpenCV's
//! `createCLAHE(clip, (tiles, tiles)).apply()` on 8-bit images.
//!
//! Why by hand: neither `image` nor `fast_image_resize` has CLAHE, and `kornia-imgproc` is not a
//! dependency (its CLAHE is not OpenCV's, either). The ceiling-camera networks are trained on
//! OpenCV-made views, so the pixels must be OpenCV's. This re-derives `clahe.cpp`
//! (`CLAHE_CalcLut_Body`, `CLAHE_Interpolation_Body`) step by step:
//!
//! 1. If the size is not divisible by the grid, the image is padded on the right and bottom with
//!    `BORDER_REFLECT_101` by `tiles - size % tiles` on *both* axes (OpenCV pads a whole extra
//!    tile on an axis that was divisible); the tile size is the padded size over the grid.
//! 2. One 256-bin histogram per tile; `clipLimit = max(1, (int)(clip * tileArea / 256))`; the
//!    clipped excess is spread as `excess / 256` per bin plus one more on every
//!    `max(256 / residual, 1)`-th bin from bin 0 until the residual is used up.
//! 3. `lut[i] = saturate_cast<uchar>(cdf[i] * (255.f / tileArea))` (ties to even).
//! 4. Each pixel blends the LUTs of the four nearest tile centres with OpenCV's `f32` formula:
//!    `txf = x * (1.f / tileW) - 0.5f`, `xa = txf - floor(txf)`, likewise `ya`, and
//!    `(l11 * (1 - xa) + l12 * xa) * (1 - ya) + (l21 * (1 - xa) + l22 * xa) * ya`, each operation
//!    rounded to `f32` (no fused multiply-add), then rounded ties-to-even.
//!
//! The interpolation walks each row in runs of columns that share the same pair of tiles, so the
//! four LUT values of a pixel come from one look-up in a table of packed `u32` built per band of
//! rows; the gathered values are then blended in one pass over the row that the compiler
//! vectorises.

use image::GrayImage;

use crate::{ImgprocError, Result};

use super::round::round_u8;

/// Largest tile grid accepted (per axis); more tiles than this is never a useful view and would
/// make the padded image and LUT table needlessly large.
pub const MAX_TILES: u32 = 256;

/// Reusable buffers of [`clahe`] (padded copy, LUTs, per-column weights).
#[derive(Debug, Default, Clone)]
pub(crate) struct ClaheScratch {
    ext: Vec<u8>,
    luts: Vec<[u8; 256]>,
    xa: Vec<f32>,
    xa1: Vec<f32>,
    /// Column runs `(start, end, tile_x1, tile_x2)` sharing one pair of tiles.
    runs: Vec<(usize, usize, usize, usize)>,
    xmap: Vec<usize>,
    /// Per column run, 256 packed `u32` of the four LUTs of the current band of rows.
    band: Vec<u32>,
    /// The packed LUT values of each pixel of a row, gathered before blending.
    packed: Vec<u32>,
}

/// Checks CLAHE parameters (shared with the spec's validation).
pub(crate) fn check_params(clip: f32, tiles: u32) -> Result<()> {
    if !(clip.is_finite() && clip > 0.0) {
        return Err(ImgprocError::Param(format!(
            "clahe clip limit must be a finite number > 0, got {clip}"
        )));
    }
    if tiles == 0 || tiles > MAX_TILES {
        return Err(ImgprocError::Param(format!(
            "clahe tile grid must be 1..={MAX_TILES}, got {tiles}"
        )));
    }
    Ok(())
}

/// Equalises contrast per tile with a clip limit, exactly as OpenCV's
/// `createCLAHE(clip, (tiles, tiles))`: lamps and dark corners both keep detail while the clip
/// keeps noise on flat walls from blowing up. `dst` must have the size of `src`.
pub fn clahe(src: &GrayImage, dst: &mut GrayImage, clip: f32, tiles: u32) -> Result<()> {
    clahe_with(src, dst, clip, tiles, &mut ClaheScratch::default())
}

/// [`clahe`] with reusable buffers.
pub(crate) fn clahe_with(
    src: &GrayImage,
    dst: &mut GrayImage,
    clip: f32,
    tiles: u32,
    scratch: &mut ClaheScratch,
) -> Result<()> {
    if src.dimensions() != dst.dimensions() {
        return Err(ImgprocError::Size(format!(
            "clahe: source {:?} and destination {:?} differ",
            src.dimensions(),
            dst.dimensions()
        )));
    }
    check_params(clip, tiles)?;
    let (w, h) = (src.width() as usize, src.height() as usize);
    if w == 0 || h == 0 {
        return Err(ImgprocError::Size(format!("clahe: empty image {w}x{h}")));
    }
    let t = tiles as usize;
    let (ew, eh) = if w % t == 0 && h % t == 0 {
        (w, h)
    } else {
        (w + t - w % t, h + t - h % t)
    };
    let (tw, th) = (ew / t, eh / t);
    let area = tw * th;
    let hist_src: &[u8] = if (ew, eh) == (w, h) {
        src.as_raw()
    } else {
        pad_reflect101(src.as_raw(), (w, h), (ew, eh), scratch);
        &scratch.ext
    };

    let lut_scale = 255.0f32 / area as f32;
    let clip_limit = ((clip as f64 * area as f64 / 256.0) as i64).max(1) as u32;
    scratch.luts.resize(t * t, [0; 256]);
    for ty in 0..t {
        for tx in 0..t {
            let mut hist = tile_histogram(hist_src, ew, (tx * tw, ty * th), (tw, th));
            clip_histogram(&mut hist, clip_limit);
            // Cumulative sum (serial), then the scaling in a separate loop that vectorises.
            let mut sum = 0u32;
            for c in hist.iter_mut() {
                sum += *c;
                *c = sum;
            }
            let lut = &mut scratch.luts[ty * t + tx];
            for (l, &c) in lut.iter_mut().zip(hist.iter()) {
                *l = round_u8(c as f32 * lut_scale);
            }
        }
    }
    interpolate(src.as_raw(), dst, (w, h), (tw, th), t, scratch);
    Ok(())
}

/// 256-bin histogram of the `tw x th` tile at `(x0, y0)` of an image `stride` pixels wide.
///
/// Four partial histograms take the pixels in turn: flat regions would otherwise increment the
/// same counter back to back and wait on each store. They are `u16` (half the memory to clear
/// per tile) whenever a tile has fewer than 2^16 pixels.
fn tile_histogram(
    img: &[u8],
    stride: usize,
    (x0, y0): (usize, usize),
    (tw, th): (usize, usize),
) -> [u32; 256] {
    let rows = img
        .chunks_exact(stride)
        .skip(y0)
        .take(th)
        .map(|row| &row[x0..x0 + tw]);
    let mut hist = [0u32; 256];
    if tw * th < 1 << 16 {
        let mut part = [[0u16; 256]; 4];
        for row in rows {
            let mut quads = row.chunks_exact(4);
            for q in &mut quads {
                part[0][q[0] as usize] += 1;
                part[1][q[1] as usize] += 1;
                part[2][q[2] as usize] += 1;
                part[3][q[3] as usize] += 1;
            }
            for &v in quads.remainder() {
                part[0][v as usize] += 1;
            }
        }
        for (i, h) in hist.iter_mut().enumerate() {
            *h = part[0][i] as u32 + part[1][i] as u32 + part[2][i] as u32 + part[3][i] as u32;
        }
    } else {
        for row in rows {
            for &v in row {
                hist[v as usize] += 1;
            }
        }
    }
    hist
}

/// Clips at `limit` and redistributes the excess as OpenCV does.
fn clip_histogram(hist: &mut [u32; 256], limit: u32) {
    let mut clipped = 0u32;
    for c in hist.iter_mut() {
        if *c > limit {
            clipped += *c - limit;
            *c = limit;
        }
    }
    let batch = clipped / 256;
    let mut residual = clipped - batch * 256;
    for c in hist.iter_mut() {
        *c += batch;
    }
    // OpenCV spreads the remainder one count at a time with a stride of 256 / residual.
    if let Some(stride) = 256u32.checked_div(residual) {
        let step = stride.max(1) as usize;
        let mut i = 0;
        while i < 256 && residual > 0 {
            hist[i] += 1;
            i += step;
            residual -= 1;
        }
    }
}

/// OpenCV's `borderInterpolate(p, len, BORDER_REFLECT_101)` for `p >= 0`.
pub(crate) fn reflect101(p: usize, len: usize) -> usize {
    if len == 1 {
        return 0;
    }
    let (mut p, n) = (p as i64, len as i64);
    while p < 0 || p >= n {
        p = if p < 0 { -p } else { 2 * n - p - 2 };
    }
    p as usize
}

/// Copies `src` (`w x h`) into `scratch.ext` (`ew x eh`), reflecting on the right and bottom.
fn pad_reflect101(
    src: &[u8],
    (w, h): (usize, usize),
    (ew, eh): (usize, usize),
    scratch: &mut ClaheScratch,
) {
    scratch.xmap.clear();
    scratch.xmap.extend((0..ew).map(|x| reflect101(x, w)));
    scratch.ext.clear();
    scratch.ext.resize(ew * eh, 0);
    for (y, out) in scratch.ext.chunks_exact_mut(ew).enumerate() {
        let sy = reflect101(y, h);
        let row = &src[sy * w..(sy + 1) * w];
        out[..w].copy_from_slice(row);
        for (o, &sx) in out[w..].iter_mut().zip(&scratch.xmap[w..]) {
            *o = row[sx];
        }
    }
}

/// Tile coordinate of pixel `p`: `(first tile, second tile, weight of the second)` with OpenCV's
/// `f32` arithmetic.
#[inline]
fn tile_coord(p: usize, inv: f32, tiles: usize) -> (usize, usize, f32) {
    let f = p as f32 * inv - 0.5f32;
    let t1 = f.floor();
    let a = f - t1;
    let t1 = t1 as i64;
    let t2 = (t1 + 1).min(tiles as i64 - 1);
    (t1.max(0) as usize, t2.max(0) as usize, a)
}

/// Bilinear blend of the tile LUTs (step 4 of the module doc).
fn interpolate(
    src: &[u8],
    dst: &mut [u8],
    (w, h): (usize, usize),
    (tw, th): (usize, usize),
    t: usize,
    scratch: &mut ClaheScratch,
) {
    let inv_tw = 1.0f32 / tw as f32;
    let inv_th = 1.0f32 / th as f32;
    scratch.xa.clear();
    scratch.xa1.clear();
    scratch.runs.clear();
    for x in 0..w {
        let (t1, t2, a) = tile_coord(x, inv_tw, t);
        scratch.xa.push(a);
        scratch.xa1.push(1.0f32 - a);
        match scratch.runs.last_mut() {
            Some(run) if run.2 == t1 && run.3 == t2 => run.1 = x + 1,
            _ => scratch.runs.push((x, x + 1, t1, t2)),
        }
    }
    // For the current band of rows (one pair of tile rows), each column run gets one table of
    // 256 `u32` holding its four LUT values side by side: one look-up per pixel instead of four.
    let runs = &scratch.runs;
    scratch.band.resize(runs.len() * 256, 0);
    scratch.packed.resize(w, 0);
    let luts = &scratch.luts;
    let mut band_rows = None;
    for (y, (srow, drow)) in src
        .chunks_exact(w)
        .zip(dst.chunks_exact_mut(w))
        .take(h)
        .enumerate()
    {
        let (ty1, ty2, ya) = tile_coord(y, inv_th, t);
        let ya1 = 1.0f32 - ya;
        if band_rows != Some((ty1, ty2)) {
            for (table, &(_, _, tx1, tx2)) in scratch.band.chunks_exact_mut(256).zip(runs) {
                let quad = [
                    &luts[ty1 * t + tx1],
                    &luts[ty1 * t + tx2],
                    &luts[ty2 * t + tx1],
                    &luts[ty2 * t + tx2],
                ];
                for (v, q) in table.iter_mut().enumerate() {
                    *q = u32::from_le_bytes([quad[0][v], quad[1][v], quad[2][v], quad[3][v]]);
                }
            }
            band_rows = Some((ty1, ty2));
        }
        for (table, &(start, end, _, _)) in scratch.band.chunks_exact(256).zip(runs) {
            let Ok(table) = <&[u32; 256]>::try_from(table) else {
                continue;
            };
            for (q, &v) in scratch.packed[start..end].iter_mut().zip(&srow[start..end]) {
                *q = table[v as usize];
            }
        }
        blend_row(
            drow,
            (&scratch.xa[..w], &scratch.xa1[..w]),
            (ya, ya1),
            &scratch.packed[..w],
        );
    }
}

/// `dst[i] = round((l11 * xa1 + l12 * xa) * ya1 + (l21 * xa1 + l22 * xa) * ya)` in `f32`, in
/// OpenCV's order of operations, with `l11..l22` the bytes of `packed[i]`. Indexed over
/// equal-length slices so that it vectorises.
#[inline]
fn blend_row(dst: &mut [u8], (xa, xa1): (&[f32], &[f32]), (ya, ya1): (f32, f32), packed: &[u32]) {
    let n = dst.len();
    let (xa, xa1, packed) = (&xa[..n], &xa1[..n], &packed[..n]);
    for i in 0..n {
        let q = packed[i];
        let (l11, l12) = ((q & 0xff) as f32, ((q >> 8) & 0xff) as f32);
        let (l21, l22) = (((q >> 16) & 0xff) as f32, (q >> 24) as f32);
        let top = l11 * xa1[i] + l12 * xa[i];
        let bottom = l21 * xa1[i] + l22 * xa[i];
        dst[i] = round_u8(top * ya1 + bottom * ya);
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn reflect101_matches_opencv_border_interpolate() {
        // len 5: ... 3 2 1 | 0 1 2 3 4 | 3 2 1 0 1 2 ...
        let got: Vec<usize> = (5..11).map(|p| reflect101(p, 5)).collect();
        assert_eq!(got, vec![3, 2, 1, 0, 1, 2]);
        // pad wider than the image (len 3): 1 0 1 2 1 0
        let got: Vec<usize> = (3..9).map(|p| reflect101(p, 3)).collect();
        assert_eq!(got, vec![1, 0, 1, 2, 1, 0]);
        assert_eq!(reflect101(7, 1), 0);
    }

    #[test]
    fn clipping_redistributes_excess() {
        let mut hist = [0u32; 256];
        hist[10] = 300; // limit 4: excess 296 = 1 per bin + 40 residual every 6th bin
        clip_histogram(&mut hist, 4);
        assert_eq!(hist.iter().sum::<u32>(), 300);
        assert_eq!(hist[10], 5);
        assert_eq!(hist[0], 2);
        assert_eq!(hist[6], 2);
        assert_eq!(hist[1], 1);
        assert_eq!(hist[240], 1);
    }

    #[test]
    fn flat_image_maps_to_one_value() -> Result<()> {
        // 16x16, 2x2 tiles of 64 px all at 100: clip limit (int)(2 * 64 / 256) = 0 -> 1;
        // the 63 clipped pixels spread as 0 per bin + 63 residual on every 4th bin from 0,
        // so the cdf at bin 100 is 1 (clip) + 26 (bins 0, 4, ..., 100) = 27 -> 27 * 255 / 64.
        let src = GrayImage::from_pixel(16, 16, image::Luma([100]));
        let mut dst = GrayImage::new(16, 16);
        clahe(&src, &mut dst, 2.0, 2)?;
        let expect = (27.0f32 * (255.0f32 / 64.0)).round() as u8;
        assert!(
            dst.pixels().all(|p| p.0[0] == expect),
            "{:?}",
            dst.get_pixel(0, 0)
        );
        Ok(())
    }

    #[test]
    fn bad_parameters_are_errors() {
        let src = GrayImage::new(8, 8);
        let mut dst = GrayImage::new(8, 8);
        assert!(clahe(&src, &mut dst, 0.0, 8).is_err());
        assert!(clahe(&src, &mut dst, -1.0, 8).is_err());
        assert!(clahe(&src, &mut dst, f32::NAN, 8).is_err());
        assert!(clahe(&src, &mut dst, 2.0, 0).is_err());
        let mut small = GrayImage::new(4, 8);
        assert!(clahe(&src, &mut small, 2.0, 8).is_err());
        let empty = GrayImage::new(0, 0);
        let mut empty_dst = GrayImage::new(0, 0);
        assert!(clahe(&empty, &mut empty_dst, 2.0, 8).is_err());
    }
}
