//! A scan as a fusing tool writes it, for tests: one mesh of a corner of a room (two walls and a
//! 0.4 m strip of floor, no ceiling) with POSITION, TEXCOORD_0 and u32 indices, one
//! `KHR_materials_unlit` material whose base colour is an embedded PNG atlas, Y up.
//!
//! In the world [`super::load`] makes of it (z up): the back wall is the plane y = 2 facing −y
//! (x 0–3 m, z 0–2.5 m), the side wall x = 0 facing +x (y 0–2 m), the floor strip x 1.3–1.7 m at
//! z = 0, between the floor samples of the walk graph's 0.5 m grid, so no floor is walkable.

use super::gltf::tests::glb;
use std::path::{Path, PathBuf};

/// The atlas's two colours (sRGB): its left half and its right half.
pub(crate) const ATLAS: [[u8; 3]; 2] = [[200, 120, 60], [40, 90, 160]];

/// Writes the scan to `path` (a `.glb`). `extras` is the JSON of `asset.extras`, if any; with
/// `unlit` false the material is an ordinary (lit) one.
pub(crate) fn write(path: &Path, extras: Option<&str>, unlit: bool) -> std::io::Result<PathBuf> {
    #[rustfmt::skip]
    let quads: [[[f32; 3]; 4]; 3] = [
        [[0.0, 0.0, -2.0], [3.0, 0.0, -2.0], [3.0, 2.5, -2.0], [0.0, 2.5, -2.0]], // back wall
        [[0.0, 0.0, 0.0], [0.0, 0.0, -2.0], [0.0, 2.5, -2.0], [0.0, 2.5, 0.0]], // side wall
        [[1.3, 0.0, 0.0], [1.7, 0.0, 0.0], [1.7, 0.0, -2.0], [1.3, 0.0, -2.0]], // floor strip
    ];
    let uv: [[f32; 2]; 4] = [[0.0, 1.0], [1.0, 1.0], [1.0, 0.0], [0.0, 0.0]];
    let mut bin = Vec::new();
    quads
        .iter()
        .flatten()
        .flatten()
        .for_each(|x| bin.extend(x.to_le_bytes()));
    (0..3)
        .flat_map(|_| uv.iter().flatten())
        .for_each(|x| bin.extend(x.to_le_bytes()));
    (0..3u32)
        .flat_map(|q| [0, 1, 2, 0, 2, 3].map(|i| 4 * q + i))
        .for_each(|i| bin.extend(i.to_le_bytes()));
    let geometry = bin.len(); // 144 + 96 + 72
    let atlas = image::RgbImage::from_fn(8, 8, |x, _| image::Rgb(ATLAS[usize::from(x >= 4)]));
    let mut png = Vec::new();
    atlas
        .write_to(&mut std::io::Cursor::new(&mut png), image::ImageFormat::Png)
        .map_err(std::io::Error::other)?;
    bin.extend(&png);
    while !bin.len().is_multiple_of(4) {
        bin.push(0);
    }
    let extras = extras.map_or(String::new(), |e| format!(r#", "extras": {e}"#));
    let unlit = if unlit {
        r#", "extensions": {"KHR_materials_unlit": {}}"#
    } else {
        ""
    };
    let json = format!(
        r#"{{
  "asset": {{"version": "2.0", "generator": "indoorloc test scan"{extras}}},
  "extensionsUsed": ["KHR_materials_unlit"],
  "scene": 0,
  "scenes": [{{"nodes": [0]}}],
  "nodes": [{{"name": "scan", "mesh": 0}}],
  "meshes": [{{"primitives": [
    {{"attributes": {{"POSITION": 0, "TEXCOORD_0": 1}}, "indices": 2, "material": 0}}
  ]}}],
  "materials": [{{"name": "scan atlas", "pbrMetallicRoughness": {{"baseColorTexture":
    {{"index": 0}}, "metallicFactor": 0.0}}{unlit}}}],
  "textures": [{{"source": 0}}],
  "images": [{{"bufferView": 3, "mimeType": "image/png"}}],
  "accessors": [
    {{"bufferView": 0, "componentType": 5126, "count": 12, "type": "VEC3",
      "min": [0.0, 0.0, -2.0], "max": [3.0, 2.5, 0.0]}},
    {{"bufferView": 1, "componentType": 5126, "count": 12, "type": "VEC2"}},
    {{"bufferView": 2, "componentType": 5125, "count": 18, "type": "SCALAR"}}
  ],
  "bufferViews": [
    {{"buffer": 0, "byteOffset": 0, "byteLength": 144}},
    {{"buffer": 0, "byteOffset": 144, "byteLength": 96}},
    {{"buffer": 0, "byteOffset": 240, "byteLength": 72}},
    {{"buffer": 0, "byteOffset": {geometry}, "byteLength": {}}}
  ],
  "buffers": [{{"byteLength": {}}}]
}}"#,
        png.len(),
        bin.len()
    );
    std::fs::write(path, glb(&json, &bin))?;
    Ok(path.to_path_buf())
}

/// `asset.extras` recording `dataset_to_world` as 16 row-major numbers.
pub(crate) fn extras(dataset_to_world: &geom::Pose) -> String {
    let m = dataset_to_world.to_matrix4();
    let numbers: Vec<String> = (0..16)
        .map(|i| format!("{:?}", m[(i / 4, i % 4)]))
        .collect();
    format!(
        r#"{{"indoorloc_scan": {{"dataset_to_world": [{}], "dataset": "scans/kitchen"}}}}"#,
        numbers.join(", ")
    )
}
