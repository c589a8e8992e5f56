//! Canny edges, following OpenCV's `cv2.Canny(img, low, high)` (aperture 3, L1 gradient).
//!
//! Why: edge maps look alike for BIM renders and photos, so a network trained on one transfers to
//! the other. Why by hand: `image`/`fast_image_resize` have no edge detector, and following
//! OpenCV's variant keeps the view reproducible with the Python tools used to inspect data.
//!
//! Steps (as in OpenCV's `canny.cpp`):
//! 1. 3x3 Sobel derivatives with `BORDER_REPLICATE`; magnitude `|gx| + |gy|`. There is no Gaussian
//!    pre-blur (OpenCV has none either); in the views the `INTER_AREA` downscale before it
//!    already low-passes the image.
//! 2. Non-maximum suppression in four directions with OpenCV's integer tangent test
//!    (`tan 22.5°` in 15-bit fixed point); outside the image the magnitude is 0. A pixel survives
//!    when its magnitude is `> low` and it is a maximum along the gradient (strictly greater than
//!    the neighbour on one side, greater or equal on the other, as OpenCV breaks ties).
//! 3. Hysteresis: survivors `> high` are edges, and so is every survivor 8-connected to an edge.
//!
//! Thresholds are floored to integers, as OpenCV does for the L1 gradient.

use image::GrayImage;

use crate::{ImgprocError, Result};

use super::gradient::{Border, Kernel, derivatives};

/// `tan(22.5°)` in 15-bit fixed point, OpenCV's `TG22`.
const TG22: i64 = 13573;
/// Fixed-point shift of [`TG22`].
const SHIFT: u32 = 15;

/// Checks Canny thresholds (shared with the spec's validation).
pub(crate) fn check_params(low: f32, high: f32) -> Result<()> {
    if !(low.is_finite() && high.is_finite() && low >= 0.0 && low <= high) {
        return Err(ImgprocError::Param(format!(
            "canny thresholds must satisfy 0 <= low <= high, got low {low}, high {high}"
        )));
    }
    Ok(())
}

/// Canny edge map of `src` into `dst` (255 on edges, 0 elsewhere); `dst` must have the size of
/// `src`. `low`/`high` are thresholds on the L1 Sobel magnitude (`|gx| + |gy|`, up to 2040).
pub fn canny(src: &GrayImage, dst: &mut GrayImage, low: f32, high: f32) -> Result<()> {
    if src.dimensions() != dst.dimensions() {
        return Err(ImgprocError::Size(format!(
            "canny: source {:?} and destination {:?} differ",
            src.dimensions(),
            dst.dimensions()
        )));
    }
    check_params(low, high)?;
    let (w, h) = (src.width() as usize, src.height() as usize);
    if w == 0 || h == 0 {
        return Ok(());
    }
    let (low, high) = (low.floor() as i32, high.floor() as i32);
    let (mut gx, mut gy) = (Vec::new(), Vec::new());
    derivatives(src, Kernel::Sobel, Border::Replicate, &mut gx, &mut gy);

    // Magnitude with a one-pixel frame of zeros.
    let mw = w + 2;
    let mut mag = vec![0i32; mw * (h + 2)];
    for y in 0..h {
        let row = &mut mag[(y + 1) * mw + 1..(y + 1) * mw + 1 + w];
        for (m, (&x, &yv)) in row.iter_mut().zip(gx[y * w..].iter().zip(&gy[y * w..])) {
            *m = x.abs() + yv.abs();
        }
    }

    // 0: candidate, 1: not an edge, 2: edge; the frame stays 1 so tracking never leaves.
    let mut map = vec![1u8; mw * (h + 2)];
    let mut stack: Vec<usize> = Vec::new();
    for y in 0..h {
        for x in 0..w {
            let j = (y + 1) * mw + x + 1;
            let m = mag[j];
            if m <= low {
                continue;
            }
            let (xs, ys) = (gx[y * w + x] as i64, gy[y * w + x] as i64);
            let ax = xs.abs();
            let ay = ys.abs() << SHIFT;
            let tg22x = ax * TG22;
            let keep = if ay < tg22x {
                m > mag[j - 1] && m >= mag[j + 1]
            } else {
                let tg67x = tg22x + (ax << (SHIFT + 1));
                if ay > tg67x {
                    m > mag[j - mw] && m >= mag[j + mw]
                } else if (xs ^ ys) < 0 {
                    m > mag[j - mw + 1] && m > mag[j + mw - 1]
                } else {
                    m > mag[j - mw - 1] && m > mag[j + mw + 1]
                }
            };
            if keep {
                if m > high {
                    map[j] = 2;
                    stack.push(j);
                } else {
                    map[j] = 0;
                }
            }
        }
    }
    while let Some(j) = stack.pop() {
        for n in [
            j - mw - 1,
            j - mw,
            j - mw + 1,
            j - 1,
            j + 1,
            j + mw - 1,
            j + mw,
            j + mw + 1,
        ] {
            if map[n] == 0 {
                map[n] = 2;
                stack.push(n);
            }
        }
    }
    for (y, out) in dst.chunks_exact_mut(w).enumerate() {
        let row = &map[(y + 1) * mw + 1..(y + 1) * mw + 1 + w];
        for (o, &m) in out.iter_mut().zip(row) {
            *o = if m == 2 { 255 } else { 0 };
        }
    }
    Ok(())
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn finds_the_outline_of_a_square() -> Result<()> {
        // A bright 10x10 square on a dark 30x30 field.
        let src = GrayImage::from_fn(30, 30, |x, y| {
            image::Luma([if (10..20).contains(&x) && (10..20).contains(&y) {
                200
            } else {
                30
            }])
        });
        let mut dst = GrayImage::new(30, 30);
        canny(&src, &mut dst, 50.0, 150.0)?;
        let on = |x: u32, y: u32| dst.get_pixel(x, y).0[0] == 255;
        // Every edge pixel lies on the square's boundary band (one pixel either side).
        for (x, y, p) in dst.enumerate_pixels() {
            if p.0[0] == 255 {
                let near_x = (9..=10).contains(&x) || (19..=20).contains(&x);
                let near_y = (9..=10).contains(&y) || (19..=20).contains(&y);
                let inside = (9..=20).contains(&x) && (9..=20).contains(&y);
                assert!(inside && (near_x || near_y), "stray edge at ({x}, {y})");
            }
        }
        // Each side is found along its whole length (one of the two boundary columns/rows).
        for t in 11..19 {
            assert!(on(9, t) || on(10, t), "left side at y = {t}");
            assert!(on(19, t) || on(20, t), "right side at y = {t}");
            assert!(on(t, 9) || on(t, 10), "top side at x = {t}");
            assert!(on(t, 19) || on(t, 20), "bottom side at x = {t}");
        }
        // Flat regions have no edges.
        assert!(!on(2, 2) && !on(15, 15) && !on(27, 27));
        Ok(())
    }

    #[test]
    fn weak_edges_need_a_strong_neighbour() -> Result<()> {
        // A step of 60 everywhere: L1 magnitude 4 * 60 = 240 on the two columns beside it.
        let src = GrayImage::from_fn(12, 8, |x, _| image::Luma([if x < 6 { 0 } else { 60 }]));
        let mut dst = GrayImage::new(12, 8);
        canny(&src, &mut dst, 100.0, 300.0)?; // no pixel above high: nothing
        assert!(dst.pixels().all(|p| p.0[0] == 0));
        canny(&src, &mut dst, 100.0, 200.0)?; // all strong
        assert!(dst.pixels().any(|p| p.0[0] == 255));
        Ok(())
    }

    #[test]
    fn bad_thresholds_are_errors() {
        let src = GrayImage::new(4, 4);
        let mut dst = GrayImage::new(4, 4);
        assert!(canny(&src, &mut dst, 100.0, 50.0).is_err());
        assert!(canny(&src, &mut dst, -1.0, 50.0).is_err());
        assert!(canny(&src, &mut dst, 1.0, f32::INFINITY).is_err());
        let mut other = GrayImage::new(5, 4);
        assert!(canny(&src, &mut other, 1.0, 2.0).is_err());
    }
}
