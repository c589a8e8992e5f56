//! Wavefront OBJ with MTL materials.
//!
//! A reader of its own rather than `tobj`: errors must name the line (tobj's carry none), a
//! malformed MTL colour must not panic (tobj 4.0.5 unwraps a two-number `Kd`), and lines and
//! points must stay distinguishable from faces (tobj turns them into degenerate triangles).
//!
//! Read: `v` (x y z; a fourth weight or vertex colours are ignored), `vt` (v flipped to point
//! down), `vn` (counted, so face references can be checked), `f` (any polygon, with 1-based or
//! negative indices, ear-clipped), `mtllib`, `usemtl`, line continuations (`\`). `l` and `p` are
//! counted and skipped; groups, smoothing groups and free-form geometry are ignored. From MTL:
//! `newmtl`, `Kd`, `Ke`, `d`, `Tr` and `map_Kd` with its `-o` and `-s` options; texture paths are
//! relative to the MTL file's folder, with Windows separators and absolute paths from the
//! exporting machine tried as file names in that folder.

use super::mesh::{RawTri, Soup, seed_of, triangulate};
use super::texture::Cache;
use super::{Frame, model_error};
use crate::world::{Material, MaterialId, Pattern};
use crate::{Result, SynthError};
use std::collections::HashMap;
use std::path::{Path, PathBuf};

/// Colour of faces without a material, or with one no MTL file defines.
const DEFAULT_COLOR: [f32; 3] = [0.7, 0.7, 0.7];

/// Reads an OBJ file and the MTL files it names.
pub(super) fn read(path: &Path, frame: Frame) -> Result<Soup> {
    let bytes = std::fs::read(path).map_err(|source| SynthError::Io {
        path: path.to_path_buf(),
        source,
    })?;
    let base = path.parent().unwrap_or_else(|| Path::new("."));
    parse(&bytes, path, base, frame)
}

/// Reads OBJ text; `path` names the file in messages, `base` is where MTL files are looked for.
pub(super) fn parse(bytes: &[u8], path: &Path, base: &Path, frame: Frame) -> Result<Soup> {
    let mut soup = Soup::new(path);
    let mut reader = Reader::new(frame, base);
    for (no, line) in logical_lines(bytes) {
        reader.line(&mut soup, no, &line)?;
    }
    reader.finish(soup)
}

/// Lines with their 1-based numbers, continuation lines (ending in `\`) joined, decoded as UTF-8
/// with invalid bytes replaced (names may be in a legacy code page; numbers are ASCII anyway).
fn logical_lines(bytes: &[u8]) -> impl Iterator<Item = (usize, String)> + '_ {
    let mut physical = bytes.split(|&b| b == b'\n').enumerate().peekable();
    std::iter::from_fn(move || {
        let (i, first) = physical.next()?;
        let mut line = String::from_utf8_lossy(first).trim_end().to_string();
        while line.ends_with('\\') {
            line.pop();
            match physical.next() {
                Some((_, more)) => {
                    line.push(' ');
                    line.push_str(String::from_utf8_lossy(more).trim_end());
                }
                None => break,
            }
        }
        Some((i + 1, line))
    })
}

/// Texture coordinate transform from `map_Kd` options: `uv · scale + offset`.
#[derive(Clone, Copy, Debug, PartialEq)]
struct UvTransform {
    /// `-s u v`.
    scale: [f32; 2],
    /// `-o u v`.
    offset: [f32; 2],
}

impl Default for UvTransform {
    fn default() -> Self {
        Self {
            scale: [1.0; 2],
            offset: [0.0; 2],
        }
    }
}

/// The state of reading one OBJ file.
struct Reader {
    /// File to world conversion.
    frame: Frame,
    /// Folder of the OBJ file.
    base: PathBuf,
    /// Texture coordinates so far, OBJ convention (v up).
    texcoords: Vec<[f32; 2]>,
    /// Normals so far (only counted).
    normals: usize,
    /// Materials by name, from the MTL files.
    by_name: HashMap<String, MaterialId>,
    /// Texture transforms of textured materials.
    uv_transform: HashMap<MaterialId, UvTransform>,
    /// The material of the faces that follow.
    current: Option<MaterialId>,
    /// The material of faces before any `usemtl`.
    default: Option<MaterialId>,
    /// Decoded textures.
    textures: Cache,
    /// Line and point elements skipped.
    lines_points: usize,
    /// Free-form curves and surfaces skipped.
    free_form: usize,
    /// Lines with keywords OBJ does not have (to recognise files that are not OBJ at all).
    unknown: usize,
    /// Corners of the face being read: position index and texture coordinate index.
    corners: Vec<(u32, Option<usize>)>,
    /// Corner positions of the face being read.
    corner_pos: Vec<[f64; 3]>,
    /// Triangles of the face being read.
    ears: Vec<[usize; 3]>,
}

impl Reader {
    /// A reader for a file in folder `base`.
    fn new(frame: Frame, base: &Path) -> Self {
        Self {
            frame,
            base: base.to_path_buf(),
            texcoords: Vec::new(),
            normals: 0,
            by_name: HashMap::new(),
            uv_transform: HashMap::new(),
            current: None,
            default: None,
            textures: Cache::default(),
            lines_points: 0,
            free_form: 0,
            unknown: 0,
            corners: Vec::new(),
            corner_pos: Vec::new(),
            ears: Vec::new(),
        }
    }

    /// Reads one logical line.
    fn line(&mut self, soup: &mut Soup, no: usize, line: &str) -> Result<()> {
        let line = line.trim();
        let (keyword, rest) = line
            .split_once(|c: char| c.is_whitespace())
            .map_or((line, ""), |(k, r)| (k, r.trim()));
        // Comments end data lines; names (mtllib, usemtl) may legitimately contain '#'.
        let data = rest.split('#').next().unwrap_or("");
        match keyword {
            "" => {}
            k if k.starts_with('#') => {}
            "v" => {
                let p = numbers::<3>(data).ok_or_else(|| {
                    err(
                        soup,
                        no,
                        format!("a vertex needs three numbers, found 'v {data}'"),
                    )
                })?;
                let p = self.frame.point(p.map(f64::from));
                soup.positions.push(p);
            }
            "vt" => {
                let mut it = data.split_whitespace().map(str::parse::<f32>);
                let u = match it.next() {
                    Some(Ok(u)) => u,
                    _ => {
                        return Err(err(
                            soup,
                            no,
                            format!("a texture coordinate needs a number, found 'vt {data}'"),
                        ));
                    }
                };
                let v = match it.next() {
                    None => 0.0,
                    Some(Ok(v)) => v,
                    Some(Err(_)) => {
                        return Err(err(soup, no, format!("bad texture coordinate 'vt {data}'")));
                    }
                };
                self.texcoords.push([u, v]);
            }
            "vn" => {
                numbers::<3>(data).ok_or_else(|| {
                    err(
                        soup,
                        no,
                        format!("a normal needs three numbers, found 'vn {data}'"),
                    )
                })?;
                self.normals += 1;
            }
            "f" | "fo" => self.face(soup, no, data)?,
            "l" | "p" => self.lines_points += 1,
            "vp" | "cstype" | "deg" | "bmat" | "step" | "curv" | "curv2" | "surf" | "parm"
            | "trim" | "hole" | "scrv" | "sp" | "end" | "con" => self.free_form += 1,
            "o" | "g" | "s" | "mg" | "usemap" | "maplib" | "lod" | "bevel" | "c_interp"
            | "d_interp" | "shadow_obj" | "trace_obj" | "ctech" | "stech" => {}
            "mtllib" => self.mtllib(soup, rest)?,
            "usemtl" => self.usemtl(soup, no, rest)?,
            _ => self.unknown += 1,
        }
        Ok(())
    }

    /// Reads a face: checks every reference, triangulates, and stores the triangles.
    fn face(&mut self, soup: &mut Soup, no: usize, data: &str) -> Result<()> {
        self.corners.clear();
        let n_pos = soup.positions.len();
        for corner in data.split_whitespace() {
            let mut parts = corner.split('/');
            let v = parts.next().unwrap_or("");
            let vt = parts.next().unwrap_or("");
            let vn = parts.next().unwrap_or("");
            if parts.next().is_some() {
                return Err(err(soup, no, format!("bad face corner '{corner}'")));
            }
            let vi = resolve(soup, no, corner, v, n_pos, "vertex")?;
            let ti = if vt.is_empty() {
                None
            } else {
                Some(resolve(
                    soup,
                    no,
                    corner,
                    vt,
                    self.texcoords.len(),
                    "texture coordinate",
                )?)
            };
            if !vn.is_empty() {
                resolve(soup, no, corner, vn, self.normals, "normal")?;
            }
            let vi =
                u32::try_from(vi).map_err(|_| err(soup, no, "more than 4 294 967 295 vertices"))?;
            self.corners.push((vi, ti));
        }
        if self.corners.len() < 3 {
            return Err(err(
                soup,
                no,
                format!(
                    "a face needs at least three corners, found {} in 'f {data}' (a half-written \
                     line?)",
                    self.corners.len()
                ),
            ));
        }
        let material = match self.current {
            Some(m) => m,
            None => self.default_material(soup)?,
        };
        let xf = self.uv_transform.get(&material).copied();
        self.corner_pos.clear();
        for &(vi, _) in &self.corners {
            self.corner_pos
                .push(soup.positions.get(vi as usize).copied().unwrap_or([0.0; 3]));
        }
        self.ears.clear();
        triangulate(&self.corner_pos, &mut self.ears);
        for ear in &self.ears {
            let c = ear.map(|i| self.corners.get(i).copied().unwrap_or((0, None)));
            let uv = match (xf, c[0].1, c[1].1, c[2].1) {
                (Some(xf), Some(a), Some(b), Some(d)) => {
                    let at = |i: usize| {
                        let [u, v] = self.texcoords.get(i).copied().unwrap_or([0.0; 2]);
                        let u = u * xf.scale[0] + xf.offset[0];
                        let v = v * xf.scale[1] + xf.offset[1];
                        [u, 1.0 - v]
                    };
                    Some([at(a), at(b), at(d)])
                }
                _ => None,
            };
            soup.tris.push(RawTri {
                v: [c[0].0, c[1].0, c[2].0],
                uv,
                material,
            });
        }
        Ok(())
    }

    /// The grey material of faces before any `usemtl`.
    fn default_material(&mut self, soup: &mut Soup) -> Result<MaterialId> {
        if let Some(m) = self.default {
            return Ok(m);
        }
        let m = soup.add_material(Material::plain("default", DEFAULT_COLOR))?;
        self.default = Some(m);
        Ok(m)
    }

    /// `usemtl NAME`: selects a material, defining a grey one (with a warning) for unknown names.
    fn usemtl(&mut self, soup: &mut Soup, no: usize, name: &str) -> Result<()> {
        if name.is_empty() {
            soup.warn(format!("line {no}: 'usemtl' without a name, ignored"));
            return Ok(());
        }
        if let Some(&m) = self.by_name.get(name) {
            self.current = Some(m);
            return Ok(());
        }
        soup.warn(format!(
            "line {no}: material '{name}' is not defined in any MTL file; it renders grey"
        ));
        let mut mat = Material::plain(name, DEFAULT_COLOR);
        mat.seed = seed_of(name);
        let m = soup.add_material(mat)?;
        self.by_name.insert(name.to_string(), m);
        self.current = Some(m);
        Ok(())
    }

    /// `mtllib FILE...`: reads material files (a missing one is a warning: colours fall back).
    fn mtllib(&mut self, soup: &mut Soup, rest: &str) -> Result<()> {
        // One name with spaces, or several names separated by spaces.
        let whole = self.base.join(rest);
        let files: Vec<String> = if whole.is_file() || !rest.contains(char::is_whitespace) {
            vec![rest.to_string()]
        } else {
            rest.split_whitespace().map(str::to_string).collect()
        };
        for name in files {
            let mtl = self.base.join(&name);
            match std::fs::read(&mtl) {
                Ok(bytes) => self.mtl(soup, &mtl, &bytes)?,
                Err(e) => soup.warn(format!(
                    "material library '{}' cannot be read ({e}); its materials render grey",
                    mtl.display()
                )),
            }
        }
        Ok(())
    }

    /// Reads an MTL file's materials (first definition of a name wins); problems are warnings.
    fn mtl(&mut self, soup: &mut Soup, mtl: &Path, bytes: &[u8]) -> Result<()> {
        let folder = mtl.parent().unwrap_or_else(|| Path::new(".")).to_path_buf();
        let mut defs: Vec<MtlDef> = Vec::new();
        let mut warnings = Vec::new();
        for (no, line) in logical_lines(bytes) {
            let line = line.trim();
            let (keyword, rest) = line
                .split_once(|c: char| c.is_whitespace())
                .map_or((line, ""), |(k, r)| (k, r.trim()));
            let mut warn = |what: String| {
                warnings.push(format!("{} line {no}: {what}", mtl.display()));
            };
            if keyword == "newmtl" {
                if rest.is_empty() {
                    warn("'newmtl' without a name, ignored".into());
                } else {
                    defs.push(MtlDef::new(rest));
                }
                continue;
            }
            let Some(def) = defs.last_mut() else {
                continue; // statements before the first newmtl have nothing to apply to
            };
            let lower = keyword.to_ascii_lowercase();
            match lower.as_str() {
                "kd" | "ke" => match colour(rest) {
                    Ok(c) if lower == "kd" => def.kd = Some(c),
                    Ok(c) => def.ke = Some(c),
                    Err(why) => warn(format!("{keyword} {why}, ignored")),
                },
                "d" | "tr" => match rest.split_whitespace().last().map(str::parse::<f32>) {
                    Some(Ok(x)) if x.is_finite() => {
                        let opacity = if lower == "d" { x } else { 1.0 - x };
                        def.opacity = Some(opacity.clamp(0.0, 1.0));
                    }
                    _ => warn(format!("'{keyword} {rest}' is not a number, ignored")),
                },
                "map_kd" => match texture_options(rest) {
                    Some((file, xf)) => def.map_kd = Some((file, xf, no)),
                    None => warn(format!("'{keyword}' without a file name, ignored")),
                },
                _ => {}
            }
        }
        for w in warnings {
            soup.warn(w);
        }
        for def in defs {
            if self.by_name.contains_key(&def.name) {
                continue;
            }
            let (mat, xf) = self.material(soup, &folder, mtl, &def);
            let m = soup.add_material(mat)?;
            if let Some(xf) = xf {
                self.uv_transform.insert(m, xf);
            }
            self.by_name.insert(def.name, m);
        }
        Ok(())
    }

    /// Turns an MTL definition into a material, loading its texture (a failure is a warning and
    /// leaves the colour).
    fn material(
        &mut self,
        soup: &mut Soup,
        folder: &Path,
        mtl: &Path,
        def: &MtlDef,
    ) -> (Material, Option<UvTransform>) {
        let color = def.kd.unwrap_or(DEFAULT_COLOR);
        let emissive = def
            .ke
            .map_or(0.0, |k| k.iter().fold(0.0f32, |a, &b| a.max(b)))
            .clamp(0.0, 1.0);
        let mut mat = Material {
            name: def.name.clone(),
            color,
            pattern: Pattern::Plain,
            seed: seed_of(&def.name),
            emissive,
            unlit: false,
        };
        let mut xf = None;
        if let Some((file, transform, no)) = &def.map_kd {
            let candidates = texture_candidates(folder, file);
            match candidates.iter().find(|p| p.is_file()) {
                None => soup.warn(format!(
                    "{} line {no}: texture '{file}' of material '{}' not found (looked for {}); \
                     the material keeps its colour",
                    mtl.display(),
                    def.name,
                    candidates
                        .first()
                        .map_or_else(|| file.clone(), |p| p.display().to_string())
                )),
                Some(p) => match self.textures.file(p) {
                    Ok(img) => {
                        mat.pattern = Pattern::Image(img);
                        xf = Some(*transform);
                    }
                    Err(e) => soup.warn(format!(
                        "{} line {no}: texture '{}' of material '{}' cannot be read ({e}); the \
                         material keeps its colour",
                        mtl.display(),
                        p.display(),
                        def.name
                    )),
                },
            }
        }
        if !matches!(mat.pattern, Pattern::Image(_)) && def.opacity.is_some_and(|o| o < 0.6) {
            mat.pattern = Pattern::Window; // glazing
        }
        (mat, xf)
    }

    /// Ends the file: an error when nothing usable was found, else the soup.
    fn finish(self, mut soup: Soup) -> Result<Soup> {
        if soup.tris.is_empty() {
            let msg = if self.lines_points > 0 || self.free_form > 0 {
                format!(
                    "the model has no faces, only {} line/point elements and {} free-form \
                     curve/surface statements, which indoorloc does not import: export surfaces \
                     as a triangle or polygon mesh",
                    self.lines_points, self.free_form
                )
            } else if soup.positions.is_empty() && self.unknown > 0 {
                format!(
                    "no vertices or faces in {} lines: this does not look like an OBJ file",
                    self.unknown
                )
            } else {
                "the model has no faces (an empty file, or vertices without faces)".to_string()
            };
            return Err(model_error(&soup.path, msg));
        }
        if self.lines_points > 0 {
            soup.warn(format!(
                "{} line and point elements skipped (only faces are imported)",
                self.lines_points
            ));
        }
        if self.free_form > 0 {
            soup.warn(format!(
                "{} free-form curve and surface statements skipped",
                self.free_form
            ));
        }
        Ok(soup)
    }
}

/// A material as an MTL file defines it.
#[derive(Clone, Debug, Default)]
struct MtlDef {
    /// Name.
    name: String,
    /// Diffuse colour.
    kd: Option<[f32; 3]>,
    /// Emitted colour.
    ke: Option<[f32; 3]>,
    /// Opacity, 0–1.
    opacity: Option<f32>,
    /// Diffuse texture: file, transform, line.
    map_kd: Option<(String, UvTransform, usize)>,
}

impl MtlDef {
    /// A material named `name`.
    fn new(name: &str) -> Self {
        Self {
            name: name.to_string(),
            ..Self::default()
        }
    }
}

/// An error at line `no` of the soup's file.
fn err(soup: &Soup, no: usize, msg: impl std::fmt::Display) -> SynthError {
    model_error(&soup.path, format!("line {no}: {msg}"))
}

/// The first `N` whitespace-separated numbers of `text`; `None` if there are fewer or one is
/// not a number.
fn numbers<const N: usize>(text: &str) -> Option<[f32; N]> {
    let mut out = [0.0; N];
    let mut it = text.split_whitespace();
    for o in &mut out {
        *o = it.next()?.parse().ok()?;
    }
    Some(out)
}

/// A face corner's index (1-based, or negative counting back from the last one defined) as a
/// 0-based index below `count`.
fn resolve(
    soup: &Soup,
    no: usize,
    corner: &str,
    text: &str,
    count: usize,
    what: &str,
) -> Result<usize> {
    let i: i64 = text.parse().map_err(|_| {
        err(
            soup,
            no,
            format!("'{corner}' is not a valid face corner (a half-written line?)"),
        )
    })?;
    let index = if i > 0 {
        usize::try_from(i - 1).ok().filter(|&j| j < count)
    } else if i < 0 {
        usize::try_from(i.unsigned_abs())
            .ok()
            .and_then(|back| count.checked_sub(back))
    } else {
        return Err(err(
            soup,
            no,
            format!("face corner '{corner}' uses {what} index 0 (OBJ counts from 1)"),
        ));
    };
    index.ok_or_else(|| {
        err(
            soup,
            no,
            format!(
                "face corner '{corner}' refers to {what} {i}, but only {count} are defined before \
                 it (a truncated or corrupt file?)"
            ),
        )
    })
}

/// An MTL colour: three numbers, or one for grey; clamped to 0–1.
fn colour(text: &str) -> std::result::Result<[f32; 3], String> {
    let words: Vec<&str> = text.split_whitespace().collect();
    if matches!(words.first(), Some(&"spectral") | Some(&"xyz")) {
        return Err(format!("'{}' colours are not supported", words[0]));
    }
    let vals: Vec<f32> = words
        .iter()
        .map(|w| w.parse::<f32>())
        .collect::<std::result::Result<_, _>>()
        .map_err(|_| format!("'{text}' is not a colour"))?;
    let c = match vals.as_slice() {
        [g] => [*g; 3],
        [r, g, b, ..] => [*r, *g, *b],
        _ => return Err(format!("'{text}' needs one or three numbers")),
    };
    if c.iter().any(|x| !x.is_finite()) {
        return Err(format!("'{text}' is not a colour"));
    }
    Ok(c.map(|x| x.clamp(0.0, 1.0)))
}

/// Splits `map_Kd` arguments into the file name and the `-o`/`-s` transform, skipping other
/// options; `None` without a file name.
fn texture_options(text: &str) -> Option<(String, UvTransform)> {
    let words: Vec<&str> = text.split_whitespace().collect();
    let mut xf = UvTransform::default();
    let mut i = 0;
    while i < words.len() {
        let takes = match words[i] {
            "-blendu" | "-blendv" | "-cc" | "-clamp" | "-imfchan" | "-texres" | "-bm"
            | "-boost" | "-type" => Some(1),
            "-mm" => Some(2),
            "-o" | "-s" | "-t" => None, // one to three numbers
            _ => break,
        };
        let option = words[i];
        i += 1;
        match takes {
            Some(n) => i += n,
            None => {
                let mut vals = Vec::new();
                while vals.len() < 3 {
                    match words.get(i).and_then(|w| w.parse::<f32>().ok()) {
                        Some(v) => {
                            vals.push(v);
                            i += 1;
                        }
                        None => break,
                    }
                }
                let u = vals.first().copied();
                let v = vals.get(1).copied().or(u);
                if let (Some(u), Some(v)) = (u, v) {
                    match option {
                        "-o" => xf.offset = [u, v],
                        "-s" => xf.scale = [u, v],
                        _ => {}
                    }
                }
            }
        }
    }
    let file = words.get(i..).map(|w| w.join(" ")).unwrap_or_default();
    (!file.is_empty()).then_some((file, xf))
}

/// Where a texture named in an MTL file may be: as written (relative to the MTL folder), with
/// Windows separators, and as a bare file name in the MTL folder (exporters write absolute paths
/// from the machine that made the file).
fn texture_candidates(folder: &Path, file: &str) -> Vec<PathBuf> {
    let mut out = vec![folder.join(file)];
    let slashed = file.replace('\\', "/");
    if slashed != file {
        out.push(folder.join(&slashed));
    }
    if let Some(name) = slashed.rsplit('/').next() {
        let bare = folder.join(name);
        if !out.contains(&bare) {
            out.push(bare);
        }
    }
    out
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::import::{ImportOptions, UpAxis, load};
    use nalgebra::Point3;

    type TestResult = std::result::Result<(), Box<dyn std::error::Error>>;

    fn fixture(name: &str) -> PathBuf {
        Path::new(env!("CARGO_MANIFEST_DIR"))
            .join("tests/data/import")
            .join(name)
    }

    /// The room fixture's options: centimetres, Y up.
    fn cm() -> ImportOptions {
        ImportOptions {
            scale: 0.01,
            ..ImportOptions::default()
        }
    }

    /// Writes `files` (name, content) into a fresh folder.
    fn folder(files: &[(&str, &str)]) -> std::io::Result<tempfile::TempDir> {
        let dir = tempfile::tempdir()?;
        for (name, text) in files {
            std::fs::write(dir.path().join(name), text)?;
        }
        Ok(dir)
    }

    /// The error message of a load that must fail.
    fn load_err(path: &Path, opts: &ImportOptions) -> String {
        match load(path, opts) {
            Ok(_) => format!("UNEXPECTED SUCCESS loading {}", path.display()),
            Err(e) => e.to_string(),
        }
    }

    /// A 4 x 3 x 2.5 m room in metres, Y up, as OBJ text (the room fixture without materials).
    const ROOM_M: &str = "v 0 0 0\nv 4 0 0\nv 4 0 -3\nv 0 0 -3\nv 0 2.5 0\nv 4 2.5 0\n\
                          v 4 2.5 -3\nv 0 2.5 -3\nf 1 2 3 4\nf 5 8 7 6\nf 1 5 6 2\nf 4 3 7 8\n\
                          f 1 4 8 5\nf 2 6 7 3\n";

    #[test]
    fn import_obj_room_fixture() -> TestResult {
        let (world, report) = load(&fixture("room.obj"), &cm())?;
        assert!(report.warnings.is_empty(), "{:?}", report.warnings);
        assert_eq!(world.name, "room.obj");
        assert_eq!(world.triangles.len(), 12);
        // Vertex 7, (400, 250, -300) cm with Y up: (4, 3, 2.5) m with Z up.
        let corner = Point3::new(4.0f32, 3.0, 2.5);
        assert!(
            world
                .triangles
                .iter()
                .flat_map(|t| t.v)
                .any(|v| (v - corner).norm() < 1e-5),
            "no vertex at {corner}"
        );
        let (lo, hi) = world.bounds().ok_or("no bounds")?;
        assert!((lo - Point3::origin()).norm() < 1e-5 && (hi - corner).norm() < 1e-5);
        // Every face points into the room (its centre is at (2, 1.5, 1.25)).
        let centre = Point3::new(2.0f32, 1.5, 1.25);
        for t in &world.triangles {
            assert!(t.normal().dot(&(centre - t.v[0])) > 0.0, "{t:?} faces out");
        }
        let by_name = |n: &str| world.materials.iter().position(|m| m.name == n);
        let (floor, wall, ceiling) = (
            by_name("floor").ok_or("floor")?,
            by_name("wall").ok_or("wall")?,
            by_name("ceiling").ok_or("ceiling")?,
        );
        assert_eq!(world.materials[wall].color, [0.8, 0.6, 0.4]);
        assert_eq!(world.materials[wall].pattern, Pattern::Plain);
        assert_eq!(world.materials[ceiling].emissive, 0.6);
        let Pattern::Image(img) = &world.materials[floor].pattern else {
            return Err("the floor has no texture".into());
        };
        assert_eq!((img.width(), img.height()), (4, 4));
        assert_eq!(img.get_pixel(0, 0).0, [200, 60, 40]);
        // The floor's vt (0, 0) at vertex 1 (the origin) is the image's bottom-left: v = 1 down.
        let floor_tris: Vec<_> = world
            .triangles
            .iter()
            .filter(|t| usize::from(t.material) == floor)
            .collect();
        assert_eq!(floor_tris.len(), 2);
        for t in &floor_tris {
            for (p, uv) in t.v.iter().zip(t.uv) {
                assert!(
                    (uv[0] - p.x / 4.0).abs() < 1e-5 && (uv[1] - (1.0 - p.y / 3.0)).abs() < 1e-5
                );
            }
        }
        // Walls get metres along the surface: the x = 4 wall spans 3 m by 2.5 m of uv.
        let wall_uv: Vec<[f32; 2]> = world
            .triangles
            .iter()
            .filter(|t| t.v.iter().all(|p| (p.x - 4.0).abs() < 1e-5))
            .flat_map(|t| t.uv)
            .collect();
        let span = |k: usize| {
            let vals = wall_uv.iter().map(|uv| uv[k]);
            vals.clone().fold(f32::MIN, f32::max) - vals.fold(f32::MAX, f32::min)
        };
        assert!((span(0) - 3.0).abs() < 1e-5 && (span(1) - 2.5).abs() < 1e-5);
        // Six walls, six planes; every triangle on one.
        assert_eq!(world.planes.len(), 6);
        assert!(world.triangles.iter().all(|t| t.plane > 0));
        // A walk grid inside the room, 0.5 m apart, on the floor.
        assert_eq!(world.walk.nodes.len(), 8 * 6);
        assert!(world.walk.nodes.iter().all(|n| n.p.x > 0.0
            && n.p.x < 4.0
            && n.p.y > 0.0
            && n.p.y < 3.0
            && n.p.z.abs() < 1e-5));
        assert_eq!(world.walk.edges.len(), 7 * 6 + 8 * 5 + 2 * 7 * 5);
        assert_eq!(world.regions.len(), 1);
        assert_eq!(world.regions[0].place.storey, 0);
        // No light sources in an OBJ: one in front of each glowing ceiling patch.
        assert!(!world.lights.is_empty());
        assert!(
            world
                .lights
                .iter()
                .all(|l| (l.position.z - 2.4).abs() < 1e-4)
        );
        Ok(())
    }

    #[test]
    fn import_obj_up_axis_z_keeps_coordinates_and_warns_without_floor() -> TestResult {
        let opts = ImportOptions {
            up: UpAxis::Z,
            ..cm()
        };
        let (world, _) = load(&fixture("room.obj"), &opts)?;
        let corner = Point3::new(4.0f32, 2.5, -3.0);
        assert!(
            world
                .triangles
                .iter()
                .flat_map(|t| t.v)
                .any(|v| (v - corner).norm() < 1e-5)
        );
        // A lone wall: nothing to stand on, and a warning says what to check.
        let dir = folder(&[(
            "wall.obj",
            "v 0 0 0\nv 4 0 0\nv 4 0 2.5\nv 0 0 2.5\nf 1 2 3 4\n",
        )])?;
        let opts = ImportOptions {
            up: UpAxis::Z,
            ..ImportOptions::default()
        };
        let (world, report) = load(&dir.path().join("wall.obj"), &opts)?;
        assert!(world.walk.nodes.is_empty());
        assert!(
            report
                .warnings
                .iter()
                .any(|w| w.contains("wall.obj") && w.contains("up axis")),
            "{:?}",
            report.warnings
        );
        Ok(())
    }

    #[test]
    fn import_obj_truncated_face_names_file_and_line() -> TestResult {
        let msg = load_err(&fixture("truncated.obj"), &ImportOptions::default());
        assert!(msg.contains("truncated.obj"), "{msg}");
        assert!(msg.contains("line 8") && msg.contains("vertex 9"), "{msg}");
        Ok(())
    }

    #[test]
    fn import_obj_half_written_lines_are_errors_with_line_numbers() -> TestResult {
        let cases = [
            (
                "v 0 0 0\nv 1 0 0\nv 1 1 0\nf 1 2",
                "line 4",
                "three corners",
            ),
            ("v 0 0 0\nv 1 0 0\nv 1 1", "line 3", "three numbers"),
            ("v 0 0 0\nv 1 0 0\nv 1 1 0\nf 1 2 3/", "", ""),
            (
                "v 0 0 0\nv 1 0 0\nv 1 1 0\nf 1 2 3/4",
                "line 4",
                "texture coordinate 4",
            ),
            ("v 0 0 0\nv 1 0 0\nv 1 1 0\nf 1 2 x", "line 4", "'x'"),
            ("v 0 0 0\nv 1 0 0\nv 1 1 0\nf 0 1 2", "line 4", "index 0"),
            (
                "v 0 0 0\nv 1 0 0\nv 1 1 0\nf -1 -2 -4",
                "line 4",
                "vertex -4",
            ),
            ("v 0 0 0\nvt 0.5\nvt\n", "line 3", "texture coordinate"),
        ];
        for (text, line, what) in cases {
            let dir = folder(&[("cut.obj", text)])?;
            let path = dir.path().join("cut.obj");
            let result = load(&path, &ImportOptions::default());
            if line.is_empty() {
                // A trailing '/' is a legal empty texture reference.
                assert!(result.is_ok(), "{result:?}");
                continue;
            }
            let msg = result.err().ok_or(format!("{text:?} loaded"))?.to_string();
            assert!(
                msg.contains("cut.obj") && msg.contains(line) && msg.contains(what),
                "{text:?}: {msg}"
            );
        }
        Ok(())
    }

    #[test]
    fn import_obj_empty_lines_only_and_not_obj_are_errors() -> TestResult {
        let dir = folder(&[
            ("empty.obj", ""),
            ("vertices.obj", "v 0 0 0\nv 1 0 0\nv 1 1 0\n"),
            ("junk.obj", "PK\u{3}\u{4} binary junk\nmore junk\n"),
        ])?;
        for (name, what) in [
            ("empty.obj", "no faces"),
            ("vertices.obj", "no faces"),
            ("junk.obj", "does not look like an OBJ file"),
        ] {
            let msg = load_err(&dir.path().join(name), &ImportOptions::default());
            assert!(msg.contains(name) && msg.contains(what), "{msg}");
        }
        let msg = load_err(&fixture("lines_only.obj"), &ImportOptions::default());
        assert!(
            msg.contains("lines_only.obj") && msg.contains("line/point"),
            "{msg}"
        );
        let msg = load_err(
            Path::new("/nonexistent/model.obj"),
            &ImportOptions::default(),
        );
        assert!(msg.contains("/nonexistent/model.obj"), "{msg}");
        Ok(())
    }

    #[test]
    fn import_obj_missing_texture_and_mtl_are_warnings() -> TestResult {
        let (world, report) = load(&fixture("missing_texture.obj"), &ImportOptions::default())?;
        let w = report.warnings.join("\n");
        assert!(
            w.contains("missing_texture.mtl") && w.contains("no_such_texture.png"),
            "{w}"
        );
        let m = world
            .materials
            .iter()
            .find(|m| m.name == "floor")
            .ok_or("floor")?;
        assert_eq!(
            (m.pattern.clone(), m.color),
            (Pattern::Plain, [0.3, 0.5, 0.7])
        );

        let dir = folder(&[(
            "room.obj",
            &format!("mtllib gone.mtl\nusemtl paint\n{ROOM_M}"),
        )])?;
        let (world, report) = load(&dir.path().join("room.obj"), &ImportOptions::default())?;
        let w = report.warnings.join("\n");
        assert!(
            w.contains("room.obj") && w.contains("gone.mtl") && w.contains("'paint'"),
            "{w}"
        );
        assert_eq!(world.triangles.len(), 12);
        Ok(())
    }

    #[test]
    fn import_obj_degenerate_and_nan_triangles_are_dropped_with_counts() -> TestResult {
        // Vertex 9 lies halfway between vertices 1 and 3; vertex 10 is not a number.
        let text = format!("{ROOM_M}v 2 0 -1.5\nv nan 1 -1\nf 1 2 2\nf 1 9 3\nf 9 10 1\nf 1 2 2\n");
        let dir = folder(&[("bad.obj", &text)])?;
        let (world, report) = load(&dir.path().join("bad.obj"), &ImportOptions::default())?;
        assert_eq!(world.triangles.len(), 12);
        let w = report.warnings.join("\n");
        assert!(w.contains("bad.obj"), "{w}");
        assert!(w.contains("1 of 16 triangles have non-finite"), "{w}");
        assert!(w.contains("3 of 16 triangles are degenerate"), "{w}");
        Ok(())
    }

    #[test]
    fn import_obj_non_manifold_edges_are_counted() -> TestResult {
        let (world, report) = load(&fixture("nonmanifold.obj"), &ImportOptions::default())?;
        assert_eq!(world.triangles.len(), 13);
        let w = report.warnings.join("\n");
        assert!(
            w.contains("nonmanifold.obj") && w.contains("1 edges are shared by more"),
            "{w}"
        );
        Ok(())
    }

    #[test]
    fn import_obj_absurd_scale_suggests_a_scale() -> TestResult {
        let path = fixture("room.obj");
        // At 100 m per unit the centimetre room is 40 km across, at 0.1 mm per unit 4 cm.
        for scale in [100.0, 0.0001] {
            let opts = ImportOptions {
                scale,
                ..ImportOptions::default()
            };
            let msg = load_err(&path, &opts);
            assert!(
                msg.contains("room.obj") && msg.contains("--scale 0.01 if it is in centimetres"),
                "{msg}"
            );
        }
        let opts = ImportOptions {
            scale: -1.0,
            ..ImportOptions::default()
        };
        assert!(load_err(&path, &opts).contains("positive"));
        Ok(())
    }

    #[test]
    fn import_obj_polygons_negative_indices_and_texture_options() -> TestResult {
        let mtl = "newmtl tiles\nKd 0.5\nmap_Kd -s 2 2 -o 0.5 0 textures\\room.png\n\
                   newmtl glass\nKd 0.6 0.8 0.9\nd 0.3\nnewmtl odd\nKd 0.5 0.5\n";
        let obj = "mtllib m.mtl\nv 0 0 0\nv 4 0 0\nv 4 0 -3\nv 2 0 -1.5\nv 0 0 -3\nvt 0 0\n\
                   usemtl tiles\n\
                   # a concave floor pentagon, relative indices, one shared texture coordinate\n\
                   f -5/-1 -4/-1 -3/-1 \\\n  -2/-1 -1/-1\nusemtl glass\nv 0 2.5 0\nf 1 2 6\n\
                   usemtl odd\nf 6 2 3\n";
        let dir = folder(&[("p.obj", obj), ("m.mtl", mtl)])?;
        std::fs::create_dir(dir.path().join("textures"))?;
        std::fs::copy(fixture("room.png"), dir.path().join("textures/room.png"))?;
        let (world, report) = load(&dir.path().join("p.obj"), &ImportOptions::default())?;
        assert_eq!(world.triangles.len(), 3 + 1 + 1);
        let tiles = world
            .materials
            .iter()
            .position(|m| m.name == "tiles")
            .ok_or("tiles")?;
        assert!(matches!(world.materials[tiles].pattern, Pattern::Image(_)));
        assert_eq!(world.materials[tiles].color, [0.5; 3]);
        // vt (0, 0) scaled by 2 and offset by (0.5, 0): u = 0.5, v = 1 - 0 = 1.
        let t = world
            .triangles
            .iter()
            .find(|t| usize::from(t.material) == tiles)
            .ok_or("t")?;
        assert_eq!(t.uv, [[0.5, 1.0]; 3]);
        let area: f32 = world
            .triangles
            .iter()
            .filter(|t| usize::from(t.material) == tiles)
            .map(|t| t.area())
            .sum();
        assert!((area - 9.0).abs() < 1e-4, "pentagon area {area}");
        let glass = world
            .materials
            .iter()
            .find(|m| m.name == "glass")
            .ok_or("glass")?;
        assert_eq!(glass.pattern, Pattern::Window);
        // The two-number Kd (which panics tobj 4.0.5) is a warning naming file and line.
        let w = report.warnings.join("\n");
        assert!(w.contains("m.mtl line 8") && w.contains("Kd"), "{w}");
        Ok(())
    }

    #[test]
    fn import_obj_never_panics_on_truncation() -> TestResult {
        let bytes = std::fs::read(fixture("room.obj"))?;
        let frame = Frame::new(&cm())?;
        let base = fixture("");
        let mut errors = 0;
        for cut in 0..bytes.len() {
            let path = fixture("room.obj");
            if let Ok(soup) = parse(&bytes[..cut], &path, &base, frame) {
                if super::super::mesh::finish(soup, &cm()).is_err() {
                    errors += 1;
                }
            } else {
                errors += 1;
            }
        }
        assert!(errors > 0);
        Ok(())
    }
}
