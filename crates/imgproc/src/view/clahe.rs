//! CLAHE (contrast-limited adaptive histogram equalisation), bit-identical to OpenCV's
//! `createCLAHE(clip, (tiles, tiles)).apply()` on 8-bit images.
//!
//! Why by hand: neither `image` nor `fast_image_resize` has CLAHE. `kornia-imgproc` 0.2 has one,
//! but it reproduces the fused multiply-adds that OpenCV's aarch64 wheels are compiled with; the
//! x86-64 wheels do not fuse, and an emulation of kornia's arithmetic differs from
//! opencv-python 5.0 (x86-64) on 0.17 % of the fixture pixels. The ceiling-camera networks are
//! trained on OpenCV-made views, so the pixels must be OpenCV's. This re-derives `clahe.cpp`
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
    if (ew, eh) != (w, h) {
        pad_reflect101(src.as_raw(), (w, h), (ew, eh), scratch);
    }

    let lut_scale = 255.0f32 / area as f32;
    let clip_limit = ((clip as f64 * area as f64 / 256.0) as i64).max(1) as u32;
    let grid = Grid {
        size: (w, h),
        stride: ew,
        tile: (tw, th),
        tiles: t,
        clip_limit,
        lut_scale,
    };
    // The padded copy (if any) is moved out of `scratch` for the call and put back afterwards.
    let ext = std::mem::take(&mut scratch.ext);
    let hist_src = if (ew, eh) == (w, h) {
        src.as_raw()
    } else {
        &ext
    };
    run_core(src.as_raw(), hist_src, dst, &grid, scratch);
    scratch.ext = ext;
    Ok(())
}

/// Sizes and parameters of one CLAHE run.
struct Grid {
    /// Image size.
    size: (usize, usize),
    /// Row length of the (possibly padded) image the histograms read.
    stride: usize,
    /// Tile size.
    tile: (usize, usize),
    /// Tiles per axis.
    tiles: usize,
    /// Absolute clip limit (counts per bin).
    clip_limit: u32,
    /// `255.f / tile area`.
    lut_scale: f32,
}

/// Runs [`core`] compiled for AVX2 when the CPU has it: the same arithmetic (no fused
/// multiply-add; Rust never contracts), so the same pixels, on wider vectors.
fn run_core(src: &[u8], hist_src: &[u8], dst: &mut [u8], grid: &Grid, scratch: &mut ClaheScratch) {
    #[cfg(target_arch = "x86_64")]
    if std::arch::is_x86_feature_detected!("avx2") {
        // SAFETY: `core_avx2` requires only AVX2, which the running CPU was just found to have.
        unsafe { core_avx2(src, hist_src, dst, grid, scratch) };
        return;
    }
    core(src, hist_src, dst, grid, scratch);
}

#[cfg(target_arch = "x86_64")]
#[target_feature(enable = "avx2")]
fn core_avx2(src: &[u8], hist_src: &[u8], dst: &mut [u8], grid: &Grid, scratch: &mut ClaheScratch) {
    core(src, hist_src, dst, grid, scratch);
}

/// Tile LUTs (steps 2-3) and interpolation (step 4).
#[inline(always)]
fn core(src: &[u8], hist_src: &[u8], dst: &mut [u8], grid: &Grid, scratch: &mut ClaheScratch) {
    let t = grid.tiles;
    let (tw, th) = grid.tile;
    scratch.luts.resize(t * t, [0; 256]);
    for ty in 0..t {
        for tx in 0..t {
            let mut hist = tile_histogram(hist_src, grid.stride, (tx * tw, ty * th), (tw, th));
            clipped_cdf(&mut hist, grid.clip_limit);
            let lut = &mut scratch.luts[ty * t + tx];
            for (l, &c) in lut.iter_mut().zip(hist.iter()) {
                // Counts are at most the tile area (< 2^31): the signed conversion vectorises.
                *l = round_u8(c as i32 as f32 * grid.lut_scale);
            }
        }
    }
    interpolate(src, dst, grid.size, grid.tile, t, scratch);
}

/// 256-bin histogram of the `tw x th` tile at `(x0, y0)` of an image `stride` pixels wide.
#[inline(always)]
fn tile_histogram(
    img: &[u8],
    stride: usize,
    (x0, y0): (usize, usize),
    (tw, th): (usize, usize),
) -> [u32; 256] {
    let mut hist = [0u32; 256];
    for row in img.chunks_exact(stride).skip(y0).take(th) {
        for &v in &row[x0..x0 + tw] {
            hist[v as usize] += 1;
        }
    }
    hist
}

/// Clips at `limit`, redistributes the excess as OpenCV does and turns the histogram into its
/// cumulative sum (one pass for the clipping, one for redistribution and summing).
#[inline(always)]
fn clipped_cdf(hist: &mut [u32; 256], limit: u32) {
    let mut clipped = 0u32;
    for c in hist.iter_mut() {
        let excess = c.saturating_sub(limit);
        clipped += excess;
        *c -= excess;
    }
    let batch = clipped / 256;
    // OpenCV adds one more to bins i = 0, step, 2 step, ... while i < 256 and the residual
    // lasts, with step = max(256 / residual, 1).
    let mut residual = clipped - batch * 256;
    let step = 256u32.checked_div(residual).unwrap_or(256).max(1) as usize;
    let mut next = 0usize;
    let mut sum = 0u32;
    for (i, c) in hist.iter_mut().enumerate() {
        let mut add = batch;
        if i == next && residual > 0 {
            add += 1;
            residual -= 1;
            next += step;
        }
        sum += *c + add;
        *c = sum;
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
#[inline(always)]
fn tile_coord(p: usize, inv: f32, tiles: usize) -> (usize, usize, f32) {
    let f = p as f32 * inv - 0.5f32;
    let t1 = f.floor();
    let a = f - t1;
    let t1 = t1 as i64;
    let t2 = (t1 + 1).min(tiles as i64 - 1);
    (t1.max(0) as usize, t2.max(0) as usize, a)
}

/// Bilinear blend of the tile LUTs (step 4 of the module doc).
#[inline(always)]
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
                pack_luts(table, quad);
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

/// `table[v]` = the four LUT values at `v` as the bytes of one `u32` (written with shifts so
/// that it vectorises).
#[inline(always)]
fn pack_luts(table: &mut [u32], quad: [&[u8; 256]; 4]) {
    let Ok(table) = <&mut [u32; 256]>::try_from(table) else {
        return;
    };
    let [a, b, c, d] = quad;
    for v in 0..256 {
        table[v] = a[v] as u32 | (b[v] as u32) << 8 | (c[v] as u32) << 16 | (d[v] as u32) << 24;
    }
}

/// `dst[i] = round((l11 * xa1 + l12 * xa) * ya1 + (l21 * xa1 + l22 * xa) * ya)` in `f32`, in
/// OpenCV's order of operations, with `l11..l22` the bytes of `packed[i]`. Indexed over
/// equal-length slices so that it vectorises.
#[inline(always)]
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
        clipped_cdf(&mut hist, 4);
        let bins: Vec<u32> = (0..256)
            .map(|i| hist[i] - if i > 0 { hist[i - 1] } else { 0 })
            .collect();
        assert_eq!(hist[255], 300);
        assert_eq!(bins[10], 5);
        assert_eq!(bins[0], 2);
        assert_eq!(bins[6], 2);
        assert_eq!(bins[234], 2);
        assert_eq!(bins[1], 1);
        assert_eq!(bins[240], 1);
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
    fn dispatched_and_portable_builds_agree() -> Result<()> {
        // See resize.rs: the AVX2 build of `core` must give the portable build's pixels.
        let src = GrayImage::from_fn(150, 110, |x, y| image::Luma([((x * 7) ^ (y * 13)) as u8]));
        for tiles in [1, 3, 8] {
            let mut a = GrayImage::new(150, 110);
            clahe(&src, &mut a, 2.5, tiles)?;
            // The portable build, by hand: same grid as `clahe_with` (150x110 never divides by
            // 3 or 8, so it pads; with 1 tile it does not).
            let t = tiles as usize;
            let (ew, eh) = if 150 % t == 0 && 110 % t == 0 {
                (150, 110)
            } else {
                (150 + t - 150 % t, 110 + t - 110 % t)
            };
            let mut scratch = ClaheScratch::default();
            if (ew, eh) != (150, 110) {
                pad_reflect101(src.as_raw(), (150, 110), (ew, eh), &mut scratch);
            }
            let area = (ew / t) * (eh / t);
            let grid = Grid {
                size: (150, 110),
                stride: ew,
                tile: (ew / t, eh / t),
                tiles: t,
                clip_limit: ((2.5f64 * area as f64 / 256.0) as u32).max(1),
                lut_scale: 255.0f32 / area as f32,
            };
            let ext = std::mem::take(&mut scratch.ext);
            let hist_src = if (ew, eh) == (150, 110) {
                src.as_raw().as_slice()
            } else {
                &ext
            };
            let mut b = GrayImage::new(150, 110);
            core(src.as_raw(), hist_src, &mut b, &grid, &mut scratch);
            assert_eq!(a, b, "{tiles} tiles");
        }
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
