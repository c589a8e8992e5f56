//! Notice boards: speckled cork in a frame, with pinned sheets and notes of small print, each
//! a little askew and casting a shadow.

use crate::render::texture::canvas::Canvas;
use crate::render::texture::color::{INK, PALETTE, PAPERS, WHITE, mix, pick, rng_for, scale, tint};
use crate::render::texture::noise::{Fbm, at, hash_unit, hash2};
use crate::render::texture::{NOTICE_BOARD_SIZE_M, Texture};
use crate::world::Material;
use rand::Rng;

pub(crate) fn notice_board(m: &Material) -> Texture {
    let t = tint(m);
    let mut rng = rng_for(m, 10);
    let [bw, bh] = NOTICE_BOARD_SIZE_M;
    let mut c = Canvas::new(256, 128, NOTICE_BOARD_SIZE_M, t);
    let cork_seed = rng.random::<u64>();
    let cork_fbm = Fbm::new(rng.random(), 6, 4, 3).grid(c.w, c.h);
    let cw = c.w;
    c.fill(|_, _, x, y| {
        let h = hash_unit(cork_seed, x as i64, y as i64);
        let speck = if h < 0.08 { 0.72 } else { 1.0 };
        scale(
            t,
            (0.92 + 0.16 * hash_unit(cork_seed ^ 1, x as i64, y as i64))
                * speck
                * (1.0 + 0.06 * at(&cork_fbm, y * cw + x)),
        )
    });
    let fw = 0.028;
    let frame_c = if rng.random_bool(0.6) {
        [0.74, 0.75, 0.77]
    } else {
        [0.42, 0.28, 0.17]
    };
    // Sheets, with their shadows and pins.
    let sheets = rng.random_range(4..10usize);
    for k in 0..sheets {
        let kind = rng.random_range(0..20u32);
        let (sw, sh) = match kind {
            0..=11 => (0.21, 0.297),
            12..=14 => (0.297, 0.21),
            15..=17 => (0.148, 0.21),
            _ => (0.076, 0.076),
        };
        let paper = if kind >= 18 {
            pick(&mut rng, &PAPERS, WHITE)
        } else if rng.random_bool(0.7) {
            WHITE
        } else {
            pick(&mut rng, &PAPERS, WHITE)
        };
        let cx = rng.random_range(fw + sw * 0.4..bw - fw - sw * 0.4);
        let cy = rng.random_range(fw + sh * 0.4..bh - fw - sh * 0.4);
        let ang = rng.random_range(-0.07f32..0.07);
        let (sin, cos) = ang.sin_cos();
        let r = 0.5 * sw.hypot(sh);
        let bbox = [cx - r, cy - r, cx + r + 0.01, cy + r + 0.01];
        let sheet_seed = hash2(rng.random(), k as i64, 0);
        let shadow = scale(t, 0.55);
        let header = rng.random_range(0..3u32);
        let header_c = pick(&mut rng, &PALETTE, INK);
        let picture = kind < 15 && rng.random_bool(0.3);
        let pic_c = pick(&mut rng, &PALETTE, INK);
        // Local sheet coordinates (from its top-left corner) and distance outside it.
        let local = move |x: f32, y: f32| {
            let (dx, dy) = (x - cx, y - cy);
            let (lx, ly) = (cos * dx + sin * dy, -sin * dx + cos * dy);
            let d = (lx.abs() - sw / 2.0).max(ly.abs() - sh / 2.0);
            (lx + sw / 2.0, ly + sh / 2.0, d)
        };
        c.paint(bbox, |x, y| {
            let (_, _, d) = local(x - 0.004, y - 0.006);
            (shadow, d)
        });
        c.paint(bbox, |x, y| {
            let (lx, ly, d) = local(x, y);
            let mut col = paper;
            let pitch = 0.016;
            let top = if header == 0 { 0.05 } else { 0.03 };
            let m = 0.018;
            if header == 0 && ly > 0.012 && ly < 0.035 && lx > m && lx < sw - m {
                col = header_c;
            } else if picture && ly > 0.05 && ly < 0.13 && lx > m && lx < sw - m {
                col = pic_c;
            } else if ly > top + if picture { 0.1 } else { 0.0 }
                && ly < sh - m
                && lx > m
                && lx < sw - m
            {
                let li = ((ly - top) / pitch).floor();
                let f = (ly - top) / pitch - li;
                let word = ((lx - m) / 0.022).floor();
                let ink = hash_unit(sheet_seed, word as i64, li as i64) > 0.22;
                if f < 0.45 && ink {
                    col = mix(paper, INK, 0.75);
                }
            }
            (col, d)
        });
        let pin = pick(&mut rng, &PALETTE, INK);
        let (px, py) = (cx - sin * (sh / 2.0 - 0.012), cy - cos * (sh / 2.0 - 0.012));
        c.circle(px + 0.002, py + 0.003, 0.007, scale(t, 0.5));
        c.circle(px, py, 0.007, pin);
    }
    c.frame(0.0, 0.0, bw, bh, fw, frame_c);
    c.frame(fw, fw, bw - fw, bh - fw, 0.004, scale(frame_c, 0.7));
    c.into_texture()
}
