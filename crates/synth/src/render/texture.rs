//! Baked textures for `textured` mode: photo-like procedural materials of an office building
//! (paint, ceiling and floor tiles, carpet, wood, concrete, brick, posters, notice boards, signs,
//! windows, light panels, vents, brushed metal, fabric) and resampled image textures.
//!
//! [`bake`] turns a [`Material`] into a [`Texture`]: sRGB texels with power-of-two sides, so the
//! renderer wraps texel indices by masking. Content is drawn from [`Material::seed`] and is
//! deterministic: the same material always gives identical texels.
//!
//! # Texture coordinates
//! Texel `(x, y)` (`texels[y * width + x]`) covers `u ∈ [x, x + 1) · repeat_m[0] / width` and
//! `v ∈ [y, y + 1) · repeat_m[1] / height`, wrapping every [`Texture::repeat_m`]. Rows go with
//! `v`: row 0 lies at `v = 0`. Wall-mounted objects (posters, notice boards, signs, windows) are
//! drawn upright for `u` running to the right and `v` running **up** the wall, as wall triangles
//! get when their `v` is the height along the wall: their top edge is the last row. Image
//! textures keep the image's row order (row 0 = the image's top row, which is glTF's `v = 0`; an
//! OBJ importer flips `v`).
//!
//! # Sizes
//! Repeating patterns have a fixed physical repeat in metres ([`Texture::repeat_m`]; tiles repeat
//! every four tiles). Objects that must not repeat are baked for one physical size, given by the
//! `*_SIZE_M` constants (`[width along u, height along v]`); the building generator maps `uv` so
//! that one repeat covers the object: for a point `(x, y)` metres from the object's bottom-left
//! corner, `uv = (x / object_width · SIZE[0], y / object_height · SIZE[1])`. An object of another
//! size takes the same texture, stretched. Wood grain, brick courses and brushed-metal streaks
//! run along `u`; vent slats too.
//!
//! # Tint
//! [`Material::color`] is the dominant colour of every procedural pattern, so `shaded` and
//! `textured` mode agree on a surface's overall colour: paint, tiles, carpet, wood, concrete,
//! bricks, metal and fabric are modulated around it; it is a poster's background, a notice
//! board's cork, a sign's plate, a window's glass (the view is scaled so its mean colour is the
//! tint; frames are aluminium, white or anthracite), a light panel's diffuser and a vent's
//! grille. A sign's content follows the plate's hue: green gives an exit sign (running figure,
//! door, arrow), bright red (e.g. `[0.8, 0.12, 0.1]`) a fire-extinguisher sign, any other colour
//! a room-number plate such as "B2.14" with a name (7 seeds in 10) or an information, toilet or
//! direction sign. [`Pattern::Tiles`] with a light tint (luminance > 0.7) gives speckled
//! acoustic ceiling tiles in a T-bar grid; darker tints give floor tiles with grout. Image
//! textures are used as they are (an importer multiplies a base-colour factor into the image
//! itself).

use crate::world::{Material, Pattern};
use image::imageops::FilterType;
use rand::{Rng, SeedableRng};
use rand_chacha::ChaCha8Rng;

/// A baked texture: sRGB texels, row-major, width and height powers of two (so the renderer
/// wraps by masking).
#[derive(Clone, Debug, PartialEq)]
pub struct Texture {
    /// Texels per row, a power of two.
    pub width: u32,
    /// Rows, a power of two.
    pub height: u32,
    /// sRGB texels, `texels[y * width + x]`; row `y` lies at `v = y · repeat_m[1] / height`.
    pub texels: Vec<[u8; 3]>,
    /// Size of one repeat in uv units: metres along the surface for procedural patterns,
    /// `[1.0, 1.0]` for image textures (whose uv run 0–1).
    pub repeat_m: [f32; 2],
}

impl Texture {
    /// The texel at integer coordinates, wrapping both ways.
    pub fn texel(&self, x: i64, y: i64) -> [u8; 3] {
        let xi = x.rem_euclid(i64::from(self.width.max(1))) as usize;
        let yi = y.rem_euclid(i64::from(self.height.max(1))) as usize;
        self.texels
            .get(yi * self.width as usize + xi)
            .copied()
            .unwrap_or([0; 3])
    }

    /// The nearest texel at `uv` (uv units, wrapping every [`Texture::repeat_m`]).
    pub fn sample_nearest(&self, uv: [f32; 2]) -> [u8; 3] {
        let x = (uv[0] / self.repeat_m[0] * self.width as f32).floor();
        let y = (uv[1] / self.repeat_m[1] * self.height as f32).floor();
        self.texel(x as i64, y as i64)
    }

    /// Mean colour, sRGB 0–1.
    pub fn mean_rgb(&self) -> [f32; 3] {
        let mut sum = [0.0f64; 3];
        for t in &self.texels {
            for (s, &c) in sum.iter_mut().zip(t) {
                *s += f64::from(c);
            }
        }
        let n = self.texels.len().max(1) as f64 * 255.0;
        sum.map(|s| (s / n) as f32)
    }

    /// The texels as an image, row 0 first (for wall objects: upside down; see the module
    /// documentation).
    pub fn to_image(&self) -> image::RgbImage {
        image::RgbImage::from_fn(self.width, self.height, |x, y| {
            image::Rgb(self.texel(i64::from(x), i64::from(y)))
        })
    }
}

/// Physical size of a poster, metres `[width, height]`.
pub const POSTER_SIZE_M: [f32; 2] = [0.6, 0.85];
/// Physical size of a notice board (cork with its frame), metres `[width, height]`.
pub const NOTICE_BOARD_SIZE_M: [f32; 2] = [1.2, 0.9];
/// Physical size of a sign plate (exit sign, information sign, room-number plate), metres
/// `[width, height]`.
pub const SIGN_SIZE_M: [f32; 2] = [0.4, 0.2];
/// Physical size of a window (frame included), metres `[width, height]`.
pub const WINDOW_SIZE_M: [f32; 2] = [1.2, 1.5];
/// Physical size of a square ceiling light panel, metres `[width, height]`; the texture's repeat.
pub const LIGHT_PANEL_SIZE_M: [f32; 2] = [0.6, 0.6];
/// Physical size of a linear light fitting, metres; it takes the light-panel texture stretched
/// (one repeat over the fitting), whose diffuser grid then reads as a louvre.
pub const LIGHT_STRIP_SIZE_M: [f32; 2] = [1.2, 0.3];
/// Physical size of a ceiling vent (a grille in a tile slot), metres `[width, height]`; slats
/// run along `u`.
pub const VENT_SIZE_M: [f32; 2] = [0.6, 0.6];
/// Repeat of painted surfaces ([`Pattern::Plain`]), metres.
pub const PAINT_REPEAT_M: f32 = 2.0;
/// Tiles per repeat along each side for [`Pattern::Tiles`] (repeat = this × tile size).
pub const TILES_PER_REPEAT: u32 = 4;
/// Repeat of carpet: 2 × 2 carpet tiles of 0.5 m laid quarter-turned, metres.
pub const CARPET_REPEAT_M: f32 = 1.0;
/// Repeat of wood, metres `[along the grain (u), across the grain (v)]`.
pub const WOOD_REPEAT_M: [f32; 2] = [1.0, 0.5];
/// Repeat of concrete, metres.
pub const CONCRETE_REPEAT_M: f32 = 2.0;
/// Repeat of brickwork: 4 stretchers (225 mm with joint) by 8 courses (75 mm), metres
/// `[along the courses (u), up the wall (v)]`.
pub const BRICK_REPEAT_M: [f32; 2] = [0.9, 0.6];
/// Repeat of brushed metal, metres; streaks run along `u`.
pub const METAL_REPEAT_M: f32 = 0.5;
/// Repeat of woven fabric, metres.
pub const FABRIC_REPEAT_M: f32 = 0.25;
/// Largest side of a resampled image texture, texels.
pub const MAX_IMAGE_SIDE: u32 = 1024;

/// Bakes the material's pattern (procedural or image) into a texture.
///
/// Procedural textures are 64–256 texels a side; see the module documentation for sizes,
/// orientation and how [`Material::color`] tints each pattern.
pub fn bake(material: &Material) -> Texture {
    let m = material;
    match &m.pattern {
        Pattern::Plain => plain(m),
        Pattern::Tiles { size } => tiles(m, *size),
        Pattern::Carpet => carpet(m),
        Pattern::Wood => wood(m),
        Pattern::Concrete => concrete(m),
        Pattern::Brick => brick(m),
        Pattern::Poster => poster(m),
        Pattern::NoticeBoard => notice_board(m),
        Pattern::Sign => sign(m),
        Pattern::Window => window(m),
        Pattern::LightPanel => light_panel(m),
        Pattern::Vent => vent(m),
        Pattern::Metal => metal(m),
        Pattern::Fabric => fabric(m),
        Pattern::Image(img) => resample_image(img, tint(m)),
    }
}

// ---------------------------------------------------------------------------------------------
// Noise
// ---------------------------------------------------------------------------------------------

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
fn at(grid: &[f32], i: usize) -> f32 {
    grid.get(i).copied().unwrap_or(0.0)
}

fn smoothstep(e0: f32, e1: f32, x: f32) -> f32 {
    let t = ((x - e0) / (e1 - e0)).clamp(0.0, 1.0);
    t * t * (3.0 - 2.0 * t)
}

// ---------------------------------------------------------------------------------------------
// Colour and drawing helpers
// ---------------------------------------------------------------------------------------------

type Rgb = [f32; 3];

const WHITE: Rgb = [0.96, 0.96, 0.94];
const INK: Rgb = [0.12, 0.12, 0.13];

/// The material's colour, made safe (finite, 0–1).
fn tint(m: &Material) -> Rgb {
    m.color.map(|c| {
        if c.is_finite() {
            c.clamp(0.0, 1.0)
        } else {
            0.5
        }
    })
}

fn rng_for(m: &Material, salt: u64) -> ChaCha8Rng {
    ChaCha8Rng::seed_from_u64(m.seed ^ salt.wrapping_mul(0xA24B_AED4_963E_E407))
}

fn scale(c: Rgb, k: f32) -> Rgb {
    c.map(|x| x * k)
}

fn mul(a: Rgb, b: Rgb) -> Rgb {
    [a[0] * b[0], a[1] * b[1], a[2] * b[2]]
}

fn mix(a: Rgb, b: Rgb, t: f32) -> Rgb {
    [
        a[0] + (b[0] - a[0]) * t,
        a[1] + (b[1] - a[1]) * t,
        a[2] + (b[2] - a[2]) * t,
    ]
}

fn luminance(c: Rgb) -> f32 {
    0.2126 * c[0] + 0.7152 * c[1] + 0.0722 * c[2]
}

fn to_u8(c: Rgb) -> [u8; 3] {
    c.map(|x| (x.clamp(0.0, 1.0) * 255.0 + 0.5) as u8)
}

/// Saturated poster and pin colours.
const PALETTE: [Rgb; 12] = [
    [0.86, 0.16, 0.14],
    [0.96, 0.55, 0.10],
    [0.98, 0.84, 0.16],
    [0.20, 0.64, 0.30],
    [0.08, 0.58, 0.62],
    [0.14, 0.34, 0.76],
    [0.09, 0.14, 0.34],
    [0.50, 0.24, 0.64],
    [0.92, 0.42, 0.60],
    [0.10, 0.10, 0.11],
    [0.96, 0.95, 0.92],
    [0.56, 0.76, 0.92],
];

/// Pastel paper colours of notes.
const PAPERS: [Rgb; 4] = [
    [0.98, 0.93, 0.55],
    [0.97, 0.78, 0.84],
    [0.74, 0.88, 0.97],
    [0.78, 0.94, 0.74],
];

fn pick<T: Copy, R: Rng>(rng: &mut R, xs: &[T], fallback: T) -> T {
    if xs.is_empty() {
        return fallback;
    }
    xs.get(rng.random_range(0..xs.len()))
        .copied()
        .unwrap_or(fallback)
}

/// A palette colour that stands out against `bg`.
fn contrasting<R: Rng>(rng: &mut R, bg: Rgb) -> Rgb {
    let mut best = PALETTE[0];
    let mut best_d = -1.0;
    for _ in 0..6 {
        let c = pick(rng, &PALETTE, PALETTE[0]);
        let d: f32 = c.iter().zip(&bg).map(|(a, b)| (a - b).abs()).sum();
        if d > 0.9 {
            return c;
        }
        if d > best_d {
            best = c;
            best_d = d;
        }
    }
    best
}

/// Ink that reads on `bg`: white on dark, near-black on light.
fn ink_on(bg: Rgb) -> Rgb {
    if luminance(bg) < 0.5 { WHITE } else { INK }
}

/// A texture from a per-texel function (repeating patterns).
fn from_fn(
    w: usize,
    h: usize,
    repeat_m: [f32; 2],
    mut f: impl FnMut(usize, usize) -> Rgb,
) -> Texture {
    let mut texels = Vec::with_capacity(w * h);
    for y in 0..h {
        for x in 0..w {
            texels.push(to_u8(f(x, y)));
        }
    }
    Texture {
        width: w as u32,
        height: h as u32,
        texels,
        repeat_m,
    }
}

/// A drawing surface in physical units: picture coordinates in metres, x to the right, y down
/// from the top edge (as one looks at the object).
struct Canvas {
    w: usize,
    h: usize,
    /// Texels per metre along x and y.
    sx: f32,
    sy: f32,
    size_m: [f32; 2],
    px: Vec<Rgb>,
}

impl Canvas {
    fn new(w: usize, h: usize, size_m: [f32; 2], c: Rgb) -> Self {
        Self {
            w,
            h,
            sx: w as f32 / size_m[0],
            sy: h as f32 / size_m[1],
            size_m,
            px: vec![c; w * h],
        }
    }

    /// Sets every texel from `f(x_m, y_m, x, y)` at texel centres.
    fn fill(&mut self, mut f: impl FnMut(f32, f32, usize, usize) -> Rgb) {
        let (w, sx, sy) = (self.w, self.sx, self.sy);
        for (i, p) in self.px.iter_mut().enumerate() {
            let (x, y) = (i % w, i / w);
            *p = f((x as f32 + 0.5) / sx, (y as f32 + 0.5) / sy, x, y);
        }
    }

    /// Blends `f(x_m, y_m) = (colour, alpha)` over every texel.
    fn fill_blend(&mut self, mut f: impl FnMut(f32, f32) -> (Rgb, f32)) {
        let (w, sx, sy) = (self.w, self.sx, self.sy);
        for (i, p) in self.px.iter_mut().enumerate() {
            let (x, y) = (i % w, i / w);
            let (c, a) = f((x as f32 + 0.5) / sx, (y as f32 + 0.5) / sy);
            *p = mix(*p, c, a.clamp(0.0, 1.0));
        }
    }

    fn blend(&mut self, x: usize, y: usize, c: Rgb, a: f32) {
        if a <= 0.0 || x >= self.w {
            return;
        }
        if let Some(p) = self.px.get_mut(y * self.w + x) {
            *p = mix(*p, c, a.min(1.0));
        }
    }

    /// Fills an axis-aligned rectangle (metres), with exact coverage at its edges.
    fn rect(&mut self, x0: f32, y0: f32, x1: f32, y1: f32, c: Rgb, alpha: f32) {
        let (px0, px1) = ((x0 * self.sx).max(0.0), (x1 * self.sx).min(self.w as f32));
        let (py0, py1) = ((y0 * self.sy).max(0.0), (y1 * self.sy).min(self.h as f32));
        if px1 <= px0 || py1 <= py0 {
            return;
        }
        for y in py0.floor() as usize..py1.ceil() as usize {
            let cy = (py1.min(y as f32 + 1.0) - py0.max(y as f32)).clamp(0.0, 1.0);
            for x in px0.floor() as usize..px1.ceil() as usize {
                let cx = (px1.min(x as f32 + 1.0) - px0.max(x as f32)).clamp(0.0, 1.0);
                self.blend(x, y, c, alpha * cx * cy);
            }
        }
    }

    /// Blends `f(x_m, y_m) = (colour, signed distance)` over the texels of a bounding box
    /// (metres), where the distance is negative inside the shape; edges are antialiased.
    fn paint(&mut self, bbox: [f32; 4], mut f: impl FnMut(f32, f32) -> (Rgb, f32)) {
        let x0 = (bbox[0] * self.sx - 1.0).floor().max(0.0) as usize;
        let y0 = (bbox[1] * self.sy - 1.0).floor().max(0.0) as usize;
        let x1 = ((bbox[2] * self.sx + 1.0).ceil().max(0.0) as usize).min(self.w);
        let y1 = ((bbox[3] * self.sy + 1.0).ceil().max(0.0) as usize).min(self.h);
        let texel_m = 0.5 * (1.0 / self.sx + 1.0 / self.sy);
        for y in y0..y1 {
            for x in x0..x1 {
                let (c, d) = f((x as f32 + 0.5) / self.sx, (y as f32 + 0.5) / self.sy);
                self.blend(x, y, c, (0.5 - d / texel_m).clamp(0.0, 1.0));
            }
        }
    }

    fn circle(&mut self, cx: f32, cy: f32, r: f32, c: Rgb) {
        self.paint([cx - r, cy - r, cx + r, cy + r], |x, y| {
            (c, (x - cx).hypot(y - cy) - r)
        });
    }

    /// A thick line segment with round caps.
    fn capsule(&mut self, a: [f32; 2], b: [f32; 2], r: f32, c: Rgb) {
        let bbox = [
            a[0].min(b[0]) - r,
            a[1].min(b[1]) - r,
            a[0].max(b[0]) + r,
            a[1].max(b[1]) + r,
        ];
        let (dx, dy) = (b[0] - a[0], b[1] - a[1]);
        let len2 = (dx * dx + dy * dy).max(1e-12);
        self.paint(bbox, |x, y| {
            let t = (((x - a[0]) * dx + (y - a[1]) * dy) / len2).clamp(0.0, 1.0);
            (c, (x - a[0] - t * dx).hypot(y - a[1] - t * dy) - r)
        });
    }

    /// A polyline of capsules.
    fn stroke(&mut self, pts: &[[f32; 2]], r: f32, c: Rgb) {
        for w in pts.windows(2) {
            self.capsule(w[0], w[1], r, c);
        }
    }

    /// A rectangle outline of line width `lw`.
    fn frame(&mut self, x0: f32, y0: f32, x1: f32, y1: f32, lw: f32, c: Rgb) {
        self.rect(x0, y0, x1, y0 + lw, c, 1.0);
        self.rect(x0, y1 - lw, x1, y1, c, 1.0);
        self.rect(x0, y0 + lw, x0 + lw, y1 - lw, c, 1.0);
        self.rect(x1 - lw, y0 + lw, x1, y1 - lw, c, 1.0);
    }

    /// The texture, rows flipped so that row 0 is the object's bottom edge (v up).
    fn into_texture(self) -> Texture {
        let mut texels = Vec::with_capacity(self.px.len());
        for row in self.px.chunks(self.w.max(1)).rev() {
            texels.extend(row.iter().map(|&c| to_u8(c)));
        }
        Texture {
            width: self.w as u32,
            height: self.h as u32,
            texels,
            repeat_m: self.size_m,
        }
    }
}

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
fn text_width(n: usize, cw: f32) -> f32 {
    (4 * n) as f32 * cw - cw
}

/// Draws block text with its top-left corner at `(x, y)`; cells `cw × ch` metres. Texels are
/// set by their centres, so neighbouring cells join without seams.
fn text(c: &mut Canvas, at: [f32; 2], cell: [f32; 2], s: &[u8], color: Rgb) {
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
fn random_word<R: Rng>(rng: &mut R, n: usize) -> Vec<u8> {
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
fn text_lines<R: Rng>(c: &mut Canvas, rng: &mut R, bbox: [f32; 4], line_h: f32, color: Rgb) {
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

// ---------------------------------------------------------------------------------------------
// Repeating patterns
// ---------------------------------------------------------------------------------------------

fn plain(m: &Material) -> Texture {
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

fn tiles(m: &Material, size: f32) -> Texture {
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

fn carpet(m: &Material) -> Texture {
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

fn wood(m: &Material) -> Texture {
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

fn concrete(m: &Material) -> Texture {
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

fn brick(m: &Material) -> Texture {
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

fn metal(m: &Material) -> Texture {
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

fn fabric(m: &Material) -> Texture {
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

// ---------------------------------------------------------------------------------------------
// Objects (one repeat covers the object)
// ---------------------------------------------------------------------------------------------

fn poster(m: &Material) -> Texture {
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

fn notice_board(m: &Material) -> Texture {
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

fn sign(m: &Material) -> Texture {
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

fn window(m: &Material) -> Texture {
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

fn light_panel(m: &Material) -> Texture {
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

fn vent(m: &Material) -> Texture {
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

// ---------------------------------------------------------------------------------------------
// Images
// ---------------------------------------------------------------------------------------------

/// The power of two nearest to `n` (in ratio), from 1 to [`MAX_IMAGE_SIDE`].
fn pow2_near(n: u32) -> u32 {
    let n = n.clamp(1, MAX_IMAGE_SIDE);
    let lo = if n.is_power_of_two() {
        n
    } else {
        n.next_power_of_two() / 2
    };
    let hi = n.next_power_of_two();
    if (n as f32 / lo as f32) <= (hi as f32 / n as f32) {
        lo
    } else {
        hi
    }
}

fn resample_image(img: &image::RgbImage, fallback: Rgb) -> Texture {
    let (w0, h0) = img.dimensions();
    if w0 == 0 || h0 == 0 {
        return Texture {
            width: 1,
            height: 1,
            texels: vec![to_u8(fallback)],
            repeat_m: [1.0, 1.0],
        };
    }
    let (w, h) = (pow2_near(w0), pow2_near(h0));
    let texels = if (w, h) == (w0, h0) {
        img.pixels().map(|p| p.0).collect()
    } else {
        image::imageops::resize(img, w, h, FilterType::Triangle)
            .pixels()
            .map(|p| p.0)
            .collect()
    };
    Texture {
        width: w,
        height: h,
        texels,
        repeat_m: [1.0, 1.0],
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use std::sync::Arc;
    use std::time::Instant;

    type TestResult = Result<(), Box<dyn std::error::Error>>;

    fn mat(pattern: Pattern, color: [f32; 3], seed: u64) -> Material {
        Material {
            name: "test".into(),
            color,
            pattern,
            seed,
            emissive: 0.0,
        }
    }

    fn test_image() -> image::RgbImage {
        image::RgbImage::from_fn(100, 60, |x, y| {
            image::Rgb([(x * 2) as u8, (y * 4) as u8, ((x + y) % 256) as u8])
        })
    }

    /// Every pattern with a typical colour: (label, material).
    fn all(seed: u64) -> Vec<(&'static str, Material)> {
        vec![
            ("plain", mat(Pattern::Plain, [0.85, 0.84, 0.8], seed)),
            (
                "ceiling tiles",
                mat(Pattern::Tiles { size: 0.6 }, [0.9, 0.9, 0.88], seed),
            ),
            (
                "floor tiles",
                mat(Pattern::Tiles { size: 0.3 }, [0.62, 0.58, 0.52], seed),
            ),
            ("carpet", mat(Pattern::Carpet, [0.3, 0.33, 0.4], seed)),
            ("wood", mat(Pattern::Wood, [0.62, 0.44, 0.28], seed)),
            ("concrete", mat(Pattern::Concrete, [0.6, 0.6, 0.58], seed)),
            ("brick", mat(Pattern::Brick, [0.6, 0.3, 0.22], seed)),
            ("poster", mat(Pattern::Poster, [0.95, 0.93, 0.85], seed)),
            ("poster dark", mat(Pattern::Poster, [0.12, 0.2, 0.4], seed)),
            (
                "notice board",
                mat(Pattern::NoticeBoard, [0.62, 0.45, 0.3], seed),
            ),
            ("exit sign", mat(Pattern::Sign, [0.1, 0.6, 0.3], seed)),
            ("blue sign", mat(Pattern::Sign, [0.15, 0.3, 0.6], seed)),
            ("white sign", mat(Pattern::Sign, [0.93, 0.93, 0.9], seed)),
            ("fire sign", mat(Pattern::Sign, [0.8, 0.12, 0.1], seed)),
            ("window", mat(Pattern::Window, [0.75, 0.85, 0.95], seed)),
            (
                "light panel",
                mat(Pattern::LightPanel, [0.97, 0.97, 0.95], seed),
            ),
            ("vent", mat(Pattern::Vent, [0.88, 0.88, 0.86], seed)),
            ("metal", mat(Pattern::Metal, [0.7, 0.71, 0.73], seed)),
            ("fabric", mat(Pattern::Fabric, [0.25, 0.3, 0.45], seed)),
            (
                "image",
                mat(Pattern::Image(Arc::new(test_image())), [1.0; 3], seed),
            ),
        ]
    }

    fn diff(a: &Texture, b: &Texture) -> f64 {
        let s: f64 = a
            .texels
            .iter()
            .zip(&b.texels)
            .map(|(p, q)| {
                p.iter()
                    .zip(q)
                    .map(|(&x, &y)| f64::from((i16::from(x) - i16::from(y)).abs()))
                    .sum::<f64>()
            })
            .sum();
        s / (a.texels.len().max(1) * 3) as f64
    }

    #[test]
    fn texture_sizes_are_powers_of_two() -> TestResult {
        for (name, m) in all(7) {
            let t = bake(&m);
            if !(t.width.is_power_of_two() && t.height.is_power_of_two()) {
                return Err(format!("{name}: {}x{}", t.width, t.height).into());
            }
            if t.texels.len() != (t.width * t.height) as usize {
                return Err(format!("{name}: {} texels", t.texels.len()).into());
            }
            if !(t.repeat_m[0] > 0.0 && t.repeat_m[1] > 0.0) {
                return Err(format!("{name}: repeat {:?}", t.repeat_m).into());
            }
        }
        Ok(())
    }

    #[test]
    fn texture_bake_is_deterministic() -> TestResult {
        for ((name, a), (_, b)) in all(42).into_iter().zip(all(42)) {
            if bake(&a) != bake(&b) {
                return Err(format!("{name}: two bakes differ").into());
            }
        }
        Ok(())
    }

    #[test]
    fn texture_posters_differ_between_seeds() -> TestResult {
        let bakes: Vec<Texture> = (0..12)
            .map(|s| bake(&mat(Pattern::Poster, [0.95, 0.93, 0.85], s)))
            .collect();
        let mut min = f64::MAX;
        for (i, a) in bakes.iter().enumerate() {
            for b in &bakes[i + 1..] {
                min = min.min(diff(a, b));
            }
        }
        println!("smallest mean absolute difference between posters: {min:.1}");
        if min < 20.0 {
            return Err(format!("posters too alike: {min:.1}").into());
        }
        for p in [
            Pattern::NoticeBoard,
            Pattern::Sign,
            Pattern::Window,
            Pattern::Carpet,
        ] {
            let d = diff(
                &bake(&mat(p.clone(), [0.6, 0.45, 0.3], 1)),
                &bake(&mat(p.clone(), [0.6, 0.45, 0.3], 2)),
            );
            println!("{p:?}: seeds 1 and 2 differ by {d:.1}");
            if d < 1.0 {
                return Err(format!("{p:?}: seeds give the same texture").into());
            }
        }
        Ok(())
    }

    #[test]
    fn texture_tint_moves_the_mean_colour() -> TestResult {
        let grey = [0.4, 0.4, 0.4];
        let red = [0.7, 0.25, 0.2];
        for (name, a) in all(3) {
            if matches!(a.pattern, Pattern::Image(_)) {
                continue;
            }
            let g = bake(&mat(a.pattern.clone(), grey, 3)).mean_rgb();
            let r = bake(&mat(a.pattern.clone(), red, 3)).mean_rgb();
            let (dr, db) = (r[0] - g[0], r[2] - g[2]);
            // Windows show mostly sky: only their frame takes the tint.
            if dr < 0.02 || dr < db + 0.03 {
                return Err(format!("{name}: grey {g:?} -> red {r:?}").into());
            }
            let light = bake(&mat(a.pattern.clone(), [0.5; 3], 3)).mean_rgb();
            let lighter = bake(&mat(a.pattern.clone(), [0.6; 3], 3)).mean_rgb();
            if lighter.iter().sum::<f32>() <= light.iter().sum::<f32>() {
                return Err(format!("{name}: lighter tint not lighter").into());
            }
        }
        Ok(())
    }

    #[test]
    fn texture_image_is_resampled_to_powers_of_two() -> TestResult {
        let t = bake(&mat(Pattern::Image(Arc::new(test_image())), [1.0; 3], 0));
        assert_eq!((t.width, t.height), (128, 64));
        assert_eq!(t.repeat_m, [1.0, 1.0]);
        // A horizontal ramp stays a ramp: red grows along each row.
        let row: Vec<u8> = (0..t.width).map(|x| t.texel(i64::from(x), 10)[0]).collect();
        assert!(row.windows(2).all(|w| w[1] + 2 >= w[0]), "{row:?}");
        assert!(row[120] > row[8] + 100);
        let big = image::RgbImage::new(3000, 10);
        let t = bake(&mat(Pattern::Image(Arc::new(big)), [1.0; 3], 0));
        assert_eq!((t.width, t.height), (MAX_IMAGE_SIDE, 8));
        let exact = image::RgbImage::from_pixel(32, 16, image::Rgb([1, 2, 3]));
        let t = bake(&mat(Pattern::Image(Arc::new(exact)), [1.0; 3], 0));
        assert_eq!((t.width, t.height), (32, 16));
        assert!(t.texels.iter().all(|&p| p == [1, 2, 3]));
        let empty = image::RgbImage::new(0, 0);
        let t = bake(&mat(Pattern::Image(Arc::new(empty)), [1.0, 0.0, 0.0], 0));
        assert_eq!(
            (t.width, t.height, t.texels.clone()),
            (1, 1, vec![[255, 0, 0]])
        );
        Ok(())
    }

    #[test]
    fn texture_tiles_tolerate_bad_sizes() {
        for size in [0.0, -1.0, f32::NAN, f32::INFINITY, 1e9] {
            let t = bake(&mat(Pattern::Tiles { size }, [0.5; 3], 0));
            assert!(t.repeat_m[0].is_finite() && t.repeat_m[0] > 0.0);
        }
        let t = bake(&mat(Pattern::Plain, [f32::NAN, 2.0, -1.0], 0));
        assert!(!t.texels.is_empty());
    }

    /// Times for a person to read; speed goals are checked by `indoorloc bench render`.
    #[test]
    #[ignore = "timing printout, checks nothing; run with --ignored"]
    fn texture_bake_times() {
        for (name, m) in all(5) {
            let mut best = f64::MAX;
            for _ in 0..5 {
                let t0 = Instant::now();
                let t = bake(&m);
                best = best.min(t0.elapsed().as_secs_f64());
                std::hint::black_box(t);
            }
            let t = bake(&m);
            println!(
                "bake {name:14} {:4}x{:<4} {:7.3} ms",
                t.width,
                t.height,
                best * 1e3
            );
        }
    }

    /// Writes a contact sheet of every pattern, two seeds each, to /tmp/textures.png: each cell
    /// shows the texture as seen on the wall (v up), repeating patterns 2 × 2 times.
    #[test]
    #[ignore = "a picture for a person to look at, checks nothing; run with --ignored"]
    fn texture_contact_sheet() -> TestResult {
        let cell = 180u32;
        let pad = 6u32;
        let cols = 8u32;
        let mut items = Vec::new();
        for ((name, a), (_, b)) in all(1).into_iter().zip(all(2)) {
            items.push((name, a));
            items.push((name, b));
        }
        let rows = (items.len() as u32).div_ceil(cols);
        let mut sheet = image::RgbImage::from_pixel(
            cols * (cell + pad) + pad,
            rows * (cell + pad) + pad,
            image::Rgb([40, 40, 40]),
        );
        for (i, (_, m)) in items.iter().enumerate() {
            let t = bake(m);
            let object = matches!(
                m.pattern,
                Pattern::Poster
                    | Pattern::NoticeBoard
                    | Pattern::Sign
                    | Pattern::Window
                    | Pattern::LightPanel
                    | Pattern::Vent
                    | Pattern::Image(_)
            );
            let reps = if object { 1.0 } else { 2.0 };
            let (aw, ah) = (t.repeat_m[0] * reps, t.repeat_m[1] * reps);
            let k = cell as f32 / aw.max(ah);
            let (cw, ch) = ((aw * k) as u32, (ah * k) as u32);
            let (ox, oy) = (
                pad + (i as u32 % cols) * (cell + pad) + (cell - cw) / 2,
                pad + (i as u32 / cols) * (cell + pad) + (cell - ch) / 2,
            );
            for y in 0..ch {
                for x in 0..cw {
                    let u = x as f32 / k;
                    // Image rows run down, procedural rows up the wall.
                    let v = if matches!(m.pattern, Pattern::Image(_)) {
                        y as f32 / k
                    } else {
                        (ch - 1 - y) as f32 / k
                    };
                    let p = t.sample_nearest([u, v]);
                    sheet.put_pixel(ox + x, oy + y, image::Rgb(p));
                }
            }
        }
        sheet.save("/tmp/textures.png")?;
        println!(
            "contact sheet: /tmp/textures.png; order: {:?}",
            all(0).iter().map(|(n, _)| *n).collect::<Vec<_>>()
        );
        Ok(())
    }
}
