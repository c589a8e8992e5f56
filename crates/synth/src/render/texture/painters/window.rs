//! Windows: a view of sky, clouds, buildings and trees, scaled so that its mean colour is the
//! tint, behind a glass reflection and an aluminium, white or anthracite frame.

use crate::render::texture::canvas::Canvas;
use crate::render::texture::color::{WHITE, mix, mul, pick, rng_for, scale, tint};
use crate::render::texture::noise::{GradientNoise, at, smoothstep};
use crate::render::texture::{Texture, WINDOW_SIZE_M};
use crate::world::Material;
use rand::Rng;

pub(crate) fn window(m: &Material) -> Texture {
    let t = tint(m);
    let mut rng = rng_for(m, 12);
    let [w, h] = WINDOW_SIZE_M;
    let mut c = Canvas::new(128, 128, WINDOW_SIZE_M, WHITE);
    let clouds = GradientNoise::new(rng.random(), 3, 2).grid(c.w, c.h);
    let clouds2 = GradientNoise::new(rng.random(), 8, 6).grid(c.w, c.h);
    let cw = c.w;
    let cloudy = rng.random_range(0.0f32..0.8);
    let zenith = mix(
        [0.32, 0.55, 0.86],
        [0.55, 0.62, 0.72],
        rng.random_range(0.0f32..0.5),
    );
    let horizon_c = [0.84, 0.89, 0.94];
    let horizon = h * rng.random_range(0.6f32..0.8);
    c.fill(|_, ym, x, y| {
        let f = (ym / horizon).clamp(0.0, 1.0);
        let sky = mix(zenith, horizon_c, f.powf(1.4));
        let n = at(&clouds, y * cw + x) + 0.4 * at(&clouds2, y * cw + x);
        let cl = smoothstep(0.6 - cloudy, 1.0 - cloudy * 0.6, n) * (1.0 - f * 0.5);
        mix(sky, [0.95, 0.95, 0.96], cl)
    });
    // Outside: ground, buildings and trees along the horizon.
    c.rect(0.0, horizon, w, h, [0.5, 0.52, 0.5], 1.0);
    let mut x = -0.1;
    while x < w {
        let bw = rng.random_range(0.15f32..0.5);
        if rng.random_bool(0.7) {
            let top = horizon - rng.random_range(0.08f32..0.5);
            let facade = scale([0.78, 0.76, 0.72], rng.random_range(0.7f32..1.05));
            c.rect(x, top, x + bw, horizon, facade, 1.0);
            let glass = mix(facade, [0.25, 0.32, 0.4], 0.7);
            let mut wy = top + 0.025;
            while wy + 0.03 < horizon {
                let mut wx = x + 0.02;
                while wx + 0.03 < x + bw {
                    c.rect(wx, wy, wx + 0.035, wy + 0.03, glass, 1.0);
                    wx += 0.06;
                }
                wy += 0.06;
            }
        }
        x += bw + rng.random_range(0.0f32..0.1);
    }
    let trees = rng.random_range(0..6);
    for _ in 0..trees {
        let tx = rng.random_range(0.0..w);
        let r = rng.random_range(0.05f32..0.13);
        let green = scale([0.25, 0.4, 0.2], rng.random_range(0.75f32..1.15));
        c.rect(
            tx - 0.01,
            horizon - r,
            tx + 0.01,
            horizon + 0.02,
            [0.3, 0.22, 0.15],
            1.0,
        );
        c.circle(tx, horizon - r * 1.3, r, green);
        c.circle(tx + r * 0.5, horizon - r * 1.0, r * 0.7, scale(green, 0.9));
    }
    // Glass: a faint reflection band.
    let band = rng.random_range(0.2f32..0.6);
    c.fill_blend(|xm, ym| {
        let d = (xm / w + 0.6 * ym / h - band).abs();
        ([1.0; 3], 0.12 * smoothstep(0.12, 0.0, d))
    });
    // The glass takes the tint: scale the view so its mean colour is the tint.
    let n = c.px.len().max(1) as f32;
    let mean =
        c.px.iter()
            .fold([0.0f32; 3], |a, p| [a[0] + p[0], a[1] + p[1], a[2] + p[2]])
            .map(|x| (x / n).max(1e-3));
    let gain = [t[0] / mean[0], t[1] / mean[1], t[2] / mean[2]];
    for p in &mut c.px {
        *p = mul(*p, gain);
    }
    // Frame, mullions and transom, with light and shadow edges.
    let frame = pick(
        &mut rng,
        &[[0.74, 0.75, 0.77], [0.92, 0.92, 0.9], [0.26, 0.27, 0.29]],
        [0.74, 0.75, 0.77],
    );
    let fw = 0.05;
    let mut bars: Vec<[f32; 4]> = vec![
        [0.0, 0.0, w, fw],
        [0.0, h - fw, w, h],
        [0.0, 0.0, fw, h],
        [w - fw, 0.0, w, h],
    ];
    let mullions = rng.random_range(0..3usize);
    for i in 0..mullions {
        let mx = w * (i + 1) as f32 / (mullions + 1) as f32;
        bars.push([mx - fw * 0.4, 0.0, mx + fw * 0.4, h]);
    }
    if rng.random_bool(0.5) {
        let ty = h * rng.random_range(0.25f32..0.4);
        bars.push([0.0, ty - fw * 0.4, w, ty + fw * 0.4]);
    }
    for &[a, b, cc, d] in &bars {
        c.rect(a, b, cc, d, frame, 1.0);
    }
    let lw = 0.01;
    for &[a, b, cc, d] in &bars {
        c.rect(a, d - lw, cc, d, scale(frame, 0.72), 1.0);
        c.rect(cc - lw, b, cc, d, scale(frame, 0.8), 1.0);
    }
    c.into_texture()
}
