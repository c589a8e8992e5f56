//! Image textures: a picture (from a glTF or OBJ model) resampled to power-of-two sides of at
//! most [`MAX_IMAGE_SIDE`] ([`MAX_ATLAS_SIDE`] for a scan's atlas), so that the renderer wraps
//! its texel indices by masking as it does for the procedural patterns.

use super::Texture;
use super::color::{Rgb, to_u8};
#[cfg(doc)]
use super::{MAX_ATLAS_SIDE, MAX_IMAGE_SIDE};
use image::imageops::FilterType;

/// The power of two nearest to `n` (in ratio), from 1 to `max` (a power of two).
fn pow2_near(n: u32, max: u32) -> u32 {
    let n = n.clamp(1, max);
    let lo = if n.is_power_of_two() {
        n
    } else {
        n.next_power_of_two() / 2
    };
    let hi = n.next_power_of_two();
    if (n as f32 / lo as f32) <= (hi as f32 / n as f32) {
        lo
    } else {
        hi
    }
}

/// `img` at power-of-two sides of at most `max` texels (`fallback`'s one texel when empty).
pub(crate) fn resample_image(img: &image::RgbImage, fallback: Rgb, max: u32) -> Texture {
    let (w0, h0) = img.dimensions();
    if w0 == 0 || h0 == 0 {
        return Texture {
            width: 1,
            height: 1,
            texels: vec![to_u8(fallback)],
            repeat_m: [1.0, 1.0],
        };
    }
    let (w, h) = (pow2_near(w0, max), pow2_near(h0, max));
    let texels = if (w, h) == (w0, h0) {
        img.pixels().map(|p| p.0).collect()
    } else {
        image::imageops::resize(img, w, h, FilterType::Triangle)
            .pixels()
            .map(|p| p.0)
            .collect()
    };
    Texture {
        width: w,
        height: h,
        texels,
        repeat_m: [1.0, 1.0],
    }
}
