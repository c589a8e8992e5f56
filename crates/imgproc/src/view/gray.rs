//! RGB to grey, bit-identical to OpenCV 5.0's `cvtColor(RGB2GRAY)` / `BGR2GRAY` for 8-bit images.
//!
//! Why by hand: `image`'s `to_luma8` uses BT.709 weights (0.2126 R + 0.7152 G + 0.0722 B),
//! `fast_image_resize` has no colour conversion and `kornia-imgproc` 0.2 uses OpenCV 4's 14-bit
//! weights; a difference of one grey level before CLAHE becomes a large difference after it.
//! OpenCV 5.0 computes `(9798 R + 19235 G + 3735 B + 2^14) >> 15` (BT.601 weights 0.299, 0.587,
//! 0.114 in 15-bit fixed point, rounded half up). OpenCV 4.x used 14-bit weights (4899, 9617,
//! 1868); they differ from 5.0 on 0.3 % of colours. This formula was checked against
//! opencv-python 5.0.0 on all 2^24 colours with no difference.

use image::{GrayImage, RgbImage};

use crate::{ImgprocError, Result};

use super::resize::RowSource;

/// Red weight (0.299 * 2^15, rounded so that the three weights sum to 2^15).
pub const R_WEIGHT: u32 = 9798;
/// Green weight (0.587 * 2^15).
pub const G_WEIGHT: u32 = 19235;
/// Blue weight (0.114 * 2^15).
pub const B_WEIGHT: u32 = 3735;
/// Fixed-point shift of the weights.
pub const GRAY_SHIFT: u32 = 15;

/// One pixel's grey value.
#[inline(always)]
pub fn gray_of(r: u8, g: u8, b: u8) -> u8 {
    ((r as u32 * R_WEIGHT + g as u32 * G_WEIGHT + b as u32 * B_WEIGHT + (1 << (GRAY_SHIFT - 1)))
        >> GRAY_SHIFT) as u8
}

/// Converts one interleaved RGB row into grey (`out.len()` pixels).
#[inline(always)]
pub(crate) fn gray_row(rgb: &[u8], out: &mut [u8]) {
    for (o, p) in out.iter_mut().zip(rgb.chunks_exact(3)) {
        *o = gray_of(p[0], p[1], p[2]);
    }
}

/// Converts `src` to grey into `dst` (same size).
pub fn rgb_to_gray(src: &RgbImage, dst: &mut GrayImage) -> Result<()> {
    if src.dimensions() != dst.dimensions() {
        return Err(ImgprocError::Size(format!(
            "gray: source {:?} and destination {:?} differ",
            src.dimensions(),
            dst.dimensions()
        )));
    }
    let w = src.width() as usize;
    if w == 0 {
        return Ok(());
    }
    for (o, i) in dst.chunks_exact_mut(w).zip(src.chunks_exact(w * 3)) {
        gray_row(i, o);
    }
    Ok(())
}

/// Grey rows of an RGB image, converted on demand (the last row is cached: the area resizer asks
/// for boundary rows twice).
pub(crate) struct GrayRows<'a> {
    rgb: &'a [u8],
    width: usize,
    buf: &'a mut Vec<u8>,
    last: Option<usize>,
}

impl<'a> GrayRows<'a> {
    pub(crate) fn new(src: &'a RgbImage, buf: &'a mut Vec<u8>) -> Self {
        let width = src.width() as usize;
        buf.clear();
        buf.resize(width, 0);
        Self {
            rgb: src.as_raw(),
            width,
            buf,
            last: None,
        }
    }
}

impl RowSource for GrayRows<'_> {
    #[inline(always)]
    fn row(&mut self, y: usize) -> &[u8] {
        if self.last != Some(y) {
            let start = y * self.width * 3;
            if let Some(rgb) = self.rgb.get(start..start + self.width * 3) {
                gray_row(rgb, self.buf);
            }
            self.last = Some(y);
        }
        self.buf
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn pure_colours_match_opencv() -> Result<()> {
        // cv2.cvtColor values (OpenCV 5.0.0) for red, green, blue, white, black, grey 128.
        let colours = [
            [255, 0, 0],
            [0, 255, 0],
            [0, 0, 255],
            [255, 255, 255],
            [0, 0, 0],
            [128, 128, 128],
        ];
        let mut src = RgbImage::new(6, 1);
        for (p, c) in src.pixels_mut().zip(colours) {
            p.0 = c;
        }
        let mut dst = GrayImage::new(6, 1);
        rgb_to_gray(&src, &mut dst)?;
        assert_eq!(dst.as_raw(), &vec![76, 150, 29, 255, 0, 128]);
        Ok(())
    }

    #[test]
    fn known_tie_cases() {
        // Colours where 14-bit and 15-bit weights disagree; OpenCV 5.0 gives these.
        assert_eq!(gray_of(227, 146, 166), 172);
        assert_eq!(gray_of(12, 145, 7), 90);
        assert_eq!(gray_of(150, 35, 229), 91);
    }

    #[test]
    fn grey_input_stays_grey() {
        for v in 0..=255u8 {
            assert_eq!(gray_of(v, v, v), v);
        }
    }

    #[test]
    fn size_mismatch_is_an_error() {
        let src = RgbImage::new(4, 3);
        let mut dst = GrayImage::new(3, 4);
        assert!(rgb_to_gray(&src, &mut dst).is_err());
    }
}
