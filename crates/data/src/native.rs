//! The native dataset: what `synth` writes, what `learn` reads, and what importers convert to.
//!
//! # Layout
//! ```text
//! DATASET/
//!   dataset.toml      DatasetInfo: name, dof (6 | 3), units, frame_rate, mount, [camera], [generator]
//!   poses.csv         frame,seq,t,x,y,z,qw,qx,qy,qz   (header required; one row per frame)
//!   frames/NNNNNN.png image of frame N (at least 6 digits, zero padded)
//!   labels.csv        optional: frame,building,floor,corridor,direction
//!   cuts.csv          optional: frame   (first frame of each new scene)
//!   depth/NNNNNN.png  optional: 16-bit depth in millimetres
//!   planes/NNNNNN.png optional: 8-bit dominant-plane ids
//!   splits.toml       train = [..], val = [..], test = [..]   (sequence names)
//! ```
//!
//! # Conventions and conversion
//! The native dataset *is* the convention of DESIGN.md, so nothing is converted: each row of
//! `poses.csv` is a camera-to-world pose (`p_world = R·p_cam + t`, OpenCV camera axes x right,
//! y down, z forward), `x, y, z` is the camera centre in metres and `qw, qx, qy, qz` the Hamilton
//! quaternion of `R`, written on the `w ≥ 0` hemisphere. A 3-DoF dataset (`dof = 3`) still stores
//! full poses: level poses built from `x, y`, heading and the `mount` of `dataset.toml`
//! ([`geom::Pose3::to_pose`]), so one reader serves both.
//!
//! In a [`Trajectory`] read from `poses.csv`, `PoseFrame::name` is the frame number formatted
//! `{:06}` (`000012`), `seq` the `seq` column and `t` the `t` column (an empty cell is `None`).
//! Columns are found by header name (any order, extra columns ignored). Numbers are written with
//! Rust's shortest round-trip formatting and a quaternion that is unit to rounding is kept as
//! written, so write → read is exact.
//!
//! # Splits
//! Splits list *sequences* (recording days or sessions), never frames: frames of one walk are
//! nearly identical, so splitting frames would leak test views into training.
//! [`split_by_sequence`] makes such splits deterministically; [`Splits::check`] rejects a sequence
//! in two lists or one that `poses.csv` lacks.

use crate::csv_table::{CsvTable, cell, csv_bytes};
use crate::error::{DataError, Result};
use crate::io::{parse_numbers, read_text, require_finite, write_atomic, write_text_atomic};
use crate::trajectory::{PoseFrame, Trajectory};
use geom::{Camera, Distortion, Mount, Pose};
use serde::{Deserialize, Serialize};
use std::collections::{BTreeMap, HashMap, HashSet};
use std::path::{Path, PathBuf};

/// File name of the dataset description.
pub const DATASET_TOML: &str = "dataset.toml";
/// File name of the pose table.
pub const POSES_CSV: &str = "poses.csv";
/// File name of the optional place labels.
pub const LABELS_CSV: &str = "labels.csv";
/// File name of the optional gold scene cuts.
pub const CUTS_CSV: &str = "cuts.csv";
/// File name of the splits.
pub const SPLITS_TOML: &str = "splits.toml";

/// Columns of `poses.csv`, in the order the writer emits them.
const POSE_COLUMNS: [&str; 10] = ["frame", "seq", "t", "x", "y", "z", "qw", "qx", "qy", "qz"];
/// Columns of `labels.csv`.
const LABEL_COLUMNS: [&str; 5] = ["frame", "building", "floor", "corridor", "direction"];
/// Units a dataset may declare: metres, or "arbitrary" for scenes without scale (NeRF, COLMAP).
const KNOWN_UNITS: [&str; 2] = ["m", "arbitrary"];

/// The content of `dataset.toml`.
///
/// Unknown top-level keys are ignored so newer writers stay readable; `[camera]` rejects unknown
/// keys because a misspelt `distortion` would otherwise silently mean "no distortion".
#[derive(Clone, Debug, PartialEq, Serialize, Deserialize)]
pub struct DatasetInfo {
    /// Human-readable dataset name.
    pub name: String,
    /// Degrees of freedom of the task: 6 (full pose) or 3 (x, y, heading).
    pub dof: u8,
    /// Unit of positions: `"m"` (metres), or `"arbitrary"` for imported scenes without scale.
    pub units: String,
    /// Frames per second of the sequences (time stamps are in `poses.csv`).
    pub frame_rate: f64,
    /// How the camera is mounted: says what heading means for a 3-DoF dataset.
    #[serde(default)]
    pub mount: Mount,
    /// Intrinsics shared by every frame.
    pub camera: CameraInfo,
    /// How the dataset was made.
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub generator: Option<Generator>,
}

/// The `[camera]` table of `dataset.toml` (OpenCV conventions: pixel centres at integers).
#[derive(Clone, Copy, Debug, PartialEq, Serialize, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct CameraInfo {
    /// Image width, pixels.
    pub width: u32,
    /// Image height, pixels.
    pub height: u32,
    /// Focal length along x, pixels.
    pub fx: f64,
    /// Focal length along y, pixels.
    pub fy: f64,
    /// Principal point x, pixels.
    pub cx: f64,
    /// Principal point y, pixels.
    pub cy: f64,
    /// `[k1, k2, p1, p2, k3]`, OpenCV's order.
    #[serde(default)]
    pub distortion: [f64; 5],
}

/// The `[generator]` table of `dataset.toml`: how the dataset was made, so it can be made again.
#[derive(Clone, Debug, Default, PartialEq, Serialize, Deserialize)]
pub struct Generator {
    /// The program, e.g. `"indoorloc synth 0.1.0"` or `"indoorloc import colmap"`.
    pub name: String,
    /// Random seed of a synthetic dataset (TOML integers: at most 2⁶³ − 1).
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub seed: Option<u64>,
    /// Where imported data came from (a path or URL).
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub source: Option<String>,
    /// Further settings that shaped the data (`world`, `mode`, `variant`, ...).
    #[serde(default, skip_serializing_if = "BTreeMap::is_empty")]
    pub settings: BTreeMap<String, String>,
}

impl CameraInfo {
    /// The table of a camera.
    pub fn from_camera(cam: &Camera) -> Self {
        Self {
            width: cam.width,
            height: cam.height,
            fx: cam.fx,
            fy: cam.fy,
            cx: cam.cx,
            cy: cam.cy,
            distortion: cam.dist.to_array(),
        }
    }

    /// The validated camera.
    pub fn to_camera(&self) -> geom::Result<Camera> {
        Camera::new(
            self.width,
            self.height,
            self.fx,
            self.fy,
            self.cx,
            self.cy,
            Distortion::from_array(self.distortion),
        )
    }
}

impl DatasetInfo {
    /// Checks `dof ∈ {3, 6}`, known units, a positive finite frame rate and a valid camera;
    /// errors name `path`.
    pub fn validate(&self, path: &Path) -> Result<()> {
        if self.dof != 3 && self.dof != 6 {
            return Err(DataError::invalid(
                path,
                format!("dof must be 3 or 6, got {}", self.dof),
            ));
        }
        if !KNOWN_UNITS.contains(&self.units.as_str()) {
            return Err(DataError::invalid(
                path,
                format!("units must be one of {KNOWN_UNITS:?}, got '{}'", self.units),
            ));
        }
        if !(self.frame_rate.is_finite() && self.frame_rate > 0.0) {
            return Err(DataError::invalid(
                path,
                format!(
                    "frame_rate must be a positive number, got {}",
                    self.frame_rate
                ),
            ));
        }
        self.camera
            .to_camera()
            .map_err(|e| DataError::invalid(path, format!("[camera]: {e}")))?;
        Ok(())
    }

    /// The camera of `[camera]`, validated.
    pub fn camera(&self) -> geom::Result<Camera> {
        self.camera.to_camera()
    }

    /// The `dataset.toml` of the native dataset at `root`, or `None` when `root` is not one
    /// (the one place that tells a native dataset by its `dataset.toml`).
    pub fn of(root: &Path) -> Result<Option<Self>> {
        let path = root.join(DATASET_TOML);
        if path.is_file() {
            Self::read(&path).map(Some)
        } else {
            Ok(None)
        }
    }

    /// Reads and validates a `dataset.toml`.
    pub fn read(path: &Path) -> Result<Self> {
        let info: Self = read_toml(path)?;
        info.validate(path)?;
        Ok(info)
    }

    /// Validates, then writes `path` atomically.
    pub fn write(&self, path: &Path) -> Result<()> {
        self.validate(path)?;
        write_toml(path, self)
    }
}

/// Which list of [`Splits`].
#[derive(Clone, Copy, Debug, PartialEq, Eq, Hash)]
pub enum SplitName {
    /// Training sequences.
    Train,
    /// Validation sequences (model selection, early stopping).
    Val,
    /// Held-out test sequences.
    Test,
}

/// The content of `splits.toml`: sequence names of each split. A sequence in no list is unused.
#[derive(Clone, Debug, Default, PartialEq, Eq, Serialize, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct Splits {
    /// Training sequences.
    #[serde(default)]
    pub train: Vec<String>,
    /// Validation sequences.
    #[serde(default)]
    pub val: Vec<String>,
    /// Test sequences.
    #[serde(default)]
    pub test: Vec<String>,
}

impl Splits {
    /// The sequences of one split.
    pub fn get(&self, which: SplitName) -> &[String] {
        match which {
            SplitName::Train => &self.train,
            SplitName::Val => &self.val,
            SplitName::Test => &self.test,
        }
    }

    /// Errors (naming `path`) when a sequence is listed twice, in two splits, or is not one of
    /// `sequences` (the sequences of `poses.csv`).
    pub fn check(&self, path: &Path, sequences: &[String]) -> Result<()> {
        let known: HashSet<&str> = sequences.iter().map(String::as_str).collect();
        let mut seen: HashMap<&str, &str> = HashMap::new();
        for (list, names) in [
            ("train", &self.train),
            ("val", &self.val),
            ("test", &self.test),
        ] {
            for name in names {
                if let Some(other) = seen.insert(name, list) {
                    return Err(DataError::invalid(
                        path,
                        format!("sequence '{name}' is listed in both {other} and {list}"),
                    ));
                }
                if !known.contains(name.as_str()) {
                    return Err(DataError::invalid(
                        path,
                        format!("{list} names sequence '{name}', which {POSES_CSV} does not have"),
                    ));
                }
            }
        }
        Ok(())
    }

    /// Reads a `splits.toml` (not checked against a dataset: see [`Splits::check`]).
    pub fn read(path: &Path) -> Result<Self> {
        read_toml(path)
    }

    /// Writes a `splits.toml` atomically.
    pub fn write(&self, path: &Path) -> Result<()> {
        write_toml(path, self)
    }
}

/// Place labels of one frame (a row of `labels.csv`). Class names are kept as text: floors like
/// `"B1"` or `"2M"` are not numbers.
#[derive(Clone, Debug, PartialEq, Eq, Serialize, Deserialize)]
pub struct Label {
    /// Frame number.
    pub frame: u64,
    /// Building name.
    pub building: String,
    /// Floor name.
    pub floor: String,
    /// Corridor (or room) name.
    pub corridor: String,
    /// Walking direction class.
    pub direction: String,
}

/// An opened native dataset: metadata checked, images not loaded.
#[derive(Clone, Debug, PartialEq)]
pub struct NativeDataset {
    /// The dataset folder.
    pub root: PathBuf,
    /// `dataset.toml`.
    pub info: DatasetInfo,
    /// `poses.csv`, with the camera of `dataset.toml`.
    pub trajectory: Trajectory,
    /// `labels.csv`, when present.
    pub labels: Option<Vec<Label>>,
    /// `cuts.csv` (frame numbers), when present.
    pub cuts: Option<Vec<u64>>,
    /// `splits.toml`.
    pub splits: Splits,
}

impl NativeDataset {
    /// Opens `root`: reads and cross-checks `dataset.toml`, `poses.csv`, `splits.toml` and, where
    /// present, `labels.csv` and `cuts.csv` (their frames must exist in `poses.csv`).
    pub fn open(root: &Path) -> Result<NativeDataset> {
        let info = DatasetInfo::read(&root.join(DATASET_TOML))?;
        let mut trajectory = read_poses(&root.join(POSES_CSV))?;
        trajectory.camera = Some(
            info.camera()
                .map_err(|e| DataError::invalid(root.join(DATASET_TOML), e.to_string()))?,
        );
        let frames = frame_set(&trajectory);
        let labels = optional_file(&root.join(LABELS_CSV))
            .map(|p| read_labels(&p, &frames))
            .transpose()?;
        let cuts = optional_file(&root.join(CUTS_CSV))
            .map(|p| read_cuts(&p, &frames))
            .transpose()?;
        let splits_path = root.join(SPLITS_TOML);
        let splits = Splits::read(&splits_path)?;
        splits.check(&splits_path, &sequences(&trajectory))?;
        Ok(NativeDataset {
            root: root.to_path_buf(),
            info,
            trajectory,
            labels,
            cuts,
            splits,
        })
    }

    /// Image path of a frame: `frames/NNNNNN.png`.
    pub fn frame_path(&self, frame: u64) -> PathBuf {
        image_path(&self.root, "frames", frame)
    }

    /// Depth image path of a frame: `depth/NNNNNN.png` (may not exist).
    pub fn depth_path(&self, frame: u64) -> PathBuf {
        image_path(&self.root, "depth", frame)
    }

    /// Plane-id image path of a frame: `planes/NNNNNN.png` (may not exist).
    pub fn plane_path(&self, frame: u64) -> PathBuf {
        image_path(&self.root, "planes", frame)
    }

    /// Frame number of the frame at `index` of the trajectory.
    pub fn frame_number(&self, index: usize) -> Option<u64> {
        self.trajectory
            .frames
            .get(index)
            .and_then(|f| f.name.parse().ok())
    }

    /// Sequence names in order of first appearance in `poses.csv`.
    pub fn sequences(&self) -> Vec<String> {
        sequences(&self.trajectory)
    }

    /// Indices (into `trajectory.frames`) of the frames of one sequence, in file order.
    pub fn sequence_frames(&self, seq: &str) -> Vec<usize> {
        self.trajectory
            .frames
            .iter()
            .enumerate()
            .filter(|(_, f)| f.seq == seq)
            .map(|(i, _)| i)
            .collect()
    }

    /// Indices (into `trajectory.frames`) of the frames whose sequence is in a split, in file order.
    pub fn split_frames(&self, which: SplitName) -> Vec<usize> {
        let seqs: HashSet<&str> = self.splits.get(which).iter().map(String::as_str).collect();
        self.trajectory
            .frames
            .iter()
            .enumerate()
            .filter(|(_, f)| seqs.contains(f.seq.as_str()))
            .map(|(i, _)| i)
            .collect()
    }

    /// The label of a frame, when `labels.csv` has one.
    pub fn label(&self, frame: u64) -> Option<&Label> {
        self.labels.as_ref()?.iter().find(|l| l.frame == frame)
    }

    /// Errors naming the first frame whose image is missing.
    pub fn check_images(&self) -> Result<()> {
        for i in 0..self.trajectory.len() {
            let frame = self
                .frame_number(i)
                .ok_or_else(|| DataError::invalid(&self.root, "frame name is not a number"))?;
            let path = self.frame_path(frame);
            if !path.is_file() {
                return Err(DataError::invalid(
                    path,
                    "image of a frame in poses.csv is missing",
                ));
            }
        }
        Ok(())
    }
}

/// The name of frame `frame` in a trajectory and its image file stem: `{:06}`.
pub fn frame_name(frame: u64) -> String {
    format!("{frame:06}")
}

/// Reads the poses of a native dataset (`path` = the dataset folder or its `poses.csv`), with the
/// camera of `dataset.toml` when that file is beside it. Splits and labels are not read.
pub fn read(path: &Path) -> Result<Trajectory> {
    let (root, poses) = if path.is_dir() {
        (path.to_path_buf(), path.join(POSES_CSV))
    } else {
        let root = path.parent().map(Path::to_path_buf).unwrap_or_default();
        (root, path.to_path_buf())
    };
    let mut trajectory = read_poses(&poses)?;
    let toml = root.join(DATASET_TOML);
    if toml.is_file() {
        let info = DatasetInfo::read(&toml)?;
        trajectory.camera = Some(
            info.camera()
                .map_err(|e| DataError::invalid(&toml, e.to_string()))?,
        );
    }
    Ok(trajectory)
}

/// Writes the metadata of a native dataset into `root`: `dataset.toml`, `poses.csv`,
/// `splits.toml`, and `labels.csv` / `cuts.csv` when given (a stale one is removed when not, so
/// the folder describes exactly what was passed). Every file is written atomically after the whole
/// input is checked. Frame names must be frame numbers (`000012` or `12`); `trajectory.camera`
/// is not used (the camera is `info.camera`). Images are written by whoever renders them.
pub fn write_metadata(
    root: &Path,
    info: &DatasetInfo,
    trajectory: &Trajectory,
    labels: Option<&[Label]>,
    cuts: Option<&[u64]>,
    splits: &Splits,
) -> Result<()> {
    let poses_path = root.join(POSES_CSV);
    info.validate(&root.join(DATASET_TOML))?;
    let poses = poses_csv(&poses_path, trajectory)?;
    let frames = frame_set(trajectory);
    splits.check(&root.join(SPLITS_TOML), &sequences(trajectory))?;
    let labels = labels
        .map(|l| labels_csv(&root.join(LABELS_CSV), l, &frames))
        .transpose()?;
    let cuts = cuts
        .map(|c| cuts_csv(&root.join(CUTS_CSV), c, &frames))
        .transpose()?;
    info.write(&root.join(DATASET_TOML))?;
    write_atomic(&poses_path, |w| w.write_all(&poses))?;
    splits.write(&root.join(SPLITS_TOML))?;
    write_or_remove(&root.join(LABELS_CSV), labels.as_deref())?;
    write_or_remove(&root.join(CUTS_CSV), cuts.as_deref())
}

/// Path of a frame's image in one of a native dataset's image folders (`frames`, `depth`,
/// `planes`): `root/<folder>/NNNNNN.png`, or the frame's `.jpg` / `.jpeg` when there is no PNG
/// (colour frames of real cameras come as JPEG; re-encoding them would only cost disk).
pub fn image_path(root: &Path, folder: &str, frame: u64) -> PathBuf {
    let dir = root.join(folder);
    let png = dir.join(format!("{}.png", frame_name(frame)));
    if png.is_file() {
        return png;
    }
    ["jpg", "jpeg"]
        .iter()
        .map(|ext| dir.join(format!("{}.{ext}", frame_name(frame))))
        .find(|p| p.is_file())
        .unwrap_or(png)
}

/// Splits sequence names (recording days or sessions: the unit that must not straddle splits)
/// into train / val / test, deterministically: the result depends only on the *set* of names
/// and `seed`. Each fraction is clamped to [0, 1] (NaN counts as 0); a split asked for
/// (fraction > 0) gets at least one sequence as long as train keeps one, val giving way before
/// test. Names within each list are sorted.
pub fn split_by_sequence(
    seqs: &[String],
    val_fraction: f64,
    test_fraction: f64,
    seed: u64,
) -> Splits {
    let mut names: Vec<String> = seqs.to_vec();
    names.sort();
    names.dedup();
    shuffle(&mut names, seed);
    let (n_val, n_test) = split_counts(names.len(), val_fraction, test_fraction);
    let mut test: Vec<String> = names[..n_test].to_vec();
    let mut val: Vec<String> = names[n_test..n_test + n_val].to_vec();
    let mut train: Vec<String> = names[n_test + n_val..].to_vec();
    for list in [&mut train, &mut val, &mut test] {
        list.sort();
    }
    Splits { train, val, test }
}

/// How many of `n` sequences go to val and test (see [`split_by_sequence`]).
fn split_counts(n: usize, val_fraction: f64, test_fraction: f64) -> (usize, usize) {
    let want = |f: f64| {
        let f = if f.is_nan() { 0.0 } else { f.clamp(0.0, 1.0) };
        if f > 0.0 {
            ((n as f64 * f).round() as usize).max(1)
        } else {
            0
        }
    };
    let (mut val, mut test) = (want(val_fraction), want(test_fraction));
    // Train keeps at least one sequence; val gives way first because a test set matters more.
    while n > 0 && val + test > n - 1 {
        if val > 0 {
            val -= 1;
        } else {
            test -= 1;
        }
    }
    if n == 0 { (0, 0) } else { (val, test) }
}

/// Fisher–Yates with splitmix64: a fixed, platform-independent generator, so splits never change
/// with a dependency update.
fn shuffle<T>(items: &mut [T], seed: u64) {
    let mut state = seed;
    let mut next = || {
        state = state.wrapping_add(0x9E37_79B9_7F4A_7C15);
        let mut z = state;
        z = (z ^ (z >> 30)).wrapping_mul(0xBF58_476D_1CE4_E5B9);
        z = (z ^ (z >> 27)).wrapping_mul(0x94D0_49BB_1331_11EB);
        z ^ (z >> 31)
    };
    for i in (1..items.len()).rev() {
        let j = (next() % (i as u64 + 1)) as usize;
        items.swap(i, j);
    }
}

// ---------------------------------------------------------------------------------------------
// poses.csv

/// Reads `poses.csv`; errors name the file and line.
fn read_poses(path: &Path) -> Result<Trajectory> {
    let table = CsvTable::read(path)?;
    let cols = table.columns(&POSE_COLUMNS)?;
    let mut first_line: HashMap<u64, usize> = HashMap::new();
    let mut frames = Vec::with_capacity(table.rows.len());
    for (line, row) in &table.rows {
        let line = *line;
        let frame = parse_frame(path, line, cell(row, cols[0]))?;
        if let Some(first) = first_line.insert(frame, line) {
            return Err(DataError::parse(
                path,
                line,
                format!("frame {frame} appears twice (also on line {first})"),
            ));
        }
        let seq = cell(row, cols[1]);
        if seq.is_empty() {
            return Err(DataError::parse(path, line, "empty seq"));
        }
        let t = optional_number(path, line, cell(row, cols[2]))?;
        let fields: Vec<&str> = cols[3..].iter().map(|&c| cell(row, c)).collect();
        let v = parse_numbers(path, line, &fields)?;
        let pose = Pose::from_t_wxyz([v[0], v[1], v[2]], [v[3], v[4], v[5], v[6]])
            .map_err(|e| DataError::parse(path, line, e.to_string()))?;
        frames.push(PoseFrame {
            name: frame_name(frame),
            seq: seq.to_string(),
            t,
            pose,
        });
    }
    if frames.is_empty() {
        return Err(DataError::invalid(path, "no frames"));
    }
    Ok(Trajectory::new(frames))
}

/// The bytes of `poses.csv` for a trajectory, after checking it can be read back.
fn poses_csv(path: &Path, traj: &Trajectory) -> Result<Vec<u8>> {
    if traj.is_empty() {
        return Err(DataError::invalid(path, "no frames to write"));
    }
    let mut seen = HashSet::new();
    let mut rows = Vec::with_capacity(traj.len());
    for f in &traj.frames {
        let frame = frame_of_name(path, &f.name)?;
        if !seen.insert(frame) {
            return Err(DataError::invalid(
                path,
                format!("frame {frame} appears twice"),
            ));
        }
        if f.seq.is_empty() {
            return Err(DataError::invalid(
                path,
                format!("frame {frame} has an empty seq"),
            ));
        }
        require_finite(path, f)?;
        if f.t.is_some_and(|t| !t.is_finite()) {
            return Err(DataError::invalid(
                path,
                format!("frame {frame} has a non-finite t"),
            ));
        }
        let [x, y, z] = f.pose.position();
        let [qw, qx, qy, qz] = f.pose.quat_wxyz();
        let t = f.t.map(|t| t.to_string()).unwrap_or_default();
        let mut row = vec![frame.to_string(), f.seq.clone(), t];
        row.extend([x, y, z, qw, qx, qy, qz].iter().map(f64::to_string));
        rows.push(row);
    }
    csv_bytes(path, &POSE_COLUMNS, rows)
}

fn parse_frame(path: &Path, line: usize, text: &str) -> Result<u64> {
    text.parse()
        .map_err(|_| DataError::parse(path, line, format!("frame '{text}' is not a frame number")))
}

/// The frame number a trajectory frame's name stands for.
fn frame_of_name(path: &Path, name: &str) -> Result<u64> {
    name.parse()
        .map_err(|_| DataError::invalid(path, format!("frame name '{name}' is not a frame number")))
}

fn frame_set(traj: &Trajectory) -> HashSet<u64> {
    traj.frames
        .iter()
        .filter_map(|f| f.name.parse().ok())
        .collect()
}

fn sequences(traj: &Trajectory) -> Vec<String> {
    let mut seen = HashSet::new();
    traj.frames
        .iter()
        .filter(|f| seen.insert(f.seq.as_str()))
        .map(|f| f.seq.clone())
        .collect()
}

fn optional_number(path: &Path, line: usize, text: &str) -> Result<Option<f64>> {
    if text.is_empty() {
        Ok(None)
    } else {
        Ok(Some(parse_numbers(path, line, &[text])?[0]))
    }
}

// ---------------------------------------------------------------------------------------------
// labels.csv and cuts.csv

fn read_labels(path: &Path, frames: &HashSet<u64>) -> Result<Vec<Label>> {
    let table = CsvTable::read(path)?;
    let cols = table.columns(&LABEL_COLUMNS)?;
    let mut seen = HashSet::new();
    let mut labels = Vec::with_capacity(table.rows.len());
    for (line, row) in &table.rows {
        let frame = known_frame(path, *line, cell(row, cols[0]), frames, &mut seen)?;
        labels.push(Label {
            frame,
            building: cell(row, cols[1]).to_string(),
            floor: cell(row, cols[2]).to_string(),
            corridor: cell(row, cols[3]).to_string(),
            direction: cell(row, cols[4]).to_string(),
        });
    }
    Ok(labels)
}

fn read_cuts(path: &Path, frames: &HashSet<u64>) -> Result<Vec<u64>> {
    let table = CsvTable::read(path)?;
    let col = table.column("frame")?;
    let mut seen = HashSet::new();
    table
        .rows
        .iter()
        .map(|(line, row)| known_frame(path, *line, cell(row, col), frames, &mut seen))
        .collect()
}

/// A frame number that `poses.csv` has and that this file has not listed before.
fn known_frame(
    path: &Path,
    line: usize,
    text: &str,
    frames: &HashSet<u64>,
    seen: &mut HashSet<u64>,
) -> Result<u64> {
    let frame = parse_frame(path, line, text)?;
    if !frames.contains(&frame) {
        return Err(DataError::parse(
            path,
            line,
            format!("frame {frame} is not in {POSES_CSV}"),
        ));
    }
    if !seen.insert(frame) {
        return Err(DataError::parse(
            path,
            line,
            format!("frame {frame} appears twice"),
        ));
    }
    Ok(frame)
}

fn labels_csv(path: &Path, labels: &[Label], frames: &HashSet<u64>) -> Result<Vec<u8>> {
    let mut seen = HashSet::new();
    let mut rows = Vec::with_capacity(labels.len());
    for l in labels {
        check_frame(path, l.frame, frames, &mut seen)?;
        rows.push(vec![
            l.frame.to_string(),
            l.building.clone(),
            l.floor.clone(),
            l.corridor.clone(),
            l.direction.clone(),
        ]);
    }
    csv_bytes(path, &LABEL_COLUMNS, rows)
}

fn cuts_csv(path: &Path, cuts: &[u64], frames: &HashSet<u64>) -> Result<Vec<u8>> {
    let mut seen = HashSet::new();
    for &c in cuts {
        check_frame(path, c, frames, &mut seen)?;
    }
    csv_bytes(
        path,
        &["frame"],
        cuts.iter().map(|c| vec![c.to_string()]).collect(),
    )
}

fn check_frame(
    path: &Path,
    frame: u64,
    frames: &HashSet<u64>,
    seen: &mut HashSet<u64>,
) -> Result<()> {
    if !frames.contains(&frame) {
        return Err(DataError::invalid(
            path,
            format!("frame {frame} is not in the trajectory"),
        ));
    }
    if !seen.insert(frame) {
        return Err(DataError::invalid(
            path,
            format!("frame {frame} appears twice"),
        ));
    }
    Ok(())
}

fn write_or_remove(path: &Path, bytes: Option<&[u8]>) -> Result<()> {
    match bytes {
        Some(b) => write_atomic(path, |w| w.write_all(b)),
        None => match std::fs::remove_file(path) {
            Err(e) if e.kind() != std::io::ErrorKind::NotFound => Err(DataError::io(path, e)),
            _ => Ok(()),
        },
    }
}

fn optional_file(path: &Path) -> Option<PathBuf> {
    path.exists().then(|| path.to_path_buf())
}

// ---------------------------------------------------------------------------------------------
// TOML and CSV helpers (shared with the other formats of this crate)

fn read_toml<T: serde::de::DeserializeOwned>(path: &Path) -> Result<T> {
    let text = read_text(path)?;
    toml::from_str(&text).map_err(|e| {
        let line = e
            .span()
            .map(|s| text[..s.start.min(text.len())].matches('\n').count() + 1)
            .unwrap_or(1);
        DataError::parse(path, line, e.message().trim().to_string())
    })
}

fn write_toml<T: Serialize>(path: &Path, value: &T) -> Result<()> {
    let text = toml::to_string(value).map_err(|e| DataError::invalid(path, e.to_string()))?;
    write_text_atomic(path, &text)
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::test_util::{geo, put, tmp};

    fn info() -> DatasetInfo {
        crate::test_util::dataset_info()
    }

    fn trajectory() -> Result<Trajectory> {
        let mut frames = Vec::new();
        for i in 0..6u64 {
            let a = i as f64 * 0.7 - 1.3;
            let pose = geo(Pose::from_euler_ypr(
                a,
                0.1 * a,
                -0.3 * a,
                [a, 2.0 * a + 0.1, 1.2],
            ))?;
            frames.push(PoseFrame {
                name: frame_name(i),
                seq: format!("seq{}", i / 2),
                t: if i == 5 { None } else { Some(i as f64 / 29.97) },
                pose,
            });
        }
        Ok(Trajectory::new(frames))
    }

    fn splits() -> Splits {
        Splits {
            train: vec!["seq0".into(), "seq1".into()],
            val: vec![],
            test: vec!["seq2".into()],
        }
    }

    fn write_dataset(root: &Path) -> Result<Trajectory> {
        let traj = trajectory()?;
        let labels = vec![Label {
            frame: 3,
            building: "A".into(),
            floor: "B1".into(),
            corridor: "north, west".into(),
            direction: "east".into(),
        }];
        write_metadata(
            root,
            &info(),
            &traj,
            Some(&labels),
            Some(&[0, 2, 4]),
            &splits(),
        )?;
        Ok(traj)
    }

    #[test]
    fn hand_written_poses_csv() -> Result<()> {
        let dir = tmp()?;
        // Columns in another order, an extra column, spaces. Frame 7 is a camera at (1, 2, 1.5)
        // rotated 90° about z: q = (cos 45°, 0, 0, sin 45°), so R maps the camera's x axis to
        // world +y (R = [0 -1 0; 1 0 0; 0 0 1]).
        put(
            dir.path(),
            POSES_CSV,
            "seq, frame, t, x, y, z, qw, qx, qy, qz, note\n\
             walk1, 7, 0.5, 1, 2, 1.5, 0.7071067811865476, 0, 0, 0.7071067811865476, hi\n",
        )?;
        let traj = read(dir.path())?;
        assert_eq!(traj.len(), 1);
        let f = &traj.frames[0];
        assert_eq!(
            (f.name.as_str(), f.seq.as_str(), f.t),
            ("000007", "walk1", Some(0.5))
        );
        assert_eq!(f.pose.position(), [1.0, 2.0, 1.5]);
        let x_axis = f.pose.rotation * nalgebra::Vector3::x();
        assert!((x_axis - nalgebra::Vector3::y()).norm() < 1e-15);
        assert!(traj.camera.is_none());
        Ok(())
    }

    #[test]
    fn round_trip_is_exact() -> Result<()> {
        let dir = tmp()?;
        let traj = write_dataset(dir.path())?;
        let ds = NativeDataset::open(dir.path())?;
        assert_eq!(ds.info, info());
        assert_eq!(ds.trajectory.frames.len(), traj.len());
        for (a, b) in traj.frames.iter().zip(&ds.trajectory.frames) {
            assert_eq!((&a.name, &a.seq, a.t), (&b.name, &b.seq, b.t));
            assert_eq!(a.pose.position(), b.pose.position());
            assert_eq!(a.pose.quat_wxyz(), b.pose.quat_wxyz());
        }
        // A second pass changes no bit.
        let again = tmp()?;
        write_metadata(
            again.path(),
            &ds.info,
            &ds.trajectory,
            None,
            None,
            &ds.splits,
        )?;
        assert_eq!(read(again.path())?, ds.trajectory);
        assert_eq!(ds.trajectory.camera, Some(geo(info().camera())?));
        assert_eq!(ds.cuts, Some(vec![0, 2, 4]));
        let labels = ds.labels.clone().unwrap_or_default();
        assert_eq!(labels.len(), 1);
        assert_eq!(
            ds.label(3).map(|l| l.corridor.as_str()),
            Some("north, west")
        );
        assert_eq!(ds.splits, splits());
        Ok(())
    }

    #[test]
    fn dataset_queries() -> Result<()> {
        let dir = tmp()?;
        write_dataset(dir.path())?;
        let ds = NativeDataset::open(dir.path())?;
        assert_eq!(ds.frame_path(12), dir.path().join("frames/000012.png"));
        assert_eq!(ds.sequences(), vec!["seq0", "seq1", "seq2"]);
        assert_eq!(ds.sequence_frames("seq1"), vec![2, 3]);
        assert_eq!(ds.split_frames(SplitName::Train), vec![0, 1, 2, 3]);
        assert_eq!(ds.split_frames(SplitName::Test), vec![4, 5]);
        assert!(ds.split_frames(SplitName::Val).is_empty());
        assert_eq!(ds.frame_number(5), Some(5));
        assert!(ds.check_images().is_err());
        // Writing again without labels removes the stale labels.csv.
        write_metadata(dir.path(), &ds.info, &ds.trajectory, None, None, &ds.splits)?;
        let ds = NativeDataset::open(dir.path())?;
        assert!(ds.labels.is_none() && ds.cuts.is_none());
        // read() accepts poses.csv itself too.
        assert_eq!(read(&dir.path().join(POSES_CSV))?, ds.trajectory);
        Ok(())
    }

    fn poses_error(text: &str) -> Result<String> {
        let dir = tmp()?;
        let p = put(dir.path(), POSES_CSV, text)?;
        match read(&p) {
            Ok(_) => Ok(String::new()),
            Err(e) => Ok(e.to_string()),
        }
    }

    #[test]
    fn malformed_poses_name_file_and_line() -> Result<()> {
        let h = "frame,seq,t,x,y,z,qw,qx,qy,qz\n";
        let ok = "0,s,0,0,0,0,1,0,0,0\n";
        let cases = [
            (
                "frame,seq,t,x,y,z,qw,qx,qy\n0,s,0,0,0,0,1,0,0\n",
                ":1:",
                "missing column(s) qz",
            ),
            (
                &format!("{h}{ok}1,s,0,nan,0,0,1,0,0,0\n"),
                ":3:",
                "non-finite",
            ),
            (
                &format!("{h}{ok}1,s,0,0,0,0,1,1,0,0\n"),
                ":3:",
                "quaternion norm",
            ),
            (
                &format!("{h}{ok}0,s,0,0,0,0,1,0,0,0\n"),
                ":3:",
                "appears twice",
            ),
            (&format!("{h}{ok}1,s,0,0,0,0,1,0,0\n"), ":3:", "9 fields"),
            (
                &format!("{h}x,s,0,0,0,0,1,0,0,0\n"),
                ":2:",
                "not a frame number",
            ),
            (
                &format!("{h}1,s,0,0,abc,0,1,0,0,0\n"),
                ":2:",
                "not a number",
            ),
            ("", ":1:", "empty file"),
            (h, "", "no frames"),
        ];
        for (text, line, msg) in cases {
            let e = poses_error(text)?;
            assert!(
                e.contains(&format!("{POSES_CSV}{line}")) && e.contains(msg),
                "{text:?}: {e}"
            );
        }
        let dir = tmp()?;
        let p = dir.path().join(POSES_CSV);
        std::fs::write(&p, [0x89, b'P', b'N', b'G', 0xff, 0x00])
            .map_err(|e| DataError::io(&p, e))?;
        let e = read(&p).err().map(|e| e.to_string()).unwrap_or_default();
        assert!(
            e.contains(POSES_CSV) && e.contains("not a text file"),
            "{e}"
        );
        Ok(())
    }

    #[test]
    fn bad_splits_and_labels_are_errors() -> Result<()> {
        let dir = tmp()?;
        write_dataset(dir.path())?;
        let open_err = || NativeDataset::open(dir.path()).err().map(|e| e.to_string());
        put(dir.path(), SPLITS_TOML, "train = [\"seq0\", \"nope\"]\n")?;
        let e = open_err().unwrap_or_default();
        assert!(e.contains(SPLITS_TOML) && e.contains("'nope'"), "{e}");
        put(
            dir.path(),
            SPLITS_TOML,
            "train = [\"seq0\"]\ntest = [\"seq0\"]\n",
        )?;
        let e = open_err().unwrap_or_default();
        assert!(e.contains("both train and test"), "{e}");
        put(
            dir.path(),
            SPLITS_TOML,
            "train = [\"seq0\"]\ntset = [\"seq1\"]\n",
        )?;
        let e = open_err().unwrap_or_default();
        assert!(e.contains(&format!("{SPLITS_TOML}:2")), "{e}");
        put(dir.path(), SPLITS_TOML, "train = [\"seq0\"]\n")?;
        assert!(open_err().is_none());
        put(
            dir.path(),
            LABELS_CSV,
            "frame,building,floor,corridor,direction\n99,a,b,c,d\n",
        )?;
        let e = open_err().unwrap_or_default();
        assert!(
            e.contains(&format!("{LABELS_CSV}:2")) && e.contains("not in poses.csv"),
            "{e}"
        );
        // The writer refuses the same mistakes before touching any file.
        let bad = Splits {
            train: vec!["seq0".into()],
            val: vec![],
            test: vec!["seq0".into()],
        };
        let other = tmp()?;
        assert!(write_metadata(other.path(), &info(), &trajectory()?, None, None, &bad).is_err());
        assert!(
            std::fs::read_dir(other.path())
                .map_err(|e| DataError::io("d", e))?
                .next()
                .is_none()
        );
        Ok(())
    }

    #[test]
    fn bad_dataset_toml_is_an_error() -> Result<()> {
        let dir = tmp()?;
        write_dataset(dir.path())?;
        let p = dir.path().join(DATASET_TOML);
        let text = read_text(&p)?;
        put(
            dir.path(),
            DATASET_TOML,
            &text.replace("dof = 6", "dof = 4"),
        )?;
        let e = NativeDataset::open(dir.path())
            .err()
            .map(|e| e.to_string())
            .unwrap_or_default();
        assert!(e.contains(DATASET_TOML) && e.contains("dof"), "{e}");
        put(
            dir.path(),
            DATASET_TOML,
            &text.replace("fx = 500.0", "fx = -500.0"),
        )?;
        let e = NativeDataset::open(dir.path())
            .err()
            .map(|e| e.to_string())
            .unwrap_or_default();
        assert!(e.contains("camera"), "{e}");
        put(
            dir.path(),
            DATASET_TOML,
            &text.replace("distortion", "distorsion"),
        )?;
        let e = NativeDataset::open(dir.path())
            .err()
            .map(|e| e.to_string())
            .unwrap_or_default();
        assert!(e.contains(DATASET_TOML) && e.contains("distorsion"), "{e}");
        Ok(())
    }

    #[test]
    fn writers_refuse_non_finite_poses() -> Result<()> {
        let mut traj = trajectory()?;
        traj.frames[1].pose.translation.x = f64::NAN;
        let dir = tmp()?;
        let e = write_metadata(dir.path(), &info(), &traj, None, None, &splits()).err();
        let e = e.map(|e| e.to_string()).unwrap_or_default();
        assert!(
            e.contains(POSES_CSV) && e.contains("'000001' holds a non-finite value"),
            "{e}"
        );
        assert!(crate::colmap::write(&traj, dir.path()).is_err());
        assert!(crate::nerf::write(&traj, &dir.path().join("t.json")).is_err());
        Ok(())
    }

    proptest::proptest! {
        #![proptest_config(proptest::prelude::ProptestConfig::with_cases(48))]
        #[test]
        fn any_pose_round_trips_exactly(
            ypr in proptest::array::uniform3(-3.2f64..3.2),
            pos in proptest::array::uniform3(-1e4f64..1e4),
            t in 0.0f64..1e9,
        ) {
            let fail = |e: DataError| proptest::test_runner::TestCaseError::fail(e.to_string());
            let pose = geo(Pose::from_euler_ypr(ypr[0], ypr[1], ypr[2], pos)).map_err(fail)?;
            let frame = PoseFrame { name: frame_name(3), seq: "s".into(), t: Some(t), pose };
            let traj = Trajectory::new(vec![frame]);
            let dir = tmp().map_err(fail)?;
            let splits = Splits { train: vec!["s".into()], ..Splits::default() };
            write_metadata(dir.path(), &info(), &traj, None, None, &splits).map_err(fail)?;
            let back = read(dir.path()).map_err(fail)?;
            let b = &back.frames[0];
            proptest::prop_assert_eq!(b.t, Some(t));
            proptest::prop_assert_eq!(b.pose.position(), pos);
            proptest::prop_assert_eq!(b.pose.quat_wxyz(), pose.quat_wxyz());
        }
    }

    #[test]
    fn sequence_splits_are_deterministic_and_disjoint() {
        let seqs: Vec<String> = (0..10).map(|i| format!("day{i}")).collect();
        let a = split_by_sequence(&seqs, 0.2, 0.2, 42);
        let mut reversed = seqs.clone();
        reversed.reverse();
        assert_eq!(a, split_by_sequence(&reversed, 0.2, 0.2, 42));
        assert_eq!((a.train.len(), a.val.len(), a.test.len()), (6, 2, 2));
        let mut all: Vec<String> = [a.train, a.val, a.test].concat();
        all.sort();
        assert_eq!(all, seqs);
        // Small sets: a requested split gets one sequence while train keeps one.
        let two = split_by_sequence(&seqs[..2], 0.1, 0.1, 1);
        assert_eq!((two.train.len(), two.val.len(), two.test.len()), (1, 0, 1));
        let one = split_by_sequence(&seqs[..1], 0.5, 0.5, 1);
        assert_eq!(one.train.len(), 1);
        assert_eq!(split_by_sequence(&[], 0.5, 0.5, 1), Splits::default());
        assert_eq!(split_by_sequence(&seqs, f64::NAN, 2.0, 1).train.len(), 1);
    }
}
