//! Training data in memory: every frame of the train and validation splits turned into the
//! network's view once, in parallel, before training starts (the datasets are small, and a view
//! made once cannot differ between epochs or between training and validation).

use std::path::{Path, PathBuf};

use data::native::{self, DatasetInfo, NativeDataset, SplitName, Splits};
use data::{PoseFrame, Trajectory};
use geom::Pose;
use imgproc::view::{View, ViewSpec};
use rayon::prelude::*;

use crate::hash::Fnv64;
use crate::{LearnError, Result};

/// Fraction of sequences held out for validation when a dataset has no `splits.toml`.
pub const DEFAULT_VAL_FRACTION: f64 = 0.2;

/// Views and poses of one split, inputs packed `[N, C, H, W]`.
#[derive(Clone, Debug, Default)]
pub struct Samples {
    /// Channels of each view.
    pub channels: usize,
    /// View width.
    pub width: usize,
    /// View height.
    pub height: usize,
    /// All views, one after the other (`N · C · H · W` values).
    pub inputs: Vec<f32>,
    /// Ground-truth pose of each view.
    pub poses: Vec<Pose>,
    /// `seq/frame` name of each view.
    pub names: Vec<String>,
}

impl Samples {
    /// Number of samples.
    pub fn len(&self) -> usize {
        self.poses.len()
    }

    /// True when there are no samples.
    pub fn is_empty(&self) -> bool {
        self.poses.is_empty()
    }

    /// Values per view.
    pub fn view_len(&self) -> usize {
        self.channels * self.width * self.height
    }

    /// The view of sample `i`.
    pub fn input(&self, i: usize) -> &[f32] {
        let n = self.view_len();
        &self.inputs[i * n..(i + 1) * n]
    }
}

/// A dataset ready for training.
#[derive(Clone, Debug)]
pub struct TrainData {
    /// `dataset.toml`.
    pub info: DatasetInfo,
    /// The splits used (from `splits.toml`, or made by sequence when the file is absent).
    pub splits: Splits,
    /// Training samples.
    pub train: Samples,
    /// Validation samples.
    pub val: Samples,
    /// Content hash of the dataset: metadata and the bytes of every image used, so a checkpoint
    /// can tell whether it is resumed on the same data.
    pub hash: String,
}

/// Opens a native dataset: with `splits.toml` through [`NativeDataset::open`], else its metadata
/// and poses with splits made by [`native::split_by_sequence`] (seeded by `seed`).
fn open(root: &Path, seed: u64) -> Result<(DatasetInfo, Trajectory, Splits)> {
    if root.join(native::SPLITS_TOML).is_file() {
        let ds = NativeDataset::open(root)?;
        return Ok((ds.info, ds.trajectory, ds.splits));
    }
    let info = DatasetInfo::read(&root.join(native::DATASET_TOML))?;
    let trajectory = native::read(root)?;
    let mut seqs: Vec<String> = trajectory.frames.iter().map(|f| f.seq.clone()).collect();
    seqs.sort();
    seqs.dedup();
    let splits = native::split_by_sequence(&seqs, DEFAULT_VAL_FRACTION, 0.0, seed);
    Ok((info, trajectory, splits))
}

/// Frames of a split, in file order.
fn split_frames<'a>(traj: &'a Trajectory, splits: &Splits, which: SplitName) -> Vec<&'a PoseFrame> {
    let seqs = splits.get(which);
    traj.frames
        .iter()
        .filter(|f| seqs.contains(&f.seq))
        .collect()
}

/// Reads the train and validation frames of the native dataset at `root` and makes their views.
/// Errors name the file: a missing or undecodable image, a view of another size than the
/// first, an empty split.
pub fn load(root: &Path, spec: &ViewSpec, seed: u64) -> Result<TrainData> {
    let (info, trajectory, splits) = open(root, seed)?;
    let train = split_frames(&trajectory, &splits, SplitName::Train);
    let val = split_frames(&trajectory, &splits, SplitName::Val);
    let splits_path = root.join(native::SPLITS_TOML);
    if train.is_empty() {
        return Err(LearnError::Input(format!(
            "{}: no training frames (train sequences: {:?})",
            splits_path.display(),
            splits.train
        )));
    }
    if val.is_empty() {
        return Err(LearnError::Input(format!(
            "{}: no validation frames; list at least one sequence under `val` (sequences: {:?})",
            splits_path.display(),
            trajectory
                .frames
                .iter()
                .map(|f| f.seq.as_str())
                .collect::<std::collections::BTreeSet<_>>()
        )));
    }
    let mut hash = Fnv64::new();
    for file in [native::DATASET_TOML, native::POSES_CSV] {
        let path = root.join(file);
        hash.update(&std::fs::read(&path).map_err(|e| LearnError::io(&path, e))?);
    }
    hash.update(format!("{splits:?}").as_bytes());
    let (train, train_hash) = make_samples(root, &train, spec)?;
    let (val, val_hash) = make_samples(root, &val, spec)?;
    if (train.channels, train.width, train.height) != (val.channels, val.width, val.height) {
        return Err(LearnError::Input(format!(
            "{}: validation views are {}x{}x{} but training views {}x{}x{}",
            root.display(),
            val.channels,
            val.height,
            val.width,
            train.channels,
            train.height,
            train.width
        )));
    }
    hash.update(&train_hash.to_le_bytes());
    hash.update(&val_hash.to_le_bytes());
    Ok(TrainData {
        info,
        splits,
        train,
        val,
        hash: hash.hex(),
    })
}

/// The image file of a frame: `frames/<name>.png`, the name read as a frame number.
fn frame_path(root: &Path, frame: &PoseFrame) -> Result<PathBuf> {
    let number: u64 = frame.name.parse().map_err(|_| {
        LearnError::Input(format!(
            "{}: frame name '{}' is not a frame number",
            root.join(native::POSES_CSV).display(),
            frame.name
        ))
    })?;
    Ok(root
        .join("frames")
        .join(format!("{}.png", native::frame_name(number))))
}

/// Reads, hashes and views one image.
fn view_of(path: &Path, spec: &ViewSpec) -> Result<(View, u64)> {
    let bytes = std::fs::read(path).map_err(|e| LearnError::io(path, e))?;
    let mut h = Fnv64::new();
    h.update(&bytes);
    let img = image::load_from_memory(&bytes).map_err(|e| LearnError::Image {
        path: path.to_path_buf(),
        msg: e.to_string(),
    })?;
    let view = spec.apply(&img, 0).map_err(|e| LearnError::Image {
        path: path.to_path_buf(),
        msg: e.to_string(),
    })?;
    Ok((view, h.finish()))
}

/// Views of `frames` (in parallel) and a hash of their image bytes (in order).
fn make_samples(root: &Path, frames: &[&PoseFrame], spec: &ViewSpec) -> Result<(Samples, u64)> {
    let views = frames
        .par_iter()
        .map(|f| view_of(&frame_path(root, f)?, spec))
        .collect::<Result<Vec<_>>>()?;
    let (c, w, h) = match views.first() {
        Some((v, _)) => (v.channels, v.width, v.height),
        None => return Ok((Samples::default(), 0)),
    };
    let mut samples = Samples {
        channels: c as usize,
        width: w as usize,
        height: h as usize,
        inputs: Vec::with_capacity(views.len() * (c * w * h) as usize),
        poses: Vec::with_capacity(views.len()),
        names: Vec::with_capacity(views.len()),
    };
    let mut hash = Fnv64::new();
    for ((view, image_hash), frame) in views.into_iter().zip(frames) {
        if (view.channels, view.width, view.height) != (c, w, h) {
            return Err(LearnError::Image {
                path: frame_path(root, frame)?,
                msg: format!(
                    "view is {}x{}x{}, the first frame's is {c}x{h}x{w} (images of one size needed)",
                    view.channels, view.height, view.width
                ),
            });
        }
        hash.update(&image_hash.to_le_bytes());
        samples.inputs.extend_from_slice(&view.data);
        samples.poses.push(frame.pose);
        samples.names.push(format!("{}/{}", frame.seq, frame.name));
    }
    Ok((samples, hash.finish()))
}
