//! Gradient magnitude (Sobel or Scharr, 3x3) as an 8-bit view.
//!
//! Why: networks trained on BIM renders must also work on photos; gradients keep the building's
//! geometry and drop most of the paint, texture and lighting that differ between the two.
//! Why by hand: `image::imageops` has no Scharr kernel and its `filter3x3` clamps every result
//! to the pixel type (losing the sign and range of derivatives); a 3x3 derivative with an
//! explicit border rule is a few lines.
//!
//! Scaling: `round(sqrt(gx^2 + gy^2) / gain)`, saturated at 255, with `gain` the kernel's weight
//! sum along the smoothing axis (4 for Sobel `[1 2 1]`, 16 for Scharr `[3 10 3]`). So an ideal
//! horizontal or vertical step of height `h` shows as `h` on the two pixels beside it, and only
//! steep diagonal edges (up to `sqrt(2) * 255`) saturate. Border: `BORDER_REFLECT_101`, OpenCV's
//! default for `cv2.Sobel`.

use image::GrayImage;
use serde::{Deserialize, Serialize};

use crate::{ImgprocError, Result};

use super::round::round_u8;

/// Which 3x3 derivative kernel.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Hash, Serialize, Deserialize)]
#[serde(rename_all = "snake_case")]
pub enum Kernel {
    /// Sobel: smoothing `[1 2 1]`, derivative `[-1 0 1]`.
    Sobel,
    /// Scharr: smoothing `[3 10 3]`, derivative `[-1 0 1]`; more rotation-invariant.
    Scharr,
}

impl Kernel {
    /// Smoothing weights (outer, centre) of the kernel.
    fn weights(self) -> (i32, i32) {
        match self {
            Kernel::Sobel => (1, 2),
            Kernel::Scharr => (3, 10),
        }
    }

    /// Sum of the smoothing weights: the response to a unit step.
    pub fn gain(self) -> f32 {
        let (o, c) = self.weights();
        (2 * o + c) as f32
    }

    /// The name used in view specs (`sobel`, `scharr`).
    pub fn name(self) -> &'static str {
        match self {
            Kernel::Sobel => "sobel",
            Kernel::Scharr => "scharr",
        }
    }
}

/// How a 3x3 kernel reads outside the image.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub(crate) enum Border {
    /// `gfedcb|abcdefgh|gfedcba` (OpenCV's default).
    Reflect101,
    /// `aaaaaa|abcdefgh|hhhhhhh` (what `cv2.Canny` uses).
    Replicate,
}

/// Index of the neighbour `i - 1` and `i + 1` of `i` in `0..n` under `border`.
#[inline]
fn neighbours(i: usize, n: usize, border: Border) -> (usize, usize) {
    let last = n - 1;
    let lo = match (i, border) {
        (0, Border::Reflect101) => 1.min(last),
        (0, Border::Replicate) => 0,
        _ => i - 1,
    };
    let hi = match border {
        _ if i < last => i + 1,
        Border::Reflect101 => last.saturating_sub(1),
        Border::Replicate => last,
    };
    (lo, hi)
}

/// 3x3 derivatives `gx`, `gy` of `src` (row-major `i32`, `w * h` each).
pub(crate) fn derivatives(
    src: &GrayImage,
    kernel: Kernel,
    border: Border,
    gx: &mut Vec<i32>,
    gy: &mut Vec<i32>,
) {
    let (w, h) = (src.width() as usize, src.height() as usize);
    gx.clear();
    gy.clear();
    gx.resize(w * h, 0);
    gy.resize(w * h, 0);
    if w == 0 || h == 0 {
        return;
    }
    let (o, c) = kernel.weights();
    let raw = src.as_raw();
    let xn: Vec<(usize, usize)> = (0..w).map(|x| neighbours(x, w, border)).collect();
    for y in 0..h {
        let (ym, yp) = neighbours(y, h, border);
        let (rm, rc, rp) = (
            &raw[ym * w..(ym + 1) * w],
            &raw[y * w..(y + 1) * w],
            &raw[yp * w..(yp + 1) * w],
        );
        let out_x = &mut gx[y * w..(y + 1) * w];
        let out_y = &mut gy[y * w..(y + 1) * w];
        for (x, (&(xm, xp), (dx, dy))) in xn.iter().zip(out_x.iter_mut().zip(out_y)).enumerate() {
            let p = |r: &[u8], i: usize| r[i] as i32;
            *dx = o * (p(rm, xp) - p(rm, xm))
                + c * (p(rc, xp) - p(rc, xm))
                + o * (p(rp, xp) - p(rp, xm));
            *dy = o * (p(rp, xm) - p(rm, xm))
                + c * (p(rp, x) - p(rm, x))
                + o * (p(rp, xp) - p(rm, xp));
        }
    }
}

/// Gradient magnitude of `src` scaled to 8 bits (see the module doc for the scaling); `dst`
/// must have the size of `src`.
pub fn grad_mag(src: &GrayImage, dst: &mut GrayImage, kernel: Kernel) -> Result<()> {
    if src.dimensions() != dst.dimensions() {
        return Err(ImgprocError::Size(format!(
            "gradmag: source {:?} and destination {:?} differ",
            src.dimensions(),
            dst.dimensions()
        )));
    }
    let (mut gx, mut gy) = (Vec::new(), Vec::new());
    derivatives(src, kernel, Border::Reflect101, &mut gx, &mut gy);
    let inv_gain = 1.0 / kernel.gain();
    for ((d, &x), &y) in dst.iter_mut().zip(&gx).zip(&gy) {
        let m = ((x * x + y * y) as f32).sqrt();
        *d = round_u8(m * inv_gain);
    }
    Ok(())
}

#[cfg(test)]
mod tests {
    use super::*;

    fn step(w: u32, h: u32, at: u32, lo: u8, hi: u8) -> GrayImage {
        GrayImage::from_fn(w, h, |x, _| image::Luma([if x < at { lo } else { hi }]))
    }

    #[test]
    fn vertical_step_gives_its_height_beside_the_edge() -> Result<()> {
        for kernel in [Kernel::Sobel, Kernel::Scharr] {
            let src = step(8, 5, 4, 20, 120);
            let mut dst = GrayImage::new(8, 5);
            grad_mag(&src, &mut dst, kernel)?;
            for y in 0..5 {
                let row: Vec<u8> = (0..8).map(|x| dst.get_pixel(x, y).0[0]).collect();
                assert_eq!(row, vec![0, 0, 0, 100, 100, 0, 0, 0], "{kernel:?} row {y}");
            }
        }
        Ok(())
    }

    #[test]
    fn flat_image_has_no_gradient_even_at_borders() -> Result<()> {
        let src = GrayImage::from_pixel(6, 4, image::Luma([200]));
        let mut dst = GrayImage::new(6, 4);
        grad_mag(&src, &mut dst, Kernel::Sobel)?;
        assert!(dst.pixels().all(|p| p.0[0] == 0));
        Ok(())
    }

    #[test]
    fn reflect101_border_of_a_ramp() {
        // Row 0 1 2 3: at x = 0 the left neighbour is x = 1 (reflect 101), so gx = 0 there.
        let src = GrayImage::from_fn(4, 1, |x, _| image::Luma([x as u8 * 10]));
        let (mut gx, mut gy) = (Vec::new(), Vec::new());
        derivatives(&src, Kernel::Sobel, Border::Reflect101, &mut gx, &mut gy);
        assert_eq!(gx, vec![0, 80, 80, 0]);
        derivatives(&src, Kernel::Sobel, Border::Replicate, &mut gx, &mut gy);
        assert_eq!(gx, vec![40, 80, 80, 40]);
        assert!(gy.iter().all(|&v| v == 0));
    }

    #[test]
    fn one_pixel_images_work() -> Result<()> {
        let src = GrayImage::from_pixel(1, 1, image::Luma([9]));
        let mut dst = GrayImage::new(1, 1);
        grad_mag(&src, &mut dst, Kernel::Scharr)?;
        assert_eq!(dst.as_raw(), &vec![0]);
        Ok(())
    }
}
