//! A texture atlas for the simplified mesh, baked from the volume's colours.
//!
//! Simplification leaves large triangles on walls and cupboard fronts, whose vertex colours
//! would smear the posters, tiles and labels the colour frames saw. Each triangle instead gets
//! a square cell of texels (about one voxel per texel, fewer where the whole atlas would pass
//! its budget): the triangle is laid on the cell's lower-left half, and every texel takes the
//! fused colour at the surface point it maps to (texels past the diagonal take the nearest
//! point of the triangle, so sampling and mipmaps at the edge see the triangle's own colours).
//! Cells are squares of a power of two texels, packed in shelves, largest first and otherwise in
//! mesh order: every cell then starts at a multiple of its size, so a renderer's mip levels
//! average texels of one cell until a cell is one texel, and past that neighbouring cells
//! mostly hold neighbouring surface.
//!
//! Why hand-written: the UV-atlas crates unwrap charts for artists (xatlas bindings need a C++
//! build of their own and take minutes on a million triangles); a cell per triangle is all a
//! renderer at 160x120 needs.

use crate::mesh::{ColoredMesh, TexturedMesh};
use crate::volume::Volume;
use rayon::prelude::*;

/// Cells of one triangle are at least this many texels across (so the first two mip levels
/// average the cell's own texels)…
pub const MIN_CELL: usize = 4;
/// …and at most this many.
const MAX_CELL: usize = 64;
/// Largest atlas side, texels: what `synth` keeps of a scan's texture without resampling it
/// (resampling would blur across cell edges).
pub const MAX_SIDE: usize = 4096;
/// Colour of atlas texels no triangle uses.
const UNUSED: [u8; 3] = [128, 128, 128];

/// How the atlas is laid out.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct AtlasConfig {
    /// Wanted texel edge on the surface, metres (the voxel is a good choice: finer holds no
    /// more colour).
    pub texel_m: f64,
    /// Most texels in the atlas; the texel grows until the cells fit, and fit in
    /// [`MAX_SIDE`] a side.
    pub max_texels: usize,
}

impl Default for AtlasConfig {
    fn default() -> Self {
        Self {
            texel_m: 0.01,
            max_texels: 12 * 1024 * 1024,
        }
    }
}

/// Bakes `mesh` (in the volume's frame) into a textured mesh.
pub fn bake(mesh: &ColoredMesh, volume: &Volume, cfg: &AtlasConfig) -> TexturedMesh {
    let n = mesh.triangle_count();
    let longest: Vec<f64> = (0..n)
        .map(|t| {
            let c = mesh.triangle(t);
            (0..3)
                .map(|k| {
                    let (a, b) = (c[k], c[(k + 1) % 3]);
                    let d: f32 = (0..3).map(|i| (a[i] - b[i]).powi(2)).sum();
                    f64::from(d.sqrt())
                })
                .fold(0.0, f64::max)
        })
        .collect();
    let mut texel = cfg.texel_m.max(1e-4);
    let (sizes, cells, width, height) = loop {
        let sizes: Vec<usize> = longest
            .iter()
            .map(|&l| {
                ((l / texel).ceil() as usize + 1)
                    .clamp(MIN_CELL, MAX_CELL)
                    .next_power_of_two()
            })
            .collect();
        let total: usize = sizes.iter().map(|s| s * s).sum();
        let smallest = sizes.iter().all(|&s| s == MIN_CELL);
        if total > cfg.max_texels && !smallest {
            texel *= (total as f64 / cfg.max_texels as f64).sqrt() * 1.05;
            continue;
        }
        let (cells, width, height) = pack(&sizes);
        if height > MAX_SIDE && !smallest {
            texel *= 1.1;
            continue;
        }
        break (sizes, cells, width, height);
    };
    let colors: Vec<Vec<[u8; 3]>> = (0..n)
        .into_par_iter()
        .map(|t| cell_colors(mesh, volume, t, sizes[t]))
        .collect();
    let mut atlas = image::RgbImage::from_pixel(width as u32, height as u32, image::Rgb(UNUSED));
    let mut out = TexturedMesh {
        positions: Vec::with_capacity(3 * n),
        uvs: Vec::with_capacity(3 * n),
        indices: Vec::with_capacity(3 * n),
        atlas: image::RgbImage::new(1, 1),
        texel_m: texel,
    };
    let (w, h) = (width as f32, height as f32);
    for t in 0..n {
        let (x0, y0) = cells[t];
        let s = sizes[t];
        for (i, c) in colors[t].iter().enumerate() {
            atlas.put_pixel((x0 + i % s) as u32, (y0 + i / s) as u32, image::Rgb(*c));
        }
        let (x0, y0, far) = (x0 as f32 + 0.5, y0 as f32 + 0.5, s as f32 - 1.0);
        let corners = mesh.triangle(t);
        for (k, uv) in [[0.0, 0.0], [far, 0.0], [0.0, far]].iter().enumerate() {
            out.indices.push(out.positions.len() as u32);
            out.positions.push(corners[k]);
            out.uvs.push([(x0 + uv[0]) / w, (y0 + uv[1]) / h]);
        }
    }
    out.atlas = atlas;
    out
}

/// The colours of triangle `t`'s `s`×`s` cell, row by row.
fn cell_colors(mesh: &ColoredMesh, volume: &Volume, t: usize, s: usize) -> Vec<[u8; 3]> {
    let c = mesh.triangle(t);
    let vc = {
        let i = &mesh.indices[3 * t..3 * t + 3];
        [0, 1, 2].map(|k| mesh.colors[i[k] as usize].map(f32::from))
    };
    let far = (s - 1) as f32;
    let mut out = Vec::with_capacity(s * s);
    for j in 0..s {
        for i in 0..s {
            let (mut a, mut b) = (i as f32 / far, j as f32 / far);
            if a + b > 1.0 {
                let sum = a + b;
                a /= sum;
                b /= sum;
            }
            let p = [0, 1, 2]
                .map(|k| f64::from(c[0][k] + a * (c[1][k] - c[0][k]) + b * (c[2][k] - c[0][k])));
            let rgb = volume.color_at(p).unwrap_or_else(|| {
                [0, 1, 2].map(|k| (1.0 - a - b) * vc[0][k] + a * vc[1][k] + b * vc[2][k])
            });
            out.push(rgb.map(|v| v.round().clamp(0.0, 255.0) as u8));
        }
    }
    out
}

/// Shelf packing of square cells: each cell's top-left texel, and the atlas's power-of-two
/// width and height.
fn pack(sizes: &[usize]) -> (Vec<(usize, usize)>, usize, usize) {
    let total: usize = sizes.iter().map(|s| s * s).sum();
    let width = ((total as f64 * 1.15).sqrt().ceil() as usize)
        .next_power_of_two()
        .clamp(MAX_CELL, MAX_SIDE);
    let mut order: Vec<usize> = (0..sizes.len()).collect();
    order.sort_by_key(|&t| std::cmp::Reverse(sizes[t]));
    let mut cells = vec![(0, 0); sizes.len()];
    let (mut x, mut y, mut shelf) = (0, 0, 0);
    for t in order {
        let s = sizes[t];
        if x + s > width {
            y += shelf;
            x = 0;
            shelf = 0;
        }
        cells[t] = (x, y);
        x += s;
        shelf = shelf.max(s);
    }
    let height = (y + shelf).next_power_of_two().max(1);
    (cells, width, height)
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn cells_are_aligned_do_not_overlap_and_fit_the_atlas() {
        let sizes = [4, 4, 64, 8, 8, 4, 4, 32, 4, 4, 16];
        let (cells, w, h) = pack(&sizes);
        assert!(w.is_power_of_two() && h.is_power_of_two());
        for (a, &(xa, ya)) in cells.iter().enumerate() {
            assert!(xa + sizes[a] <= w && ya + sizes[a] <= h);
            assert!(
                xa % sizes[a] == 0 && ya % sizes[a] == 0,
                "cell {a} unaligned"
            );
            for (b, &(xb, yb)) in cells.iter().enumerate().skip(a + 1) {
                let apart = xa + sizes[a] <= xb
                    || xb + sizes[b] <= xa
                    || ya + sizes[a] <= yb
                    || yb + sizes[b] <= ya;
                assert!(apart, "cells {a} and {b} overlap");
            }
        }
    }
}
