//! glTF 2.0: `.gltf` (JSON with external, embedded `data:` or GLB buffers) and `.glb`.
//!
//! The `gltf` crate validates the document and reads buffers and accessors; what it would panic
//! on or cannot see without optional features is done here: the GLB container is split with
//! checked lengths, every accessor's type and byte range is checked before it is read, images
//! are decoded one by one (so a missing texture is a warning, not a failed import), and
//! `KHR_lights_punctual`, `KHR_materials_emissive_strength` and `KHR_materials_unlit` are read
//! from the raw JSON.
//!
//! Every mesh primitive reachable from the default scene (else the first scene, else every root
//! node) is imported with its node's global transform; a transform with a negative determinant
//! (a mirror) flips the winding back, as the spec requires.

use super::mesh::{RawLight, RawTri, Soup, seed_of};
use super::texture::{self, Cache};
use super::{Frame, model_error};
use crate::world::{Material, MaterialId, Pattern};
use crate::{Result, SynthError};
use ::gltf as gl;
use geom::Pose;
use gl::accessor::{DataType, Dimensions};
use gl::json::Value;
use gl::mesh::Mode;
use image::RgbImage;
use nalgebra::{Matrix4, Vector4};
use std::collections::{BTreeMap, HashMap};
use std::path::Path;
use std::sync::Arc;

/// Extensions this importer handles when a file requires them.
const HANDLED: &[&str] = &[
    "KHR_lights_punctual",
    "KHR_materials_emissive_strength",
    "KHR_materials_unlit",
];

/// Material `extras` key of a texture atlas's smallest cell side in texels ([`Pattern::Atlas`];
/// written by `recon`).
pub const ATLAS_CELL_EXTRA: &str = "indoorloc_atlas_cell";

/// Reads a `.gltf` or `.glb` file and what it references.
pub(super) fn read(path: &Path, frame: Frame) -> Result<Soup> {
    let bytes = std::fs::read(path).map_err(|source| SynthError::Io {
        path: path.to_path_buf(),
        source,
    })?;
    let base = path.parent().unwrap_or_else(|| Path::new("."));
    parse(&bytes, path, base, frame)
}

/// Reads glTF or GLB bytes; `path` names the file in messages, `base` is where relative URIs
/// point.
pub(super) fn parse(bytes: &[u8], path: &Path, base: &Path, frame: Frame) -> Result<Soup> {
    let fail = |msg: String| model_error(path, msg);
    let (json, blob) = if bytes.starts_with(b"glTF") {
        split_glb(bytes).map_err(fail)?
    } else {
        (bytes, None)
    };
    let json = trim_padding(json);
    let mut raw: Value = gl::json::deserialize::from_slice(json)
        .map_err(|e| fail(format!("not valid glTF JSON: {e}")))?;
    if !raw.is_object() {
        return Err(fail(
            "not a glTF document (the JSON is not an object)".into(),
        ));
    }
    let version = raw
        .get("asset")
        .and_then(|a| a.get("version"))
        .and_then(Value::as_str)
        .unwrap_or("")
        .to_string();
    if !version.starts_with("2.") {
        return Err(fail(format!(
            "glTF version '{version}' is not supported: indoorloc reads glTF 2.0 (convert \
             glTF 1.0 files first)"
        )));
    }
    let mut soup = Soup::new(path);
    extensions(&mut raw, &mut soup)?;
    check_position_refs(&raw).map_err(fail)?;
    let root: gl::json::Root = gl::json::deserialize::from_value(raw.clone())
        .map_err(|e| fail(format!("not a valid glTF document: {e}")))?;
    let doc = gl::Document::from_json(root).map_err(|e| fail(describe(&e)))?;
    let buffers = gl::import_buffers(&doc, Some(base), blob.map(<[u8]>::to_vec))
        .map_err(|e| fail(format!("cannot load buffer data: {}", describe(&e))))?;

    let mut reader = Reader {
        doc: &doc,
        raw: &raw,
        buffers: &buffers,
        base,
        frame,
        soup,
        materials: HashMap::new(),
        images: HashMap::new(),
        files: Cache::default(),
        skipped: BTreeMap::new(),
        directional: 0,
    };
    reader.scene()?;
    reader.finish()
}

/// The JSON chunk and the optional binary chunk of a GLB container, every length checked.
fn split_glb(bytes: &[u8]) -> std::result::Result<(&[u8], Option<&[u8]>), String> {
    let word = |at: usize| {
        bytes
            .get(at..at + 4)
            .map(|b| u32::from_le_bytes([b[0], b[1], b[2], b[3]]) as usize)
    };
    let truncated = || format!("truncated GLB file ({} bytes)", bytes.len());
    let version = word(4).ok_or_else(truncated)?;
    if version != 2 {
        return Err(format!(
            "GLB version {version} is not supported: indoorloc reads glTF 2.0"
        ));
    }
    let length = word(8).ok_or_else(truncated)?;
    if length > bytes.len() {
        return Err(format!(
            "truncated GLB file: its header says {length} bytes, the file has {}",
            bytes.len()
        ));
    }
    let (mut json, mut bin) = (None, None);
    let mut at = 12;
    while at + 8 <= length {
        let (Some(size), Some(kind)) = (word(at), word(at + 4)) else {
            return Err(truncated());
        };
        let start = at + 8;
        let end = start
            .checked_add(size)
            .filter(|&e| e <= length)
            .ok_or_else(|| {
                format!(
                    "truncated GLB file: a chunk of {size} bytes at byte {at} ends past its end"
                )
            })?;
        let chunk = bytes.get(start..end).ok_or_else(truncated)?;
        match kind {
            0x4E4F_534A if json.is_none() => json = Some(chunk),
            0x004E_4942 if bin.is_none() => bin = Some(chunk),
            _ => {}
        }
        at = end;
    }
    Ok((json.ok_or("GLB file without a JSON chunk")?, bin))
}

/// The `asset.extras.indoorloc_scan.dataset_to_world` record of a `.gltf` or `.glb` file (see
/// [`super::scan_frame`]); only the JSON is read, not the buffers.
pub(super) fn scan_frame(path: &Path) -> Result<Option<Pose>> {
    let bytes = std::fs::read(path).map_err(|source| SynthError::Io {
        path: path.to_path_buf(),
        source,
    })?;
    let fail = |msg: String| model_error(path, msg);
    let json = if bytes.starts_with(b"glTF") {
        split_glb(&bytes).map_err(fail)?.0
    } else {
        &bytes
    };
    let raw: Value = gl::json::deserialize::from_slice(trim_padding(json))
        .map_err(|e| fail(format!("not valid glTF JSON: {e}")))?;
    let Some(scan) = raw
        .get("asset")
        .and_then(|a| a.get("extras"))
        .and_then(|e| e.get("indoorloc_scan"))
    else {
        return Ok(None);
    };
    const WHAT: &str = "asset.extras.indoorloc_scan.dataset_to_world";
    let numbers: Option<Vec<f64>> = scan
        .get("dataset_to_world")
        .and_then(Value::as_array)
        .and_then(|a| a.iter().map(Value::as_f64).collect());
    let matrix: [f64; 16] = numbers.and_then(|v| v.try_into().ok()).ok_or_else(|| {
        fail(format!(
            "{WHAT} must be 16 numbers (a row-major 4x4 matrix)"
        ))
    })?;
    Pose::from_row_major(&matrix)
        .map(Some)
        .map_err(|e| fail(format!("{WHAT} is not a rigid transform: {e}")))
}

/// JSON without the trailing spaces or NUL bytes that pad GLB chunks.
fn trim_padding(json: &[u8]) -> &[u8] {
    let end = json
        .iter()
        .rposition(|&b| !(b == 0 || b.is_ascii_whitespace()))
        .map_or(0, |i| i + 1);
    &json[..end]
}

/// A `gltf` error in words, with at most five validation problems listed.
fn describe(e: &gl::Error) -> String {
    match e {
        gl::Error::Validation(problems) => {
            let listed: Vec<String> = problems
                .iter()
                .take(5)
                .map(|(path, err)| format!("{path}: {err}"))
                .collect();
            let more = problems.len().saturating_sub(5);
            let tail = if more > 0 {
                format!(" (and {more} more)")
            } else {
                String::new()
            };
            format!("invalid glTF: {}{tail}", listed.join("; "))
        }
        other => other.to_string(),
    }
}

/// What an unsupported extension does, for the error message.
fn extension_words(name: &str) -> &'static str {
    match name {
        "KHR_draco_mesh_compression" => "Draco mesh compression",
        "EXT_meshopt_compression" => "meshopt compression",
        "KHR_mesh_quantization" => "quantized vertex data",
        "KHR_texture_transform" => "texture transforms",
        "EXT_mesh_gpu_instancing" => "GPU instancing",
        "KHR_texture_basisu" => "KTX2/Basis textures",
        "EXT_texture_webp" => "WebP textures",
        "KHR_materials_pbrSpecularGlossiness" => "specular-glossiness materials",
        _ => "not known to indoorloc",
    }
}

/// Rejects required extensions that are not handled, warns about used ones that are ignored,
/// and removes the handled ones from `extensionsRequired` (the `gltf` crate would otherwise
/// reject what its disabled features do not cover).
fn extensions(raw: &mut Value, soup: &mut Soup) -> Result<()> {
    let names = |key: &str, raw: &Value| -> Vec<String> {
        raw.get(key)
            .and_then(Value::as_array)
            .map(|a| {
                a.iter()
                    .filter_map(Value::as_str)
                    .map(String::from)
                    .collect()
            })
            .unwrap_or_default()
    };
    let required = names("extensionsRequired", raw);
    let unsupported: Vec<String> = required
        .iter()
        .filter(|e| !HANDLED.contains(&e.as_str()))
        .map(|e| format!("{e} ({})", extension_words(e)))
        .collect();
    if !unsupported.is_empty() {
        return Err(model_error(
            &soup.path,
            format!(
                "the file requires glTF extensions indoorloc does not support: {}; re-export the \
                 model without them (for example without mesh compression)",
                unsupported.join(", ")
            ),
        ));
    }
    for used in names("extensionsUsed", raw) {
        match used.as_str() {
            "EXT_mesh_gpu_instancing" => soup.warn(
                "uses GPU instancing (EXT_mesh_gpu_instancing): only each instanced mesh's \
                 base copy is imported",
            ),
            "KHR_texture_transform" => {
                soup.warn("texture transforms (KHR_texture_transform) are ignored")
            }
            _ => {}
        }
    }
    if let Some(obj) = raw.as_object_mut() {
        obj.remove("extensionsRequired");
    }
    Ok(())
}

/// Checks that every primitive's POSITION names an existing accessor: `gltf-json` 1.4.1's
/// validation indexes the accessor list with it unchecked (and would panic).
fn check_position_refs(raw: &Value) -> std::result::Result<(), String> {
    let accessors = raw
        .get("accessors")
        .and_then(Value::as_array)
        .map_or(0, Vec::len);
    let meshes = raw.get("meshes").and_then(Value::as_array);
    for (i, mesh) in meshes.into_iter().flatten().enumerate() {
        let prims = mesh.get("primitives").and_then(Value::as_array);
        for (j, prim) in prims.into_iter().flatten().enumerate() {
            let pos = prim.get("attributes").and_then(|a| a.get("POSITION"));
            if let Some(pos) = pos
                && pos.as_u64().is_none_or(|k| k >= accessors as u64)
            {
                return Err(format!(
                    "mesh {i} primitive {j}: POSITION refers to accessor {pos}, but the file \
                         has {accessors}"
                ));
            }
        }
    }
    Ok(())
}

/// sRGB encoding of a linear colour channel (glTF factors are linear; materials are sRGB).
fn srgb(linear: f32) -> f32 {
    let c = if linear.is_finite() {
        linear.clamp(0.0, 1.0)
    } else {
        0.0
    };
    if c >= 1.0 {
        1.0
    } else if c <= 0.003_130_8 {
        12.92 * c
    } else {
        1.055 * c.powf(1.0 / 2.4) - 0.055
    }
}

/// Checks an accessor before the `gltf` crate reads it: a supported layout, data present, and
/// every byte in range (the crate's readers assume all of this).
fn check_accessor(
    acc: &gl::Accessor,
    buffers: &[gl::buffer::Data],
    types: &[DataType],
    dims: Dimensions,
) -> std::result::Result<(), String> {
    if acc.sparse().is_some() {
        return Err("uses a sparse accessor, which indoorloc does not support".into());
    }
    if !types.contains(&acc.data_type()) || acc.dimensions() != dims {
        return Err(format!(
            "has {:?} {:?} data where indoorloc reads {types:?} {dims:?} (quantized data needs \
             KHR_mesh_quantization, which is not supported)",
            acc.data_type(),
            acc.dimensions()
        ));
    }
    let count = acc.count();
    if count == 0 {
        return Err("is empty".into());
    }
    let view = acc.view().ok_or(
        "has no buffer view, so no data (compressed with Draco or meshopt?, which are not \
         supported)",
    )?;
    let elem = acc.size();
    let stride = view.stride().unwrap_or(elem);
    if stride < elem {
        return Err(format!(
            "has a stride of {stride} bytes for {elem}-byte elements"
        ));
    }
    let need = stride
        .checked_mul(count - 1)
        .and_then(|n| n.checked_add(elem))
        .and_then(|n| n.checked_add(acc.offset()));
    if need.is_none_or(|n| n > view.length()) {
        return Err(format!(
            "reaches past the end of buffer view {} ({count} elements)",
            view.index()
        ));
    }
    let data = buffers
        .get(view.buffer().index())
        .ok_or("refers to a missing buffer")?;
    let end = view.offset().checked_add(view.length());
    if end.is_none_or(|e| e > data.0.len()) {
        return Err(format!(
            "uses buffer view {}, which reaches past the end of buffer {}",
            view.index(),
            view.buffer().index()
        ));
    }
    Ok(())
}

/// A material as imported: its id, and the texture coordinate set of its texture (if one
/// loaded).
type MaterialUse = (MaterialId, Option<u32>);

/// The state of reading one glTF document.
struct Reader<'a> {
    /// The validated document.
    doc: &'a gl::Document,
    /// The JSON, for what disabled crate features hide.
    raw: &'a Value,
    /// Buffer contents.
    buffers: &'a [gl::buffer::Data],
    /// Folder that relative URIs start from.
    base: &'a Path,
    /// File to world conversion.
    frame: Frame,
    /// What has been read.
    soup: Soup,
    /// Imported materials by glTF index (`None`: the default material).
    materials: HashMap<Option<usize>, MaterialUse>,
    /// Decoded images by glTF index.
    images: HashMap<usize, std::result::Result<Arc<RgbImage>, String>>,
    /// Decoded external image files.
    files: Cache,
    /// Primitives skipped, by mode.
    skipped: BTreeMap<&'static str, usize>,
    /// Directional lights skipped.
    directional: usize,
}

impl Reader<'_> {
    /// An error about the file.
    fn fail(&self, msg: impl Into<String>) -> SynthError {
        model_error(&self.soup.path, msg)
    }

    /// Imports every node of the scene, depth first, with global transforms.
    fn scene(&mut self) -> Result<()> {
        let doc = self.doc;
        let roots: Vec<gl::Node> = match doc.default_scene().or_else(|| doc.scenes().next()) {
            Some(scene) => scene.nodes().collect(),
            None => {
                let mut child = vec![false; doc.nodes().len()];
                for n in doc.nodes() {
                    for c in n.children() {
                        if let Some(slot) = child.get_mut(c.index()) {
                            *slot = true;
                        }
                    }
                }
                let roots: Vec<gl::Node> = doc
                    .nodes()
                    .filter(|n| !child.get(n.index()).copied().unwrap_or(true))
                    .collect();
                if !roots.is_empty() {
                    self.soup
                        .warn("the file has no scene; importing every root node");
                }
                roots
            }
        };
        let mut visited = vec![false; doc.nodes().len()];
        let mut stack: Vec<(gl::Node, Matrix4<f64>)> = roots
            .into_iter()
            .rev()
            .map(|n| (n, Matrix4::identity()))
            .collect();
        while let Some((node, parent)) = stack.pop() {
            match visited.get_mut(node.index()) {
                Some(seen) if !*seen => *seen = true,
                _ => {
                    self.soup.warn(format!(
                        "node {} is reached twice (a cycle or a shared child); imported once",
                        node.index()
                    ));
                    continue;
                }
            }
            let m = node.transform().matrix();
            let global = parent * Matrix4::from_fn(|r, c| f64::from(m[c][r]));
            if let Some(mesh) = node.mesh() {
                for prim in mesh.primitives() {
                    self.primitive(&mesh, &prim, &global)?;
                }
            }
            self.light(node.index(), &global);
            let children: Vec<gl::Node> = node.children().collect();
            for child in children.into_iter().rev() {
                stack.push((child, global));
            }
        }
        Ok(())
    }

    /// Imports one primitive's triangles.
    fn primitive(&mut self, mesh: &gl::Mesh, prim: &gl::Primitive, m: &Matrix4<f64>) -> Result<()> {
        let what = match mesh.name() {
            Some(name) => format!(
                "mesh {} ('{name}') primitive {}",
                mesh.index(),
                prim.index()
            ),
            None => format!("mesh {} primitive {}", mesh.index(), prim.index()),
        };
        let mode = prim.mode();
        let skipped = match mode {
            Mode::Triangles | Mode::TriangleStrip | Mode::TriangleFan => None,
            Mode::Points => Some("POINTS"),
            Mode::Lines => Some("LINES"),
            Mode::LineLoop => Some("LINE_LOOP"),
            Mode::LineStrip => Some("LINE_STRIP"),
        };
        if let Some(name) = skipped {
            *self.skipped.entry(name).or_default() += 1;
            return Ok(());
        }
        let Some(pos) = prim.get(&gl::Semantic::Positions) else {
            self.soup
                .warn(format!("{what} has no POSITION attribute; skipped"));
            return Ok(());
        };
        check_accessor(&pos, self.buffers, &[DataType::F32], Dimensions::Vec3)
            .map_err(|e| self.fail(format!("{what}: POSITION {e}")))?;
        let buffers = self.buffers;
        let reader = prim.reader(|b| buffers.get(b.index()).map(|d| d.0.as_slice()));
        let positions: Vec<[f32; 3]> = reader
            .read_positions()
            .ok_or_else(|| self.fail(format!("{what}: POSITION data cannot be read")))?
            .collect();
        let n = positions.len();
        let first = self.soup.positions.len();
        let last = first
            .checked_add(n)
            .filter(|&l| u32::try_from(l).is_ok())
            .ok_or_else(|| self.fail("more than 4 294 967 295 vertices"))?;
        let _ = last;
        for p in &positions {
            let q = m * Vector4::new(f64::from(p[0]), f64::from(p[1]), f64::from(p[2]), 1.0);
            self.soup.positions.push(self.frame.point([q.x, q.y, q.z]));
        }

        let indices: Vec<u32> = match prim.indices() {
            Some(acc) => {
                check_accessor(
                    &acc,
                    self.buffers,
                    &[DataType::U8, DataType::U16, DataType::U32],
                    Dimensions::Scalar,
                )
                .map_err(|e| self.fail(format!("{what}: indices {e}")))?;
                reader
                    .read_indices()
                    .ok_or_else(|| self.fail(format!("{what}: indices cannot be read")))?
                    .into_u32()
                    .collect()
            }
            None => (0..n as u32).collect(),
        };
        if let Some(bad) = indices.iter().find(|&&i| i as usize >= n) {
            return Err(self.fail(format!(
                "{what}: index {bad} refers past its {n} vertices (a corrupt file?)"
            )));
        }

        let (material, tex_set) = self.material(prim.material())?;
        let uvs: Option<Vec<[f32; 2]>> = tex_set.and_then(|set| {
            let acc = prim.get(&gl::Semantic::TexCoords(set))?;
            match check_accessor(
                &acc,
                self.buffers,
                &[DataType::F32, DataType::U8, DataType::U16],
                Dimensions::Vec2,
            ) {
                Ok(()) => {}
                Err(e) => {
                    self.soup
                        .warn(format!("{what}: TEXCOORD_{set} {e}; ignored"));
                    return None;
                }
            }
            let uv: Vec<[f32; 2]> = reader.read_tex_coords(set)?.into_f32().collect();
            (uv.len() == n).then_some(uv)
        });

        let flip = m.fixed_view::<3, 3>(0, 0).determinant() < 0.0;
        let mut push = |a: u32, b: u32, c: u32| {
            let (b, c) = if flip { (c, b) } else { (b, c) };
            let uv = uvs.as_ref().and_then(|uv| {
                Some([
                    *uv.get(a as usize)?,
                    *uv.get(b as usize)?,
                    *uv.get(c as usize)?,
                ])
            });
            let base = first as u32;
            self.soup.tris.push(RawTri {
                v: [base + a, base + b, base + c],
                uv,
                material,
            });
        };
        match mode {
            Mode::TriangleStrip => {
                for (k, w) in indices.windows(3).enumerate() {
                    if k % 2 == 0 {
                        push(w[0], w[1], w[2]);
                    } else {
                        push(w[1], w[0], w[2]);
                    }
                }
            }
            Mode::TriangleFan => {
                if let Some((&hub, rest)) = indices.split_first() {
                    for w in rest.windows(2) {
                        push(hub, w[0], w[1]);
                    }
                }
            }
            _ => {
                for t in indices.chunks_exact(3) {
                    push(t[0], t[1], t[2]);
                }
            }
        }
        Ok(())
    }

    /// The imported material for a glTF material, created on first use.
    fn material(&mut self, mat: gl::Material) -> Result<MaterialUse> {
        let key = mat.index();
        if let Some(&known) = self.materials.get(&key) {
            return Ok(known);
        }
        let name = match (mat.name(), key) {
            (Some(n), _) => n.to_string(),
            (None, Some(i)) => format!("material {i}"),
            (None, None) => "default".to_string(),
        };
        let pbr = mat.pbr_metallic_roughness();
        let f = pbr.base_color_factor();
        let extension = |name: &str| {
            key.and_then(|i| self.raw.get("materials")?.get(i))
                .and_then(|m| m.get("extensions")?.get(name))
        };
        let strength = extension("KHR_materials_emissive_strength")
            .and_then(|e| e.get("emissiveStrength")?.as_f64())
            .unwrap_or(1.0) as f32;
        let emissive = mat.emissive_factor().iter().fold(0.0f32, |a, &b| a.max(b)) * strength;
        // `recon`'s scans mark their texture an atlas of cells (see `Pattern::Atlas`).
        let atlas_cell = key
            .and_then(|i| self.raw.get("materials")?.get(i))
            .and_then(|m| m.get("extras")?.get(ATLAS_CELL_EXTRA)?.as_u64())
            .and_then(|c| u32::try_from(c).ok())
            .filter(|c| c.is_power_of_two());
        let mut m = Material {
            seed: seed_of(&name),
            color: [srgb(f[0]), srgb(f[1]), srgb(f[2])],
            pattern: Pattern::Plain,
            emissive: if emissive.is_finite() {
                emissive.clamp(0.0, 1.0)
            } else {
                0.0
            },
            unlit: extension("KHR_materials_unlit").is_some(),
            name,
        };
        let mut set = None;
        if let Some(info) = pbr.base_color_texture() {
            let image = info.texture().source().index();
            match self.image(image) {
                Ok(img) => {
                    m.pattern = match atlas_cell {
                        Some(cell) => Pattern::Atlas { image: img, cell },
                        None => Pattern::Image(img),
                    };
                    set = Some(info.tex_coord());
                }
                Err(why) => {
                    let msg = format!(
                        "texture image {image} of material '{}' cannot be loaded ({why}); the \
                         material keeps its colour",
                        m.name
                    );
                    self.soup.warn(msg);
                }
            }
        }
        if matches!(m.pattern, Pattern::Plain)
            && mat.alpha_mode() == gl::material::AlphaMode::Blend
            && f[3] < 0.6
        {
            m.pattern = Pattern::Window; // glazing
        }
        let id = self.soup.add_material(m)?;
        self.materials.insert(key, (id, set));
        Ok((id, set))
    }

    /// Decodes image `index` once: from a buffer view, a `data:` URI or a file next to the model.
    fn image(&mut self, index: usize) -> std::result::Result<Arc<RgbImage>, String> {
        if let Some(done) = self.images.get(&index) {
            return done.clone();
        }
        let result = self.decode_image(index);
        self.images.insert(index, result.clone());
        result
    }

    /// See [`Reader::image`].
    fn decode_image(&mut self, index: usize) -> std::result::Result<Arc<RgbImage>, String> {
        let raw = self
            .raw
            .get("images")
            .and_then(|a| a.get(index))
            .ok_or("no such image")?;
        if let Some(view) = raw.get("bufferView").and_then(Value::as_u64) {
            let view = self
                .doc
                .views()
                .nth(view as usize)
                .ok_or("its buffer view does not exist")?;
            let data = self
                .buffers
                .get(view.buffer().index())
                .ok_or("its buffer does not exist")?;
            let bytes = view
                .offset()
                .checked_add(view.length())
                .and_then(|end| data.0.get(view.offset()..end))
                .ok_or("its buffer view reaches past the end of the buffer")?;
            return texture::decode(bytes).map(Arc::new);
        }
        let uri = raw
            .get("uri")
            .and_then(Value::as_str)
            .ok_or("the image has neither a uri nor a bufferView")?;
        if let Some(rest) = uri.strip_prefix("data:") {
            let (meta, payload) = rest.split_once(',').ok_or("malformed data: URI")?;
            if !meta.ends_with(";base64") {
                return Err("data: URI is not base64".into());
            }
            let bytes = texture::base64(payload).ok_or("bad base64 in data: URI")?;
            return texture::decode(&bytes).map(Arc::new);
        }
        if uri.contains("://") {
            return Err(format!(
                "'{uri}' is remote; only files next to the model are read"
            ));
        }
        let file = self.base.join(texture::percent_decode(uri));
        self.files
            .file(&file)
            .map_err(|e| format!("'{}': {e}", file.display()))
    }

    /// Adds the `KHR_lights_punctual` light attached to node `index`, if any.
    fn light(&mut self, index: usize, m: &Matrix4<f64>) {
        let Some(light) = self
            .raw
            .get("nodes")
            .and_then(|n| n.get(index))
            .and_then(|n| {
                n.get("extensions")?
                    .get("KHR_lights_punctual")?
                    .get("light")?
                    .as_u64()
            })
        else {
            return;
        };
        let Some(def) = self.raw.get("extensions").and_then(|e| {
            e.get("KHR_lights_punctual")?
                .get("lights")?
                .get(light as usize)
        }) else {
            self.soup.warn(format!(
                "node {index} refers to missing light {light}; ignored"
            ));
            return;
        };
        match def.get("type").and_then(Value::as_str) {
            Some("point") | Some("spot") => {
                let p = m * Vector4::new(0.0, 0.0, 0.0, 1.0);
                self.soup.lights.push(RawLight {
                    position: self.frame.point([p.x, p.y, p.z]),
                    intensity: def.get("intensity").and_then(Value::as_f64).unwrap_or(1.0),
                });
            }
            _ => self.directional += 1,
        }
    }

    /// Ends the document: an error when nothing usable was found, else the soup.
    fn finish(mut self) -> Result<Soup> {
        let skipped: Vec<String> = self
            .skipped
            .iter()
            .map(|(mode, n)| format!("{n} {mode}"))
            .collect();
        if self.soup.tris.is_empty() {
            let msg = if !skipped.is_empty() {
                format!(
                    "the model's only primitives are {}, which indoorloc does not import: it \
                     needs TRIANGLES (or strips and fans)",
                    skipped.join(", ")
                )
            } else if self.doc.meshes().len() == 0 {
                "the file has no meshes".to_string()
            } else {
                "no mesh with triangles is placed in the scene (an empty model)".to_string()
            };
            return Err(self.fail(msg));
        }
        if !skipped.is_empty() {
            let msg = format!(
                "skipped primitives that are not triangles: {}",
                skipped.join(", ")
            );
            self.soup.warn(msg);
        }
        if self.directional > 0 {
            let msg = format!(
                "{} directional lights ignored (daylight comes from the world's atmosphere)",
                self.directional
            );
            self.soup.warn(msg);
        }
        Ok(self.soup)
    }
}

#[cfg(test)]
pub(super) mod tests {
    use super::*;
    use crate::World;
    use crate::import::{ImportOptions, load};
    use nalgebra::Point3;
    use std::path::PathBuf;

    type TestResult = std::result::Result<(), Box<dyn std::error::Error>>;

    fn fixture(name: &str) -> PathBuf {
        Path::new(env!("CARGO_MANIFEST_DIR"))
            .join("tests/data/import")
            .join(name)
    }

    /// Standard base64 with padding.
    pub(in crate::import) fn base64_encode(bytes: &[u8]) -> String {
        const A: &[u8; 64] = b"ABCDEFGHIJKLMNOPQRSTUVWXYZabcdefghijklmnopqrstuvwxyz0123456789+/";
        let mut out = String::new();
        for chunk in bytes.chunks(3) {
            let b = [
                chunk[0],
                *chunk.get(1).unwrap_or(&0),
                *chunk.get(2).unwrap_or(&0),
            ];
            let n = (u32::from(b[0]) << 16) | (u32::from(b[1]) << 8) | u32::from(b[2]);
            for k in 0..4 {
                if k <= chunk.len() {
                    out.push(A[(n >> (18 - 6 * k) & 63) as usize] as char);
                } else {
                    out.push('=');
                }
            }
        }
        out
    }

    /// Where the room's texture comes from.
    pub(in crate::import) enum Texture<'a> {
        /// A URI (a file next to the model).
        Uri(&'a str),
        /// PNG bytes in the binary buffer (GLB).
        Embedded(&'a [u8]),
    }

    /// The room of `room.obj` as glTF: JSON (without `buffers`' URI when `buffer_uri` is `None`)
    /// and its binary buffer. Mesh coordinates are local to node "room", which is translated by
    /// (1, 0, 0); its child "lamp" carries a point light at (1, 2.3, −1.5) relative to it.
    /// `room.gltf` is this with the buffer as a data: URI (see `import_gltf_fixture_is_current`).
    pub(in crate::import) fn room_gltf(
        texture: Texture,
        buffer_uri: Option<&str>,
    ) -> (String, Vec<u8>) {
        let positions: [[f32; 3]; 8] = [
            [-1.0, 0.0, 0.0],
            [3.0, 0.0, 0.0],
            [3.0, 0.0, -3.0],
            [-1.0, 0.0, -3.0],
            [-1.0, 2.5, 0.0],
            [3.0, 2.5, 0.0],
            [3.0, 2.5, -3.0],
            [-1.0, 2.5, -3.0],
        ];
        // glTF's v runs down the image: OBJ's vt (0, 0) at vertex 1 is (0, 1) here.
        let uvs: [[f32; 2]; 8] = [
            [0.0, 1.0],
            [1.0, 1.0],
            [1.0, 0.0],
            [0.0, 0.0],
            [0.0, 0.0],
            [0.0, 0.0],
            [0.0, 0.0],
            [0.0, 0.0],
        ];
        let floor: [u16; 6] = [0, 1, 2, 0, 2, 3];
        let ceiling: [u16; 6] = [4, 7, 6, 4, 6, 5];
        let walls: [u16; 24] = [
            0, 4, 5, 0, 5, 1, 3, 2, 6, 3, 6, 7, 0, 3, 7, 0, 7, 4, 1, 5, 6, 1, 6, 2,
        ];
        let mut bin = Vec::new();
        positions
            .iter()
            .flatten()
            .for_each(|x| bin.extend(x.to_le_bytes()));
        uvs.iter()
            .flatten()
            .for_each(|x| bin.extend(x.to_le_bytes()));
        floor
            .iter()
            .chain(&ceiling)
            .chain(&walls)
            .for_each(|i| bin.extend(i.to_le_bytes()));
        let geometry = bin.len(); // 232
        let (image, extra_view) = match texture {
            Texture::Uri(uri) => (format!(r#"{{"uri": "{uri}"}}"#), String::new()),
            Texture::Embedded(png) => {
                bin.extend(png);
                let view = format!(
                    r#",
    {{"buffer": 0, "byteOffset": {geometry}, "byteLength": {}}}"#,
                    png.len()
                );
                (
                    r#"{"bufferView": 3, "mimeType": "image/png"}"#.to_string(),
                    view,
                )
            }
        };
        while bin.len() % 4 != 0 {
            bin.push(0);
        }
        let uri = buffer_uri.map_or(String::new(), |u| format!(r#", "uri": "{u}""#));
        let json = format!(
            r#"{{
  "asset": {{"version": "2.0", "generator": "indoorloc test helper room_gltf"}},
  "extensionsUsed": ["KHR_lights_punctual", "KHR_materials_emissive_strength"],
  "extensions": {{"KHR_lights_punctual": {{"lights": [
    {{"type": "point", "name": "lamp", "intensity": 40.0}}
  ]}}}},
  "scene": 0,
  "scenes": [{{"nodes": [0]}}],
  "nodes": [
    {{"name": "room", "mesh": 0, "translation": [1.0, 0.0, 0.0], "children": [1]}},
    {{"name": "lamp", "translation": [1.0, 2.3, -1.5],
      "extensions": {{"KHR_lights_punctual": {{"light": 0}}}}}}
  ],
  "meshes": [{{"name": "room", "primitives": [
    {{"attributes": {{"POSITION": 0, "TEXCOORD_0": 1}}, "indices": 2, "material": 0}},
    {{"attributes": {{"POSITION": 0}}, "indices": 3, "material": 2}},
    {{"attributes": {{"POSITION": 0}}, "indices": 4, "material": 1}}
  ]}}],
  "materials": [
    {{"name": "floor", "pbrMetallicRoughness": {{"baseColorTexture": {{"index": 0}}}}}},
    {{"name": "wall", "pbrMetallicRoughness": {{"baseColorFactor": [0.5, 0.25, 0.2, 1.0]}}}},
    {{"name": "ceiling", "pbrMetallicRoughness": {{"baseColorFactor": [0.8, 0.8, 0.8, 1.0]}},
      "emissiveFactor": [1.0, 1.0, 1.0],
      "extensions": {{"KHR_materials_emissive_strength": {{"emissiveStrength": 0.6}}}}}}
  ],
  "textures": [{{"source": 0}}],
  "images": [{image}],
  "accessors": [
    {{"bufferView": 0, "componentType": 5126, "count": 8, "type": "VEC3",
      "min": [-1.0, 0.0, -3.0], "max": [3.0, 2.5, 0.0]}},
    {{"bufferView": 1, "componentType": 5126, "count": 8, "type": "VEC2"}},
    {{"bufferView": 2, "byteOffset": 0, "componentType": 5123, "count": 6, "type": "SCALAR"}},
    {{"bufferView": 2, "byteOffset": 12, "componentType": 5123, "count": 6, "type": "SCALAR"}},
    {{"bufferView": 2, "byteOffset": 24, "componentType": 5123, "count": 24, "type": "SCALAR"}}
  ],
  "bufferViews": [
    {{"buffer": 0, "byteOffset": 0, "byteLength": 96, "target": 34962}},
    {{"buffer": 0, "byteOffset": 96, "byteLength": 64, "target": 34962}},
    {{"buffer": 0, "byteOffset": 160, "byteLength": 72, "target": 34963}}{extra_view}
  ],
  "buffers": [{{"byteLength": {}{uri}}}]
}}
"#,
            bin.len()
        );
        (json, bin)
    }

    /// A GLB container holding `json` and `bin`, each chunk padded to 4 bytes.
    pub(in crate::import) fn glb(json: &str, bin: &[u8]) -> Vec<u8> {
        let mut j = json.as_bytes().to_vec();
        while !j.len().is_multiple_of(4) {
            j.push(b' ');
        }
        let mut b = bin.to_vec();
        while !b.len().is_multiple_of(4) {
            b.push(0);
        }
        let total = 12 + 8 + j.len() + 8 + b.len();
        let mut out = Vec::with_capacity(total);
        out.extend(b"glTF");
        out.extend(2u32.to_le_bytes());
        out.extend((total as u32).to_le_bytes());
        out.extend((j.len() as u32).to_le_bytes());
        out.extend(0x4E4F_534Au32.to_le_bytes());
        out.extend(j);
        out.extend((b.len() as u32).to_le_bytes());
        out.extend(0x004E_4942u32.to_le_bytes());
        out.extend(b);
        out
    }

    /// The room as a .glb with its texture inside, written to a fresh folder.
    fn room_glb() -> std::io::Result<(tempfile::TempDir, PathBuf)> {
        let png = std::fs::read(fixture("room.png"))?;
        let (json, bin) = room_gltf(Texture::Embedded(&png), None);
        let dir = tempfile::tempdir()?;
        let path = dir.path().join("room.glb");
        std::fs::write(&path, glb(&json, &bin))?;
        Ok((dir, path))
    }

    /// Writes a .gltf built from `edit(room JSON)` with an embedded buffer next to room.png.
    fn edited(
        name: &str,
        edit: impl Fn(String) -> String,
    ) -> std::io::Result<(tempfile::TempDir, PathBuf)> {
        let (json, bin) = room_gltf(Texture::Uri("room.png"), None);
        let uri = format!(
            "data:application/octet-stream;base64,{}",
            base64_encode(&bin)
        );
        let json = json.replace(
            &format!(r#""byteLength": {}}}]"#, bin.len()),
            &format!(r#""byteLength": {}, "uri": "{uri}"}}]"#, bin.len()),
        );
        let dir = tempfile::tempdir()?;
        std::fs::copy(fixture("room.png"), dir.path().join("room.png"))?;
        let path = dir.path().join(name);
        std::fs::write(&path, edit(json))?;
        Ok((dir, path))
    }

    fn load_err(path: &Path) -> String {
        match load(path, &ImportOptions::default()) {
            Ok(_) => format!("UNEXPECTED SUCCESS loading {}", path.display()),
            Err(e) => e.to_string(),
        }
    }

    /// The checks shared by room.gltf and the GLB room.
    fn check_room(world: &crate::World) -> TestResult {
        assert_eq!(world.triangles.len(), 12);
        // Local (3, 2.5, -3) + node translation (1, 0, 0) = (4, 2.5, -3) Y up = (4, 3, 2.5) Z up.
        let corner = Point3::new(4.0f32, 3.0, 2.5);
        assert!(
            world
                .triangles
                .iter()
                .flat_map(|t| t.v)
                .any(|v| (v - corner).norm() < 1e-5)
        );
        let centre = Point3::new(2.0f32, 1.5, 1.25);
        assert!(
            world
                .triangles
                .iter()
                .all(|t| t.normal().dot(&(centre - t.v[0])) > 0.0)
        );
        let find = |n: &str| {
            world
                .materials
                .iter()
                .find(|m| m.name == n)
                .ok_or(n.to_string())
        };
        let wall = find("wall")?;
        let expect = [0.5f32, 0.25, 0.2].map(|c| 1.055 * c.powf(1.0 / 2.4) - 0.055);
        assert!(
            wall.color
                .iter()
                .zip(expect)
                .all(|(a, b)| (a - b).abs() < 1e-6),
            "{:?}",
            wall.color
        );
        assert!((wall.color[0] - 0.7354).abs() < 1e-3); // linear 0.5 is sRGB 0.735
        assert_eq!(find("ceiling")?.emissive, 0.6);
        let Pattern::Image(img) = &find("floor")?.pattern else {
            return Err("floor without texture".into());
        };
        assert_eq!(
            (img.width(), img.height(), img.get_pixel(1, 0).0),
            (4, 4, [40, 80, 200])
        );
        assert_eq!(world.planes.len(), 6);
        assert_eq!(world.walk.nodes.len(), 48);
        // The lamp: (1, 2.3, -1.5) in the room node, + (1, 0, 0): (2, 2.3, -1.5) Y up.
        assert_eq!(world.lights.len(), 1);
        assert!((world.lights[0].position - Point3::new(2.0, 1.5, 2.3)).norm() < 1e-5);
        assert_eq!(world.lights[0].intensity, 1.0);
        Ok(())
    }

    #[test]
    fn import_gltf_room_fixture_matches_obj() -> TestResult {
        let (world, report) = load(&fixture("room.gltf"), &ImportOptions::default())?;
        assert!(report.warnings.is_empty(), "{:?}", report.warnings);
        check_room(&world)?;
        // The same room as OBJ: the same triangles, corner for corner, and the same floor uv.
        let obj_opts = ImportOptions {
            scale: 0.01,
            ..ImportOptions::default()
        };
        let (obj, _) = load(&fixture("room.obj"), &obj_opts)?;
        let key = |w: &crate::World| {
            let mut k: Vec<[i64; 9]> = w
                .triangles
                .iter()
                .map(|t| {
                    let mut c: Vec<[i64; 3]> =
                        t.v.iter()
                            .map(|p| [p.x, p.y, p.z].map(|x| (x * 1000.0).round() as i64))
                            .collect();
                    let r = (0..3).min_by_key(|&i| c[i]).unwrap_or(0);
                    c.rotate_left(r); // same winding, canonical first corner
                    [
                        c[0][0], c[0][1], c[0][2], c[1][0], c[1][1], c[1][2], c[2][0], c[2][1],
                        c[2][2],
                    ]
                })
                .collect();
            k.sort_unstable();
            k
        };
        assert_eq!(key(&world), key(&obj));
        let floor_uv = |w: &crate::World| {
            let m = w
                .materials
                .iter()
                .position(|m| m.name == "floor")
                .unwrap_or(usize::MAX);
            let mut uv: Vec<[i64; 5]> = w
                .triangles
                .iter()
                .filter(|t| usize::from(t.material) == m)
                .flat_map(|t| {
                    t.v.iter().zip(t.uv).map(|(p, uv)| {
                        [p.x, p.y, p.z, uv[0], uv[1]].map(|x| (x * 1000.0).round() as i64)
                    })
                })
                .collect();
            uv.sort_unstable();
            uv
        };
        assert_eq!(floor_uv(&world).len(), 6);
        assert_eq!(floor_uv(&world), floor_uv(&obj));
        Ok(())
    }

    #[test]
    fn import_gltf_glb_with_embedded_texture() -> TestResult {
        let (_dir, path) = room_glb()?;
        let (world, report) = load(&path, &ImportOptions::default())?;
        assert!(report.warnings.is_empty(), "{:?}", report.warnings);
        check_room(&world)?;
        assert_eq!(world.name, "room.glb");
        Ok(())
    }

    /// `room.gltf` is `room_gltf` with the buffer as a data: URI. Regenerate it with
    /// `INDOORLOC_BLESS=1 cargo test -p synth import_gltf_fixture_is_current`.
    #[test]
    fn import_gltf_fixture_is_current() -> TestResult {
        let (_, bin) = room_gltf(Texture::Uri("room.png"), None);
        let uri = format!(
            "data:application/octet-stream;base64,{}",
            base64_encode(&bin)
        );
        let (json, _) = room_gltf(Texture::Uri("room.png"), Some(&uri));
        let path = fixture("room.gltf");
        if std::env::var_os("INDOORLOC_BLESS").is_some() {
            std::fs::write(&path, &json)?;
        }
        assert_eq!(
            std::fs::read_to_string(&path)?,
            json,
            "run with INDOORLOC_BLESS=1"
        );
        Ok(())
    }

    #[test]
    fn import_gltf_missing_texture_is_a_warning() -> TestResult {
        let (_dir, path) = edited("nope.gltf", |j| {
            j.replace(r#""uri": "room.png""#, r#""uri": "gone.png""#)
        })?;
        let (world, report) = load(&path, &ImportOptions::default())?;
        let w = report.warnings.join("\n");
        assert!(
            w.contains("nope.gltf") && w.contains("gone.png") && w.contains("'floor'"),
            "{w}"
        );
        let floor = world
            .materials
            .iter()
            .find(|m| m.name == "floor")
            .ok_or("floor")?;
        assert_eq!(
            (floor.pattern.clone(), floor.color),
            (Pattern::Plain, [1.0; 3])
        );
        Ok(())
    }

    #[test]
    fn import_gltf_unsupported_features_are_errors_naming_them() -> TestResult {
        let msg = load_err(&fixture("draco.gltf"));
        assert!(
            msg.contains("draco.gltf") && msg.contains("KHR_draco_mesh_compression"),
            "{msg}"
        );
        assert!(msg.contains("Draco mesh compression"), "{msg}");

        let (_d, path) = edited("ext.gltf", |j| {
            j.replace(r#""extensionsUsed": ["#, r#""extensionsRequired": ["EXT_foo", "KHR_lights_punctual"], "extensionsUsed": ["EXT_foo", "#)
        })?;
        let msg = load_err(&path);
        assert!(
            msg.contains("ext.gltf") && msg.contains("EXT_foo") && !msg.contains("KHR_lights"),
            "{msg}"
        );

        // Requiring only what is handled is fine.
        let (_d, path) = edited("lights.gltf", |j| {
            j.replace(
                r#""extensionsUsed": ["#,
                r#""extensionsRequired": ["KHR_lights_punctual"], "extensionsUsed": ["#,
            )
        })?;
        assert_eq!(load(&path, &ImportOptions::default())?.0.lights.len(), 1);

        // Only lines: an error naming the mode; lines beside triangles: a warning.
        let lines = |j: String| {
            j.replace(
                r#""indices": 2, "material": 0}"#,
                r#""indices": 2, "material": 0, "mode": 1}"#,
            )
        };
        let (_d, path) = edited("lines.gltf", move |j| {
            lines(j)
                .replace(
                    r#""indices": 3, "material": 2}"#,
                    r#""indices": 3, "material": 2, "mode": 0}"#,
                )
                .replace(
                    r#""indices": 4, "material": 1}"#,
                    r#""indices": 4, "material": 1, "mode": 3}"#,
                )
        })?;
        let msg = load_err(&path);
        assert!(
            msg.contains("lines.gltf")
                && msg.contains("1 LINES")
                && msg.contains("1 POINTS")
                && msg.contains("1 LINE_STRIP"),
            "{msg}"
        );
        let (_d, path) = edited("some_lines.gltf", lines)?;
        let (world, report) = load(&path, &ImportOptions::default())?;
        assert_eq!(world.triangles.len(), 10);
        assert!(
            report
                .warnings
                .iter()
                .any(|w| w.contains("some_lines.gltf") && w.contains("1 LINES"))
        );

        // glTF 1.0.
        let (_d, path) = edited("old.gltf", |j| {
            j.replace(r#""version": "2.0""#, r#""version": "1.0""#)
        })?;
        let msg = load_err(&path);
        assert!(msg.contains("old.gltf") && msg.contains("'1.0'"), "{msg}");
        Ok(())
    }

    #[test]
    fn import_gltf_empty_and_corrupt_files_are_errors() -> TestResult {
        type Edit = Box<dyn Fn(String) -> String>;
        let cases: Vec<(&str, Edit, &str)> = vec![
            (
                "nomesh.gltf",
                Box::new(|j: String| j.replace(r#""mesh": 0, "#, "")),
                "no mesh",
            ),
            (
                "index.gltf",
                Box::new(|j: String| {
                    j.replace(
                        r#""count": 8, "type": "VEC3""#,
                        r#""count": 5, "type": "VEC3""#,
                    )
                }),
                "index 7 refers past its 5 vertices",
            ),
            (
                "range.gltf",
                Box::new(|j: String| {
                    j.replace(
                        r#""count": 24, "type": "SCALAR""#,
                        r#""count": 240, "type": "SCALAR""#,
                    )
                }),
                "reaches past the end",
            ),
            (
                "quantized.gltf",
                Box::new(|j: String| {
                    j.replace(
                        r#""componentType": 5126, "count": 8, "type": "VEC3""#,
                        r#""componentType": 5123, "count": 8, "type": "VEC3""#,
                    )
                }),
                "KHR_mesh_quantization",
            ),
            (
                "json.gltf",
                Box::new(|j: String| j[..j.len() / 2].to_string()),
                "not valid glTF JSON",
            ),
            (
                "empty.gltf",
                Box::new(|_| String::new()),
                "not valid glTF JSON",
            ),
        ];
        for (name, edit, what) in cases {
            let (_d, path) = edited(name, edit)?;
            let msg = load_err(&path);
            assert!(msg.contains(name) && msg.contains(what), "{name}: {msg}");
        }
        let (_d, path) = room_glb()?;
        let bytes = std::fs::read(&path)?;
        let cut = path.with_file_name("cut.glb");
        std::fs::write(&cut, &bytes[..bytes.len() - 10])?;
        let msg = load_err(&cut);
        assert!(
            msg.contains("cut.glb") && msg.contains("truncated GLB"),
            "{msg}"
        );
        Ok(())
    }

    #[test]
    fn import_gltf_mirrored_node_keeps_faces_inward_and_strips_fans_convert() -> TestResult {
        // Mirror the room in x about the node origin: x in [-3, 1] + 1 = [-2, 2].
        let (_d, path) = edited("mirror.gltf", |j| {
            j.replace(
                r#""translation": [1.0, 0.0, 0.0]"#,
                r#""translation": [1.0, 0.0, 0.0], "scale": [-1.0, 1.0, 1.0]"#,
            )
        })?;
        let (world, _) = load(&path, &ImportOptions::default())?;
        let centre = Point3::new(0.0f32, 1.5, 1.25);
        assert!(
            world
                .triangles
                .iter()
                .all(|t| t.normal().dot(&(centre - t.v[0])) > 0.0)
        );
        // The floor as a fan (0 1 2 3) and the ceiling as a strip (4 7 5 6): same triangles.
        let (_d, path) = edited("fan.gltf", |j| {
            j.replace(
                r#""indices": 2, "material": 0}"#,
                r#""indices": 2, "material": 0, "mode": 6}"#,
            )
            .replace(
                r#""count": 6, "type": "SCALAR"}"#,
                r#""count": 4, "type": "SCALAR"}"#,
            )
            .replace(
                r#""indices": 3, "material": 2}"#,
                r#""indices": 3, "material": 2, "mode": 5}"#,
            )
        })?;
        // Rewrite the two index runs: floor 0 1 2 3 (fan), ceiling 4 7 5 6 (strip).
        let text = std::fs::read_to_string(&path)?;
        let (_, mut bin) = room_gltf(Texture::Uri("room.png"), None);
        for (k, i) in [0u16, 1, 2, 3].iter().enumerate() {
            bin[160 + 2 * k..162 + 2 * k].copy_from_slice(&i.to_le_bytes());
        }
        for (k, i) in [4u16, 7, 5, 6].iter().enumerate() {
            bin[172 + 2 * k..174 + 2 * k].copy_from_slice(&i.to_le_bytes());
        }
        let start = text.find("base64,").ok_or("no data uri")? + 7;
        let end = start + text[start..].find('"').ok_or("no end")?;
        let text = format!("{}{}{}", &text[..start], base64_encode(&bin), &text[end..]);
        std::fs::write(&path, text)?;
        let (world, report) = load(&path, &ImportOptions::default())?;
        assert!(report.warnings.is_empty(), "{:?}", report.warnings);
        assert_eq!(world.triangles.len(), 12);
        assert_eq!(world.planes.len(), 6);
        let centre = Point3::new(2.0f32, 1.5, 1.25);
        assert!(
            world
                .triangles
                .iter()
                .all(|t| t.normal().dot(&(centre - t.v[0])) > 0.0)
        );
        Ok(())
    }

    /// A material whose `extras` name its texture an atlas of cells (as `recon` writes it) gets
    /// [`Pattern::Atlas`]; a cell side that is not a power of two is not trusted.
    #[test]
    fn import_gltf_atlas_cells_from_material_extras() -> TestResult {
        let with_cell = |cell: &'static str| {
            move |j: String| {
                j.replace(
                    r#"{"name": "floor", "pbrMetallicRoughness""#,
                    &format!(
                        r#"{{"name": "floor", "extras": {{"{ATLAS_CELL_EXTRA}": {cell}}}, "pbrMetallicRoughness""#
                    ),
                )
            }
        };
        let floor = |world: &World| {
            world
                .materials
                .iter()
                .find(|m| m.name == "floor")
                .map(|m| m.pattern.clone())
        };
        let (_d, path) = edited("atlas.gltf", with_cell("4"))?;
        let (world, _) = load(&path, &ImportOptions::default())?;
        let Some(Pattern::Atlas { image, cell: 4 }) = floor(&world) else {
            return Err(format!("{:?}", floor(&world)).into());
        };
        assert!(image.width() > 0);
        let (_d, path) = edited("odd_cell.gltf", with_cell("3"))?;
        let (world, _) = load(&path, &ImportOptions::default())?;
        assert!(matches!(floor(&world), Some(Pattern::Image(_))));
        Ok(())
    }

    /// `KHR_materials_unlit` marks a material unlit; a model whose every triangle is unlit gets
    /// no invented lights (its glowing ceiling would otherwise get one), one with a lit material
    /// still does.
    #[test]
    fn import_gltf_unlit_materials_and_no_invented_lights() -> TestResult {
        let unlit = r#""extensions": {"KHR_materials_unlit": {}}, "pbrMetallicRoughness""#;
        let edit = |all: bool| {
            move |j: String| {
                let j = j
                    .replace(
                        r#""extensions": {"KHR_lights_punctual": {"light": 0}}"#,
                        r#""extras": {}"#,
                    )
                    .replace(
                        r#"{"name": "floor", "pbrMetallicRoughness""#,
                        &format!(r#"{{"name": "floor", {unlit}"#),
                    )
                    .replace(
                        r#""extensions": {"KHR_materials_emissive_strength""#,
                        r#""extensions": {"KHR_materials_unlit": {}, "KHR_materials_emissive_strength""#,
                    );
                if all {
                    j.replace(
                        r#"{"name": "wall", "pbrMetallicRoughness""#,
                        &format!(r#"{{"name": "wall", {unlit}"#),
                    )
                } else {
                    j
                }
            }
        };
        let (_d, path) = edited("unlit.gltf", edit(true))?;
        let (world, report) = load(&path, &ImportOptions::default())?;
        assert!(world.materials.iter().all(|m| m.unlit));
        assert!(world.lights.is_empty(), "{:?}", world.lights);
        assert!(report.warnings.is_empty(), "{:?}", report.warnings);
        let (_d, path) = edited("some_unlit.gltf", edit(false))?;
        let (world, _) = load(&path, &ImportOptions::default())?;
        let unlit: Vec<(&str, bool)> = world
            .materials
            .iter()
            .map(|m| (m.name.as_str(), m.unlit))
            .collect();
        assert_eq!(
            unlit,
            [("floor", true), ("ceiling", true), ("wall", false)],
            "{unlit:?}"
        );
        assert!(!world.lights.is_empty());
        // The room as it is has no unlit material.
        let (world, _) = load(&fixture("room.gltf"), &ImportOptions::default())?;
        assert!(world.materials.iter().all(|m| !m.unlit));
        Ok(())
    }

    /// A scan with part of a floor and no ceiling imports, with a warning and an empty walk
    /// graph, one region over its box and no lights.
    #[test]
    fn import_scan_without_walkable_floor_is_a_warning() -> TestResult {
        use crate::import::test_scan;
        let dir = tempfile::tempdir()?;
        let path = test_scan::write(&dir.path().join("kitchen.glb"), None, true)?;
        let (world, report) = load(&path, &ImportOptions::default())?;
        let w = report.warnings.join("\n");
        assert!(
            w.contains("kitchen.glb") && w.contains("no walkable floor"),
            "{w}"
        );
        assert!(world.walk.nodes.is_empty());
        assert!(world.lights.is_empty());
        assert_eq!(world.regions.len(), 1);
        assert_eq!(world.triangles.len(), 6);
        assert!(world.materials.iter().all(|m| m.unlit));
        // The back wall (glTF z = -2) lies at world y = 2, facing -y.
        assert!(
            world
                .triangles
                .iter()
                .any(|t| { t.v.iter().all(|p| (p.y - 2.0).abs() < 1e-6) && t.normal().y < -0.99 })
        );
        Ok(())
    }

    #[test]
    fn scan_frame_reads_dataset_to_world() -> TestResult {
        use crate::import::{scan_frame, test_scan};
        let dir = tempfile::tempdir()?;
        let t = geom::Pose::from_euler_ypr(0.3, -0.1, 0.05, [1.0, 2.0, 0.5])?;
        let path = test_scan::write(
            &dir.path().join("scan.glb"),
            Some(&test_scan::extras(&t)),
            true,
        )?;
        let read = scan_frame(&path)?.ok_or("no transform")?;
        assert!((read.translation - t.translation).norm() < 1e-12);
        assert!(read.rotation.angle_to(&t.rotation) < 1e-9);
        // The same as .gltf text; without the record; an OBJ.
        let bytes = std::fs::read(&path)?;
        let (json, _) = split_glb(&bytes)?;
        let text = dir.path().join("scan.gltf");
        std::fs::write(&text, json)?;
        assert!(scan_frame(&text)?.is_some());
        let bare = test_scan::write(&dir.path().join("bare.glb"), None, true)?;
        assert_eq!(scan_frame(&bare)?, None);
        assert_eq!(scan_frame(&fixture("room.obj"))?, None);
        // Malformed records are errors naming the file.
        let bad = [
            (
                r#"{"indoorloc_scan": {"dataset_to_world": [1, 0, 0]}}"#,
                "16 numbers",
            ),
            (r#"{"indoorloc_scan": {"dataset": "x"}}"#, "16 numbers"),
            (
                r#"{"indoorloc_scan": {"dataset_to_world":
                    [2, 0, 0, 0, 0, 2, 0, 0, 0, 0, 2, 0, 0, 0, 0, 1]}}"#,
                "not a rigid transform",
            ),
        ];
        for (extras, what) in bad {
            let path = test_scan::write(&dir.path().join("bad.glb"), Some(extras), true)?;
            let msg = scan_frame(&path).err().ok_or("accepted")?.to_string();
            assert!(msg.contains("bad.glb") && msg.contains(what), "{msg}");
        }
        let missing = scan_frame(&dir.path().join("gone.glb"))
            .err()
            .ok_or("read a missing file")?
            .to_string();
        assert!(missing.contains("gone.glb"), "{missing}");
        Ok(())
    }

    #[test]
    fn import_gltf_never_panics_on_truncated_or_mutated_files() -> TestResult {
        use rand::{Rng, SeedableRng};
        let png = std::fs::read(fixture("room.png"))?;
        let (json, bin) = room_gltf(Texture::Embedded(&png), None);
        let bytes = glb(&json, &bin);
        let frame = Frame::new(&ImportOptions::default())?;
        let path = fixture("fuzz.glb");
        let base = fixture("");
        let run = |b: &[u8]| {
            if let Ok(soup) = parse(b, &path, &base, frame) {
                let _ = crate::import::mesh::finish(soup, &ImportOptions::default());
            }
        };
        for cut in 0..bytes.len() {
            run(&bytes[..cut]);
        }
        let mut rng = rand_chacha::ChaCha8Rng::seed_from_u64(4);
        for _ in 0..2000 {
            let mut b = bytes.clone();
            for _ in 0..rng.random_range(1..4) {
                let i = rng.random_range(0..b.len());
                b[i] = if rng.random_bool(0.5) {
                    rng.random()
                } else {
                    b'0' + rng.random_range(0..10u8)
                };
            }
            run(&b);
        }
        Ok(())
    }
}
