//! `seq.toml`: what a sequence model is and what it was trained on (see the [module
//! docs](super) for the file layout).

use std::path::Path;

use serde::{Deserialize, Serialize};

use super::head::SeqHeadConfig;
use super::train::SeqConfig;
use crate::checkpoint::{DatasetRef, StateFiles};
use crate::{LearnError, Result};

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
        if meta.head.hidden > super::MAX_LSTM_UNITS {
            return Err(LearnError::corrupt(
                &path,
                format!(
                    "{} LSTM units, more than {}",
                    meta.head.hidden,
                    super::MAX_LSTM_UNITS
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
