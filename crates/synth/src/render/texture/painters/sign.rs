//! Sign plates: exit and fire-extinguisher signs, information, toilet and direction signs, and
//! room-number plates, chosen by the plate's colour and the seed; with the pictograms they draw
//! (running and standing figures, arrows).

use crate::render::texture::canvas::Canvas;
use crate::render::texture::color::{INK, PALETTE, Rgb, ink_on, pick, rng_for, scale, tint};
use crate::render::texture::glyphs::{random_word, text, text_lines, text_width};
use crate::render::texture::noise::hash_signed;
use crate::render::texture::{SIGN_SIZE_M, Texture};
use crate::world::Material;
use rand::Rng;

/// What a sign shows, from its plate colour and seed.
#[derive(Clone, Copy, Debug, PartialEq)]
enum SignKind {
    Exit,
    Fire,
    Info,
    Plate,
}

fn sign_kind<R: Rng>(c: Rgb, rng: &mut R) -> SignKind {
    let max = c[0].max(c[1]).max(c[2]);
    let min = c[0].min(c[1]).min(c[2]);
    if max - min > 0.2 && c[1] >= max && c[1] > c[0] * 1.2 {
        SignKind::Exit
    } else if c[0] > 0.55 && c[0] > 2.5 * c[1] && c[0] > 2.5 * c[2] {
        SignKind::Fire
    } else if rng.random_bool(0.7) {
        SignKind::Plate
    } else {
        SignKind::Info
    }
}

/// A running figure in the box `[x, y, s × s]`, mirrored when `left`.
fn running_figure(c: &mut Canvas, x: f32, y: f32, s: f32, left: bool, col: Rgb) {
    let p = |px: f32, py: f32| [x + s * if left { 1.0 - px } else { px }, y + s * py];
    c.circle(p(0.62, 0.12)[0], p(0.62, 0.12)[1], s * 0.09, col);
    let r = s * 0.055;
    c.capsule(p(0.56, 0.3), p(0.44, 0.58), r * 1.2, col);
    c.stroke(&[p(0.55, 0.33), p(0.72, 0.45), p(0.86, 0.36)], r, col);
    c.stroke(&[p(0.53, 0.32), p(0.36, 0.4), p(0.24, 0.3)], r, col);
    c.stroke(&[p(0.44, 0.58), p(0.62, 0.74), p(0.6, 0.95)], r, col);
    c.stroke(&[p(0.44, 0.58), p(0.3, 0.78), p(0.1, 0.82)], r, col);
}

/// An arrow from `a` to `b` with line radius `r`.
fn arrow(c: &mut Canvas, a: [f32; 2], b: [f32; 2], r: f32, col: Rgb) {
    let (dx, dy) = (b[0] - a[0], b[1] - a[1]);
    let len = dx.hypot(dy).max(1e-6);
    let (ux, uy) = (dx / len, dy / len);
    let hl = len * 0.4;
    c.capsule(a, b, r, col);
    c.capsule(b, [b[0] - hl * (ux - uy), b[1] - hl * (uy + ux)], r, col);
    c.capsule(b, [b[0] - hl * (ux + uy), b[1] - hl * (uy - ux)], r, col);
}

/// A standing figure (toilet sign): `skirt` gives the dress.
fn standing_figure(c: &mut Canvas, x: f32, y: f32, s: f32, skirt: bool, col: Rgb) {
    c.circle(x, y + s * 0.1, s * 0.09, col);
    if skirt {
        c.paint(
            [x - s * 0.2, y + s * 0.2, x + s * 0.2, y + s * 0.65],
            |px, py| {
                let f = ((py - y - s * 0.22) / (s * 0.42)).clamp(0.0, 1.0);
                let half = s * (0.07 + 0.12 * f);
                (
                    col,
                    ((px - x).abs() - half).max((py - y - s * 0.43).abs() - s * 0.22),
                )
            },
        );
    } else {
        c.rect(
            x - s * 0.1,
            y + s * 0.22,
            x + s * 0.1,
            y + s * 0.62,
            col,
            1.0,
        );
    }
    c.capsule(
        [x - s * 0.05, y + s * 0.6],
        [x - s * 0.05, y + s * 0.95],
        s * 0.045,
        col,
    );
    c.capsule(
        [x + s * 0.05, y + s * 0.6],
        [x + s * 0.05, y + s * 0.95],
        s * 0.045,
        col,
    );
}

pub(crate) fn sign(m: &Material) -> Texture {
    let t = tint(m);
    let mut rng = rng_for(m, 11);
    let [w, h] = SIGN_SIZE_M;
    let mut c = Canvas::new(128, 64, SIGN_SIZE_M, t);
    let ink = ink_on(t);
    let grain = rng.random::<u64>();
    c.fill(|xm, ym, x, y| {
        // A faint sheen across the plate.
        let g =
            1.0 + 0.04 * (1.0 - (xm / w + ym / h)) + 0.01 * hash_signed(grain, x as i64, y as i64);
        scale(t, g)
    });
    c.frame(0.0, 0.0, w, h, 0.004, scale(t, 0.75));
    if rng.random_bool(0.5) {
        c.frame(0.012, 0.012, w - 0.012, h - 0.012, 0.004, ink);
    }
    let s = h * 0.7;
    let (gy, lw) = ((h - s) / 2.0, s * 0.06);
    match sign_kind(t, &mut rng) {
        SignKind::Exit => {
            let left = rng.random_bool(0.5);
            let (fx, ax0, ax1) = if left {
                (w - 0.03 - s, 0.15, 0.04)
            } else {
                (0.03, w - 0.15, w - 0.04)
            };
            // Door frame behind the figure, then the figure, then the arrow.
            let dx = if left { fx } else { fx + s * 0.45 };
            c.frame(dx, gy, dx + s * 0.55, gy + s, lw, ink);
            running_figure(&mut c, fx, gy, s, left, ink);
            arrow(&mut c, [ax0, h / 2.0], [ax1, h / 2.0], lw * 1.2, ink);
        }
        SignKind::Fire => {
            let x = 0.05 + rng.random_range(0.0f32..0.05);
            c.capsule([x, gy + s * 0.35], [x, gy + s * 0.92], s * 0.13, ink);
            c.rect(
                x - s * 0.05,
                gy + s * 0.1,
                x + s * 0.05,
                gy + s * 0.22,
                ink,
                1.0,
            );
            c.stroke(
                &[
                    [x + s * 0.05, gy + s * 0.14],
                    [x + s * 0.3, gy + s * 0.2],
                    [x + s * 0.32, gy + s * 0.6],
                ],
                lw,
                ink,
            );
            if rng.random_bool(0.5) {
                arrow(
                    &mut c,
                    [w - 0.14, h / 2.0],
                    [w - 0.04, h / 2.0],
                    lw * 1.2,
                    ink,
                );
            } else {
                text_lines(
                    &mut c,
                    &mut rng,
                    [0.16, gy + 0.01, w - 0.03, gy + s],
                    0.012,
                    ink,
                );
            }
        }
        SignKind::Info => match rng.random_range(0..3u32) {
            0 => {
                let (cx, cy, r) = (0.03 + s / 2.0, h / 2.0, s / 2.0);
                c.circle(cx, cy, r, ink);
                c.circle(cx, cy, r * 0.82, t);
                c.circle(cx, cy - r * 0.45, r * 0.12, ink);
                c.capsule([cx, cy - r * 0.15], [cx, cy + r * 0.5], r * 0.11, ink);
                text_lines(
                    &mut c,
                    &mut rng,
                    [0.05 + s, gy + 0.015, w - 0.03, gy + s],
                    0.012,
                    ink,
                );
            }
            1 => {
                standing_figure(&mut c, w * 0.3, gy, s, false, ink);
                c.rect(w * 0.5 - lw / 2.0, gy, w * 0.5 + lw / 2.0, gy + s, ink, 1.0);
                standing_figure(&mut c, w * 0.7, gy, s, true, ink);
            }
            _ => {
                let left = rng.random_bool(0.5);
                let (a, b) = if left { (0.13, 0.03) } else { (0.03, 0.13) };
                arrow(&mut c, [a, h / 2.0], [b, h / 2.0], lw * 1.2, ink);
                let n = rng.random_range(3..6usize);
                let word = random_word(&mut rng, n);
                let cw = ((w - 0.2) / text_width(n, 1.0)).min(0.012);
                text(
                    &mut c,
                    [0.17, h / 2.0 - cw * 2.6],
                    [cw, cw * 1.05],
                    &word,
                    ink,
                );
            }
        },
        SignKind::Plate => {
            // A room number such as "B2.14", with the room's name in small letters below.
            let mut num = vec![b'A' + rng.random_range(0..3u8)];
            num.push(b'0' + rng.random_range(0..4u8));
            num.push(b'.');
            num.push(b'0' + rng.random_range(0..3u8));
            num.push(b'0' + rng.random_range(0..10u8));
            if rng.random_bool(0.3) {
                num.remove(0);
            }
            let stripe = rng.random_bool(0.5);
            let x0 = if stripe {
                let sc = pick(&mut rng, &PALETTE[..8], INK);
                c.rect(0.004, 0.004, 0.035, h - 0.004, sc, 1.0);
                0.05
            } else {
                0.025
            };
            let cw = 0.014;
            text(&mut c, [x0, 0.035], [cw, cw * 1.2], &num, ink);
            let n = rng.random_range(5..10usize);
            let name = random_word(&mut rng, n);
            text(
                &mut c,
                [x0, 0.035 + cw * 6.0 + 0.015],
                [0.006, 0.0065],
                &name,
                ink,
            );
        }
    }
    c.into_texture()
}
