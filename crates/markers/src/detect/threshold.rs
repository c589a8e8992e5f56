//! OpenCV's `adaptiveThreshold(MEAN_C, THRESH_BINARY_INV)` at several window sizes from one
//! integral image.
//!
//! OpenCV takes the window mean with `boxFilter(BORDER_REPLICATE)` rounded to the nearest
//! integer (its fixed-point and floating paths agree with exact rounding for every window it
//! can meet here: the window area is odd, so no half-way ties) and marks a pixel when
//! `src - mean <= -floor(C)`. Rounding `s / d` to nearest and comparing is the same as the
//! division-free `2s + d >= 2d (src + floor(C))`, which is what runs here: one integral image
//! of the replicate-padded source serves every window size, and each output is written straight
//! into the zero-framed 0/1 buffer the contour scanner wants.

/// Integral image of the source padded by `pad` replicated pixels on every side.
pub(crate) struct Integral {
    /// `(w + 2 pad + 1) x (h + 2 pad + 1)` wrapping sums, first row and column zero.
    sums: Vec<u32>,
    stride: usize,
    pad: usize,
    width: usize,
    height: usize,
}

impl Integral {
    /// Builds the integral image of `gray` (`width x height`, row-major) padded by `pad`.
    pub(crate) fn new(gray: &[u8], width: usize, height: usize, pad: usize) -> Self {
        let pw = width + 2 * pad;
        let ph = height + 2 * pad;
        let stride = pw + 1;
        let mut sums = vec![0u32; stride * (ph + 1)];
        let mut row_sum = vec![0u32; pw];
        for py in 0..ph {
            let sy = py.saturating_sub(pad).min(height - 1);
            let src = &gray[sy * width..(sy + 1) * width];
            // Row prefix sums of the padded row.
            let mut acc = 0u32;
            let left = u32::from(src[0]);
            let right = u32::from(src[width - 1]);
            let mut k = 0;
            for _ in 0..pad {
                acc = acc.wrapping_add(left);
                row_sum[k] = acc;
                k += 1;
            }
            for &v in src {
                acc = acc.wrapping_add(u32::from(v));
                row_sum[k] = acc;
                k += 1;
            }
            for _ in 0..pad {
                acc = acc.wrapping_add(right);
                row_sum[k] = acc;
                k += 1;
            }
            let (above, below) = sums.split_at_mut((py + 1) * stride);
            let above = &above[py * stride + 1..py * stride + 1 + pw];
            let out = &mut below[1..1 + pw];
            for ((o, &a), &r) in out.iter_mut().zip(above).zip(&row_sum) {
                *o = a.wrapping_add(r);
            }
        }
        Self {
            sums,
            stride,
            pad,
            width,
            height,
        }
    }

    /// Writes the inverted mean-C threshold for an odd `window` (≤ `2 pad + 1`) into `out`, a
    /// `(width + 2) x (height + 2)` buffer whose one-pixel frame stays 0; inside, 1 marks a
    /// pixel darker than its window mean by at least `floor(constant)`.
    pub(crate) fn threshold_into(&self, gray: &[u8], window: usize, constant: f64, out: &mut [u8]) {
        let r = window / 2;
        debug_assert!(r <= self.pad && window % 2 == 1);
        let (w, h) = (self.width, self.height);
        let ow = w + 2;
        debug_assert_eq!(out.len(), ow * (h + 2));
        let d = (window * window) as i64;
        let c = constant.floor() as i64;
        // fg  <=>  2s + d >= 2d (g + c)  <=>  2s + d - 2dc >= 2d g
        let two_d = 2 * d;
        let bias = d - two_d * c;
        let off = self.pad - r;
        let st = self.stride;
        if window * window * 255 * 2 + 2 * d as usize * 300 < i32::MAX as usize {
            let (two_d, bias) = (two_d as i32, bias as i32);
            for y in 0..h {
                let top = &self.sums[(y + off) * st + off..];
                let bot = &self.sums[(y + off + window) * st + off..];
                let src = &gray[y * w..(y + 1) * w];
                let dst = &mut out[(y + 1) * ow + 1..(y + 1) * ow + 1 + w];
                let (ta, tb) = (&top[..w], &top[window..window + w]);
                let (ba, bb) = (&bot[..w], &bot[window..window + w]);
                for x in 0..w {
                    let s = bb[x]
                        .wrapping_sub(tb[x])
                        .wrapping_sub(ba[x])
                        .wrapping_add(ta[x]) as i32;
                    dst[x] = u8::from(2 * s + bias >= two_d * i32::from(src[x]));
                }
            }
        } else {
            for y in 0..h {
                let top = &self.sums[(y + off) * st + off..];
                let bot = &self.sums[(y + off + window) * st + off..];
                let src = &gray[y * w..(y + 1) * w];
                let dst = &mut out[(y + 1) * ow + 1..(y + 1) * ow + 1 + w];
                for x in 0..w {
                    let s = bot[x + window]
                        .wrapping_sub(top[x + window])
                        .wrapping_sub(bot[x])
                        .wrapping_add(top[x]) as i64;
                    dst[x] = u8::from(2 * s + bias >= two_d * i64::from(src[x]));
                }
            }
        }
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    /// Straightforward OpenCV semantics: replicate border, mean rounded to nearest.
    fn reference(gray: &[u8], w: usize, h: usize, window: usize, c: i64) -> Vec<u8> {
        let r = window as i64 / 2;
        let mut out = vec![0u8; (w + 2) * (h + 2)];
        for y in 0..h as i64 {
            for x in 0..w as i64 {
                let mut s = 0i64;
                for dy in -r..=r {
                    for dx in -r..=r {
                        let sy = (y + dy).clamp(0, h as i64 - 1) as usize;
                        let sx = (x + dx).clamp(0, w as i64 - 1) as usize;
                        s += i64::from(gray[sy * w + sx]);
                    }
                }
                let d = (window * window) as i64;
                let mean = (2 * s + d) / (2 * d);
                let g = i64::from(gray[y as usize * w + x as usize]);
                out[(y as usize + 1) * (w + 2) + x as usize + 1] = u8::from(g - mean <= -c);
            }
        }
        out
    }

    #[test]
    fn matches_the_direct_definition_including_borders() {
        let (w, h) = (37, 29);
        let gray: Vec<u8> = (0..w * h)
            .map(|i| ((i * 7919 + (i / w) * 31) % 256) as u8)
            .collect();
        let integral = Integral::new(&gray, w, h, 11);
        for window in [3, 13, 23] {
            let mut out = vec![0u8; (w + 2) * (h + 2)];
            integral.threshold_into(&gray, window, 7.0, &mut out);
            assert_eq!(out, reference(&gray, w, h, window, 7), "window {window}");
        }
    }

    #[test]
    fn windows_larger_than_the_image_replicate() {
        let (w, h) = (2, 3);
        let gray = [10u8, 200, 30, 40, 250, 0];
        let integral = Integral::new(&gray, w, h, 11);
        let mut out = vec![0u8; (w + 2) * (h + 2)];
        integral.threshold_into(&gray, 23, 7.0, &mut out);
        assert_eq!(out, reference(&gray, w, h, 23, 7));
    }
}
