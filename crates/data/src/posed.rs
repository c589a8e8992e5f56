//! One opener for posed image collections: every command that takes a dataset (`train`,
//! `localize`, `study real`, …) calls [`open`], so a layout read by one reads everywhere.
//!
//! # Layouts
//! - **native**: `dataset.toml` + `poses.csv` + `frames/NNNNNN.png` (or `.jpg` / `.jpeg`),
//!   depth in `depth/NNNNNN.png` where present; own split from `splits.toml` when present.
//! - **7-Scenes**: a scene folder (`seq-XX/` folders, `TrainSplit.txt` / `TestSplit.txt` as the
//!   own split when both are present) or one sequence folder; colour `frame-N.color.png` or
//!   `.color.jpg`, depth `frame-N.depth.png`; camera [`sevenscenes::rgb_camera`].
//! - **TUM RGB-D**: a folder with `rgb.txt` and `groundtruth.txt` (and `depth.txt`): each colour
//!   image takes the ground-truth pose nearest in time, and each depth image likewise, within
//!   [`TUM_MAX_DT_S`] as the TUM tools' `associate.py` does; images without a pose are left out.
//!   The files store no intrinsics: the ROS default camera (525, 525, 319.5, 239.5) unless told.
//! - **COLMAP**: a text model folder with its images in `images/` beside it, in its parent, or
//!   two folders up (`sparse/0` under a project with `images/`).
//! - **Cambridge / PoseNet**: a list file (`dataset_train.txt`) or a scene folder holding
//!   `dataset_train.txt` and `dataset_test.txt` (the own split); no intrinsics.
//! - **NeRF**: `transforms.json` or its folder; frames without an image are left out.
//!
//! Depth is carried where the format has it ([`PosedImage::depth`]). Splits are per frame
//! ([`PosedDataset::parts`]): the dataset's own split when it has one, with validation blocks
//! cut out of its training sequences, else a [`BlockSplit`] of each sequence.

use crate::blocks::BlockSplit;
use crate::native::{self, DatasetInfo, NativeDataset, SplitName, Splits};
use crate::{DataError, PoseFrame, Result, cambridge, colmap, formats, io, nerf, sevenscenes};
use geom::{Camera, Distortion};
use std::collections::HashSet;
use std::path::{Path, PathBuf};

/// Largest time difference, seconds, between a TUM image and the pose it takes (`associate.py`'s
/// default).
pub const TUM_MAX_DT_S: f64 = 0.02;

/// The layout a dataset was read from.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum Layout {
    /// indoorloc's own folder.
    Native,
    /// Microsoft 7-Scenes.
    SevenScenes,
    /// TUM RGB-D.
    Tum,
    /// A COLMAP text model.
    Colmap,
    /// Cambridge Landmarks / PoseNet lists.
    Cambridge,
    /// NeRF `transforms.json`.
    Nerf,
}

/// One posed image of a dataset.
#[derive(Clone, Debug, PartialEq)]
pub struct PosedImage {
    /// Name, sequence, time and camera-to-world pose.
    pub frame: PoseFrame,
    /// The colour image.
    pub image: PathBuf,
    /// The depth image (16-bit, millimetres, or the format's own scale), where the format has one.
    pub depth: Option<PathBuf>,
}

/// A posed image collection in any layout [`open`] reads.
#[derive(Clone, Debug)]
pub struct PosedDataset {
    /// The path it was opened from.
    pub root: PathBuf,
    /// Its layout.
    pub layout: Layout,
    /// The camera of every image, where the format tells it (or has a customary one).
    pub camera: Option<Camera>,
    /// The posed images, sequences in order and frames in order within each.
    pub images: Vec<PosedImage>,
    /// The split the dataset's own files give, by sequence (native `splits.toml`, 7-Scenes and
    /// Cambridge train/test lists).
    pub own_split: Option<Splits>,
    /// `dataset.toml` of a native dataset.
    pub info: Option<DatasetInfo>,
    /// Indices into `images` of the frames a scene cut comes before (a native `cuts.csv`).
    pub cuts: Vec<usize>,
}

/// How a dataset's frames are split into train, validation and test.
#[derive(Clone, Copy, Debug, Default, PartialEq, Eq)]
pub enum SplitPlan {
    /// The dataset's own split where it has one (validation blocks cut from its training
    /// sequences when it names none), else the default [`BlockSplit`].
    #[default]
    Auto,
    /// Blocks of every sequence, whatever the dataset's own split says.
    Blocks(BlockSplit),
}

impl PosedDataset {
    /// A dataset's name for reports: the folder or file name.
    pub fn name(&self) -> String {
        if let Some(info) = &self.info {
            return info.name.clone();
        }
        let path = if self.root.file_name().is_some() {
            self.root.clone()
        } else {
            std::fs::canonicalize(&self.root).unwrap_or_else(|_| self.root.clone())
        };
        path.file_name()
            .map(|n| n.to_string_lossy().into_owned())
            .unwrap_or_else(|| self.root.display().to_string())
    }

    /// The camera, or an error naming the dataset when the format stores none.
    pub fn require_camera(&self) -> Result<Camera> {
        self.camera.ok_or_else(|| {
            DataError::invalid(
                &self.root,
                "the images of this dataset have no single known camera (the format stores no \
                 intrinsics, or the images use several)",
            )
        })
    }

    /// The part of every image (`None`: in no split, e.g. a native sequence no list names).
    pub fn parts(&self, plan: SplitPlan) -> Vec<Option<SplitName>> {
        let blocks = match plan {
            SplitPlan::Blocks(b) => b,
            SplitPlan::Auto => BlockSplit::default(),
        };
        let own = match plan {
            SplitPlan::Auto => self.own_split.as_ref(),
            SplitPlan::Blocks(_) => None,
        };
        let mut index_in_seq = 0;
        let mut out = Vec::with_capacity(self.images.len());
        for (i, img) in self.images.iter().enumerate() {
            if i > 0 && self.images[i - 1].frame.seq != img.frame.seq {
                index_in_seq = 0;
            }
            let seq = &img.frame.seq;
            out.push(match own {
                None => Some(blocks.part(index_in_seq)),
                Some(s) if s.val.is_empty() && s.train.contains(seq) => {
                    Some(blocks.part_of_training(index_in_seq))
                }
                Some(s) => [SplitName::Train, SplitName::Val, SplitName::Test]
                    .into_iter()
                    .find(|&w| s.get(w).contains(seq)),
            });
            index_in_seq += 1;
        }
        out
    }

    /// The images a retrieval index or a map is built from: the training and validation parts
    /// (retrieval chooses nothing on validation frames, so they are mapped too, as the peer
    /// `sift_pnp.py` maps every frame outside the test blocks).
    pub fn mapped(&self, plan: SplitPlan) -> Vec<&PosedImage> {
        self.images
            .iter()
            .zip(self.parts(plan))
            .filter(|(_, p)| matches!(p, Some(SplitName::Train | SplitName::Val)))
            .map(|(img, _)| img)
            .collect()
    }

    /// The images of one part.
    pub fn split(&self, plan: SplitPlan, which: SplitName) -> Vec<&PosedImage> {
        self.images
            .iter()
            .zip(self.parts(plan))
            .filter(|(_, p)| *p == Some(which))
            .map(|(img, _)| img)
            .collect()
    }

    /// What the split is, in words, for reports.
    pub fn describe_split(&self, plan: SplitPlan) -> String {
        match (plan, &self.own_split) {
            (SplitPlan::Auto, Some(s)) if s.val.is_empty() => format!(
                "the dataset's own (train {:?}, test {:?}; validation: blocks {} of training)",
                s.train,
                s.test,
                BlockSplit::default()
            ),
            (SplitPlan::Auto, Some(s)) => format!(
                "the dataset's own (train {:?}, val {:?}, test {:?})",
                s.train, s.val, s.test
            ),
            (SplitPlan::Auto, None) => format!("blocks {}", BlockSplit::default()),
            (SplitPlan::Blocks(b), _) => format!("blocks {b}"),
        }
    }
}

/// True when `path` holds a posed image collection [`open`] reads (told from the files there,
/// not opened), false for anything else, e.g. a folder of plain images or a video.
pub fn is_dataset(path: &Path) -> bool {
    if path.is_dir()
        && (path.join(native::POSES_CSV).is_file()
            || path.join("rgb.txt").is_file()
            || path.join(cambridge_list(SplitName::Train)).is_file())
    {
        return true;
    }
    matches!(
        formats::detect(path),
        Ok(formats::Format::Native
            | formats::Format::SevenScenes
            | formats::Format::Colmap
            | formats::Format::Nerf
            | formats::Format::Cambridge)
    )
}

/// Opens a posed image collection in any layout of the module docs. Errors name the file: an
/// unknown layout, a pose file that does not parse, an image that is missing, depth files that
/// do not match the colour images, an empty collection.
pub fn open(path: &Path) -> Result<PosedDataset> {
    let meta = std::fs::metadata(path).map_err(|e| DataError::io(path, e))?;
    let native = meta.is_dir() && path.join(native::POSES_CSV).is_file();
    let ds = if native {
        open_native(path)?
    } else if meta.is_dir() && path.join("rgb.txt").is_file() {
        open_tum(path)?
    } else if meta.is_dir() && path.join(cambridge_list(SplitName::Train)).is_file() {
        open_cambridge_scene(path)?
    } else {
        match formats::detect(path).map_err(|_| unknown_layout(path))? {
            formats::Format::Native => open_native(path)?,
            formats::Format::SevenScenes => open_7scenes(path)?,
            formats::Format::Colmap => open_colmap(path)?,
            formats::Format::Nerf => open_nerf(path)?,
            formats::Format::Cambridge => open_cambridge_list(path)?,
            _ => return Err(unknown_layout(path)),
        }
    };
    if ds.images.is_empty() {
        return Err(DataError::invalid(path, "no posed images"));
    }
    if let Some(missing) = ds.images.iter().find(|i| !i.image.is_file()) {
        return Err(DataError::invalid(
            &missing.image,
            format!("image of frame '{}' is missing", missing.frame.name),
        ));
    }
    Ok(ds)
}

fn unknown_layout(path: &Path) -> DataError {
    DataError::invalid(
        path,
        "not a posed image dataset: expected a native folder (dataset.toml, poses.csv), a \
         7-Scenes scene or sequence, a TUM RGB-D folder (rgb.txt, groundtruth.txt), a COLMAP text \
         model, a Cambridge list or a NeRF transforms.json",
    )
}

fn open_native(path: &Path) -> Result<PosedDataset> {
    let root = if path.is_dir() {
        path.to_path_buf()
    } else {
        path.parent().map(Path::to_path_buf).unwrap_or_default()
    };
    let (info, trajectory, own_split, cut_frames) = if root.join(native::SPLITS_TOML).is_file() {
        let ds = NativeDataset::open(&root)?;
        (ds.info, ds.trajectory, Some(ds.splits), ds.cuts)
    } else {
        let info = DatasetInfo::read(&root.join(native::DATASET_TOML))?;
        (info, native::read(&root)?, None, None)
    };
    let cut_frames: HashSet<u64> = cut_frames.unwrap_or_default().into_iter().collect();
    let cuts = trajectory
        .frames
        .iter()
        .enumerate()
        .filter(|(_, f)| f.name.parse().is_ok_and(|n| cut_frames.contains(&n)))
        .map(|(i, _)| i)
        .collect();
    let poses_csv = root.join(native::POSES_CSV);
    let images = trajectory
        .frames
        .into_iter()
        .map(|frame| {
            let number: u64 = frame.name.parse().map_err(|_| {
                DataError::invalid(
                    &poses_csv,
                    format!("frame name '{}' is not a frame number", frame.name),
                )
            })?;
            let depth = native::image_path(&root, "depth", number);
            Ok(PosedImage {
                image: native::image_path(&root, "frames", number),
                depth: depth.is_file().then_some(depth),
                frame,
            })
        })
        .collect::<Result<Vec<_>>>()?;
    Ok(PosedDataset {
        camera: trajectory.camera,
        root: path.to_path_buf(),
        layout: Layout::Native,
        images,
        own_split,
        info: Some(info),
        cuts,
    })
}

fn open_7scenes(path: &Path) -> Result<PosedDataset> {
    let traj = sevenscenes::read(path)?;
    let in_seq = traj.frames.first().is_some_and(|f| {
        path.join(format!("{}{}", f.name, sevenscenes::POSE_SUFFIX))
            .is_file()
    });
    let own_split = if path.join("TrainSplit.txt").is_file() && path.join("TestSplit.txt").is_file()
    {
        let s = sevenscenes::read_split(path)?;
        Some(Splits {
            train: s.train,
            val: Vec::new(),
            test: s.test,
        })
    } else {
        None
    };
    let images = traj
        .frames
        .into_iter()
        .map(|frame| {
            let dir = if in_seq {
                path.to_path_buf()
            } else {
                path.join(&frame.seq)
            };
            let png = dir.join(format!("{}.color.png", frame.name));
            let jpg = dir.join(format!("{}.color.jpg", frame.name));
            let depth = dir.join(format!("{}.depth.png", frame.name));
            PosedImage {
                image: if png.is_file() || !jpg.is_file() {
                    png
                } else {
                    jpg
                },
                depth: depth.is_file().then_some(depth),
                frame,
            }
        })
        .collect();
    Ok(PosedDataset {
        root: path.to_path_buf(),
        layout: Layout::SevenScenes,
        camera: traj.camera,
        images,
        own_split,
        info: None,
        cuts: Vec::new(),
    })
}

/// The ROS default intrinsics the TUM RGB-D benchmark recommends for its 640x480 images when the
/// sensor's own calibration is not used.
pub fn tum_default_camera() -> Camera {
    Camera {
        width: 640,
        height: 480,
        fx: 525.0,
        fy: 525.0,
        cx: 319.5,
        cy: 239.5,
        dist: Distortion::default(),
    }
}

/// `timestamp path` lines of a TUM `rgb.txt` / `depth.txt` (comments and blank lines skipped).
fn tum_list(path: &Path) -> Result<Vec<(f64, String)>> {
    let text = io::read_text(path)?;
    let mut out = Vec::new();
    for (i, line) in text.lines().enumerate() {
        let fields: Vec<&str> = line.split_whitespace().collect();
        if fields.is_empty() || fields[0].starts_with('#') {
            continue;
        }
        let [t, file] = fields[..] else {
            return Err(DataError::parse(
                path,
                i + 1,
                "expected 'timestamp filename'",
            ));
        };
        let t: f64 = t
            .parse()
            .ok()
            .filter(|t: &f64| t.is_finite())
            .ok_or_else(|| DataError::parse(path, i + 1, format!("'{t}' is not a time stamp")))?;
        out.push((t, file.to_string()));
    }
    Ok(out)
}

/// Index of the time in sorted `times` nearest to `t`, when within `max_dt`.
fn nearest(times: &[f64], t: f64, max_dt: f64) -> Option<usize> {
    let i = times.partition_point(|&x| x < t);
    [i.checked_sub(1), (i < times.len()).then_some(i)]
        .into_iter()
        .flatten()
        .min_by(|&a, &b| (times[a] - t).abs().total_cmp(&(times[b] - t).abs()))
        .filter(|&j| (times[j] - t).abs() <= max_dt)
}

fn open_tum(dir: &Path) -> Result<PosedDataset> {
    let gt_path = dir.join("groundtruth.txt");
    if !gt_path.is_file() {
        return Err(DataError::invalid(
            &gt_path,
            "a TUM RGB-D folder needs groundtruth.txt beside rgb.txt",
        ));
    }
    let mut gt = crate::tum::read(&gt_path)?.frames;
    gt.sort_by(|a, b| a.t.unwrap_or(0.0).total_cmp(&b.t.unwrap_or(0.0)));
    let gt_times: Vec<f64> = gt.iter().map(|f| f.t.unwrap_or(0.0)).collect();
    let depth = if dir.join("depth.txt").is_file() {
        tum_list(&dir.join("depth.txt"))?
    } else {
        Vec::new()
    };
    let depth_times: Vec<f64> = depth.iter().map(|d| d.0).collect();
    if depth_times.windows(2).any(|w| w[1] < w[0]) {
        return Err(DataError::invalid(
            dir.join("depth.txt"),
            "time stamps are not in increasing order",
        ));
    }
    let seq = dir
        .file_name()
        .map(|n| n.to_string_lossy().into_owned())
        .unwrap_or_else(|| "tum".into());
    let mut images = Vec::new();
    for (t, file) in tum_list(&dir.join("rgb.txt"))? {
        let Some(g) = nearest(&gt_times, t, TUM_MAX_DT_S) else {
            continue;
        };
        let name = Path::new(&file)
            .file_stem()
            .map(|s| s.to_string_lossy().into_owned())
            .unwrap_or_else(|| file.clone());
        images.push(PosedImage {
            frame: PoseFrame {
                name,
                seq: seq.clone(),
                t: Some(t),
                pose: gt[g].pose,
            },
            image: dir.join(&file),
            depth: nearest(&depth_times, t, TUM_MAX_DT_S).map(|d| dir.join(&depth[d].1)),
        });
    }
    if images.is_empty() {
        return Err(DataError::invalid(
            dir.join("rgb.txt"),
            format!("no image has a pose in groundtruth.txt within {TUM_MAX_DT_S} s"),
        ));
    }
    if !depth.is_empty() && images.iter().any(|i| i.depth.is_none()) {
        return Err(DataError::invalid(
            dir.join("depth.txt"),
            format!("some colour images have no depth image within {TUM_MAX_DT_S} s"),
        ));
    }
    Ok(PosedDataset {
        root: dir.to_path_buf(),
        layout: Layout::Tum,
        camera: Some(tum_default_camera()),
        images,
        own_split: None,
        info: None,
        cuts: Vec::new(),
    })
}

fn open_colmap(path: &Path) -> Result<PosedDataset> {
    let model = if path.is_dir() {
        path.to_path_buf()
    } else {
        path.parent().map(Path::to_path_buf).unwrap_or_default()
    };
    let traj = colmap::read(&model)?;
    let first = &traj.frames[0].name;
    let candidates = [
        model.join("images"),
        model.join("..").join("images"),
        model.join("..").join("..").join("images"),
        model.clone(),
    ];
    let image_dir = candidates
        .iter()
        .find(|d| d.join(first).is_file())
        .ok_or_else(|| {
            DataError::invalid(
                &model,
                format!(
                    "the image '{first}' of images.txt is in none of images/, ../images, \
                     ../../images or the model folder"
                ),
            )
        })?
        .clone();
    let images = traj
        .frames
        .into_iter()
        .map(|frame| PosedImage {
            image: image_dir.join(&frame.name),
            depth: None,
            frame,
        })
        .collect();
    Ok(PosedDataset {
        root: path.to_path_buf(),
        layout: Layout::Colmap,
        camera: traj.camera,
        images,
        own_split: None,
        info: None,
        cuts: Vec::new(),
    })
}

fn open_nerf(path: &Path) -> Result<PosedDataset> {
    let (traj, paths) = nerf::read_with_images(path)?;
    let images = traj
        .frames
        .into_iter()
        .zip(paths)
        .filter(|(_, p)| p.is_file())
        .map(|(frame, image)| PosedImage {
            frame,
            image,
            depth: None,
        })
        .collect();
    Ok(PosedDataset {
        root: path.to_path_buf(),
        layout: Layout::Nerf,
        camera: traj.camera,
        images,
        own_split: None,
        info: None,
        cuts: Vec::new(),
    })
}

/// The list file of a Cambridge split.
fn cambridge_list(which: SplitName) -> &'static str {
    match which {
        SplitName::Train => "dataset_train.txt",
        SplitName::Val => "dataset_val.txt",
        SplitName::Test => "dataset_test.txt",
    }
}

fn cambridge_images(list: &Path) -> Result<Vec<PosedImage>> {
    let root = list.parent().map(Path::to_path_buf).unwrap_or_default();
    Ok(cambridge::read(list)?
        .frames
        .into_iter()
        .map(|frame| PosedImage {
            image: root.join(&frame.name),
            depth: None,
            frame,
        })
        .collect())
}

fn open_cambridge_list(list: &Path) -> Result<PosedDataset> {
    Ok(PosedDataset {
        root: list.to_path_buf(),
        layout: Layout::Cambridge,
        camera: None,
        images: cambridge_images(list)?,
        own_split: None,
        info: None,
        cuts: Vec::new(),
    })
}

/// A Cambridge scene folder: its train and test lists are the own split, by sequence (`seq1/…`).
fn open_cambridge_scene(dir: &Path) -> Result<PosedDataset> {
    let mut images = cambridge_images(&dir.join(cambridge_list(SplitName::Train)))?;
    let train: HashSet<String> = images.iter().map(|i| i.frame.seq.clone()).collect();
    let test_list = dir.join(cambridge_list(SplitName::Test));
    let mut test = HashSet::new();
    if test_list.is_file() {
        let test_images = cambridge_images(&test_list)?;
        test = test_images.iter().map(|i| i.frame.seq.clone()).collect();
        if let Some(both) = train.intersection(&test).next() {
            return Err(DataError::invalid(
                &test_list,
                format!("sequence '{both}' is in both dataset_train.txt and dataset_test.txt"),
            ));
        }
        images.extend(test_images);
    }
    let sorted = |s: HashSet<String>| {
        let mut v: Vec<String> = s.into_iter().collect();
        v.sort();
        v
    };
    Ok(PosedDataset {
        root: dir.to_path_buf(),
        layout: Layout::Cambridge,
        camera: None,
        images,
        own_split: Some(Splits {
            train: sorted(train),
            val: Vec::new(),
            test: sorted(test),
        }),
        info: None,
        cuts: Vec::new(),
    })
}

#[cfg(test)]
mod tests;
