//! `indoorloc localize`: poses of images from a trained model, one line per frame as each is
//! done (JSON lines as DESIGN.md specifies, or TUM), so a pipe sees poses while a long input is
//! still being read.

use anyhow::{Context, Result, bail};
use clap::{Args, ValueEnum};
use data::blocks::BlockSplit;
use data::frames::{self, FrameSource};
use data::native::SplitName;
use data::posed::{self, SplitPlan};
use learn::place::{PlaceLocalizer, PlaceMeta, PlacePrediction};
use learn::seq::{SeqLocalizer, SeqMeta, SeqTracker};
use learn::{Estimate, Localizer};
use map::retrieval::RetrievalIndex;
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

/// Which frames of a posed dataset.
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
    #[arg(long, value_name = "MODEL", required_unless_present_any = ["retrieve", "map"])]
    model: Option<PathBuf>,
    /// Refine each pose against this keyframe map (`indoorloc map build`): local features
    /// matched to the keyframes retrieved and those near the coarse pose, PnP + RANSAC. Lines
    /// gain `refined`, `inliers` (and `fallback`, why the coarse pose was kept). Without
    /// --model the map alone localizes, from its own retrieval.
    #[arg(long, value_name = "MAP")]
    map: Option<PathBuf>,
    /// With --map: a refined pose farther from the coarse one than this many of its sigmas is
    /// refused (the coarse pose is kept)…
    #[arg(long, default_value_t = map::RefineConfig::default().gate_sigmas, value_name = "K")]
    gate_sigmas: f64,
    /// …but never closer than this, metres.
    #[arg(long, default_value_t = map::RefineConfig::default().gate_floor_m, value_name = "M")]
    gate_floor: f64,
    /// No network: answer each frame with the pose of the most similar frame of this posed
    /// dataset outside its test part (training and validation under --blocks or its own split; a thumbnail
    /// descriptor, see `map::retrieval`). `sigma_pos_m` / `sigma_rot_deg` are the spread of the
    /// five most similar frames.
    #[arg(long, value_name = "DATASET", conflicts_with = "model")]
    retrieve: Option<PathBuf>,
    /// An image, an image folder, a video file, or a posed dataset: a native folder, a 7-Scenes
    /// scene or sequence, a TUM RGB-D folder, a COLMAP model, a Cambridge list or scene folder,
    /// a NeRF transforms.json.
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
    #[arg(long, default_value_t = learn::DEFAULT_MC_SEED, value_name = "SEED")]
    mc_seed: u64,
    /// Output format.
    #[arg(long, value_enum, default_value_t = OutFormat::Jsonl)]
    format: OutFormat,
    /// For a posed dataset: which split's frames (the dataset's own split, else blocks of
    /// consecutive frames; see --blocks).
    #[arg(long, value_enum, default_value_t = Split::All)]
    split: Split,
    /// Split every sequence into blocks, BLOCK:EVERY[:OFFSET], as `train --blocks` did (the
    /// same value gives the same held-out frames).
    #[arg(long, value_name = "BLOCK:EVERY[:OFFSET]")]
    blocks: Option<BlockSplit>,
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
    Retrieval(RetrievalIndex),
}

/// The place and sequence models in the folder `model`, as the options ask for them; checks
/// that the model's camera mount is the input's.
fn load_models(
    args: &LocalizeArgs,
    model: &Path,
) -> Result<(Option<PlaceLocalizer>, Option<SeqLocalizer>)> {
    let places = if PlaceMeta::exists(model) {
        Some(PlaceLocalizer::load(model)?)
    } else {
        None
    };
    let place_only = places.is_some() && !model.join(learn::checkpoint::MODEL_TOML).is_file();
    if place_only && args.format == OutFormat::Tum {
        bail!(
            "{}: holds a place model only; TUM lines need poses (use --format jsonl)",
            model.display()
        );
    }
    if !place_only {
        check_mount(model, &args.input)?;
    }
    let sequence = if SeqMeta::exists(model) && !args.single && !place_only {
        Some(SeqLocalizer::load(model)?.with_seed(args.mc_seed))
    } else {
        None
    };
    Ok((places, sequence))
}

/// The retrieval index of the training part of the posed dataset at `path`.
fn retrieval_index(path: &Path, blocks: Option<BlockSplit>) -> Result<RetrievalIndex> {
    let ds = posed::open(path)?;
    let plan = blocks.map_or(SplitPlan::Auto, SplitPlan::Blocks);
    let mapped = ds.mapped(plan);
    if mapped.is_empty() {
        bail!(
            "{}: no training frames to retrieve from ({})",
            path.display(),
            ds.describe_split(plan)
        );
    }
    Ok(RetrievalIndex::of_images(&mapped)?)
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
    /// 3x3 position covariance, m², row-major: the refinement's (from its Jacobian) when
    /// refined, else the model's calibrated one (the retrieval's: `sigma_pos_m² / 3` on the
    /// diagonal).
    pub cov_pos_m2: [f64; 9],
    /// With a map: whether the pose comes from it.
    #[serde(skip_serializing_if = "Option::is_none")]
    pub refined: Option<bool>,
    /// With a map: PnP inliers.
    #[serde(skip_serializing_if = "Option::is_none")]
    pub inliers: Option<usize>,
    /// With a map: why the coarse pose was kept.
    #[serde(skip_serializing_if = "Option::is_none")]
    pub fallback: Option<String>,
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
            cov_pos_m2: std::array::from_fn(|k| est.cov_pos_m2[(k / 3, k % 3)]),
            refined: None,
            inliers: None,
            fallback: None,
        }
    }

    /// The fields of a map refinement of a coarse estimate (`None`: the map alone).
    pub fn refined(coarse: Option<&Estimate>, r: &map::Refinement) -> Self {
        let mut out = match (coarse, r.refined) {
            (Some(est), false) => PoseFields::of(est),
            _ => {
                let cov = r.cov_pos_m2.unwrap_or_else(nalgebra::Matrix3::zeros);
                let rot = r.cov_rot_rad2.unwrap_or_else(nalgebra::Matrix3::zeros);
                PoseFields {
                    position: r.pose.position(),
                    quaternion: r.pose.quat_wxyz(),
                    pose3: None,
                    sigma_pos_m: cov.trace().max(0.0).sqrt(),
                    sigma_rot_deg: rot.trace().max(0.0).sqrt().to_degrees(),
                    cov_pos_m2: std::array::from_fn(|k| cov[(k / 3, k % 3)]),
                    refined: None,
                    inliers: None,
                    fallback: None,
                }
            }
        };
        out.refined = Some(r.refined);
        out.inliers = Some(r.inliers);
        out.fallback = r.fallback.as_ref().map(ToString::to_string);
        out
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
    let (places, sequence) = match (&args.retrieve, &args.model) {
        (None, Some(model)) => load_models(args, model)?,
        (None, None) if args.map.is_none() => {
            bail!("give --model MODEL, --retrieve DATASET or --map MAP")
        }
        _ => (None, None),
    };
    let keyframe_map = args.map.as_deref().map(map::file::load).transpose()?;
    if !(args.gate_sigmas > 0.0 && args.gate_floor >= 0.0) {
        bail!("--gate-sigmas must be > 0 and --gate-floor ≥ 0");
    }
    let refine_cfg = map::RefineConfig {
        gate_sigmas: args.gate_sigmas,
        gate_floor_m: args.gate_floor,
        ..map::RefineConfig::default()
    };
    let mut estimator = match &args.retrieve {
        Some(path) => Some(Estimator::Retrieval(retrieval_index(path, args.blocks)?)),
        None => None,
    };
    let place_only = places.is_some()
        && args
            .model
            .as_ref()
            .is_some_and(|m| !m.join(learn::checkpoint::MODEL_TOML).is_file());
    if estimator.is_none() {
        estimator = match &sequence {
            Some(seq) => Some(Estimator::Sequence(seq, seq.tracker(args.mc))),
            None if place_only => None,
            None => args
                .model
                .as_ref()
                .map(|m| -> Result<Estimator<'_>> {
                    Ok(Estimator::Single(
                        Localizer::load(m)?
                            .with_tta(args.tta)
                            .with_seed(args.mc_seed),
                    ))
                })
                .transpose()?,
        };
    }
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
    let items = frames_of(&args.input, args.split, args.blocks)?;
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
            Some(Estimator::Retrieval(index)) => Some(
                index
                    .localize(&img)
                    .map(|r| Estimate {
                        pose: r.pose,
                        pose3: None,
                        sigma_pos_m: r.sigma_pos_m,
                        cov_pos_m2: nalgebra::Matrix3::identity() * (r.sigma_pos_m.powi(2) / 3.0),
                        sigma_rot_deg: r.sigma_rot_deg,
                        passes: 0,
                    })
                    .map_err(|e| learn::LearnError::Input(e.to_string())),
            ),
        }
        .transpose()
        .with_context(|| format!("frame {}", item.name))?;
        let pose = match &keyframe_map {
            Some(km) => {
                let coarse = est.as_ref().map(|e| map::Coarse {
                    pose: e.pose,
                    sigma_pos_m: e.sigma_pos_m,
                });
                let r = km
                    .refine(&img, coarse.as_ref(), &refine_cfg)
                    .with_context(|| {
                        let map = args.map.as_deref().unwrap_or(Path::new("")).display();
                        format!("frame {} against {map}", item.name)
                    })?;
                Some(PoseFields::refined(est.as_ref(), &r))
            }
            None => est.as_ref().map(PoseFields::of),
        };
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
            pose,
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

/// The frames of `input`, decoded lazily: a posed dataset's frames (of `split`, from
/// [`data::posed::open`] in any layout it reads), or any frame source `data::frames` opens
/// (image, image folder, video). A dataset's new sequences, gaps in its frames (frames of
/// another split between) and its own cuts start a new scene. Frames keep the reader's names
/// and sequences, so `eval` pairs the output with the same poses.
fn frames_of(
    input: &Path,
    split: Split,
    blocks: Option<BlockSplit>,
) -> Result<Box<dyn Iterator<Item = Item>>> {
    if posed::is_dataset(input) {
        let ds = posed::open(input)?;
        let plan = blocks.map_or(SplitPlan::Auto, SplitPlan::Blocks);
        let parts = ds.parts(plan);
        let want = match split {
            Split::All => None,
            Split::Train => Some(SplitName::Train),
            Split::Val => Some(SplitName::Val),
            Split::Test => Some(SplitName::Test),
        };
        let indices: Vec<usize> = (0..ds.images.len())
            .filter(|&i| want.is_none_or(|w| parts[i] == Some(w)))
            .collect();
        if indices.is_empty() {
            bail!(
                "{}: the {split:?} split has no frames ({})",
                input.display(),
                ds.describe_split(plan)
            );
        }
        let mut previous: Option<usize> = None;
        return Ok(Box::new(indices.into_iter().map(move |i| {
            let img = &ds.images[i];
            let new_seq = i > 0 && ds.images[i - 1].frame.seq != img.frame.seq;
            let gap = previous.is_some_and(|p| p + 1 != i);
            previous = Some(i);
            let f = &img.frame;
            Item {
                name: f.name.clone(),
                seq: (!f.seq.is_empty()).then(|| f.seq.clone()),
                t: f.t,
                new_scene: gap || new_seq || ds.cuts.binary_search(&i).is_ok(),
                image: frames::decode_image(&img.image).map_err(Into::into),
            }
        })));
    }
    if split != Split::All || blocks.is_some() {
        bail!(
            "{}: --split and --blocks need a posed dataset (native, 7-Scenes, TUM, COLMAP, \
             Cambridge, NeRF)",
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
