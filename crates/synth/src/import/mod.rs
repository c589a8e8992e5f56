//! Building models exported by BIM tools, imported as a [`World`]: Wavefront OBJ (with its MTL
//! materials and textures) and glTF 2.0 (`.gltf` with embedded or external buffers, and binary
//! `.glb`).
//!
//! # Conversion to world coordinates
//! A source point `p` becomes `up(p · scale · units)`: first the units factor and
//! [`ImportOptions::scale`] turn file units into metres, then [`UpAxis`] turns the file's up axis
//! into the world's z. For [`UpAxis::Y`] (glTF by definition, and what most OBJ exporters write)
//! that is a +90° rotation about x, `(x, y, z) → (x, −z, y)`: +Y becomes +Z, +Z (towards a glTF
//! viewer) becomes −Y, and the frame stays right-handed, so counter-clockwise faces stay
//! counter-clockwise. [`UpAxis::Z`] (Revit, IFC, many CAD exports) keeps coordinates as they are.
//! Example, hand-checked in the tests: the OBJ vertex `(400, 250, −300)` in centimetres, Y up,
//! with scale 0.01 lands at world `(4, 3, 2.5)` m. Models georeferenced far (> 10 km) from the
//! origin are shifted horizontally so that `f32` keeps millimetres; the shift is reported.
//!
//! # What the importer derives
//! - Triangles with materials: the colour (OBJ `Kd`, glTF `baseColorFactor` converted from linear
//!   to sRGB), an image texture (OBJ `map_Kd`, glTF `baseColorTexture`), emission (OBJ `Ke`,
//!   glTF `emissiveFactor` × `KHR_materials_emissive_strength`, the brightest channel, clamped to
//!   0–1), see-through untextured materials (opacity below 0.6) as [`Pattern::Window`], and glTF
//!   `KHR_materials_unlit` as [`Material::unlit`] (a scan's photographed colours, shown as they
//!   are; OBJ has no such material).
//! - Texture coordinates: textured triangles keep theirs as image coordinates, u to the right
//!   and v **down** from the top-left corner (glTF's convention; OBJ's upward `vt` is flipped),
//!   passed through as they are, so repeating textures may go beyond 0–1. Untextured triangles get
//!   metres along their surface for the procedural patterns: a projection onto the triangle's
//!   plane with u horizontal and v up the slope (floors and ceilings, within 25° of level, use
//!   world x and y), so every triangle of one plane shares one seamless frame.
//! - Dominant planes: triangles clustered by normal (within 2°) and offset (within 2 cm); clusters
//!   of at least 1 m² become [`Plane`]s, largest first (so 8-bit plane images keep the biggest).
//! - Free space: models carry no labels, so one [`Region`] per detected storey spans the model's
//!   footprint (building 0, storeys numbered from the lowest walkable level), and the walk graph
//!   is a 0.5 m grid of floor points (see "Limits").
//! - Lights: glTF `KHR_lights_punctual` point and spot lights (spots as points), with intensity
//!   relative to the file's median light; a model without lights gets one over each emissive
//!   surface patch, and a model with neither gets lights under its ceilings every 3 m, unless
//!   every triangle is unlit (a scan: its light is in its photographs).
//!
//! # Bad files
//! Problems that make the model unusable are errors ([`SynthError::Model`], naming the file and,
//! for OBJ, the line): no faces, a face referring to a vertex that does not exist (a truncated
//! file), a half-written line, a model more than 10 km or less than 0.5 m across after scaling
//! (wrong units: the message suggests a `--scale`), and what is not supported (below). Problems
//! the model survives are warnings in [`ImportReport`]: a missing or unreadable texture or MTL
//! file (the material keeps its colour), unknown material names, degenerate or non-finite
//! triangles (dropped and counted), edges shared by more than two triangles (non-manifold, counted),
//! lines and points next to surfaces (skipped), and no walkable floor found.
//!
//! # Not supported
//! glTF: Draco (`KHR_draco_mesh_compression`), meshopt (`EXT_meshopt_compression`) and quantized
//! (`KHR_mesh_quantization`) geometry, sparse accessors, GPU instancing, texture transforms and any
//! other extension a file *requires* (an error names it); skins, morph targets, cameras and
//! animations are ignored; light colours are ignored. Point, line and line-strip primitives are
//! skipped (an error when a model has nothing else); triangle strips and fans are converted.
//! OBJ: free-form curves and surfaces, and points and lines (an error when a model has nothing
//! else); the `map_Kd` options `-o` and `-s` are applied, others are skipped. Textures: PNG, JPEG
//! and BMP.
//!
//! # Limits
//! The walk graph samples floors on a 0.5 m grid (coarser for models over ~700 m across): a point
//! is walkable where an upward-facing surface (normal within ~30° of up; floors must face up, as
//! BIM exports do) has at least 2 m of headroom, measured by casting a vertical ray against all
//! triangles, and nothing within 0.2 m around it at 0.4 m and 1 m height. Points with nothing
//! overhead (roofs, terraces) are left out unless the model has no ceilings at all. Grid
//! neighbours (8-connected) within 0.4 m of height are joined when straight segments 0.4 m and 1 m
//! above the floor hit no triangle; islands under 2 m² (furniture tops) are dropped. Doors
//! narrower than about 0.9 m may be missed by the 0.5 m grid, stairs steeper than 0.4 m rise per
//! 0.5 m are not joined, and storeys are found from clusters of walkable heights at least 2 m apart.

mod gltf;
mod mesh;
mod obj;
mod planes;
#[cfg(test)]
pub(crate) mod test_scan;
mod texture;
mod walk;

use crate::world::World;
#[cfg(doc)]
use crate::world::{Material, Pattern, Plane, Region};
use crate::{Result, SynthError};
use std::path::Path;

/// Where the model's up axis points in the file.
#[derive(Clone, Copy, Debug, Default, PartialEq, Eq, Hash)]
pub enum UpAxis {
    /// +Y is up: glTF (always) and most OBJ exporters (Blender, SketchUp, 3ds Max defaults).
    /// Converted by a +90° rotation about x: `(x, y, z) → (x, −z, y)`.
    #[default]
    Y,
    /// +Z is up, as in the world: Revit, IFC-based and CAD exports. Kept as it is.
    Z,
}

impl std::str::FromStr for UpAxis {
    type Err = String;
    fn from_str(s: &str) -> std::result::Result<Self, String> {
        match s.to_ascii_lowercase().as_str() {
            "y" | "+y" => Ok(UpAxis::Y),
            "z" | "+z" => Ok(UpAxis::Z),
            _ => Err(format!("unknown up axis '{s}' (one of: y, z)")),
        }
    }
}

/// Length units a model file may be written in.
#[derive(Clone, Copy, Debug, PartialEq, Eq, Hash)]
pub enum Units {
    /// Metres (glTF by definition).
    Metres,
    /// Centimetres.
    Centimetres,
    /// Millimetres (common in BIM exports).
    Millimetres,
    /// Inches.
    Inches,
    /// Feet (Revit's internal unit).
    Feet,
}

impl Units {
    /// Every unit, in a fixed order.
    pub const ALL: [Units; 5] = [
        Units::Metres,
        Units::Centimetres,
        Units::Millimetres,
        Units::Inches,
        Units::Feet,
    ];

    /// Metres per unit.
    pub fn metres(self) -> f64 {
        match self {
            Units::Metres => 1.0,
            Units::Centimetres => 0.01,
            Units::Millimetres => 0.001,
            Units::Inches => 0.0254,
            Units::Feet => 0.3048,
        }
    }

    /// The short name used on the command line (`m`, `cm`, `mm`, `in`, `ft`).
    pub fn name(self) -> &'static str {
        match self {
            Units::Metres => "m",
            Units::Centimetres => "cm",
            Units::Millimetres => "mm",
            Units::Inches => "in",
            Units::Feet => "ft",
        }
    }

    /// The unit in words, for messages.
    fn words(self) -> &'static str {
        match self {
            Units::Metres => "metres",
            Units::Centimetres => "centimetres",
            Units::Millimetres => "millimetres",
            Units::Inches => "inches",
            Units::Feet => "feet",
        }
    }
}

impl std::str::FromStr for Units {
    type Err = String;
    fn from_str(s: &str) -> std::result::Result<Self, String> {
        let unit = match s.to_ascii_lowercase().as_str() {
            "m" | "metre" | "metres" | "meter" | "meters" => Units::Metres,
            "cm" | "centimetre" | "centimetres" | "centimeter" | "centimeters" => {
                Units::Centimetres
            }
            "mm" | "millimetre" | "millimetres" | "millimeter" | "millimeters" => {
                Units::Millimetres
            }
            "in" | "inch" | "inches" => Units::Inches,
            "ft" | "foot" | "feet" => Units::Feet,
            _ => return Err(format!("unknown units '{s}' (one of: m, cm, mm, in, ft)")),
        };
        Ok(unit)
    }
}

/// How to read a model file.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct ImportOptions {
    /// Multiplies every coordinate (after [`ImportOptions::units`]): 0.001 for a model in
    /// millimetres when `units` is not given. Must be positive and finite.
    pub scale: f32,
    /// The file's up axis. Default [`UpAxis::Y`], right for glTF (whose spec fixes +Y up) and for
    /// most OBJ exporters; BIM tools that keep Z up (Revit, IFC converters) need [`UpAxis::Z`].
    pub up: UpAxis,
    /// The file's length unit, if known; `None` means metres (times `scale`).
    pub units: Option<Units>,
}

impl Default for ImportOptions {
    fn default() -> Self {
        Self {
            scale: 1.0,
            up: UpAxis::Y,
            units: None,
        }
    }
}

impl ImportOptions {
    /// Metres per file unit: `scale` times the units factor.
    pub fn metres_per_unit(&self) -> f64 {
        f64::from(self.scale) * self.units.map_or(1.0, Units::metres)
    }
}

/// What an import noticed but survived: each warning names the file.
#[derive(Clone, Debug, Default, PartialEq, Eq)]
pub struct ImportReport {
    /// Warnings, one sentence each, in the order found.
    pub warnings: Vec<String>,
}

/// Reads a building model into a [`World`], dispatching on the extension: `.obj` (with the MTL
/// files it names), `.gltf` or `.glb`. See the module documentation for the conversion, what is
/// derived, and which problems are errors and which are warnings.
///
/// # Errors
/// [`SynthError::Io`] when the file cannot be read, [`SynthError::Config`] for a non-positive
/// scale, [`SynthError::Model`] when the file is malformed, unsupported, empty or of an absurd
/// size.
pub fn load(path: &Path, opts: &ImportOptions) -> Result<(World, ImportReport)> {
    let frame = Frame::new(opts)?;
    let ext = path
        .extension()
        .and_then(|e| e.to_str())
        .map(str::to_ascii_lowercase)
        .unwrap_or_default();
    let soup = match ext.as_str() {
        "obj" => obj::read(path, frame)?,
        "gltf" | "glb" => gltf::read(path, frame)?,
        _ => {
            return Err(model_error(
                path,
                format!(
                    "unsupported model format '{}': indoorloc imports .obj (with .mtl), .gltf \
                     and .glb; convert other formats (IFC, FBX, DAE) to glTF or OBJ first",
                    if ext.is_empty() { "(none)" } else { &ext }
                ),
            ));
        }
    };
    mesh::finish(soup, opts)
}

/// The rigid transform `T` from a scanned dataset's pose frame to the world [`load`] makes of
/// the scan's model, as a scan's glTF records it: `asset.extras.indoorloc_scan.dataset_to_world`,
/// 16 numbers of a row-major 4x4 matrix (beside `"dataset"`, the dataset's path). A camera pose
/// `P` of the dataset (camera-to-world in its own frame) is `T.compose(&P)` in the world. It
/// holds for the default [`ImportOptions`] (metres, Y up), which a scan's GLB is written for.
///
/// `Ok(None)` for a model without the record, and for OBJ and other formats, which carry none.
///
/// # Errors
/// [`SynthError::Io`] when the file cannot be read; [`SynthError::Model`] (naming the file)
/// when it is not glTF, or the record is not 16 numbers or not a rigid transform.
pub fn scan_frame(path: &Path) -> Result<Option<geom::Pose>> {
    let ext = path
        .extension()
        .and_then(|e| e.to_str())
        .map(str::to_ascii_lowercase);
    match ext.as_deref() {
        Some("gltf" | "glb") => gltf::scan_frame(path),
        _ => Ok(None),
    }
}

/// The conversion from file coordinates to world coordinates (see the module documentation).
#[derive(Clone, Copy, Debug, PartialEq)]
struct Frame {
    /// Metres per file unit.
    scale: f64,
    /// The file's up axis.
    up: UpAxis,
}

impl Frame {
    /// Checks the options: a scale that is not positive would mirror or collapse the model.
    fn new(opts: &ImportOptions) -> Result<Self> {
        let scale = opts.metres_per_unit();
        if !(scale.is_finite() && scale > 0.0) {
            return Err(SynthError::Config(format!(
                "import scale must be a positive number, got {}",
                opts.scale
            )));
        }
        Ok(Self { scale, up: opts.up })
    }

    /// A file point (already through any node transform) in world metres, z up.
    fn point(&self, p: [f64; 3]) -> [f64; 3] {
        let [x, y, z] = p.map(|c| c * self.scale);
        match self.up {
            UpAxis::Y => [x, -z, y],
            UpAxis::Z => [x, y, z],
        }
    }
}

/// A [`SynthError::Model`] for `path`.
fn model_error(path: &Path, msg: impl Into<String>) -> SynthError {
    SynthError::Model {
        path: path.to_path_buf(),
        msg: msg.into(),
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    type TestResult = std::result::Result<(), Box<dyn std::error::Error>>;

    #[test]
    fn import_options_defaults_and_names() -> TestResult {
        let d = ImportOptions::default();
        assert_eq!((d.scale, d.up, d.units), (1.0, UpAxis::Y, None));
        assert_eq!("Z".parse::<UpAxis>()?, UpAxis::Z);
        assert!("x".parse::<UpAxis>().is_err());
        for u in Units::ALL {
            assert_eq!(u.name().parse::<Units>()?, u);
        }
        assert_eq!("millimetres".parse::<Units>()?, Units::Millimetres);
        assert!("furlong".parse::<Units>().is_err());
        let opts = ImportOptions {
            scale: 2.0,
            units: Some(Units::Millimetres),
            ..d
        };
        assert!((opts.metres_per_unit() - 0.002).abs() < 1e-12);
        Ok(())
    }

    #[test]
    fn import_up_axis_conversion_by_hand() -> TestResult {
        // Y up: +Y becomes +Z, +Z (towards a glTF viewer) becomes -Y, +X stays.
        let y = Frame::new(&ImportOptions::default())?;
        assert_eq!(y.point([1.0, 0.0, 0.0]), [1.0, 0.0, 0.0]);
        assert_eq!(y.point([0.0, 1.0, 0.0]), [0.0, 0.0, 1.0]);
        assert_eq!(y.point([0.0, 0.0, 1.0]), [0.0, -1.0, 0.0]);
        // Units first, then the axes: 400 cm, 250 cm, -300 cm -> (4, 3, 2.5) m.
        let cm = Frame::new(&ImportOptions {
            units: Some(Units::Centimetres),
            ..ImportOptions::default()
        })?;
        let p = cm.point([400.0, 250.0, -300.0]);
        assert!(
            (p[0] - 4.0).abs() < 1e-12 && (p[1] - 3.0).abs() < 1e-12 && (p[2] - 2.5).abs() < 1e-12
        );
        let z = Frame::new(&ImportOptions {
            up: UpAxis::Z,
            ..ImportOptions::default()
        })?;
        assert_eq!(z.point([1.0, 2.0, 3.0]), [1.0, 2.0, 3.0]);
        Ok(())
    }

    #[test]
    fn import_unknown_format_is_an_error_naming_the_file() -> TestResult {
        let err = load(Path::new("building.fbx"), &ImportOptions::default())
            .err()
            .ok_or("loaded an .fbx")?
            .to_string();
        assert!(
            err.contains("building.fbx") && err.contains("'fbx'"),
            "{err}"
        );
        let bad = ImportOptions {
            scale: 0.0,
            ..ImportOptions::default()
        };
        assert!(load(Path::new("room.obj"), &bad).is_err());
        Ok(())
    }
}
