//! The overall shift of the picture between two frames, from their row and column profiles.
//!
//! A camera that turns or walks fast moves the whole picture by a few thumbnail pixels between
//! frames (3 px or more at 10 frames/s), and a plain column difference then grows as if the
//! scene changed. Matching the frames' mean-brightness profiles (one value per thumbnail column,
//! one per row) finds that shift in a few hundred operations; the detector then compares the
//! path with the previous frame's path moved by it. A cut has no shift that makes the frames
//! match, so its difference stays high.

/// Grey-level profiles of a thumbnail, each shifted to zero mean (blind to brightness).
#[derive(Clone, Debug, Default)]
pub(crate) struct Profiles {
    /// Mean of each column, left to right.
    columns: Vec<f32>,
    /// Mean of each row, top to bottom.
    rows: Vec<f32>,
}

impl Profiles {
    /// Profiles of an RGB thumbnail of `width` x `height`.
    pub(crate) fn of(rgb: &[u8], width: usize, height: usize) -> Profiles {
        let mut columns = vec![0f32; width];
        let mut rows = vec![0f32; height];
        for (y, row) in rgb.chunks_exact(3 * width).take(height).enumerate() {
            for (x, px) in row.chunks_exact(3).enumerate() {
                let g = f32::from(px[0]) + f32::from(px[1]) + f32::from(px[2]);
                columns[x] += g;
                rows[y] += g;
            }
        }
        let centre = |v: &mut Vec<f32>, n: usize| {
            let scale = 1.0 / (3.0 * n.max(1) as f32);
            v.iter_mut().for_each(|x| *x *= scale);
            let mean = v.iter().sum::<f32>() / v.len().max(1) as f32;
            v.iter_mut().for_each(|x| *x -= mean);
        };
        centre(&mut columns, height);
        centre(&mut rows, width);
        Profiles { columns, rows }
    }

    /// `(dx, dy)` such that this frame at `(x, y)` looks most like `prev` at `(x + dx, y + dy)`,
    /// each within `±max_x`, `±max_y`.
    pub(crate) fn shift_from(&self, prev: &Profiles, max_x: i32, max_y: i32) -> (i32, i32) {
        (
            best_shift(&self.columns, &prev.columns, max_x),
            best_shift(&self.rows, &prev.rows, max_y),
        )
    }
}

/// The `s` in `-max..=max` minimising the mean `|cur[i] − prev[i + s]|` over the overlap (at
/// least half the profile); 0 on ties, so a still camera keeps its plain comparison.
fn best_shift(cur: &[f32], prev: &[f32], max: i32) -> i32 {
    let n = cur.len().min(prev.len()) as i32;
    let mut best = (f32::INFINITY, 0);
    for s in -max..=max {
        let (lo, hi) = ((-s).max(0), (n - s).min(n));
        if hi - lo < n / 2 || hi <= lo {
            continue;
        }
        let sad: f32 = (lo..hi)
            .map(|i| (cur[i as usize] - prev[(i + s) as usize]).abs())
            .sum::<f32>()
            / (hi - lo) as f32;
        // Prefer the smaller shift unless a larger one is clearly better.
        let key = (sad * 1.02 + 0.01 * s.unsigned_abs() as f32, s.abs());
        if key.0 < best.0 {
            best = (key.0, s);
        }
    }
    best.1
}

#[cfg(test)]
mod tests {
    use super::*;

    /// A textured thumbnail moved by (3, -1) pixels is found moved by that much.
    #[test]
    fn finds_the_shift_of_a_moved_picture() {
        let (w, h) = (64usize, 48usize);
        let texture = |x: i32, y: i32| -> u8 {
            let v = (x * 37 + y * 11 + (x * y) % 23) % 200;
            (v.rem_euclid(200) + 20) as u8
        };
        let frame = |ox: i32, oy: i32| -> Vec<u8> {
            let mut v = Vec::with_capacity(w * h * 3);
            for y in 0..h as i32 {
                for x in 0..w as i32 {
                    let g = texture(x + ox, y + oy);
                    v.extend_from_slice(&[g, g, g]);
                }
            }
            v
        };
        let prev = Profiles::of(&frame(0, 0), w, h);
        let cur = Profiles::of(&frame(-3, 1), w, h);
        // cur at x shows texture(x - 3): prev at x - 3, so dx = -3; dy = +1
        assert_eq!(cur.shift_from(&prev, 4, 4), (-3, 1));
        assert_eq!(prev.shift_from(&prev, 4, 4), (0, 0));
    }
}
