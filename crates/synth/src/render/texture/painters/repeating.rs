//! The repeating surfaces: paint, ceiling and floor tiles, carpet, wood, concrete, brickwork,
//! brushed metal and woven fabric. Each is a texture with a fixed physical repeat, modulated
//! around the material's tint and baked texel by texel.

use crate::render::texture::color::{
    PALETTE, from_fn, luminance, mix, mul, pick, rng_for, scale, tint,
};
use crate::render::texture::noise::{
    Fbm, GradientNoise, ValueNoise, at, hash_signed, hash_unit, hash2, smoothstep,
};
use crate::render::texture::{
    BRICK_REPEAT_M, CARPET_REPEAT_M, CONCRETE_REPEAT_M, FABRIC_REPEAT_M, METAL_REPEAT_M,
    PAINT_REPEAT_M, TILES_PER_REPEAT, Texture, WOOD_REPEAT_M,
};
use crate::world::Material;
use rand::Rng;

pub(crate) fn plain(m: &Material) -> Texture {
    let t = tint(m);
    let mut rng = rng_for(m, 1);
    let n = 64;
    let mottle = Fbm::new(rng.random(), 3, 3, 3).grid(n, n);
    let fine = rng.random::<u64>();
    from_fn(n, n, [PAINT_REPEAT_M; 2], |x, y| {
        let i = y * n + x;
        let k = 1.0 + 0.03 * at(&mottle, i) + 0.01 * hash_signed(fine, x as i64, y as i64);
        scale(t, k)
    })
}

pub(crate) fn tiles(m: &Material, size: f32) -> Texture {
    let size = if size.is_finite() {
        size.clamp(0.02, 20.0)
    } else {
        0.6
    };
    let t = tint(m);
    let mut rng = rng_for(m, 2);
    let per = TILES_PER_REPEAT as usize;
    let tp = 64usize; // texels per tile
    let n = per * tp;
    let ceiling = luminance(t) > 0.7;
    let bright: Vec<f32> = (0..per * per)
        .map(|_| 1.0 + rng.random_range(-1.0f32..1.0) * if ceiling { 0.025 } else { 0.05 })
        .collect();
    let warm: Vec<f32> = (0..per * per)
        .map(|_| rng.random_range(-1.0f32..1.0) * if ceiling { 0.0 } else { 0.02 })
        .collect();
    // Mottling is smooth: bake it at half resolution.
    let mottle = Fbm::new(rng.random(), 4, 4, 4).grid(n / 2, n / 2);
    let fissure_noise = ValueNoise::new(rng.random(), 6 * per, 6 * per);
    let fissure = if ceiling {
        fissure_noise.grid(n, n)
    } else {
        Vec::new()
    };
    let speck = rng.random::<u64>();
    // Joint half-width in texels: a 24 mm T-bar grid on ceilings, 3 mm grout on floors.
    let half = if ceiling {
        (0.012 / size * tp as f32).clamp(0.8, 4.0)
    } else {
        (0.0015 / size * tp as f32).clamp(0.5, 2.0)
    };
    let grout = if ceiling {
        scale(t, 0.93)
    } else {
        mix(scale(t, 0.5), [0.35, 0.34, 0.32], 0.5)
    };
    from_fn(n, n, [size * per as f32; 2], |x, y| {
        let i = y * n + x;
        let mottle = at(&mottle, (y / 2) * (n / 2) + x / 2);
        let (tx, ty) = (x / tp, y / tp);
        let (lx, ly) = ((x % tp) as f32 + 0.5, (y % tp) as f32 + 0.5);
        let d = lx.min(tp as f32 - lx).min(ly.min(tp as f32 - ly));
        let b = bright.get(ty * per + tx).copied().unwrap_or(1.0);
        let w = warm.get(ty * per + tx).copied().unwrap_or(0.0);
        let hash = hash2(speck, x as i64, y as i64);
        let white = (hash >> 40) as f32 / (1u64 << 23) as f32 - 1.0;
        let mut tile = if ceiling {
            let h = (hash & 0xFF_FFFF) as f32 / (1u64 << 24) as f32;
            let pin = if h < 0.12 { 0.80 + h } else { 1.0 };
            let f = at(&fissure, i).abs();
            let fis = if f < 0.06 { 0.93 } else { 1.0 };
            scale(t, b * (1.0 + 0.02 * mottle + 0.015 * white) * pin * fis)
        } else {
            let k = b * (1.0 + 0.05 * mottle + 0.02 * white);
            [t[0] * k * (1.0 + w), t[1] * k, t[2] * k * (1.0 - w)]
        };
        // The tile's edge: recessed (ceiling) or bevelled (floor), a little darker.
        if d >= half + 2.0 {
            return tile;
        }
        let edge = smoothstep(half + 2.0, half, d);
        tile = scale(tile, 1.0 - edge * if ceiling { 0.18 } else { 0.08 });
        let g = (half + 0.5 - d).clamp(0.0, 1.0);
        mix(tile, grout, g)
    })
}

pub(crate) fn carpet(m: &Material) -> Texture {
    let t = tint(m);
    let mut rng = rng_for(m, 3);
    let n = 128usize;
    let half = n / 2;
    let along = ValueNoise::new(rng.random(), 8, 96).grid(n, n);
    let across = ValueNoise::new(rng.random(), 96, 8).grid(n, n);
    let mottle = Fbm::new(rng.random(), 4, 4, 3).grid(n, n);
    let yarn = rng.random::<u64>();
    let tile_b: [f32; 4] = std::array::from_fn(|_| 1.0 + rng.random_range(-0.03f32..0.03));
    // A faint pattern: pin stripes, a small grid of dots, or plain heather.
    let style = rng.random_range(0..3u32);
    let pitch = rng.random_range(5..9usize);
    let fleck = mix(t, pick(&mut rng, &PALETTE, t), 0.35);
    let dark = mul(t, [0.72, 0.74, 0.8]);
    let light = mix(t, [1.0; 3], 0.15);
    from_fn(n, n, [CARPET_REPEAT_M; 2], |x, y| {
        let i = y * n + x;
        let (tx, ty) = (x / half, y / half);
        // Quarter-turned carpet tiles: the pile runs along u or v alternately.
        let pile = if (tx + ty) % 2 == 0 {
            at(&along, i)
        } else {
            at(&across, i)
        };
        let h = hash_unit(yarn, x as i64, y as i64);
        let mut c = if h < 0.18 {
            dark
        } else if h > 0.9 {
            light
        } else {
            t
        };
        if hash_unit(yarn ^ 0x77, x as i64, y as i64) < 0.03 {
            c = fleck;
        }
        let (lx, ly) = (x % half, y % half);
        let pattern = match style {
            0 if lx % pitch == 0 => 0.94,
            1 if lx % pitch == 0 && ly % pitch == 0 => 0.9,
            _ => 1.0,
        };
        let seam = if lx == 0 || ly == 0 { 0.93 } else { 1.0 };
        let k = tile_b[(ty * 2 + tx) % 4] * (1.0 + 0.05 * pile + 0.04 * at(&mottle, i));
        scale(c, k * pattern * seam)
    })
}

pub(crate) fn wood(m: &Material) -> Texture {
    let t = tint(m);
    let mut rng = rng_for(m, 4);
    let (w, h) = (64usize, 256usize);
    let rings = rng.random_range(9..18) as f32;
    let warp = GradientNoise::new(rng.random(), 2, 3).grid(w, h);
    let warp2 = GradientNoise::new(rng.random(), 4, 12).grid(w, h);
    let pores = ValueNoise::new(rng.random(), 16, 256).grid(w, h);
    let fine = rng.random::<u64>();
    let late = mul(t, [0.62, 0.54, 0.48]);
    from_fn(w, h, WOOD_REPEAT_M, |x, y| {
        let i = y * w + x;
        let v = (y as f32 + 0.5) / h as f32;
        let phase = v * rings + 1.6 * at(&warp, i) + 0.25 * at(&warp2, i);
        let ring = phase - phase.floor();
        let dark = smoothstep(0.5, 0.88, ring) * (1.0 - smoothstep(0.9, 1.0, ring));
        let c = mix(t, late, 0.6 * dark);
        scale(
            c,
            1.0 + 0.06 * at(&pores, i) + 0.025 * hash_signed(fine, x as i64, y as i64),
        )
    })
}

pub(crate) fn concrete(m: &Material) -> Texture {
    let t = tint(m);
    let mut rng = rng_for(m, 5);
    let n = 128usize;
    let blotch = Fbm::new(rng.random(), 4, 4, 5).grid(n, n);
    let stain = Fbm::new(rng.random(), 3, 3, 3).grid(n, n);
    let hue = ValueNoise::new(rng.random(), 3, 3).grid(n, n);
    let pore = rng.random::<u64>();
    from_fn(n, n, [CONCRETE_REPEAT_M; 2], |x, y| {
        let i = y * n + x;
        let h = hash_unit(pore, x as i64, y as i64);
        let p = if h < 0.015 { 0.72 } else { 1.0 };
        let k = (1.0 + 0.09 * at(&blotch, i) - 0.08 * smoothstep(0.2, 0.6, at(&stain, i))
            + 0.04 * (h * 2.0 - 1.0))
            * p;
        let w = 0.02 * at(&hue, i);
        [t[0] * k * (1.0 + w), t[1] * k, t[2] * k * (1.0 - w)]
    })
}

pub(crate) fn brick(m: &Material) -> Texture {
    let t = tint(m);
    let mut rng = rng_for(m, 6);
    let n = 128usize;
    let (cols, courses) = (4usize, 8usize);
    let (bw, bh) = (n / cols, n / courses);
    let shade: Vec<(f32, f32)> = (0..cols * courses)
        .map(|_| {
            (
                rng.random_range(0.8f32..1.1),
                rng.random_range(-0.06f32..0.06),
            )
        })
        .collect();
    let surface = Fbm::new(rng.random(), 8, 8, 3).grid(n, n);
    let grain = rng.random::<u64>();
    let mortar = [0.70, 0.68, 0.64];
    from_fn(n, n, BRICK_REPEAT_M, |x, y| {
        let i = y * n + x;
        let course = y / bh;
        let xo = x + (course % 2) * bw / 2;
        let (col, lx, ly) = ((xo / bw) % cols, xo % bw, y % bh);
        let white = hash_signed(grain, x as i64, y as i64);
        if ly < 2 || lx < 2 {
            return scale(mortar, 0.95 + 0.05 * white);
        }
        let (b, r) = shade
            .get(course * cols + col)
            .copied()
            .unwrap_or((1.0, 0.0));
        let edge = if ly == 2 || lx == 2 || ly == bh - 1 || lx == bw - 1 {
            0.88
        } else {
            1.0
        };
        let k = b * edge * (1.0 + 0.07 * at(&surface, i) + 0.05 * white);
        [t[0] * k * (1.0 + r), t[1] * k, t[2] * k * (1.0 - r)]
    })
}

pub(crate) fn metal(m: &Material) -> Texture {
    let t = tint(m);
    let mut rng = rng_for(m, 7);
    let n = 128usize;
    let streak = ValueNoise::new(rng.random(), 2, 128).grid(n, n);
    let streak2 = ValueNoise::new(rng.random(), 5, 64).grid(n, n);
    let sheen = Fbm::new(rng.random(), 2, 2, 2).grid(n, n);
    let fine = rng.random::<u64>();
    from_fn(n, n, [METAL_REPEAT_M; 2], |x, y| {
        let i = y * n + x;
        let k = 1.0
            + 0.05 * at(&streak, i)
            + 0.035 * at(&streak2, i)
            + 0.06 * at(&sheen, i)
            + 0.015 * hash_signed(fine, x as i64, y as i64);
        scale(t, k)
    })
}

pub(crate) fn fabric(m: &Material) -> Texture {
    let t = tint(m);
    let mut rng = rng_for(m, 8);
    let n = 128usize;
    let cell = 4usize;
    let threads = rng.random::<u64>();
    let weft = mix(
        mul(t, [0.82, 0.82, 0.86]),
        pick(&mut rng, &PALETTE, t),
        0.08,
    );
    let mottle = Fbm::new(rng.random(), 3, 3, 2).grid(n, n);
    from_fn(n, n, [FABRIC_REPEAT_M; 2], |x, y| {
        let i = y * n + x;
        let (cx, cy) = (x / cell, y / cell);
        let warp_up = (cx + cy) % 2 == 0;
        let (c, across, thread) = if warp_up {
            (t, x % cell, cx as i64)
        } else {
            (weft, y % cell, 10_000 + cy as i64)
        };
        let p = (across as f32 + 0.5) / cell as f32;
        let profile = 0.8 + 0.2 * (p * std::f32::consts::PI).sin();
        let k = profile
            * (1.0 + 0.06 * hash_signed(threads, thread, 0))
            * (1.0 + 0.03 * at(&mottle, i));
        scale(c, k)
    })
}
