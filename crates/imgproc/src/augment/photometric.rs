//! Photometric augmentation: brightness, contrast, gamma, colour, blur, noise, erasing.
//!
//! Every op keeps the pixel geometry, so all of them are safe for every pose label. The tone ops
//! (brightness, contrast, gamma) are 256-entry lookup tables on bytes and work on any channel
//! count; [`augment`](super::augment) fuses them into one table. Written here rather than taken
//! from `image::imageops` because those allocate a new image per call (no buffer reuse), have no
//! seeded noise or erasing, and `imageops::blur` has no fixed border rule.

use std::sync::OnceLock;

use image::{ImageBuffer, Pixel, RgbImage};
use rand::Rng;

use super::geometric::{bytes, bytes_mut, reflect101, same_size};
use crate::{ImgprocError, Result};

/// An 8-bit lookup table.
pub(crate) type Lut = [u8; 256];

/// The table that changes nothing.
pub(crate) fn identity_lut() -> Lut {
    std::array::from_fn(|v| v as u8)
}

/// `second ∘ first`.
pub(crate) fn compose_lut(first: &Lut, second: &Lut) -> Lut {
    std::array::from_fn(|v| second[usize::from(first[v])])
}

/// Rounds to the nearest byte, clamping to [0, 255] (NaN goes to 0).
#[inline]
pub(crate) fn to_byte(v: f32) -> u8 {
    (v + 0.5).clamp(0.0, 255.0) as u8
}

fn check_finite_nonneg(name: &str, v: f64) -> Result<()> {
    if v.is_finite() && v >= 0.0 {
        Ok(())
    } else {
        Err(ImgprocError::Param(format!(
            "{name} must be finite and ≥ 0, got {v}"
        )))
    }
}

/// Brightness table: `v · factor`.
pub(crate) fn brightness_lut(factor: f64) -> Result<Lut> {
    check_finite_nonneg("brightness factor", factor)?;
    Ok(std::array::from_fn(|v| to_byte((v as f64 * factor) as f32)))
}

/// Contrast table about `mean`: `mean + (v − mean) · factor`.
pub(crate) fn contrast_lut(factor: f64, mean: f64) -> Result<Lut> {
    check_finite_nonneg("contrast factor", factor)?;
    Ok(std::array::from_fn(|v| {
        to_byte((mean + (v as f64 - mean) * factor) as f32)
    }))
}

/// Gamma table: `255 · (v / 255)^gamma`.
pub(crate) fn gamma_lut(gamma: f64) -> Result<Lut> {
    if !(gamma.is_finite() && gamma > 0.0) {
        return Err(ImgprocError::Param(format!(
            "gamma must be finite and > 0, got {gamma}"
        )));
    }
    Ok(std::array::from_fn(|v| {
        to_byte((255.0 * (v as f64 / 255.0).powf(gamma)) as f32)
    }))
}

/// Mean of all bytes after mapping them through `lut` (one histogram pass).
pub(crate) fn mapped_mean(bytes: &[u8], lut: &Lut) -> f64 {
    if bytes.is_empty() {
        return 0.0;
    }
    let mut hist = [0u64; 256];
    for &b in bytes {
        hist[usize::from(b)] += 1;
    }
    let sum: u64 = hist
        .iter()
        .zip(lut.iter())
        .map(|(n, &v)| n * u64::from(v))
        .sum();
    sum as f64 / bytes.len() as f64
}

fn map_lut<P: Pixel<Subpixel = u8>>(
    src: &ImageBuffer<P, Vec<u8>>,
    dst: &mut ImageBuffer<P, Vec<u8>>,
    lut: &Lut,
) -> Result<()> {
    same_size(src, dst)?;
    for (o, &i) in bytes_mut(dst)?.iter_mut().zip(bytes(src)?) {
        *o = lut[usize::from(i)];
    }
    Ok(())
}

/// Multiplies every channel by `factor` (≥ 0), clamped to 255: an exposure change.
///
/// Multiplicative rather than additive because a longer exposure or a brighter lamp scales the
/// light reaching the sensor; black stays black.
pub fn adjust_brightness<P: Pixel<Subpixel = u8>>(
    src: &ImageBuffer<P, Vec<u8>>,
    dst: &mut ImageBuffer<P, Vec<u8>>,
    factor: f64,
) -> Result<()> {
    map_lut(src, dst, &brightness_lut(factor)?)
}

/// Scales the distance of every value from the image mean by `factor` (≥ 0; 0 gives a flat
/// image of the mean), clamped to [0, 255]. The mean is over all pixels and channels, so the
/// op does not shift colours.
pub fn adjust_contrast<P: Pixel<Subpixel = u8>>(
    src: &ImageBuffer<P, Vec<u8>>,
    dst: &mut ImageBuffer<P, Vec<u8>>,
    factor: f64,
) -> Result<()> {
    let mean = mapped_mean(bytes(src)?, &identity_lut());
    map_lut(src, dst, &contrast_lut(factor, mean)?)
}

/// Applies `255 · (v / 255)^gamma` (gamma > 0; < 1 brightens the shadows, > 1 darkens them):
/// a different camera response curve.
pub fn adjust_gamma<P: Pixel<Subpixel = u8>>(
    src: &ImageBuffer<P, Vec<u8>>,
    dst: &mut ImageBuffer<P, Vec<u8>>,
    gamma: f64,
) -> Result<()> {
    map_lut(src, dst, &gamma_lut(gamma)?)
}

/// The 3×3 RGB matrix that scales chroma by `saturation` and turns hue by `hue` radians.
///
/// Works in YIQ, where Y is BT.601 luma and (I, Q) the chroma plane: saturation scales (I, Q),
/// hue rotates it, and luma is untouched. One matrix per image instead of a per-pixel HSV round
/// trip; the hue turn agrees with an HSV hue shift to within a few degrees. Positive `hue` moves
/// red towards yellow (the direction of increasing HSV hue), which in (I, Q) is clockwise.
pub(crate) fn color_matrix(saturation: f64, hue: f64) -> Result<[[f32; 3]; 3]> {
    check_finite_nonneg("saturation", saturation)?;
    if !hue.is_finite() {
        return Err(ImgprocError::Param(format!(
            "hue shift must be finite, got {hue}"
        )));
    }
    const T: [[f64; 3]; 3] = [
        [0.299, 0.587, 0.114],
        [0.595_716, -0.274_453, -0.321_263],
        [0.211_456, -0.522_591, 0.311_135],
    ];
    let t_inv = invert3(&T);
    let (s, c) = (-hue).sin_cos();
    let chroma = [
        [1.0, 0.0, 0.0],
        [0.0, saturation * c, -saturation * s],
        [0.0, saturation * s, saturation * c],
    ];
    let m = mul3(&t_inv, &mul3(&chroma, &T));
    Ok(m.map(|row| row.map(|v| v as f32)))
}

pub(crate) fn mul3(a: &[[f64; 3]; 3], b: &[[f64; 3]; 3]) -> [[f64; 3]; 3] {
    std::array::from_fn(|i| std::array::from_fn(|j| (0..3).map(|k| a[i][k] * b[k][j]).sum()))
}

fn invert3(m: &[[f64; 3]; 3]) -> [[f64; 3]; 3] {
    // Adjugate over determinant; T is well conditioned (det ≈ 0.3).
    let c = |i: usize, j: usize| {
        let (i1, i2) = ((i + 1) % 3, (i + 2) % 3);
        let (j1, j2) = ((j + 1) % 3, (j + 2) % 3);
        m[i1][j1] * m[i2][j2] - m[i1][j2] * m[i2][j1]
    };
    let det: f64 = (0..3).map(|j| m[0][j] * c(0, j)).sum();
    std::array::from_fn(|i| std::array::from_fn(|j| c(j, i) / det))
}

/// Applies a 3×3 colour matrix to interleaved RGB bytes.
pub(crate) fn apply_color_matrix(src: &[u8], dst: &mut [u8], m: &[[f32; 3]; 3]) {
    for (o, i) in dst.chunks_exact_mut(3).zip(src.chunks_exact(3)) {
        let (r, g, b) = (f32::from(i[0]), f32::from(i[1]), f32::from(i[2]));
        for (oc, row) in o.iter_mut().zip(m.iter()) {
            *oc = to_byte(row[0] * r + row[1] * g + row[2] * b);
        }
    }
}

/// Scales colour saturation by `saturation` (≥ 0; 0 gives grey, 1 unchanged) and shifts hue by
/// `hue` radians (positive: red towards yellow), keeping BT.601 luma up to clamping.
///
/// Both are one 3×3 matrix in YIQ space (scale and turn the chroma plane), so the cost is a
/// matrix product per pixel rather than an HSV round trip; the hue turn agrees with an HSV hue
/// shift to within a few degrees.
pub fn adjust_color(src: &RgbImage, dst: &mut RgbImage, saturation: f64, hue: f64) -> Result<()> {
    same_size(src, dst)?;
    let m = color_matrix(saturation, hue)?;
    apply_color_matrix(bytes(src)?, bytes_mut(dst)?, &m);
    Ok(())
}

/// Quantiles of the standard normal distribution at `(i + ½) / 4096`, rescaled to unit variance.
///
/// Sensor noise needs one normal sample per byte; a table lookup on 12 random bits is several
/// times cheaper than Box–Muller (a log, a root and a sine per pair) and, being symmetric, has
/// exactly zero mean. The tails stop at ±3.4σ, which is no loss for augmentation.
fn normal_table() -> &'static [f32; 4096] {
    static TABLE: OnceLock<[f32; 4096]> = OnceLock::new();
    TABLE.get_or_init(|| {
        let mut t = [0f64; 4096];
        for i in 0..2048 {
            let q = inverse_normal_cdf((i as f64 + 0.5) / 4096.0);
            t[i] = q;
            t[4095 - i] = -q;
        }
        let var = t.iter().map(|q| q * q).sum::<f64>() / 4096.0;
        let scale = 1.0 / var.sqrt();
        t.map(|q| (q * scale) as f32)
    })
}

/// Acklam's rational approximation of the normal quantile function (relative error < 1.2e-9).
fn inverse_normal_cdf(p: f64) -> f64 {
    const A: [f64; 6] = [
        -3.969_683_028_665_376e1,
        2.209_460_984_245_205e2,
        -2.759_285_104_469_687e2,
        1.383_577_518_672_69e2,
        -3.066_479_806_614_716e1,
        2.506_628_277_459_239,
    ];
    const B: [f64; 5] = [
        -5.447_609_879_822_406e1,
        1.615_858_368_580_409e2,
        -1.556_989_798_598_866e2,
        6.680_131_188_771_972e1,
        -1.328_068_155_288_572e1,
    ];
    const C: [f64; 6] = [
        -7.784_894_002_430_293e-3,
        -3.223_964_580_411_365e-1,
        -2.400_758_277_161_838,
        -2.549_732_539_343_734,
        4.374_664_141_464_968,
        2.938_163_982_698_783,
    ];
    const D: [f64; 4] = [
        7.784_695_709_041_462e-3,
        3.224_671_290_700_398e-1,
        2.445_134_137_142_996,
        3.754_408_661_907_416,
    ];
    const P_LOW: f64 = 0.024_25;
    let tail = |q: f64| {
        (((((C[0] * q + C[1]) * q + C[2]) * q + C[3]) * q + C[4]) * q + C[5])
            / ((((D[0] * q + D[1]) * q + D[2]) * q + D[3]) * q + 1.0)
    };
    if p < P_LOW {
        tail((-2.0 * p.ln()).sqrt())
    } else if p > 1.0 - P_LOW {
        -tail((-2.0 * (1.0 - p).ln()).sqrt())
    } else {
        let q = p - 0.5;
        let r = q * q;
        (((((A[0] * r + A[1]) * r + A[2]) * r + A[3]) * r + A[4]) * r + A[5]) * q
            / (((((B[0] * r + B[1]) * r + B[2]) * r + B[3]) * r + B[4]) * r + 1.0)
    }
}

/// Adds independent zero-mean Gaussian noise of standard deviation `sigma` grey levels (≥ 0) to
/// every channel of every pixel, clamped to [0, 255]: sensor read and shot noise, roughly.
pub fn add_gaussian_noise<P: Pixel<Subpixel = u8>, R: Rng + ?Sized>(
    src: &ImageBuffer<P, Vec<u8>>,
    dst: &mut ImageBuffer<P, Vec<u8>>,
    sigma: f64,
    rng: &mut R,
) -> Result<()> {
    same_size(src, dst)?;
    check_finite_nonneg("noise sigma", sigma)?;
    add_noise_slice(bytes(src)?, bytes_mut(dst)?, sigma as f32, rng);
    Ok(())
}

pub(crate) fn add_noise_slice<R: Rng + ?Sized>(
    src: &[u8],
    dst: &mut [u8],
    sigma: f32,
    rng: &mut R,
) {
    let table = normal_table();
    // Five 12-bit table indices from every 64 random bits.
    for (o, i) in dst.chunks_mut(5).zip(src.chunks(5)) {
        let mut bits = rng.next_u64();
        for (ob, &ib) in o.iter_mut().zip(i.iter()) {
            let z = table[(bits & 0xFFF) as usize];
            bits >>= 12;
            *ob = to_byte(f32::from(ib) + sigma * z);
        }
    }
}

/// The largest blur sigma accepted, pixels: beyond it the image is a flat mean anyway.
pub const MAX_BLUR_SIGMA: f64 = 50.0;

/// Normalised Gaussian taps for `sigma`, radius `ceil(3σ)` (at least 1).
fn gaussian_kernel(sigma: f64) -> Vec<f32> {
    let r = ((3.0 * sigma).ceil() as usize).max(1);
    let k: Vec<f64> = (0..=2 * r)
        .map(|i| {
            let x = i as f64 - r as f64;
            (-x * x / (2.0 * sigma * sigma)).exp()
        })
        .collect();
    let sum: f64 = k.iter().sum();
    k.iter().map(|v| (v / sum) as f32).collect()
}

/// Gaussian blur with standard deviation `sigma` pixels (0 ≤ sigma ≤ [`MAX_BLUR_SIGMA`]; 0
/// copies), separable, border reflect-101 (OpenCV's default): defocus and motion softness.
pub fn gaussian_blur<P: Pixel<Subpixel = u8>>(
    src: &ImageBuffer<P, Vec<u8>>,
    dst: &mut ImageBuffer<P, Vec<u8>>,
    sigma: f64,
) -> Result<()> {
    same_size(src, dst)?;
    check_finite_nonneg("blur sigma", sigma)?;
    if sigma > MAX_BLUR_SIGMA {
        return Err(ImgprocError::Param(format!(
            "blur sigma {sigma} exceeds {MAX_BLUR_SIGMA} pixels"
        )));
    }
    let (w, h) = (src.width() as usize, src.height() as usize);
    blur_slice(
        bytes(src)?,
        bytes_mut(dst)?,
        w,
        h,
        usize::from(P::CHANNEL_COUNT),
        sigma,
    );
    Ok(())
}

pub(crate) fn blur_slice(src: &[u8], dst: &mut [u8], w: usize, h: usize, cn: usize, sigma: f64) {
    if sigma == 0.0 || w == 0 || h == 0 {
        dst.copy_from_slice(src);
        return;
    }
    let k = gaussian_kernel(sigma);
    let r = k.len() / 2;
    let row_len = w * cn;
    // Horizontal pass into f32, one reflected row at a time; the reflection is a gather table
    // computed once, so the per-row work is a copy and a contiguous multiply-add per tap.
    let xs: Vec<usize> = (0..w + 2 * r)
        .map(|px| reflect101(px as i64 - r as i64, w))
        .collect();
    let mut tmp = vec![0f32; row_len * h];
    let mut pad = vec![0f32; (w + 2 * r) * cn];
    for (srow, trow) in src.chunks_exact(row_len).zip(tmp.chunks_exact_mut(row_len)) {
        for (out, &sx) in pad.chunks_exact_mut(cn).zip(xs.iter()) {
            for (o, &v) in out.iter_mut().zip(&srow[sx * cn..sx * cn + cn]) {
                *o = f32::from(v);
            }
        }
        for (j, &kj) in k.iter().enumerate() {
            let off = j * cn;
            for (t, &p) in trow.iter_mut().zip(&pad[off..off + row_len]) {
                *t += kj * p;
            }
        }
    }
    // Vertical pass, accumulating whole rows so the inner loop runs over contiguous memory.
    let mut acc = vec![0f32; row_len];
    for (y, drow) in dst.chunks_exact_mut(row_len).enumerate() {
        acc.fill(0.0);
        for (j, &kj) in k.iter().enumerate() {
            let sy = reflect101(y as i64 + j as i64 - r as i64, h);
            for (a, &t) in acc.iter_mut().zip(&tmp[sy * row_len..(sy + 1) * row_len]) {
                *a += kj * t;
            }
        }
        for (d, &a) in drow.iter_mut().zip(acc.iter()) {
            *d = to_byte(a);
        }
    }
}

/// How an erased rectangle is filled.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum EraseFill {
    /// One random colour per rectangle: a plain occluder (a person's jacket, a sign).
    Color,
    /// Independent random bytes per pixel: an occluder with no usable structure.
    Noise,
}

/// Parameters of [`random_erase`].
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct EraseParams {
    /// Number of rectangles.
    pub count: u32,
    /// Total area of the rectangles as a fraction of the image, in [0, 1], split equally between
    /// them (overlaps make the covered fraction smaller).
    pub area_fraction: f64,
    /// Range of the rectangles' width/height ratio, both > 0; drawn log-uniformly so that
    /// `r` and `1/r` are equally likely.
    pub aspect: [f64; 2],
    /// How rectangles are filled.
    pub fill: EraseFill,
}

/// One erased rectangle, pixels.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub struct EraseRect {
    /// Left column.
    pub x: u32,
    /// Top row.
    pub y: u32,
    /// Width.
    pub w: u32,
    /// Height.
    pub h: u32,
}

impl EraseParams {
    pub(crate) fn validate(&self) -> Result<()> {
        let [a0, a1] = self.aspect;
        let ok = self.area_fraction.is_finite()
            && (0.0..=1.0).contains(&self.area_fraction)
            && a0.is_finite()
            && a1.is_finite()
            && a0 > 0.0
            && a0 <= a1;
        if ok {
            Ok(())
        } else {
            Err(ImgprocError::Param(format!(
                "erasing needs area fraction in [0, 1] and 0 < aspect min ≤ max; got {self:?}"
            )))
        }
    }
}

/// Occludes `count` random rectangles (random erasing, Zhong et al. 2020) so that a network
/// cannot rely on any single landmark; returns the rectangles.
pub fn random_erase<P: Pixel<Subpixel = u8>, R: Rng + ?Sized>(
    src: &ImageBuffer<P, Vec<u8>>,
    dst: &mut ImageBuffer<P, Vec<u8>>,
    params: &EraseParams,
    rng: &mut R,
) -> Result<Vec<EraseRect>> {
    same_size(src, dst)?;
    params.validate()?;
    let d = bytes_mut(dst)?;
    d.copy_from_slice(bytes(src)?);
    Ok(erase_slice(
        d,
        src.width(),
        src.height(),
        usize::from(P::CHANNEL_COUNT),
        params,
        rng,
    ))
}

pub(crate) fn erase_slice<R: Rng + ?Sized>(
    buf: &mut [u8],
    w: u32,
    h: u32,
    cn: usize,
    params: &EraseParams,
    rng: &mut R,
) -> Vec<EraseRect> {
    let mut rects = Vec::with_capacity(params.count as usize);
    if w == 0 || h == 0 || params.count == 0 {
        return rects;
    }
    let (wf, hf) = (f64::from(w), f64::from(h));
    let area = params.area_fraction * wf * hf / f64::from(params.count);
    let (l0, l1) = (params.aspect[0].ln(), params.aspect[1].ln());
    for _ in 0..params.count {
        let ratio = (l0 + (l1 - l0) * rng.random::<f64>()).exp();
        // Width from the aspect, then height from the area, each clamped to the image so that
        // a very wide request still covers its area where it can.
        let rw = (area * ratio).sqrt().round().clamp(0.0, wf);
        let rh = if rw > 0.0 {
            (area / rw).round().clamp(0.0, hf)
        } else {
            0.0
        };
        let rw = if rh > 0.0 && rh >= hf {
            (area / hf).round().clamp(0.0, wf)
        } else {
            rw
        };
        let (rw, rh) = (rw as u32, rh as u32);
        let x = (rng.random::<f64>() * f64::from(w - rw + 1)).floor() as u32;
        let y = (rng.random::<f64>() * f64::from(h - rh + 1)).floor() as u32;
        let (x, y) = (x.min(w - rw), y.min(h - rh));
        let colour: [u8; 4] = rng.random();
        for row in y..y + rh {
            let start = (row as usize * w as usize + x as usize) * cn;
            let line = &mut buf[start..start + rw as usize * cn];
            match params.fill {
                EraseFill::Color => {
                    for px in line.chunks_exact_mut(cn) {
                        for (k, b) in px.iter_mut().enumerate() {
                            *b = colour[k % 4];
                        }
                    }
                }
                EraseFill::Noise => rng.fill(line),
            }
        }
        rects.push(EraseRect { x, y, w: rw, h: rh });
    }
    rects
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::augment::test_util::{mean_var, noise_image, scene};
    use image::{GrayImage, Luma, Rgb};
    use rand::SeedableRng;
    use rand_chacha::ChaCha8Rng;

    /// Every grey level once per row, 4 rows.
    fn ramp() -> GrayImage {
        GrayImage::from_fn(256, 4, |x, _| Luma([x as u8]))
    }

    fn monotone(img: &GrayImage) -> bool {
        img.as_raw()[..256].windows(2).all(|w| w[0] <= w[1])
    }

    #[test]
    fn tone_ops_are_monotone_and_clamped() -> Result<()> {
        let src = ramp();
        let mut dst = GrayImage::new(256, 4);
        for f in [0.0, 0.5, 1.0, 1.3, 3.0] {
            adjust_brightness(&src, &mut dst, f)?;
            assert!(monotone(&dst), "brightness {f}");
            assert_eq!(dst.get_pixel(100, 0)[0], to_byte((100.0 * f) as f32));
            if f > 1.0 {
                assert_eq!(dst.get_pixel(255, 0)[0], 255, "clamped");
            }
            adjust_contrast(&src, &mut dst, f)?;
            assert!(monotone(&dst), "contrast {f}");
            // The ramp's mean is 127.5: it stays put, the ends move away from it or clamp.
            let (m, _) = mean_var(&dst);
            assert!((m - 127.5).abs() < 1.0, "contrast {f}: mean {m}");
            if f > 1.0 {
                assert_eq!((dst.get_pixel(0, 0)[0], dst.get_pixel(255, 0)[0]), (0, 255));
            }
        }
        for g in [0.4, 0.8, 1.0, 1.5, 2.5] {
            adjust_gamma(&src, &mut dst, g)?;
            assert!(monotone(&dst), "gamma {g}");
            assert_eq!((dst.get_pixel(0, 0)[0], dst.get_pixel(255, 0)[0]), (0, 255));
            let mid = dst.get_pixel(128, 0)[0];
            assert!(
                if g < 1.0 { mid > 128 } else { mid <= 128 },
                "gamma {g}: {mid}"
            );
        }
        adjust_brightness(&src, &mut dst, 1.0)?;
        assert_eq!(dst, src);
        adjust_contrast(&src, &mut dst, 0.0)?;
        assert!(dst.pixels().all(|p| p[0] == 128), "contrast 0 is the mean");
        Ok(())
    }

    #[test]
    fn colour_jitter_keeps_luma() -> Result<()> {
        let src = scene(64, 48);
        let mut dst = RgbImage::new(64, 48);
        adjust_color(&src, &mut dst, 1.0, 0.0)?;
        let max_diff = |a: &RgbImage, b: &RgbImage| {
            a.as_raw()
                .iter()
                .zip(b.as_raw())
                .map(|(&p, &q)| p.abs_diff(q))
                .max()
                .unwrap_or(0)
        };
        assert!(max_diff(&src, &dst) <= 1, "neutral jitter is the identity");
        adjust_color(&src, &mut dst, 0.0, 0.0)?;
        for (s, d) in src.pixels().zip(dst.pixels()) {
            let luma = 0.299 * f64::from(s[0]) + 0.587 * f64::from(s[1]) + 0.114 * f64::from(s[2]);
            for c in 0..3 {
                assert!(
                    (f64::from(d[c]) - luma).abs() <= 1.0,
                    "grey at saturation 0"
                );
            }
        }
        // A hue shift of +30° moves a (soft, so nothing clamps) red towards yellow: green rises
        // above blue, luma stays.
        let red = RgbImage::from_pixel(2, 2, Rgb([180, 90, 90]));
        let mut out = RgbImage::new(2, 2);
        adjust_color(&red, &mut out, 1.0, 30f64.to_radians())?;
        let p = out.get_pixel(0, 0);
        assert!(p[1] > p[2] + 20 && p[0] > p[1], "{p:?}");
        let luma = |p: &Rgb<u8>| {
            0.299 * f64::from(p[0]) + 0.587 * f64::from(p[1]) + 0.114 * f64::from(p[2])
        };
        assert!((luma(p) - luma(red.get_pixel(0, 0))).abs() < 1.0, "{p:?}");
        Ok(())
    }

    #[test]
    fn noise_is_zero_mean_with_the_requested_sigma() -> Result<()> {
        let src = RgbImage::from_pixel(200, 200, Rgb([128, 128, 128]));
        let mut dst = RgbImage::new(200, 200);
        let mut rng = ChaCha8Rng::seed_from_u64(5);
        add_gaussian_noise(&src, &mut dst, 10.0, &mut rng)?;
        let (m, v) = mean_var(&dst);
        assert!((m - 128.0).abs() < 0.1, "mean {m}");
        assert!((v.sqrt() - 10.0).abs() < 0.3, "sigma {}", v.sqrt());
        // The table is exactly symmetric with unit variance.
        let t = normal_table();
        assert!(t.iter().map(|&z| f64::from(z)).sum::<f64>().abs() < 1e-3);
        let var = t.iter().map(|&z| f64::from(z).powi(2)).sum::<f64>() / 4096.0;
        assert!((var - 1.0).abs() < 1e-5);
        add_gaussian_noise(&src, &mut dst, 0.0, &mut rng)?;
        assert_eq!(dst, src);
        Ok(())
    }

    #[test]
    fn blur_reduces_variance() -> Result<()> {
        let src = noise_image(64, 48, 1);
        let mut dst = RgbImage::new(64, 48);
        let (m0, v0) = mean_var(&src);
        let mut last = v0;
        for sigma in [0.5, 1.0, 2.0] {
            gaussian_blur(&src, &mut dst, sigma)?;
            let (m, v) = mean_var(&dst);
            assert!(v < last, "sigma {sigma}: variance {v} not below {last}");
            assert!((m - m0).abs() < 1.0, "blur keeps the mean");
            last = v;
        }
        gaussian_blur(&src, &mut dst, 0.0)?;
        assert_eq!(dst, src);
        let flat = GrayImage::from_pixel(5, 3, Luma([77]));
        let mut out = GrayImage::new(5, 3);
        gaussian_blur(&flat, &mut out, 4.0)?;
        assert_eq!(
            out, flat,
            "a flat image stays flat, even with a kernel wider than it"
        );
        Ok(())
    }

    #[test]
    fn erasing_covers_the_requested_area() -> Result<()> {
        let src = RgbImage::from_pixel(200, 100, Rgb([1, 2, 3]));
        let mut dst = RgbImage::new(200, 100);
        let mut rng = ChaCha8Rng::seed_from_u64(11);
        for (fraction, fill) in [
            (0.25, EraseFill::Color),
            (0.1, EraseFill::Noise),
            (1.0, EraseFill::Color),
        ] {
            for _ in 0..10 {
                let params = EraseParams {
                    count: 1,
                    area_fraction: fraction,
                    aspect: [0.3, 3.0],
                    fill,
                };
                let rects = random_erase(&src, &mut dst, &params, &mut rng)?;
                let changed = src
                    .pixels()
                    .zip(dst.pixels())
                    .filter(|(a, b)| a != b)
                    .count();
                let covered = changed as f64 / 20_000.0;
                assert!(
                    (covered - fraction).abs() < 0.01,
                    "{fraction}: covered {covered}"
                );
                let r = rects[0];
                assert!(r.x + r.w <= 200 && r.y + r.h <= 100);
            }
        }
        let params = EraseParams {
            count: 4,
            area_fraction: 0.2,
            aspect: [1.0, 1.0],
            fill: EraseFill::Color,
        };
        let rects = random_erase(&src, &mut dst, &params, &mut rng)?;
        assert_eq!(rects.len(), 4);
        let changed = src
            .pixels()
            .zip(dst.pixels())
            .filter(|(a, b)| a != b)
            .count();
        assert!(
            changed as f64 <= 0.2 * 20_000.0 * 1.02,
            "overlaps only lower the cover"
        );
        Ok(())
    }

    #[test]
    fn bad_parameters_are_errors() {
        let src = RgbImage::new(8, 8);
        let mut dst = RgbImage::new(8, 8);
        let mut rng = ChaCha8Rng::seed_from_u64(0);
        assert!(adjust_brightness(&src, &mut dst, -0.1).is_err());
        assert!(adjust_contrast(&src, &mut dst, f64::NAN).is_err());
        assert!(adjust_gamma(&src, &mut dst, 0.0).is_err());
        assert!(adjust_color(&src, &mut dst, -1.0, 0.0).is_err());
        assert!(adjust_color(&src, &mut dst, 1.0, f64::INFINITY).is_err());
        assert!(add_gaussian_noise(&src, &mut dst, -1.0, &mut rng).is_err());
        assert!(gaussian_blur(&src, &mut dst, -0.5).is_err());
        assert!(gaussian_blur(&src, &mut dst, MAX_BLUR_SIGMA + 1.0).is_err());
        let mut params = EraseParams {
            count: 1,
            area_fraction: 1.5,
            aspect: [1.0, 2.0],
            fill: EraseFill::Color,
        };
        assert!(random_erase(&src, &mut dst, &params, &mut rng).is_err());
        params.area_fraction = 0.5;
        params.aspect = [0.0, 1.0];
        assert!(random_erase(&src, &mut dst, &params, &mut rng).is_err());
        params.aspect = [2.0, 1.0];
        assert!(random_erase(&src, &mut dst, &params, &mut rng).is_err());
        let mut small = RgbImage::new(4, 8);
        assert!(adjust_brightness(&src, &mut small, 1.0).is_err());
        assert!(gaussian_blur(&src, &mut small, 1.0).is_err());
    }
}
