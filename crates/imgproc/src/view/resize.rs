//! Resizing: OpenCV's `INTER_AREA` for downscaling, bilinear for upscaling.
//!
//! Why by hand: the views must match OpenCV's pixels exactly, because CLAHE after the resize
//! amplifies every difference (one grey level upstream leaves only 63–73 % of CLAHE pixels within
//! one level). `fast_image_resize`'s box/convolution filters are not OpenCV's area interpolation
//! for non-integer factors and do not promise OpenCV's rounding, and `kornia-imgproc` 0.2's
//! OpenCV-compatible resize covers only `INTER_LINEAR`/`INTER_NEAREST`; so area resizing re-derives
//! `cv::resize(..., INTER_AREA)` for 8-bit images (OpenCV 5.0 `resize.cpp`):
//!
//! - integer factors (`src = k * dst` on both axes): the block sum; for 2x2 blocks
//!   `(sum + 2) >> 2`, otherwise `cvRound((float)sum * (1.f / area))` (ties to even);
//! - other factors: the per-axis weight tables of `computeResizeAreaTab` (built in `f64`, weights
//!   stored as `f32`), accumulated in `f32` in OpenCV's order (horizontal taps per source row,
//!   then `sum = beta * row` / `sum += beta * row` per destination row, no fused multiply-add) and
//!   rounded ties-to-even.
//!
//! Upscaling (either axis larger) uses `fast_image_resize`'s bilinear interpolation: there is no
//! parity requirement there and the library is fast and well tested.
//!
//! The area code reads the source through [`RowSource`] so that the hot view can convert RGB to
//! grey one row at a time while resizing, without a full-size grey image.

use fast_image_resize::images::{Image as FirImage, ImageRef as FirImageRef};
use fast_image_resize::{FilterType, PixelType, ResizeAlg, ResizeOptions, Resizer};
use image::{GrayImage, RgbImage};

use crate::{ImgprocError, Result};

use super::round::round_u8;

/// Supplies source rows to the area resizer (`cn` interleaved channels per pixel).
pub(crate) trait RowSource {
    /// Row `y` of the source, `width * cn` bytes.
    fn row(&mut self, y: usize) -> &[u8];
}

/// Rows of an interleaved 8-bit buffer.
pub(crate) struct SliceRows<'a> {
    pub data: &'a [u8],
    pub stride: usize,
}

impl RowSource for SliceRows<'_> {
    #[inline(always)]
    fn row(&mut self, y: usize) -> &[u8] {
        let start = y * self.stride;
        self.data.get(start..start + self.stride).unwrap_or(&[])
    }
}

/// One tap of OpenCV's `DecimateAlpha` table: destination index, source index, weight.
#[derive(Debug, Clone, Copy)]
struct Tap {
    di: usize,
    si: usize,
    alpha: f32,
}

/// Reusable buffers of the area resizer (tables and row accumulators).
#[derive(Debug, Default, Clone)]
pub(crate) struct AreaScratch {
    xtab: Vec<Tap>,
    ytab: Vec<Tap>,
    buf: Vec<f32>,
    sum: Vec<f32>,
    acc: Vec<u32>,
    /// Key of the cached tables: (sw, sh, dw, dh).
    key: Option<(usize, usize, usize, usize)>,
}

/// OpenCV's `computeResizeAreaTab` (with `cn = 1`: indices are in pixels).
fn area_tab(ssize: usize, dsize: usize, scale: f64, tab: &mut Vec<Tap>) {
    tab.clear();
    let ss = ssize as i64;
    for dx in 0..dsize {
        let fsx1 = dx as f64 * scale;
        let fsx2 = fsx1 + scale;
        let cell_width = scale.min(ssize as f64 - fsx1);
        let mut sx1 = fsx1.ceil() as i64;
        let mut sx2 = fsx2.floor() as i64;
        sx2 = sx2.min(ss - 1);
        sx1 = sx1.min(sx2);
        if sx1 as f64 - fsx1 > 1e-3 {
            tab.push(Tap {
                di: dx,
                si: (sx1 - 1).max(0) as usize,
                alpha: ((sx1 as f64 - fsx1) / cell_width) as f32,
            });
        }
        for sx in sx1..sx2 {
            tab.push(Tap {
                di: dx,
                si: sx.max(0) as usize,
                alpha: (1.0 / cell_width) as f32,
            });
        }
        if fsx2 - sx2 as f64 > 1e-3 {
            tab.push(Tap {
                di: dx,
                si: sx2.max(0) as usize,
                alpha: ((fsx2 - sx2 as f64).min(1.0).min(cell_width) / cell_width) as f32,
            });
        }
    }
}

/// The scale factors OpenCV derives from the sizes: `scale = 1 / (dst / src)` in `f64`.
fn scales(sw: usize, sh: usize, dw: usize, dh: usize) -> (f64, f64) {
    (1.0 / (dw as f64 / sw as f64), 1.0 / (dh as f64 / sh as f64))
}

/// `Some(k)` when OpenCV treats `scale` as the integer `k` (`|scale - k| < DBL_EPSILON`).
fn integer_scale(scale: f64) -> Option<usize> {
    let k = scale.round();
    ((scale - k).abs() < f64::EPSILON && k >= 1.0).then_some(k as usize)
}

/// True when `cv::resize(INTER_AREA)` uses true area averaging (no axis grows).
pub(crate) fn is_downscale(sw: u32, sh: u32, dw: u32, dh: u32) -> bool {
    dw <= sw && dh <= sh
}

/// Area-resizes `sw x sh` (`cn` channels, rows from `src`) into `dst` (`dw x dh`), bit-exact
/// with OpenCV. Requires `dw <= sw`, `dh <= sh`, all sizes non-zero (checked by the callers).
///
/// Runs the code compiled for AVX2 when the CPU has it: the same integer and `f32` operations
/// (Rust never fuses multiply-adds), so the same pixels, on wider vectors.
pub(crate) fn area_resize<R: RowSource>(
    src: &mut R,
    ssize: (usize, usize),
    cn: usize,
    dst: &mut [u8],
    dsize: (usize, usize),
    scratch: &mut AreaScratch,
) {
    #[cfg(target_arch = "x86_64")]
    if std::arch::is_x86_feature_detected!("avx2") {
        // SAFETY: `area_resize_avx2` requires only AVX2, which the running CPU was just found to
        // have.
        unsafe { area_resize_avx2(src, ssize, cn, dst, dsize, scratch) };
        return;
    }
    area_resize_portable(src, ssize, cn, dst, dsize, scratch);
}

#[cfg(target_arch = "x86_64")]
#[target_feature(enable = "avx2")]
fn area_resize_avx2<R: RowSource>(
    src: &mut R,
    ssize: (usize, usize),
    cn: usize,
    dst: &mut [u8],
    dsize: (usize, usize),
    scratch: &mut AreaScratch,
) {
    area_resize_portable(src, ssize, cn, dst, dsize, scratch);
}

/// [`area_resize`] for any CPU (also the body of the AVX2 build).
#[inline(always)]
pub(crate) fn area_resize_portable<R: RowSource>(
    src: &mut R,
    (sw, sh): (usize, usize),
    cn: usize,
    dst: &mut [u8],
    (dw, dh): (usize, usize),
    scratch: &mut AreaScratch,
) {
    let (scale_x, scale_y) = scales(sw, sh, dw, dh);
    if let (Some(ix), Some(iy)) = (integer_scale(scale_x), integer_scale(scale_y)) {
        area_integer(src, cn, dst, (dw, dh), (ix, iy), &mut scratch.acc);
        return;
    }
    if scratch.key != Some((sw, sh, dw, dh)) {
        area_tab(sw, dw, scale_x, &mut scratch.xtab);
        area_tab(sh, dh, scale_y, &mut scratch.ytab);
        scratch.key = Some((sw, sh, dw, dh));
    }
    let width = dw * cn;
    scratch.buf.clear();
    scratch.buf.resize(width, 0.0);
    scratch.sum.clear();
    scratch.sum.resize(width, 0.0);
    let (buf, sum) = (&mut scratch.buf, &mut scratch.sum);
    let xtab = &scratch.xtab;
    let mut prev_dy = scratch.ytab.first().map_or(0, |t| t.di);
    // `buf` holds the horizontal pass of row `buf_row`; a source row on a boundary between two
    // destination rows is used twice and computed once (OpenCV recomputes it: same values).
    let mut buf_row = usize::MAX;
    for yt in &scratch.ytab {
        if yt.si != buf_row {
            let row = src.row(yt.si);
            buf.fill(0.0);
            horizontal_taps(row, cn, xtab, buf);
            buf_row = yt.si;
        }
        let beta = yt.alpha;
        if yt.di != prev_dy {
            let out = &mut dst[prev_dy * width..(prev_dy + 1) * width];
            for ((o, s), b) in out.iter_mut().zip(sum.iter_mut()).zip(buf.iter()) {
                *o = round_u8(*s);
                *s = beta * *b;
            }
            prev_dy = yt.di;
        } else {
            for (s, b) in sum.iter_mut().zip(buf.iter()) {
                *s += beta * *b;
            }
        }
    }
    let out = &mut dst[prev_dy * width..(prev_dy + 1) * width];
    for (o, s) in out.iter_mut().zip(sum.iter()) {
        *o = round_u8(*s);
    }
}

/// `buf[di*cn + c] += row[si*cn + c] * alpha` over the taps, in table order.
#[inline(always)]
fn horizontal_taps(row: &[u8], cn: usize, xtab: &[Tap], buf: &mut [f32]) {
    match cn {
        1 => {
            for t in xtab {
                if let (Some(b), Some(&s)) = (buf.get_mut(t.di), row.get(t.si)) {
                    *b += s as f32 * t.alpha;
                }
            }
        }
        3 => {
            for t in xtab {
                let (d, s) = (t.di * 3, t.si * 3);
                if let (Some(b), Some(p)) = (buf.get_mut(d..d + 3), row.get(s..s + 3)) {
                    b[0] += p[0] as f32 * t.alpha;
                    b[1] += p[1] as f32 * t.alpha;
                    b[2] += p[2] as f32 * t.alpha;
                }
            }
        }
        _ => {
            for t in xtab {
                let (d, s) = (t.di * cn, t.si * cn);
                if let (Some(b), Some(p)) = (buf.get_mut(d..d + cn), row.get(s..s + cn)) {
                    for (b, &p) in b.iter_mut().zip(p) {
                        *b += p as f32 * t.alpha;
                    }
                }
            }
        }
    }
}

/// Integer factors: block sums in `u32`, OpenCV's two rounding rules.
#[inline(always)]
fn area_integer<R: RowSource>(
    src: &mut R,
    cn: usize,
    dst: &mut [u8],
    (dw, dh): (usize, usize),
    (ix, iy): (usize, usize),
    acc: &mut Vec<u32>,
) {
    let width = dw * cn;
    acc.clear();
    acc.resize(width, 0);
    let area = (ix * iy) as u32;
    let scale = 1.0f32 / area as f32;
    for (dy, out) in dst.chunks_exact_mut(width).take(dh).enumerate() {
        acc.fill(0);
        for sy in dy * iy..(dy + 1) * iy {
            let row = src.row(sy);
            add_block_row(row, cn, ix, acc);
        }
        if ix == 2 && iy == 2 {
            for (o, &a) in out.iter_mut().zip(acc.iter()) {
                *o = ((a + 2) >> 2) as u8;
            }
        } else {
            for (o, &a) in out.iter_mut().zip(acc.iter()) {
                *o = round_u8(a as f32 * scale);
            }
        }
    }
}

/// `acc[dx*cn + c] += sum of row[(dx*ix + k)*cn + c], k < ix`, specialised for the common cases
/// so that the compiler vectorises them.
#[inline(always)]
fn add_block_row(row: &[u8], cn: usize, ix: usize, acc: &mut [u32]) {
    match (cn, ix) {
        (_, 1) => {
            for (a, &p) in acc.iter_mut().zip(row) {
                *a += p as u32;
            }
        }
        (1, 2) => {
            for (a, p) in acc.iter_mut().zip(row.chunks_exact(2)) {
                *a += p[0] as u32 + p[1] as u32;
            }
        }
        (1, 4) => {
            for (a, p) in acc.iter_mut().zip(row.chunks_exact(4)) {
                *a += (p[0] as u32 + p[1] as u32) + (p[2] as u32 + p[3] as u32);
            }
        }
        (1, _) => {
            for (a, p) in acc.iter_mut().zip(row.chunks_exact(ix)) {
                *a += p.iter().map(|&v| v as u32).sum::<u32>();
            }
        }
        _ => {
            for (a, p) in acc.chunks_exact_mut(cn).zip(row.chunks_exact(ix * cn)) {
                for px in p.chunks_exact(cn) {
                    for (a, &v) in a.iter_mut().zip(px) {
                        *a += v as u32;
                    }
                }
            }
        }
    }
}

fn check_sizes(sw: u32, sh: u32, dw: u32, dh: u32) -> Result<()> {
    if sw == 0 || sh == 0 || dw == 0 || dh == 0 {
        return Err(ImgprocError::Size(format!(
            "resize {sw}x{sh} -> {dw}x{dh}: sizes must be non-zero"
        )));
    }
    Ok(())
}

/// Bilinear resize of an interleaved 8-bit buffer with `fast_image_resize`.
fn bilinear(
    src: &[u8],
    (sw, sh): (u32, u32),
    dst: &mut [u8],
    (dw, dh): (u32, u32),
    pixel: PixelType,
) -> Result<()> {
    let fir = |e: &dyn std::fmt::Display| ImgprocError::Size(format!("resize: {e}"));
    let src_view = FirImageRef::new(sw, sh, src, pixel).map_err(|e| fir(&e))?;
    let mut dst_view = FirImage::from_slice_u8(dw, dh, dst, pixel).map_err(|e| fir(&e))?;
    let options = ResizeOptions::new().resize_alg(ResizeAlg::Interpolation(FilterType::Bilinear));
    Resizer::new()
        .resize(&src_view, &mut dst_view, &options)
        .map_err(|e| fir(&e))
}

/// Resizes a grey image to the size of `dst`: OpenCV `INTER_AREA` (bit-exact) when no axis
/// grows, bilinear otherwise; equal sizes copy.
pub fn resize_gray(src: &GrayImage, dst: &mut GrayImage) -> Result<()> {
    resize_gray_with(src, dst, &mut AreaScratch::default())
}

/// [`resize_gray`] with reusable buffers.
pub(crate) fn resize_gray_with(
    src: &GrayImage,
    dst: &mut GrayImage,
    scratch: &mut AreaScratch,
) -> Result<()> {
    let ((sw, sh), (dw, dh)) = (src.dimensions(), dst.dimensions());
    check_sizes(sw, sh, dw, dh)?;
    if (sw, sh) == (dw, dh) {
        dst.copy_from_slice(src);
        return Ok(());
    }
    if !is_downscale(sw, sh, dw, dh) {
        return bilinear(src, (sw, sh), dst, (dw, dh), PixelType::U8);
    }
    let mut rows = SliceRows {
        data: src.as_raw(),
        stride: sw as usize,
    };
    area_resize(
        &mut rows,
        (sw as usize, sh as usize),
        1,
        dst,
        (dw as usize, dh as usize),
        scratch,
    );
    Ok(())
}

/// Resizes an RGB image to the size of `dst`: OpenCV `INTER_AREA` (bit-exact) when no axis
/// grows, bilinear otherwise; equal sizes copy.
pub fn resize_rgb(src: &RgbImage, dst: &mut RgbImage) -> Result<()> {
    resize_rgb_with(src, dst, &mut AreaScratch::default())
}

/// [`resize_rgb`] with reusable buffers.
pub(crate) fn resize_rgb_with(
    src: &RgbImage,
    dst: &mut RgbImage,
    scratch: &mut AreaScratch,
) -> Result<()> {
    let ((sw, sh), (dw, dh)) = (src.dimensions(), dst.dimensions());
    check_sizes(sw, sh, dw, dh)?;
    if (sw, sh) == (dw, dh) {
        dst.copy_from_slice(src);
        return Ok(());
    }
    if !is_downscale(sw, sh, dw, dh) {
        return bilinear(src, (sw, sh), dst, (dw, dh), PixelType::U8x3);
    }
    let mut rows = SliceRows {
        data: src.as_raw(),
        stride: sw as usize * 3,
    };
    area_resize(
        &mut rows,
        (sw as usize, sh as usize),
        3,
        dst,
        (dw as usize, dh as usize),
        scratch,
    );
    Ok(())
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn area_4x4_to_2x2_is_block_mean_with_ties_to_even() -> Result<()> {
        // Blocks (2x2 factor uses (s + 2) >> 2: ties up).
        let src = GrayImage::from_raw(
            4,
            4,
            vec![0, 1, 10, 10, 0, 1, 10, 11, 5, 5, 0, 0, 5, 5, 0, 2],
        )
        .ok_or_else(|| ImgprocError::Size("raw".into()))?;
        let mut dst = GrayImage::new(2, 2);
        resize_gray(&src, &mut dst)?;
        // sums 2, 41, 20, 2 -> (2+2)>>2 = 1, (41+2)>>2 = 10, 5, 1
        assert_eq!(dst.as_raw(), &vec![1, 10, 5, 1]);
        Ok(())
    }

    #[test]
    fn area_4x_factor_rounds_half_to_even() -> Result<()> {
        // 4x4 -> 1x1: sum 8 over 16 pixels = 0.5 -> 0 (ties to even); sum 24 -> 1.5 -> 2.
        let mut raw = vec![0u8; 16];
        raw[..8].fill(1);
        let src = GrayImage::from_raw(4, 4, raw).ok_or_else(|| ImgprocError::Size("raw".into()))?;
        let mut dst = GrayImage::new(1, 1);
        resize_gray(&src, &mut dst)?;
        assert_eq!(dst.as_raw(), &vec![0]);
        let mut raw = vec![1u8; 16];
        raw[..8].fill(2);
        let src = GrayImage::from_raw(4, 4, raw).ok_or_else(|| ImgprocError::Size("raw".into()))?;
        resize_gray(&src, &mut dst)?;
        assert_eq!(dst.as_raw(), &vec![2]);
        Ok(())
    }

    #[test]
    fn area_non_integer_factor_weights() -> Result<()> {
        // 3 -> 2 pixels: weights (1, 0.5) / 1.5 and (0.5, 1) / 1.5.
        let src = GrayImage::from_raw(3, 1, vec![30, 60, 90])
            .ok_or_else(|| ImgprocError::Size("raw".into()))?;
        let mut dst = GrayImage::new(2, 1);
        resize_gray(&src, &mut dst)?;
        assert_eq!(dst.as_raw(), &vec![40, 80]);
        Ok(())
    }

    #[test]
    fn upscale_is_bilinear_and_constant_stays_constant() -> Result<()> {
        let src = RgbImage::from_pixel(3, 2, image::Rgb([7, 100, 250]));
        let mut dst = RgbImage::new(7, 5);
        resize_rgb(&src, &mut dst)?;
        assert!(dst.pixels().all(|p| p.0 == [7, 100, 250]));
        Ok(())
    }

    #[test]
    fn dispatched_and_portable_builds_agree() {
        // On CPUs with AVX2 `area_resize` runs a separately compiled copy; both must give the
        // same pixels (on other CPUs this compares the portable code with itself).
        let mut state = 0x2545_f491u32;
        let raw: Vec<u8> = (0..97 * 61 * 3)
            .map(|_| {
                state ^= state << 13;
                state ^= state >> 17;
                state ^= state << 5;
                (state >> 24) as u8
            })
            .collect();
        for cn in [1, 3] {
            for (dw, dh) in [(40, 30), (33, 17), (97, 30), (48, 61), (1, 1)] {
                let (mut a, mut b) = (vec![0u8; dw * dh * cn], vec![0u8; dw * dh * cn]);
                let mut rows = SliceRows {
                    data: &raw[..97 * 61 * cn],
                    stride: 97 * cn,
                };
                area_resize(
                    &mut rows,
                    (97, 61),
                    cn,
                    &mut a,
                    (dw, dh),
                    &mut AreaScratch::default(),
                );
                area_resize_portable(
                    &mut rows,
                    (97, 61),
                    cn,
                    &mut b,
                    (dw, dh),
                    &mut AreaScratch::default(),
                );
                assert_eq!(a, b, "cn {cn}, {dw}x{dh}");
            }
        }
    }

    #[test]
    fn zero_sizes_are_errors() {
        let src = GrayImage::new(4, 4);
        let mut dst = GrayImage::new(0, 3);
        assert!(resize_gray(&src, &mut dst).is_err());
        let src = GrayImage::new(0, 4);
        let mut dst = GrayImage::new(2, 2);
        assert!(resize_gray(&src, &mut dst).is_err());
    }
}
