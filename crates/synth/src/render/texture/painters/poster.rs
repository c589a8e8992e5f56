//! Posters: a white border around the tinted background, one of five layouts of picture
//! blocks, bands, discs, block-letter titles and small print, and sometimes a logo.

use crate::render::texture::canvas::Canvas;
use crate::render::texture::color::{Rgb, WHITE, contrasting, ink_on, rng_for, tint};
use crate::render::texture::glyphs::{random_word, text, text_lines, text_width};
use crate::render::texture::{POSTER_SIZE_M, Texture};
use crate::world::Material;
use rand::Rng;

pub(crate) fn poster(m: &Material) -> Texture {
    let t = tint(m);
    let mut rng = rng_for(m, 9);
    let [pw, ph] = POSTER_SIZE_M;
    let mut c = Canvas::new(128, 256, POSTER_SIZE_M, WHITE);
    let margin = rng.random_range(0.018f32..0.04);
    let (x0, y0, x1, y1) = (margin, margin, pw - margin, ph - margin);
    let (w, h) = (x1 - x0, y1 - y0);
    let bg = t;
    c.rect(x0, y0, x1, y1, bg, 1.0);
    let accent = contrasting(&mut rng, bg);
    let accent2 = contrasting(&mut rng, accent);
    let ink = ink_on(bg);
    let layout = rng.random_range(0..5u32);
    let title_len = rng.random_range(4..9usize);
    let title = random_word(&mut rng, title_len);
    // Title: block letters as large as fit the width.
    let fit_title = |c: &mut Canvas, y: f32, max_h: f32, color: Rgb| {
        let cw = (w * 0.86 / (4 * title.len()) as f32).min(max_h / 5.0);
        let tw = text_width(title.len(), cw);
        text(c, [x0 + (w - tw) / 2.0, y], [cw, cw * 1.15], &title, color);
        cw * 1.15 * 5.0
    };
    match layout {
        0 => {
            // A picture block on top, a title band under it, text at the bottom.
            let ib = y0 + h * rng.random_range(0.45f32..0.6);
            c.rect(x0, y0, x1, ib, accent, 1.0);
            for _ in 0..rng.random_range(2..5) {
                let col = contrasting(&mut rng, accent);
                let (cx, cy) = (
                    x0 + w * rng.random_range(0.1f32..0.9),
                    y0 + (ib - y0) * rng.random_range(0.15f32..0.85),
                );
                let r = w * rng.random_range(0.08f32..0.3);
                if rng.random_bool(0.5) {
                    c.circle(cx, cy, r, col);
                } else {
                    c.rect(
                        (cx - r).max(x0),
                        (cy - r * 0.7).max(y0),
                        (cx + r).min(x1),
                        (cy + r * 0.7).min(ib),
                        col,
                        1.0,
                    );
                }
            }
            let bh = h * 0.1;
            c.rect(x0, ib, x1, ib + bh, accent2, 1.0);
            fit_title(&mut c, ib + bh * 0.2, bh * 0.6, ink_on(accent2));
            text_lines(
                &mut c,
                &mut rng,
                [x0 + 0.03, ib + bh + 0.03, x1 - 0.03, y1 - 0.04],
                0.007,
                ink,
            );
        }
        1 => {
            // Title band on top, a big disc, text under it.
            let bh = h * rng.random_range(0.1f32..0.16);
            c.rect(x0, y0, x1, y0 + bh, accent, 1.0);
            fit_title(&mut c, y0 + bh * 0.2, bh * 0.6, ink_on(accent));
            let r = w * rng.random_range(0.25f32..0.4);
            let cy = y0 + bh + 0.03 + r;
            c.circle(x0 + w / 2.0, cy, r, accent2);
            c.circle(x0 + w / 2.0, cy, r * 0.45, contrasting(&mut rng, accent2));
            text_lines(
                &mut c,
                &mut rng,
                [x0 + 0.04, cy + r + 0.04, x1 - 0.04, y1 - 0.03],
                0.007,
                ink,
            );
        }
        2 => {
            // Vertical bands of colour, title low down.
            let bands = rng.random_range(2..5usize);
            let mut prev = bg;
            for i in 0..bands {
                let col = contrasting(&mut rng, prev);
                prev = col;
                let bx = x0 + w * (i as f32 + 0.5) / bands as f32;
                c.rect(bx, y0, bx + w / bands as f32 * 0.5, y0 + h * 0.6, col, 1.0);
            }
            let ty = y0 + h * 0.64;
            let th = fit_title(&mut c, ty, h * 0.1, ink);
            text_lines(
                &mut c,
                &mut rng,
                [x0 + 0.03, ty + th + 0.03, x1 - 0.03, y1 - 0.03],
                0.006,
                ink,
            );
        }
        3 => {
            // Title band and a grid of coloured blocks with captions.
            let bh = h * 0.12;
            c.rect(x0, y0, x1, y0 + bh, accent, 1.0);
            fit_title(&mut c, y0 + bh * 0.2, bh * 0.6, ink_on(accent));
            let (gc, gr) = (2usize, rng.random_range(2..4usize));
            let gy0 = y0 + bh + 0.03;
            let cell_w = (w - 0.06) / gc as f32;
            let cell_h = (y1 - 0.03 - gy0) / gr as f32;
            for r in 0..gr {
                for k in 0..gc {
                    let cx = x0 + 0.03 + k as f32 * cell_w;
                    let cy = gy0 + r as f32 * cell_h;
                    let col = contrasting(&mut rng, bg);
                    c.rect(
                        cx + 0.01,
                        cy,
                        cx + cell_w - 0.01,
                        cy + cell_h * 0.6,
                        col,
                        1.0,
                    );
                    text_lines(
                        &mut c,
                        &mut rng,
                        [
                            cx + 0.01,
                            cy + cell_h * 0.66,
                            cx + cell_w - 0.01,
                            cy + cell_h - 0.01,
                        ],
                        0.006,
                        ink,
                    );
                }
            }
        }
        _ => {
            // Typographic: two or three huge letters, a rule, text.
            let n = rng.random_range(2..4usize);
            let big = random_word(&mut rng, n);
            let cw = w * 0.8 / (4 * big.len()) as f32;
            let bx = x0 + (w - text_width(big.len(), cw)) / 2.0;
            text(&mut c, [bx, y0 + 0.05], [cw, cw * 1.4], &big, accent);
            let ry = y0 + 0.05 + cw * 7.0 + 0.03;
            c.rect(x0 + 0.04, ry, x1 - 0.04, ry + 0.012, accent2, 1.0);
            let th = fit_title(&mut c, ry + 0.04, h * 0.06, ink);
            text_lines(
                &mut c,
                &mut rng,
                [x0 + 0.04, ry + 0.08 + th, x1 - 0.04, y1 - 0.03],
                0.006,
                ink,
            );
        }
    }
    // A logo in a corner.
    if rng.random_bool(0.6) {
        let r = 0.025;
        let (lx, ly) = (x1 - 0.03 - r, y1 - 0.03 - r);
        c.circle(lx, ly, r, accent2);
        c.circle(lx, ly, r * 0.5, bg);
    }
    c.into_texture()
}
