//! Orientation and the binary descriptor of a corner: ORB's intensity centroid over a disc of
//! radius 15, and 256 comparisons of smoothed grey levels at point pairs drawn once from an
//! isotropic Gaussian (BRIEF's pattern "G II", σ = S/5 for a 31-pixel patch, clipped to the
//! patch), rotated by the corner's orientation. The pattern comes from a fixed seed, so every
//! map and every query use the same one.

use image::GrayImage;
use std::sync::OnceLock;

/// Bytes of a descriptor.
pub const DESCRIPTOR_BYTES: usize = 32;

/// A 256-bit binary descriptor, as four words (compared by their Hamming distance).
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

/// The level smoothed by the 7x7 Gaussian (separable, edges replicated). Each row is first
/// copied with its edges replicated, and the vertical pass reads seven whole rows, so both
/// inner loops run over plain slices and vectorise.
pub(crate) fn smooth(img: &GrayImage) -> GrayImage {
    #[cfg(target_arch = "x86_64")]
    {
        if std::arch::is_x86_feature_detected!("avx2") {
            // SAFETY: the CPU has AVX2, the only feature the function is compiled for.
            return unsafe { smooth_avx2(img) };
        }
    }
    smooth_portable(img)
}

/// [`smooth_portable`] compiled for AVX2: twice the lanes of the baseline's SSE2.
#[cfg(target_arch = "x86_64")]
#[target_feature(enable = "avx2")]
fn smooth_avx2(img: &GrayImage) -> GrayImage {
    smooth_portable(img)
}

#[inline(always)]
fn smooth_portable(img: &GrayImage) -> GrayImage {
    let (w, h) = (img.width() as usize, img.height() as usize);
    let src = img.as_raw();
    let mut rows = vec![0u32; w * h];
    let mut padded = vec![0u32; w + 6];
    for (line, row) in src.chunks_exact(w).zip(rows.chunks_exact_mut(w)) {
        for (p, &v) in padded[3..w + 3].iter_mut().zip(line) {
            *p = u32::from(v);
        }
        padded[..3].fill(u32::from(line[0]));
        padded[w + 3..].fill(u32::from(line[w - 1]));
        for (k, &g) in GAUSS7.iter().enumerate() {
            for (r, &p) in row.iter_mut().zip(&padded[k..k + w]) {
                *r += g * p;
            }
        }
    }
    let mut out = vec![0u8; w * h];
    let mut sum = vec![0u32; w];
    for (y, out_row) in out.chunks_exact_mut(w).enumerate() {
        sum.fill(32768);
        for (k, &g) in GAUSS7.iter().enumerate() {
            let sy = (y + k).saturating_sub(3).min(h - 1);
            for (s, &r) in sum.iter_mut().zip(&rows[sy * w..(sy + 1) * w]) {
                *s += g * r;
            }
        }
        for (o, &s) in out_row.iter_mut().zip(&sum) {
            *o = (s >> 16) as u8;
        }
    }
    GrayImage::from_raw(w as u32, h as u32, out).expect("buffer of the image's size")
}

/// The direction of the intensity centroid of the disc around a pixel, radians. Summed row by
/// row (each row's plain sum and its x-moment), so the inner loop runs over a slice.
pub(crate) fn orientation(img: &GrayImage, x: u32, y: u32) -> f32 {
    let w = img.width() as usize;
    let px = img.as_raw();
    let (x, y) = (x as usize, y as usize);
    let (mut m10, mut m01) = (0i64, 0i64);
    for (dy, &half) in (-ORIENT_RADIUS..=ORIENT_RADIUS).zip(disc_half_widths()) {
        let row = (y as i64 + i64::from(dy)) as usize * w;
        let line = &px[row + x - half..=row + x + half];
        let (mut sum, mut moment) = (0i32, 0i32);
        for (dx, &v) in (-(half as i32)..).zip(line) {
            sum += i32::from(v);
            moment += dx * i32::from(v);
        }
        m10 += i64::from(moment);
        m01 += i64::from(dy) * i64::from(sum);
    }
    (m01 as f32).atan2(m10 as f32)
}

/// Half the width of each row of the orientation disc, top to bottom.
fn disc_half_widths() -> &'static [usize; 2 * ORIENT_RADIUS as usize + 1] {
    static HALVES: OnceLock<[usize; 2 * ORIENT_RADIUS as usize + 1]> = OnceLock::new();
    HALVES.get_or_init(|| {
        let r = ORIENT_RADIUS;
        std::array::from_fn(|i| {
            let dy = i as i32 - r;
            ((r * r - dy * dy) as f32).sqrt() as usize
        })
    })
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
/// The rotated pattern's pixel offsets are computed first, all 512 in one loop that
/// vectorises; the comparisons then only load and compare.
pub(crate) fn describe(smooth: &GrayImage, x: u32, y: u32, angle: f32) -> Descriptor {
    let w = smooth.width() as i32;
    let px = smooth.as_raw();
    let (s, c) = angle.sin_cos();
    let centre = (y * smooth.width() + x) as i32;
    // Nearest pixel by truncating a shifted positive value: a conversion instruction, where
    // `f32::round` is a library call (a tenth of the extraction's time).
    // SAFETY (`to_int_unchecked`): `c` and `s` are a sine and cosine and the pattern's
    // coordinates lie within ±13, so `v + 64.5` is finite and within 64.5 ± 19.
    let nearest = |v: f32| unsafe { (v + 64.5).to_int_unchecked::<i32>() } - 64;
    let pattern = pattern_points();
    let mut offsets = [0i32; 512];
    for ((o, &u), &v) in offsets.iter_mut().zip(&pattern.xs).zip(&pattern.ys) {
        *o = centre + nearest(c * u - s * v) + w * nearest(s * u + c * v);
    }
    let lowest = offsets.iter().copied().min().unwrap_or(0);
    let highest = offsets.iter().copied().max().unwrap_or(0);
    assert!(
        lowest >= 0 && (highest as usize) < px.len(),
        "a corner within {BORDER} pixels of the level's edge"
    );
    let mut d = [0u64; 4];
    for (word, pairs) in d.iter_mut().zip(offsets.chunks_exact(128)) {
        for (bit, pair) in pairs.chunks_exact(2).enumerate() {
            // SAFETY: every offset was checked to lie inside `px` above.
            let (a, b) = unsafe {
                (
                    *px.get_unchecked(pair[0] as usize),
                    *px.get_unchecked(pair[1] as usize),
                )
            };
            *word |= u64::from(a < b) << bit;
        }
    }
    d
}

/// The pattern's points as two coordinate lists: pair k's first point at 2k, its second at
/// 2k + 1.
struct PatternPoints {
    xs: [f32; 512],
    ys: [f32; 512],
}

fn pattern_points() -> &'static PatternPoints {
    static POINTS: OnceLock<PatternPoints> = OnceLock::new();
    POINTS.get_or_init(|| {
        let p = pattern();
        PatternPoints {
            xs: std::array::from_fn(|i| p[i / 2][2 * (i % 2)]),
            ys: std::array::from_fn(|i| p[i / 2][2 * (i % 2) + 1]),
        }
    })
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

    #[test]
    fn smoothing_equals_the_direct_sum_with_replicated_edges() {
        let img = GrayImage::from_fn(23, 11, |x, y| {
            Luma([((x * 37 + y * 91 + x * y * 13) % 256) as u8])
        });
        let (w, h) = (23i64, 11i64);
        let at = |x: i64, y: i64| {
            u32::from(img.get_pixel(x.clamp(0, w - 1) as u32, y.clamp(0, h - 1) as u32)[0])
        };
        let got = smooth(&img);
        for y in 0..h {
            for x in 0..w {
                let mut s = 0u32;
                for (j, &gy) in GAUSS7.iter().enumerate() {
                    let row: u32 = GAUSS7
                        .iter()
                        .enumerate()
                        .map(|(i, &gx)| gx * at(x + i as i64 - 3, y + j as i64 - 3))
                        .sum();
                    s += gy * row;
                }
                assert_eq!(
                    u32::from(got.get_pixel(x as u32, y as u32)[0]),
                    (s + 32768) >> 16,
                    "({x}, {y})"
                );
            }
        }
    }
}
