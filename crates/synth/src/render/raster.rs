//! The rasterizer's first, visibility pass: which triangle is nearest at each raster pixel.
//!
//! Triangles come from the scene's grid, cell by cell, nearest cell first; a cell whose box lies
//! behind everything already drawn in its screen rectangle (a coarse max-depth buffer of 8x8
//! tiles) is skipped, which indoors removes everything behind the walls in view. Each triangle is
//! clipped against the near plane (and, when it projects absurdly far off screen, a guard band),
//! snapped to 1/16 pixel and filled with integer edge functions under the top-left rule, so
//! triangles sharing an edge cover every pixel centre along it exactly once. Only `1/z` and a
//! triangle index are written; shading happens once per pixel afterwards (deferred).

// `!(x > y)` is deliberate here: it is also true for NaN, which must fail the check.
#![allow(clippy::neg_cmp_op_on_partial_ord)]

use super::FrameStats;
use super::lens::RasterCam;
use super::scene::{Grid, RenderScene, SceneTri, dot32, fmax, fmin};
use crate::world::Triangle;
use geom::Pose;

/// No triangle at this pixel.
pub(crate) const NONE: u32 = u32::MAX;

/// Near clipping distance, metres: cameras stand close to walls, and `1/z` depth keeps full
/// precision however near the plane is.
pub(crate) const NEAR: f32 = 0.005;

/// Sub-pixel bits of snapped vertex positions.
const SUB_BITS: u32 = 4;
/// Sub-pixel steps per pixel.
const SUB: i64 = 1 << SUB_BITS;

/// Pixels past the raster's edge beyond which triangles are clipped, keeping fixed-point
/// coordinates (and edge-function products) far inside `i64`.
const GUARD: f32 = 4096.0;

/// Side of the square tiles of the coarse depth buffer, pixels.
const HIZ: usize = 8;

/// The camera of one (sub-)frame.
#[derive(Clone, Copy, Debug)]
pub(crate) struct View {
    /// The raster drawn into.
    pub cam: RasterCam,
    /// World → camera rotation, rows.
    pub rot: [[f32; 3]; 3],
    /// Camera centre, world.
    pub c: [f32; 3],
    /// Far clipping distance along the optical axis, metres.
    pub far: f32,
    /// Camera-space normals of the four side planes through the centre (inside: `n · p ≥ 0`).
    side: [[f32; 3]; 4],
    /// World-space planes of the frustum (`n · p + d ≥ 0` inside): four sides, near, far.
    planes: [[f32; 4]; 6],
    /// World ray through raster position `(sx, sy)`: `ray0 + sx·ray_x + sy·ray_y` (its camera z
    /// component is 1, so a point at depth z is `c + z·ray`).
    pub ray0: [f32; 3],
    /// See `ray0`.
    pub ray_x: [f32; 3],
    /// See `ray0`.
    pub ray_y: [f32; 3],
}

impl View {
    /// The view of a camera-to-world pose.
    pub fn new(pose: &Pose, cam: RasterCam, far: f32) -> View {
        let m = pose.rotation.inverse().to_rotation_matrix();
        let m = m.matrix();
        let rot: [[f32; 3]; 3] = std::array::from_fn(|r| std::array::from_fn(|k| m[(r, k)] as f32));
        let c = [0, 1, 2].map(|k| pose.translation[k] as f32);
        // Camera → world of a direction: the transpose of `rot`.
        let to_world = |v: [f32; 3]| -> [f32; 3] {
            std::array::from_fn(|k| rot[0][k] * v[0] + rot[1][k] * v[1] + rot[2][k] * v[2])
        };
        let (w, h) = (cam.w as f32, cam.h as f32);
        let side = [
            [cam.fx, 0.0, cam.cx + 0.5],
            [-cam.fx, 0.0, w - 0.5 - cam.cx],
            [0.0, cam.fy, cam.cy + 0.5],
            [0.0, -cam.fy, h - 0.5 - cam.cy],
        ];
        let mut planes = [[0.0f32; 4]; 6];
        for (p, s) in planes.iter_mut().zip(side.iter()) {
            // Unit normals, so plane values are distances (for spheres against the frustum).
            let n = to_world(*s);
            let len = dot32(n, n).sqrt().max(f32::MIN_POSITIVE);
            let n = n.map(|v| v / len);
            *p = [n[0], n[1], n[2], -dot32(n, c)];
        }
        let fwd = to_world([0.0, 0.0, 1.0]);
        planes[4] = [fwd[0], fwd[1], fwd[2], -dot32(fwd, c) - NEAR];
        planes[5] = [-fwd[0], -fwd[1], -fwd[2], dot32(fwd, c) + far];
        let rx = to_world([1.0 / cam.fx, 0.0, 0.0]);
        let ry = to_world([0.0, 1.0 / cam.fy, 0.0]);
        let r0 = to_world([-cam.cx / cam.fx, -cam.cy / cam.fy, 1.0]);
        View {
            cam,
            rot,
            c,
            far,
            side,
            planes,
            ray0: r0,
            ray_x: rx,
            ray_y: ry,
        }
    }

    /// True when a sphere reaches into the frustum (conservatively: it is not entirely outside
    /// one of its planes).
    pub fn sphere_in_view(&self, p: [f32; 3], r: f32) -> bool {
        self.planes
            .iter()
            .all(|pl| pl[0] * p[0] + pl[1] * p[1] + pl[2] * p[2] + pl[3] >= -r)
    }

    /// World point → camera coordinates.
    #[inline(always)]
    pub fn world_to_cam(&self, p: [f32; 3]) -> [f32; 3] {
        let d = [p[0] - self.c[0], p[1] - self.c[1], p[2] - self.c[2]];
        self.rotate(d)
    }

    /// World direction → camera coordinates.
    #[inline(always)]
    pub fn rotate(&self, d: [f32; 3]) -> [f32; 3] {
        [
            dot32(self.rot[0], d),
            dot32(self.rot[1], d),
            dot32(self.rot[2], d),
        ]
    }

    /// World point at raster position `(sx, sy)` and depth `z`.
    #[inline(always)]
    pub fn point(&self, sx: f32, sy: f32, z: f32) -> [f32; 3] {
        std::array::from_fn(|k| {
            self.c[k] + z * (self.ray0[k] + sx * self.ray_x[k] + sy * self.ray_y[k])
        })
    }
}

/// A triangle drawn this frame, with the screen-space planes the shader interpolates: `1/z`,
/// `u/z` and `v/z` are affine in raster position, so `value(sx, sy) = a·sx + (b·sy + c)`.
#[derive(Clone, Copy, Debug)]
pub(crate) struct VisTri {
    /// `1/z` plane.
    pub w: [f32; 3],
    /// `u/z` plane.
    pub u: [f32; 3],
    /// `v/z` plane.
    pub v: [f32; 3],
    /// World normal of the side facing the camera.
    pub n: [f32; 3],
    /// Dominant-plane id.
    pub plane: u32,
    /// Scene material index.
    pub material: u16,
}

impl VisTri {
    /// `1/z` at a raster position (the same expression the fill loop uses, so the direct path
    /// reads back exactly what the depth test compared).
    #[inline(always)]
    pub fn w_at(&self, sx: f32, sy: f32) -> f32 {
        self.w[0] * sx + (self.w[1] * sy + self.w[2])
    }
}

/// Buffers of the visibility pass, reused from frame to frame.
#[derive(Debug, Default)]
pub(crate) struct Raster {
    /// The raster.
    pub cam: Option<RasterCam>,
    /// `1/z` per raster pixel (0: nothing).
    pub zbuf: Vec<f32>,
    /// Index into `vis` per raster pixel ([`NONE`]: nothing).
    pub ids: Vec<u32>,
    /// Triangles that won at least one pixel when drawn.
    pub vis: Vec<VisTri>,
    /// Per coarse tile: the smallest `1/z` (farthest depth) of its pixels.
    hiz: Vec<f32>,
    /// Per coarse tile: `hiz` is stale.
    hiz_dirty: Vec<bool>,
    tiles_w: usize,
    /// Cells in view this frame: `(distance² bits << 32) | cell`.
    cells: Vec<u64>,
    /// The grid's cell edges along world x, y, z, in camera coordinates.
    cell_axes: [[f32; 3]; 3],
    /// Marks of triangles already visited this frame (or on this shadow ray).
    pub stamps: Stamps,
    /// The scene the stamps belong to.
    scene_id: u64,
    /// This frame's extra triangles, prepared.
    extra: Vec<SceneTri>,
    /// Counters of the last frame.
    pub stats: FrameStats,
}

/// Per scene triangle, the number of the last pass (frame or shadow ray) that visited it, so a
/// triangle listed in several grid cells is handled once per pass.
#[derive(Debug, Default)]
pub(crate) struct Stamps {
    /// Per triangle.
    pub marks: Vec<u32>,
    /// The current pass.
    pub stamp: u32,
}

impl Stamps {
    /// Starts a new pass (clearing the marks when the counter wraps).
    pub fn next(&mut self) -> u32 {
        self.stamp = self.stamp.wrapping_add(1);
        if self.stamp == 0 {
            self.marks.fill(0);
            self.stamp = 1;
        }
        self.stamp
    }
}

impl Raster {
    /// Sizes the buffers for a scene and a raster.
    fn prepare(&mut self, scene: &RenderScene, cam: RasterCam) {
        if self.scene_id != scene.id || self.stamps.marks.len() != scene.tris.len() {
            self.stamps.marks.clear();
            self.stamps.marks.resize(scene.tris.len(), 0);
            self.stamps.stamp = 0;
            self.scene_id = scene.id;
        }
        let n = cam.w * cam.h;
        if self.cam != Some(cam) {
            self.zbuf.resize(n, 0.0);
            self.ids.resize(n, NONE);
            self.tiles_w = cam.w.div_ceil(HIZ);
            let tiles = self.tiles_w * cam.h.div_ceil(HIZ);
            self.hiz.resize(tiles, 0.0);
            self.hiz_dirty.resize(tiles, false);
            self.cam = Some(cam);
        }
        self.zbuf.fill(0.0);
        self.ids.fill(NONE);
        self.hiz.fill(0.0);
        self.hiz_dirty.fill(false);
        self.vis.clear();
        self.stats = FrameStats::default();
    }

    /// Draws the scene and `extra` (this frame's people, drawn without the grid) for `view`.
    #[inline(always)]
    pub fn draw(&mut self, scene: &RenderScene, view: &View, extra: &[Triangle]) {
        self.prepare(scene, view.cam);
        // Extra triangles first: they stand near the camera and occlude cells behind them.
        let mut prepared = std::mem::take(&mut self.extra);
        prepared.clear();
        prepared.extend(
            extra
                .iter()
                .filter_map(|t| SceneTri::new(t, scene.material_index(t.material))),
        );
        for t in &prepared {
            self.draw_tri(t, view);
        }
        self.extra = prepared;

        let stamp = self.stamps.next();
        let g = scene.grid.cell;
        self.cell_axes = [
            view.rotate([g, 0.0, 0.0]),
            view.rotate([0.0, g, 0.0]),
            view.rotate([0.0, 0.0, g]),
        ];
        self.collect_cells(&scene.grid, view);
        let cells = std::mem::take(&mut self.cells);
        for &key in &cells {
            let cell = (key & 0xffff_ffff) as usize;
            if !self.cell_visible(&scene.grid, cell, view) {
                self.stats.cells_occluded += 1;
                continue;
            }
            for &ti in scene.grid.items(cell) {
                let slot = &mut self.stamps.marks[ti as usize];
                if *slot == stamp {
                    continue;
                }
                *slot = stamp;
                self.draw_tri(&scene.tris[ti as usize], view);
            }
        }
        self.cells = cells;
    }

    /// Lists the non-empty grid cells that intersect the view frustum, nearest first.
    fn collect_cells(&mut self, grid: &Grid, view: &View) {
        self.cells.clear();
        let cam = view.cam;
        // Bounding box of the frustum: the centre and the far corners.
        let mut lo = view.c;
        let mut hi = view.c;
        for (sx, sy) in [
            (-0.5, -0.5),
            (cam.w as f32 - 0.5, -0.5),
            (-0.5, cam.h as f32 - 0.5),
            (cam.w as f32 - 0.5, cam.h as f32 - 0.5),
        ] {
            let p = view.point(sx, sy, view.far);
            for k in 0..3 {
                lo[k] = lo[k].min(p[k]);
                hi[k] = hi[k].max(p[k]);
            }
        }
        let grid_hi: [f32; 3] =
            std::array::from_fn(|k| grid.lo[k] + grid.cell * grid.dims[k] as f32);
        if (0..3).any(|k| !(hi[k] >= grid.lo[k] && lo[k] <= grid_hi[k])) {
            return;
        }
        let (a, b) = grid.range(lo, hi);
        // A plane's value at a cell's most positive corner is affine in the cell's indices, so
        // along a row of cells each plane keeps an interval of x; the frustum keeps their
        // intersection (convex), found with six divisions per row instead of a test per cell.
        let g = grid.cell;
        // Exclusive ranges: inclusive ones cost an extra test per step.
        for z in a[2]..b[2] + 1 {
            for y in a[1]..b[1] + 1 {
                let (mut xa, mut xb) = (a[0] as f32, b[0] as f32);
                for p in &view.planes {
                    // Value at the corner of cell (0, y, z) that is most positive along p.
                    let corner = [0.0, y as f32, z as f32];
                    let mut c = p[3];
                    for k in 0..3 {
                        let off = if p[k] >= 0.0 { 1.0 } else { 0.0 };
                        c += p[k] * (grid.lo[k] + (corner[k] + off) * g);
                    }
                    let slope = p[0] * g;
                    // Keep x with c + slope·x ≥ 0, widened by a cell against rounding.
                    if slope > 1e-9 {
                        xa = xa.max((-c / slope).floor() - 1.0);
                    } else if slope < -1e-9 {
                        xb = xb.min((-c / slope).ceil() + 1.0);
                    } else if c < 0.0 {
                        xb = -1.0;
                    }
                }
                if !(xa <= xb) {
                    continue;
                }
                let row = grid.index([0, y, z]);
                for x in xa.max(a[0] as f32) as usize..xb.min(b[0] as f32) as usize + 1 {
                    let cell = row + x;
                    if grid.is_empty(cell) {
                        continue;
                    }
                    let (blo, bhi) = grid.cell_box(cell);
                    let d2: f32 = (0..3)
                        .map(|k| {
                            let d = (blo[k] - view.c[k]).max(view.c[k] - bhi[k]).max(0.0);
                            d * d
                        })
                        .sum();
                    self.cells.push(((d2.to_bits() as u64) << 32) | cell as u64);
                }
            }
        }
        self.cells.sort_unstable();
        self.stats.cells_in_view = self.cells.len() as u32;
    }

    /// False when the cell's box lies behind what is already drawn everywhere it projects. The
    /// corners' camera coordinates are one transform plus steps along the rotated cell edges.
    #[inline(always)]
    fn cell_visible(&mut self, grid: &Grid, cell: usize, view: &View) -> bool {
        let (lo, _) = grid.cell_box(cell);
        let cam = view.cam;
        let q0 = view.world_to_cam(lo);
        let [ex, ey, ez] = self.cell_axes;
        // The eight corners in lanes (corner `c` steps along x, y, z by its bits 0, 1, 2), so
        // their projection is a few vector instructions.
        let step = |c: usize, k: usize| -> f32 {
            let (a, b, c) = ((c & 1) as f32, ((c >> 1) & 1) as f32, ((c >> 2) & 1) as f32);
            q0[k] + a * ex[k] + b * ey[k] + c * ez[k]
        };
        let qx: [f32; 8] = std::array::from_fn(|c| step(c, 0));
        let qy: [f32; 8] = std::array::from_fn(|c| step(c, 1));
        let qz: [f32; 8] = std::array::from_fn(|c| step(c, 2));
        if qz.iter().any(|&z| !(z > NEAR)) {
            return true;
        }
        let (mut sx, mut sy) = ([0.0f32; 8], [0.0f32; 8]);
        for c in 0..8 {
            let iz = 1.0 / qz[c];
            sx[c] = cam.fx * qx[c] * iz + cam.cx;
            sy[c] = cam.fy * qy[c] * iz + cam.cy;
        }
        let x0 = sx.into_iter().fold(f32::MAX, fmin);
        let x1 = sx.into_iter().fold(f32::MIN, fmax);
        let y0 = sy.into_iter().fold(f32::MAX, fmin);
        let y1 = sy.into_iter().fold(f32::MIN, fmax);
        let zmin = qz.into_iter().fold(f32::MAX, fmin);
        !self.rect_hidden([x0, x1, y0, y1], zmin)
    }

    /// True when everything in the raster rectangle `[x0, x1, y0, y1]` (pixels) is already nearer
    /// than `zmin` (or the rectangle is off the raster).
    #[inline(always)]
    fn rect_hidden(&mut self, r: [f32; 4], zmin: f32) -> bool {
        let Some(cam) = self.cam else {
            return true;
        };
        let (wl, hl) = (cam.w as f32 - 1.0, cam.h as f32 - 1.0);
        let [x0, x1, y0, y1] = r;
        if !(x1 >= 0.0 && y1 >= 0.0 && x0 <= wl && y0 <= hl) {
            return true;
        }
        // Truncation is floor here (non-negative); one pixel more stands in for ceil.
        let tx0 = fmax(x0, 0.0) as usize / HIZ;
        let tx1 = (fmin(x1, wl) as usize + 1).min(cam.w - 1) / HIZ;
        let ty0 = fmax(y0, 0.0) as usize / HIZ;
        let ty1 = (fmin(y1, hl) as usize + 1).min(cam.h - 1) / HIZ;
        let wnear = 1.0 / zmin;
        for ty in ty0..ty1 + 1 {
            for tx in tx0..tx1 + 1 {
                // A stale value is at most the true one (pixels only come nearer), so it may
                // prove the tile hidden as it is; refresh it only when it cannot.
                let t = ty * self.tiles_w + tx;
                if wnear >= self.hiz[t] && (!self.hiz_dirty[t] || wnear >= self.hiz_at(tx, ty)) {
                    return false;
                }
            }
        }
        true
    }

    /// The farthest `1/z` of a coarse tile, refreshed if stale.
    #[inline(always)]
    fn hiz_at(&mut self, tx: usize, ty: usize) -> f32 {
        let t = ty * self.tiles_w + tx;
        if self.hiz_dirty[t] {
            let cam = self.cam.map(|c| (c.w, c.h)).unwrap_or((0, 0));
            let (x0, x1) = (tx * HIZ, ((tx + 1) * HIZ).min(cam.0));
            // One running minimum per column, reduced at the end: the same minimum (the buffer
            // holds no NaN) as a running scalar, but the compiler keeps the columns in vector
            // lanes.
            let mut lanes = [f32::MAX; HIZ];
            for y in ty * HIZ..((ty + 1) * HIZ).min(cam.1) {
                let row = &self.zbuf[y * cam.0 + x0..y * cam.0 + x1];
                if let Ok(row) = <&[f32; HIZ]>::try_from(row) {
                    for (m, &w) in lanes.iter_mut().zip(row) {
                        *m = fmin(*m, w);
                    }
                } else {
                    for (m, &w) in lanes.iter_mut().zip(row) {
                        *m = fmin(*m, w);
                    }
                }
            }
            self.hiz[t] = lanes.into_iter().fold(f32::MAX, fmin);
            self.hiz_dirty[t] = false;
        }
        self.hiz[t]
    }

    /// Culls, clips and fills one triangle.
    #[inline(always)]
    fn draw_tri(&mut self, t: &SceneTri, view: &View) {
        self.stats.triangles_tested += 1;
        // The triangle's plane in camera space is nc · q = dc; the camera (q = 0) sees the
        // front face when it lies on the normal's side: 0 > dc. (Tested first: it needs no
        // transformed corners.)
        let dc = t.d - dot32(t.n, view.c);
        // Edge-on (the plane passes through the eye) or not finite: covers nothing.
        if !(dc.abs() > 1e-7) {
            return;
        }
        let front = dc < 0.0;
        if t.cull && !front {
            return;
        }
        let p = t.v.map(|q| view.world_to_cam(q));
        let behind = [p[0][2] < NEAR, p[1][2] < NEAR, p[2][2] < NEAR];
        if behind[0] && behind[1] && behind[2] {
            return;
        }
        if p[0][2] > view.far && p[1][2] > view.far && p[2][2] > view.far {
            return;
        }
        for s in &view.side {
            if dot32(*s, p[0]) < 0.0 && dot32(*s, p[1]) < 0.0 && dot32(*s, p[2]) < 0.0 {
                return;
            }
        }
        // Clip (rarely needed) and project.
        let cam = view.cam;
        let mut a = [[0.0f32; 3]; 9];
        let mut b = [[0.0f32; 3]; 9];
        a[..3].copy_from_slice(&p);
        let mut n = 3;
        if behind[0] || behind[1] || behind[2] {
            n = clip(&a[..n], &mut b, |q| q[2] - NEAR);
            a = b;
            if n < 3 {
                return;
            }
        }
        let (lx, hx) = (-GUARD, cam.w as f32 + GUARD);
        let (ly, hy) = (-GUARD, cam.h as f32 + GUARD);
        let mut xy = [(0.0f32, 0.0f32); 9];
        let mut inside_band = true;
        for (o, q) in xy.iter_mut().zip(&a[..n]) {
            let iz = 1.0 / q[2];
            *o = (cam.fx * q[0] * iz + cam.cx, cam.fy * q[1] * iz + cam.cy);
            inside_band &= o.0 >= lx && o.0 <= hx && o.1 >= ly && o.1 <= hy;
        }
        if !inside_band {
            // x ≥ lx  ⇔  fx·X + (cx − lx)·Z ≥ 0, and so on for the other three sides.
            let planes = [
                [cam.fx, 0.0, cam.cx - lx],
                [-cam.fx, 0.0, hx - cam.cx],
                [0.0, cam.fy, cam.cy - ly],
                [0.0, -cam.fy, hy - cam.cy],
            ];
            for pl in planes {
                n = clip(&a[..n], &mut b, |q| dot32(pl, *q));
                a = b;
                if n < 3 {
                    return;
                }
            }
            for (o, q) in xy.iter_mut().zip(&a[..n]) {
                let iz = 1.0 / q[2];
                *o = (cam.fx * q[0] * iz + cam.cx, cam.fy * q[1] * iz + cam.cy);
            }
        }
        let mut rect = [f32::MAX, f32::MIN, f32::MAX, f32::MIN];
        let mut zmin = f32::MAX;
        for (&(x, y), q) in xy[..n].iter().zip(&a[..n]) {
            if !(x.is_finite() && y.is_finite()) {
                return;
            }
            rect = [
                fmin(rect[0], x),
                fmax(rect[1], x),
                fmin(rect[2], y),
                fmax(rect[3], y),
            ];
            zmin = fmin(zmin, q[2]);
        }
        // Hidden behind what is drawn already (most triangles of partly visible cells).
        if self.rect_hidden(rect, zmin) {
            return;
        }
        let nc = view.rotate(t.n);
        let inv = 1.0 / dc;
        let w = [
            nc[0] / cam.fx * inv,
            nc[1] / cam.fy * inv,
            (nc[2] - nc[0] * cam.cx / cam.fx - nc[1] * cam.cy / cam.fy) * inv,
        ];
        let id = self.vis.len() as u32;
        let mut wrote = false;
        // Round half away from zero (by truncation: `round` is a library call on baseline x86).
        let half = |v: f32| if v >= 0.0 { v + 0.5 } else { v - 0.5 };
        let snap = |(x, y): (f32, f32)| (half(x * SUB as f32) as i64, half(y * SUB as f32) as i64);
        let v0 = snap(xy[0]);
        for i in 1..n - 1 {
            wrote |= self.fill(v0, snap(xy[i]), snap(xy[i + 1]), id, w);
        }
        if !wrote {
            return;
        }
        self.stats.triangles_drawn += 1;
        // u = g · q + h in camera space; u/z = g · ray + h · (1/z).
        let uvplane = |g: [f32; 4]| -> [f32; 3] {
            let gc = view.rotate([g[0], g[1], g[2]]);
            let h = g[3] + dot32([g[0], g[1], g[2]], view.c);
            [
                gc[0] / cam.fx + h * w[0],
                gc[1] / cam.fy + h * w[1],
                gc[2] - gc[0] * cam.cx / cam.fx - gc[1] * cam.cy / cam.fy + h * w[2],
            ]
        };
        self.vis.push(VisTri {
            w,
            u: uvplane(t.gu),
            v: uvplane(t.gv),
            n: if front { t.n } else { t.n.map(|c| -c) },
            plane: t.plane,
            material: t.material,
        });
    }

    /// Fills a snapped triangle: depth test against `1/z` from the plane `w`, top-left rule.
    #[inline(always)]
    fn fill(&mut self, a: (i64, i64), b: (i64, i64), c: (i64, i64), id: u32, w: [f32; 3]) -> bool {
        let Some(cam) = self.cam else {
            return false;
        };
        let area = (b.0 - a.0) * (c.1 - a.1) - (b.1 - a.1) * (c.0 - a.0);
        if area == 0 {
            return false;
        }
        // Orient so the edge functions are positive inside (clockwise on a y-down screen).
        let (b, c) = if area > 0 { (b, c) } else { (c, b) };
        let min_x = a.0.min(b.0).min(c.0);
        let max_x = a.0.max(b.0).max(c.0);
        let min_y = a.1.min(b.1).min(c.1);
        let max_y = a.1.max(b.1).max(c.1);
        // Pixel centres (integer positions) inside the bounding box.
        let x0 = ((min_x + SUB - 1) >> SUB_BITS).max(0);
        let x1 = (max_x >> SUB_BITS).min(cam.w as i64 - 1);
        let y0 = ((min_y + SUB - 1) >> SUB_BITS).max(0);
        let y1 = (max_y >> SUB_BITS).min(cam.h as i64 - 1);
        if x0 > x1 || y0 > y1 {
            return false;
        }
        // Edge p→q: E(P) = (q.x − p.x)(P.y − p.y) − (q.y − p.y)(P.x − p.x), at the first
        // pixel centre, with its steps per pixel in x and y. A pixel centre exactly on an edge
        // belongs to the triangle only for a top edge (horizontal, going right) or a left edge
        // (going up); the other triangle on that edge sees it reversed, so exactly one of them
        // draws it.
        let edge = |p: (i64, i64), q: (i64, i64)| -> (i64, i64, i64) {
            let dx = q.0 - p.0;
            let dy = q.1 - p.1;
            let top_left = dy < 0 || (dy == 0 && dx > 0);
            let e = dx * (y0 * SUB - p.1) - dy * (x0 * SUB - p.0) - if top_left { 0 } else { 1 };
            (e, -dy * SUB, dx * SUB)
        };
        let (mut r0, sx0, sy0) = edge(a, b);
        let (mut r1, sx1, sy1) = edge(b, c);
        let (mut r2, sx2, sy2) = edge(c, a);
        let width = cam.w;
        let mut wrote = false;
        // Wide triangles: find each row's span from the edge functions (a float estimate made
        // exact with the integer test) instead of scanning the bounding box from its left.
        let wide = x1 - x0 > 8;
        let kmax = x1 - x0;
        let inv = [sx0, sx1, sx2].map(|s| if s != 0 { 1.0 / s as f64 } else { 0.0 });
        for y in y0..y1 + 1 {
            let row = y as usize * width;
            let wrow = w[1] * y as f32 + w[2];
            let (mut k0, mut k1) = (0, kmax);
            if wide {
                for ((r, s), inv) in [r0, r1, r2].into_iter().zip([sx0, sx1, sx2]).zip(inv) {
                    let (a, b) = edge_span(r, s, kmax, inv);
                    k0 = k0.max(a);
                    k1 = k1.min(b);
                }
            }
            if wide && k0 <= k1 {
                // The span is exact: every pixel in it is inside, so the loop is only the depth
                // test, which vectorizes.
                let span = row + (x0 + k0) as usize..row + (x0 + k1) as usize + 1;
                let mut any = false;
                for ((z, idx), x) in self.zbuf[span.clone()]
                    .iter_mut()
                    .zip(&mut self.ids[span])
                    .zip((x0 + k0) as i32..)
                {
                    // (`i32` converts to `f32` in vector lanes; `i64` would not.)
                    let wv = w[0] * x as f32 + wrow;
                    let nearer = wv > *z;
                    *z = if nearer { wv } else { *z };
                    *idx = if nearer { id } else { *idx };
                    any |= nearer;
                }
                wrote |= any;
            } else if k0 <= k1 {
                let (mut e0, mut e1, mut e2) = (r0 + sx0 * k0, r1 + sx1 * k0, r2 + sx2 * k0);
                let span = row + (x0 + k0) as usize..row + (x0 + k1) as usize + 1;
                let mut seen = false;
                for ((z, idx), x) in self.zbuf[span.clone()]
                    .iter_mut()
                    .zip(&mut self.ids[span])
                    .zip(x0 + k0..)
                {
                    if (e0 | e1 | e2) >= 0 {
                        seen = true;
                        let wv = w[0] * x as f32 + wrow;
                        if wv > *z {
                            *z = wv;
                            *idx = id;
                            wrote = true;
                        }
                    } else if seen {
                        // Convex: the span of this row is over.
                        break;
                    }
                    e0 += sx0;
                    e1 += sx1;
                    e2 += sx2;
                }
            }
            r0 += sy0;
            r1 += sy1;
            r2 += sy2;
        }
        if wrote {
            let (tx0, tx1) = (x0 as usize / HIZ, x1 as usize / HIZ);
            for ty in y0 as usize / HIZ..y1 as usize / HIZ + 1 {
                self.hiz_dirty[ty * self.tiles_w + tx0..ty * self.tiles_w + tx1 + 1].fill(true);
            }
        }
        wrote
    }
}

/// The pixels `k ∈ [a, b] ⊆ [0, kmax]` of a row where the edge function `r + s·k` is ≥ 0
/// (`inv = 1/s`); empty when `a > b`. The float estimate of the crossing is the answer or one
/// short of it, so one integer test (without a branch) makes it exact; a check, which always
/// passes unless rounding misled the estimate by more, guards the answer. Rows take three of
/// these each, and unpredictable branches here once cost more than the pixels of the row.
#[inline(always)]
fn edge_span(r: i64, s: i64, kmax: i64, inv: f64) -> (i64, i64) {
    let inside = |k: i64| r + s * k >= 0;
    if s > 0 {
        if r >= 0 {
            return (0, kmax);
        }
        // The first pixel inside (`kmax + 1`: none).
        let est = (-(r as f64) * inv).clamp(0.0, (kmax + 1) as f64) as i64;
        let mut k = (est + i64::from(!inside(est))).min(kmax + 1);
        if !((k > kmax || inside(k)) && (k == 0 || !inside(k - 1))) {
            k = est;
            while k <= kmax && !inside(k) {
                k += 1;
            }
            while k > 0 && inside(k - 1) {
                k -= 1;
            }
        }
        (k, kmax)
    } else if s < 0 {
        if r < 0 {
            return (1, 0);
        }
        // The last pixel inside (−1: none).
        let est = ((r as f64) * -inv).clamp(-1.0, kmax as f64) as i64;
        let mut k = (est + i64::from(inside(est + 1))).min(kmax);
        if !((k < 0 || inside(k)) && (k == kmax || !inside(k + 1))) {
            k = est;
            while k >= 0 && !inside(k) {
                k -= 1;
            }
            while k < kmax && inside(k + 1) {
                k += 1;
            }
        }
        (0, k)
    } else if r >= 0 {
        (0, kmax)
    } else {
        (1, 0)
    }
}

/// Sutherland–Hodgman against one plane (`dist ≥ 0` inside); returns the new vertex count. The
/// crossing point of an edge is computed from its inside end, so the two triangles sharing a
/// clipped edge get bit-identical new vertices and no crack opens between them.
fn clip(src: &[[f32; 3]], dst: &mut [[f32; 3]; 9], dist: impl Fn(&[f32; 3]) -> f32) -> usize {
    let mut n = 0;
    for i in 0..src.len() {
        let a = src[i];
        let b = src[(i + 1) % src.len()];
        let da = dist(&a);
        let db = dist(&b);
        if da >= 0.0 && n < 9 {
            dst[n] = a;
            n += 1;
        }
        if (da >= 0.0) != (db >= 0.0) && n < 9 {
            let (pi, po, di, dout) = if da >= 0.0 {
                (a, b, da, db)
            } else {
                (b, a, db, da)
            };
            let t = di / (di - dout);
            dst[n] = std::array::from_fn(|k| pi[k] + t * (po[k] - pi[k]));
            n += 1;
        }
    }
    n
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::World;

    /// Every pixel centre inside a triangulated square is drawn by exactly one triangle, also
    /// where edges pass exactly through pixel centres (the top-left rule), and none twice.
    #[test]
    fn render_fill_covers_each_pixel_once() -> crate::Result<()> {
        let scene = RenderScene::new(&World::default())?;
        let cam = RasterCam {
            w: 40,
            h: 40,
            fx: 1.0,
            fy: 1.0,
            cx: 0.0,
            cy: 0.0,
        };
        let mut r = Raster::default();
        // A 6x6 grid of vertices over [4, 36]², interior ones moved off the lattice (some by
        // whole pixels, so edges run exactly through pixel centres), split both ways.
        let n = 6;
        let vert = |i: i64, j: i64| -> (i64, i64) {
            let inner = i > 0 && i < n - 1 && j > 0 && j < n - 1;
            let (dx, dy) = if inner {
                (
                    ((i * 7 + j * 3) % 5 - 2) * 8,
                    ((i * 5 + j * 11) % 7 - 3) * 5,
                )
            } else {
                (0, 0)
            };
            (
                (4 + i * 32 / (n - 1)) * SUB + dx,
                (4 + j * 32 / (n - 1)) * SUB + dy,
            )
        };
        let mut count = vec![0u32; 40 * 40];
        let mut tris = Vec::new();
        for i in 0..n - 1 {
            for j in 0..n - 1 {
                let (a, b, c, d) = (
                    vert(i, j),
                    vert(i + 1, j),
                    vert(i + 1, j + 1),
                    vert(i, j + 1),
                );
                if (i + j) % 2 == 0 {
                    tris.push((a, b, c));
                    tris.push((a, c, d));
                } else {
                    tris.push((a, b, d));
                    tris.push((b, c, d));
                }
            }
        }
        // Both windings, as the rasterizer sees front and back faces.
        for (k, &(a, b, c)) in tris.iter().enumerate() {
            r.prepare(&scene, cam);
            let (b, c) = if k % 3 == 0 { (c, b) } else { (b, c) };
            r.fill(a, b, c, 7, [0.0, 0.0, 1.0]);
            for (n, &id) in count.iter_mut().zip(&r.ids) {
                *n += u32::from(id == 7);
            }
        }
        for y in 0..40 {
            for x in 0..40 {
                let c = count[y * 40 + x];
                let inside = (5..36).contains(&x) && (5..36).contains(&y);
                let outside = !(4..=36).contains(&x) || !(4..=36).contains(&y);
                assert!(c <= 1, "pixel ({x}, {y}) drawn {c} times");
                if inside {
                    assert_eq!(c, 1, "pixel ({x}, {y}) not drawn");
                }
                if outside {
                    assert_eq!(c, 0, "pixel ({x}, {y}) outside drawn");
                }
            }
        }
        Ok(())
    }

    /// A triangle crossing the near plane keeps the part in front: its clipped vertices are
    /// shared bit for bit with its neighbour's, so the pair leaves no crack.
    #[test]
    fn render_clip_shares_crossings() {
        let a = [0.3, -0.2, -1.0];
        let b = [0.1, 0.4, 2.0];
        let mut out1 = [[0.0f32; 3]; 9];
        let mut out2 = [[0.0f32; 3]; 9];
        let n1 = clip(&[a, b, [1.0, 1.0, 3.0]], &mut out1, |q| q[2] - NEAR);
        let n2 = clip(&[b, a, [-1.0, 0.5, 1.0]], &mut out2, |q| q[2] - NEAR);
        let cross1: Vec<_> = out1[..n1]
            .iter()
            .filter(|q| q[2] == NEAR || (q[2] - NEAR).abs() < 1e-6)
            .collect();
        let cross2: Vec<_> = out2[..n2]
            .iter()
            .filter(|q| q[2] == NEAR || (q[2] - NEAR).abs() < 1e-6)
            .collect();
        assert!(
            cross1.iter().any(|p| cross2.contains(p)),
            "{cross1:?} {cross2:?}"
        );
    }
}
