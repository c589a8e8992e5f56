//! Test images and image statistics shared by the augmentation tests.

use image::{Rgb, RgbImage};
use rand::{Rng, SeedableRng};
use rand_chacha::ChaCha8Rng;

/// A synthetic corridor-like scene: a shaded wall and floor, a door, a window, a lamp and a
/// skirting line, in distinct colours, with soft shading so that both edges and smooth
/// regions are present.
pub fn scene(w: u32, h: u32) -> RgbImage {
    let (wf, hf) = (f64::from(w), f64::from(h));
    RgbImage::from_fn(w, h, |x, y| {
        let (u, v) = (f64::from(x) / wf, f64::from(y) / hf);
        let shade = 0.75 + 0.25 * (1.0 - (u - 0.5).abs() * 2.0);
        let mut c = if v > 0.7 {
            [150.0, 110.0, 70.0] // wooden floor
        } else {
            [200.0, 195.0, 180.0] // off-white wall
        };
        if (0.12..0.3).contains(&u) && (0.25..0.7).contains(&v) {
            c = [60.0, 90.0, 160.0]; // blue door
        }
        if (0.55..0.85).contains(&u) && (0.15..0.45).contains(&v) {
            c = [140.0, 190.0, 230.0]; // window
        }
        if ((u - 0.45) * wf).hypot((v - 0.1) * hf) < 0.05 * wf {
            c = [255.0, 245.0, 200.0]; // lamp
        }
        if (0.68..0.7).contains(&v) {
            c = [40.0, 40.0, 40.0]; // skirting board
        }
        Rgb(c.map(|k| (k * shade).round().clamp(0.0, 255.0) as u8))
    })
}

/// An image of independent uniform random bytes.
pub fn noise_image(w: u32, h: u32, seed: u64) -> RgbImage {
    let mut rng = ChaCha8Rng::seed_from_u64(seed);
    RgbImage::from_fn(w, h, |_, _| Rgb(rng.random()))
}

/// Multi-channel Sobel gradient magnitude `√(Σ_c |∇I_c|²)` at every interior pixel.
pub fn gradient_magnitude(img: &RgbImage) -> Vec<f64> {
    let (w, h) = img.dimensions();
    let p = |x: u32, y: u32, c: usize| f64::from(img.get_pixel(x, y)[c]);
    let mut out = Vec::with_capacity(((w - 2) * (h - 2)) as usize);
    for y in 1..h - 1 {
        for x in 1..w - 1 {
            let mut s = 0.0;
            for c in 0..3 {
                let gx = p(x + 1, y - 1, c) + 2.0 * p(x + 1, y, c) + p(x + 1, y + 1, c)
                    - p(x - 1, y - 1, c)
                    - 2.0 * p(x - 1, y, c)
                    - p(x - 1, y + 1, c);
                let gy = p(x - 1, y + 1, c) + 2.0 * p(x, y + 1, c) + p(x + 1, y + 1, c)
                    - p(x - 1, y - 1, c)
                    - 2.0 * p(x, y - 1, c)
                    - p(x + 1, y - 1, c);
                s += gx * gx + gy * gy;
            }
            out.push(s.sqrt());
        }
    }
    out
}

/// Pearson correlation of two equally long samples.
pub fn pearson(a: &[f64], b: &[f64]) -> f64 {
    let n = a.len() as f64;
    let (ma, mb) = (a.iter().sum::<f64>() / n, b.iter().sum::<f64>() / n);
    let (mut sab, mut saa, mut sbb) = (0.0, 0.0, 0.0);
    for (x, y) in a.iter().zip(b) {
        sab += (x - ma) * (y - mb);
        saa += (x - ma) * (x - ma);
        sbb += (y - mb) * (y - mb);
    }
    sab / (saa * sbb).sqrt()
}

/// Joint colour histogram with 4 levels per channel (64 bins), normalised to sum 1.
pub fn colour_histogram(img: &RgbImage) -> [f64; 64] {
    let mut hist = [0f64; 64];
    for p in img.pixels() {
        let [r, g, b] = p.0.map(|v| usize::from(v >> 6));
        hist[r * 16 + g * 4 + b] += 1.0;
    }
    let n = f64::from(img.width() * img.height());
    hist.map(|v| v / n)
}

/// Histogram intersection: 1 for identical colour distributions, 0 for disjoint ones.
pub fn intersection(a: &[f64; 64], b: &[f64; 64]) -> f64 {
    a.iter().zip(b).map(|(x, y)| x.min(*y)).sum()
}

/// Mean and variance of all bytes.
pub fn mean_var(bytes: &[u8]) -> (f64, f64) {
    let n = bytes.len() as f64;
    let m = bytes.iter().map(|&v| f64::from(v)).sum::<f64>() / n;
    let v = bytes
        .iter()
        .map(|&v| (f64::from(v) - m).powi(2))
        .sum::<f64>()
        / n;
    (m, v)
}
