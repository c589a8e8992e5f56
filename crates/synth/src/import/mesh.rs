//! What every format's reader produces (a triangle soup in world metres) and what turns it into a
//! [`World`]: validation, texture coordinates, planes, free space and lights.

use super::{ImportOptions, ImportReport, Units, model_error, planes, walk};
use crate::Result;
use crate::world::{Light, Material, MaterialId, Triangle, World};
use nalgebra::{Point3, Vector3};
use std::collections::HashMap;
use std::path::{Path, PathBuf};

/// A model is at most this wide, metres: more means the units are wrong.
const MAX_EXTENT_M: f64 = 10_000.0;
/// A model is at least this wide, metres: less means the units are wrong.
const MIN_EXTENT_M: f64 = 0.5;
/// Triangles smaller than this, square metres, are degenerate (no direction to shade or cluster).
const MIN_AREA_M2: f64 = 1e-10;
/// Beyond this distance from the origin, metres, `f32` coordinates lose millimetres, so the model
/// is shifted.
const FAR_FROM_ORIGIN_M: f64 = 10_000.0;
/// Floors and ceilings within this many degrees of level get world-aligned texture coordinates.
const LEVEL_COS: f32 = 0.906; // cos 25°

/// A triangle as a reader found it.
#[derive(Clone, Debug, PartialEq)]
pub(super) struct RawTri {
    /// Indices into [`Soup::positions`], counter-clockwise seen from the front.
    pub v: [u32; 3],
    /// Texture coordinates (u right, v down, 0–1 over the image), when the file has them.
    pub uv: Option<[[f32; 2]; 3]>,
    /// The material.
    pub material: MaterialId,
}

/// A light as a reader found it.
#[derive(Clone, Debug, PartialEq)]
pub(super) struct RawLight {
    /// Position, world metres (before any shift towards the origin).
    pub position: [f64; 3],
    /// Intensity in the file's own units (glTF: candela).
    pub intensity: f64,
}

/// A model read from a file, in world metres with z up, not yet checked.
#[derive(Debug, Default)]
pub(super) struct Soup {
    /// The file, for messages.
    pub path: PathBuf,
    /// Vertex positions, world metres.
    pub positions: Vec<[f64; 3]>,
    /// Triangles.
    pub tris: Vec<RawTri>,
    /// Materials.
    pub materials: Vec<Material>,
    /// Light sources.
    pub lights: Vec<RawLight>,
    /// Warnings so far, each naming the file.
    pub warnings: Vec<String>,
}

impl Soup {
    /// An empty model read from `path`.
    pub fn new(path: &Path) -> Self {
        Self {
            path: path.to_path_buf(),
            ..Self::default()
        }
    }

    /// Records a warning, prefixed with the file name.
    pub fn warn(&mut self, msg: impl AsRef<str>) {
        let w = format!("{}: {}", self.path.display(), msg.as_ref());
        self.warnings.push(w);
    }

    /// Adds a material, failing past the 65 536 a [`MaterialId`] can number.
    pub fn add_material(&mut self, m: Material) -> Result<MaterialId> {
        let id = MaterialId::try_from(self.materials.len()).map_err(|_| {
            model_error(
                &self.path,
                format!(
                    "more than {} materials; merge materials before exporting",
                    MaterialId::MAX as usize + 1
                ),
            )
        })?;
        self.materials.push(m);
        Ok(id)
    }
}

/// A stable seed for a material's procedural content, from its name (FNV-1a), so the same model
/// always renders the same.
pub(super) fn seed_of(name: &str) -> u64 {
    name.bytes().fold(0xcbf2_9ce4_8422_2325, |h, b| {
        (h ^ u64::from(b)).wrapping_mul(0x0100_0000_01b3)
    })
}

/// Splits a planar polygon (corner positions in order) into triangles of corner indices with the
/// polygon's winding: ear clipping in the plane of its Newell normal, so concave outlines (an
/// L-shaped floor) come out right; a fan where the outline is degenerate or self-intersecting.
pub(super) fn triangulate(p: &[[f64; 3]], out: &mut Vec<[usize; 3]>) {
    let n = p.len();
    if n < 3 {
        return;
    }
    if n == 3 {
        out.push([0, 1, 2]);
        return;
    }
    let mut normal = [0.0f64; 3];
    for i in 0..n {
        let a = p[i];
        let b = p[(i + 1) % n];
        normal[0] += (a[1] - b[1]) * (a[2] + b[2]);
        normal[1] += (a[2] - b[2]) * (a[0] + b[0]);
        normal[2] += (a[0] - b[0]) * (a[1] + b[1]);
    }
    let axis = (0..3)
        .max_by(|&i, &j| normal[i].abs().total_cmp(&normal[j].abs()))
        .unwrap_or(2);
    // (u, v) cyclic after `axis`, so u × v points along +axis; flipping v when the normal points
    // along −axis makes the polygon counter-clockwise in 2-D.
    let (iu, iv) = match axis {
        0 => (1, 2),
        1 => (2, 0),
        _ => (0, 1),
    };
    let sign = if normal[axis] >= 0.0 { 1.0 } else { -1.0 };
    let q: Vec<[f64; 2]> = p.iter().map(|c| [c[iu], c[iv] * sign]).collect();
    let cross = |a: [f64; 2], b: [f64; 2], c: [f64; 2]| {
        (b[0] - a[0]) * (c[1] - a[1]) - (b[1] - a[1]) * (c[0] - a[0])
    };
    let start = out.len();
    let mut idx: Vec<usize> = (0..n).collect();
    let mut guard = 0usize;
    while idx.len() > 3 && guard < n * n {
        guard += 1;
        let m = idx.len();
        let mut clipped = false;
        // Ears tried from the second corner on, so a convex polygon becomes the fan from its
        // first corner (0 1 2, 0 2 3, ...), as other tools split it.
        for k in (1..=m).map(|k| k % m) {
            let (a, b, c) = (idx[(k + m - 1) % m], idx[k], idx[(k + 1) % m]);
            if cross(q[a], q[b], q[c]) <= 0.0 {
                continue; // reflex or flat corner
            }
            let inside = idx.iter().any(|&o| {
                o != a
                    && o != b
                    && o != c
                    && cross(q[a], q[b], q[o]) >= 0.0
                    && cross(q[b], q[c], q[o]) >= 0.0
                    && cross(q[c], q[a], q[o]) >= 0.0
            });
            if !inside {
                out.push([a, b, c]);
                idx.remove(k);
                clipped = true;
                break;
            }
        }
        if !clipped {
            break;
        }
    }
    if idx.len() == 3 {
        out.push([idx[0], idx[1], idx[2]]);
    } else {
        // Not a simple polygon in its plane: the fan is as good a guess as any.
        out.truncate(start);
        out.extend((1..n - 1).map(|i| [0, i, i + 1]));
    }
}

/// Metres-along-the-surface texture coordinates for an untextured triangle (see the module
/// documentation): a frame that depends only on the normal, so a plane's triangles share it.
fn surface_uv(v: &[Point3<f32>; 3], n: &Vector3<f32>) -> [[f32; 2]; 3] {
    if n.z.abs() >= LEVEL_COS {
        // Floors read with +x right and +y up on the page; ceilings mirrored, as seen from below.
        let s = n.z.signum();
        return v.map(|p| [p.x, s * p.y]);
    }
    let u_axis = Vector3::new(-n.y, n.x, 0.0).normalize(); // horizontal, z × n
    let v_axis = n.cross(&u_axis); // up the surface
    v.map(|p| [p.coords.dot(&u_axis), p.coords.dot(&v_axis)])
}

/// Checks and completes a model: drops bad triangles, rejects absurd sizes, counts non-manifold
/// edges, fills in texture coordinates, planes, regions, the walk graph and lights.
pub(super) fn finish(mut soup: Soup, opts: &ImportOptions) -> Result<(World, ImportReport)> {
    let path = soup.path.clone();
    if soup.tris.is_empty() {
        return Err(model_error(
            &path,
            "the model has no triangles (an empty file, or one without faces)",
        ));
    }

    // Validity in f64, before anything is rounded to f32.
    let mut non_finite = 0usize;
    let mut degenerate = 0usize;
    let mut keep = Vec::with_capacity(soup.tris.len());
    let mut lo = [f64::INFINITY; 3];
    let mut hi = [f64::NEG_INFINITY; 3];
    for (i, t) in soup.tris.iter().enumerate() {
        let Some(p) = corners(&soup.positions, t) else {
            non_finite += 1;
            continue;
        };
        if p.iter().flatten().any(|c| !c.is_finite()) {
            non_finite += 1;
            continue;
        }
        let e1 = sub(p[1], p[0]);
        let e2 = sub(p[2], p[0]);
        let c = [
            e1[1] * e2[2] - e1[2] * e2[1],
            e1[2] * e2[0] - e1[0] * e2[2],
            e1[0] * e2[1] - e1[1] * e2[0],
        ];
        let area = 0.5 * (c[0] * c[0] + c[1] * c[1] + c[2] * c[2]).sqrt();
        if area.is_nan() || area < MIN_AREA_M2 {
            degenerate += 1;
            continue;
        }
        for q in &p {
            for k in 0..3 {
                lo[k] = lo[k].min(q[k]);
                hi[k] = hi[k].max(q[k]);
            }
        }
        keep.push(i);
    }
    let total = soup.tris.len();
    if non_finite > 0 {
        soup.warn(format!(
            "{non_finite} of {total} triangles have non-finite (NaN or infinite) coordinates and \
             were dropped"
        ));
    }
    if degenerate > 0 {
        soup.warn(format!(
            "{degenerate} of {total} triangles are degenerate (zero area) and were dropped"
        ));
    }
    if keep.is_empty() {
        return Err(model_error(
            &path,
            format!(
                "none of the model's {total} triangles is usable ({degenerate} degenerate, \
                 {non_finite} with non-finite coordinates)"
            ),
        ));
    }
    check_extent(&path, lo, hi, opts)?;

    // Georeferenced models sit kilometres from the origin, where f32 loses millimetres.
    let mut shift = [0.0f64; 3];
    for k in 0..3 {
        let centre = 0.5 * (lo[k] + hi[k]);
        if centre.abs() > FAR_FROM_ORIGIN_M {
            shift[k] = -lo[k].floor();
        }
    }
    if shift != [0.0; 3] {
        soup.warn(format!(
            "the model lies {:.1} km from the origin (georeferenced?); shifted by ({}, {}, {}) m \
             so that coordinates keep millimetre precision",
            (0.5 * (lo[0] + hi[0])).hypot(0.5 * (lo[1] + hi[1])) / 1000.0,
            shift[0],
            shift[1],
            shift[2]
        ));
    }
    let to_f32 = |p: [f64; 3]| {
        Point3::new(
            (p[0] + shift[0]) as f32,
            (p[1] + shift[1]) as f32,
            (p[2] + shift[2]) as f32,
        )
    };

    let textured: Vec<bool> = soup
        .materials
        .iter()
        .map(|m| m.pattern.image().is_some())
        .collect();
    let mut missing_uv: HashMap<MaterialId, usize> = HashMap::new();
    let mut triangles = Vec::with_capacity(keep.len());
    let mut rounded_away = 0usize;
    for &i in &keep {
        let t = &soup.tris[i];
        let Some(p) = corners(&soup.positions, t) else {
            continue;
        };
        let v = p.map(to_f32);
        let mut tri = Triangle {
            v,
            uv: [[0.0; 2]; 3],
            material: t.material,
            plane: 0,
        };
        let n = tri.normal();
        if n == Vector3::zeros() {
            rounded_away += 1; // a sliver that f32 cannot represent
            continue;
        }
        let is_textured = textured
            .get(usize::from(t.material))
            .copied()
            .unwrap_or(false);
        tri.uv = match (is_textured, t.uv) {
            (true, Some(uv)) => uv,
            (true, None) => {
                *missing_uv.entry(t.material).or_default() += 1;
                surface_uv(&tri.v, &n)
            }
            (false, _) => surface_uv(&tri.v, &n),
        };
        triangles.push(tri);
    }
    if rounded_away > 0 {
        soup.warn(format!(
            "{rounded_away} slivers too thin for single precision were dropped"
        ));
    }
    let mut missing: Vec<_> = missing_uv.into_iter().collect();
    missing.sort_unstable();
    for (m, count) in missing {
        let name = soup
            .materials
            .get(usize::from(m))
            .map_or("?", |m| m.name.as_str())
            .to_string();
        soup.warn(format!(
            "{count} triangles with the textured material '{name}' have no texture coordinates; \
             its texture repeats once per metre on them"
        ));
    }

    let bad_edges = non_manifold_edges(&triangles);
    if bad_edges > 0 {
        soup.warn(format!(
            "{bad_edges} edges are shared by more than two triangles (non-manifold geometry: \
             duplicated or intersecting surfaces); the model still renders, but planes and the \
             walk graph may be less reliable"
        ));
    }

    let mut world = World {
        name: path.file_name().map_or_else(
            || path.display().to_string(),
            |f| f.to_string_lossy().into(),
        ),
        triangles,
        materials: std::mem::take(&mut soup.materials),
        ..World::default()
    };
    planes::assign(&mut world);
    let free = walk::build(&mut world);
    match free.nodes {
        0 => soup.warn(
            "no walkable floor found (an upward-facing surface with 2 m of headroom): the walk \
             graph is empty; check the up axis (Y or Z) and the scale (a scan with only part of \
             a floor has none: draw poses near its camera path instead)",
        ),
        _ if !free.covered => soup.warn(
            "no floor has a ceiling above it; the walk graph includes uncovered surfaces such \
             as roofs",
        ),
        _ => {}
    }

    world.lights = file_lights(&soup.lights, shift);
    // A scan shows the light it was photographed in; lamps invented for it would only cost
    // render time (unlit surfaces ignore them) and give `SomeLightsOff` nothing real to switch.
    let all_unlit = world.triangles.iter().all(|t| {
        world
            .materials
            .get(usize::from(t.material))
            .is_some_and(|m| m.unlit)
    });
    if world.lights.is_empty() && !all_unlit {
        world.lights = emissive_lights(&world);
        if world.lights.is_empty() {
            world.lights = walk::ceiling_lights(&world, &free);
            if !world.lights.is_empty() {
                let n = world.lights.len();
                soup.warn(format!(
                    "no light sources or glowing surfaces: placed {n} light{} under the \
                     ceilings, 3 m apart",
                    if n == 1 { "" } else { "s" }
                ));
            }
        }
    }

    Ok((
        world,
        ImportReport {
            warnings: soup.warnings,
        },
    ))
}

/// The corner positions of a raw triangle, `None` when an index is out of range (readers check,
/// so this only guards against a reader's bug).
fn corners(positions: &[[f64; 3]], t: &RawTri) -> Option<[[f64; 3]; 3]> {
    Some([
        *positions.get(t.v[0] as usize)?,
        *positions.get(t.v[1] as usize)?,
        *positions.get(t.v[2] as usize)?,
    ])
}

/// `a − b`.
fn sub(a: [f64; 3], b: [f64; 3]) -> [f64; 3] {
    [a[0] - b[0], a[1] - b[1], a[2] - b[2]]
}

/// Rejects a model whose size says the units are wrong, suggesting scales that would fit.
fn check_extent(path: &Path, lo: [f64; 3], hi: [f64; 3], opts: &ImportOptions) -> Result<()> {
    let extent = (0..3).map(|k| hi[k] - lo[k]).fold(0.0f64, f64::max);
    if (MIN_EXTENT_M..=MAX_EXTENT_M).contains(&extent) {
        return Ok(());
    }
    let per_unit = opts.metres_per_unit();
    let raw = extent / per_unit;
    let hints: Vec<String> = Units::ALL
        .iter()
        .filter(|u| (2.0..=2000.0).contains(&(raw * u.metres())))
        .map(|u| format!("--scale {} if it is in {}", u.metres(), u.words()))
        .collect();
    let hint = if hints.is_empty() {
        let guess = 10f64.powf((50.0 / raw).log10().round());
        format!("try --scale {guess}")
    } else {
        hints.join(", ")
    };
    let what = if extent > MAX_EXTENT_M {
        format!("{extent:.0} m across, larger than any building (at most 10 km)")
    } else {
        format!("{extent:.3} m across, smaller than any building (at least 0.5 m)")
    };
    Err(model_error(
        path,
        format!(
            "the model is {what} at {per_unit} m per file unit, so its units are probably not \
             what was assumed: use {hint}"
        ),
    ))
}

/// Edges shared by more than two triangles, with corners welded on a 1 mm grid (exporters
/// duplicate vertices at material and texture seams, which must not count as open edges).
fn non_manifold_edges(tris: &[Triangle]) -> usize {
    let mut ids: HashMap<[i64; 3], u32> = HashMap::with_capacity(tris.len());
    let mut edges: HashMap<(u32, u32), u32> = HashMap::with_capacity(tris.len() * 3 / 2);
    for t in tris {
        let c = t.v.map(|p| {
            let key = [p.x, p.y, p.z].map(|x| (f64::from(x) * 1000.0).round() as i64);
            let next = ids.len() as u32;
            *ids.entry(key).or_insert(next)
        });
        for (a, b) in [(c[0], c[1]), (c[1], c[2]), (c[2], c[0])] {
            if a != b {
                *edges.entry((a.min(b), a.max(b))).or_default() += 1;
            }
        }
    }
    edges.values().filter(|&&n| n > 2).count()
}

/// The file's lights, with intensities relative to its median light (exporters disagree wildly on
/// units, but a building's typical fixture is what [`Light::intensity`] 1.0 means).
fn file_lights(raw: &[RawLight], shift: [f64; 3]) -> Vec<Light> {
    let mut positive: Vec<f64> = raw
        .iter()
        .map(|l| l.intensity)
        .filter(|i| i.is_finite() && *i > 0.0)
        .collect();
    positive.sort_by(f64::total_cmp);
    let median = positive.get(positive.len() / 2).copied().unwrap_or(1.0);
    raw.iter()
        .filter(|l| l.position.iter().all(|c| c.is_finite()))
        .map(|l| Light {
            position: Point3::new(
                (l.position[0] + shift[0]) as f32,
                (l.position[1] + shift[1]) as f32,
                (l.position[2] + shift[2]) as f32,
            ),
            intensity: if l.intensity.is_finite() {
                (l.intensity / median).clamp(0.0, 10.0) as f32
            } else {
                1.0
            },
            on: true,
            fixture: None,
        })
        .collect()
}

/// One light 10 cm in front of each glowing surface patch (emissive triangles pooled per 2 m cell
/// and material), for models that mark light fixtures only by their material.
fn emissive_lights(world: &World) -> Vec<Light> {
    #[derive(Default)]
    struct Patch {
        area: f32,
        centre: Vector3<f32>,
        normal: Vector3<f32>,
    }
    let mut patches: HashMap<(i32, i32, i32, MaterialId), Patch> = HashMap::new();
    let mut order = Vec::new();
    for t in &world.triangles {
        let emissive = world
            .materials
            .get(usize::from(t.material))
            .map_or(0.0, |m| m.emissive);
        if emissive < 0.05 {
            continue;
        }
        let c = (t.v[0].coords + t.v[1].coords + t.v[2].coords) / 3.0;
        let key = (
            (c.x / 2.0).floor() as i32,
            (c.y / 2.0).floor() as i32,
            (c.z / 2.0).floor() as i32,
            t.material,
        );
        let a = t.area();
        let patch = patches.entry(key).or_insert_with(|| {
            order.push(key);
            Patch::default()
        });
        patch.area += a;
        patch.centre += c * a;
        patch.normal += t.normal() * a;
    }
    order
        .iter()
        .filter_map(|key| {
            let p = patches.get(key)?;
            if p.area <= 0.0 {
                return None;
            }
            let normal = p.normal.try_normalize(1e-6).unwrap_or_else(Vector3::zeros);
            let emissive = world.materials.get(usize::from(key.3))?.emissive;
            Some(Light {
                position: Point3::from(p.centre / p.area + normal * 0.1),
                intensity: emissive,
                on: true,
                fixture: Some(key.3),
            })
        })
        .collect()
}

#[cfg(test)]
mod tests {
    use super::*;

    type TestResult = std::result::Result<(), Box<dyn std::error::Error>>;

    #[test]
    fn import_triangulates_concave_polygon_with_its_winding() -> TestResult {
        // An L-shaped floor, counter-clockwise seen from above (+z).
        let l = [
            [0.0, 0.0, 0.0],
            [2.0, 0.0, 0.0],
            [2.0, 1.0, 0.0],
            [1.0, 1.0, 0.0],
            [1.0, 2.0, 0.0],
            [0.0, 2.0, 0.0],
        ];
        let mut out = Vec::new();
        triangulate(&l, &mut out);
        assert_eq!(out.len(), 4);
        let mut area = 0.0;
        for t in &out {
            let [a, b, c] = t.map(|i| l[i]);
            let z = (b[0] - a[0]) * (c[1] - a[1]) - (b[1] - a[1]) * (c[0] - a[0]);
            assert!(z > 0.0, "triangle {t:?} flipped");
            area += z / 2.0;
        }
        assert!((area - 3.0f64).abs() < 1e-9);
        // The same outline wound the other way (seen from below) keeps its winding too.
        let r: Vec<[f64; 3]> = l.iter().rev().copied().collect();
        out.clear();
        triangulate(&r, &mut out);
        for t in &out {
            let [a, b, c] = t.map(|i| r[i]);
            let z = (b[0] - a[0]) * (c[1] - a[1]) - (b[1] - a[1]) * (c[0] - a[0]);
            assert!(z < 0.0);
        }
        Ok(())
    }

    #[test]
    fn import_extent_limits() -> TestResult {
        let opts = ImportOptions::default();
        let path = Path::new("m.obj");
        for (size, ok) in [
            (400.0, true),
            (0.5, true),
            (10_000.0, true),
            (0.4, false),
            (12_000.0, false),
        ] {
            let result = check_extent(path, [0.0; 3], [size, 1.0_f64.min(size), 0.0], &opts);
            assert_eq!(result.is_ok(), ok, "{size} m: {result:?}");
        }
        // A 12 m building in millimetres read as metres.
        let msg = check_extent(path, [0.0; 3], [12_000.0, 8_000.0, 3_000.0], &opts)
            .err()
            .ok_or("12 km accepted")?
            .to_string();
        assert!(
            msg.starts_with("m.obj: the model is 12000 m across"),
            "{msg}"
        );
        assert!(
            msg.contains("--scale 0.001 if it is in millimetres"),
            "{msg}"
        );
        Ok(())
    }

    #[test]
    fn import_surface_uv_is_metres_along_a_sloped_wall() -> TestResult {
        // A wall leaning back 30°: moving 1 m up its slope must move v by 1.
        let n = Vector3::new(
            0.0f32,
            -(30f32.to_radians().cos()),
            30f32.to_radians().sin(),
        );
        let up_slope = n.cross(&Vector3::new(1.0, 0.0, 0.0));
        let a = Point3::new(0.0f32, 0.0, 0.0);
        let v = [a, a + Vector3::new(1.0, 0.0, 0.0), a + up_slope];
        let uv = surface_uv(&v, &n);
        let du = ((uv[1][0] - uv[0][0]).powi(2) + (uv[1][1] - uv[0][1]).powi(2)).sqrt();
        let dv = ((uv[2][0] - uv[0][0]).powi(2) + (uv[2][1] - uv[0][1]).powi(2)).sqrt();
        assert!((du - 1.0).abs() < 1e-5 && (dv - 1.0).abs() < 1e-5);
        assert!((uv[2][1] - uv[0][1]).abs() > 0.99, "v runs up the slope");
        Ok(())
    }
}
