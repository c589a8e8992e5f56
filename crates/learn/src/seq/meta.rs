//! `seq.toml`: what a sequence model is and what it was trained on (see the [module
//! docs](super) for the file layout).

use std::path::{Path, PathBuf};

use serde::{Deserialize, Serialize};

use super::head::SeqHeadConfig;
use crate::checkpoint::{DatasetRef, StateFiles};
use crate::config::Schedule;
use crate::{LearnError, Result};

/// The most LSTM units a sequence model has: its gates hold `4·H·(F + O + H)` weights, and a
/// hand-edited `seq.toml` must not ask for gigabytes before its weights are read.
pub const MAX_LSTM_UNITS: usize = 4096;

/// File name of the sequence model's description.
pub const SEQ_TOML: &str = "seq.toml";
/// File name of the sequence model's best weights.
pub const SEQ_BPK: &str = "seq.bpk";
/// Folder of the sequence model's resume state.
pub const SEQ_STATE_DIR: &str = "seq-state";
/// Layout version of `seq.toml`: 2 since the head corrects the single-frame outputs (a head
/// of version 1 read features alone).
pub const SEQ_FORMAT: u32 = 2;

/// Metrics of one finished epoch of the sequence model.
#[derive(Clone, Debug, PartialEq, Serialize, Deserialize)]
pub struct SeqEpoch {
    /// Epoch number, from 1.
    pub epoch: usize,
    /// Mean training loss.
    pub train_loss: f64,
    /// Median validation position error, metres (validation recordings run whole, the state
    /// carried from frame to frame, as live).
    pub val_median_pos_m: f64,
    /// Median validation rotation error, degrees.
    pub val_median_rot_deg: f64,
    /// Mean |Δ position error| between consecutive validation frames, metres.
    pub val_jitter_m: f64,
    /// Wall time of the epoch, seconds.
    pub seconds: f64,
}

/// The content of `seq.toml`.
#[derive(Clone, Debug, PartialEq, Serialize, Deserialize)]
pub struct SeqMeta {
    /// Layout version ([`SEQ_FORMAT`]).
    pub format: u32,
    /// Content hash of the `model.bpk` whose features the head was trained on.
    pub base_weights_hash: String,
    /// The dataset the head was trained on (absent in files written before it was recorded,
    /// when it was always the single-frame model's).
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub dataset: Option<DatasetRef>,
    /// The head to rebuild before loading the weights.
    pub head: SeqHeadConfig,
    /// Dropout on each frame's features (training and MC inference).
    pub dropout: f64,
    /// The training configuration (resuming checks the new one against it).
    pub config: SeqConfig,
    /// Epochs finished.
    pub epoch: usize,
    /// Epoch whose weights are in `seq.bpk`.
    pub best_epoch: usize,
    /// Median validation position error of `seq.bpk`, metres.
    pub val_median_pos_m: f64,
    /// Median validation rotation error of `seq.bpk`, degrees.
    pub val_median_rot_deg: f64,
    /// Content hash of `seq.bpk`.
    pub weights_hash: String,
    /// Resume state.
    pub state: StateFiles,
    /// Metrics of every finished epoch.
    pub history: Vec<SeqEpoch>,
}

impl SeqMeta {
    /// Whether `dir` holds a sequence model.
    pub fn exists(dir: &Path) -> bool {
        dir.join(SEQ_TOML).is_file()
    }

    /// Reads and checks `dir/seq.toml`.
    pub fn read(dir: &Path) -> Result<SeqMeta> {
        let path = dir.join(SEQ_TOML);
        if !path.is_file() {
            return Err(LearnError::corrupt(
                &path,
                "missing: the model has no sequence part (train one with `train --window K`)",
            ));
        }
        let text = data::io::read_text(&path)?;
        let meta: SeqMeta =
            toml::from_str(&text).map_err(|e| LearnError::corrupt(&path, e.to_string()))?;
        if meta.format != SEQ_FORMAT {
            return Err(LearnError::corrupt(
                &path,
                format!(
                    "layout version {} (this build reads {SEQ_FORMAT}); train the sequence part \
                     again with `train --window`",
                    meta.format
                ),
            ));
        }
        if meta.head.features == 0 || meta.head.hidden == 0 || meta.head.outputs == 0 {
            return Err(LearnError::corrupt(&path, "head with a zero width"));
        }
        if meta.head.hidden > MAX_LSTM_UNITS {
            return Err(LearnError::corrupt(
                &path,
                format!(
                    "{} LSTM units, more than {}",
                    meta.head.hidden, MAX_LSTM_UNITS
                ),
            ));
        }
        if !(0.0..1.0).contains(&meta.dropout) {
            return Err(LearnError::corrupt(
                &path,
                format!("dropout {} outside [0, 1)", meta.dropout),
            ));
        }
        Ok(meta)
    }

    /// Writes `dir/seq.toml` atomically.
    pub fn write(&self, dir: &Path) -> Result<()> {
        let path = dir.join(SEQ_TOML);
        let text = toml::to_string(self).map_err(|e| LearnError::corrupt(&path, e.to_string()))?;
        data::io::write_text_atomic(&path, &text)?;
        Ok(())
    }
}

/// Everything [`train_sequence`](super::train_sequence) needs; [`SeqConfig::new`] gives the
/// defaults.
#[derive(Clone, Debug, PartialEq, Serialize, Deserialize)]
pub struct SeqConfig {
    /// Dataset of the training and validation recordings: the single-frame model's own, or
    /// another of the same place and camera whose recordings run at the rate the sequence
    /// model will (see [`super::MAX_STEP_RATIO`]). Frames the CNN never trained on give the LSTM
    /// features as noisy as a new frame's.
    pub data: PathBuf,
    /// Checkpoint folder of the single-frame model; the sequence part is written beside it.
    pub model: PathBuf,
    /// Frames per training window (K).
    pub window: usize,
    /// Frames between the starts of consecutive training windows.
    pub stride: usize,
    /// LSTM units.
    pub hidden: usize,
    /// Epochs to reach (a resumed run continues up to this number).
    pub epochs: usize,
    /// Windows per step.
    pub batch_size: usize,
    /// Base learning rate.
    pub lr: f64,
    /// Learning-rate schedule over the whole run.
    pub schedule: Schedule,
    /// AdamW weight decay.
    pub weight_decay: f64,
    /// β of the pose loss; `None`: the single-frame model's.
    pub beta: Option<f64>,
    /// Dropout on each frame's features; `None`: the single-frame model's.
    pub dropout: Option<f64>,
    /// Jittered copies of each training view whose features windows draw from, besides the
    /// clean view (`loader::jitter_view`).
    pub jittered_copies: usize,
    /// Stop after this many epochs without a better validation median position error.
    pub patience: Option<usize>,
    /// Seed of initialisation, window order, jitter and dropout.
    pub seed: u64,
    /// Continue from the sequence checkpoint in `model` when there is one.
    pub resume: bool,
    /// Replace a sequence part already in `model` (without it or `resume` one is refused).
    #[serde(default, skip_serializing)]
    pub force: bool,
}

impl SeqConfig {
    /// Defaults: windows of 20 frames every frame (on the quick demo's walks windows of 10
    /// lost to the single frame on one seed of two: `study sequence --quick`), 256 LSTM units,
    /// 10 epochs of 32 windows a step, AdamW at 1e-3 (cosine decay to 1 %) with weight decay
    /// 1e-4, β and dropout of the single-frame model, two jittered copies, patience 4, seed 0.
    pub fn new(data: impl Into<PathBuf>, model: impl Into<PathBuf>) -> SeqConfig {
        SeqConfig {
            data: data.into(),
            model: model.into(),
            window: 20,
            stride: 1,
            hidden: 256,
            epochs: 10,
            batch_size: 32,
            lr: 1e-3,
            schedule: Schedule::Cosine {
                final_fraction: 0.01,
            },
            weight_decay: 1e-4,
            beta: None,
            dropout: None,
            jittered_copies: 2,
            patience: Some(4),
            seed: 0,
            resume: false,
            force: false,
        }
    }

    pub(super) fn validate(&self) -> Result<()> {
        let bad = |m: String| Err(LearnError::Config(m));
        if self.window < 2 {
            return bad(format!(
                "window {} too short: a sequence model needs at least 2 frames",
                self.window
            ));
        }
        if self.stride == 0 || self.hidden == 0 || self.epochs == 0 || self.batch_size == 0 {
            return bad("stride, LSTM units, epochs and batch size must be at least 1".into());
        }
        if self.hidden > MAX_LSTM_UNITS {
            return bad(format!(
                "{} LSTM units, more than {}",
                self.hidden, MAX_LSTM_UNITS
            ));
        }
        if !(self.lr.is_finite() && self.lr > 0.0) {
            return bad(format!("learning rate {} must be positive", self.lr));
        }
        if !(self.weight_decay.is_finite() && self.weight_decay >= 0.0) {
            return bad(format!("weight decay {} must be >= 0", self.weight_decay));
        }
        if self.beta.is_some_and(|b| !(b.is_finite() && b >= 0.0)) {
            return bad("beta must be >= 0".into());
        }
        if self.dropout.is_some_and(|p| !(0.0..1.0).contains(&p)) {
            return bad("dropout must be in [0, 1)".into());
        }
        self.schedule.validate()
    }

    /// The fields a resumed run must share with the checkpoint.
    pub(super) fn resume_key(&self) -> SeqConfig {
        SeqConfig {
            data: PathBuf::new(),
            model: PathBuf::new(),
            epochs: 0,
            patience: None,
            resume: false,
            force: false,
            ..self.clone()
        }
    }
}
