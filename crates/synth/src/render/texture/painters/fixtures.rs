//! Ceiling fittings: light panels (prismatic, louvred or opal diffusers in a frame; linear
//! fittings take the same texture stretched) and vents (slatted grilles).

use crate::render::texture::canvas::Canvas;
use crate::render::texture::color::{rng_for, scale, tint};
use crate::render::texture::noise::hash_signed;
use crate::render::texture::{LIGHT_PANEL_SIZE_M, Texture, VENT_SIZE_M};
use crate::world::Material;
use rand::Rng;

pub(crate) fn light_panel(m: &Material) -> Texture {
    let t = tint(m);
    let mut rng = rng_for(m, 13);
    let [w, h] = LIGHT_PANEL_SIZE_M;
    let mut c = Canvas::new(128, 128, LIGHT_PANEL_SIZE_M, t);
    let style = rng.random_range(0..3u32);
    let cells = [8usize, 10, 12, 4][rng.random_range(0..4usize)];
    let fw = 0.022;
    let (iw, ih) = (w - 2.0 * fw, h - 2.0 * fw);
    let grid = rng.random::<u64>();
    c.fill(|xm, ym, x, y| {
        let (s, u) = ((xm - fw) / iw, (ym - fw) / ih);
        let r = (2.0 * s - 1.0).abs().max((2.0 * u - 1.0).abs());
        let mut k = 1.0 - 0.07 * r * r;
        let (cs, cu) = (s * cells as f32, u * cells as f32);
        let (fs, fu) = (cs - cs.floor(), cu - cu.floor());
        let line = |f: f32, n: f32| f < 0.08 * n || f > 1.0 - 0.08 * n;
        match style {
            // Prismatic diffuser: a fine grid.
            0 => {
                if line(fs, 0.8) || line(fu, 0.8) {
                    k *= 0.86;
                }
                k *= 1.0 + 0.015 * hash_signed(grid, x as i64, y as i64);
            }
            // Louvre: bright cells shading to the grid.
            1 => {
                let cell = (1.0 - (2.0 * fs - 1.0).powi(2)) * (1.0 - (2.0 * fu - 1.0).powi(2));
                k *= 0.8 + 0.2 * cell.sqrt();
            }
            // Opal diffuser with a coarse grid.
            _ => {
                if line(s * 2.0 - (s * 2.0).floor(), 0.25)
                    || line(u * 2.0 - (u * 2.0).floor(), 0.25)
                {
                    k *= 0.9;
                }
            }
        }
        scale(t, k)
    });
    c.frame(0.0, 0.0, w, h, fw, scale(t, 0.8));
    c.frame(
        fw - 0.005,
        fw - 0.005,
        w - fw + 0.005,
        h - fw + 0.005,
        0.005,
        scale(t, 0.66),
    );
    c.into_texture()
}

pub(crate) fn vent(m: &Material) -> Texture {
    let t = tint(m);
    let mut rng = rng_for(m, 14);
    let [w, h] = VENT_SIZE_M;
    let n = 64usize;
    let mut c = Canvas::new(n, n, VENT_SIZE_M, t);
    let slats = rng.random_range(8..13) as f32;
    let face = rng.random_range(0.45f32..0.65);
    let fw = 0.04;
    let ih = h - 2.0 * fw;
    let sy = c.sy;
    c.fill(|xm, ym, _, _| {
        if xm < fw || xm > w - fw || ym < fw || ym > h - fw {
            return t;
        }
        // Four samples down the texel: slat faces shade from lit to dark, gaps are dark.
        let mut k = 0.0;
        for i in 0..4 {
            let y = ym + (i as f32 - 1.5) / (4.0 * sy);
            let p = ((y - fw) / ih * slats).rem_euclid(1.0);
            k += if p < face { 1.0 - 0.3 * p / face } else { 0.22 };
        }
        scale(t, k / 4.0)
    });
    c.frame(0.0, 0.0, w, h, 0.006, scale(t, 0.82));
    c.frame(
        fw - 0.006,
        fw - 0.006,
        w - fw + 0.006,
        h - fw + 0.006,
        0.006,
        scale(t, 0.6),
    );
    c.into_texture()
}
