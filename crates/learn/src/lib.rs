//! Pose regression for indoorloc: the networks, losses, training, checkpoints and inference.
//! This is the only crate that depends on burn.
//!
//! # Entry points
//! - [`train`] with a [`TrainConfig`]: trains on a native dataset (train/val split by
//!   sequence), checkpoints every epoch into a folder, resumes, stops early.
//! - [`Localizer::load`] then [`Localizer::predict`] / [`Localizer::predict_batch`]: poses of
//!   images with Monte-Carlo-dropout uncertainty ([`Estimate`]).
//! - [`net`]: the networks ([`Arch::Small`], [`Arch::Resnet18`], layer for layer as the PyTorch
//!   peer `torch_apr.py`; [`Arch::Mobilenetv2`] with torchvision's ImageNet weights, frozen,
//!   from [`pretrained`]), [`loss`], [`head`] (what outputs mean), [`checkpoint`] (the folder
//!   layout), [`dataset`] (views in memory), [`window`] (which runs of frames a sequence model
//!   may see as one stretch of time), [`seq`] (the LSTM of a CNN+LSTM sequence model and its
//!   live, resettable stream), [`planes`] (dominant-plane targets and loss of the auxiliary
//!   plane task), [`explain`] (Grad-CAM: [`Explainer`] and [`Saliency`]).
//!
//! # Backend
//! burn 0.22 picks the backend by device: training runs on `Device::flex().autodiff()`,
//! inference on `Device::flex()` (pure-Rust CPU, SIMD, threads from rayon's global pool).
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
pub mod dataset;
mod error;
pub mod explain;
mod hash;
pub mod head;
pub mod infer;
pub mod kernels;
pub mod loader;
pub mod loss;
pub mod net;
pub mod place;
pub mod planes;
pub mod pretrained;
pub mod progress;
pub mod seq;
pub mod train;
pub mod tta;
pub mod window;

pub use error::{LearnError, Result};
pub use explain::{CamLayer, Explainer, Saliency};
pub use head::{PoseCoding, Task};
pub use infer::{Estimate, Localizer};
pub use net::{Arch, HeadConfig, NetConfig, PoseNet};
pub use progress::Progress;
pub use train::{
    EpochMetrics, Loaded, OptimizerKind, Schedule, TrainConfig, TrainEvent, TrainSummary, train,
};
