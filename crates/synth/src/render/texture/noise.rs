//! Noise for the procedural materials: lattice hashes, periodic value noise, periodic gradient
//! (Perlin) noise and their fractal sum. Every noise wraps over the unit square, so a texture
//! baked from it tiles without a seam.
//!
//! A module of its own because every painter draws on it and it is the part of texture baking
//! that is of use by itself: the parent module re-exports its public items.

/// A 64-bit integer hash of a seed and a 2-D lattice point (SplitMix64 finaliser).
pub fn hash2(seed: u64, x: i64, y: i64) -> u64 {
    let mut h = seed
        ^ (x as u64).wrapping_mul(0x9E37_79B9_7F4A_7C15)
        ^ (y as u64)
            .wrapping_mul(0xC2B2_AE3D_27D4_EB4F)
            .rotate_left(31);
    h ^= h >> 30;
    h = h.wrapping_mul(0xBF58_476D_1CE4_E5B9);
    h ^= h >> 27;
    h = h.wrapping_mul(0x94D0_49BB_1331_11EB);
    h ^ (h >> 31)
}

/// Uniform hash noise in `[0, 1)` at a lattice point.
pub fn hash_unit(seed: u64, x: i64, y: i64) -> f32 {
    (hash2(seed, x, y) >> 40) as f32 / (1u64 << 24) as f32
}

/// Uniform hash noise in `[-1, 1)` at a lattice point.
pub fn hash_signed(seed: u64, x: i64, y: i64) -> f32 {
    hash_unit(seed, x, y) * 2.0 - 1.0
}

/// Wraps lattice coordinate `x` onto `n` cells: (cell, fraction within it).
fn wrap_cell(x: f32, n: usize) -> (usize, usize, f32) {
    let f = x.floor();
    let i = (f as i64).rem_euclid(n as i64) as usize;
    let j = if i + 1 >= n { 0 } else { i + 1 };
    (i, j, x - f)
}

/// Smoothstep fade 3t² − 2t³.
fn fade(t: f32) -> f32 {
    t * t * (3.0 - 2.0 * t)
}

/// For each of `len` texel centres along an axis, the lattice cells either side on an `n`-cell
/// periodic lattice and the fraction between them.
fn axis(n: usize, len: usize) -> Vec<(usize, usize, f32)> {
    (0..len)
        .map(|i| wrap_cell((i as f32 + 0.5) / len as f32 * n as f32, n))
        .collect()
}

/// Periodic value noise: random values on an `nx × ny` lattice over the unit square, smoothly
/// interpolated. It wraps at 1 in both directions, so textures baked from it tile seamlessly.
#[derive(Clone, Debug)]
pub struct ValueNoise {
    nx: usize,
    ny: usize,
    values: Vec<f32>,
}

impl ValueNoise {
    /// Noise with `nx × ny` lattice cells over the unit square (at least 1 each).
    pub fn new(seed: u64, nx: usize, ny: usize) -> Self {
        let (nx, ny) = (nx.max(1), ny.max(1));
        let values = (0..nx * ny)
            .map(|i| hash_signed(seed, (i % nx) as i64, (i / nx) as i64))
            .collect();
        Self { nx, ny, values }
    }

    /// Noise at `(s, t)` in unit-square coordinates (wrapping), in `[-1, 1]`.
    pub fn at(&self, s: f32, t: f32) -> f32 {
        let (x0, x1, fx) = wrap_cell(s * self.nx as f32, self.nx);
        let (y0, y1, fy) = wrap_cell(t * self.ny as f32, self.ny);
        let v = |x: usize, y: usize| self.values.get(y * self.nx + x).copied().unwrap_or(0.0);
        let (sx, sy) = (fade(fx), fade(fy));
        let a = v(x0, y0) + (v(x1, y0) - v(x0, y0)) * sx;
        let b = v(x0, y1) + (v(x1, y1) - v(x0, y1)) * sx;
        a + (b - a) * sy
    }

    /// Adds `amp ×` the noise at the centres of a `w × h` texel grid (row-major) to `out`.
    pub fn add_grid(&self, out: &mut [f32], w: usize, h: usize, amp: f32) {
        let ax: Vec<(usize, usize, f32)> = axis(self.nx, w)
            .into_iter()
            .map(|(a, b, f)| (a, b, fade(f)))
            .collect();
        let nx = self.nx;
        let mut lattice_row = vec![0.0f32; nx];
        for ((y0, y1, fy), row) in axis(self.ny, h).into_iter().zip(out.chunks_mut(w.max(1))) {
            // Interpolate the two lattice rows once, then each texel along x.
            let sy = fade(fy);
            let r0 = self.values.get(y0 * nx..(y0 + 1) * nx).unwrap_or(&[]);
            let r1 = self.values.get(y1 * nx..(y1 + 1) * nx).unwrap_or(&[]);
            for ((l, &a), &b) in lattice_row.iter_mut().zip(r0).zip(r1) {
                *l = amp * (a + (b - a) * sy);
            }
            for (o, &(x0, x1, sx)) in row.iter_mut().zip(&ax) {
                let (a, b) = (lattice_row[x0], lattice_row[x1]);
                *o += a + (b - a) * sx;
            }
        }
    }

    /// The noise at the centres of a `w × h` texel grid spanning the unit square, row-major.
    pub fn grid(&self, w: usize, h: usize) -> Vec<f32> {
        let mut out = vec![0.0; w * h];
        self.add_grid(&mut out, w, h, 1.0);
        out
    }
}

/// Periodic gradient (Perlin) noise on an `nx × ny` lattice over the unit square; smoother and
/// less blocky than [`ValueNoise`], for warps and clouds.
#[derive(Clone, Debug)]
pub struct GradientNoise {
    nx: usize,
    ny: usize,
    grads: Vec<[f32; 2]>,
}

impl GradientNoise {
    /// Noise with `nx × ny` lattice cells over the unit square (at least 1 each).
    pub fn new(seed: u64, nx: usize, ny: usize) -> Self {
        let (nx, ny) = (nx.max(1), ny.max(1));
        let grads = (0..nx * ny)
            .map(|i| {
                let a = hash_unit(seed, (i % nx) as i64, (i / nx) as i64) * std::f32::consts::TAU;
                [a.cos(), a.sin()]
            })
            .collect();
        Self { nx, ny, grads }
    }

    /// Noise at `(s, t)` in unit-square coordinates (wrapping), roughly in `[-1, 1]`.
    pub fn at(&self, s: f32, t: f32) -> f32 {
        let (x0, x1, fx) = wrap_cell(s * self.nx as f32, self.nx);
        let (y0, y1, fy) = wrap_cell(t * self.ny as f32, self.ny);
        let dot = |x: usize, y: usize, dx: f32, dy: f32| {
            let g = self.grads.get(y * self.nx + x).copied().unwrap_or([0.0; 2]);
            g[0] * dx + g[1] * dy
        };
        let q = |t: f32| t * t * t * (t * (t * 6.0 - 15.0) + 10.0);
        let (sx, sy) = (q(fx), q(fy));
        let a = dot(x0, y0, fx, fy) + (dot(x1, y0, fx - 1.0, fy) - dot(x0, y0, fx, fy)) * sx;
        let b = dot(x0, y1, fx, fy - 1.0)
            + (dot(x1, y1, fx - 1.0, fy - 1.0) - dot(x0, y1, fx, fy - 1.0)) * sx;
        ((a + (b - a) * sy) * 1.5).clamp(-1.0, 1.0)
    }

    /// The noise at the centres of a `w × h` texel grid spanning the unit square, row-major.
    pub fn grid(&self, w: usize, h: usize) -> Vec<f32> {
        let q = |t: f32| t * t * t * (t * (t * 6.0 - 15.0) + 10.0);
        let ax = axis(self.nx, w);
        let nx = self.nx;
        let mut out = Vec::with_capacity(w * h);
        for (y0, y1, fy) in axis(self.ny, h) {
            let sy = q(fy);
            let r0 = self.grads.get(y0 * nx..(y0 + 1) * nx).unwrap_or(&[]);
            let r1 = self.grads.get(y1 * nx..(y1 + 1) * nx).unwrap_or(&[]);
            if r0.len() < nx || r1.len() < nx {
                out.resize(w * h, 0.0);
                return out;
            }
            out.extend(ax.iter().map(|&(x0, x1, fx)| {
                let sx = q(fx);
                let d = |g: [f32; 2], dx: f32, dy: f32| g[0] * dx + g[1] * dy;
                let a0 = d(r0[x0], fx, fy);
                let a = a0 + (d(r0[x1], fx - 1.0, fy) - a0) * sx;
                let b0 = d(r1[x0], fx, fy - 1.0);
                let b = b0 + (d(r1[x1], fx - 1.0, fy - 1.0) - b0) * sx;
                ((a + (b - a) * sy) * 1.5).clamp(-1.0, 1.0)
            }));
        }
        out
    }
}

/// Fractal (multi-octave) periodic value noise: octave `k` has `2^k` times the base lattice and
/// half the previous amplitude; normalised to `[-1, 1]`.
#[derive(Clone, Debug)]
pub struct Fbm {
    octaves: Vec<(ValueNoise, f32)>,
    norm: f32,
}

impl Fbm {
    /// `octaves` octaves (at least 1) starting from an `nx × ny` lattice.
    pub fn new(seed: u64, nx: usize, ny: usize, octaves: usize) -> Self {
        let mut amp = 1.0;
        let mut norm = 0.0;
        let octaves = (0..octaves.max(1))
            .map(|k| {
                let n = ValueNoise::new(
                    seed.wrapping_add((k as u64).wrapping_mul(0x632B_E59B_D9B4_E019)),
                    nx << k,
                    ny << k,
                );
                let layer = (n, amp);
                norm += amp;
                amp *= 0.5;
                layer
            })
            .collect();
        Self { octaves, norm }
    }

    /// Noise at `(s, t)` in unit-square coordinates (wrapping), in `[-1, 1]`.
    pub fn at(&self, s: f32, t: f32) -> f32 {
        self.octaves
            .iter()
            .map(|(n, a)| a * n.at(s, t))
            .sum::<f32>()
            / self.norm
    }

    /// The noise at the centres of a `w × h` texel grid spanning the unit square, row-major.
    pub fn grid(&self, w: usize, h: usize) -> Vec<f32> {
        let mut out = vec![0.0; w * h];
        for (n, a) in &self.octaves {
            n.add_grid(&mut out, w, h, a / self.norm);
        }
        out
    }
}

/// A value of a noise grid, 0 outside it.
pub(crate) fn at(grid: &[f32], i: usize) -> f32 {
    grid.get(i).copied().unwrap_or(0.0)
}

pub(crate) fn smoothstep(e0: f32, e1: f32, x: f32) -> f32 {
    let t = ((x - e0) / (e1 - e0)).clamp(0.0, 1.0);
    t * t * (3.0 - 2.0 * t)
}
