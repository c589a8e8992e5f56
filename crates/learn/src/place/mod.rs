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

mod classes;
mod infer;
mod meta;
mod net;
mod train;
mod walk;

pub use classes::{LEVELS, PlaceClasses, class_names, decode, joint, place_posterior};
pub use infer::{PlaceLocalizer, PlacePrediction, PlaceTracker, WalkFrame};
pub use meta::{
    PLACE_BPK, PLACE_FORMAT, PLACE_STATE_DIR, PLACE_TOML, PlaceConfig, PlaceEpoch, PlaceMeta,
    PlaceSplit,
};
pub use net::{PlaceNet, PlaceNetConfig};
pub use train::{PlaceEvent, PlaceLoaded, PlaceSummary, accuracy, train_place};
pub use walk::{DEFAULT_LAG_S, PlaceFilter, PlaceSmoother, PlaceTransitions};
