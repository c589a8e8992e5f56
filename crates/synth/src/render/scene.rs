//! [`RenderScene`]: a [`World`] prepared once for fast rendering — triangles with precomputed
//! planes and texture gradients, baked and mip-mapped textures, switched-on lights, and a uniform
//! grid of triangles for frustum and occlusion culling and for shadow rays.

// `!(x > y)` is deliberate here: it is also true for NaN, which must fail the check.
#![allow(clippy::neg_cmp_op_on_partial_ord)]

use super::raster::Stamps;
use super::texture::{self, Texture};
use crate::error::{Result, SynthError};
use crate::world::{Atmosphere, Material, Pattern, Triangle, World};
use rayon::prelude::*;
use std::collections::HashMap;
use std::sync::atomic::{AtomicU64, Ordering};

/// Most texels per side of a mip level 0. [`texture::bake`] already keeps pattern and image
/// textures within [`texture::MAX_IMAGE_SIDE`] (the renderer's images are small, so bigger ones
/// would only cost cache misses); a scan's atlas may reach [`texture::MAX_ATLAS_SIDE`], and
/// shrinking it here would blend each triangle's cell with its neighbours' (a network of
/// lines along every triangle's edges, and a quarter of the texels: a kitchen's 4096 x 2048
/// atlas was rendered at 1024 x 512 until this allowed the atlas's side).
const MAX_TEXTURE_SIDE: u32 = texture::MAX_ATLAS_SIDE;

/// Triangles smaller than this (m²) cover no pixel from any sensible distance; dropping them
/// keeps their undefined normals and texture gradients out of the renderer.
const MIN_AREA: f64 = 1e-10;

/// A triangle ready for the rasterizer: world-space corners, its plane, and the affine maps from
/// world points on the plane to texture coordinates (so a frame needs only rotations, no cross
/// products, to set up perspective-correct interpolation).
#[derive(Clone, Copy, Debug, PartialEq)]
pub(crate) struct SceneTri {
    /// Corners, world coordinates.
    pub v: [[f32; 3]; 3],
    /// Unit normal of the front face (counter-clockwise side).
    pub n: [f32; 3],
    /// Plane offset: `n · p = d` on the triangle.
    pub d: f32,
    /// `u = gu[0..3] · p + gu[3]` for world points `p` on the plane.
    pub gu: [f32; 4],
    /// `v = gv[0..3] · p + gv[3]`.
    pub gv: [f32; 4],
    /// Dominant-plane id (0 none).
    pub plane: u32,
    /// Index into [`RenderScene::materials`] (always valid).
    pub material: u16,
    /// The back face may be culled: the triangle belongs to a closed, consistently oriented,
    /// outward-facing mesh, whose back faces can only be seen from inside the solid.
    pub cull: bool,
}

impl SceneTri {
    /// Prepares a triangle; `None` when it is degenerate (zero area) or not finite, since such a
    /// triangle covers no pixel and has no plane to interpolate on.
    pub fn new(t: &Triangle, material: u16) -> Option<SceneTri> {
        let p = t.v.map(|q| [q.x as f64, q.y as f64, q.z as f64]);
        if !p.iter().flatten().all(|c| c.is_finite()) {
            return None;
        }
        let e1 = sub(p[1], p[0]);
        let e2 = sub(p[2], p[0]);
        let n = cross(e1, e2);
        let nn = dot(n, n);
        if !(nn.sqrt() / 2.0 > MIN_AREA) || !nn.is_finite() {
            return None;
        }
        let len = nn.sqrt();
        let unit = [n[0] / len, n[1] / len, n[2] / len];
        // Gradients of the barycentric coordinates of p1 and p2 within the plane.
        let ga = scale(cross(e2, n), 1.0 / nn);
        let gb = scale(cross(n, e1), 1.0 / nn);
        let uv =
            t.uv.map(|c| c.map(|x| if x.is_finite() { x as f64 } else { 0.0 }));
        let affine = |k: usize| -> [f32; 4] {
            let d1 = uv[1][k] - uv[0][k];
            let d2 = uv[2][k] - uv[0][k];
            let g = [
                d1 * ga[0] + d2 * gb[0],
                d1 * ga[1] + d2 * gb[1],
                d1 * ga[2] + d2 * gb[2],
            ];
            let h = uv[0][k] - dot(g, p[0]);
            [g[0] as f32, g[1] as f32, g[2] as f32, h as f32]
        };
        Some(SceneTri {
            v: p.map(|q| q.map(|c| c as f32)),
            n: unit.map(|c| c as f32),
            d: dot(unit, p[0]) as f32,
            gu: affine(0),
            gv: affine(1),
            plane: t.plane,
            material,
            cull: false,
        })
    }
}

/// One mip level: power-of-two sides so texture wrap is a bit mask.
#[derive(Clone, Debug)]
pub(crate) struct Level {
    /// `width - 1`.
    wmask: i32,
    /// `height - 1`.
    hmask: i32,
    /// `log2(width)`.
    wshift: u32,
    /// Texels per texture-coordinate unit along u and v.
    su: f32,
    sv: f32,
    /// sRGB texels packed `r | g << 8 | b << 16`, row-major.
    texels: Vec<u32>,
}

impl Level {
    /// The four texels around `(u, v)` (top-left, top-right, bottom-left, bottom-right, wrapping)
    /// and the fractions of the way to the right and bottom ones, in 1/256.
    #[inline(always)]
    fn bilinear_taps(&self, u: f32, v: f32) -> ([usize; 4], u32, u32) {
        let x = u * self.su - 0.5;
        let y = v * self.sv - 0.5;
        let (xi, yi) = (floor_i32(x), floor_i32(y));
        // Fractions in 1/256 (the `as i32` conversions are single instructions, unlike floor).
        let fx = ((x - xi as f32) * 256.0) as i32 as u32 & 0xff;
        let fy = ((y - yi as f32) * 256.0) as i32 as u32 & 0xff;
        let ix0 = xi & self.wmask;
        let iy0 = yi & self.hmask;
        let ix1 = (ix0 + 1) & self.wmask;
        let iy1 = (iy0 + 1) & self.hmask;
        let r0 = (iy0 << self.wshift) as usize;
        let r1 = (iy1 << self.wshift) as usize;
        let (ix0, ix1) = (ix0 as usize, ix1 as usize);
        ([r0 + ix0, r0 + ix1, r1 + ix0, r1 + ix1], fx, fy)
    }

    /// Index of the texel holding `(u, v)`, wrapping.
    #[inline(always)]
    fn nearest_index(&self, u: f32, v: f32) -> usize {
        let xi = floor_i32(u * self.su) & self.wmask;
        let yi = floor_i32(v * self.sv) & self.hmask;
        ((yi << self.wshift) | xi) as usize
    }
}

/// A mip-mapped texture.
#[derive(Clone, Debug)]
pub(crate) struct Mips {
    levels: Vec<Level>,
    /// Texels per uv unit of level 0, squared, along u and v (for the level of detail).
    pub su2: f32,
    /// See `su2`.
    pub sv2: f32,
}

impl Mips {
    /// Mip levels of a baked texture; a malformed texture (size and texel count disagree) becomes
    /// one texel of `fallback`, so a bad texture never stops a render. `cell`: the texture is
    /// an atlas of cells at least this many texels a side ([`Pattern::Atlas`], measured on
    /// `tex`): the levels stop where such a cell is one texel.
    fn new(tex: &Texture, fallback: [u8; 3], cell: Option<f64>) -> Mips {
        let ok = tex.width > 0
            && tex.height > 0
            && (tex.width as usize).checked_mul(tex.height as usize) == Some(tex.texels.len());
        let (w, h, texels) = if ok {
            (tex.width, tex.height, tex.texels.as_slice())
        } else {
            (1, 1, std::slice::from_ref(&fallback))
        };
        let repeat = tex
            .repeat_m
            .map(|r| if r.is_finite() && r > 1e-6 { r } else { 1.0 });
        let lin = luts();
        let src: Vec<[f32; 3]> = texels
            .iter()
            .map(|c| c.map(|x| lin.to_linear[x as usize]))
            .collect();
        let (tw, th) = (pot(w), pot(h));
        let mut cur = if (tw, th) == (w, h) {
            src
        } else {
            resample(&src, w as usize, h as usize, tw as usize, th as usize)
        };
        let (mut cw, mut ch) = (tw as usize, th as usize);
        // Levels 0 ..= log2(cell): the last one holds each cell's mean.
        let most = cell.map_or(usize::MAX, |c| c.max(1.0).log2().floor() as usize + 1);
        let mut levels = Vec::new();
        loop {
            levels.push(Level {
                wmask: cw as i32 - 1,
                hmask: ch as i32 - 1,
                wshift: cw.trailing_zeros(),
                su: cw as f32 / repeat[0],
                sv: ch as f32 / repeat[1],
                texels: cur.iter().map(|&c| pack(c.map(linear_to_srgb8))).collect(),
            });
            if (cw == 1 && ch == 1) || levels.len() == most {
                break;
            }
            let (nw, nh) = ((cw / 2).max(1), (ch / 2).max(1));
            let mut next = vec![[0.0f32; 3]; nw * nh];
            for y in 0..nh {
                for x in 0..nw {
                    let mut acc = [0.0f32; 3];
                    let xs = [(2 * x) % cw, (2 * x + 1) % cw];
                    let ys = [(2 * y) % ch, (2 * y + 1) % ch];
                    for yy in ys {
                        for xx in xs {
                            let c = cur[yy * cw + xx];
                            for k in 0..3 {
                                acc[k] += c[k] * 0.25;
                            }
                        }
                    }
                    next[y * nw + x] = acc;
                }
            }
            cur = next;
            cw = nw;
            ch = nh;
        }
        let (su, sv) = (levels[0].su, levels[0].sv);
        Mips {
            levels,
            su2: su * su,
            sv2: sv * sv,
        }
    }

    /// [`Mips::sample`] over a run of pixels, eight at a time. Eight neighbours nearly always
    /// sample one level the same way, nearest or bilinear (their footprints differ little), and
    /// then their levels, texel addresses and blends are computed in vector lanes, leaving only
    /// the fetches one at a time; otherwise each pixel is sampled on its own.
    #[inline(always)]
    pub fn sample_run(&self, u: &[f32], v: &[f32], rho2: &[f32], out: &mut [u32]) {
        const N: usize = 8;
        let mut chunks = out.chunks_exact_mut(N);
        let lanes = u
            .chunks_exact(N)
            .zip(v.chunks_exact(N))
            .zip(rho2.chunks_exact(N));
        for (o, ((u, v), r)) in (&mut chunks).zip(lanes) {
            let (mut e, mut lvl) = ([0i32; N], [0i32; N]);
            for k in 0..N {
                (e[k], lvl[k]) = self.level_of(r[k]);
            }
            let level = (0..N).all(|k| lvl[k] == lvl[0]);
            let near = (0..N).map(|k| self.nearest(e[k], lvl[k]));
            let (mut all_near, mut none_near) = (true, true);
            for n in near {
                all_near &= n;
                none_near &= !n;
            }
            if level && none_near {
                // All magnified on one level: taps and blends in lanes too.
                let l = &self.levels[lvl[0] as usize];
                let (mut taps, mut fx, mut fy) = ([[0usize; 4]; N], [0u32; N], [0u32; N]);
                for k in 0..N {
                    (taps[k], fx[k], fy[k]) = l.bilinear_taps(u[k], v[k]);
                }
                let c = taps.map(|t| t.map(|i| l.texels[i]));
                for k in 0..N {
                    o[k] = blend(c[k], fx[k], fy[k]);
                }
            } else if level && all_near {
                let l = &self.levels[lvl[0] as usize];
                let mut idx = [0usize; N];
                for k in 0..N {
                    idx[k] = l.nearest_index(u[k], v[k]);
                }
                for (o, i) in o.iter_mut().zip(idx) {
                    *o = l.texels[i];
                }
            } else {
                for k in 0..N {
                    o[k] = self.sample(u[k], v[k], r[k]);
                }
            }
        }
        for k in out.len() - out.len() % N..out.len() {
            out[k] = self.sample(u[k], v[k], rho2[k]);
        }
    }

    /// The texture's mean colour in linear light: of its last level (one texel, or an
    /// atlas's cell means).
    pub fn mean_linear(&self) -> [f32; 3] {
        let Some(last) = self.levels.last().filter(|l| !l.texels.is_empty()) else {
            return [0.0; 3];
        };
        let mut sum = [0.0f64; 3];
        for &c in &last.texels {
            for (k, shift) in [0, 8, 16].into_iter().enumerate() {
                let byte = ((c >> shift) & 0xff) as u8;
                sum[k] += f64::from(srgb_to_linear(f32::from(byte) / 255.0));
            }
        }
        sum.map(|s| (s / last.texels.len() as f64) as f32)
    }

    /// The level of detail for `rho2`, the squared texel footprint of a pixel on level 0:
    /// `floor(log2 rho²)` from the float's exponent, and the level where a pixel spans about one
    /// texel (`round(log2 rho)`: half a level rounds up), at most the last.
    #[inline(always)]
    fn level_of(&self, rho2: f32) -> (i32, i32) {
        let e = ((rho2.to_bits() >> 23) & 0xff) as i32 - 127;
        let last = self.levels.len() as i32 - 1;
        (e, ((e + 1) >> 1).max(0).min(last))
    }

    /// Where a pixel of footprint exponent `e` on level `lvl` takes the nearest texel: it is
    /// minified (covers a texel or more of level 0), so the level already averages what it
    /// covers; or it is on the last level, of one texel.
    #[inline(always)]
    fn nearest(&self, e: i32, lvl: i32) -> bool {
        e >= 0 || lvl == self.levels.len() as i32 - 1
    }

    /// Bilinear sample at `(u, v)` on the mip level whose texels are about one pixel big, given
    /// `rho2`, the squared texel footprint of a pixel on level 0. Returns packed sRGB.
    #[inline(always)]
    pub fn sample(&self, u: f32, v: f32, rho2: f32) -> u32 {
        let (e, lvl) = self.level_of(rho2);
        let l = &self.levels[lvl as usize];
        if self.nearest(e, lvl) {
            return l.texels[l.nearest_index(u, v)];
        }
        // Magnified: bilinear, so texels near the camera do not show as blocks.
        let (taps, fx, fy) = l.bilinear_taps(u, v);
        let c = taps.map(|i| l.texels[i]);
        blend(c, fx, fy)
    }
}

/// Bilinear blend of four packed sRGB texels (top-left, top-right, bottom-left, bottom-right)
/// with fractions in 1/256.
#[inline(always)]
fn blend(c: [u32; 4], fx: u32, fy: u32) -> u32 {
    lerp_packed(lerp_packed(c[0], c[1], fx), lerp_packed(c[2], c[3], fx), fy)
}

/// `min` as one instruction (`f32::min` also orders NaN, which costs several); returns `a` when
/// `b` is NaN.
#[inline(always)]
pub(crate) fn fmin(a: f32, b: f32) -> f32 {
    if b < a { b } else { a }
}

/// `max` as one instruction; returns `a` when `b` is NaN.
#[inline(always)]
pub(crate) fn fmax(a: f32, b: f32) -> f32 {
    if b > a { b } else { a }
}

/// `floor` by truncation (saturating for huge values; `f32::floor` is a library call on baseline
/// x86-64).
#[inline(always)]
pub(crate) fn floor_i32(x: f32) -> i32 {
    let i = x as i32;
    i.wrapping_sub(((i as f32) > x) as i32)
}

/// Linear interpolation of two packed sRGB texels, `f` in 0–256 (two channels at once in the
/// red/blue lanes, so four texels cost a handful of integer operations).
#[inline(always)]
fn lerp_packed(a: u32, b: u32, f: u32) -> u32 {
    let g = 256 - f;
    let rb = (((a & 0x00ff_00ff) * g + (b & 0x00ff_00ff) * f) >> 8) & 0x00ff_00ff;
    let gg = (((a & 0x0000_ff00) * g + (b & 0x0000_ff00) * f) >> 8) & 0x0000_ff00;
    rb | gg
}

/// Packs sRGB bytes as `r | g << 8 | b << 16`.
fn pack(c: [u8; 3]) -> u32 {
    c[0] as u32 | (c[1] as u32) << 8 | (c[2] as u32) << 16
}

/// The power of two nearest to `n` (in log scale), at most [`MAX_TEXTURE_SIDE`].
fn pot(n: u32) -> u32 {
    let n = n.clamp(1, MAX_TEXTURE_SIDE);
    let lo = 1u32 << (31 - n.leading_zeros());
    if lo == n {
        return n;
    }
    let hi = (lo * 2).min(MAX_TEXTURE_SIDE);
    if (n as f64) * (n as f64) >= (lo as f64) * (hi as f64) {
        hi
    } else {
        lo
    }
}

/// Bilinear resampling of a repeating texture to a new size (linear colour).
fn resample(src: &[[f32; 3]], w: usize, h: usize, nw: usize, nh: usize) -> Vec<[f32; 3]> {
    let mut out = vec![[0.0f32; 3]; nw * nh];
    for y in 0..nh {
        let fy = (y as f32 + 0.5) * h as f32 / nh as f32 - 0.5;
        let y0 = fy.floor();
        let ty = fy - y0;
        let ya = (y0 as isize).rem_euclid(h as isize) as usize;
        let yb = (ya + 1) % h;
        for x in 0..nw {
            let fx = (x as f32 + 0.5) * w as f32 / nw as f32 - 0.5;
            let x0 = fx.floor();
            let tx = fx - x0;
            let xa = (x0 as isize).rem_euclid(w as isize) as usize;
            let xb = (xa + 1) % w;
            let mut c = [0.0f32; 3];
            for (k, ck) in c.iter_mut().enumerate() {
                let top = src[ya * w + xa][k] * (1.0 - tx) + src[ya * w + xb][k] * tx;
                let bot = src[yb * w + xa][k] * (1.0 - tx) + src[yb * w + xb][k] * tx;
                *ck = top * (1.0 - ty) + bot * ty;
            }
            out[y * nw + x] = c;
        }
    }
    out
}

/// Lookup table from sRGB bytes to linear light.
pub(crate) struct Luts {
    /// sRGB byte → linear 0–1.
    pub to_linear: [f32; 256],
}

/// The sRGB transfer curve (linear 0–1 → sRGB byte), exact, for building mip levels.
pub(crate) fn linear_to_srgb8(x: f32) -> u8 {
    let t = x.clamp(0.0, 1.0);
    let s = if t <= 0.003_130_8 {
        12.92 * t
    } else {
        1.055 * t.powf(1.0 / 2.4) - 0.055
    };
    (s * 255.0 + 0.5).clamp(0.0, 255.0) as u8
}

/// The process-wide lookup table (built once, read by every renderer).
pub(crate) fn luts() -> &'static Luts {
    static LUTS: std::sync::OnceLock<Luts> = std::sync::OnceLock::new();
    LUTS.get_or_init(|| {
        let mut to_linear = [0.0f32; 256];
        for (i, v) in to_linear.iter_mut().enumerate() {
            *v = srgb_to_linear(i as f32 / 255.0);
        }
        Luts { to_linear }
    })
}

/// The sRGB transfer curve, inverted.
pub(crate) fn srgb_to_linear(s: f32) -> f32 {
    let s = s.clamp(0.0, 1.0);
    if s <= 0.040_45 {
        s / 12.92
    } else {
        ((s + 0.055) / 1.055).powf(2.4)
    }
}

/// What the shader needs of a material.
#[derive(Clone, Debug)]
pub(crate) struct SceneMaterial {
    /// `Material::color` in linear light (the flat colour of `shaded` mode); for an unlit
    /// material, times its texture's mean colour.
    pub albedo: [f32; 3],
    /// Light given off, after switched-off fixtures are accounted for.
    pub emissive: f32,
    /// A window pane: lit by daylight rather than by lamps.
    pub window: bool,
    /// Shown as it is, scaled only by [`RenderScene::unlit_gain`] (`Material::unlit`).
    pub unlit: bool,
    /// The baked texture.
    pub mips: Mips,
}

/// Light sources that are switched on, as parallel arrays.
#[derive(Clone, Debug, Default)]
pub(crate) struct Lights {
    /// Positions, metres.
    pub pos: Vec<[f32; 3]>,
    /// Intensities (1 = a typical ceiling panel).
    pub intensity: Vec<f32>,
}

/// The floor and ceiling of a labelled region, for choosing the lights of the camera's storey.
#[derive(Clone, Copy, Debug)]
pub(crate) struct Storey {
    min: [f32; 2],
    max: [f32; 2],
    floor: f32,
    ceiling: f32,
}

/// A uniform grid of cubic cells over the world's bounds; each cell lists the triangles whose
/// plane passes through it (compressed rows: `start[c]..start[c + 1]` into `items`).
#[derive(Clone, Debug)]
pub(crate) struct Grid {
    /// Corner of cell (0, 0, 0).
    pub lo: [f32; 3],
    /// Cell edge, metres.
    pub cell: f32,
    /// Cells along x, y, z.
    pub dims: [usize; 3],
    start: Vec<u32>,
    items: Vec<u32>,
}

impl Grid {
    /// An empty grid (for a world without triangles).
    fn empty() -> Grid {
        Grid {
            lo: [0.0; 3],
            cell: 1.0,
            dims: [1, 1, 1],
            start: vec![0, 0],
            items: Vec::new(),
        }
    }

    /// Builds the grid: about four triangle references per cell on average, cells no smaller
    /// than 25 cm and no more than 2²⁰ of them.
    fn new(tris: &[SceneTri]) -> Grid {
        if tris.is_empty() {
            return Grid::empty();
        }
        let mut lo = [f32::INFINITY; 3];
        let mut hi = [f32::NEG_INFINITY; 3];
        for t in tris {
            for p in &t.v {
                for k in 0..3 {
                    lo[k] = lo[k].min(p[k]);
                    hi[k] = hi[k].max(p[k]);
                }
            }
        }
        let ext: [f64; 3] = std::array::from_fn(|k| (hi[k] - lo[k]) as f64);
        let target = (tris.len() as f64 / 4.0).max(1.0);
        // Volume with each extent at least 1 m, so flat worlds still get a sensible cell size.
        let vol = ext.iter().map(|e| e.max(1.0)).product::<f64>();
        let mut cell = (vol / target).cbrt().max(0.25);
        let dims_for = |cell: f64| -> [usize; 3] {
            std::array::from_fn(|k| ((ext[k] / cell).floor() as usize + 1).max(1))
        };
        let mut dims = dims_for(cell);
        while dims.iter().product::<usize>() > 1 << 20 {
            cell *= 1.25;
            dims = dims_for(cell);
        }
        let cell = cell as f32;
        let mut grid = Grid {
            lo,
            cell,
            dims,
            start: Vec::new(),
            items: Vec::new(),
        };
        let mut pairs: Vec<(u32, u32)> = Vec::new();
        for (i, t) in tris.iter().enumerate() {
            let (a, b) = grid.range(
                [0, 1, 2].map(|k| t.v[0][k].min(t.v[1][k]).min(t.v[2][k])),
                [0, 1, 2].map(|k| t.v[0][k].max(t.v[1][k]).max(t.v[2][k])),
            );
            let half = cell * 0.5;
            // Radius of a cell projected on the triangle's normal, plus a little slack.
            let r = half * (t.n[0].abs() + t.n[1].abs() + t.n[2].abs()) + 1e-4;
            for z in a[2]..=b[2] {
                for y in a[1]..=b[1] {
                    for x in a[0]..=b[0] {
                        let c = [x, y, z].map(|i| i as f32);
                        let centre: [f32; 3] =
                            std::array::from_fn(|k| grid.lo[k] + (c[k] + 0.5) * cell);
                        let dist = t.n[0] * centre[0] + t.n[1] * centre[1] + t.n[2] * centre[2];
                        if (dist - t.d).abs() <= r {
                            pairs.push((grid.index([x, y, z]) as u32, i as u32));
                        }
                    }
                }
            }
        }
        let ncells = dims.iter().product::<usize>();
        let mut start = vec![0u32; ncells + 1];
        for &(c, _) in &pairs {
            start[c as usize + 1] += 1;
        }
        for c in 0..ncells {
            start[c + 1] += start[c];
        }
        let mut fill = start.clone();
        let mut items = vec![0u32; pairs.len()];
        for &(c, t) in &pairs {
            items[fill[c as usize] as usize] = t;
            fill[c as usize] += 1;
        }
        grid.start = start;
        grid.items = items;
        grid
    }

    /// Flat index of a cell.
    #[inline]
    pub fn index(&self, c: [usize; 3]) -> usize {
        (c[2] * self.dims[1] + c[1]) * self.dims[0] + c[0]
    }

    /// Cell coordinates of a point, clamped into the grid.
    #[inline]
    pub fn coord(&self, p: [f32; 3]) -> [usize; 3] {
        std::array::from_fn(|k| {
            let f = ((p[k] - self.lo[k]) / self.cell).floor();
            // `as usize` maps NaN and negatives to 0.
            (f as usize).min(self.dims[k] - 1)
        })
    }

    /// Inclusive cell range of an axis-aligned box.
    pub fn range(&self, lo: [f32; 3], hi: [f32; 3]) -> ([usize; 3], [usize; 3]) {
        (self.coord(lo), self.coord(hi))
    }

    /// World box of a cell.
    #[inline]
    pub fn cell_box(&self, c: usize) -> ([f32; 3], [f32; 3]) {
        let x = c % self.dims[0];
        let y = (c / self.dims[0]) % self.dims[1];
        let z = c / (self.dims[0] * self.dims[1]);
        let lo = [
            self.lo[0] + x as f32 * self.cell,
            self.lo[1] + y as f32 * self.cell,
            self.lo[2] + z as f32 * self.cell,
        ];
        (lo, lo.map(|v| v + self.cell))
    }

    /// Triangles listed in a cell.
    #[inline]
    pub fn items(&self, c: usize) -> &[u32] {
        let a = self.start[c] as usize;
        let b = self.start[c + 1] as usize;
        &self.items[a..b]
    }

    /// True when a cell lists no triangle.
    #[inline]
    pub fn is_empty(&self, c: usize) -> bool {
        self.start[c] == self.start[c + 1]
    }
}

/// Gives every scene a distinct number, so a renderer notices when it is handed another scene
/// and resets its per-triangle bookkeeping.
static NEXT_SCENE_ID: AtomicU64 = AtomicU64::new(1);

/// A [`World`] prepared once for rendering many frames: baked textures with mip levels,
/// triangles with precomputed planes and texture gradients (degenerate and non-finite triangles
/// dropped), the lights that are on, and a uniform grid of triangles that the renderer walks
/// front to back to skip what lies outside the view or behind walls.
///
/// Share one scene between threads by reference; give each thread its own
/// [`Renderer`](super::Renderer).
#[derive(Clone, Debug)]
pub struct RenderScene {
    pub(crate) id: u64,
    pub(crate) tris: Vec<SceneTri>,
    pub(crate) materials: Vec<SceneMaterial>,
    pub(crate) lights: Lights,
    pub(crate) storeys: Vec<Storey>,
    pub(crate) grid: Grid,
    pub(crate) ambient: f32,
    /// Radiance of an unlit surface per unit albedo: 1 at the default ambient level, in
    /// proportion to the ambient level otherwise (see `Atmosphere::DEFAULT_AMBIENT`).
    pub(crate) unlit_gain: f32,
    pub(crate) daylight: f32,
    pub(crate) haze: f32,
    pub(crate) haze_color: [f32; 3],
    /// Every triangle is unlit: a scan, whose gaps are filled in the photo-like modes
    /// (`render::fill`).
    pub(crate) scan: bool,
    dropped: usize,
}

impl RenderScene {
    /// Prepares `world`: bakes every material's texture, builds the grid and finds which back
    /// faces are safe to cull. Degenerate or non-finite triangles are dropped (see
    /// [`RenderScene::dropped_triangles`]); triangles naming a missing material get a grey one.
    pub fn new(world: &World) -> Result<RenderScene> {
        if world.triangles.len() >= u32::MAX as usize {
            return Err(SynthError::Config(format!(
                "{} triangles is more than the renderer can index",
                world.triangles.len()
            )));
        }
        if world.materials.len() >= u16::MAX as usize {
            return Err(SynthError::Config(format!(
                "{} materials is more than a material id can name",
                world.materials.len()
            )));
        }
        let atm = &world.atmosphere;
        let fallback = Material::plain("missing material", [0.6, 0.6, 0.6]);
        let fallback_id = world.materials.len() as u16;
        // A fixture's glow follows its lights: off when every light showing it is off.
        let mut glow: Vec<Option<f32>> = vec![None; world.materials.len()];
        for l in &world.lights {
            if let Some(g) = l.fixture.and_then(|m| glow.get_mut(m as usize)) {
                let on = if l.on && l.intensity.is_finite() {
                    l.intensity.max(0.0)
                } else {
                    0.0
                };
                *g = Some(g.unwrap_or(0.0).max(on));
            }
        }
        // Baking is most of the preparation of a world with many materials: in parallel (the
        // result does not depend on the order or the thread count).
        let all: Vec<&Material> = world.materials.iter().chain([&fallback]).collect();
        let mut materials: Vec<SceneMaterial> = all
            .par_iter()
            .enumerate()
            .map(|(i, m)| {
                let color = m.color.map(|c| if c.is_finite() { c } else { 0.5 });
                let emissive = if m.emissive.is_finite() {
                    m.emissive.clamp(0.0, 4.0)
                } else {
                    0.0
                };
                let fixture = glow.get(i).copied().flatten().unwrap_or(1.0).min(1.5);
                let byte = color.map(|c| (c.clamp(0.0, 1.0) * 255.0 + 0.5) as u8);
                let tex = texture::bake(m);
                let cell = match &m.pattern {
                    // The cell as baked: `bake` may have reduced the atlas.
                    Pattern::Atlas { image, cell } => Some(
                        f64::from(*cell) * f64::from(tex.width) / f64::from(image.width().max(1)),
                    ),
                    _ => None,
                };
                let mips = Mips::new(&tex, byte, cell);
                let mut albedo = color.map(srgb_to_linear);
                if m.unlit {
                    // A scan's flat colour is its photographs' mean, not the glTF factor
                    // (white): `shaded` mode then shows its form in its own tone.
                    let mean = mips.mean_linear();
                    albedo = [0, 1, 2].map(|k| albedo[k] * mean[k]);
                }
                SceneMaterial {
                    albedo,
                    emissive: emissive * fixture,
                    window: matches!(m.pattern, Pattern::Window),
                    unlit: m.unlit,
                    mips,
                }
            })
            .collect();
        materials.shrink_to_fit();

        let mut tris = Vec::with_capacity(world.triangles.len());
        for t in &world.triangles {
            let m = if (t.material as usize) < world.materials.len() {
                t.material
            } else {
                fallback_id
            };
            if let Some(st) = SceneTri::new(t, m) {
                tris.push(st);
            }
        }
        let dropped = world.triangles.len() - tris.len();
        mark_cullable(&mut tris);
        let grid = Grid::new(&tris);

        let mut lights = Lights::default();
        for l in &world.lights {
            let p = [l.position.x, l.position.y, l.position.z];
            if l.on
                && l.intensity.is_finite()
                && l.intensity > 0.0
                && p.iter().all(|c| c.is_finite())
            {
                lights.pos.push(p);
                lights.intensity.push(l.intensity);
            }
        }
        let storeys = world
            .regions
            .iter()
            .map(|r| Storey {
                min: r.min,
                max: r.max,
                floor: r.floor_z,
                ceiling: r.ceiling_z,
            })
            .collect();
        let finite01 = |x: f32, default: f32| if x.is_finite() { x.max(0.0) } else { default };
        let ambient = finite01(atm.ambient, Atmosphere::DEFAULT_AMBIENT);
        let scan = !tris.is_empty()
            && tris
                .iter()
                .all(|t| materials[usize::from(t.material)].unlit);
        Ok(RenderScene {
            id: NEXT_SCENE_ID.fetch_add(1, Ordering::Relaxed),
            tris,
            materials,
            lights,
            storeys,
            grid,
            ambient,
            unlit_gain: ambient / Atmosphere::DEFAULT_AMBIENT,
            daylight: finite01(atm.daylight, 0.0),
            haze: finite01(atm.haze, 0.0),
            haze_color: atm.haze_color.map(|c| srgb_to_linear(finite01(c, 0.5))),
            scan,
            dropped,
        })
    }

    /// Triangles the renderer draws.
    pub fn triangle_count(&self) -> usize {
        self.tris.len()
    }

    /// Triangles of the world left out because they were degenerate (zero area) or had
    /// non-finite corners.
    pub fn dropped_triangles(&self) -> usize {
        self.dropped
    }

    /// Lights that are switched on.
    pub fn light_count(&self) -> usize {
        self.lights.pos.len()
    }

    /// The material index a world material id maps to (missing ids → the grey fallback).
    pub(crate) fn material_index(&self, id: u16) -> u16 {
        if (id as usize) < self.materials.len() - 1 {
            id
        } else {
            (self.materials.len() - 1) as u16
        }
    }

    /// Floor and ceiling heights of the storey at `p`, if `p` is in a labelled region: the
    /// region's floor, and the highest ceiling of the regions on that floor. A doorway is a
    /// region of its own with the door's height as its ceiling; taking that ceiling would leave
    /// out every lamp of the rooms on either side and render a camera passing through the door
    /// dark for a frame or two.
    pub(crate) fn storey_at(&self, p: [f32; 3]) -> Option<(f32, f32)> {
        let here = self.storeys.iter().find(|s| {
            p[0] >= s.min[0]
                && p[0] <= s.max[0]
                && p[1] >= s.min[1]
                && p[1] <= s.max[1]
                && p[2] >= s.floor
                && p[2] < s.ceiling
        })?;
        let ceiling = self
            .storeys
            .iter()
            .filter(|s| (s.floor - here.floor).abs() < 0.05)
            .fold(here.ceiling, |c, s| c.max(s.ceiling));
        Some((here.floor, ceiling))
    }

    /// True when the segment `from → to` hits a triangle of the scene (fixtures — emissive
    /// materials — excepted, so a lamp does not shadow itself). Walks the grid with a 3-D DDA;
    /// `stamps` marks triangles already tested on this ray.
    pub(crate) fn occluded(&self, from: [f32; 3], to: [f32; 3], stamps: &mut Stamps) -> bool {
        let stamp = stamps.next();
        let g = &self.grid;
        let dir = sub32(to, from);
        let len = dot32(dir, dir).sqrt();
        if !(len > 1e-6) {
            return false;
        }
        // Clip the segment to the grid box.
        let mut t0 = 0.0f32;
        let mut t1 = 1.0f32;
        for k in 0..3 {
            let lo = g.lo[k];
            let hi = g.lo[k] + g.cell * g.dims[k] as f32;
            if dir[k].abs() < 1e-12 {
                if from[k] < lo || from[k] > hi {
                    return false;
                }
            } else {
                let a = (lo - from[k]) / dir[k];
                let b = (hi - from[k]) / dir[k];
                t0 = t0.max(a.min(b));
                t1 = t1.min(a.max(b));
            }
        }
        if t0 > t1 {
            return false;
        }
        let start: [f32; 3] = std::array::from_fn(|k| from[k] + dir[k] * t0);
        let mut c = g.coord(start);
        let mut step = [0isize; 3];
        let mut t_max = [f32::INFINITY; 3];
        let mut t_delta = [f32::INFINITY; 3];
        for k in 0..3 {
            if dir[k] > 0.0 {
                step[k] = 1;
                let edge = g.lo[k] + (c[k] + 1) as f32 * g.cell;
                t_max[k] = (edge - from[k]) / dir[k];
                t_delta[k] = g.cell / dir[k];
            } else if dir[k] < 0.0 {
                step[k] = -1;
                let edge = g.lo[k] + c[k] as f32 * g.cell;
                t_max[k] = (edge - from[k]) / dir[k];
                t_delta[k] = -g.cell / dir[k];
            }
        }
        let max_steps = g.dims.iter().sum::<usize>() + 3;
        for _ in 0..max_steps {
            for &ti in g.items(g.index(c)) {
                let slot = &mut stamps.marks[ti as usize];
                if *slot == stamp {
                    continue;
                }
                *slot = stamp;
                let t = &self.tris[ti as usize];
                if self.materials[t.material as usize].emissive > 0.0 {
                    continue;
                }
                if segment_hits(t, from, dir) {
                    return true;
                }
            }
            // Next cell along the ray.
            let k = if t_max[0] < t_max[1] {
                if t_max[0] < t_max[2] { 0 } else { 2 }
            } else if t_max[1] < t_max[2] {
                1
            } else {
                2
            };
            if t_max[k] > t1 {
                return false;
            }
            let next = c[k] as isize + step[k];
            if next < 0 || next >= g.dims[k] as isize {
                return false;
            }
            c[k] = next as usize;
            t_max[k] += t_delta[k];
        }
        false
    }
}

/// Möller–Trumbore: does the segment `from + s·dir`, `s ∈ (0, 1)`, cross the triangle?
fn segment_hits(t: &SceneTri, from: [f32; 3], dir: [f32; 3]) -> bool {
    let e1 = sub32(t.v[1], t.v[0]);
    let e2 = sub32(t.v[2], t.v[0]);
    let p = cross32(dir, e2);
    let det = dot32(e1, p);
    if det.abs() < 1e-12 {
        return false;
    }
    let inv = 1.0 / det;
    let s = sub32(from, t.v[0]);
    let u = dot32(s, p) * inv;
    if !(0.0..=1.0).contains(&u) {
        return false;
    }
    let q = cross32(s, e1);
    let v = dot32(dir, q) * inv;
    if v < 0.0 || u + v > 1.0 {
        return false;
    }
    let along = dot32(e2, q) * inv;
    along > 1e-4 && along < 1.0
}

/// Marks the triangles whose back faces are never visible from outside a solid: those of closed
/// (every directed edge has exactly one reversed twin), outward-oriented (positive signed volume)
/// connected meshes. Open sheets, double-sided walls (zero volume) and inward-facing room boxes
/// keep both faces, since a camera may stand on either side of them.
fn mark_cullable(tris: &mut [SceneTri]) {
    let mut vid: HashMap<[u32; 3], u32> = HashMap::new();
    let mut corners = Vec::with_capacity(tris.len());
    for t in tris.iter() {
        let ids = t.v.map(|p| {
            // +0.0 folds −0.0 into 0.0 so both spell the same vertex.
            let key = p.map(|c| (c + 0.0).to_bits());
            let next = vid.len() as u32;
            *vid.entry(key).or_insert(next)
        });
        corners.push(ids);
    }
    let mut edges: HashMap<(u32, u32), (u32, u32)> = HashMap::new(); // edge → (count, triangle)
    for (i, c) in corners.iter().enumerate() {
        for k in 0..3 {
            let e = edges.entry((c[k], c[(k + 1) % 3])).or_insert((0, i as u32));
            e.0 += 1;
        }
    }
    let mut parent: Vec<u32> = (0..tris.len() as u32).collect();
    fn find(parent: &mut [u32], mut x: u32) -> u32 {
        while parent[x as usize] != x {
            let up = parent[parent[x as usize] as usize];
            parent[x as usize] = up;
            x = up;
        }
        x
    }
    let mut closed_tri = vec![true; tris.len()];
    for (i, c) in corners.iter().enumerate() {
        for k in 0..3 {
            let (a, b) = (c[k], c[(k + 1) % 3]);
            let fwd = edges.get(&(a, b)).map(|e| e.0).unwrap_or(0);
            match edges.get(&(b, a)) {
                Some(&(1, j)) if fwd == 1 && a != b => {
                    let (ra, rb) = (find(&mut parent, i as u32), find(&mut parent, j));
                    if ra != rb {
                        parent[ra as usize] = rb;
                    }
                }
                _ => closed_tri[i] = false,
            }
        }
    }
    let n = tris.len();
    let mut closed = vec![true; n];
    let mut volume = vec![0.0f64; n];
    let mut area = vec![0.0f64; n];
    for i in 0..n {
        let r = find(&mut parent, i as u32) as usize;
        closed[r] &= closed_tri[i];
        let v = tris[i].v.map(|p| p.map(|c| c as f64));
        volume[r] += dot(v[0], cross(v[1], v[2])) / 6.0;
        let n2 = cross(sub(v[1], v[0]), sub(v[2], v[0]));
        area[r] += dot(n2, n2).sqrt() / 2.0;
    }
    for (i, t) in tris.iter_mut().enumerate() {
        let r = find(&mut parent, i as u32) as usize;
        // Thin double-sided sheets have ~zero volume: demand a volume that a real solid has.
        t.cull = closed[r] && volume[r] > 1e-4 * area[r].powf(1.5);
    }
}

fn sub(a: [f64; 3], b: [f64; 3]) -> [f64; 3] {
    [a[0] - b[0], a[1] - b[1], a[2] - b[2]]
}
fn dot(a: [f64; 3], b: [f64; 3]) -> f64 {
    a[0] * b[0] + a[1] * b[1] + a[2] * b[2]
}
fn cross(a: [f64; 3], b: [f64; 3]) -> [f64; 3] {
    [
        a[1] * b[2] - a[2] * b[1],
        a[2] * b[0] - a[0] * b[2],
        a[0] * b[1] - a[1] * b[0],
    ]
}
fn scale(a: [f64; 3], s: f64) -> [f64; 3] {
    a.map(|x| x * s)
}
pub(crate) fn sub32(a: [f32; 3], b: [f32; 3]) -> [f32; 3] {
    [a[0] - b[0], a[1] - b[1], a[2] - b[2]]
}
pub(crate) fn dot32(a: [f32; 3], b: [f32; 3]) -> f32 {
    a[0] * b[0] + a[1] * b[1] + a[2] * b[2]
}
pub(crate) fn cross32(a: [f32; 3], b: [f32; 3]) -> [f32; 3] {
    [
        a[1] * b[2] - a[2] * b[1],
        a[2] * b[0] - a[0] * b[2],
        a[0] * b[1] - a[1] * b[0],
    ]
}

#[cfg(test)]
mod tests {
    use super::*;

    /// Red and blue cells of 4 texels, alternating along each row, as `recon`'s atlas packs
    /// triangles.
    fn cell_atlas(w: u32, h: u32) -> Texture {
        Texture {
            width: w,
            height: h,
            texels: (0..w * h)
                .map(|i| match (i % w) / 4 % 2 {
                    0 => [200, 40, 40],
                    _ => [40, 40, 200],
                })
                .collect(),
            repeat_m: [1.0, 1.0],
        }
    }

    #[test]
    fn a_scan_atlas_keeps_every_texel_of_its_cells() {
        let (w, h) = (texture::MAX_ATLAS_SIDE, 8);
        let tex = cell_atlas(w, h);
        let mips = Mips::new(&tex, [0; 3], None);
        let level = &mips.levels[0];
        assert_eq!((level.wmask + 1, level.hmask + 1), (w as i32, h as i32));
        for x in [0, 3, 4, 7, 2048, w as usize - 1] {
            assert_eq!(level.texels[x], pack(tex.texels[x]), "texel {x}");
        }
    }

    /// Past the cell, a mip level of an atlas would average unrelated triangles' cells (red and
    /// blue into purple): an atlas's levels stop at the cell, whose one texel is its mean.
    #[test]
    fn an_atlas_mip_chain_stops_where_a_cell_is_one_texel() {
        let tex = cell_atlas(64, 16);
        let atlas = Mips::new(&tex, [0; 3], Some(4.0));
        assert_eq!(atlas.levels.len(), 3);
        let last = atlas.levels.last().unwrap();
        assert_eq!((last.wmask + 1, last.hmask + 1), (16, 4));
        for (x, &c) in last.texels[..16].iter().enumerate() {
            let cell = if x % 2 == 0 {
                [200, 40, 40]
            } else {
                [40, 40, 200]
            };
            assert_eq!(c, pack(cell), "cell {x}");
        }
        // Any footprint, however large, samples a cell's own colour.
        let far = atlas.sample(0.5 / 64.0, 0.5, 1e6);
        assert_eq!(far, pack([200, 40, 40]));
        let mean = atlas.mean_linear();
        assert!((mean[0] - mean[2]).abs() < 1e-6 && mean[0] > mean[1]);

        let image = Mips::new(&tex, [0; 3], None);
        assert_eq!(image.levels.len(), 7);
        let mixed = image.levels[3].texels[0];
        assert_ne!(
            mixed,
            pack([200, 40, 40]),
            "a plain image's level 3 mixes the cells"
        );
    }

    #[test]
    fn textures_between_powers_of_two_are_rounded_in_log_scale() {
        assert_eq!(pot(1000), 1024);
        assert_eq!(pot(700), 512);
        assert_eq!(pot(4096), 4096);
        assert_eq!(pot(10_000), texture::MAX_ATLAS_SIDE);
    }
}
