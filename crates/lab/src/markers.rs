//! `indoorloc markers detect|generate|locate`: ArUco markers in photos, printable markers, and the
//! camera pose from a marker map.

use crate::output::{median, print_json, print_text};
use crate::{Context, Result, bail, ensure};
use clap::{Args, Subcommand};
use geom::Camera;
use markers::{DetectParams, Dictionary, Marker, MarkerMap};
use serde::Serialize;
use std::path::{Path, PathBuf};
use std::time::Instant;

/// Arguments of `indoorloc markers`.
#[derive(Args, Debug)]
pub struct MarkersConfig {
    #[command(subcommand)]
    action: Action,
}

#[derive(Subcommand, Debug)]
enum Action {
    /// Find ArUco markers: ids and corners (OpenCV's order TL, TR, BR, BL), with each marker's
    /// pose when a calibrated camera and the marker size are given.
    Detect(DetectConfig),
    /// Write printable markers: PNG and SVG with a quiet zone and the id printed underneath.
    Generate(GenerateConfig),
    /// Camera pose in the building from the markers of a marker map seen in each image.
    Locate(LocateConfig),
}

/// Which dictionary: a predefined one by name or an OpenCV YAML file.
#[derive(Args, Debug, Clone)]
struct DictArg {
    /// Predefined dictionary: 4x4_50 … 7x7_1000 (also DICT_6X6_250), original.
    #[arg(long = "dict", default_value = "4x4_50")]
    name: String,
    /// A custom dictionary in OpenCV's YAML (nmarkers, markersize, marker_N); overrides --dict.
    #[arg(long = "dict-file", value_name = "FILE.yml")]
    file: Option<PathBuf>,
}

impl DictArg {
    fn load(&self) -> Result<Dictionary> {
        Ok(match &self.file {
            Some(f) => Dictionary::from_opencv_yaml(f)?,
            None => Dictionary::predefined(&self.name)?,
        })
    }
}

#[derive(Args, Debug)]
struct DetectConfig {
    /// Images (PNG, JPEG, BMP).
    #[arg(required = true)]
    images: Vec<PathBuf>,
    #[command(flatten)]
    dict: DictArg,
    /// Camera intrinsics (OpenCV YAML, as `indoorloc calibrate` writes): adds each marker's pose.
    #[arg(long, value_name = "FILE", requires = "size")]
    camera: Option<PathBuf>,
    /// Side of the markers' black square, metres (for poses).
    #[arg(long)]
    size: Option<f64>,
    /// Move corners onto the sub-pixel edges of the black square (always on with --camera):
    /// OpenCV's default corners sit half a pixel inside it.
    #[arg(long)]
    refine: bool,
    /// Print one JSON document instead of a table.
    #[arg(long)]
    json: bool,
}

#[derive(Args, Debug)]
struct GenerateConfig {
    #[command(flatten)]
    dict: DictArg,
    /// Ids to write: a range `A-B`, a list `1,5,9`, or one id.
    #[arg(long, default_value = "0-9")]
    ids: String,
    /// Output folder.
    #[arg(long, value_name = "DIR")]
    out: PathBuf,
    /// PNG pixels per marker cell.
    #[arg(long, default_value_t = 40)]
    cell_px: u32,
    /// Printed side of the black square in the SVG, millimetres.
    #[arg(long, default_value_t = 100.0)]
    size_mm: f64,
    /// Print one JSON document instead of a list.
    #[arg(long)]
    json: bool,
}

#[derive(Args, Debug)]
struct LocateConfig {
    /// Images (PNG, JPEG, BMP).
    #[arg(required = true)]
    images: Vec<PathBuf>,
    /// The marker map (TOML: dictionary, and per marker id, size, position, quaternion).
    #[arg(long, value_name = "FILE")]
    map: PathBuf,
    /// Camera intrinsics (OpenCV YAML).
    #[arg(long, value_name = "FILE")]
    camera: PathBuf,
    /// Dictionary (default: the map's, else 4x4_50).
    #[arg(long = "dict")]
    dict: Option<String>,
    /// A custom dictionary in OpenCV's YAML; overrides --dict and the map's.
    #[arg(long = "dict-file", value_name = "FILE.yml")]
    dict_file: Option<PathBuf>,
    /// Print one JSON document instead of a table.
    #[arg(long)]
    json: bool,
}

/// Runs `indoorloc markers`.
pub fn run(args: &MarkersConfig, sink: &mut dyn crate::Output) -> Result<()> {
    match &args.action {
        Action::Detect(a) => detect(a, sink),
        Action::Generate(a) => generate(a, sink),
        Action::Locate(a) => locate(a, sink),
    }
}

/// A marker in the output, with its pose when asked for.
#[derive(Debug, Serialize)]
struct MarkerOut {
    id: u32,
    corners: [[f64; 2]; 4],
    #[serde(skip_serializing_if = "Option::is_none")]
    pose: Option<PoseOut>,
}

#[derive(Debug, Serialize)]
struct PoseOut {
    /// Marker centre in the camera frame, metres.
    position: [f64; 3],
    /// Marker-to-camera rotation (w, x, y, z).
    quaternion: [f64; 4],
    rms_px: f64,
    /// The other IPPE solution fits nearly as well.
    ambiguous: bool,
}

#[derive(Debug, Serialize)]
struct ImageOut {
    image: PathBuf,
    markers: Vec<MarkerOut>,
    ms: f64,
}

#[derive(Debug, Serialize)]
struct DetectOutput {
    dictionary: String,
    images: Vec<ImageOut>,
    ms_per_image: f64,
}

fn detect(args: &DetectConfig, sink: &mut dyn crate::Output) -> Result<()> {
    let dict = args.dict.load()?;
    let camera = args.camera.as_deref().map(read_camera).transpose()?;
    if let Some(s) = args.size {
        ensure!(
            s > 0.0 && s.is_finite(),
            "--size must be a positive number of metres"
        );
    }
    let params = DetectParams {
        refine_edges: args.refine || camera.is_some(),
        ..DetectParams::default()
    };
    let mut images = Vec::new();
    for path in &args.images {
        let gray = markers::load_gray(path)?;
        let t0 = Instant::now();
        let found = markers::detect(&gray, &dict, &params);
        let ms = t0.elapsed().as_secs_f64() * 1e3;
        let markers = found
            .iter()
            .map(|m| MarkerOut {
                id: m.id,
                corners: m.corners.map(|c| [round3(c.x), round3(c.y)]),
                pose: camera
                    .as_ref()
                    .zip(args.size)
                    .and_then(|(cam, size)| pose_of(m, size, cam)),
            })
            .collect();
        images.push(ImageOut {
            image: path.clone(),
            markers,
            ms,
        });
    }
    let out = DetectOutput {
        dictionary: dict.name().to_string(),
        ms_per_image: median(&images.iter().map(|i| i.ms).collect::<Vec<_>>()),
        images,
    };
    if args.json {
        return print_json(sink, &out);
    }
    let mut t = report::Table::new("ArUco markers", ["image", "markers", "ids", "ms"]);
    for i in &out.images {
        let ids: Vec<String> = i.markers.iter().map(|m| m.id.to_string()).collect();
        t.push_row([
            i.image.display().to_string(),
            i.markers.len().to_string(),
            ids.join(" "),
            format!("{:.2}", i.ms),
        ]);
    }
    print_text(
        sink,
        &format!(
            "{}median {:.2} ms per image ({})\n",
            t.to_text(),
            out.ms_per_image,
            out.dictionary
        ),
    )
}

fn pose_of(m: &Marker, size: f64, camera: &Camera) -> Option<PoseOut> {
    let p = markers::estimate_marker_pose(m, size, camera)?;
    let pose = &p.best.marker_in_camera;
    Some(PoseOut {
        position: pose.position(),
        quaternion: pose.quat_wxyz(),
        rms_px: p.best.rms_px,
        ambiguous: p.ambiguous,
    })
}

fn round3(v: f64) -> f64 {
    (v * 1000.0).round() / 1000.0
}

/// Reads camera intrinsics written by `indoorloc calibrate` or OpenCV.
pub(crate) fn read_camera(path: &Path) -> Result<Camera> {
    Ok(calib::read_camera_yaml(path)?)
}

#[derive(Debug, Serialize)]
struct GenerateOutput {
    dictionary: String,
    files: Vec<PathBuf>,
}

fn generate(args: &GenerateConfig, sink: &mut dyn crate::Output) -> Result<()> {
    let dict = args.dict.load()?;
    let ids = parse_ids(&args.ids, dict.len() as u32)?;
    ensure!(args.cell_px >= 1, "--cell-px must be at least 1");
    ensure!(args.size_mm > 0.0, "--size-mm must be positive");
    let files =
        markers::generate::write_markers(&dict, &ids, &args.out, args.cell_px, args.size_mm)?;
    let out = GenerateOutput {
        dictionary: dict.name().to_string(),
        files,
    };
    if args.json {
        return print_json(sink, &out);
    }
    let list: String = out
        .files
        .iter()
        .map(|f| format!("{}\n", f.display()))
        .collect();
    print_text(sink, &list)
}

/// `A-B`, `1,5,9` or `7`, each id below `count`.
fn parse_ids(spec: &str, count: u32) -> Result<Vec<u32>> {
    let mut ids = Vec::new();
    for part in spec.split(',').map(str::trim).filter(|p| !p.is_empty()) {
        let num = |s: &str| {
            s.trim()
                .parse::<u32>()
                .with_context(|| format!("--ids '{spec}': '{s}' is not an id"))
        };
        match part.split_once('-') {
            Some((a, b)) => {
                let (a, b) = (num(a)?, num(b)?);
                ensure!(a <= b, "--ids '{spec}': range {a}-{b} runs backwards");
                ids.extend(a..=b);
            }
            None => ids.push(num(part)?),
        }
    }
    ensure!(!ids.is_empty(), "--ids '{spec}': no ids");
    if let Some(bad) = ids.iter().find(|&&i| i >= count) {
        bail!("--ids '{spec}': id {bad} is past the dictionary's end (ids 0..{count})");
    }
    Ok(ids)
}

#[derive(Debug, Serialize)]
struct LocateImage {
    image: PathBuf,
    /// Camera position in the building, metres; null when no map marker was usable.
    position: Option<[f64; 3]>,
    /// Camera-to-building rotation (w, x, y, z).
    quaternion: Option<[f64; 4]>,
    sigma_pos_m: Option<f64>,
    sigma_rot_deg: Option<f64>,
    markers_used: Vec<u32>,
    markers_rejected: Vec<u32>,
    /// Ids detected that the map does not list.
    markers_unknown: Vec<u32>,
    rms_px: Option<f64>,
    ambiguous: bool,
}

#[derive(Debug, Serialize)]
struct LocateOutput {
    images: Vec<LocateImage>,
    located: usize,
}

fn locate(args: &LocateConfig, sink: &mut dyn crate::Output) -> Result<()> {
    let map = MarkerMap::read(&args.map)?;
    let camera = read_camera(&args.camera)?;
    let dict = match (&args.dict_file, &args.dict, &map.dictionary) {
        (Some(f), _, _) => Dictionary::from_opencv_yaml(f)?,
        (None, Some(n), _) | (None, None, Some(n)) => Dictionary::predefined(n)?,
        (None, None, None) => Dictionary::predefined("4x4_50")?,
    };
    // Poses need the sub-pixel corners.
    let params = DetectParams {
        refine_edges: true,
        ..DetectParams::default()
    };
    let mut images = Vec::new();
    for path in &args.images {
        let gray = markers::load_gray(path)?;
        let found = markers::detect(&gray, &dict, &params);
        let known: std::collections::BTreeSet<u32> = map.markers.iter().map(|m| m.id).collect();
        let unknown = found
            .iter()
            .map(|m| m.id)
            .filter(|id| !known.contains(id))
            .collect();
        let l = markers::locate(&found, &map, &camera);
        images.push(LocateImage {
            image: path.clone(),
            position: l.as_ref().map(|l| l.pose.position()),
            quaternion: l.as_ref().map(|l| l.pose.quat_wxyz()),
            sigma_pos_m: l.as_ref().map(|l| l.sigma_pos_m),
            sigma_rot_deg: l.as_ref().map(|l| l.sigma_rot_deg),
            markers_used: l
                .as_ref()
                .map(|l| l.markers_used.clone())
                .unwrap_or_default(),
            markers_rejected: l
                .as_ref()
                .map(|l| l.markers_rejected.clone())
                .unwrap_or_default(),
            markers_unknown: unknown,
            rms_px: l.as_ref().map(|l| l.rms_px),
            ambiguous: l.as_ref().is_some_and(|l| l.ambiguous),
        });
    }
    let out = LocateOutput {
        located: images.iter().filter(|i| i.position.is_some()).count(),
        images,
    };
    if args.json {
        return print_json(sink, &out);
    }
    let mut t = report::Table::new(
        "Camera pose from markers",
        [
            "image",
            "x (m)",
            "y (m)",
            "z (m)",
            "σ pos (m)",
            "used",
            "rejected",
        ],
    );
    for i in &out.images {
        let p = i
            .position
            .map_or(["-".to_string(), "-".into(), "-".into()], |p| {
                p.map(|v| format!("{v:.3}"))
            });
        let [x, y, z] = p;
        t.push_row([
            i.image.display().to_string(),
            x,
            y,
            z,
            i.sigma_pos_m.map_or("-".into(), |s| format!("{s:.3}")),
            format!("{:?}", i.markers_used),
            format!("{:?}", i.markers_rejected),
        ]);
    }
    print_text(
        sink,
        &format!(
            "{}{} of {} images located\n",
            t.to_text(),
            out.located,
            out.images.len()
        ),
    )
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn id_lists_and_ranges_parse_and_bad_ones_are_refused() {
        assert_eq!(parse_ids("0-3", 50).unwrap(), vec![0, 1, 2, 3]);
        assert_eq!(parse_ids("1,5, 9", 50).unwrap(), vec![1, 5, 9]);
        assert_eq!(parse_ids("7", 50).unwrap(), vec![7]);
        assert!(parse_ids("3-1", 50).is_err());
        assert!(
            parse_ids("49-50", 50)
                .unwrap_err()
                .to_string()
                .contains("50")
        );
        assert!(parse_ids("x", 50).is_err());
    }
}
