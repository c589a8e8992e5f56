//! `indoorloc train`: trains a pose-regression network on a posed dataset, with a checkpoint
//! every epoch (`--resume` continues from it).

use crate::output::{print_json, print_text};
use crate::progress::TrainingDisplay;
use crate::{Context, Result};
use clap::{Args, ValueEnum};
use learn::calibrate::ValidationPasses;
use learn::place::{PlaceConfig, PlaceEpoch, PlaceLoaded};
use learn::seq::{SeqConfig, SeqEpoch, SeqFeatures, SeqSummary};
use learn::{Arch, EpochMetrics, Loaded, OptimizerKind, Schedule, Task, TrainConfig, TrainSummary};
use serde::Serialize;
use std::path::PathBuf;
use std::time::Instant;

/// What `train` learns.
#[derive(Clone, Copy, Debug, PartialEq, Eq, ValueEnum)]
pub enum TaskArg {
    /// 6-DoF pose.
    Pose6,
    /// 3-DoF pose of a ceiling camera.
    Pose3,
    /// Place classes.
    Place,
}

impl TaskArg {
    /// The pose task, `None` for places.
    fn pose(self) -> Option<Task> {
        match self {
            TaskArg::Pose6 => Some(Task::Pose6),
            TaskArg::Pose3 => Some(Task::Pose3),
            TaskArg::Place => None,
        }
    }
}

/// Arguments of `indoorloc train`.
#[derive(Args, Debug)]
pub struct TrainCommand {
    /// Posed images in any layout `data` opens: a native folder (train / val by sequence from
    /// its splits.toml), a 7-Scenes scene or sequence, a TUM RGB-D folder, a COLMAP model, a
    /// Cambridge scene, a NeRF transforms.json.
    #[arg(long, value_name = "DATASET")]
    data: PathBuf,
    /// Split every sequence into blocks of consecutive frames, BLOCK:EVERY[:OFFSET] (100:5: the
    /// last block of every five held out for testing, validation blocks cut from the rest the
    /// same way); default: the dataset's own split, else 100:5 for recordings without one.
    /// Pass the same value to `localize --blocks` to localize the held-out frames.
    #[arg(long, value_name = "BLOCK:EVERY[:OFFSET]")]
    blocks: Option<data::blocks::BlockSplit>,
    /// Checkpoint folder (model.toml, model.bpk, training state).
    #[arg(long, value_name = "MODEL")]
    out: PathBuf,
    /// pose6 (position + quaternion), pose3 (x, y, heading of a ceiling camera), or place
    /// (building, floor, corridor and direction classifier from labels.csv, written as
    /// place.toml / place.bpk); default: pose from the dataset's dof.
    #[arg(long, value_enum)]
    task: Option<TaskArg>,
    /// For --task place: validation frames by recording session (sequence) or drawn at random
    /// from all frames (leaky: near-twins of validation frames are in training).
    #[arg(long, default_value = "session", value_parser = ["session", "random"])]
    place_split: String,
    /// For --task place: average the last feature map to a GRID x GRID grid before the heads
    /// (1: global average pooling; 2 keeps the view's layout, which tells a corridor's two
    /// directions apart more often).
    #[arg(long, default_value_t = 2, value_name = "GRID")]
    place_grid: usize,
    /// Backbone: small (fast), resnet18, resnet34, googlenet (GoogLeNet + BatchNorm up to its
    /// first auxiliary classifier, as ceiling-camera work uses) or mobilenetv2 (ImageNet
    /// weights, frozen; fetch them once with `indoorloc weights fetch`). Default: the
    /// real-photo recipe (mobilenetv2, 150 epochs) for a 6-DoF pose network on real photos (a
    /// 7-Scenes, TUM, COLMAP, Cambridge or NeRF dataset) when the weights are there, else small.
    #[arg(long)]
    arch: Option<Arch>,
    /// Input view: a preset (gray160, rgb256, ...) or spec text; default gray160 for pose3,
    /// rgb256 for pose6.
    #[arg(long)]
    view: Option<String>,
    /// Epochs to reach (a resumed run continues up to this number); default 30, 150 with the
    /// real-photo recipe.
    #[arg(long)]
    epochs: Option<usize>,
    /// Images per step.
    #[arg(long, default_value_t = 32)]
    batch: usize,
    /// Cap on optimisation steps per epoch.
    #[arg(long)]
    steps_per_epoch: Option<usize>,
    /// Base learning rate (cosine decay to 1 % of it).
    #[arg(long, default_value_t = 1e-3)]
    lr: f64,
    /// Adam with AMSGrad instead of AdamW.
    #[arg(long)]
    amsgrad: bool,
    /// Weight decay.
    #[arg(long, default_value_t = 1e-4)]
    weight_decay: f64,
    /// β of the loss: metres per unit of quaternion (or heading) distance.
    #[arg(long, default_value_t = 10.0)]
    beta: f64,
    /// Learn the weighting of position and rotation loss (homoscedastic uncertainty) instead of β.
    #[arg(long)]
    learned_weighting: bool,
    /// Dropout on the pooled features and the hidden layer (also the MC-dropout rate at
    /// inference).
    #[arg(long, default_value_t = 0.2)]
    dropout: f64,
    /// Width of a hidden layer in the head (0: one linear layer, as torch_apr.py).
    #[arg(long, default_value_t = 1024)]
    hidden: usize,
    /// Also predict each image's position-error scale (aleatoric uncertainty, trained by its
    /// likelihood); it adds to sigma_pos_m at inference. Default: true, unless
    /// --learned-weighting is given (the two weigh the position term in different ways).
    #[arg(long, action = clap::ArgAction::Set, value_name = "BOOL")]
    aleatoric: Option<bool>,
    /// Two networks of the chosen backbone: one for the position, one for the rotation
    /// (heading), as the ceiling-camera literature does. Twice the cost.
    #[arg(long)]
    split: bool,
    /// Jitter the training views on the loader thread: contrast, brightness, noise and
    /// occluding rectangles (photometric only, so every pose label stays true).
    #[arg(long)]
    augment: bool,
    /// Shape-biased training: restyle half the training views (random tone curves, inversion,
    /// material texture, coloured light; edges kept) so the network learns shape, not paint.
    #[arg(long)]
    shape_bias: bool,
    /// Place classifier only: zoom (±10 %) and shift (±8 %) each training view a little, as if
    /// the camera stood a step nearer or had turned a few degrees; a pose label would no longer
    /// be true, a place label is.
    #[arg(long)]
    reframe: bool,
    /// Train a dominant-plane branch beside the pose (classes, plane parameters and the depth
    /// they induce); needs `depth/` for every frame, and uses `planes/` when there (else the
    /// planes are found in the depth by RANSAC).
    #[arg(long)]
    planes: bool,
    /// Stop after this many epochs without a better validation median position error; default
    /// 10, none with the real-photo recipe (the best epoch is still the one kept).
    #[arg(long)]
    patience: Option<usize>,
    /// Seed of initialisation, shuffling, augmentation and dropout.
    #[arg(long, default_value_t = 0)]
    seed: u64,
    /// Also train a sequence model (CNN+LSTM) over windows of K consecutive frames (20 when
    /// K is left out), on the features of the single-frame network (trained first, or reused
    /// with --resume); written beside it (seq.toml, seq.bpk), and used by `localize` on
    /// recordings.
    #[arg(long, value_name = "K", num_args = 0..=1, default_missing_value = "20")]
    window: Option<usize>,
    /// Dataset the sequence model trains on (default: --data): recordings of the same place
    /// and camera at the frame rate the model will run at, when --data's training walks are
    /// sparser (an LSTM learns the motion between frames; training and validation recordings
    /// that move more than 3x apart per frame are refused).
    #[arg(long, value_name = "DIR", requires = "window")]
    seq_data: Option<PathBuf>,
    /// LSTM units of the sequence model.
    #[arg(long, default_value_t = 256)]
    lstm_units: usize,
    /// Epochs of the sequence model.
    #[arg(long, default_value_t = 10)]
    seq_epochs: usize,
    /// β of the sequence model's loss (default: --beta).
    #[arg(long)]
    seq_beta: Option<f64>,
    /// Continue from the checkpoint in --out.
    #[arg(long, conflicts_with = "force")]
    resume: bool,
    /// Replace the model --out holds (without --resume or --force, a folder holding one is
    /// refused).
    #[arg(long)]
    force: bool,
    /// Print one JSON document instead of a table.
    #[arg(long)]
    json: bool,
}

impl TrainCommand {
    /// The library configuration these arguments describe.
    pub fn config(&self) -> TrainConfig {
        let task = self.task.and_then(TaskArg::pose);
        let real = self.arch.is_none() && task != Some(Task::Pose3) && is_real_photos(&self.data);
        let mut cfg = if real {
            TrainConfig::for_real_photos(&self.data, &self.out)
        } else {
            TrainConfig::new(&self.data, &self.out)
        };
        cfg.task = task;
        if let Some(arch) = self.arch {
            cfg.arch = arch;
        }
        cfg.view = self.view.clone();
        if let Some(epochs) = self.epochs {
            cfg.epochs = epochs;
        }
        cfg.batch_size = self.batch;
        cfg.max_steps_per_epoch = self.steps_per_epoch;
        cfg.lr = self.lr;
        cfg.schedule = Schedule::Cosine {
            final_fraction: 0.01,
        };
        cfg.optimizer = if self.amsgrad {
            OptimizerKind::Amsgrad
        } else {
            OptimizerKind::AdamW
        };
        cfg.weight_decay = self.weight_decay;
        cfg.beta = self.beta;
        cfg.learned_weighting = self.learned_weighting;
        cfg.dropout = self.dropout;
        cfg.hidden = self.hidden;
        cfg.aleatoric = self.aleatoric.unwrap_or(!self.learned_weighting);
        cfg.split = self.split;
        cfg.augment = self.augment;
        cfg.shape_bias = self.shape_bias;
        cfg.planes = self.planes;
        cfg.blocks = self.blocks;
        if self.patience.is_some() {
            cfg.patience = self.patience;
        }
        cfg.seed = self.seed;
        cfg.resume = self.resume;
        cfg.force = self.force;
        cfg
    }

    /// The sequence model's configuration, when --window asks for one.
    pub fn seq_config(&self) -> Option<SeqConfig> {
        let window = self.window?;
        let mut cfg = SeqConfig::new(self.seq_data.as_ref().unwrap_or(&self.data), &self.out);
        cfg.window = window;
        cfg.hidden = self.lstm_units;
        cfg.epochs = self.seq_epochs;
        cfg.beta = Some(self.seq_beta.unwrap_or(self.beta));
        cfg.dropout = Some(self.dropout);
        cfg.patience = Some(self.patience.unwrap_or(DEFAULT_PATIENCE));
        cfg.seed = self.seed;
        cfg.resume = self.resume;
        cfg.force = self.force;
        Some(cfg)
    }
}

/// Epochs of a network outside the real-photo recipe.
const DEFAULT_EPOCHS: usize = 30;

/// Patience outside the real-photo recipe.
const DEFAULT_PATIENCE: usize = 10;

/// Whether `path` is a dataset of real photos: a posed layout other than indoorloc's own
/// (whose folders the renderer writes).
fn is_real_photos(path: &std::path::Path) -> bool {
    data::posed::is_dataset(path)
        && data::posed::open(path).is_ok_and(|ds| ds.layout != data::posed::Layout::Native)
}

/// The `--json` document.
#[derive(Debug, Serialize)]
struct TrainOutput {
    out: PathBuf,
    epochs: usize,
    best_epoch: usize,
    val_median_pos_m: f64,
    val_median_rot_deg: f64,
    stopped_early: bool,
    train_frames: usize,
    val_frames: usize,
    /// The sequence model, with --window.
    #[serde(skip_serializing_if = "Option::is_none")]
    sequence: Option<SeqOutput>,
    seconds: f64,
}

/// The sequence part of the `--json` document.
#[derive(Debug, Serialize)]
struct SeqOutput {
    window: usize,
    windows: usize,
    epochs: usize,
    best_epoch: usize,
    val_median_pos_m: f64,
    val_median_rot_deg: f64,
}

/// The place classifier's configuration these arguments describe.
pub fn place_config(args: &TrainCommand) -> Result<PlaceConfig> {
    crate::ensure!(
        !args.planes,
        "--planes trains a pose network's plane branch; a place classifier takes --augment and --shape-bias"
    );
    crate::ensure!(
        !args.arch.is_some_and(Arch::pretrained),
        "a place classifier trains its whole backbone; a frozen pretrained one is for pose networks"
    );
    let mut cfg = PlaceConfig::new(&args.data, &args.out);
    cfg.arch = args.arch.unwrap_or(Arch::Small);
    cfg.view = args.view.clone();
    cfg.epochs = args.epochs.unwrap_or(DEFAULT_EPOCHS);
    cfg.batch_size = args.batch;
    cfg.lr = args.lr;
    cfg.weight_decay = args.weight_decay;
    cfg.dropout = args.dropout;
    cfg.split = args.place_split.parse()?;
    cfg.augment = args.augment;
    cfg.shape_bias = args.shape_bias;
    cfg.reframe = args.reframe;
    cfg.grid = args.place_grid;
    cfg.patience = Some(args.patience.unwrap_or(DEFAULT_PATIENCE));
    cfg.seed = args.seed;
    cfg.resume = args.resume;
    cfg.force = args.force;
    Ok(cfg)
}

/// The `--json` document of `train --task place`.
#[derive(Debug, Serialize)]
struct PlaceOutput {
    out: PathBuf,
    epochs: usize,
    best_epoch: usize,
    split: String,
    val_accuracy: PlaceAccuracy,
    train_frames: usize,
    val_frames: usize,
    seconds: f64,
}

/// Accuracy per level.
#[derive(Debug, Serialize)]
pub struct PlaceAccuracy {
    /// Building.
    pub building: f64,
    /// Floor.
    pub floor: f64,
    /// Corridor and direction.
    pub corridor: f64,
}

impl From<[f64; 3]> for PlaceAccuracy {
    fn from([building, floor, corridor]: [f64; 3]) -> Self {
        PlaceAccuracy {
            building,
            floor,
            corridor,
        }
    }
}

/// Runs `indoorloc train --task place`.
fn run_place(args: &TrainCommand, sink: &mut dyn crate::Output) -> Result<()> {
    crate::ensure!(
        args.window.is_none(),
        "--window trains a sequence model of poses; a place classifier takes single frames"
    );
    let start = Instant::now();
    let cfg = place_config(args)?;
    let display = TrainingDisplay {
        lines: !args.json,
        prefix: "",
        loaded: &|l: &PlaceLoaded| {
            format!(
                "data: {} train / {} val frames, classes {:?} (building, floor, place), {:.1} s",
                l.train, l.val, l.classes, l.seconds
            )
        },
        epoch: &|m: &PlaceEpoch| {
            let [b, f, c] = m.val_accuracy.map(|a| 100.0 * a);
            format!(
                "epoch {:>3}  loss {:.4}  val accuracy building {b:.1} %  floor {f:.1} %  place {c:.1} %  {:.1} s",
                m.epoch, m.train_loss, m.seconds
            )
        },
    };
    let summary = display.run(|progress| learn::place::train_place(&cfg, progress));
    let summary = summary?;
    let out = PlaceOutput {
        out: summary.out.clone(),
        epochs: summary.epochs,
        best_epoch: summary.best_epoch,
        split: args.place_split.clone(),
        val_accuracy: summary.val_accuracy.into(),
        train_frames: summary.train_frames,
        val_frames: summary.val_frames,
        seconds: start.elapsed().as_secs_f64(),
    };
    if args.json {
        print_json(sink, &out)
    } else {
        let a = &out.val_accuracy;
        print_text(
            sink,
            &format!(
                "model     {}\nepochs    {} (best {})\nval       building {:.1} %, floor {:.1} %, place {:.1} % ({} split)\nframes    {} train, {} val\ntime      {:.1} s\n",
                out.out.display(),
                out.epochs,
                out.best_epoch,
                100.0 * a.building,
                100.0 * a.floor,
                100.0 * a.corridor,
                out.split,
                out.train_frames,
                out.val_frames,
                out.seconds
            ),
        )
    }
}

/// Runs `indoorloc train`.
pub fn run(args: &TrainCommand, sink: &mut dyn crate::Output) -> Result<()> {
    if args.task == Some(TaskArg::Place) {
        return run_place(args, sink);
    }
    crate::ensure!(
        !args.reframe,
        "--reframe is for a place classifier (--task place): a zoomed or shifted view no longer \
         shows the pose of its label"
    );
    let start = Instant::now();
    let summary = train_with_progress(&args.config(), !args.json)?;
    let sequence = match args.seq_config() {
        Some(cfg) => {
            let seq = train_sequence_with_progress(&cfg, !args.json)?;
            Some(SeqOutput {
                window: cfg.window,
                windows: seq.windows,
                epochs: seq.epochs,
                best_epoch: seq.best_epoch,
                val_median_pos_m: seq.val_median_pos_m,
                val_median_rot_deg: seq.val_median_rot_deg,
            })
        }
        None => None,
    };
    let out = TrainOutput {
        out: summary.out.clone(),
        epochs: summary.epochs,
        best_epoch: summary.best_epoch,
        val_median_pos_m: summary.val_median_pos_m,
        val_median_rot_deg: summary.val_median_rot_deg,
        stopped_early: summary.stopped_early,
        train_frames: summary.train_frames,
        val_frames: summary.val_frames,
        sequence,
        seconds: start.elapsed().as_secs_f64(),
    };
    if args.json {
        print_json(sink, &out)
    } else {
        let seq = out.sequence.as_ref().map_or(String::new(), |s| {
            format!(
                "sequence  window {}, {} windows, epochs {} (best {}), val median {:.3} m, {:.2}°\n",
                s.window, s.windows, s.epochs, s.best_epoch, s.val_median_pos_m, s.val_median_rot_deg
            )
        });
        print_text(
            sink,
            &format!(
                "model     {}\nepochs    {} (best {}{})\nval       median {:.3} m, {:.2}°\nframes    {} train, {} val\n{seq}time      {:.1} s\n",
                out.out.display(),
                out.epochs,
                out.best_epoch,
                if out.stopped_early {
                    ", stopped early"
                } else {
                    ""
                },
                out.val_median_pos_m,
                out.val_median_rot_deg,
                out.train_frames,
                out.val_frames,
                out.seconds
            ),
        )
    }
}

/// Trains with a progress bar per epoch and one line per finished epoch on stderr (`lines`:
/// also when stderr is not a terminal, for logs).
pub fn train_with_progress(cfg: &TrainConfig, lines: bool) -> Result<TrainSummary> {
    let display = TrainingDisplay {
        lines,
        prefix: "",
        loaded: &|l: &Loaded| {
            let [c, h, w] = l.input;
            format!(
                "data: {} train / {} val frames, input {c}x{h}x{w}, loaded in {:.1} s",
                l.train, l.val, l.seconds
            )
        },
        epoch: &|m: &EpochMetrics| {
            format!(
                "epoch {:>3}  loss {:.4}  train {:.3} m  val median {:.3} m {:.2}°{}  lr {:.2e}  {:.1} s",
                m.epoch,
                m.train_loss,
                m.train_pos_m,
                m.val_median_pos_m,
                m.val_median_rot_deg,
                m.val_plane_accuracy
                    .map_or(String::new(), |a| format!("  planes {:.1} %", 100.0 * a)),
                m.lr,
                m.seconds
            )
        },
    };
    let summary = display.run(|progress| learn::train(cfg, progress))?;
    calibrate_fused(cfg, summary.validation.as_ref())?;
    Ok(summary)
}

/// Fits the fused track's calibration for the model `cfg` trained ([`track::calibrate`]) when it
/// has a network calibration and no fused one: the validation walk through the temporal filter,
/// from the network calibration's own passes (`validation`) when this run made them (a
/// fraction of a second), else localized again (a model resumed from before the fused
/// calibration existed).
fn calibrate_fused(cfg: &TrainConfig, validation: Option<&ValidationPasses>) -> Result<()> {
    let meta = learn::checkpoint::ModelMeta::read(&cfg.out)?;
    if meta.uncertainty.is_some_and(|u| u.fused.is_none()) {
        let plan = cfg
            .blocks
            .map_or(data::posed::SplitPlan::Auto, data::posed::SplitPlan::Blocks);
        track::calibrate::calibrate_model(&cfg.out, &cfg.data, plan, validation)
            .with_context(|| format!("calibrating the fused track of {}", cfg.out.display()))?;
    }
    Ok(())
}

/// Trains the sequence part with a progress bar per epoch and one line per finished epoch on
/// stderr (`lines`: also when stderr is not a terminal).
pub fn train_sequence_with_progress(cfg: &SeqConfig, lines: bool) -> Result<SeqSummary> {
    let display = TrainingDisplay {
        lines,
        prefix: "lstm ",
        loaded: &|f: &SeqFeatures| {
            format!(
                "sequence: {} train / {} val frames, {} windows of {}, {} feature copies, {:.1} s",
                f.train, f.val, f.windows, cfg.window, f.copies, f.seconds
            )
        },
        epoch: &|m: &SeqEpoch| {
            format!(
                "lstm epoch {:>3}  loss {:.4}  val median {:.3} m {:.2}°  jitter {:.3} m  {:.1} s",
                m.epoch,
                m.train_loss,
                m.val_median_pos_m,
                m.val_median_rot_deg,
                m.val_jitter_m,
                m.seconds
            )
        },
    };
    Ok(display.run(|progress| learn::seq::train_sequence(cfg, progress))?)
}

#[cfg(test)]
mod tests {
    use super::*;
    use clap::Parser;

    #[derive(Parser)]
    struct Wrap {
        #[command(flatten)]
        train: TrainCommand,
    }

    fn parse(extra: &[&str]) -> TrainCommand {
        let mut argv = vec!["train", "--data", "d", "--out", "m"];
        argv.extend_from_slice(extra);
        Wrap::parse_from(argv).train
    }

    #[test]
    fn window_alone_means_twenty_frames_and_the_sequence_shares_beta_and_dropout() {
        assert!(parse(&[]).seq_config().is_none());
        let cfg = parse(&["--window"]).seq_config();
        assert_eq!(cfg.as_ref().map(|c| c.window), Some(20));
        let cfg = parse(&["--window", "4", "--beta", "600", "--dropout", "0.3"]).seq_config();
        let cfg = cfg.as_ref();
        assert_eq!(
            cfg.map(|c| (c.window, c.beta, c.dropout)),
            Some((4, Some(600.0), Some(0.3)))
        );
        let cfg = parse(&["--window", "4", "--seq-beta", "50"]).seq_config();
        assert_eq!(cfg.and_then(|c| c.beta), Some(50.0));
        // the sequence part's own recordings, or the network's
        let own = parse(&["--window", "--seq-data", "walks"]).seq_config();
        assert_eq!(own.map(|c| c.data), Some(PathBuf::from("walks")));
        let same = parse(&["--window"]).seq_config();
        assert_eq!(same.map(|c| c.data), Some(PathBuf::from("d")));
    }

    #[test]
    fn reframing_is_for_places_only() {
        let place = place_config(&parse(&["--task", "place", "--reframe"])).unwrap();
        assert!(place.reframe);
        assert!(!place_config(&parse(&["--task", "place"])).unwrap().reframe);
        let err = run(&parse(&["--reframe"]), &mut crate::Collected::default()).unwrap_err();
        assert!(
            err.to_string().contains("--reframe is for a place"),
            "{err}"
        );
    }
}
