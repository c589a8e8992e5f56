//! Global histogram equalisation, as OpenCV's `equalizeHist` on 8-bit images.
//!
//! Why by hand: `image` has no histogram equalisation (`imageops` only has contrast/brighten),
//! and it is a dozen lines. OpenCV's rule: find the lowest occupied bin `i0`; if it holds every
//! pixel the image becomes `i0`; otherwise `lut[i0] = 0` and for higher bins
//! `lut[i] = saturate_cast<uchar>(cdf_above_i0(i) * (255.f / (N - hist[i0])))`, so the darkest
//! level maps to 0 and the brightest to 255.

use image::GrayImage;

use crate::{ImgprocError, Result};

use super::round::round_u8;

/// Spreads the grey levels of `src` over 0..=255 by its cumulative histogram (OpenCV's
/// `equalizeHist`); a global, parameter-free contrast normalisation. `dst` must have the size of
/// `src`.
pub fn equalize(src: &GrayImage, dst: &mut GrayImage) -> Result<()> {
    if src.dimensions() != dst.dimensions() {
        return Err(ImgprocError::Size(format!(
            "equalize: source {:?} and destination {:?} differ",
            src.dimensions(),
            dst.dimensions()
        )));
    }
    let mut hist = [0u32; 256];
    for &v in src.as_raw() {
        hist[v as usize] += 1;
    }
    let total = src.as_raw().len() as u32;
    let Some(i0) = hist.iter().position(|&c| c != 0) else {
        return Ok(()); // empty image
    };
    if hist[i0] == total {
        dst.fill(i0 as u8);
        return Ok(());
    }
    let scale = 255.0f32 / (total - hist[i0]) as f32;
    let mut lut = [0u8; 256];
    let mut sum = 0u32;
    for i in i0 + 1..256 {
        sum += hist[i];
        lut[i] = round_u8(sum as f32 * scale);
    }
    for (d, &s) in dst.iter_mut().zip(src.as_raw()) {
        *d = lut[s as usize];
    }
    Ok(())
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn ramp_spreads_to_full_range() -> Result<()> {
        // 64 levels 100..164, one pixel each: lut = round(k * 255 / 63).
        let src = GrayImage::from_fn(64, 1, |x, _| image::Luma([100 + x as u8]));
        let mut dst = GrayImage::new(64, 1);
        equalize(&src, &mut dst)?;
        assert_eq!(dst.get_pixel(0, 0).0[0], 0);
        assert_eq!(dst.get_pixel(63, 0).0[0], 255);
        assert_eq!(dst.get_pixel(21, 0).0[0], 85); // 21 * 255 / 63 = 85
        assert!(dst.as_raw().windows(2).all(|w| w[0] < w[1]));
        Ok(())
    }

    #[test]
    fn constant_image_keeps_its_value() -> Result<()> {
        let src = GrayImage::from_pixel(5, 4, image::Luma([77]));
        let mut dst = GrayImage::new(5, 4);
        equalize(&src, &mut dst)?;
        assert!(dst.pixels().all(|p| p.0[0] == 77));
        Ok(())
    }

    #[test]
    fn size_mismatch_is_an_error() {
        let src = GrayImage::new(5, 4);
        let mut dst = GrayImage::new(4, 5);
        assert!(equalize(&src, &mut dst).is_err());
    }
}
