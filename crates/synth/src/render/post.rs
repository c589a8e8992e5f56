//! The last pass: linear radiance → sRGB bytes with vignetting and sensor noise; geometry edges;
//! gradient magnitude.

use super::lens::Lens;
use super::raster::{NONE, VisTri};
use super::scene::{dot32, luts};
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

/// SplitMix64's finalizer: a well-mixed 64-bit hash, so noise needs no generator state and every
/// pixel's noise depends only on the seed and the pixel.
#[inline(always)]
pub(crate) fn mix(mut z: u64) -> u64 {
    z = (z ^ (z >> 30)).wrapping_mul(0xbf58_476d_1ce4_e5b9);
    z = (z ^ (z >> 27)).wrapping_mul(0x94d0_49bb_1331_11eb);
    z ^ (z >> 31)
}

/// Averages `subframes` of linear radiance, applies vignetting, tone-maps to sRGB and adds noise.
pub(crate) fn finish(accum: &[[f32; 3]], subframes: usize, rgb: &mut [u8], w: usize, h: usize, sensor: Sensor) {
    let lut = luts();
    let inv = 1.0 / subframes.max(1) as f32;
    let (cx, cy) = ((w as f32 - 1.0) / 2.0, (h as f32 - 1.0) / 2.0);
    let r2norm = 1.0 / (cx * cx + cy * cy).max(1.0);
    let vig = sensor.vignetting.clamp(0.0, 1.0);
    let amp = noise_amp(sensor.noise);
    let key = mix(sensor.seed ^ 0x5851_f42d_4c95_7f2d);
    for y in 0..h {
        let dy = y as f32 - cy;
        for x in 0..w {
            let i = y * w + x;
            let dx = x as f32 - cx;
            let f = inv * (1.0 - vig * (dx * dx + dy * dy) * r2norm);
            let a = accum[i];
            let mut px = [
                lut.encode_one(a[0] * f),
                lut.encode_one(a[1] * f),
                lut.encode_one(a[2] * f),
            ];
            if amp > 0 {
                add_noise(&mut px, key, i, amp);
            }
            rgb[3 * i..3 * i + 3].copy_from_slice(&px);
        }
    }
}

/// Fixed-point scale (1/65536) of the noise variate for a standard deviation of `noise` (fraction
/// of full scale).
pub(crate) fn noise_amp(noise: f32) -> i32 {
    // The variate, a sum of two uniform bytes minus 255, has σ = 255/√6.
    let scale = noise.clamp(0.0, 1.0) * 255.0 / (255.0 / 6f32.sqrt());
    (scale * 65536.0) as i32
}

/// Adds the noise of pixel `i` (`amp` from [`noise_amp`]): a triangular variate per channel, a
/// close and cheap stand-in for Gaussian read noise, drawn from a hash of the frame's key and
/// the pixel so it needs no generator state.
#[inline(always)]
pub(crate) fn add_noise(px: &mut [u8; 3], key: u64, i: usize, amp: i32) {
    let mut h = (key ^ i as u64).wrapping_mul(0x9e37_79b9_7f4a_7c15);
    h ^= h >> 32;
    h = h.wrapping_mul(0xd6e8_feb8_6659_fd93);
    h ^= h >> 29;
    for (k, c) in px.iter_mut().enumerate() {
        let a = ((h >> (16 * k)) & 0xff) as i32;
        let b = ((h >> (16 * k + 8)) & 0xff) as i32;
        let v = *c as i32 + (((a + b - 255) * amp + 32768) >> 16);
        *c = v.clamp(0, 255) as u8;
    }
}

/// White where the visible geometry changes: another dominant plane, a crease (normals more than
/// about 20° apart), an occlusion boundary (the neighbour's depth is not on this pixel's plane),
/// or geometry against empty space. Coplanar triangles of one surface draw no line.
pub(crate) fn edges(shade: &Shade, vis: &[VisTri], lens: &Lens, rgb: &mut [u8], w: usize, h: usize) {
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
pub(crate) fn gradmag(rgb: &mut [u8], gray: &mut Vec<f32>, w: usize, h: usize) {
    gray.clear();
    gray.extend(
        rgb.chunks_exact(3)
            .map(|c| 0.299 * c[0] as f32 + 0.587 * c[1] as f32 + 0.114 * c[2] as f32),
    );
    let at = |x: isize, y: isize| -> f32 {
        let xc = x.clamp(0, w as isize - 1) as usize;
        let yc = y.clamp(0, h as isize - 1) as usize;
        gray[yc * w + xc]
    };
    for y in 0..h as isize {
        for x in 0..w as isize {
            let gx = (at(x + 1, y - 1) + 2.0 * at(x + 1, y) + at(x + 1, y + 1))
                - (at(x - 1, y - 1) + 2.0 * at(x - 1, y) + at(x - 1, y + 1));
            let gy = (at(x - 1, y + 1) + 2.0 * at(x, y + 1) + at(x + 1, y + 1))
                - (at(x - 1, y - 1) + 2.0 * at(x, y - 1) + at(x + 1, y - 1));
            // A full black-to-white step gives 4·255; a quarter of that saturates.
            let m = ((gx * gx + gy * gy).sqrt() * 0.25).min(255.0) as u8;
            let i = (y as usize * w + x as usize) * 3;
            rgb[i..i + 3].fill(m);
        }
    }
}
