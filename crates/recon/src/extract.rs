//! The volume's zero surface as a coloured triangle mesh: naive surface nets
//! (`fast-surface-nets`) over each block with one voxel of its neighbours around it, so that
//! the blocks' meshes join without seams; vertices of the same lattice cell are welded.
//!
//! A TSDF also changes sign where it should not: between a voxel that was never observed
//! (stored as +1, free) and one behind a surface, and across the jump from +1 to −1 at the edge
//! of an object seen from one side. Only cells whose eight corners were all observed and lie
//! inside the truncation band (|d| < 1) make vertices; a quad with any other corner is dropped.
//! Each vertex takes the blend of its cell's voxel colours.

use crate::mesh::ColoredMesh;
use crate::volume::{BLOCK, Volume};
use fast_surface_nets::ndshape::{ConstShape, ConstShape3u32};
use fast_surface_nets::{SurfaceNetsBuffer, surface_nets};
use rayon::prelude::*;
use std::collections::HashMap;

/// A block with one voxel of padding on every side.
const PADDED: u32 = BLOCK as u32 + 2;
type Chunk = ConstShape3u32<PADDED, PADDED, PADDED>;

/// One block's share of the mesh: triangles whose corners are named by their global cell.
struct Piece {
    /// Cell (lattice coordinates of its first corner), position (lattice units) and colour of
    /// each vertex.
    vertices: Vec<([i32; 3], [f32; 3], [u8; 3])>,
    /// Indices into `vertices`, three per triangle.
    indices: Vec<u32>,
}

/// Extracts the surface of `volume` (positions in metres, the volume's frame).
pub fn extract(volume: &Volume) -> ColoredMesh {
    let origins: Vec<[i32; 3]> = volume.block_origins().collect();
    let pieces: Vec<Piece> = origins
        .par_iter()
        .map_init(SurfaceNetsBuffer::default, |buffer, origin| {
            block_piece(volume, *origin, buffer)
        })
        .collect();
    let mut mesh = ColoredMesh::default();
    let mut welded: HashMap<[i32; 3], u32> = HashMap::new();
    for piece in pieces {
        let ids: Vec<u32> = piece
            .vertices
            .iter()
            .map(|(cell, p, c)| {
                *welded.entry(*cell).or_insert_with(|| {
                    mesh.positions
                        .push(p.map(|v| (f64::from(v) * volume.voxel_m) as f32));
                    mesh.colors.push(*c);
                    (mesh.positions.len() - 1) as u32
                })
            })
            .collect();
        mesh.indices
            .extend(piece.indices.iter().map(|&i| ids[i as usize]));
    }
    mesh
}

/// The mesh of one block (first voxel at lattice `origin`).
fn block_piece(volume: &Volume, origin: [i32; 3], buffer: &mut SurfaceNetsBuffer) -> Piece {
    let start = origin.map(|c| c - 1);
    let n = Chunk::USIZE;
    let mut sdf = vec![1.0f32; n];
    let mut usable = vec![false; n];
    let mut color = vec![[0.0f32; 3]; n];
    for i in 0..Chunk::SIZE {
        let [x, y, z] = Chunk::delinearize(i);
        let g = [
            start[0] + x as i32,
            start[1] + y as i32,
            start[2] + z as i32,
        ];
        if let Some(v) = volume.voxel(g)
            && v.weight > 0.0
        {
            sdf[i as usize] = v.tsdf;
            usable[i as usize] = v.tsdf.abs() < 0.999;
            color[i as usize] = v.color;
        }
    }
    surface_nets(&sdf, &Chunk {}, [0; 3], [PADDED - 1; 3], buffer);
    // Which vertices lie in fully usable cells, and their colours.
    let mut keep = vec![u32::MAX; buffer.positions.len()];
    let mut piece = Piece {
        vertices: Vec::new(),
        indices: Vec::new(),
    };
    for (v, (&cell, &p)) in buffer
        .surface_points
        .iter()
        .zip(&buffer.positions)
        .enumerate()
    {
        let corners = (0..8u32).map(|c| {
            Chunk::linearize([
                cell[0] + (c & 1),
                cell[1] + ((c >> 1) & 1),
                cell[2] + ((c >> 2) & 1),
            ]) as usize
        });
        if !corners.clone().all(|i| usable[i]) {
            continue;
        }
        let f = [0, 1, 2].map(|k| (p[k] - cell[k] as f32).clamp(0.0, 1.0));
        let mut rgb = [0.0f32; 3];
        for (c, i) in corners.enumerate() {
            let w: f32 = (0..3)
                .map(|k| if (c >> k) & 1 == 1 { f[k] } else { 1.0 - f[k] })
                .product();
            for (a, b) in rgb.iter_mut().zip(color[i]) {
                *a += w * b;
            }
        }
        keep[v] = piece.vertices.len() as u32;
        piece.vertices.push((
            [0, 1, 2].map(|k| start[k] + cell[k] as i32),
            [0, 1, 2].map(|k| p[k] + start[k] as f32),
            rgb.map(|c| c.round().clamp(0.0, 255.0) as u8),
        ));
    }
    for tri in buffer.indices.chunks_exact(3) {
        let ids = [0, 1, 2].map(|k| keep[tri[k] as usize]);
        if ids.iter().all(|&i| i != u32::MAX) {
            piece.indices.extend(ids);
        }
    }
    piece
}
