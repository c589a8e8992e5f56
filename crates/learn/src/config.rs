//! What a training run is told: [`TrainConfig`] (kept in `model.toml`, so that a resumed run
//! can be checked against it), its optimizer and learning-rate schedule, and the rule that
//! picks the epoch a checkpoint keeps ([`validation_score`]).

use std::path::PathBuf;

use serde::{Deserialize, Serialize};

use crate::head::Task;
use crate::net::Arch;
use crate::{LearnError, Result};

/// The optimizer.
#[derive(Clone, Copy, Debug, PartialEq, Eq, Serialize, Deserialize)]
#[serde(rename_all = "lowercase")]
pub enum OptimizerKind {
    /// AdamW (decoupled weight decay).
    AdamW,
    /// Adam with AMSGrad (weight decay as an L2 penalty), as in the ceiling-camera literature.
    Amsgrad,
}

/// The learning-rate schedule over the whole run.
#[derive(Clone, Copy, Debug, PartialEq, Serialize, Deserialize)]
#[serde(rename_all = "lowercase")]
pub enum Schedule {
    /// The base rate throughout.
    Constant,
    /// Cosine decay from the base rate to `final_fraction` of it at the last step.
    Cosine {
        /// Final rate as a fraction of the base rate.
        final_fraction: f64,
    },
    /// Multiply by `gamma` every `every_epochs` epochs.
    Step {
        /// Epochs between decays.
        every_epochs: usize,
        /// Decay factor.
        gamma: f64,
    },
}

impl Schedule {
    /// Checks the schedule's parameters.
    pub fn validate(&self) -> Result<()> {
        let bad = |m: String| Err(LearnError::Config(m));
        match *self {
            Schedule::Cosine { final_fraction } if !(0.0..=1.0).contains(&final_fraction) => bad(
                format!("cosine final fraction {final_fraction} must be in [0, 1]"),
            ),
            Schedule::Step {
                every_epochs,
                gamma,
            } if every_epochs == 0 || !(gamma.is_finite() && gamma > 0.0) => {
                bad("step schedule needs every_epochs >= 1 and gamma > 0".into())
            }
            _ => Ok(()),
        }
    }

    /// The rate at `step` of `total` steps (`steps_per_epoch` of them per epoch).
    pub fn lr(&self, base: f64, step: usize, total: usize, steps_per_epoch: usize) -> f64 {
        match *self {
            Schedule::Constant => base,
            Schedule::Cosine { final_fraction } => {
                let t = if total > 1 {
                    step as f64 / (total - 1) as f64
                } else {
                    0.0
                };
                let lo = base * final_fraction;
                lo + 0.5 * (base - lo) * (1.0 + (std::f64::consts::PI * t.min(1.0)).cos())
            }
            Schedule::Step {
                every_epochs,
                gamma,
            } => {
                let epoch = step / steps_per_epoch.max(1);
                base * gamma.powi((epoch / every_epochs.max(1)) as i32)
            }
        }
    }
}

/// Everything [`train`](crate::train()) needs. [`TrainConfig::new`] gives the defaults.
#[derive(Clone, Debug, PartialEq, Serialize, Deserialize)]
pub struct TrainConfig {
    /// Native dataset folder.
    pub data: PathBuf,
    /// Checkpoint folder (created).
    pub out: PathBuf,
    /// Task; `None`: from the dataset's `dof`.
    pub task: Option<Task>,
    /// Backbone.
    pub arch: Arch,
    /// View preset name or spec text; `None`: `gray160` for 3-DoF, `rgb256` for 6-DoF.
    pub view: Option<String>,
    /// Epochs to reach (a resumed run continues up to this number).
    pub epochs: usize,
    /// Images per step (at least 2: BatchNorm needs batch statistics).
    pub batch_size: usize,
    /// Cap on steps per epoch (`None`: one pass over the training frames).
    pub max_steps_per_epoch: Option<usize>,
    /// Base learning rate.
    pub lr: f64,
    /// Learning-rate schedule.
    pub schedule: Schedule,
    /// Optimizer.
    pub optimizer: OptimizerKind,
    /// Weight decay.
    pub weight_decay: f64,
    /// β of the PoseNet loss (metres per unit of quaternion distance).
    pub beta: f64,
    /// Learn the weighting of the two loss parts instead of using β.
    pub learned_weighting: bool,
    /// Dropout probability on the pooled features and the hidden layer (also used by MC
    /// inference).
    pub dropout: f64,
    /// Width of the hidden layer of the head; 0: a single linear layer.
    #[serde(default)]
    pub hidden: usize,
    /// Predict a per-image position-error scale and train it by its likelihood
    /// ([`crate::net::HeadConfig::aleatoric`]).
    #[serde(default)]
    pub aleatoric: bool,
    /// Two networks, one for the position and one for the rotation ([`crate::NetConfig::split`]).
    #[serde(default)]
    pub split: bool,
    /// Jitter the training views (contrast, brightness, noise, occluders; see
    /// `loader::jitter_view`).
    #[serde(default)]
    pub augment: bool,
    /// Shape-biased training: restyle half the training views (random tone curves, inversion,
    /// texture, coloured light; edges kept, see `loader::style_view`) so the network
    /// cannot key on paint and light.
    #[serde(default)]
    pub shape_bias: bool,
    /// Train a dominant-plane branch beside the pose ([`crate::net::NetConfig::planes`]); the
    /// dataset needs depth for every frame (and plane ids, else planes are found in the depth).
    #[serde(default)]
    pub planes: bool,
    /// Split the dataset's sequences into blocks of consecutive frames (train / validation);
    /// `None`: the dataset's own split, else the default blocks ([`data::posed::SplitPlan`]).
    #[serde(default)]
    pub blocks: Option<data::blocks::BlockSplit>,
    /// Stop after this many epochs without a better validation median position error.
    pub patience: Option<usize>,
    /// Seed of initialisation, shuffling and dropout.
    pub seed: u64,
    /// Continue from the checkpoint in `out` when there is one.
    pub resume: bool,
    /// Replace a checkpoint already in `out`; without it (or `resume`) a folder holding one is
    /// refused, so that no trained model is lost by a repeated command.
    #[serde(default, skip_serializing)]
    pub force: bool,
}

impl TrainConfig {
    /// Defaults: small network, 30 epochs, batch 32, AdamW at 1e-3 with weight decay 1e-4 and a
    /// cosine schedule, β = 10 (indoors a 0.1 m error and a 5° error weigh about the same),
    /// dropout 0.2, a 1024-wide hidden layer in the head, a per-image error scale (aleatoric),
    /// patience 10, seed 0.
    pub fn new(data: impl Into<PathBuf>, out: impl Into<PathBuf>) -> TrainConfig {
        TrainConfig {
            data: data.into(),
            out: out.into(),
            task: None,
            arch: Arch::Small,
            view: None,
            epochs: 30,
            batch_size: 32,
            max_steps_per_epoch: None,
            lr: 1e-3,
            schedule: Schedule::Cosine {
                final_fraction: 0.01,
            },
            optimizer: OptimizerKind::AdamW,
            weight_decay: 1e-4,
            beta: 10.0,
            learned_weighting: false,
            dropout: 0.2,
            hidden: 1024,
            aleatoric: true,
            split: false,
            augment: false,
            shape_bias: false,
            planes: false,
            blocks: None,
            patience: Some(10),
            seed: 0,
            resume: false,
            force: false,
        }
    }

    /// The recipe for real photos (640x480 colour frames of a building): the frozen ImageNet
    /// MobileNetV2 ([`Arch::Mobilenetv2`], 320x240 view) and its head trained for 150 epochs,
    /// the epoch kept by the validation blocks, when its weights are in the cache
    /// ([`crate::pretrained`]); otherwise the small network from scratch with the defaults of
    /// [`TrainConfig::new`]. Measured in ARCHITECTURE.md, "Real data".
    pub fn for_real_photos(data: impl Into<PathBuf>, out: impl Into<PathBuf>) -> TrainConfig {
        let mut cfg = TrainConfig::new(data, out);
        if crate::pretrained::locate(&crate::pretrained::MOBILENET_V2).is_ok() {
            cfg.arch = Arch::Mobilenetv2;
            cfg.epochs = 150;
            cfg.patience = None;
        }
        cfg
    }

    pub(crate) fn validate(&self) -> Result<()> {
        let bad = |m: String| Err(LearnError::Config(m));
        if self.epochs == 0 {
            return bad("epochs must be at least 1".into());
        }
        if self.batch_size < 2 {
            return bad(format!(
                "batch size {} too small: BatchNorm needs at least 2 images per batch",
                self.batch_size
            ));
        }
        if self.max_steps_per_epoch == Some(0) {
            return bad("max steps per epoch must be at least 1".into());
        }
        if !(self.lr.is_finite() && self.lr > 0.0) {
            return bad(format!("learning rate {} must be positive", self.lr));
        }
        if !(self.weight_decay.is_finite() && self.weight_decay >= 0.0) {
            return bad(format!("weight decay {} must be >= 0", self.weight_decay));
        }
        if !(self.beta.is_finite() && self.beta >= 0.0) {
            return bad(format!("beta {} must be >= 0", self.beta));
        }
        if !(0.0..1.0).contains(&self.dropout) {
            return bad(format!("dropout {} must be in [0, 1)", self.dropout));
        }
        if self.arch.pretrained() && (self.augment || self.shape_bias || self.planes || self.split)
        {
            return bad(format!(
                "{} trains on its frozen layers' maps, computed once per frame: it takes no augmentation, shape bias, plane branch or split network",
                self.arch
            ));
        }
        if self.aleatoric && self.learned_weighting {
            return bad(
                "the per-image scale (aleatoric) already weighs the position term; use it or learned weighting, not both".into(),
            );
        }
        self.schedule.validate()
    }

    /// The fields a resumed run must share with the checkpoint: all but the paths, `epochs`,
    /// `patience` and `resume`, which may change between runs, and the task and view, which are
    /// compared as resolved (an unset task means the dataset's, an unset view the default).
    pub(crate) fn resume_key(&self) -> TrainConfig {
        TrainConfig {
            data: PathBuf::new(),
            out: PathBuf::new(),
            task: None,
            view: None,
            epochs: 0,
            patience: None,
            resume: false,
            force: false,
            ..self.clone()
        }
    }
}

/// Position error that counts as much as [`SCORE_ROT_DEG`] of rotation when epochs are
/// compared: the middle rung of the accuracy ladder, (0.5 m, 5°).
pub const SCORE_POS_M: f64 = 0.5;
/// Rotation error that counts as much as [`SCORE_POS_M`] of position.
pub const SCORE_ROT_DEG: f64 = 5.0;

/// How the epoch kept in `model.bpk` is chosen: the lowest sum of the validation medians, each
/// in units of the (0.5 m, 5°) rung (lower is better).
///
/// Position alone once kept an epoch at 1.84 m and 117° over epochs at 2.0 m and 2.7° (the
/// shape-biased model of `study robustness`, 9.1 m on its held-out walk): a pose is both.
pub fn validation_score(median_pos_m: f64, median_rot_deg: f64) -> f64 {
    median_pos_m / SCORE_POS_M + median_rot_deg / SCORE_ROT_DEG
}
