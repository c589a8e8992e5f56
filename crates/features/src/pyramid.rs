//! The image pyramid: the image at full resolution and area-averaged down by a constant factor
//! per level ([`imgproc::view::resize_gray`], OpenCV's `INTER_AREA`), each level made from the
//! full image so that no level inherits the rounding of the one above.

use crate::describe::BORDER;
use crate::{FeatureError, Result};
use image::GrayImage;

/// The levels and the scale of each (full-resolution pixels per level pixel).
pub(crate) struct Pyramid {
    pub levels: Vec<GrayImage>,
    pub scales: Vec<f32>,
}

impl Pyramid {
    /// Up to `levels` levels `factor` apart; levels too small to hold a described corner are
    /// left out.
    pub fn build(img: &GrayImage, levels: usize, factor: f32) -> Result<Pyramid> {
        let min_side = 2 * BORDER + 8;
        let mut out = Pyramid {
            levels: Vec::with_capacity(levels),
            scales: Vec::with_capacity(levels),
        };
        for level in 0..levels {
            let scale = factor.powi(level as i32);
            let w = (img.width() as f32 / scale).round() as u32;
            let h = (img.height() as f32 / scale).round() as u32;
            if w < min_side || h < min_side {
                break;
            }
            let image = if level == 0 {
                img.clone()
            } else {
                let mut dst = GrayImage::new(w, h);
                imgproc::view::resize_gray(img, &mut dst)
                    .map_err(|e| FeatureError::Pyramid(e.to_string()))?;
                dst
            };
            // The true scale of a rounded size, per axis averaged.
            let true_scale = 0.5 * (img.width() as f32 / w as f32 + img.height() as f32 / h as f32);
            out.levels.push(image);
            out.scales.push(true_scale);
        }
        Ok(out)
    }
}

/// Features per level, falling geometrically with the level's side as ORB shares them, summing
/// to `total`.
pub(crate) fn quotas(total: usize, levels: usize, factor: f32) -> Vec<usize> {
    if levels == 0 {
        return Vec::new();
    }
    let r = 1.0 / factor as f64;
    let first = total as f64 * (1.0 - r) / (1.0 - r.powi(levels as i32));
    let mut out: Vec<usize> = (0..levels)
        .map(|l| (first * r.powi(l as i32)).round() as usize)
        .collect();
    let given: usize = out.iter().sum();
    out[0] = (out[0] + total).saturating_sub(given);
    out
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn quotas_sum_to_the_total_and_fall_with_the_level() {
        let q = quotas(1500, 6, 1.2);
        assert_eq!(q.iter().sum::<usize>(), 1500);
        assert!(q.windows(2).all(|w| w[0] > w[1]), "{q:?}");
        assert_eq!(quotas(10, 1, 1.2), vec![10]);
    }

    #[test]
    fn levels_shrink_by_the_factor_and_stop_when_too_small() -> Result<()> {
        let img = GrayImage::new(640, 480);
        let p = Pyramid::build(&img, 8, 1.2)?;
        assert_eq!(p.levels.len(), 8);
        assert_eq!(p.levels[1].width(), 533);
        assert!((p.scales[1] - 1.2).abs() < 0.01);
        let tiny = Pyramid::build(&GrayImage::new(60, 60), 8, 1.2)?;
        assert!(tiny.levels.len() < 3, "{}", tiny.levels.len());
        Ok(())
    }
}
