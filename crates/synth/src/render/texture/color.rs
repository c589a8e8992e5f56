//! What every painter shares: colours as sRGB triples in 0–1 (`Rgb`) and their arithmetic, a
//! material's tint made safe and its random stream, the palettes of posters, pins and notes,
//! and `from_fn`, which bakes a repeating pattern texel by texel.

use super::Texture;
use crate::world::Material;
use rand::{Rng, SeedableRng};
use rand_chacha::ChaCha8Rng;

pub(crate) type Rgb = [f32; 3];

pub(crate) const WHITE: Rgb = [0.96, 0.96, 0.94];
pub(crate) const INK: Rgb = [0.12, 0.12, 0.13];

/// The material's colour, made safe (finite, 0–1).
pub(crate) fn tint(m: &Material) -> Rgb {
    m.color.map(|c| {
        if c.is_finite() {
            c.clamp(0.0, 1.0)
        } else {
            0.5
        }
    })
}

pub(crate) fn rng_for(m: &Material, salt: u64) -> ChaCha8Rng {
    ChaCha8Rng::seed_from_u64(m.seed ^ salt.wrapping_mul(0xA24B_AED4_963E_E407))
}

pub(crate) fn scale(c: Rgb, k: f32) -> Rgb {
    c.map(|x| x * k)
}

pub(crate) fn mul(a: Rgb, b: Rgb) -> Rgb {
    [a[0] * b[0], a[1] * b[1], a[2] * b[2]]
}

pub(crate) fn mix(a: Rgb, b: Rgb, t: f32) -> Rgb {
    [
        a[0] + (b[0] - a[0]) * t,
        a[1] + (b[1] - a[1]) * t,
        a[2] + (b[2] - a[2]) * t,
    ]
}

pub(crate) fn luminance(c: Rgb) -> f32 {
    0.2126 * c[0] + 0.7152 * c[1] + 0.0722 * c[2]
}

pub(crate) fn to_u8(c: Rgb) -> [u8; 3] {
    c.map(|x| (x.clamp(0.0, 1.0) * 255.0 + 0.5) as u8)
}

/// Saturated poster and pin colours.
pub(crate) const PALETTE: [Rgb; 12] = [
    [0.86, 0.16, 0.14],
    [0.96, 0.55, 0.10],
    [0.98, 0.84, 0.16],
    [0.20, 0.64, 0.30],
    [0.08, 0.58, 0.62],
    [0.14, 0.34, 0.76],
    [0.09, 0.14, 0.34],
    [0.50, 0.24, 0.64],
    [0.92, 0.42, 0.60],
    [0.10, 0.10, 0.11],
    [0.96, 0.95, 0.92],
    [0.56, 0.76, 0.92],
];

/// Pastel paper colours of notes.
pub(crate) const PAPERS: [Rgb; 4] = [
    [0.98, 0.93, 0.55],
    [0.97, 0.78, 0.84],
    [0.74, 0.88, 0.97],
    [0.78, 0.94, 0.74],
];

pub(crate) fn pick<T: Copy, R: Rng>(rng: &mut R, xs: &[T], fallback: T) -> T {
    if xs.is_empty() {
        return fallback;
    }
    xs.get(rng.random_range(0..xs.len()))
        .copied()
        .unwrap_or(fallback)
}

/// A palette colour that stands out against `bg`.
pub(crate) fn contrasting<R: Rng>(rng: &mut R, bg: Rgb) -> Rgb {
    let mut best = PALETTE[0];
    let mut best_d = -1.0;
    for _ in 0..6 {
        let c = pick(rng, &PALETTE, PALETTE[0]);
        let d: f32 = c.iter().zip(&bg).map(|(a, b)| (a - b).abs()).sum();
        if d > 0.9 {
            return c;
        }
        if d > best_d {
            best = c;
            best_d = d;
        }
    }
    best
}

/// Ink that reads on `bg`: white on dark, near-black on light.
pub(crate) fn ink_on(bg: Rgb) -> Rgb {
    if luminance(bg) < 0.5 { WHITE } else { INK }
}

/// A texture from a per-texel function (repeating patterns).
pub(crate) fn from_fn(
    w: usize,
    h: usize,
    repeat_m: [f32; 2],
    mut f: impl FnMut(usize, usize) -> Rgb,
) -> Texture {
    let mut texels = Vec::with_capacity(w * h);
    for y in 0..h {
        for x in 0..w {
            texels.push(to_u8(f(x, y)));
        }
    }
    Texture {
        width: w as u32,
        height: h as u32,
        texels,
        repeat_m,
    }
}
