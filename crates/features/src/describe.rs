//! Orientation and the binary descriptor of a corner: ORB's intensity centroid over a disc of
//! radius 15, and 256 comparisons of smoothed grey levels at point pairs drawn once from an
//! isotropic Gaussian (BRIEF's pattern "G II", σ = S/5 for a 31-pixel patch, clipped to the
//! patch), rotated by the corner's orientation. The pattern comes from a fixed seed, so every
//! map and every query use the same one.

use image::GrayImage;
use std::sync::OnceLock;

/// Bytes of a descriptor.
pub const DESCRIPTOR_BYTES: usize = 32;

/// A 256-bit binary descriptor, as four words (compared with [`Descriptor::distance`]).
pub type Descriptor = [u64; 4];

/// Pixels kept clear at each side of a level: the rotated pattern reaches 13·√2 < 19 pixels,
/// the orientation disc 15, Harris refinement 5.
pub(crate) const BORDER: u32 = 20;

/// Radius of the orientation disc.
const ORIENT_RADIUS: i32 = 15;
/// Largest pattern coordinate.
const PATTERN_HALF: f32 = 13.0;
/// The smoothing kernel: a 7-tap Gaussian, σ = 2 (ORB's), in 1/256.
const GAUSS7: [u32; 7] = [18, 33, 49, 56, 49, 33, 18];

/// Hamming distance between two descriptors.
pub fn distance(a: &Descriptor, b: &Descriptor) -> u32 {
    (a[0] ^ b[0]).count_ones()
        + (a[1] ^ b[1]).count_ones()
        + (a[2] ^ b[2]).count_ones()
        + (a[3] ^ b[3]).count_ones()
}

/// The level smoothed by the 7x7 Gaussian (separable, edges replicated).
pub(crate) fn smooth(img: &GrayImage) -> GrayImage {
    let (w, h) = (img.width() as usize, img.height() as usize);
    let src = img.as_raw();
    let clamp = |v: isize, n: usize| v.clamp(0, n as isize - 1) as usize;
    let mut rows = vec![0u32; w * h];
    for y in 0..h {
        let line = &src[y * w..(y + 1) * w];
        for x in 0..w {
            rows[y * w + x] = GAUSS7
                .iter()
                .enumerate()
                .map(|(k, &g)| g * u32::from(line[clamp(x as isize + k as isize - 3, w)]))
                .sum();
        }
    }
    let mut out = vec![0u8; w * h];
    for y in 0..h {
        for x in 0..w {
            let s: u32 = GAUSS7
                .iter()
                .enumerate()
                .map(|(k, &g)| g * rows[clamp(y as isize + k as isize - 3, h) * w + x])
                .sum();
            out[y * w + x] = ((s + 32768) >> 16) as u8;
        }
    }
    GrayImage::from_raw(w as u32, h as u32, out).expect("buffer of the image's size")
}

/// The direction of the intensity centroid of the disc around a pixel, radians.
pub(crate) fn orientation(img: &GrayImage, x: u32, y: u32) -> f32 {
    let w = img.width() as i32;
    let px = img.as_raw();
    let (x, y) = (x as i32, y as i32);
    let (mut m10, mut m01) = (0i64, 0i64);
    for dy in -ORIENT_RADIUS..=ORIENT_RADIUS {
        let half = ((ORIENT_RADIUS * ORIENT_RADIUS - dy * dy) as f32).sqrt() as i32;
        let row = ((y + dy) * w) as usize;
        for dx in -half..=half {
            let v = i64::from(px[row + (x + dx) as usize]);
            m10 += i64::from(dx) * v;
            m01 += i64::from(dy) * v;
        }
    }
    (m01 as f32).atan2(m10 as f32)
}

/// The 256 point pairs `(x1, y1, x2, y2)` of the pattern.
fn pattern() -> &'static [[f32; 4]; 256] {
    static PATTERN: OnceLock<[[f32; 4]; 256]> = OnceLock::new();
    PATTERN.get_or_init(|| {
        // SplitMix64 and Box-Muller: a fixed, portable draw with no dependency.
        let mut state = 0x1d00_710c_u64;
        let mut uniform = move || {
            state = state.wrapping_add(0x9e37_79b9_7f4a_7c15);
            let mut z = state;
            z = (z ^ (z >> 30)).wrapping_mul(0xbf58_476d_1ce4_e5b9);
            z = (z ^ (z >> 27)).wrapping_mul(0x94d0_49bb_1331_11eb);
            z ^= z >> 31;
            ((z >> 11) as f64 + 0.5) / (1u64 << 53) as f64
        };
        let sigma = 31.0 / 5.0;
        let mut gauss = move || {
            let (u, v) = (uniform(), uniform());
            let g = (-2.0 * u.ln()).sqrt() * (std::f64::consts::TAU * v).cos() * sigma;
            (g as f32).round().clamp(-PATTERN_HALF, PATTERN_HALF)
        };
        let mut out = [[0.0f32; 4]; 256];
        for pair in &mut out {
            loop {
                *pair = [gauss(), gauss(), gauss(), gauss()];
                if pair[0] != pair[2] || pair[1] != pair[3] {
                    break;
                }
            }
        }
        out
    })
}

/// The descriptor of the corner at `(x, y)` of a smoothed level, pattern rotated by `angle`.
pub(crate) fn describe(smooth: &GrayImage, x: u32, y: u32, angle: f32) -> Descriptor {
    let w = smooth.width() as i32;
    let px = smooth.as_raw();
    let (s, c) = angle.sin_cos();
    let (x, y) = (x as i32, y as i32);
    // Nearest pixel by truncating a shifted positive value: a conversion instruction, where
    // `f32::round` is a library call (a tenth of the extraction's time).
    let nearest = |v: f32| (v + 64.5) as i32 - 64;
    let at = |u: f32, v: f32| {
        let xx = x + nearest(c * u - s * v);
        let yy = y + nearest(s * u + c * v);
        px[(yy * w + xx) as usize]
    };
    let mut d = [0u64; 4];
    for (k, p) in pattern().iter().enumerate() {
        if at(p[0], p[1]) < at(p[2], p[3]) {
            d[k / 64] |= 1 << (k % 64);
        }
    }
    d
}

#[cfg(test)]
mod tests {
    use super::*;
    use image::Luma;

    #[test]
    fn the_pattern_is_fixed_and_inside_the_patch() {
        let p = pattern();
        assert!(p.iter().flatten().all(|v| v.abs() <= PATTERN_HALF));
        // Spread like the Gaussian it was drawn from: about σ = 6.2, clipped.
        let var = p.iter().flatten().map(|v| v * v).sum::<f32>() / 1024.0;
        assert!((4.5..7.0).contains(&var.sqrt()), "{}", var.sqrt());
        assert_eq!(p[0], pattern()[0]);
    }

    #[test]
    fn orientation_points_to_the_bright_side() {
        let mut img = GrayImage::from_pixel(64, 64, Luma([10]));
        for y in 0..64 {
            for x in 32..64 {
                img.put_pixel(x, y, Luma([200]));
            }
        }
        assert!(orientation(&img, 32, 32).abs() < 0.1);
        let down = GrayImage::from_fn(64, 64, |_, y| Luma([if y > 32 { 200 } else { 10 }]));
        let a = orientation(&down, 32, 32);
        assert!((a - std::f32::consts::FRAC_PI_2).abs() < 0.1, "{a}");
    }

    #[test]
    fn distance_counts_differing_bits_and_smoothing_keeps_flat_images() {
        assert_eq!(distance(&[0; 4], &[u64::MAX; 4]), 256);
        assert_eq!(distance(&[1, 2, 3, 4], &[1, 2, 3, 4]), 0);
        assert_eq!(distance(&[0, 0, 0, 0], &[0b101, 0, 0, 1 << 63]), 3);
        let flat = GrayImage::from_pixel(40, 30, Luma([77]));
        assert_eq!(smooth(&flat), flat);
    }
}
