//! Writing a scan's mesh: glTF binary (what `synth --world` and every 3-D viewer open) and PLY
//! with vertex colours (what MeshLab, Open3D and CloudCompare expect from a scan). Both are
//! written atomically (temporary file, then rename).
//!
//! The GLB holds one textured mesh in glTF's own axes (+Y up, so a viewer shows the room upright
//! and `synth`'s importer turns it back into z up), one material marked `KHR_materials_unlit`
//! (the atlas is what the cameras saw, light included: a renderer must not light it again), and
//! in `asset.extras.indoorloc_scan` the transform from the scanned dataset's pose frame to the
//! model's z-up world (`dataset_to_world`, 16 numbers, row-major), so poses of the dataset can be
//! rendered in the model.
//!
//! Why hand-written: the layout is a fixed handful of accessors; `gltf-json` would add a second
//! copy of the glTF schema types for the few lines of `serde_json` below, and the PLY header is
//! ten lines.

use crate::mesh::{ColoredMesh, TexturedMesh};
use crate::{ReconError, Result};
use geom::Pose;
use serde_json::json;
use std::io::Write;
use std::path::Path;

/// glTF's +Y-up axes from the world's z up: `(x, y, z) → (x, z, −y)`.
fn to_gltf_axes(p: [f32; 3]) -> [f32; 3] {
    [p[0], p[2], -p[1]]
}

fn write_error(path: &Path, e: impl std::fmt::Display) -> ReconError {
    ReconError::Write {
        path: path.to_path_buf(),
        msg: e.to_string(),
    }
}

/// Appends `bytes` to `bin` at a 4-byte boundary; returns (offset, length).
fn push_view(bin: &mut Vec<u8>, bytes: &[u8]) -> (usize, usize) {
    while !bin.len().is_multiple_of(4) {
        bin.push(0);
    }
    let offset = bin.len();
    bin.extend_from_slice(bytes);
    (offset, bytes.len())
}

/// Writes `mesh` (world frame, z up) as a GLB file; `dataset_to_world` and `dataset` are
/// recorded in the file's extras.
pub fn write_glb(
    path: &Path,
    mesh: &TexturedMesh,
    dataset_to_world: &Pose,
    dataset: &str,
) -> Result<()> {
    if mesh.indices.is_empty() {
        return Err(write_error(path, "the mesh has no triangles"));
    }
    let positions: Vec<[f32; 3]> = mesh.positions.iter().map(|&p| to_gltf_axes(p)).collect();
    let (mut lo, mut hi) = ([f32::INFINITY; 3], [f32::NEG_INFINITY; 3]);
    for p in &positions {
        for k in 0..3 {
            lo[k] = lo[k].min(p[k]);
            hi[k] = hi[k].max(p[k]);
        }
    }
    let mut png = Vec::new();
    image::DynamicImage::ImageRgb8(mesh.atlas.clone())
        .write_to(&mut std::io::Cursor::new(&mut png), image::ImageFormat::Png)
        .map_err(|e| write_error(path, e))?;
    let mut bin = Vec::new();
    let pos_bytes: Vec<u8> = positions
        .iter()
        .flatten()
        .flat_map(|v| v.to_le_bytes())
        .collect();
    let uv_bytes: Vec<u8> = mesh
        .uvs
        .iter()
        .flatten()
        .flat_map(|v| v.to_le_bytes())
        .collect();
    let idx_bytes: Vec<u8> = mesh.indices.iter().flat_map(|v| v.to_le_bytes()).collect();
    let views = [
        push_view(&mut bin, &pos_bytes),
        push_view(&mut bin, &uv_bytes),
        push_view(&mut bin, &idx_bytes),
        push_view(&mut bin, &png),
    ];
    while !bin.len().is_multiple_of(4) {
        bin.push(0);
    }
    let m = dataset_to_world.to_matrix4();
    let row_major: Vec<f64> = (0..4)
        .flat_map(|r| (0..4).map(move |c| m[(r, c)]))
        .collect();
    let doc = json!({
        "asset": {
            "version": "2.0",
            "generator": concat!("indoorloc recon ", env!("CARGO_PKG_VERSION")),
            "extras": {"indoorloc_scan": {"dataset_to_world": row_major, "dataset": dataset}}
        },
        "extensionsUsed": ["KHR_materials_unlit"],
        "scene": 0,
        "scenes": [{"nodes": [0]}],
        "nodes": [{"mesh": 0, "name": "scan"}],
        "meshes": [{"name": "scan", "primitives": [{
            "attributes": {"POSITION": 0, "TEXCOORD_0": 1},
            "indices": 2, "material": 0, "mode": 4
        }]}],
        "materials": [{
            "name": "scan",
            "pbrMetallicRoughness": {
                "baseColorTexture": {"index": 0},
                "metallicFactor": 0.0,
                "roughnessFactor": 1.0
            },
            "extensions": {"KHR_materials_unlit": {}},
            // The texture is an atlas of cells, one per triangle: a renderer's mip levels
            // past the smallest cell would average unrelated triangles (`synth` stops there).
            "extras": {"indoorloc_atlas_cell": crate::atlas::MIN_CELL}
        }],
        "textures": [{"source": 0, "sampler": 0}],
        "samplers": [{"magFilter": 9729, "minFilter": 9987, "wrapS": 33071, "wrapT": 33071}],
        "images": [{"bufferView": 3, "mimeType": "image/png"}],
        "accessors": [
            {"bufferView": 0, "componentType": 5126, "count": positions.len(), "type": "VEC3",
             "min": lo, "max": hi},
            {"bufferView": 1, "componentType": 5126, "count": mesh.uvs.len(), "type": "VEC2"},
            {"bufferView": 2, "componentType": 5125, "count": mesh.indices.len(), "type": "SCALAR"}
        ],
        "bufferViews": [
            {"buffer": 0, "byteOffset": views[0].0, "byteLength": views[0].1, "target": 34962},
            {"buffer": 0, "byteOffset": views[1].0, "byteLength": views[1].1, "target": 34962},
            {"buffer": 0, "byteOffset": views[2].0, "byteLength": views[2].1, "target": 34963},
            {"buffer": 0, "byteOffset": views[3].0, "byteLength": views[3].1}
        ],
        "buffers": [{"byteLength": bin.len()}]
    });
    let mut text = serde_json::to_vec(&doc).map_err(|e| write_error(path, e))?;
    while !text.len().is_multiple_of(4) {
        text.push(b' ');
    }
    let total = 12 + 8 + text.len() + 8 + bin.len();
    let total = u32::try_from(total)
        .map_err(|_| write_error(path, format!("{total} bytes: over glTF's 4 GiB limit")))?;
    data::io::write_atomic(path, |w: &mut dyn Write| {
        w.write_all(b"glTF")?;
        w.write_all(&2u32.to_le_bytes())?;
        w.write_all(&total.to_le_bytes())?;
        w.write_all(&(text.len() as u32).to_le_bytes())?;
        w.write_all(b"JSON")?;
        w.write_all(&text)?;
        w.write_all(&(bin.len() as u32).to_le_bytes())?;
        w.write_all(b"BIN\0")?;
        w.write_all(&bin)
    })?;
    Ok(())
}

/// Writes `mesh` as binary little-endian PLY with vertex colours.
pub fn write_ply(path: &Path, mesh: &ColoredMesh) -> Result<()> {
    data::io::write_atomic(path, |w: &mut dyn Write| {
        write!(
            w,
            "ply\nformat binary_little_endian 1.0\ncomment indoorloc recon: metres, z up\n\
             element vertex {}\nproperty float x\nproperty float y\nproperty float z\n\
             property uchar red\nproperty uchar green\nproperty uchar blue\n\
             element face {}\nproperty list uchar int vertex_indices\nend_header\n",
            mesh.positions.len(),
            mesh.triangle_count()
        )?;
        let mut buf = Vec::with_capacity(15 * mesh.positions.len());
        for (p, c) in mesh.positions.iter().zip(&mesh.colors) {
            for v in p {
                buf.extend_from_slice(&v.to_le_bytes());
            }
            buf.extend_from_slice(c);
        }
        w.write_all(&buf)?;
        buf.clear();
        for tri in mesh.indices.chunks_exact(3) {
            buf.push(3);
            for &i in tri {
                buf.extend_from_slice(&(i as i32).to_le_bytes());
            }
        }
        w.write_all(&buf)
    })?;
    Ok(())
}
