//! Pose regression for indoorloc: the networks, losses, training, checkpoints and inference.
//! This is the only crate that depends on burn.
//!
//! # Entry points
//! - [`train()`] with a [`TrainConfig`]: trains on a native dataset (train/val split by
//!   sequence), checkpoints every epoch into a folder, resumes, stops early.
//! - [`Localizer::load`] then [`Localizer::predict`] / [`Localizer::predict_batch`]: poses of
//!   images with Monte-Carlo-dropout uncertainty ([`Estimate`]).
//! - [`checkpoint`]: the model folder ([`ModelMeta`] is its `model.toml`); [`calibrate`]: what
//!   sigma's parts ([`SigmaParts`]) weigh ([`SigmaWeights`]) and mean
//!   ([`UncertaintyCalibration`]).
//! - The networks: [`Arch::Small`], [`Arch::Resnet18`] (layer for layer as the PyTorch peer
//!   `torch_apr.py`), [`Arch::Mobilenetv2`] with torchvision's ImageNet weights, frozen, from
//!   [`pretrained`]; [`NetConfig`] and [`HeadConfig`] say how one is built, [`PoseCoding`] what
//!   its outputs mean.
//! - [`seq`]: CNN+LSTM sequence models and their live, resettable stream, over [`window`]s of
//!   frames; [`place`]: the place classifier and its smoothing along a walk; [`planes`]:
//!   dominant-plane targets of the auxiliary plane task; [`Explainer`] and [`Saliency`]:
//!   Grad-CAM; [`bench`](mod@bench): timings.
//!
//! # Layout
//! Configurations and stored formats lie at the bottom, so that no module imports one that
//! imports it back (`scripts/module-cycles.py crates/learn/src` checks it): `config`
//! ([`TrainConfig`]), `sigma` ([`SigmaParts`], [`SigmaWeights`], [`UncertaintyCalibration`]) and
//! [`checkpoint`] (`model.toml`, weights files) under `infer` ([`Localizer`]), [`calibrate`] and
//! `train`; each of [`place`] and [`seq`] keeps its own stored format in a `meta` module under
//! its training and inference. The networks (`net`, with its CPU kernels) know nothing of
//! training or checkpoints.
//!
//! # Backend
//! burn 0.22 picks the backend by device: by default training runs on
//! `Device::flex().autodiff()`, inference on `Device::flex()` (pure-Rust CPU, SIMD, threads
//! from rayon's global pool); [`device::select`] moves both to a GPU (feature `wgpu`).
//!
//! # Example
//! ```no_run
//! let mut cfg = learn::TrainConfig::new("data/walk", "models/walk");
//! cfg.epochs = 5;
//! let summary = learn::train(&cfg, &mut |_event| {})?;
//! let loc = learn::Localizer::load(&summary.out)?;
//! let img = image::open("photo.png").map_err(|e| learn::LearnError::Input(e.to_string()))?;
//! let est = loc.predict(&img, 16)?;
//! println!("{:?} ± {:.2} m", est.pose.position(), est.sigma_pos_m);
//! # Ok::<(), learn::LearnError>(())
//! ```

pub mod bench;
pub mod calibrate;
pub mod checkpoint;
mod config;
mod dataset;
pub mod device;
mod error;
mod explain;
mod hash;
mod head;
mod infer;
mod kernels;
mod loader;
mod loss;
mod net;
pub mod place;
pub mod planes;
pub mod pretrained;
mod progress;
pub mod seq;
mod sigma;
mod train;
mod tta;
pub mod window;

pub use checkpoint::{EpochMetrics, ModelMeta};
pub use config::{OptimizerKind, Schedule, TrainConfig};
pub use dataset::HOLDOUT_EVERY;
pub use device::ComputeDevice;
pub use error::{LearnError, Result};
pub use explain::{CamLayer, Explainer, Saliency};
pub use head::{PoseCoding, Task};
pub use infer::{DEFAULT_MC_SEED, Estimate, Localizer};
pub use net::{Arch, HeadConfig, NetConfig, PoseNet};
pub use progress::Progress;
pub use sigma::{SigmaParts, SigmaWeights, UncertaintyCalibration};
pub use train::{Loaded, TrainEvent, TrainSummary, train};
