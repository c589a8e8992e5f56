//! Coarse place recognition: which building, which floor, and which corridor and walking
//! direction an image was taken in, as a classifier with one head per level on the same
//! backbones as the pose networks.
//!
//! The corridor class is the whole place, `building/floor/corridor/direction` (corridor names
//! repeat between floors and buildings), so a right corridor answer implies a right building
//! and floor. Each head is a linear layer on the features pooled to a small grid (with
//! dropout in training), trained by the sum of the three cross-entropies, and read together
//! ([`joint`]) so that the building, floor and place of an answer agree.
//!
//! # Files (beside a pose model's, or alone)
//! ```text
//! MODEL/
//!   place.toml                    PlaceMeta: classes, network, view, dataset, metrics
//!   place.bpk                     weights of the best epoch
//!   place-state/weights-NNNN.bpk  state after the last finished epoch (resume)
//!   place-state/optimizer-NNNN.bpk
//! ```

mod infer;
mod train;
mod walk;

use std::collections::BTreeSet;
use std::path::Path;

use burn::module::Module;
use burn::nn::pool::{AdaptiveAvgPool2d, AdaptiveAvgPool2dConfig};
use burn::nn::{Linear, LinearConfig};
use burn::tensor::{Device, Tensor};
use data::native::Label;
use serde::{Deserialize, Serialize};

use crate::checkpoint::{DatasetRef, StateFiles};
use crate::net::{Arch, Backbone, seeded_init};
use crate::{LearnError, Result};

pub use infer::{PlaceLocalizer, PlacePrediction, PlaceTracker, WalkFrame};
pub use train::{
    PlaceConfig, PlaceEvent, PlaceLoaded, PlaceSplit, PlaceSummary, accuracy, train_place,
};
pub use walk::{PlaceFilter, PlaceSmoother, PlaceTransitions};

/// File name of the place model's description.
pub const PLACE_TOML: &str = "place.toml";
/// File name of the place model's best weights.
pub const PLACE_BPK: &str = "place.bpk";
/// Folder of the place model's resume state.
pub const PLACE_STATE_DIR: &str = "place-state";
/// Layout version of `place.toml`.
pub const PLACE_FORMAT: u32 = 1;

/// How long `localize` waits before it tells a frame's place, seconds: the frames of that time
/// after it settle a turn the frames before it cannot (see [`PlaceSmoother`]). On the study's
/// held-out walks (frames 0.4 s apart; walks of 10 and of 40 frames; two models), 2 s came
/// within 0.2 points of waiting for the whole walk, where 1.2 s fell up to 0.4 short.
pub const DEFAULT_LAG_S: f64 = 2.0;

/// The levels of a place, in head order.
pub const LEVELS: [&str; 3] = ["building", "floor", "corridor"];

/// The class names of each level, sorted.
#[derive(Clone, Debug, PartialEq, Eq, Serialize, Deserialize)]
pub struct PlaceClasses {
    /// Building names.
    pub building: Vec<String>,
    /// Floor names, `building/floor`.
    pub floor: Vec<String>,
    /// Places, `building/floor/corridor/direction`.
    pub corridor: Vec<String>,
}

impl PlaceClasses {
    /// The classes that occur in `labels`.
    pub fn of<'a>(labels: impl IntoIterator<Item = &'a Label>) -> PlaceClasses {
        let mut sets: [BTreeSet<String>; 3] = Default::default();
        for label in labels {
            for (set, name) in sets.iter_mut().zip(class_names(label)) {
                set.insert(name);
            }
        }
        let [building, floor, corridor] = sets.map(|s| s.into_iter().collect());
        PlaceClasses {
            building,
            floor,
            corridor,
        }
    }

    /// The class lists in head order.
    pub fn levels(&self) -> [&[String]; 3] {
        [&self.building, &self.floor, &self.corridor]
    }

    /// Number of classes per level.
    pub fn sizes(&self) -> [usize; 3] {
        self.levels().map(<[String]>::len)
    }

    /// For each place class, the indices of its building and floor classes: the hierarchy that
    /// [`joint`] decodes by. `None` when a place's floor or building is not in the lists (a
    /// hand-edited `place.toml`); the levels are then read independently.
    pub fn tree(&self) -> Option<Vec<[usize; 2]>> {
        self.corridor
            .iter()
            .map(|place| {
                let floor = place.rsplitn(3, '/').nth(2)?;
                let building = floor.rsplit_once('/')?.0;
                let f = self
                    .floor
                    .binary_search_by(|n| n.as_str().cmp(floor))
                    .ok()?;
                let b = self
                    .building
                    .binary_search_by(|n| n.as_str().cmp(building))
                    .ok()?;
                Some([b, f])
            })
            .collect()
    }

    /// The class index of `label` at each level; `None` when one of its classes is unknown.
    pub fn indices(&self, label: &Label) -> Option<[usize; 3]> {
        let names = class_names(label);
        let mut out = [0; 3];
        for ((slot, classes), name) in out.iter_mut().zip(self.levels()).zip(&names) {
            *slot = classes.binary_search(name).ok()?;
        }
        Some(out)
    }
}

/// The class name of a label at each level: building, `building/floor`,
/// `building/floor/corridor/direction`.
pub fn class_names(label: &Label) -> [String; 3] {
    let floor = format!("{}/{}", label.building, label.floor);
    let place = format!("{floor}/{}/{}", label.corridor, label.direction);
    [label.building.clone(), floor, place]
}

/// The most likely consistent place of one image from the three heads' probabilities:
/// the place class `c` maximising `p_building(b(c)) · p_floor(f(c)) · p_place(c)` (the heads as a
/// product of experts), with the building and floor it lies in. Each level's probability is the
/// posterior of that product, renormalised over the places, summed over the places in the class.
///
/// Why: each head alone is free to disagree with the others (`B0/F2` from the floor head beside
/// `B0/F1/C2/back` from the place head), and the place head alone throws away what the building
/// and floor heads know. `tree` is [`PlaceClasses::tree`]; `probs` the softmax of each head.
pub fn joint(probs: [&[f32]; 3], tree: &[[usize; 2]]) -> [(usize, f32); 3] {
    decode(&place_posterior(probs, tree), tree)
}

/// The posterior over place classes of the heads' product (see [`joint`]), summing to 1.
pub fn place_posterior(probs: [&[f32]; 3], tree: &[[usize; 2]]) -> Vec<f32> {
    let [building, floor, place] = probs;
    // Scores in log space, shifted by their maximum so that the exponentials cannot underflow
    // all together.
    let log = |p: f32| p.max(f32::MIN_POSITIVE).ln();
    let scores: Vec<f32> = tree
        .iter()
        .zip(place)
        .map(|(&[b, f], &p)| log(building[b]) + log(floor[f]) + log(p))
        .collect();
    let top = scores.iter().copied().fold(f32::NEG_INFINITY, f32::max);
    let mut weights: Vec<f32> = scores.iter().map(|s| (s - top).exp()).collect();
    let total: f32 = weights.iter().sum();
    weights.iter_mut().for_each(|w| *w /= total);
    weights
}

/// The most likely place of a `posterior` over place classes, with its building and floor and
/// each one's probability (the posterior mass of the places in it).
pub fn decode(posterior: &[f32], tree: &[[usize; 2]]) -> [(usize, f32); 3] {
    let best = argmax(posterior).0;
    let [b, f] = tree.get(best).copied().unwrap_or_default();
    let mass = |keep: &dyn Fn(&[usize; 2]) -> bool| {
        tree.iter()
            .zip(posterior)
            .filter(|(t, _)| keep(t))
            .map(|(_, w)| w)
            .sum::<f32>()
    };
    [
        (b, mass(&|t| t[0] == b)),
        (f, mass(&|t| t[1] == f)),
        (best, posterior.get(best).copied().unwrap_or(0.0)),
    ]
}

/// The index of the largest value and the value (the first of equals).
pub(super) fn argmax(values: &[f32]) -> (usize, f32) {
    values.iter().enumerate().fold(
        (0, f32::NEG_INFINITY),
        |acc, (i, &v)| if v > acc.1 { (i, v) } else { acc },
    )
}

/// What a [`PlaceNet`] is built from.
#[derive(Clone, Debug, PartialEq, Eq, Serialize, Deserialize)]
pub struct PlaceNetConfig {
    /// Backbone.
    pub arch: Arch,
    /// Input channels: 1 or 3.
    pub channels: usize,
    /// Classes per level (building, floor, corridor).
    pub classes: [usize; 3],
    /// Side of the grid the last feature map is averaged to before the heads: 1 is global
    /// average pooling; 2 keeps which quarter of the view a feature is in, which helps to tell
    /// which way along a corridor the camera faces (the two views share their features, not
    /// their layout): on the place-split study's held-out walks, 69.5 % corridor and direction
    /// right against 66.2 % with global pooling. Models from before the grid read as 1.
    #[serde(default = "global_pool")]
    pub grid: usize,
}

fn global_pool() -> usize {
    1
}

impl PlaceNetConfig {
    /// A network with freshly initialised weights; the same seed gives the same weights.
    pub fn init(&self, device: &Device, seed: u64) -> Result<PlaceNet> {
        if self.channels != 1 && self.channels != 3 {
            return Err(LearnError::Config(format!(
                "input channels must be 1 or 3, not {}",
                self.channels
            )));
        }
        if self.classes.contains(&0) {
            return Err(LearnError::Config("a level without classes".into()));
        }
        if !(1..=4).contains(&self.grid) {
            return Err(LearnError::Config(format!(
                "pooling grid {} must be 1 to 4",
                self.grid
            )));
        }
        let features = self.arch.features() * self.grid * self.grid;
        let head = |n: usize| LinearConfig::new(features, n).init(device);
        Ok(seeded_init(device, seed, || PlaceNet {
            backbone: Backbone::new(self.arch, self.channels, device),
            pool: AdaptiveAvgPool2dConfig::new([self.grid, self.grid]).init(),
            building: head(self.classes[0]),
            floor: head(self.classes[1]),
            corridor: head(self.classes[2]),
        }))
    }
}

/// Backbone, average pool to a small grid (1x1: global), one linear head per level.
#[derive(Module, Debug)]
pub struct PlaceNet {
    backbone: Backbone,
    pool: AdaptiveAvgPool2d,
    building: Linear,
    floor: Linear,
    corridor: Linear,
}

impl PlaceNet {
    /// Pooled features `[B, F · grid²]` of a batch `[B, C, H, W]`.
    pub fn features(&self, x: Tensor<4>) -> Tensor<2> {
        self.pool.forward(self.backbone.forward(x)).flatten(1, 3)
    }

    /// Logits of each level, `[B, classes]`, from (masked) features.
    pub fn logits(&self, features: Tensor<2>) -> [Tensor<2>; 3] {
        [
            self.building.forward(features.clone()),
            self.floor.forward(features.clone()),
            self.corridor.forward(features),
        ]
    }

    /// The network with BatchNorm folded into the convolutions (inference only).
    pub fn fold_batchnorm(self) -> PlaceNet {
        PlaceNet {
            backbone: self.backbone.fold(),
            ..self
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
    /// ([`PlaceFilter`]); models from before it have none, and their frames are placed alone.
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
