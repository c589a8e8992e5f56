//! Lettering for posters and signs: a 3 × 5 block font (capitals, digits, `.` and `-`) drawn
//! onto a [`Canvas`], random words, and lines of dashes that read as small print from a distance.

use super::canvas::Canvas;
use super::color::Rgb;
use rand::Rng;

/// A 3 × 5 block font (rows top to bottom, 3 bits each, left bit first).
const FONT_AZ: [u16; 26] = [
    0b010_101_111_101_101,
    0b110_101_110_101_110,
    0b011_100_100_100_011,
    0b110_101_101_101_110,
    0b111_100_110_100_111,
    0b111_100_110_100_100,
    0b011_100_101_101_011,
    0b101_101_111_101_101,
    0b111_010_010_010_111,
    0b001_001_001_101_010,
    0b101_101_110_101_101,
    0b100_100_100_100_111,
    0b101_111_111_101_101,
    0b110_101_101_101_101,
    0b010_101_101_101_010,
    0b110_101_110_100_100,
    0b010_101_101_110_011,
    0b110_101_110_101_101,
    0b011_100_010_001_110,
    0b111_010_010_010_010,
    0b101_101_101_101_111,
    0b101_101_101_101_010,
    0b101_101_111_111_101,
    0b101_101_010_101_101,
    0b101_101_010_010_010,
    0b111_001_010_100_111,
];
const FONT_09: [u16; 10] = [
    0b111_101_101_101_111,
    0b010_110_010_010_111,
    0b110_001_010_100_111,
    0b110_001_010_001_110,
    0b101_101_111_001_001,
    0b111_100_110_001_110,
    0b011_100_110_101_010,
    0b111_001_010_010_010,
    0b010_101_010_101_010,
    0b010_101_011_001_110,
];

fn glyph(ch: u8) -> u16 {
    match ch {
        b'A'..=b'Z' => FONT_AZ.get((ch - b'A') as usize).copied().unwrap_or(0),
        b'0'..=b'9' => FONT_09.get((ch - b'0') as usize).copied().unwrap_or(0),
        b'.' => 0b000_000_000_000_010,
        b'-' => 0b000_000_111_000_000,
        _ => 0,
    }
}

/// Width of `n` characters of block text with cell width `cw`.
pub(crate) fn text_width(n: usize, cw: f32) -> f32 {
    (4 * n) as f32 * cw - cw
}

/// Draws block text with its top-left corner at `(x, y)`; cells `cw × ch` metres. Texels are
/// set by their centres, so neighbouring cells join without seams.
pub(crate) fn text(c: &mut Canvas, at: [f32; 2], cell: [f32; 2], s: &[u8], color: Rgb) {
    let [cw, ch] = cell;
    if s.is_empty() || cw <= 0.0 || ch <= 0.0 {
        return;
    }
    let bbox = [
        at[0],
        at[1],
        at[0] + text_width(s.len(), cw),
        at[1] + 5.0 * ch,
    ];
    let x0 = (bbox[0] * c.sx).floor().max(0.0) as usize;
    let y0 = (bbox[1] * c.sy).floor().max(0.0) as usize;
    let x1 = ((bbox[2] * c.sx).ceil().max(0.0) as usize).min(c.w);
    let y1 = ((bbox[3] * c.sy).ceil().max(0.0) as usize).min(c.h);
    for y in y0..y1 {
        let row = ((y as f32 + 0.5) / c.sy - at[1]) / ch;
        if !(0.0..5.0).contains(&row) {
            continue;
        }
        for x in x0..x1 {
            let col = ((x as f32 + 0.5) / c.sx - at[0]) / cw;
            if col < 0.0 {
                continue;
            }
            let (i, k) = ((col as usize) / 4, (col as usize) % 4);
            let Some(&chr) = s.get(i) else { continue };
            if k < 3 && (glyph(chr) >> (14 - (row as usize * 3 + k))) & 1 == 1 {
                c.blend(x, y, color, 1.0);
            }
        }
    }
}

/// A random upper-case word or two, `n` characters.
pub(crate) fn random_word<R: Rng>(rng: &mut R, n: usize) -> Vec<u8> {
    let mut s: Vec<u8> = (0..n).map(|_| b'A' + rng.random_range(0..26u8)).collect();
    if n >= 6 && rng.random_bool(0.6) {
        let k = rng.random_range(2..n - 2);
        if let Some(ch) = s.get_mut(k) {
            *ch = b' ';
        }
    }
    s
}

/// "Text": lines of dark dashes (words) filling a box, the last line shorter.
pub(crate) fn text_lines<R: Rng>(
    c: &mut Canvas,
    rng: &mut R,
    bbox: [f32; 4],
    line_h: f32,
    color: Rgb,
) {
    let [x0, y0, x1, y1] = bbox;
    let pitch = line_h * 2.2;
    let n = ((y1 - y0 + line_h * 1.2) / pitch).floor().max(0.0) as usize;
    let word = (line_h * 2.5).max(0.01);
    for i in 0..n {
        let y = y0 + i as f32 * pitch;
        let end = if i + 1 == n {
            x0 + (x1 - x0) * rng.random_range(0.3f32..0.8)
        } else {
            x1 - (x1 - x0) * rng.random_range(0.0f32..0.15)
        };
        let mut x = x0;
        while x < end {
            let len = word * rng.random_range(0.6f32..2.6);
            let xe = (x + len).min(end);
            if xe - x > word * 0.4 {
                c.rect(x, y, xe, y + line_h, color, 0.9);
            }
            x = xe + word * 0.55;
        }
    }
}
