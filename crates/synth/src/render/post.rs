//! The last pass: linear radiance → sRGB bytes with vignetting and sensor noise; geometry edges;
//! gradient magnitude.

use super::lens::Lens;
use super::raster::{NONE, VisTri};
use super::scene::dot32;
use super::shade::Shade;

/// Sensor model of the photo-like modes.
#[derive(Clone, Copy, Debug)]
pub(crate) struct Sensor {
    /// Standard deviation of the noise, fraction of full scale.
    pub noise: f32,
    /// Brightness lost at the image corners, 0–1.
    pub vignetting: f32,
    /// Seed of the noise.
    pub seed: u64,
}

/// SplitMix64's finalizer: a well-mixed 64-bit hash (turns a seed into a frame's noise key).
#[inline(always)]
pub(crate) fn mix(mut z: u64) -> u64 {
    z = (z ^ (z >> 30)).wrapping_mul(0xbf58_476d_1ce4_e5b9);
    z = (z ^ (z >> 27)).wrapping_mul(0x94d0_49bb_1331_11eb);
    z ^ (z >> 31)
}

/// A 32-bit hash of shifts, adds and xors only (Jenkins' one-at-a-time finalizer, twice): no
/// multiplies, which baseline x86-64 (SSE2) cannot do four at a time, so rows of noise vectorize.
#[inline(always)]
fn hash32(mut x: u32) -> u32 {
    for _ in 0..2 {
        x = x.wrapping_add(x << 10);
        x ^= x >> 6;
        x = x.wrapping_add(x << 3);
        x ^= x >> 11;
        x = x.wrapping_add(x << 15);
    }
    x
}

/// Coefficients of sRGB encoding as a polynomial in `x^(1/4)` (least squares on 0–1; within
/// 1.2 levels of 255 of the exact curve), so encoding needs two square roots and no table.
const SRGB_POLY: [f32; 6] = [
    -0.052_951_2,
    -0.281_070_9,
    9.086_772,
    -19.454_353,
    17.439_068,
    -5.741_222,
];

/// Linear light → display level 0–255 (not rounded): identity below a knee, then a soft
/// shoulder so lamps and sunlit windows saturate gracefully instead of clipping hard; then the
/// sRGB curve. Branch-free, so a row of it vectorizes.
#[inline(always)]
pub(crate) fn encode(x: f32) -> f32 {
    const KNEE: f32 = 0.8;
    let u = (x - KNEE) * (1.0 / (1.0 - KNEE));
    let shoulder = KNEE + (1.0 - KNEE) * u / (1.0 + u);
    let t = if x > KNEE { shoulder } else { x };
    let t = if t > 0.0 { t } else { 0.0 };
    let q = t.sqrt().sqrt();
    let mut s = 0.0;
    for c in SRGB_POLY.iter().rev() {
        s = (s + c) * q;
    }
    // The fit ends at 254.0 for t = 1; stretch it to full scale.
    s * 255.96
}

/// The sensor model for one image: vignetting, tone mapping and sRGB encoding, noise.
#[derive(Clone, Copy, Debug)]
pub(crate) struct Finisher {
    vig: f32,
    vcx: f32,
    vcy: f32,
    amp: f32,
    key: u32,
    width: usize,
}

/// Rows of one finished image channel by channel (reused scratch).
#[derive(Debug, Default)]
pub(crate) struct RowBytes {
    r: Vec<u8>,
    g: Vec<u8>,
    b: Vec<u8>,
}

impl Finisher {
    /// The sensor model of a `w` x `h` image.
    pub fn new(sensor: Sensor, w: usize, h: usize) -> Finisher {
        let (vcx, vcy) = ((w as f32 - 1.0) / 2.0, (h as f32 - 1.0) / 2.0);
        // The noise variate, a sum of two uniform bytes minus 255, has σ = 255/√6.
        let amp = sensor.noise.clamp(0.0, 1.0) * 255.0 / (255.0 / 6f32.sqrt());
        Finisher {
            vig: sensor.vignetting.clamp(0.0, 1.0) / (vcx * vcx + vcy * vcy).max(1.0),
            vcx,
            vcy,
            amp,
            key: (mix(sensor.seed ^ 0x5851_f42d_4c95_7f2d) >> 32) as u32,
            width: w,
        }
    }

    /// Encodes row `y` of linear radiance (`scale`·(r, g, b)) into interleaved sRGB bytes.
    /// Noise depends only on the seed and the pixel: the same seed gives the same bytes.
    #[allow(clippy::too_many_arguments)]
    #[inline(always)]
    pub fn row(
        &self,
        y: usize,
        scale: f32,
        r: &[f32],
        g: &[f32],
        b: &[f32],
        tmp: &mut RowBytes,
        out: &mut [u8],
    ) {
        let n = r.len().min(g.len()).min(b.len());
        for v in [&mut tmp.r, &mut tmp.g, &mut tmp.b] {
            v.resize(n, 0);
        }
        let dy = y as f32 - self.vcy;
        let dy2 = dy * dy;
        let base = (y * self.width) as u32;
        // Clamp, then round to nearest by adding 1.5·2²³ (the integer lands in the low mantissa
        // bits): no float→int conversion, which would keep the loop from vectorizing.
        let quant = |v: f32| -> u8 {
            let v = if v > 0.0 { v } else { 0.0 };
            let v = if v < 255.0 { v } else { 255.0 };
            ((v + 12_582_912.0).to_bits() & 0xff) as u8
        };
        let chans = tmp.r.iter_mut().zip(tmp.g.iter_mut()).zip(tmp.b.iter_mut());
        for (x, (((or, og), ob), ((&lr, &lg), &lb))) in
            chans.zip(r.iter().zip(g).zip(b)).enumerate()
        {
            let dx = x as f32 - self.vcx;
            let f = scale * (1.0 - self.vig * (dx * dx + dy2));
            let h1 = hash32(self.key ^ (base + x as u32));
            let h2 = hash32(h1 ^ 0x68e3_1da4);
            let tri = |h: u32| ((h & 0xff) + ((h >> 8) & 0xff)) as f32 - 255.0;
            *or = quant(encode(lr * f) + tri(h1) * self.amp);
            *og = quant(encode(lg * f) + tri(h1 >> 16) * self.amp);
            *ob = quant(encode(lb * f) + tri(h2) * self.amp);
        }
        for (px, ((&r, &g), &b)) in out
            .chunks_exact_mut(3)
            .zip(tmp.r.iter().zip(&tmp.g).zip(&tmp.b))
        {
            px[0] = r;
            px[1] = g;
            px[2] = b;
        }
    }
}

/// Averages `subframes` of linear radiance (motion blur) and finishes the image.
#[inline(always)]
pub(crate) fn finish(
    accum: &[[f32; 3]],
    subframes: usize,
    rgb: &mut [u8],
    w: usize,
    h: usize,
    sensor: Sensor,
    scratch: &mut (Vec<f32>, Vec<f32>, Vec<f32>, RowBytes),
) {
    let fin = Finisher::new(sensor, w, h);
    let inv = 1.0 / subframes.max(1) as f32;
    let (r, g, b, tmp) = scratch;
    for y in 0..h {
        let row = &accum[y * w..(y + 1) * w];
        r.clear();
        g.clear();
        b.clear();
        r.extend(row.iter().map(|c| c[0]));
        g.extend(row.iter().map(|c| c[1]));
        b.extend(row.iter().map(|c| c[2]));
        fin.row(y, inv, r, g, b, tmp, &mut rgb[3 * y * w..3 * (y + 1) * w]);
    }
}

/// White where the visible geometry changes: another dominant plane, a crease (normals more than
/// about 20° apart), an occlusion boundary (the neighbour's depth is not on this pixel's plane),
/// or geometry against empty space. Coplanar triangles of one surface draw no line.
#[inline(always)]
pub(crate) fn edges(
    shade: &Shade,
    vis: &[VisTri],
    lens: &Lens,
    rgb: &mut [u8],
    w: usize,
    h: usize,
) {
    let pos = |i: usize, x: usize, y: usize| -> (f32, f32) {
        if lens.map.is_empty() {
            (x as f32, y as f32)
        } else {
            (lens.map[i].sx, lens.map[i].sy)
        }
    };
    let differs = |i: usize, j: usize, xj: usize, yj: usize| -> bool {
        let (a, b) = (shade.vis[i], shade.vis[j]);
        if a == b {
            return false;
        }
        if a == NONE || b == NONE {
            return true;
        }
        let (ta, tb) = (&vis[a as usize], &vis[b as usize]);
        if ta.plane != 0 && tb.plane != 0 && ta.plane != tb.plane {
            return true;
        }
        if dot32(ta.n, tb.n) < 0.94 {
            return true;
        }
        let (sx, sy) = pos(j, xj, yj);
        let predicted = ta.w_at(sx, sy);
        let actual = shade.w[j];
        (predicted - actual).abs() > 0.02 * actual
    };
    for y in 0..h {
        for x in 0..w {
            let i = y * w + x;
            let edge = (x + 1 < w && differs(i, i + 1, x + 1, y))
                || (y + 1 < h && differs(i, i + w, x, y + 1));
            let v = if edge { 255 } else { 0 };
            rgb[3 * i..3 * i + 3].fill(v);
        }
    }
}

/// Replaces the image by the Sobel gradient magnitude of its luma (grey); `gray` is scratch.
#[inline(always)]
pub(crate) fn gradmag(rgb: &mut [u8], gray: &mut Vec<f32>, w: usize, h: usize) {
    gray.clear();
    gray.extend(
        rgb.chunks_exact(3)
            .map(|c| 0.299 * c[0] as f32 + 0.587 * c[1] as f32 + 0.114 * c[2] as f32),
    );
    if w == 0 || h == 0 {
        return;
    }
    let sobel = |r0: &[f32], r1: &[f32], r2: &[f32], (xm, x, xp): (usize, usize, usize)| -> u8 {
        let gx = (r0[xp] + 2.0 * r1[xp] + r2[xp]) - (r0[xm] + 2.0 * r1[xm] + r2[xm]);
        let gy = (r2[xm] + 2.0 * r2[x] + r2[xp]) - (r0[xm] + 2.0 * r0[x] + r0[xp]);
        // A full black-to-white step gives 4·255; a quarter of that saturates.
        ((gx * gx + gy * gy).sqrt() * 0.25).min(255.0) as u8
    };
    for y in 0..h {
        // Rows above and below, clamped at the image's edges.
        let row = |y: usize| &gray[y * w..(y + 1) * w];
        let (r0, r1, r2) = (row(y.saturating_sub(1)), row(y), row((y + 1).min(h - 1)));
        let out = &mut rgb[3 * y * w..3 * (y + 1) * w];
        let edge = |x: usize| sobel(r0, r1, r2, (x.saturating_sub(1), x, (x + 1).min(w - 1)));
        let (first, last) = (edge(0), edge(w - 1));
        // Inside the row every neighbour exists: one loop over shifted slices, no clamping,
        // which vectorizes.
        if w > 2 {
            let inner = out[3..3 * (w - 1)].chunks_exact_mut(3);
            for (x, px) in (1..w - 1).zip(inner) {
                px.fill(sobel(r0, r1, r2, (x - 1, x, x + 1)));
            }
        }
        out[..3].fill(first);
        out[3 * (w - 1)..].fill(last);
    }
}
