//! Saliency maps drawn over the frame they explain (Grad-CAM's usual picture).
//!
//! The map (a few cells a side) is upsampled bilinearly to the image, coloured with the
//! "inferno" ramp (dark purple, red, yellow: readable in grey print and by most colour-blind
//! readers) and blended over the image, more opaque where the map is hot, so the frame stays
//! visible where the network does not look. Written by hand: a few lines of arithmetic that no
//! crate offers for a plain `RgbImage`.

use image::{Rgb, RgbImage};

use crate::{ReportError, Result};

/// Stops of the inferno colour ramp, at 0, 0.25, 0.5, 0.75 and 1.
const INFERNO: [[f32; 3]; 5] = [
    [0.0, 0.0, 4.0],
    [87.0, 16.0, 110.0],
    [188.0, 55.0, 84.0],
    [249.0, 142.0, 9.0],
    [252.0, 255.0, 164.0],
];

/// The inferno colour of `v` in `[0, 1]`.
fn inferno(v: f32) -> [f32; 3] {
    let x = v.clamp(0.0, 1.0) * (INFERNO.len() - 1) as f32;
    let k = (x.floor() as usize).min(INFERNO.len() - 2);
    let t = x - k as f32;
    std::array::from_fn(|c| INFERNO[k][c] * (1.0 - t) + INFERNO[k + 1][c] * t)
}

/// The map `values` (`width x height` cells, row-major, in `[0, 1]`) upsampled to `img`'s size
/// and blended over it (see the module docs).
pub fn saliency_overlay(
    img: &RgbImage,
    width: usize,
    height: usize,
    values: &[f32],
) -> Result<RgbImage> {
    if width == 0 || height == 0 || values.len() != width * height {
        return Err(ReportError::BadInput(format!(
            "a saliency map of {width}x{height} cells needs {} values, not {}",
            width * height,
            values.len()
        )));
    }
    let (iw, ih) = (img.width().max(1), img.height().max(1));
    // Cell centres sit at (i + 0.5) · size / cells; sample between them, clamped at the edges.
    let at = |x: f32, y: f32| {
        let fx = (x * width as f32 / iw as f32 - 0.5).clamp(0.0, (width - 1) as f32);
        let fy = (y * height as f32 / ih as f32 - 0.5).clamp(0.0, (height - 1) as f32);
        let (x0, y0) = (fx.floor() as usize, fy.floor() as usize);
        let (x1, y1) = ((x0 + 1).min(width - 1), (y0 + 1).min(height - 1));
        let (tx, ty) = (fx - x0 as f32, fy - y0 as f32);
        let v = |x: usize, y: usize| values[y * width + x];
        (v(x0, y0) * (1.0 - tx) + v(x1, y0) * tx) * (1.0 - ty)
            + (v(x0, y1) * (1.0 - tx) + v(x1, y1) * tx) * ty
    };
    Ok(RgbImage::from_fn(img.width(), img.height(), |x, y| {
        let v = at(x as f32 + 0.5, y as f32 + 0.5).clamp(0.0, 1.0);
        let colour = inferno(v);
        let alpha = 0.25 + 0.5 * v;
        let p = img.get_pixel(x, y).0;
        Rgb(std::array::from_fn(|c| {
            (f32::from(p[c]) * (1.0 - alpha) + colour[c] * alpha).round() as u8
        }))
    }))
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn the_hot_cell_is_bright_and_the_cold_one_keeps_the_frame() {
        let img = RgbImage::from_pixel(40, 20, Rgb([100, 100, 100]));
        let out = saliency_overlay(&img, 2, 1, &[0.0, 1.0]).unwrap();
        let (cold, hot) = (out.get_pixel(2, 10).0, out.get_pixel(37, 10).0);
        // Hot: mostly the ramp's pale yellow; cold: the grey frame under a dark purple tint.
        assert!(hot[0] > 200 && hot[1] > 200, "{hot:?}");
        assert!(cold.iter().all(|&c| (60..=110).contains(&c)), "{cold:?}");
        // Between the two cell centres the map rises smoothly, and so does the brightness.
        let luma = |p: [u8; 3]| {
            0.299 * f32::from(p[0]) + 0.587 * f32::from(p[1]) + 0.114 * f32::from(p[2])
        };
        let row: Vec<f32> = (0..40).map(|x| luma(out.get_pixel(x, 10).0)).collect();
        assert!(row.windows(2).all(|w| w[1] >= w[0] - 1.0), "{row:?}");
        assert!(row[39] > row[0] + 100.0);
        assert!(saliency_overlay(&img, 2, 2, &[0.0; 3]).is_err());
    }
}
