//! Training data in memory: every frame of the train and validation splits turned into the
//! network's view once, in parallel, before training starts (the datasets are small, and a view
//! made once cannot differ between epochs or between training and validation).

use std::path::{Path, PathBuf};

use data::PoseFrame;
use data::blocks::BlockSplit;
use data::native::{self, DatasetInfo, SplitName, Splits};
use data::posed::{self, Layout, PosedDataset, PosedImage, SplitPlan};
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

    /// Sequence and frame number of sample `i`, from its `seq/frame` name; `None` when the
    /// frame's name does not end in a number (posed photos).
    pub fn frame_key(&self, i: usize) -> Option<(&str, u64)> {
        let (seq, frame) = self.names.get(i)?.rsplit_once('/')?;
        // `000012` (native), `frame-000012` (7-Scenes): the number the name ends with.
        let digits = frame.len() - frame.trim_end_matches(|c: char| c.is_ascii_digit()).len();
        Some((seq, frame[frame.len() - digits..].parse().ok()?))
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

    /// The views of samples `range` as one batch `[len, C, H, W]` on `device`.
    pub fn batch(
        &self,
        range: std::ops::Range<usize>,
        device: &burn::tensor::Device,
    ) -> burn::tensor::Tensor<4> {
        let n = self.view_len();
        burn::tensor::Tensor::from_data(
            burn::tensor::TensorData::new(
                self.inputs[range.start * n..range.end * n].to_vec(),
                [range.len(), self.channels, self.height, self.width],
            ),
            device,
        )
    }

    /// The samples `indices` of `self` and then of `other` (indices past `self.len()` count
    /// on into `other`), e.g. to split the frames of two splits again.
    pub fn select(&self, other: &Samples, indices: &[usize]) -> Samples {
        let mut out = Samples {
            channels: self.channels,
            width: self.width,
            height: self.height,
            ..Samples::default()
        };
        for &i in indices {
            let (from, j) = if i < self.len() {
                (self, i)
            } else {
                (other, i - self.len())
            };
            out.inputs.extend_from_slice(from.input(j));
            out.poses.push(from.poses[j]);
            out.names.push(from.names[j].clone());
        }
        out
    }
}

/// A dataset ready for training.
#[derive(Clone, Debug)]
pub struct TrainData {
    /// `dataset.toml`.
    pub info: DatasetInfo,
    /// Training samples.
    pub train: Samples,
    /// Validation samples.
    pub val: Samples,
    /// Content hash of the dataset: metadata and the bytes of every image used, so a checkpoint
    /// can tell whether it is resumed on the same data.
    pub hash: String,
}

/// Every fifth frame of a posed photo collection without sequences is held out for validation
/// (the protocol of the real-photo acceptance test: train on four fifths, test on the rest).
pub const HOLDOUT_EVERY: usize = 5;

/// A frame with the image file it was taken from.
struct Shot {
    frame: PoseFrame,
    path: PathBuf,
}

/// Opens a dataset in any layout [`data::posed::open`] reads and splits it:
/// - `blocks` given: blocks of every sequence ([`BlockSplit`]), training and validation parts;
/// - a native folder with `splits.toml`: its sequences; without one, sequences split by
///   [`native::split_by_sequence`] seeded by `seed` (synthetic walks are many sequences);
/// - posed photos without an order (NeRF, COLMAP): every [`HOLDOUT_EVERY`]-th frame validates;
/// - recordings (7-Scenes, TUM, Cambridge): the dataset's own split with validation blocks cut
///   from its training sequences, else the default blocks.
///
/// Returns the metadata and the train and validation shots.
fn open(
    root: &Path,
    seed: u64,
    blocks: Option<BlockSplit>,
) -> Result<(DatasetInfo, Splits, Vec<Shot>, Vec<Shot>)> {
    let ds = posed::open(root)?;
    let shot = |img: &PosedImage| Shot {
        frame: img.frame.clone(),
        path: img.image.clone(),
    };
    let info = match &ds.info {
        Some(info) => info.clone(),
        None => info_of(&ds)?,
    };
    if let Some(b) = blocks {
        let plan = SplitPlan::Blocks(b);
        let part = |w| ds.split(plan, w).into_iter().map(shot).collect::<Vec<_>>();
        let splits = Splits {
            train: vec![format!("blocks {b}: training blocks")],
            val: vec![format!("blocks {b}: validation blocks")],
            test: vec![format!("blocks {b}: held-out blocks")],
        };
        return Ok((info, splits, part(SplitName::Train), part(SplitName::Val)));
    }
    match ds.layout {
        Layout::Native => {
            let splits = ds.own_split.clone().unwrap_or_else(|| {
                let mut seqs: Vec<String> = ds.images.iter().map(|i| i.frame.seq.clone()).collect();
                seqs.sort();
                seqs.dedup();
                native::split_by_sequence(&seqs, DEFAULT_VAL_FRACTION, 0.0, seed)
            });
            let part = |w: SplitName| -> Vec<Shot> {
                let seqs = splits.get(w);
                ds.images
                    .iter()
                    .filter(|i| seqs.contains(&i.frame.seq))
                    .map(shot)
                    .collect()
            };
            let (train, val) = (part(SplitName::Train), part(SplitName::Val));
            Ok((info, splits, train, val))
        }
        Layout::Nerf | Layout::Colmap => {
            let (mut train, mut val) = (Vec::new(), Vec::new());
            for (i, img) in ds.images.iter().enumerate() {
                if i % HOLDOUT_EVERY == HOLDOUT_EVERY - 1 {
                    val.push(shot(img));
                } else {
                    train.push(shot(img));
                }
            }
            let splits = Splits {
                train: vec![format!("every frame but each {HOLDOUT_EVERY}th")],
                val: vec![format!("every {HOLDOUT_EVERY}th frame")],
                test: Vec::new(),
            };
            Ok((info, splits, train, val))
        }
        Layout::SevenScenes | Layout::Tum | Layout::Cambridge => {
            let plan = SplitPlan::Auto;
            let part = |w| ds.split(plan, w).into_iter().map(shot).collect::<Vec<_>>();
            let splits = Splits {
                train: vec![ds.describe_split(plan)],
                val: vec!["validation part of that split".into()],
                test: Vec::new(),
            };
            Ok((info, splits, part(SplitName::Train), part(SplitName::Val)))
        }
    }
}

/// `dataset.toml` of a dataset in another tool's layout: a forward 6-DoF camera in metres (the
/// units of COLMAP and NeRF worlds are whatever their tool chose).
fn info_of(ds: &PosedDataset) -> Result<DatasetInfo> {
    let camera = ds.require_camera().map_err(|e| {
        LearnError::Input(format!(
            "{e}; a pose network learns one camera: convert the dataset to the native layout \
             with its intrinsics"
        ))
    })?;
    let units = match ds.layout {
        Layout::Nerf | Layout::Colmap => "arbitrary",
        _ => "m",
    };
    Ok(DatasetInfo {
        name: ds.name(),
        dof: 6,
        units: units.into(),
        frame_rate: 0.0,
        mount: geom::Mount::Forward,
        camera: native::CameraInfo::from_camera(&camera),
        generator: None,
    })
}

/// Degrees of freedom of the dataset at `root`: a native `dataset.toml`'s `dof`, else 6.
pub fn dof(root: &Path) -> Result<u8> {
    Ok(DatasetInfo::of(root)?.map_or(6, |info| info.dof))
}

/// Reads the train and validation frames of the dataset at `root` (any layout of [`open`]) and
/// makes their views.
/// Errors name the file: a missing or undecodable image, a view of another size than the
/// first, an empty split.
pub fn load(
    root: &Path,
    spec: &ViewSpec,
    seed: u64,
    blocks: Option<BlockSplit>,
) -> Result<TrainData> {
    let (info, splits, train, val) = open(root, seed, blocks)?;
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
            splits.train
        )));
    }
    let mut hash = Fnv64::new();
    hash.update(format!("{info:?}").as_bytes());
    for shot in train.iter().chain(&val) {
        hash.update(format!("{:?}", shot.frame).as_bytes());
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
        train,
        val,
        hash: hash.hex(),
    })
}

/// Refuses `frames` views of `per_view` values each (`f32`) when they need more than
/// `available` bytes: the process would be killed for memory part-way through, with nothing
/// said. `None` (memory unknown) lets everything through.
fn check_memory(
    frames: usize,
    per_view: usize,
    available: Option<u64>,
) -> std::result::Result<(), String> {
    let need = (frames as u64)
        .saturating_mul(per_view as u64)
        .saturating_mul(std::mem::size_of::<f32>() as u64);
    match available {
        Some(free) if need > free => Err(format!(
            "{frames} views of {per_view} values need {:.1} GB of memory and {:.1} GB is \
             available: train on fewer frames or with a smaller view",
            need as f64 / 1e9,
            free as f64 / 1e9
        )),
        _ => Ok(()),
    }
}

/// Memory available to new allocations (`MemAvailable` of `/proc/meminfo`), bytes; `None`
/// where that is not known.
fn available_memory() -> Option<u64> {
    let text = std::fs::read_to_string("/proc/meminfo").ok()?;
    let line = text.lines().find(|l| l.starts_with("MemAvailable:"))?;
    let kib: u64 = line.split_whitespace().nth(1)?.parse().ok()?;
    Some(kib * 1024)
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

/// Views are made this many frames at a time, so that memory peaks at the samples plus one
/// chunk of views rather than at twice the samples.
const VIEW_CHUNK: usize = 512;

/// Views of the frames of the dataset at `root` (in parallel, a chunk at a time) and a hash of their image bytes (in
/// order). Refused before any work when the views would not fit in the memory available.
fn make_samples(root: &Path, shots: &[Shot], spec: &ViewSpec) -> Result<(Samples, u64)> {
    let Some(first) = shots.first() else {
        return Ok((Samples::default(), 0));
    };
    let (view, _) = view_of(&first.path, spec)?;
    let (c, w, h) = (view.channels, view.width, view.height);
    check_memory(shots.len(), view.data.len(), available_memory())
        .map_err(|msg| LearnError::Input(format!("{}: {msg}", root.display())))?;
    let mut samples = Samples {
        channels: c as usize,
        width: w as usize,
        height: h as usize,
        inputs: Vec::with_capacity(shots.len() * view.data.len()),
        poses: Vec::with_capacity(shots.len()),
        names: Vec::with_capacity(shots.len()),
    };
    let mut hash = Fnv64::new();
    for chunk in shots.chunks(VIEW_CHUNK) {
        let views = chunk
            .par_iter()
            .map(|s| view_of(&s.path, spec))
            .collect::<Result<Vec<_>>>()?;
        for ((view, image_hash), Shot { frame, path }) in views.into_iter().zip(chunk) {
            if (view.channels, view.width, view.height) != (c, w, h) {
                return Err(LearnError::Image {
                    path: path.clone(),
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
    }
    Ok((samples, hash.finish()))
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn views_that_do_not_fit_in_memory_are_refused_before_any_work() {
        // 38400 views of 3x240x240: 26.5 GB.
        let e = check_memory(38400, 3 * 240 * 240, Some(24_000_000_000)).unwrap_err();
        assert!(e.contains("26.5 GB"), "{e}");
        assert!(check_memory(38400, 3 * 48 * 64, Some(24_000_000_000)).is_ok());
        assert!(check_memory(usize::MAX, usize::MAX, None).is_ok());
        assert!(available_memory().is_none_or(|b| b > 0));
    }
}
