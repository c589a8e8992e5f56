//! The second, shading pass: per output pixel, the visible triangle's depth, world position,
//! texture and light — computed once per pixel, after visibility is settled.
//!
//! Lighting is Lambertian from point lights with a softened inverse-square falloff and a smooth
//! range limit ([`RANGE`]); each 16x16 tile of the image takes the ≤ 8 lights nearest to what
//! it shows, from the lights of the camera's storey that can reach the view. Without shadows,
//! light passes through walls (a lamp in the next room brightens this side of the floor a
//! little); with `shadows` every light is tested by a ray through the scene's grid.

use super::RenderMode;
use super::lens::Lens;
use super::raster::{NONE, Raster, View, VisTri};
use super::scene::{Luts, RenderScene, dot32, luts};

/// Tile side for light lists, pixels.
const TILE: usize = 16;
/// Lights per tile.
const MAX_LIGHTS: usize = 8;
/// Lights considered per frame (the nearest that can reach the view).
const MAX_FRAME_LIGHTS: usize = 64;
/// A light's reach, metres: its contribution fades smoothly to zero there.
pub(crate) const RANGE: f32 = 9.0;
/// Squared softening distance of the falloff (a panel is not a point).
const SOFT2: f32 = 0.25;
/// Irradiance scale of a light of intensity 1: a floor 2.7 m under a panel gets about 0.65.
const LIGHT_GAIN: f32 = 5.0;
/// Radiance of a fully emissive surface per unit albedo (saturates to white).
const EMISSIVE_GAIN: f32 = 2.5;
/// Radiance of a window per unit albedo at full daylight.
const WINDOW_GAIN: f32 = 1.6;

/// The lights of one tile, as parallel arrays padded with zero-intensity lights so the loop over
/// them has a fixed length and vectorizes.
#[derive(Clone, Copy, Debug, Default)]
struct TileLights {
    x: [f32; MAX_LIGHTS],
    y: [f32; MAX_LIGHTS],
    z: [f32; MAX_LIGHTS],
    i: [f32; MAX_LIGHTS],
    n: usize,
}

/// Per-pixel results of the resolve step and per-tile light lists, reused between frames.
#[derive(Debug, Default)]
pub(crate) struct Shade {
    /// Visible triangle per output pixel (index into the raster's `vis`, [`NONE`]: nothing).
    pub vis: Vec<u32>,
    /// `1/z` per output pixel (0: nothing).
    pub w: Vec<f32>,
    /// World position per output pixel.
    pos: Vec<[f32; 3]>,
    /// Bounding box of what each tile shows.
    tile_box: Vec<([f32; 3], [f32; 3])>,
    tiles: Vec<TileLights>,
    tiles_w: usize,
    /// Lights of this frame: (squared distance to the camera, light index).
    cand: Vec<(f32, u32)>,
    width: usize,
    height: usize,
}

impl Shade {
    /// Per output pixel: which triangle, its exact `1/z` at the pixel's (lens-mapped) raster
    /// position, and its world position; per tile, the box of world positions.
    pub fn resolve(&mut self, raster: &Raster, lens: &Lens, view: &View, w: usize, h: usize) {
        let n = w * h;
        if self.width != w || self.height != h {
            self.vis.resize(n, NONE);
            self.w.resize(n, 0.0);
            self.pos.resize(n, [0.0; 3]);
            self.tiles_w = w.div_ceil(TILE);
            let tiles = self.tiles_w * h.div_ceil(TILE);
            self.tile_box.resize(tiles, ([0.0; 3], [0.0; 3]));
            self.tiles.resize(tiles, TileLights::default());
            self.width = w;
            self.height = h;
        }
        let empty = ([f32::MAX; 3], [f32::MIN; 3]);
        self.tile_box.fill(empty);
        let direct = lens.map.is_empty();
        for y in 0..h {
            let trow = (y / TILE) * self.tiles_w;
            for x in 0..w {
                let i = y * w + x;
                let (sx, sy, ri) = if direct {
                    (x as f32, y as f32, i)
                } else {
                    let s = lens.map[i];
                    (s.sx, s.sy, s.idx as usize)
                };
                let id = raster.ids.get(ri).copied().unwrap_or(NONE);
                let wv = if id == NONE {
                    0.0
                } else if direct {
                    raster.zbuf[ri]
                } else {
                    raster.vis[id as usize].w_at(sx, sy)
                };
                if !(wv > 0.0 && wv.is_finite()) {
                    self.vis[i] = NONE;
                    self.w[i] = 0.0;
                    continue;
                }
                self.vis[i] = id;
                self.w[i] = wv;
                let p = view.point(sx, sy, 1.0 / wv);
                self.pos[i] = p;
                let b = &mut self.tile_box[trow + x / TILE];
                for k in 0..3 {
                    b.0[k] = b.0[k].min(p[k]);
                    b.1[k] = b.1[k].max(p[k]);
                }
            }
        }
    }

    /// Chooses the lights of the frame, then of every tile.
    pub fn choose_lights(&mut self, scene: &RenderScene, view: &View) {
        self.cand.clear();
        let storey = scene.storey_at(view.c);
        for (i, (p, &inten)) in scene
            .lights
            .pos
            .iter()
            .zip(&scene.lights.intensity)
            .enumerate()
        {
            if let Some((floor, ceiling)) = storey {
                if p[2] < floor - 0.3 || p[2] > ceiling + 0.3 {
                    continue;
                }
            }
            if inten <= 0.0 || !view.sphere_in_view(*p, RANGE) {
                continue;
            }
            let d = [p[0] - view.c[0], p[1] - view.c[1], p[2] - view.c[2]];
            self.cand.push((dot32(d, d), i as u32));
        }
        self.cand
            .sort_unstable_by(|a, b| a.0.total_cmp(&b.0).then(a.1.cmp(&b.1)));
        self.cand.truncate(MAX_FRAME_LIGHTS);
        let range2 = RANGE * RANGE;
        for (t, (lo, hi)) in self.tile_box.iter().enumerate() {
            let mut best = [(f32::MAX, 0u32); MAX_LIGHTS];
            let mut count = 0;
            if lo[0] <= hi[0] {
                for &(_, li) in &self.cand {
                    let p = scene.lights.pos[li as usize];
                    let d2: f32 = (0..3)
                        .map(|k| {
                            let d = (lo[k] - p[k]).max(p[k] - hi[k]).max(0.0);
                            d * d
                        })
                        .sum();
                    if d2 >= range2 {
                        continue;
                    }
                    // Insertion into the sorted list of the nearest.
                    let mut j = count.min(MAX_LIGHTS - 1);
                    if count == MAX_LIGHTS && d2 >= best[j].0 {
                        continue;
                    }
                    while j > 0 && best[j - 1].0 > d2 {
                        best[j] = best[j - 1];
                        j -= 1;
                    }
                    best[j] = (d2, li);
                    count = (count + 1).min(MAX_LIGHTS);
                }
            }
            let tl = &mut self.tiles[t];
            *tl = TileLights::default();
            tl.n = count;
            for (k, &(_, li)) in best[..count].iter().enumerate() {
                let p = scene.lights.pos[li as usize];
                tl.x[k] = p[0];
                tl.y[k] = p[1];
                tl.z[k] = p[2];
                tl.i[k] = scene.lights.intensity[li as usize] * LIGHT_GAIN;
            }
        }
    }

    /// Linear radiance of every output pixel into `accum` (added to it unless `first`).
    #[allow(clippy::too_many_arguments)]
    pub fn shade(
        &self,
        scene: &RenderScene,
        raster: &mut Raster,
        lens: &Lens,
        view: &View,
        mode: RenderMode,
        shadows: bool,
        accum: &mut [[f32; 3]],
        first: bool,
    ) {
        let lut = luts();
        let (w, h) = (self.width, self.height);
        let background = if scene.haze > 0.0 {
            scene.haze_color
        } else {
            [0.0; 3]
        };
        let textured = mode != RenderMode::Shaded;
        let direct = lens.map.is_empty();
        for y in 0..h {
            let trow = (y / TILE) * self.tiles_w;
            for x in 0..w {
                let i = y * w + x;
                let id = self.vis[i];
                let rad = if id == NONE {
                    background
                } else {
                    let t = raster.vis[id as usize];
                    let (sx, sy) = if direct {
                        (x as f32, y as f32)
                    } else {
                        (lens.map[i].sx, lens.map[i].sy)
                    };
                    let tl = &self.tiles[trow + x / TILE];
                    self.pixel(scene, raster, lut, &t, tl, i, sx, sy, textured, shadows, view)
                };
                if first {
                    accum[i] = rad;
                } else {
                    for k in 0..3 {
                        accum[i][k] += rad[k];
                    }
                }
            }
        }
    }

    /// Radiance of one covered pixel.
    #[allow(clippy::too_many_arguments)]
    #[inline(always)]
    fn pixel(
        &self,
        scene: &RenderScene,
        raster: &mut Raster,
        lut: &Luts,
        t: &VisTri,
        tl: &TileLights,
        i: usize,
        sx: f32,
        sy: f32,
        textured: bool,
        shadows: bool,
        view: &View,
    ) -> [f32; 3] {
        let m = &scene.materials[t.material as usize];
        let wv = self.w[i];
        let z = 1.0 / wv;
        let p = self.pos[i];
        let albedo = if textured {
            let uz = t.u[0] * sx + (t.u[1] * sy + t.u[2]);
            let vz = t.v[0] * sx + (t.v[1] * sy + t.v[2]);
            let u = uz * z;
            let v = vz * z;
            // Screen derivatives of u and v: d(u)/dx = z·(du/z/dx − u·d(1/z)/dx).
            let dudx = z * (t.u[0] - u * t.w[0]);
            let dudy = z * (t.u[1] - u * t.w[1]);
            let dvdx = z * (t.v[0] - v * t.w[0]);
            let dvdy = z * (t.v[1] - v * t.w[1]);
            let rx = dudx * dudx * m.mips.su2 + dvdx * dvdx * m.mips.sv2;
            let ry = dudy * dudy * m.mips.su2 + dvdy * dvdy * m.mips.sv2;
            let c = m.mips.sample(u, v, rx.max(ry));
            [
                lut.to_linear[(c & 0xff) as usize],
                lut.to_linear[((c >> 8) & 0xff) as usize],
                lut.to_linear[((c >> 16) & 0xff) as usize],
            ]
        } else {
            m.albedo
        };
        let direct = if tl.n == 0 {
            0.0
        } else if shadows {
            shadowed(scene, raster, tl, p, t.n)
        } else if tl.n <= 4 {
            direct4(tl, p, t.n)
        } else {
            direct8(tl, p, t.n)
        };
        let e = scene.ambient + direct;
        let mut light = if m.window {
            0.05 + 0.3 * e + WINDOW_GAIN * scene.daylight
        } else {
            e
        };
        light += m.emissive * EMISSIVE_GAIN;
        let mut rad = albedo.map(|a| a * light);
        if scene.haze > 0.0 {
            let d = [p[0] - view.c[0], p[1] - view.c[1], p[2] - view.c[2]];
            let f = (-scene.haze * dot32(d, d).sqrt()).exp();
            for k in 0..3 {
                rad[k] = rad[k] * f + scene.haze_color[k] * (1.0 - f);
            }
        }
        rad
    }
}

/// Irradiance of one light at `p` with normal `n` (light already scaled by the gain).
#[inline(always)]
fn one_light(lx: f32, ly: f32, lz: f32, li: f32, p: [f32; 3], n: [f32; 3]) -> f32 {
    let dx = lx - p[0];
    let dy = ly - p[1];
    let dz = lz - p[2];
    let d2 = dx * dx + dy * dy + dz * dz;
    let ndl = n[0] * dx + n[1] * dy + n[2] * dz;
    let ndl = if ndl > 0.0 { ndl } else { 0.0 };
    // Smooth range window (1 − (d/R)²)², zero beyond the range.
    let q = 1.0 - d2 * (1.0 / (RANGE * RANGE));
    let q = if q > 0.0 { q * q } else { 0.0 };
    // cos θ / (d² + soft²) with cos θ = n·l / d.
    li * q * ndl / ((d2 + 1e-12).sqrt() * (d2 + SOFT2))
}

/// Sum over the first four lights of a tile (branch-free, vectorizes).
#[inline(always)]
fn direct4(tl: &TileLights, p: [f32; 3], n: [f32; 3]) -> f32 {
    let mut acc = [0.0f32; 4];
    for (k, a) in acc.iter_mut().enumerate() {
        *a = one_light(tl.x[k], tl.y[k], tl.z[k], tl.i[k], p, n);
    }
    (acc[0] + acc[1]) + (acc[2] + acc[3])
}

/// Sum over all eight light slots of a tile.
#[inline(always)]
fn direct8(tl: &TileLights, p: [f32; 3], n: [f32; 3]) -> f32 {
    let mut acc = [0.0f32; MAX_LIGHTS];
    for (k, a) in acc.iter_mut().enumerate() {
        *a = one_light(tl.x[k], tl.y[k], tl.z[k], tl.i[k], p, n);
    }
    ((acc[0] + acc[1]) + (acc[2] + acc[3])) + ((acc[4] + acc[5]) + (acc[6] + acc[7]))
}

/// Like [`direct8`], but each light counts only when a ray to it is clear.
fn shadowed(scene: &RenderScene, raster: &mut Raster, tl: &TileLights, p: [f32; 3], n: [f32; 3]) -> f32 {
    let mut sum = 0.0;
    // Start the ray a little off the surface so it does not hit its own triangle.
    let from = [p[0] + n[0] * 2e-3, p[1] + n[1] * 2e-3, p[2] + n[2] * 2e-3];
    for k in 0..tl.n {
        let c = one_light(tl.x[k], tl.y[k], tl.z[k], tl.i[k], p, n);
        if c <= 1e-4 {
            continue;
        }
        let to = [tl.x[k], tl.y[k], tl.z[k]];
        // Stop a few centimetres short of the lamp, whose own fixture may surround it.
        let d = [to[0] - from[0], to[1] - from[1], to[2] - from[2]];
        let len = dot32(d, d).sqrt();
        let short = if len > 0.1 { (len - 0.05) / len } else { 0.0 };
        let end = [from[0] + d[0] * short, from[1] + d[1] * short, from[2] + d[2] * short];
        let stamp = raster.next_stamp();
        if !scene.occluded(from, end, &mut raster.stamps, stamp) {
            sum += c;
        }
    }
    sum
}
