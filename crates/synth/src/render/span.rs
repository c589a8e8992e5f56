//! Shading a row as arrays: the row is cut into runs of pixels that see one triangle, and each
//! step of shading (light from the grid, texture coordinates and level of detail, radiance) is a
//! loop over a run with the triangle's and material's numbers held constant. Those loops have no
//! branches and no calls, so the compiler turns them into vector code (several pixels an
//! instruction); only the texel fetch stays one pixel at a time. Each step does the operations
//! of the one-pixel-at-a-time shader in the same order, so images are the same.

use super::raster::VisTri;
use super::scene::{SceneMaterial, fmax};

/// Per-row arrays, reused between rows and frames (every one `width` long).
#[derive(Debug, Default)]
pub(crate) struct RowArrays {
    /// Raster position of each pixel.
    pub sx: Vec<f32>,
    /// See `sx`.
    pub sy: Vec<f32>,
    /// Light interpolated from the four grid nodes around each pixel, valid where all four see
    /// the pixel's surface.
    pub grid_e: Vec<f32>,
    /// What the four grid nodes around each pixel see: top-left, top-right, bottom-left,
    /// bottom-right.
    pub keys: [Vec<u32>; 4],
    /// Irradiance per pixel.
    pub e: Vec<f32>,
    /// Texture coordinates and the squared texel footprint of each pixel.
    pub u: Vec<f32>,
    /// See `u`.
    pub v: Vec<f32>,
    /// See `u`.
    pub rho2: Vec<f32>,
    /// The texel of each pixel, packed sRGB.
    pub texel: Vec<u32>,
}

impl RowArrays {
    /// Sizes every array for rows of `w` pixels.
    pub fn resize(&mut self, w: usize) {
        for a in [
            &mut self.sx,
            &mut self.sy,
            &mut self.grid_e,
            &mut self.e,
            &mut self.u,
            &mut self.v,
            &mut self.rho2,
        ] {
            a.resize(w, 0.0);
        }
        for k in &mut self.keys {
            k.resize(w, 0);
        }
        self.texel.resize(w, 0);
    }
}

/// Bilinear light of the grid for a whole row, whatever each node sees (`cols`: per pixel, the
/// nodes left and right and the weight of the right one; `fy`: the weight of the lower row).
#[inline(always)]
pub(crate) fn grid_row(
    out: &mut [f32],
    cols: &[(u32, u32, f32)],
    (e0, e1): (&[f32], &[f32]),
    fy: f32,
) {
    for (o, &(k0, k1, fx)) in out.iter_mut().zip(cols) {
        let (k0, k1) = (k0 as usize, k1 as usize);
        let top = e0[k0] + (e0[k1] - e0[k0]) * fx;
        let bot = e1[k0] + (e1[k1] - e1[k0]) * fx;
        *o = top + (bot - top) * fy;
    }
}

/// What the four grid nodes around each pixel of a row see.
#[inline(always)]
pub(crate) fn grid_keys(
    keys: &mut [Vec<u32>; 4],
    cols: &[(u32, u32, f32)],
    id0: &[u32],
    id1: &[u32],
) {
    let [k00, k01, k10, k11] = keys;
    for ((((a, b), c), d), &(k0, k1, _)) in k00
        .iter_mut()
        .zip(k01.iter_mut())
        .zip(k10.iter_mut())
        .zip(k11.iter_mut())
        .zip(cols)
    {
        let (k0, k1) = (k0 as usize, k1 as usize);
        (*a, *b, *c, *d) = (id0[k0], id0[k1], id1[k0], id1[k1]);
    }
}

/// Copies the grid's light into `e` over a run of the surface `key`; true when some pixel has a
/// node that sees another surface (its light must then be found another way).
#[inline(always)]
pub(crate) fn grid_light(e: &mut [f32], grid_e: &[f32], keys: [&[u32]; 4], key: u32) -> bool {
    let mut off = false;
    let [a, b, c, d] = keys;
    for (((((o, &g), &a), &b), &c), &d) in e.iter_mut().zip(grid_e).zip(a).zip(b).zip(c).zip(d) {
        *o = g;
        off |= (a != key) | (b != key) | (c != key) | (d != key);
    }
    off
}

/// Texture coordinates `(u, v)` of a run of pixels on triangle `t`, and their squared texel
/// footprint on level 0 of material `m`'s texture (from the screen derivatives of u and v:
/// du/dx = z·(d(u/z)/dx − u·d(1/z)/dx)).
#[allow(clippy::too_many_arguments)]
#[inline(always)]
pub(crate) fn tex_coords(
    t: &VisTri,
    m: &SceneMaterial,
    (sx, sy, w): (&[f32], &[f32], &[f32]),
    u_out: &mut [f32],
    v_out: &mut [f32],
    rho2: &mut [f32],
) {
    let (su2, sv2) = (m.mips.su2, m.mips.sv2);
    let outs = u_out.iter_mut().zip(v_out.iter_mut()).zip(rho2.iter_mut());
    for (((&sx, &sy), &wv), ((uo, vo), ro)) in sx.iter().zip(sy).zip(w).zip(outs) {
        let z = 1.0 / wv;
        let u = (t.u[0] * sx + (t.u[1] * sy + t.u[2])) * z;
        let v = (t.v[0] * sx + (t.v[1] * sy + t.v[2])) * z;
        let dudx = t.u[0] - u * t.w[0];
        let dudy = t.u[1] - u * t.w[1];
        let dvdx = t.v[0] - v * t.w[0];
        let dvdy = t.v[1] - v * t.w[1];
        let rx = dudx * dudx * su2 + dvdx * dvdx * sv2;
        let ry = dudy * dudy * su2 + dvdy * dvdy * sv2;
        (*uo, *vo, *ro) = (u, v, fmax(rx, ry) * (z * z));
    }
}

/// Light on a lit material (not `unlit`) at irradiance `e`: ambient plus `e`, or daylight for a
/// window, plus what the surface gives off.
#[inline(always)]
pub(crate) fn lit(
    m: &SceneMaterial,
    e: f32,
    ambient: f32,
    daylight: f32,
    window_gain: f32,
    emissive_gain: f32,
) -> f32 {
    let e = ambient + e;
    let light = if m.window {
        0.05 + 0.3 * e + window_gain * daylight
    } else {
        e
    };
    light + m.emissive * emissive_gain
}

/// Radiance of a run: albedo (already in `r, g, b`, or `flat` when given) times `light(e)`.
#[inline(always)]
pub(crate) fn radiance(
    (r, g, b): (&mut [f32], &mut [f32], &mut [f32]),
    e: &[f32],
    flat: Option<[f32; 3]>,
    light: impl Fn(f32) -> f32,
) {
    let px = r.iter_mut().zip(g.iter_mut()).zip(b.iter_mut()).zip(e);
    match flat {
        Some(a) => {
            for (((r, g), b), &e) in px {
                let l = light(e);
                (*r, *g, *b) = (a[0] * l, a[1] * l, a[2] * l);
            }
        }
        None => {
            for (((r, g), b), &e) in px {
                let l = light(e);
                (*r, *g, *b) = (*r * l, *g * l, *b * l);
            }
        }
    }
}
