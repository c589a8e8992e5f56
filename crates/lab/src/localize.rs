//! `indoorloc localize`: poses of images from a trained model, one line per frame as each is
//! done (JSON lines as DESIGN.md specifies, or TUM), so a pipe sees poses while a long input is
//! still being read.

use crate::{Result, bail};
use clap::{Args, ValueEnum};
use data::blocks::BlockSplit;
use data::posed::{self, SplitPlan};
use learn::Localizer;
use learn::place::{PlaceLocalizer, PlaceMeta, PlacePrediction};
use learn::seq::{SeqLocalizer, SeqMeta};
use map::retrieval::RetrievalIndex;
use serde::Serialize;
use std::io::Write;
use std::path::{Path, PathBuf};
use track::{
    Estimation, Estimator, MapEstimator, NetworkEstimator, Recorded, RetrievalEstimator,
    SequenceEstimator, Stages,
};

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

impl From<Split> for track::Split {
    fn from(s: Split) -> track::Split {
        match s {
            Split::All => track::Split::All,
            Split::Train => track::Split::Train,
            Split::Val => track::Split::Val,
            Split::Test => track::Split::Test,
        }
    }
}

/// Arguments of `indoorloc localize`.
#[derive(Args, Debug)]
pub struct LocalizeConfig {
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
    /// With --map: match the K keyframes retrieval finds most similar each with its two
    /// nearest, solve each group alone and keep the best, instead of pooling the three most
    /// similar (for a map whose images look unlike the frames, e.g. renders of a scan against
    /// photos: twice the matching time).
    #[arg(long, value_name = "K")]
    map_groups: Option<usize>,
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

/// The place and sequence models in the folder `model`, as the options ask for them; checks
/// that the model's camera mount is the input's.
fn load_models(
    args: &LocalizeConfig,
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
    /// The fields of a frame's last estimate: the estimator's own figures where it states
    /// them (a network's sigmas and 3-DoF pose), else those of its covariance; with a map, its
    /// note on the frame.
    pub fn of(e: &Estimation) -> Self {
        let (pose3, sigma_pos_m, sigma_rot_deg) = match e.stated {
            Some(s) => (s.pose3, s.sigma_pos_m, s.sigma_rot_deg),
            None => (None, e.sigma_pos_m(), e.sigma_rot_rad.to_degrees()),
        };
        let note = e.refinement.as_ref();
        PoseFields {
            position: e.pose.position(),
            quaternion: e.pose.quat_wxyz(),
            pose3: pose3.map(|p| [p.x, p.y, p.heading]),
            sigma_pos_m,
            sigma_rot_deg,
            cov_pos_m2: std::array::from_fn(|k| e.cov_pos_m2[(k / 3, k % 3)]),
            refined: note.map(|n| n.refined),
            inliers: note.map(|n| n.inliers),
            fallback: note.and_then(|n| n.fallback.clone()),
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

/// Runs `indoorloc localize`: the frames through [`track::Recorded`] with the estimators the
/// options name (network or sequence model, or retrieval; then the map), no filter, and the
/// place model along the walk.
pub fn run(args: &LocalizeConfig, sink: &mut dyn crate::Output) -> Result<()> {
    let (places, sequence) = match (&args.retrieve, &args.model) {
        (None, Some(model)) => load_models(args, model)?,
        (None, None) if args.map.is_none() => {
            bail!("give --model MODEL, --retrieve DATASET or --map MAP")
        }
        _ => (None, None),
    };
    if !(args.gate_sigmas > 0.0 && args.gate_floor >= 0.0) {
        bail!("--gate-sigmas must be > 0 and --gate-floor ≥ 0");
    }
    if args.place_lag.is_nan() || args.place_lag < 0.0 {
        bail!("--place-lag {}: must be 0 or more seconds", args.place_lag);
    }
    let place_only = places.is_some()
        && args
            .model
            .as_ref()
            .is_some_and(|m| !m.join(learn::checkpoint::MODEL_TOML).is_file());
    let mut estimators: Vec<Box<dyn Estimator + Send + '_>> = Vec::new();
    match (&args.retrieve, &sequence, &args.model) {
        (Some(path), _, _) => estimators.push(Box::new(RetrievalEstimator::new(retrieval_index(
            path,
            args.blocks,
        )?))),
        (None, Some(seq), _) => estimators.push(Box::new(SequenceEstimator::new(seq, args.mc))),
        (None, None, Some(model)) if !place_only => {
            estimators.push(Box::new(NetworkEstimator::from_localizer(
                Localizer::load(model)?
                    .with_tta(args.tta)
                    .with_seed(args.mc_seed),
                args.mc,
            )))
        }
        _ => {}
    }
    if let Some(path) = &args.map {
        let refine = map::RefineConfig {
            gate_sigmas: args.gate_sigmas,
            gate_floor_m: args.gate_floor,
            ..args
                .map_groups
                .map_or_else(map::RefineConfig::default, map::RefineConfig::grouped)
        };
        let mut map = MapEstimator::new(map::file::load(path)?, refine).named(path);
        if estimators.is_empty() {
            map = map.alone();
        }
        estimators.push(Box::new(map));
    }
    let mut recorded = Recorded::new(Stages::new(estimators, None, false));
    if let Some(loc) = &places {
        // A place model follows the walk unless each frame is to stand alone.
        recorded = recorded.with_places(loc, (!args.single).then_some(args.place_lag));
    }
    if let Some(path) = &args.cuts {
        recorded = recorded.with_cuts(data::cuts::read(path)?.into_iter().collect());
    }
    if !posed::is_dataset(&args.input) && (args.split != Split::All || args.blocks.is_some()) {
        bail!(
            "{}: --split and --blocks need a posed dataset (native, 7-Scenes, TUM, COLMAP, \
             Cambridge, NeRF)",
            args.input.display()
        );
    }
    let frames = track::frames(&args.input, args.split.into(), args.blocks)?.inspect(|f| {
        if let Err(e) = &f.image {
            crate::progress::note(&format!("indoorloc: skipped: {}", crate::error::chain(e)));
        }
    });
    let mut buffer = Vec::new();
    let w: &mut dyn Write = if args.out.is_some() {
        &mut buffer
    } else {
        sink.stream()
    };
    let summary = recorded.run(frames, |out| -> Result<()> {
        let line = PoseLine {
            frame: out.name,
            seq: out.seq,
            t: out.t,
            pose: out.processed.last().map(PoseFields::of),
            place: out.place.as_ref().map(PlaceField::of),
            latency_ms: out.latency_ms,
        };
        line.write(args.format, out.index, w)
    })?;
    if let Some(path) = &args.out {
        data::io::write_atomic(path, |f| f.write_all(&buffer))?;
    }
    if let Some(first) = summary.unreadable.first() {
        bail!(
            "{}: {} of {} frames could not be read (first: {first}); the others were localised",
            args.input.display(),
            summary.unreadable.len(),
            summary.unreadable.len() + summary.done,
        );
    }
    Ok(())
}

/// A pose model localizes the camera it was trained for: a native dataset whose `dataset.toml`
/// records another mount (a ceiling camera's frames for a forward camera's model, or the other
/// way) is refused, as its poses would be decoded in the wrong frame.
fn check_mount(model: &Path, input: &Path) -> Result<()> {
    let Some(info) = data::native::DatasetInfo::of(input)? else {
        return Ok(());
    };
    let info_path = input.join(data::native::DATASET_TOML);
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
