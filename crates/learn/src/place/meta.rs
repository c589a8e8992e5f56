//! `place.toml`: what a place model is, how it was trained and on what (see the [module
//! docs](super) for the file layout).

use std::path::{Path, PathBuf};

use serde::{Deserialize, Serialize};

use super::classes::PlaceClasses;
use super::net::PlaceNetConfig;
use super::walk::PlaceTransitions;
use crate::checkpoint::{DatasetRef, StateFiles};
use crate::net::Arch;
use crate::{LearnError, Result};

/// File name of the place model's description.
pub const PLACE_TOML: &str = "place.toml";
/// File name of the place model's best weights.
pub const PLACE_BPK: &str = "place.bpk";
/// Folder of the place model's resume state.
pub const PLACE_STATE_DIR: &str = "place-state";
/// Layout version of `place.toml`.
pub const PLACE_FORMAT: u32 = 1;

/// How training and validation frames are told apart.
#[derive(Clone, Copy, Debug, PartialEq, Eq, Serialize, Deserialize)]
#[serde(rename_all = "lowercase")]
pub enum PlaceSplit {
    /// By recording session (sequence), as the dataset's splits say.
    Session,
    /// Frames drawn at random from the pooled training and validation frames (leaky).
    Random,
}

impl std::str::FromStr for PlaceSplit {
    type Err = LearnError;
    fn from_str(s: &str) -> Result<Self> {
        match s.trim() {
            "session" => Ok(PlaceSplit::Session),
            "random" => Ok(PlaceSplit::Random),
            other => Err(LearnError::Config(format!(
                "unknown split '{other}'; known: session, random"
            ))),
        }
    }
}

/// Everything [`train_place`](super::train_place) needs; [`PlaceConfig::new`] gives the
/// defaults.
#[derive(Clone, Debug, PartialEq, Serialize, Deserialize)]
pub struct PlaceConfig {
    /// Native dataset folder with `labels.csv`.
    pub data: PathBuf,
    /// Checkpoint folder (may also hold a pose model).
    pub out: PathBuf,
    /// Backbone.
    pub arch: Arch,
    /// View preset or spec text; `None`: `place240`.
    pub view: Option<String>,
    /// Epochs to reach.
    pub epochs: usize,
    /// Images per step (at least 2).
    pub batch_size: usize,
    /// Base learning rate (cosine decay to 1 %).
    pub lr: f64,
    /// AdamW weight decay.
    pub weight_decay: f64,
    /// Dropout on the pooled features.
    pub dropout: f64,
    /// Side of the pooling grid ([`super::PlaceNetConfig::grid`]).
    #[serde(default = "super::net::global_pool")]
    pub grid: usize,
    /// Session or random split.
    pub split: PlaceSplit,
    /// Jitter the training views (`loader::jitter_view`).
    pub augment: bool,
    /// Restyle half the training views (`loader::style_view`): the place is told by
    /// layout and fittings, not by how the lamps light the paint today.
    #[serde(default)]
    pub shape_bias: bool,
    /// Zoom and shift the training views a little (`loader::reframe_view`): new
    /// viewpoints between the walks' frames.
    #[serde(default)]
    pub reframe: bool,
    /// Stop after this many epochs without a better mean validation accuracy.
    pub patience: Option<usize>,
    /// Seed of initialisation, order, jitter and dropout.
    pub seed: u64,
    /// Continue from the checkpoint in `out`.
    pub resume: bool,
    /// Replace a place model already in `out` (without it or `resume` one is refused).
    #[serde(default, skip_serializing)]
    pub force: bool,
}

impl PlaceConfig {
    /// Defaults: small network, `place240`, a 2x2 pooling grid, 10 epochs of 32 images, AdamW
    /// at 1e-3 with weight decay 1e-4, dropout 0.2, session split, patience 5, seed 0.
    pub fn new(data: impl Into<PathBuf>, out: impl Into<PathBuf>) -> PlaceConfig {
        PlaceConfig {
            data: data.into(),
            out: out.into(),
            arch: Arch::Small,
            view: None,
            epochs: 10,
            batch_size: 32,
            lr: 1e-3,
            weight_decay: 1e-4,
            dropout: 0.2,
            grid: 2,
            split: PlaceSplit::Session,
            augment: false,
            shape_bias: false,
            reframe: false,
            patience: Some(5),
            seed: 0,
            resume: false,
            force: false,
        }
    }

    pub(super) fn validate(&self) -> Result<()> {
        let bad = |m: String| Err(LearnError::Config(m));
        if self.epochs == 0 {
            return bad("epochs must be at least 1".into());
        }
        if self.batch_size < 2 {
            return bad("batch size must be at least 2 (BatchNorm)".into());
        }
        if !(self.lr.is_finite() && self.lr > 0.0) {
            return bad(format!("learning rate {} must be positive", self.lr));
        }
        if !(self.weight_decay.is_finite() && self.weight_decay >= 0.0) {
            return bad(format!("weight decay {} must be >= 0", self.weight_decay));
        }
        if !(0.0..1.0).contains(&self.dropout) {
            return bad(format!("dropout {} must be in [0, 1)", self.dropout));
        }
        Ok(())
    }

    pub(super) fn resume_key(&self) -> PlaceConfig {
        PlaceConfig {
            data: PathBuf::new(),
            out: PathBuf::new(),
            epochs: 0,
            patience: None,
            resume: false,
            force: false,
            ..self.clone()
        }
    }
}

/// Metrics of one finished epoch.
#[derive(Clone, Debug, PartialEq, Serialize, Deserialize)]
pub struct PlaceEpoch {
    /// Epoch number, from 1.
    pub epoch: usize,
    /// Mean training loss (sum of the three cross-entropies).
    pub train_loss: f64,
    /// Validation accuracy per level (building, floor, corridor).
    pub val_accuracy: [f64; 3],
    /// Wall time of the epoch, seconds.
    pub seconds: f64,
}

/// The content of `place.toml`.
#[derive(Clone, Debug, PartialEq, Serialize, Deserialize)]
pub struct PlaceMeta {
    /// Layout version ([`PLACE_FORMAT`]).
    pub format: u32,
    /// The network to rebuild.
    pub net: PlaceNetConfig,
    /// Class names per level.
    pub classes: PlaceClasses,
    /// The input view, as view-spec text.
    pub view: String,
    /// Input shape `[channels, height, width]`.
    pub input: [usize; 3],
    /// Dropout on the pooled features in training.
    pub dropout: f64,
    /// The dataset.
    pub dataset: DatasetRef,
    /// The training configuration.
    pub config: PlaceConfig,
    /// Epochs finished.
    pub epoch: usize,
    /// Epoch whose weights are in `place.bpk`.
    pub best_epoch: usize,
    /// Validation accuracy of `place.bpk` per level.
    pub val_accuracy: [f64; 3],
    /// Content hash of `place.bpk`.
    pub weights_hash: String,
    /// Resume state.
    pub state: StateFiles,
    /// Metrics of every finished epoch.
    pub history: Vec<PlaceEpoch>,
    /// How the training walks moved between places, for filtering places along a walk
    /// ([`super::PlaceFilter`]); models from before it have none, and their frames are placed
    /// alone.
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub transitions: Option<PlaceTransitions>,
}

impl PlaceMeta {
    /// Whether `dir` holds a place model.
    pub fn exists(dir: &Path) -> bool {
        dir.join(PLACE_TOML).is_file()
    }

    /// Reads and checks `dir/place.toml`.
    pub fn read(dir: &Path) -> Result<PlaceMeta> {
        let path = dir.join(PLACE_TOML);
        if !path.is_file() {
            return Err(LearnError::corrupt(
                &path,
                "missing: no place model here (train one with `train --task place`)",
            ));
        }
        let text = data::io::read_text(&path)?;
        let meta: PlaceMeta =
            toml::from_str(&text).map_err(|e| LearnError::corrupt(&path, e.to_string()))?;
        let bad = |msg: String| Err(LearnError::corrupt(&path, msg));
        if meta.format != PLACE_FORMAT {
            return bad(format!(
                "layout version {} (this build reads {PLACE_FORMAT})",
                meta.format
            ));
        }
        if meta.net.classes != meta.classes.sizes() {
            return bad(format!(
                "the network has {:?} classes, the class lists {:?}",
                meta.net.classes,
                meta.classes.sizes()
            ));
        }
        if meta.input[0] != meta.net.channels || meta.input.contains(&0) {
            return bad(format!("input {:?} does not fit the network", meta.input));
        }
        if let Some(t) = &meta.transitions {
            let places = meta.classes.corridor.len();
            if t.changes.len() != places || t.changes.iter().any(|row| row.len() != places) {
                return bad(format!(
                    "[transitions] changes must be {places}x{places}, one row and column per place"
                ));
            }
            if !(t.frame_s > 0.0 && t.frame_s.is_finite()) || t.stays > t.pairs {
                return bad(format!(
                    "[transitions] frame_s {} must be positive and stays {} at most pairs {}",
                    t.frame_s, t.stays, t.pairs
                ));
            }
        }
        Ok(meta)
    }

    /// Writes `dir/place.toml` atomically.
    pub fn write(&self, dir: &Path) -> Result<()> {
        let path = dir.join(PLACE_TOML);
        let text = toml::to_string(self).map_err(|e| LearnError::corrupt(&path, e.to_string()))?;
        data::io::write_text_atomic(&path, &text)?;
        Ok(())
    }
}
