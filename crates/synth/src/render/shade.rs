//! The second, shading pass: per output pixel, the visible triangle's depth, texture and light,
//! computed once per pixel after visibility is settled.
//!
//! Lighting is Lambertian from point lights with a softened inverse-square falloff and a smooth
//! range limit ([`RANGE`]); each 16x16 tile of the image takes the ≤ 8 lights nearest to what it
//! shows, from the lights of the camera's storey that can reach the view. Light varies slowly
//! over a surface, so it is evaluated exactly on a grid of every fourth pixel and interpolated in
//! between from the grid nodes that see the same surface (the same dominant plane, or the same
//! triangle off the planes); a pixel with no such node near it is lit exactly. Interpolating
//! across tiles also hides the seams that per-tile light lists would leave. Without shadows,
//! light passes through walls (a lamp in the next room brightens this side of the floor a
//! little); with `shadows`, every light is tested with a ray through the scene's grid.
//!
//! An unlit surface (`Material::unlit`, a scan's photographed texture) takes none of this: its
//! radiance is its albedo times the scene's `unlit_gain`, 1 under the default atmosphere, so
//! a render reproduces the photograph's colours (up to the sensor's tone curve, vignetting and
//! noise) instead of lighting its baked-in light a second time. Haze still applies. In `shaded`
//! mode, which shows no textures, an unlit surface takes its texture's mean colour lit by a
//! headlight (30 % ambient, 70 % by the cosine to the view ray), so a scan's form shows.

// `!(x > y)` is deliberate here: it is also true for NaN, which must fail the check.
#![allow(clippy::neg_cmp_op_on_partial_ord)]

use super::RenderMode;
use super::lens::Lens;
use super::post::Sensor;
use super::raster::{NONE, Raster, Stamps, View, VisTri};
use super::scene::{RenderScene, dot32, luts};
use super::span;

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
/// Spacing of the grid where light is evaluated exactly, pixels (a power of two).
const STEP_BITS: usize = 2;
const STEP: usize = 1 << STEP_BITS;

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

/// What a tile shows: its range of `1/z` and of raster positions.
#[derive(Clone, Copy, Debug)]
struct TileExtent {
    w: [f32; 2],
    sx: [f32; 2],
    sy: [f32; 2],
}

impl TileExtent {
    const EMPTY: TileExtent = TileExtent {
        w: [f32::MAX, f32::MIN],
        sx: [f32::MAX, f32::MIN],
        sy: [f32::MAX, f32::MIN],
    };
}

/// Where shaded pixels go.
pub(crate) enum Sink<'a> {
    /// Straight to sRGB bytes, with the sensor model (a frame of one exposure).
    Bytes(&'a mut [u8], Sensor),
    /// Into linear radiance, set (`true`) or added (motion-blur sub-frames).
    Accum(&'a mut [[f32; 3]], bool),
}

/// Per-pixel results of the resolve step, per-tile light lists and the light grid, reused
/// between frames.
#[derive(Debug, Default)]
pub(crate) struct Shade {
    /// Visible triangle per output pixel (index into the raster's `vis`, [`NONE`]: nothing).
    pub vis: Vec<u32>,
    /// `1/z` per output pixel (0: nothing).
    pub w: Vec<f32>,
    extent: Vec<TileExtent>,
    tiles: Vec<TileLights>,
    tiles_w: usize,
    /// Lights of this frame: (squared distance to the camera, light index).
    cand: Vec<(f32, u32)>,
    /// Light grid: nodes per row and column.
    nodes: [usize; 2],
    /// Irradiance at each node.
    node_e: Vec<f32>,
    /// What each node sees: its dominant plane, or its triangle where it has none (see
    /// [`light_key`]).
    node_id: Vec<u32>,
    /// Radiance of the row being shaded (red, green, blue) and its bytes.
    row: (Vec<f32>, Vec<f32>, Vec<f32>, super::post::RowBytes),
    /// Per pixel column: the light-grid nodes on either side and the weight of the right one.
    cols: Vec<(u32, u32, f32)>,
    /// Per pixel row: the same for the nodes above and below.
    rows: Vec<(u32, u32, f32)>,
    /// Per-row arrays of the shader.
    arrays: super::span::RowArrays,
    width: usize,
    height: usize,
}

impl Shade {
    /// Per output pixel: which triangle and its exact `1/z` at the pixel's (lens-mapped) raster
    /// position; per tile, the range of what it shows.
    #[inline(always)]
    pub fn resolve(&mut self, raster: &Raster, lens: &Lens, w: usize, h: usize) {
        let n = w * h;
        if self.width != w || self.height != h {
            self.vis.resize(n, NONE);
            self.w.resize(n, 0.0);
            self.tiles_w = w.div_ceil(TILE);
            let tiles = self.tiles_w * h.div_ceil(TILE);
            self.extent.resize(tiles, TileExtent::EMPTY);
            self.tiles.resize(tiles, TileLights::default());
            self.nodes = [(w - 1).div_ceil(STEP) + 1, (h - 1).div_ceil(STEP) + 1];
            self.node_e.resize(self.nodes[0] * self.nodes[1], 0.0);
            self.node_id.resize(self.nodes[0] * self.nodes[1], NONE);
            let table = |n: usize, nodes: usize| -> Vec<(u32, u32, f32)> {
                (0..n)
                    .map(|x| {
                        let (k, f) = grid_pos(x, n);
                        (k as u32, (k + 1).min(nodes - 1) as u32, f)
                    })
                    .collect()
            };
            self.cols = table(w, self.nodes[0]);
            self.rows = table(h, self.nodes[1]);
            self.width = w;
            self.height = h;
        }
        self.extent.fill(TileExtent::EMPTY);
        if lens.map.is_empty() {
            self.vis.copy_from_slice(&raster.ids[..n]);
            self.w.copy_from_slice(&raster.zbuf[..n]);
            for y in 0..h {
                let trow = (y / TILE) * self.tiles_w;
                for tx in 0..self.tiles_w {
                    let x0 = tx * TILE;
                    let x1 = (x0 + TILE).min(w);
                    let (mut lo, mut hi) = (f32::MAX, f32::MIN);
                    for &v in &self.w[y * w + x0..y * w + x1] {
                        if v > 0.0 {
                            lo = lo.min(v);
                            hi = hi.max(v);
                        }
                    }
                    if lo <= hi {
                        let e = &mut self.extent[trow + tx];
                        e.w = [e.w[0].min(lo), e.w[1].max(hi)];
                        e.sx = [x0 as f32 - 0.5, x1 as f32 - 0.5];
                        e.sy = [e.sy[0].min(y as f32 - 0.5), y as f32 + 0.5];
                    }
                }
            }
            return;
        }
        for y in 0..h {
            let trow = (y / TILE) * self.tiles_w;
            for x in 0..w {
                let i = y * w + x;
                let s = lens.map[i];
                let id = raster.ids.get(s.idx as usize).copied().unwrap_or(NONE);
                let wv = if id == NONE {
                    0.0
                } else {
                    raster.vis[id as usize].w_at(s.sx, s.sy)
                };
                if !(wv > 0.0 && wv.is_finite()) {
                    self.vis[i] = NONE;
                    self.w[i] = 0.0;
                    continue;
                }
                self.vis[i] = id;
                self.w[i] = wv;
                let e = &mut self.extent[trow + x / TILE];
                e.w = [e.w[0].min(wv), e.w[1].max(wv)];
                e.sx = [e.sx[0].min(s.sx), e.sx[1].max(s.sx)];
                e.sy = [e.sy[0].min(s.sy), e.sy[1].max(s.sy)];
            }
        }
    }

    /// Chooses the lights of the frame, then of every tile.
    #[inline(always)]
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
            if let Some((floor, ceiling)) = storey
                && (p[2] < floor - 0.3 || p[2] > ceiling + 0.3)
            {
                continue;
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
        for (t, ext) in self.extent.iter().enumerate() {
            let tl = &mut self.tiles[t];
            *tl = TileLights::default();
            if !(ext.w[0] <= ext.w[1]) || self.cand.is_empty() {
                continue;
            }
            // World box of the tile's frustum slice between its nearest and farthest depth.
            let (z0, z1) = (1.0 / ext.w[1], 1.0 / ext.w[0]);
            let mut lo = [f32::MAX; 3];
            let mut hi = [f32::MIN; 3];
            for sx in ext.sx {
                for sy in ext.sy {
                    for z in [z0, z1] {
                        let p = view.point(sx, sy, z);
                        for k in 0..3 {
                            lo[k] = lo[k].min(p[k]);
                            hi[k] = hi[k].max(p[k]);
                        }
                    }
                }
            }
            let mut best = [(f32::MAX, 0u32); MAX_LIGHTS];
            let mut count = 0;
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

    /// Raster position of output pixel `i` at `(x, y)`.
    #[inline(always)]
    fn sample_pos(lens: &Lens, i: usize, x: usize, y: usize) -> (f32, f32) {
        if lens.map.is_empty() {
            (x as f32, y as f32)
        } else {
            (lens.map[i].sx, lens.map[i].sy)
        }
    }

    /// Direct irradiance at output pixel `(x, y)` (which sees a triangle); `stamps` is for
    /// shadow rays, when `shadows`.
    #[allow(clippy::too_many_arguments)]
    #[inline(always)]
    fn irradiance_at(
        &self,
        scene: &RenderScene,
        vis: &[VisTri],
        stamps: &mut Stamps,
        lens: &Lens,
        view: &View,
        x: usize,
        y: usize,
        shadows: bool,
    ) -> f32 {
        let i = y * self.width + x;
        let t = &vis[self.vis[i] as usize];
        let n = t.n;
        let (sx, sy) = Self::sample_pos(lens, i, x, y);
        let p = view.point(sx, sy, 1.0 / self.w[i]);
        let tl = &self.tiles[(y / TILE) * self.tiles_w + x / TILE];
        if tl.n == 0 {
            0.0
        } else if shadows {
            shadowed(scene, stamps, tl, p, n)
        } else if tl.n <= 4 {
            direct4(tl, p, n)
        } else {
            direct8(tl, p, n)
        }
    }

    /// Shades every output pixel into `sink`.
    #[allow(clippy::too_many_arguments)]
    #[inline(always)]
    pub fn shade(
        &mut self,
        scene: &RenderScene,
        raster: &mut Raster,
        lens: &Lens,
        view: &View,
        mode: RenderMode,
        shadows: bool,
        sink: Sink<'_>,
    ) {
        let (w, h) = (self.width, self.height);
        let vis = &raster.vis;
        let stamps = &mut raster.stamps;
        let mut exact = 0u32;
        // Light on the grid of every STEP-th pixel.
        let [nx, ny] = self.nodes;
        for j in 0..ny {
            let y = (j * STEP).min(h - 1);
            for k in 0..nx {
                let x = (k * STEP).min(w - 1);
                let id = self.vis[y * w + x];
                let (e, key) = if id == NONE {
                    (0.0, NONE)
                } else {
                    let e = self.irradiance_at(scene, vis, stamps, lens, view, x, y, shadows);
                    (e, light_key(&vis[id as usize], id))
                };
                self.node_e[j * nx + k] = e;
                self.node_id[j * nx + k] = key;
            }
        }
        let lut = luts();
        let background = if scene.haze > 0.0 {
            scene.haze_color
        } else {
            [0.0; 3]
        };
        let textured = mode != RenderMode::Shaded;
        let cam = view.cam;
        let direct = lens.map.is_empty();
        let mats = &scene.materials;
        let mut rowbuf = std::mem::take(&mut self.row);
        let (rr, rg, rb, bytes_tmp) = &mut rowbuf;
        for v in [&mut *rr, &mut *rg, &mut *rb] {
            v.resize(w, 0.0);
        }
        let mut a = std::mem::take(&mut self.arrays);
        a.resize(w);
        let finisher = match &sink {
            Sink::Bytes(_, s) => Some(super::post::Finisher::new(*s, w, h)),
            Sink::Accum(..) => None,
        };
        let mut sink = sink;
        for y in 0..h {
            let (j0, j1, fy) = self.rows[y];
            let (j0, j1) = (j0 as usize, j1 as usize);
            let row = y * w;
            let vis_row = &self.vis[row..row + w];
            let w_row = &self.w[row..row + w];
            let (id0, id1) = (
                &self.node_id[j0 * nx..][..nx],
                &self.node_id[j1 * nx..][..nx],
            );
            let (e0, e1) = (&self.node_e[j0 * nx..][..nx], &self.node_e[j1 * nx..][..nx]);
            if direct {
                // (An `i32` counter: it converts to `f32` in vector lanes, a `usize` does not.)
                for ((sx, sy), x) in a.sx.iter_mut().zip(a.sy.iter_mut()).zip(0i32..) {
                    (*sx, *sy) = (x as f32, y as f32);
                }
            } else {
                for ((sx, sy), s) in a.sx.iter_mut().zip(a.sy.iter_mut()).zip(&lens.map[row..]) {
                    (*sx, *sy) = (s.sx, s.sy);
                }
            }
            span::grid_row(&mut a.grid_e, &self.cols, (e0, e1), fy);
            span::grid_keys(&mut a.keys, &self.cols, id0, id1);
            // Runs of pixels that see one triangle (or nothing).
            let mut x0 = 0;
            while x0 < w {
                let id = vis_row[x0];
                let x1 = x0 + vis_row[x0..].iter().take_while(|&&v| v == id).count();
                let run = x0..x1;
                x0 = x1;
                let (r, g, b) = (
                    &mut rr[run.clone()],
                    &mut rg[run.clone()],
                    &mut rb[run.clone()],
                );
                if id == NONE {
                    r.fill(background[0]);
                    g.fill(background[1]);
                    b.fill(background[2]);
                    continue;
                }
                let t = &vis[id as usize];
                let m = &mats[t.material as usize];
                let key = light_key(t, id);
                // Light: interpolated on the grid where the four nodes around a pixel see this
                // surface.
                let keys = [0, 1, 2, 3].map(|k| &a.keys[k][run.clone()]);
                if span::grid_light(&mut a.e[run.clone()], &a.grid_e[run.clone()], keys, key) {
                    for x in run.clone() {
                        let (k0, k1, fx) = self.cols[x];
                        let (k0, k1) = (k0 as usize, k1 as usize);
                        let same = [id0[k0], id0[k1], id1[k0], id1[k1]].map(|n| n == key);
                        if same[0] && same[1] && same[2] && same[3] {
                            continue;
                        }
                        a.e[x] = if same[0] || same[1] || same[2] || same[3] {
                            // Near an edge of the surface: the bilinear weights of the nodes
                            // on it, renormalised (light varies little over the few pixels to
                            // them).
                            let wts = [
                                (1.0 - fx) * (1.0 - fy),
                                fx * (1.0 - fy),
                                (1.0 - fx) * fy,
                                fx * fy,
                            ];
                            let vals = [e0[k0], e0[k1], e1[k0], e1[k1]];
                            let (mut sw, mut se) = (0.0, 0.0);
                            for k in 0..4 {
                                if same[k] {
                                    sw += wts[k];
                                    se += wts[k] * vals[k];
                                }
                            }
                            if sw > 0.05 {
                                se / sw
                            } else {
                                exact += 1;
                                self.irradiance_at(scene, vis, stamps, lens, view, x, y, shadows)
                            }
                        } else {
                            exact += 1;
                            self.irradiance_at(scene, vis, stamps, lens, view, x, y, shadows)
                        };
                    }
                }
                let (sx, sy) = (&a.sx[run.clone()], &a.sy[run.clone()]);
                let ws = &w_row[run.clone()];
                let flat = if textured {
                    span::tex_coords(
                        t,
                        m,
                        (sx, sy, ws),
                        &mut a.u[run.clone()],
                        &mut a.v[run.clone()],
                        &mut a.rho2[run.clone()],
                    );
                    let texels = &mut a.texel[run.clone()];
                    m.mips.sample_run(
                        &a.u[run.clone()],
                        &a.v[run.clone()],
                        &a.rho2[run.clone()],
                        texels,
                    );
                    let px = r.iter_mut().zip(g.iter_mut()).zip(b.iter_mut());
                    for (((r, g), b), &c) in px.zip(&*texels) {
                        *r = lut.to_linear[(c & 0xff) as usize];
                        *g = lut.to_linear[((c >> 8) & 0xff) as usize];
                        *b = lut.to_linear[((c >> 16) & 0xff) as usize];
                    }
                    None
                } else {
                    Some(m.albedo)
                };
                let e = &a.e[run.clone()];
                if m.unlit && textured {
                    // Its light is in its colours already (a scan's photographs).
                    span::radiance((r, g, b), e, flat, |_| scene.unlit_gain);
                } else if m.unlit {
                    // `shaded` has no photograph to show, and a scan has no lamps: a headlight
                    // shows its form, as a BIM model's shaded render does.
                    let albedo = m.albedo;
                    for ((((r, g), b), &sx), &sy) in r
                        .iter_mut()
                        .zip(g.iter_mut())
                        .zip(b.iter_mut())
                        .zip(sx)
                        .zip(sy)
                    {
                        let ray = [0, 1, 2]
                            .map(|k| view.ray0[k] + sx * view.ray_x[k] + sy * view.ray_y[k]);
                        let cos = dot32(t.n, ray).abs() / dot32(ray, ray).sqrt();
                        let light = scene.unlit_gain * (0.3 + 0.7 * cos);
                        (*r, *g, *b) = (albedo[0] * light, albedo[1] * light, albedo[2] * light);
                    }
                } else {
                    let (ambient, daylight) = (scene.ambient, scene.daylight);
                    span::radiance((r, g, b), e, flat, |e| {
                        span::lit(m, e, ambient, daylight, WINDOW_GAIN, EMISSIVE_GAIN)
                    });
                }
                if scene.haze > 0.0 {
                    let px = r.iter_mut().zip(g.iter_mut()).zip(b.iter_mut());
                    for ((((r, g), b), (&sx, &sy)), &wv) in px.zip(sx.iter().zip(sy)).zip(ws) {
                        let z = 1.0 / wv;
                        let rx = (sx - cam.cx) / cam.fx;
                        let ry = (sy - cam.cy) / cam.fy;
                        let dist = z * (1.0 + rx * rx + ry * ry).sqrt();
                        let f = (-scene.haze * dist).exp();
                        let hc = scene.haze_color;
                        *r = *r * f + hc[0] * (1.0 - f);
                        *g = *g * f + hc[1] * (1.0 - f);
                        *b = *b * f + hc[2] * (1.0 - f);
                    }
                }
            }
            match &mut sink {
                Sink::Bytes(bytes, _) => {
                    if let Some(f) = &finisher {
                        f.row(
                            y,
                            1.0,
                            rr,
                            rg,
                            rb,
                            bytes_tmp,
                            &mut bytes[3 * row..3 * (row + w)],
                        );
                    }
                }
                Sink::Accum(acc, first) => {
                    let acc_row = &mut acc[row..row + w];
                    for (a, ((&r, &g), &b)) in acc_row.iter_mut().zip(rr.iter().zip(&*rg).zip(&*rb))
                    {
                        if *first {
                            *a = [r, g, b];
                        } else {
                            a[0] += r;
                            a[1] += g;
                            a[2] += b;
                        }
                    }
                }
            }
        }
        self.arrays = a;
        self.row = rowbuf;
        raster.stats.lit_exactly = exact;
    }
}

/// Which surface a pixel's light belongs to: light is continuous over a dominant plane (one
/// position-and-normal field however the plane is split into triangles), so its id serves; a
/// triangle off the dominant planes is its own surface.
#[inline(always)]
fn light_key(t: &VisTri, id: u32) -> u32 {
    if t.plane != 0 {
        t.plane & 0x7fff_ffff
    } else {
        0x8000_0000 | id
    }
}

/// The light-grid cell of pixel coordinate `x` (of `n`) and the fraction of the way to the next
/// node (nodes at multiples of STEP and at the last pixel).
#[inline(always)]
fn grid_pos(x: usize, n: usize) -> (usize, f32) {
    let k = x >> STEP_BITS;
    let a = k << STEP_BITS;
    let b = (a + STEP).min(n - 1);
    let f = if b > a {
        if b - a == STEP {
            (x - a) as f32 * (1.0 / STEP as f32)
        } else {
            (x - a) as f32 / (b - a) as f32
        }
    } else {
        0.0
    };
    (k, f)
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
fn shadowed(
    scene: &RenderScene,
    stamps: &mut Stamps,
    tl: &TileLights,
    p: [f32; 3],
    n: [f32; 3],
) -> f32 {
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
        let end = [
            from[0] + d[0] * short,
            from[1] + d[1] * short,
            from[2] + d[2] * short,
        ];
        if !scene.occluded(from, end, stamps) {
            sum += c;
        }
    }
    sum
}
