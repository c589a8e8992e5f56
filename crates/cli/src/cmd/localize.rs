//! `indoorloc localize`: poses of images from a trained model, one line per frame as each is
//! done (JSON lines as DESIGN.md specifies, or TUM), so a pipe sees poses while a long input is
//! still being read.

use anyhow::{Context, Result, bail};
use clap::{Args, ValueEnum};
use data::formats::{self, Format};
use data::frames::{self, FrameSource};
use data::native::{NativeDataset, SplitName};
use data::{PoseFrame, cambridge, sevenscenes};
use learn::place::{PlaceLocalizer, PlaceMeta, PlacePrediction};
use learn::seq::{SeqLocalizer, SeqMeta, SeqTracker};
use learn::{Estimate, Localizer};
use serde::Serialize;
use std::collections::VecDeque;
use std::io::Write;
use std::path::{Path, PathBuf};
use std::time::Instant;

/// Output formats.
#[derive(Clone, Copy, Debug, PartialEq, Eq, ValueEnum)]
pub enum OutFormat {
    /// One JSON object per frame: frame, position, quaternion [w, x, y, z], sigma_pos_m, ...
    Jsonl,
    /// TUM trajectory lines: t tx ty tz qx qy qz qw (t: the frame's time, else its index).
    Tum,
}

/// Which frames of a native dataset.
#[derive(Clone, Copy, Debug, PartialEq, Eq, ValueEnum)]
pub enum Split {
    /// Every frame.
    All,
    /// The training sequences.
    Train,
    /// The validation sequences.
    Val,
    /// The test sequences.
    Test,
}

/// Arguments of `indoorloc localize`.
#[derive(Args, Debug)]
pub struct LocalizeArgs {
    /// Checkpoint folder written by `indoorloc train`.
    #[arg(long, value_name = "MODEL")]
    model: PathBuf,
    /// An image, an image folder, a video file, a native dataset folder, a 7-Scenes scene or
    /// sequence folder, or a Cambridge list file (dataset_test.txt).
    input: PathBuf,
    /// Monte-Carlo-dropout passes per frame (0: one deterministic pass, no uncertainty).
    #[arg(long, default_value_t = 16)]
    mc: usize,
    /// Test-time augmentation: each frame is also seen as four copies shifted by one 80th of
    /// its width (a slight pan or tilt); the position is their mean and their spread joins
    /// `sigma_pos_m`, at five times the backbone's cost. Single-frame models only.
    #[arg(long, default_value_t = true, action = clap::ArgAction::Set, value_name = "BOOL")]
    tta: bool,
    /// Seed of the MC-dropout masks: every frame is seen through the same `--mc` thinned
    /// networks drawn from it, so a frame's sigma does not depend on the frames around it.
    #[arg(long, default_value_t = learn::infer::DEFAULT_MC_SEED, value_name = "SEED")]
    mc_seed: u64,
    /// Output format.
    #[arg(long, value_enum, default_value_t = OutFormat::Jsonl)]
    format: OutFormat,
    /// For a native dataset or a 7-Scenes scene (TrainSplit.txt / TestSplit.txt): which
    /// split's frames.
    #[arg(long, value_enum, default_value_t = Split::All)]
    split: Split,
    /// Write to this file (atomically, when all frames are done) instead of stdout.
    #[arg(long, value_name = "FILE")]
    out: Option<PathBuf>,
    /// Each frame alone: a sequence model (trained with `train --window`) uses only its
    /// single-frame network, and a place model places every frame without the frames around it.
    #[arg(long)]
    single: bool,
    /// Seconds a place model waits before it tells a frame's place, taking in the frames of
    /// that time after it (lines come out that much later): 0 answers each frame from the frames
    /// before it only, as live; `inf` waits for the end of each walk.
    #[arg(long, value_name = "SECONDS", default_value_t = learn::place::DEFAULT_LAG_S)]
    place_lag: f64,
    /// Scene cuts where a sequence model and the place filter start over (a cut list or
    /// `scenecut --json` output: positions of frames in the input, from 0). A native dataset's
    /// own cuts.csv, new sequences and gaps in frame numbers always start them over.
    #[arg(long, value_name = "FILE")]
    cuts: Option<PathBuf>,
}

/// Which model localizes: the single-frame network, or a sequence model's live tracker.
// One per run, never stored in bulk: the size difference of the variants costs nothing.
#[allow(clippy::large_enum_variant)]
enum Estimator<'a> {
    Single(Localizer),
    Sequence(&'a SeqLocalizer, SeqTracker<'a>),
}

/// One output line in JSON lines format.
#[derive(Debug, Serialize)]
pub struct PoseLine {
    /// Image file stem, native frame name, or video frame index.
    pub frame: String,
    /// Sequence of a native dataset frame (so `eval` pairs by sequence and name).
    #[serde(skip_serializing_if = "Option::is_none")]
    pub seq: Option<String>,
    /// Time of the frame where the source has one.
    #[serde(skip_serializing_if = "Option::is_none")]
    pub t: Option<f64>,
    /// The pose, when the model folder holds a pose model.
    #[serde(flatten, skip_serializing_if = "Option::is_none")]
    pub pose: Option<PoseFields>,
    /// The place, when the model folder holds a place model.
    #[serde(skip_serializing_if = "Option::is_none")]
    pub place: Option<PlaceField>,
    /// Time to localise this frame (view + network), milliseconds.
    pub latency_ms: f64,
}

/// The pose part of a [`PoseLine`].
#[derive(Debug, Serialize)]
pub struct PoseFields {
    /// Camera centre in the world, metres.
    pub position: [f64; 3],
    /// Camera-to-world rotation, w, x, y, z.
    pub quaternion: [f64; 4],
    /// 3-DoF pose `[x, y, heading]` for 3-DoF models.
    #[serde(skip_serializing_if = "Option::is_none")]
    pub pose3: Option<[f64; 3]>,
    /// `sqrt(trace Σ_pos)`, metres: the MC passes' spread plus the model's predicted error
    /// scale, when it has one.
    pub sigma_pos_m: f64,
    /// RMS rotation of the MC passes about their mean, degrees.
    pub sigma_rot_deg: f64,
}

impl PoseFields {
    /// The fields of `est`.
    pub fn of(est: &Estimate) -> Self {
        PoseFields {
            position: est.pose.position(),
            quaternion: est.pose.quat_wxyz(),
            pose3: est.pose3.map(|p| [p.x, p.y, p.heading]),
            sigma_pos_m: est.sigma_pos_m,
            sigma_rot_deg: est.sigma_rot_deg,
        }
    }
}

/// The place of a frame, as DESIGN.md's `localize` contract names it.
#[derive(Debug, Serialize)]
pub struct PlaceField {
    /// Building name.
    pub building: String,
    /// Floor name.
    pub floor: String,
    /// Corridor name (`none` outside corridors).
    pub corridor: String,
    /// Walking direction class.
    pub direction: String,
    /// Probability of this place (corridor and direction) under the model.
    pub p: f64,
}

impl PlaceField {
    /// The field of a prediction.
    pub fn of(p: &PlacePrediction) -> Self {
        let [building, floor, corridor, direction] = p.parts();
        PlaceField {
            building,
            floor,
            corridor,
            direction,
            p: p.corridor.1,
        }
    }
}

impl PoseLine {
    fn write(&self, format: OutFormat, index: usize, w: &mut dyn Write) -> Result<()> {
        match (format, &self.pose) {
            (OutFormat::Jsonl, _) => {
                serde_json::to_writer(&mut *w, self)?;
                writeln!(w)?;
            }
            (OutFormat::Tum, Some(pose)) => {
                let [x, y, z] = pose.position;
                let [qw, qx, qy, qz] = pose.quaternion;
                let t = self.t.unwrap_or(index as f64);
                writeln!(
                    w,
                    "{t:.6} {x:.6} {y:.6} {z:.6} {qx:.9} {qy:.9} {qz:.9} {qw:.9}"
                )?;
            }
            (OutFormat::Tum, None) => bail!("TUM lines need poses; this model gives places only"),
        }
        Ok(())
    }
}

/// One frame to localise: where its pixels come from and what to call it.
struct Item {
    name: String,
    seq: Option<String>,
    t: Option<f64>,
    /// The frame starts a new stretch of time (a cut or a gap in a native dataset).
    new_scene: bool,
    image: Result<image::DynamicImage>,
}

/// Runs `indoorloc localize`.
pub fn run(args: &LocalizeArgs) -> Result<()> {
    let places = if PlaceMeta::exists(&args.model) {
        Some(PlaceLocalizer::load(&args.model)?)
    } else {
        None
    };
    let place_only = places.is_some() && !args.model.join(learn::checkpoint::MODEL_TOML).is_file();
    if place_only && args.format == OutFormat::Tum {
        bail!(
            "{}: holds a place model only; TUM lines need poses (use --format jsonl)",
            args.model.display()
        );
    }
    if !place_only {
        check_mount(&args.model, &args.input)?;
    }
    let sequence = if SeqMeta::exists(&args.model) && !args.single && !place_only {
        Some(SeqLocalizer::load(&args.model)?.with_seed(args.mc_seed))
    } else {
        None
    };
    let mut estimator = match &sequence {
        Some(seq) => Some(Estimator::Sequence(seq, seq.tracker(args.mc))),
        None if place_only => None,
        None => Some(Estimator::Single(
            Localizer::load(&args.model)?
                .with_tta(args.tta)
                .with_seed(args.mc_seed),
        )),
    };
    if args.place_lag.is_nan() || args.place_lag < 0.0 {
        bail!("--place-lag {}: must be 0 or more seconds", args.place_lag);
    }
    // A place model follows the walk unless each frame is to stand alone.
    let mut place_tracker = places
        .as_ref()
        .filter(|_| !args.single)
        .map(|loc| (loc, loc.tracker(args.place_lag)));
    // Lines whose place is still to be told (the tracker's lag), oldest first.
    let mut waiting: VecDeque<(usize, PoseLine)> = VecDeque::new();
    let cuts = match &args.cuts {
        Some(path) => data::cuts::read(path)?,
        None => Vec::new(),
    };
    let mut last_seq: Option<Option<String>> = None;
    let items = frames_of(&args.input, args.split)?;
    let mut buffer = Vec::new();
    let stdout = std::io::stdout();
    let mut lock = stdout.lock();
    let w: &mut dyn Write = if args.out.is_some() {
        &mut buffer
    } else {
        &mut lock
    };
    let mut bad = Vec::new();
    let mut done = 0usize;
    for (index, item) in items.enumerate() {
        let img = match item.image {
            Ok(img) => img,
            Err(e) => {
                eprintln!("indoorloc: skipped: {e:#}");
                bad.push(item.name);
                continue;
            }
        };
        let t0 = Instant::now();
        let starts_over = item.new_scene
            || cuts.binary_search(&(index as u64)).is_ok()
            || last_seq.as_ref().is_some_and(|s| *s != item.seq);
        last_seq = Some(item.seq.clone());
        let est = match &mut estimator {
            None => None,
            Some(Estimator::Sequence(seq, tracker)) => {
                if starts_over {
                    tracker.reset();
                }
                let view = seq.base().view(&img)?;
                Some(tracker.step(&view))
            }
            Some(Estimator::Single(loc)) => Some(loc.predict(&img, args.mc)),
        }
        .transpose()
        .with_context(|| format!("frame {}", item.name))?;
        let (place, told) = match &mut place_tracker {
            Some((loc, tracker)) => {
                if starts_over {
                    tell(&mut waiting, tracker.finish(), args.format, w)?;
                }
                let told = tracker
                    .step(&loc.view(&img)?, item.t)
                    .with_context(|| format!("frame {}", item.name))?;
                (None, Some(told))
            }
            None => {
                let place = places.as_ref().map(|p| p.predict(&img)).transpose();
                (place.with_context(|| format!("frame {}", item.name))?, None)
            }
        };
        let line = PoseLine {
            frame: item.name,
            seq: item.seq,
            t: item.t,
            pose: est.as_ref().map(PoseFields::of),
            place: place.as_ref().map(PlaceField::of),
            latency_ms: t0.elapsed().as_secs_f64() * 1e3,
        };
        match told {
            Some(told) => {
                waiting.push_back((index, line));
                tell(&mut waiting, told, args.format, w)?;
            }
            None => line.write(args.format, index, w)?,
        }
        done += 1;
    }
    if let Some((_, tracker)) = &mut place_tracker {
        tell(&mut waiting, tracker.finish(), args.format, w)?;
    }
    if let Some((_, line)) = waiting.front() {
        bail!(
            "frame {}: the place tracker never told its place",
            line.frame
        );
    }
    if let Some(path) = &args.out {
        data::io::write_atomic(path, |f| f.write_all(&buffer))?;
    }
    if !bad.is_empty() {
        bail!(
            "{}: {} of {} frames could not be read (first: {}); the others were localised",
            args.input.display(),
            bad.len(),
            bad.len() + done,
            bad[0]
        );
    }
    Ok(())
}

/// Writes the waiting lines whose places have been `told` (oldest first, one place per line).
fn tell(
    waiting: &mut VecDeque<(usize, PoseLine)>,
    told: Vec<PlacePrediction>,
    format: OutFormat,
    w: &mut dyn Write,
) -> Result<()> {
    for place in told {
        let (index, mut line) = waiting
            .pop_front()
            .context("the place tracker told more places than frames it was given")?;
        line.place = Some(PlaceField::of(&place));
        line.write(format, index, w)?;
    }
    Ok(())
}

/// Where a posed frame's image is.
type ImageOf = Box<dyn Fn(&PoseFrame) -> PathBuf>;

/// The frames of a posed collection in another tool's layout, decoded lazily: a 7-Scenes scene
/// or sequence folder (`frame-NNNNNN.color.png` beside each pose file; `split` from its split
/// files) or a Cambridge list (image paths relative to the list's folder). `None` for anything
/// else. Frames keep the reader's names and sequences, so `eval` pairs the output with the
/// same poses.
fn posed_frames(input: &Path, split: Split) -> Result<Option<Box<dyn Iterator<Item = Item>>>> {
    let is_list = input.is_file()
        && input
            .extension()
            .is_some_and(|e| e.eq_ignore_ascii_case("txt"));
    if !(input.is_dir() || is_list) {
        return Ok(None);
    }
    let Ok(format) = formats::detect(input) else {
        return Ok(None);
    };
    let (frames, image_of): (Vec<PoseFrame>, ImageOf) = match format {
        Format::SevenScenes => {
            let traj = sevenscenes::read(input)?;
            let keep: Option<Vec<String>> = match split {
                Split::All => None,
                Split::Train | Split::Test => {
                    let s = sevenscenes::read_split(input)?;
                    Some(if split == Split::Train {
                        s.train
                    } else {
                        s.test
                    })
                }
                Split::Val => bail!(
                    "{}: 7-Scenes has train and test splits, not val",
                    input.display()
                ),
            };
            let frames: Vec<PoseFrame> = traj
                .frames
                .into_iter()
                .filter(|f| keep.as_ref().is_none_or(|k| k.contains(&f.seq)))
                .collect();
            // A sequence folder holds its frames; a scene folder holds seq-XX folders.
            let in_seq = frames.first().is_some_and(|f| {
                input
                    .join(format!("{}{}", f.name, sevenscenes::POSE_SUFFIX))
                    .is_file()
            });
            let root = input.to_path_buf();
            (
                frames,
                Box::new(move |f: &PoseFrame| {
                    let dir = if in_seq {
                        root.clone()
                    } else {
                        root.join(&f.seq)
                    };
                    dir.join(format!("{}.color.png", f.name))
                }),
            )
        }
        Format::Cambridge => {
            if split != Split::All {
                bail!(
                    "{}: a Cambridge list is one split already; leave out --split",
                    input.display()
                );
            }
            let root = input.parent().unwrap_or(Path::new(".")).to_path_buf();
            (
                cambridge::read(input)?.frames,
                Box::new(move |f: &PoseFrame| root.join(&f.name)),
            )
        }
        _ => return Ok(None),
    };
    if frames.is_empty() {
        bail!("{}: the {split:?} split has no frames", input.display());
    }
    Ok(Some(Box::new(frames.into_iter().map(move |f| Item {
        image: frames::decode_image(&image_of(&f)).map_err(Into::into),
        name: f.name,
        seq: (!f.seq.is_empty()).then_some(f.seq),
        t: f.t,
        new_scene: false,
    }))))
}

/// A pose model localizes the camera it was trained for: a native dataset whose `dataset.toml`
/// records another mount (a ceiling camera's frames for a forward camera's model, or the other
/// way) is refused, as its poses would be decoded in the wrong frame.
fn check_mount(model: &Path, input: &Path) -> Result<()> {
    let info_path = input.join(data::native::DATASET_TOML);
    if !info_path.is_file() {
        return Ok(());
    }
    let info = data::native::DatasetInfo::read(&info_path)?;
    let coding = learn::checkpoint::ModelMeta::read(model)?.coding;
    if info.mount != coding.mount {
        bail!(
            "{}: frames of a {:?} camera, but the model in {} localizes a {:?} camera",
            info_path.display(),
            info.mount,
            model.display(),
            coding.mount
        );
    }
    Ok(())
}

/// The frames of `input`, decoded lazily: a native dataset's frames (of `split`), a 7-Scenes or
/// Cambridge collection's ([`posed_frames`]), or any frame source `data::frames` opens (image,
/// image folder, video).
fn frames_of(input: &Path, split: Split) -> Result<Box<dyn Iterator<Item = Item>>> {
    if let Some(items) = posed_frames(input, split)? {
        return Ok(items);
    }
    if input.join("dataset.toml").is_file() {
        let ds = NativeDataset::open(input)?;
        let indices: Vec<usize> = match split {
            Split::All => (0..ds.trajectory.len()).collect(),
            Split::Train => ds.split_frames(SplitName::Train),
            Split::Val => ds.split_frames(SplitName::Val),
            Split::Test => ds.split_frames(SplitName::Test),
        };
        if indices.is_empty() {
            bail!("{}: the {split:?} split has no frames", input.display());
        }
        let cuts = ds.cuts.clone().unwrap_or_default();
        let mut previous: Option<u64> = None;
        return Ok(Box::new(indices.into_iter().filter_map(move |i| {
            let frame = ds.frame_number(i)?;
            let f = &ds.trajectory.frames[i];
            let gap = previous.is_some_and(|p| p + 1 != frame);
            previous = Some(frame);
            Some(Item {
                name: f.name.clone(),
                seq: (!f.seq.is_empty()).then(|| f.seq.clone()),
                t: f.t,
                new_scene: gap || cuts.binary_search(&frame).is_ok(),
                image: frames::decode_image(&ds.frame_path(frame)).map_err(Into::into),
            })
        })));
    }
    if split != Split::All {
        bail!(
            "{}: --split needs a native dataset or 7-Scenes scene folder",
            input.display()
        );
    }
    let source: Box<dyn FrameSource + Send> = frames::open(input)?;
    Ok(Box::new(source.enumerate().map(|(i, r)| match r {
        Ok(f) => Item {
            name: f.name,
            seq: None,
            t: f.t,
            new_scene: false,
            image: Ok(image::DynamicImage::ImageRgb8(f.image)),
        },
        Err(e) => Item {
            name: format!("{i:06}"),
            seq: None,
            t: None,
            new_scene: false,
            image: Err(e.into()),
        },
    })))
}
