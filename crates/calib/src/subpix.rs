//! Sub-pixel corner refinement, OpenCV's `cornerSubPix` algorithm.
//!
//! At the true corner `q`, every image gradient `g(p)` in the window is orthogonal to `p - q`
//! (on an edge the gradient is normal to the edge through `q`; in flat areas it is zero). The
//! refined corner solves `Σ w g gᵀ q = Σ w g gᵀ p` with Gaussian weights `w` over a
//! `(2w+1)²` window sampled bilinearly around the current estimate, iterated until the step
//! is below 0.001 px or after 30 iterations. A corner that would move further than the half
//! window keeps its start position, as in OpenCV.

use image::GrayImage;
use nalgebra::Point2;

/// Maximum iterations, OpenCV's usual criteria.
const MAX_ITERS: usize = 30;
/// Stop when a step is shorter than this (pixels).
const EPS: f64 = 0.001;

/// A grayscale image as `f32`, for bilinear sampling with replicated borders.
pub(crate) struct FloatImage {
    pub(crate) width: usize,
    pub(crate) height: usize,
    pub(crate) data: Vec<f32>,
}

impl FloatImage {
    pub(crate) fn from_gray(gray: &GrayImage) -> Self {
        Self {
            width: gray.width() as usize,
            height: gray.height() as usize,
            data: gray.as_raw().iter().map(|&v| v as f32).collect(),
        }
    }

    #[inline]
    fn at(&self, x: isize, y: isize) -> f32 {
        let x = x.clamp(0, self.width as isize - 1) as usize;
        let y = y.clamp(0, self.height as isize - 1) as usize;
        self.data[y * self.width + x]
    }

    /// Fills `out` (`size x size`, row-major) with the bilinearly sampled patch centred on
    /// `(cx, cy)`: sample `(i, j)` is at `(cx - (size-1)/2 + j, cy - (size-1)/2 + i)`, as
    /// OpenCV's `getRectSubPix`.
    fn patch(&self, cx: f64, cy: f64, size: usize, out: &mut [f32]) {
        let half = (size as f64 - 1.0) * 0.5;
        let x0 = cx - half;
        let y0 = cy - half;
        let ix = x0.floor();
        let iy = y0.floor();
        let ax = (x0 - ix) as f32;
        let ay = (y0 - iy) as f32;
        let (ix, iy) = (ix as isize, iy as isize);
        let inside = ix >= 0
            && iy >= 0
            && ix + (size as isize) < self.width as isize
            && iy + (size as isize) < self.height as isize;
        let w00 = (1.0 - ax) * (1.0 - ay);
        let w01 = ax * (1.0 - ay);
        let w10 = (1.0 - ax) * ay;
        let w11 = ax * ay;
        for i in 0..size {
            let y = iy + i as isize;
            for j in 0..size {
                let x = ix + j as isize;
                let v = if inside {
                    let base = y as usize * self.width + x as usize;
                    w00 * self.data[base]
                        + w01 * self.data[base + 1]
                        + w10 * self.data[base + self.width]
                        + w11 * self.data[base + self.width + 1]
                } else {
                    w00 * self.at(x, y)
                        + w01 * self.at(x + 1, y)
                        + w10 * self.at(x, y + 1)
                        + w11 * self.at(x + 1, y + 1)
                };
                out[i * size + j] = v;
            }
        }
    }
}

/// Refines `corners` in place to sub-pixel accuracy with OpenCV's `cornerSubPix` algorithm
/// (search window `(2 * half_window + 1)²`, no dead zone, Gaussian weights, 30 iterations or a
/// step below 0.001 px). OpenCV's calibration sample uses `half_window = 11`. Corners outside
/// the image, or that would move further than `half_window`, are left where they were. A
/// `half_window` of 0 or an empty image leaves the corners unchanged.
pub fn refine_corners(gray: &GrayImage, corners: &mut [Point2<f64>], half_window: usize) {
    if half_window == 0 || gray.width() == 0 || gray.height() == 0 {
        return;
    }
    let img = FloatImage::from_gray(gray);
    refine_corners_f(&img, corners, half_window);
}

/// [`refine_corners`] on an image already converted to `f32`.
pub(crate) fn refine_corners_f(img: &FloatImage, corners: &mut [Point2<f64>], half_window: usize) {
    let win = half_window as isize;
    let win_size = 2 * half_window + 1;
    let patch_size = win_size + 2;
    // Gaussian weights: exp(-(x/w)²) with x in [-w, w], as OpenCV.
    let mut mask = vec![0f64; win_size * win_size];
    for i in 0..win_size {
        let y = (i as f64 - half_window as f64) / half_window as f64;
        let vy = (-y * y).exp();
        for j in 0..win_size {
            let x = (j as f64 - half_window as f64) / half_window as f64;
            mask[i * win_size + j] = vy * (-x * x).exp();
        }
    }
    let mut patch = vec![0f32; patch_size * patch_size];
    let (w, h) = (img.width as f64, img.height as f64);
    for corner in corners.iter_mut() {
        let start = *corner;
        if !(start.x.is_finite() && start.y.is_finite()) {
            continue;
        }
        if start.x < 0.0 || start.y < 0.0 || start.x >= w || start.y >= h {
            continue;
        }
        let mut c = start;
        for _ in 0..MAX_ITERS {
            img.patch(c.x, c.y, patch_size, &mut patch);
            let (mut a, mut b, mut cc, mut bb1, mut bb2) = (0.0, 0.0, 0.0, 0.0, 0.0);
            for i in 0..win_size {
                let py = i as f64 - win as f64;
                let row = (i + 1) * patch_size;
                for j in 0..win_size {
                    let m = mask[i * win_size + j];
                    let tgx = (patch[row + j + 2] - patch[row + j]) as f64;
                    let tgy =
                        (patch[row + patch_size + j + 1] - patch[row - patch_size + j + 1]) as f64;
                    let gxx = tgx * tgx * m;
                    let gxy = tgx * tgy * m;
                    let gyy = tgy * tgy * m;
                    let px = j as f64 - win as f64;
                    a += gxx;
                    b += gxy;
                    cc += gyy;
                    bb1 += gxx * px + gxy * py;
                    bb2 += gxy * px + gyy * py;
                }
            }
            let det = a * cc - b * b;
            if det.abs() <= f64::EPSILON * f64::EPSILON {
                break;
            }
            let scale = 1.0 / det;
            let next = Point2::new(
                c.x + cc * scale * bb1 - b * scale * bb2,
                c.y - b * scale * bb1 + a * scale * bb2,
            );
            let step2 = (next - c).norm_squared();
            c = next;
            if !(c.x.is_finite() && c.y.is_finite())
                || c.x < 0.0
                || c.y < 0.0
                || c.x >= w
                || c.y >= h
            {
                break;
            }
            if step2 <= EPS * EPS {
                break;
            }
        }
        let moved_too_far = (c.x - start.x).abs() > half_window as f64
            || (c.y - start.y).abs() > half_window as f64;
        if c.x.is_finite() && c.y.is_finite() && !moved_too_far {
            *corner = c;
        }
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    /// A blurred synthetic X-junction at a known sub-pixel position.
    fn saddle(cx: f64, cy: f64) -> GrayImage {
        GrayImage::from_fn(64, 64, |x, y| {
            // supersample 4x4 for a soft, exact edge
            let mut acc = 0.0f64;
            for sy in 0..4 {
                for sx in 0..4 {
                    let px = x as f64 + (sx as f64 + 0.5) / 4.0 - 0.5 - cx;
                    let py = y as f64 + (sy as f64 + 0.5) / 4.0 - 0.5 - cy;
                    acc += if (px > 0.0) == (py > 0.0) {
                        220.0
                    } else {
                        30.0
                    };
                }
            }
            image::Luma([(acc / 16.0).round() as u8])
        })
    }

    #[test]
    fn finds_synthetic_saddle() {
        let img = saddle(31.3, 30.7);
        let mut c = [Point2::new(33.0, 29.0)];
        refine_corners(&img, &mut c, 5);
        assert!(
            (c[0].x - 31.3).abs() < 0.05 && (c[0].y - 30.7).abs() < 0.05,
            "{:?}",
            c[0]
        );
    }

    #[test]
    fn blank_and_border_do_not_panic() {
        let img = GrayImage::new(10, 10);
        let mut c = [
            Point2::new(0.0, 0.0),
            Point2::new(9.9, 9.9),
            Point2::new(-5.0, 3.0),
        ];
        refine_corners(&img, &mut c, 11);
        assert_eq!(c[2], Point2::new(-5.0, 3.0));
        refine_corners(&GrayImage::new(0, 0), &mut c, 3);
    }
}
