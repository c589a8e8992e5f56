//! FAST-9 corners (Rosten & Drummond 2006) with non-maximum suppression, ranked by the Harris
//! response over a 7x7 window (as ORB ranks them), spread over a grid of cells so that one
//! textured corner of the picture cannot take every feature, and placed to a fraction of a
//! pixel by a parabola through the Harris response.

use crate::ExtractConfig;
use crate::describe::BORDER;
use image::GrayImage;

/// The 16 pixels of the radius-3 Bresenham circle, clockwise from the top.
const CIRCLE: [(i32, i32); 16] = [
    (0, -3),
    (1, -3),
    (2, -2),
    (3, -1),
    (3, 0),
    (3, 1),
    (2, 2),
    (1, 3),
    (0, 3),
    (-1, 3),
    (-2, 2),
    (-3, 1),
    (-3, 0),
    (-3, -1),
    (-2, -2),
    (-1, -3),
];

/// Harris's k.
const HARRIS_K: f32 = 0.04;
/// Half the Harris window (7x7).
const HARRIS_HALF: i32 = 3;

/// A corner of one pyramid level.
#[derive(Clone, Copy, Debug, PartialEq)]
pub(crate) struct Corner {
    /// Pixel column and row on the level.
    pub x: u32,
    pub y: u32,
    /// Sub-pixel offset from the pixel, in [-0.5, 0.5].
    pub dx: f32,
    pub dy: f32,
    /// Harris response.
    pub response: f32,
}

/// Up to `quota` corners of a level (see the module docs): FAST at `cfg.threshold`, or at
/// `cfg.min_threshold` when that finds fewer than `quota` (one scan finds both).
pub(crate) fn corners(img: &GrayImage, quota: usize, cfg: &ExtractConfig) -> Vec<Corner> {
    let low = cfg.min_threshold.min(cfg.threshold);
    let [at_low, at_high] = fast(img, low, cfg.threshold);
    let found = if at_high.len() >= quota {
        at_high
    } else {
        at_low
    };
    let mut ranked: Vec<Corner> = found
        .into_iter()
        .map(|(x, y)| Corner {
            x,
            y,
            dx: 0.0,
            dy: 0.0,
            response: harris(img, x as i32, y as i32),
        })
        .collect();
    ranked.sort_by(|a, b| b.response.total_cmp(&a.response));
    let mut chosen = spread(ranked, quota, img.width(), img.height(), cfg.cell);
    for c in &mut chosen {
        refine(img, c);
    }
    chosen
}

/// FAST-9 corners at two thresholds (`low` ≤ `high`), each set after 3x3 non-maximum
/// suppression on its own FAST score, inside the border a descriptor needs. One scan: a
/// corner at `high` is one at `low`.
fn fast(img: &GrayImage, low: u8, high: u8) -> [Vec<(u32, u32)>; 2] {
    let (w, h) = (img.width() as usize, img.height() as usize);
    let b = BORDER as usize;
    if w <= 2 * b || h <= 2 * b {
        return [Vec::new(), Vec::new()];
    }
    let px = img.as_raw();
    let offsets: Vec<isize> = CIRCLE
        .iter()
        .map(|&(dx, dy)| dy as isize * w as isize + dx as isize)
        .collect();
    let thresholds = [i16::from(low), i16::from(high.max(low))];
    let mut scores = [vec![0u16; w * h], vec![0u16; w * h]];
    let mut candidates = [Vec::new(), Vec::new()];
    let mut arcs = RingArcs::new(w - 2 * b);
    for y in b..h - b {
        let row = y * w;
        arcs.scan(px, w, y, thresholds[0] as u8);
        for x in arcs.corners().map(|i| i + b) {
            let i = row + x;
            let p = i16::from(px[i]);
            let ring: [i16; 16] =
                std::array::from_fn(|k| i16::from(px[(i as isize + offsets[k]) as usize]));
            for (k, &t) in thresholds.iter().enumerate() {
                match fast_score(p, &ring, t) {
                    Some(score) => {
                        scores[k][i] = score;
                        candidates[k].push((x as u32, y as u32));
                    }
                    // Not a corner at the low threshold: not at the high one either.
                    None => break,
                }
            }
        }
    }
    for (cands, score) in candidates.iter_mut().zip(&scores) {
        cands.retain(|&(x, y)| {
            let i = y as usize * w + x as usize;
            let s = score[i];
            // Ties go to the first in scan order: strictly above the neighbours before, at
            // least the neighbours after.
            let before = [i - w - 1, i - w, i - w + 1, i - 1];
            let after = [i + 1, i + w - 1, i + w, i + w + 1];
            before.iter().all(|&j| s > score[j]) && after.iter().all(|&j| s >= score[j])
        });
    }
    candidates
}

/// The segment test of FAST over a whole row at once: for each pixel inside the border, the
/// ring pixels brighter than it plus `t` and darker than it minus `t` as two 16-bit masks,
/// built one ring position at a time over the row (byte compares the compiler vectorises),
/// then the arc-of-nine test on every mask. A third of a textured image's pixels pass a
/// cheaper pre-test at FAST's low threshold, too many to examine one by one.
struct RingArcs {
    hi: Vec<u8>,
    lo: Vec<u8>,
    bright: Vec<u16>,
    dark: Vec<u16>,
    corner: Vec<bool>,
}

impl RingArcs {
    fn new(n: usize) -> Self {
        RingArcs {
            hi: vec![0; n],
            lo: vec![0; n],
            bright: vec![0; n],
            dark: vec![0; n],
            corner: vec![false; n],
        }
    }

    /// Tests the pixels of row `y` (from the border on) at threshold `t`.
    fn scan(&mut self, px: &[u8], w: usize, y: usize, t: u8) {
        #[cfg(target_arch = "x86_64")]
        {
            if std::arch::is_x86_feature_detected!("avx2") {
                // SAFETY: the CPU has AVX2, the only feature the function is compiled for.
                return unsafe { self.scan_avx2(px, w, y, t) };
            }
        }
        self.scan_portable(px, w, y, t);
    }

    /// [`Self::scan_portable`] compiled for AVX2: twice the lanes of the baseline's SSE2.
    #[cfg(target_arch = "x86_64")]
    #[target_feature(enable = "avx2")]
    fn scan_avx2(&mut self, px: &[u8], w: usize, y: usize, t: u8) {
        self.scan_portable(px, w, y, t);
    }

    #[inline(always)]
    fn scan_portable(&mut self, px: &[u8], w: usize, y: usize, t: u8) {
        let b = BORDER as usize;
        let n = self.hi.len();
        let centre = &px[y * w + b..y * w + b + n];
        for ((hi, lo), &p) in self.hi.iter_mut().zip(&mut self.lo).zip(centre) {
            *hi = p.saturating_add(t);
            *lo = p.saturating_sub(t);
        }
        self.bright.fill(0);
        self.dark.fill(0);
        for (k, &(dx, dy)) in CIRCLE.iter().enumerate() {
            let start =
                ((y as isize + dy as isize) * w as isize + b as isize + dx as isize) as usize;
            let ring = &px[start..start + n];
            let lanes = self
                .bright
                .iter_mut()
                .zip(&mut self.dark)
                .zip(&self.hi)
                .zip(&self.lo);
            for ((((bm, dm), &hi), &lo), &v) in lanes.zip(ring) {
                *bm |= u16::from(v > hi) << k;
                *dm |= u16::from(v < lo) << k;
            }
        }
        for ((c, &bm), &dm) in self.corner.iter_mut().zip(&self.bright).zip(&self.dark) {
            *c = has_arc_of_nine(u32::from(bm)) | has_arc_of_nine(u32::from(dm));
        }
    }

    /// Positions (from the border) of the corners the last scan found.
    fn corners(&self) -> impl Iterator<Item = usize> + '_ {
        self.corner
            .iter()
            .enumerate()
            .filter(|(_, c)| **c)
            .map(|(x, _)| x)
    }
}

/// The FAST score of a pixel `p` with its ring at threshold `t` (the larger of the summed
/// excesses of the brighter and the darker ring pixels), when it is a corner there.
fn fast_score(p: i16, ring: &[i16; 16], t: i16) -> Option<u16> {
    let (hi, lo) = (p + t, p - t);
    // Masks first, without branches; the sums only for the few pixels that are corners.
    let (mut bmask, mut dmask) = (0u32, 0u32);
    for (k, &v) in ring.iter().enumerate() {
        bmask |= u32::from(v > hi) << k;
        dmask |= u32::from(v < lo) << k;
    }
    if !(has_arc_of_nine(bmask) || has_arc_of_nine(dmask)) {
        return None;
    }
    let bsum: u32 = ring.iter().map(|&v| (v - hi).max(0) as u32).sum();
    let dsum: u32 = ring.iter().map(|&v| (lo - v).max(0) as u32).sum();
    Some(bsum.max(dsum).clamp(1, u32::from(u16::MAX)) as u16)
}

/// True when nine consecutive bits (circularly) of a 16-bit mask are set.
fn has_arc_of_nine(mask: u32) -> bool {
    let m = mask | (mask << 16);
    let mut run = m;
    for s in 1..9 {
        run &= m >> s;
    }
    run != 0
}

/// Harris response at a pixel: central-difference gradients over a 7x7 window.
fn harris(img: &GrayImage, x: i32, y: i32) -> f32 {
    let w = img.width() as i32;
    let px = img.as_raw();
    let at = |xx: i32, yy: i32| f32::from(px[(yy * w + xx) as usize]);
    let (mut a, mut b, mut c) = (0.0f32, 0.0f32, 0.0f32);
    for yy in y - HARRIS_HALF..=y + HARRIS_HALF {
        for xx in x - HARRIS_HALF..=x + HARRIS_HALF {
            let gx = at(xx + 1, yy) - at(xx - 1, yy);
            let gy = at(xx, yy + 1) - at(xx, yy - 1);
            a += gx * gx;
            b += gy * gy;
            c += gx * gy;
        }
    }
    a * b - c * c - HARRIS_K * (a + b) * (a + b)
}

/// The strongest corners (ranked, best first) with at most a fair share per grid cell; what
/// the cells leave over fills the quota in rank order.
fn spread(ranked: Vec<Corner>, quota: usize, w: u32, h: u32, cell: u32) -> Vec<Corner> {
    if ranked.len() <= quota {
        return ranked;
    }
    let (cols, rows) = (w.div_ceil(cell) as usize, h.div_ceil(cell) as usize);
    let cap = (2 * quota).div_ceil(cols * rows).max(2);
    let mut per_cell = vec![0usize; cols * rows];
    let mut chosen = Vec::with_capacity(quota);
    let mut left = Vec::new();
    for c in ranked {
        let k = (c.y / cell) as usize * cols + (c.x / cell) as usize;
        if chosen.len() < quota && per_cell[k] < cap {
            per_cell[k] += 1;
            chosen.push(c);
        } else {
            left.push(c);
        }
    }
    let missing = quota - chosen.len();
    chosen.extend(left.into_iter().take(missing));
    chosen
}

/// Moves a corner to the peak of a parabola through the Harris response of it and its
/// neighbours, per axis, when it is a peak along that axis (offset within half a pixel).
fn refine(img: &GrayImage, c: &mut Corner) {
    let (x, y) = (c.x as i32, c.y as i32);
    let r0 = c.response;
    let peak = |minus: f32, plus: f32| {
        let curvature = minus - 2.0 * r0 + plus;
        if curvature < 0.0 {
            (0.5 * (minus - plus) / curvature).clamp(-0.5, 0.5)
        } else {
            0.0
        }
    };
    c.dx = peak(harris(img, x - 1, y), harris(img, x + 1, y));
    c.dy = peak(harris(img, x, y - 1), harris(img, x, y + 1));
}

#[cfg(test)]
mod tests {
    use super::*;
    use image::Luma;

    /// A dark image with one bright square: four corners.
    fn square() -> GrayImage {
        let mut img = GrayImage::from_pixel(96, 96, Luma([30]));
        for y in 30..66 {
            for x in 30..66 {
                img.put_pixel(x, y, Luma([200]));
            }
        }
        img
    }

    #[test]
    fn arcs_of_nine_are_found_around_the_circle() {
        assert!(has_arc_of_nine(0b1_1111_1111));
        assert!(has_arc_of_nine(
            0b1111_0000_0000_0011_1111 & 0xffff | 0xf000
        ));
        assert!(!has_arc_of_nine(0b1111_1111));
        assert!(!has_arc_of_nine(0b0101_0101_0101_0101));
        // Wrapping: bits 12..16 and 0..5 (nine).
        assert!(has_arc_of_nine(0xf000 | 0b1_1111));
    }

    #[test]
    fn the_corners_of_a_square_are_found_near_its_corners() {
        let img = square();
        let cfg = ExtractConfig::default();
        let found = corners(&img, 10, &cfg);
        assert!(found.len() >= 4, "{found:?}");
        for (cx, cy) in [(30.0, 30.0), (65.0, 30.0), (30.0, 65.0), (65.0, 65.0)] {
            let best = found
                .iter()
                .map(|c| {
                    let (x, y) = (c.x as f32 + c.dx, c.y as f32 + c.dy);
                    ((x - cx).powi(2) + (y - cy).powi(2)).sqrt()
                })
                .fold(f32::INFINITY, f32::min);
            assert!(best < 2.5, "no corner near ({cx}, {cy}): {found:?}");
        }
        // A flat image has none.
        assert!(corners(&GrayImage::from_pixel(96, 96, Luma([90])), 10, &cfg).is_empty());
    }

    #[test]
    fn the_grid_keeps_strong_corners_from_crowding_one_cell() {
        let mk = |x, y, r| Corner {
            x,
            y,
            dx: 0.0,
            dy: 0.0,
            response: r,
        };
        // Ten strong corners in one cell, two weak ones elsewhere; quota 4 over 4 cells: cap 2.
        let mut ranked: Vec<Corner> = (0..10).map(|i| mk(i, 1, 100.0 - i as f32)).collect();
        ranked.push(mk(40, 40, 1.0));
        ranked.push(mk(40, 5, 0.5));
        let got = spread(ranked, 4, 64, 64, 32);
        assert_eq!(got.len(), 4);
        assert!(got.iter().any(|c| c.x == 40 && c.y == 40));
        assert!(got.iter().any(|c| c.x == 40 && c.y == 5));
    }
}
