//! The networks: a backbone ([`Arch`]), global average pooling, and one linear head whose input
//! can be masked for dropout.
//!
//! Dropout is an explicit inverted-Bernoulli mask on the pooled features ([`mc`]) rather than
//! burn's `Dropout`, which is a no-op outside autodiff training: the same mask code serves
//! training and Monte-Carlo inference, and N stochastic passes run as one batch (the pooled
//! features are computed once, repeated N times, masked, and sent through the head together).

mod conv;
pub mod mc;
mod resnet;
mod small;

use std::fmt;
use std::str::FromStr;
use std::sync::Mutex;

use burn::module::{Module, ModuleVisitor, Param};
use burn::nn::pool::{AdaptiveAvgPool2d, AdaptiveAvgPool2dConfig};
use burn::nn::{Linear, LinearConfig};
use burn::tensor::{Device, Tensor};
use serde::{Deserialize, Serialize};

use crate::{LearnError, Result};

pub use resnet::{RESNET_FEATURES, ResNet};
pub use small::{SMALL_CHANNELS, SmallNet};

/// Which backbone a [`PoseNet`] uses.
#[derive(Clone, Copy, Debug, PartialEq, Eq, Serialize, Deserialize)]
#[serde(rename_all = "lowercase")]
pub enum Arch {
    /// Five conv stages, 32-64-128-256-256 (fast; the default).
    Small,
    /// torchvision's ResNet-18 layout.
    Resnet18,
}

impl Arch {
    /// Names accepted by [`Arch::from_str`].
    pub const NAMES: &'static [&'static str] = &["small", "resnet18"];

    /// Width of the pooled feature vector.
    pub fn features(self) -> usize {
        match self {
            Arch::Small => SMALL_CHANNELS[SMALL_CHANNELS.len() - 1],
            Arch::Resnet18 => RESNET_FEATURES,
        }
    }
}

impl fmt::Display for Arch {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        f.write_str(match self {
            Arch::Small => "small",
            Arch::Resnet18 => "resnet18",
        })
    }
}

impl FromStr for Arch {
    type Err = LearnError;
    fn from_str(s: &str) -> Result<Self> {
        match s.trim() {
            "small" => Ok(Arch::Small),
            "resnet18" => Ok(Arch::Resnet18),
            other => Err(LearnError::Config(format!(
                "unknown architecture '{other}'; known: {}",
                Arch::NAMES.join(", ")
            ))),
        }
    }
}

/// What a [`PoseNet`] is built from; stored in the checkpoint so it can be rebuilt for loading.
#[derive(Clone, Debug, PartialEq, Serialize, Deserialize)]
pub struct NetConfig {
    /// Backbone.
    pub arch: Arch,
    /// Input channels: 1 (grey) or 3 (RGB).
    pub channels: usize,
    /// Outputs of the head (7 for 6-DoF poses, 4 for 3-DoF).
    pub outputs: usize,
    /// With the learned loss weighting, the network also holds the two log-variances
    /// `s_x, s_q` (trained with it, saved with it).
    pub learned_weighting: bool,
}

impl NetConfig {
    /// Builds the network on `device` with freshly initialised weights; the same `seed` gives
    /// the same weights.
    pub fn init(&self, device: &Device, seed: u64) -> Result<PoseNet> {
        if self.channels != 1 && self.channels != 3 {
            return Err(LearnError::Config(format!(
                "input channels must be 1 or 3, not {}",
                self.channels
            )));
        }
        if self.outputs == 0 {
            return Err(LearnError::Config(
                "a network needs at least one output".into(),
            ));
        }
        // burn's random initialisers draw from one generator per backend, seeded globally, and
        // parameters are initialised lazily on first use. Seeding and forcing every parameter
        // under one lock keeps two models built at the same time (tests, threads) from
        // interleaving their draws.
        static INIT: Mutex<()> = Mutex::new(());
        let _guard = INIT.lock().unwrap_or_else(|e| e.into_inner());
        device.seed(seed);
        let backbone = match self.arch {
            Arch::Small => Backbone::Small(SmallNet::new(self.channels, device)),
            Arch::Resnet18 => Backbone::ResNet(ResNet::resnet18(self.channels, device)),
        };
        let net = PoseNet {
            backbone,
            pool: AdaptiveAvgPool2dConfig::new([1, 1]).init(),
            head: LinearConfig::new(self.arch.features(), self.outputs).init(device),
            // Kendall & Cipolla (2017) start at s_x = 0, s_q = -3.
            log_vars: self
                .learned_weighting
                .then(|| Param::from_tensor(Tensor::from_floats([0.0, -3.0], device))),
        };
        net.visit(&mut Materialize);
        Ok(net)
    }
}

/// Forces lazily initialised parameters (see [`NetConfig::init`]).
struct Materialize;

impl ModuleVisitor for Materialize {
    fn visit_float<const D: usize>(&mut self, param: &Param<Tensor<D>>) {
        let _ = param.val();
    }
}

/// Counts trainable parameters: every float parameter except BatchNorm's running statistics,
/// which burn's `num_params` includes but PyTorch does not count.
#[derive(Default)]
struct CountTrainable {
    path: Vec<String>,
    count: usize,
}

impl ModuleVisitor for CountTrainable {
    fn enter_module(&mut self, name: &str, _container_type: &str) {
        self.path.push(name.to_string());
    }

    fn exit_module(&mut self, _name: &str, _container_type: &str) {
        self.path.pop();
    }

    fn visit_float<const D: usize>(&mut self, param: &Param<Tensor<D>>) {
        let running = matches!(
            self.path.last().map(String::as_str),
            Some("running_mean" | "running_var")
        );
        if !running {
            self.count += param.lazy_shape().num_elements();
        }
    }
}

/// The backbone of a [`PoseNet`].
// One per network and never stored in bulk, so the size difference of the variants costs
// nothing; burn's `Module` derive cannot see through a `Box`.
#[allow(clippy::large_enum_variant)]
#[derive(Module, Debug)]
pub enum Backbone {
    /// The small network.
    Small(SmallNet),
    /// ResNet-18.
    ResNet(ResNet),
}

impl Backbone {
    fn forward(&self, x: Tensor<4>) -> Tensor<4> {
        match self {
            Backbone::Small(n) => n.forward(x),
            Backbone::ResNet(n) => n.forward(x),
        }
    }
}

/// A pose-regression network: backbone, global average pool, linear head.
#[derive(Module, Debug)]
pub struct PoseNet {
    backbone: Backbone,
    pool: AdaptiveAvgPool2d,
    head: Linear,
    log_vars: Option<Param<Tensor<1>>>,
}

impl PoseNet {
    /// Pooled features `[B, F]` of a batch `[B, C, H, W]`.
    pub fn features(&self, x: Tensor<4>) -> Tensor<2> {
        self.pool.forward(self.backbone.forward(x)).flatten(1, 3)
    }

    /// The head applied to features `[B, F] -> [B, outputs]`.
    pub fn head(&self, features: Tensor<2>) -> Tensor<2> {
        self.head.forward(features)
    }

    /// Outputs without dropout, `[B, C, H, W] -> [B, outputs]`.
    pub fn forward(&self, x: Tensor<4>) -> Tensor<2> {
        self.head(self.features(x))
    }

    /// Outputs with a dropout mask on the pooled features (`mask`: `[B, F]`, see [`mc`]).
    pub fn forward_masked(&self, x: Tensor<4>, mask: Tensor<2>) -> Tensor<2> {
        self.head(self.features(x) * mask)
    }

    /// The learned loss log-variances `[s_x, s_q]`, when the network has them.
    pub fn log_vars(&self) -> Option<Tensor<1>> {
        self.log_vars.as_ref().map(Param::val)
    }

    /// Trainable parameters, counted as PyTorch does (BatchNorm running statistics excluded).
    pub fn trainable_params(&self) -> usize {
        let mut count = CountTrainable::default();
        self.visit(&mut count);
        count.count
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    fn config(arch: Arch, channels: usize) -> NetConfig {
        NetConfig {
            arch,
            channels,
            outputs: 7,
            learned_weighting: false,
        }
    }

    #[test]
    fn parameter_counts_match_the_pytorch_peer() -> Result<()> {
        let device = Device::flex();
        // torch_apr.py: 980,455 (small) and 11,173,831 (resnet18) for one input channel.
        assert_eq!(
            config(Arch::Small, 1).init(&device, 0)?.trainable_params(),
            980_455
        );
        assert_eq!(
            config(Arch::Resnet18, 1)
                .init(&device, 0)?
                .trainable_params(),
            11_173_831
        );
        // Three channels add 2 · 32 · 9 (small) and 2 · 64 · 49 (resnet18) conv weights.
        assert_eq!(
            config(Arch::Small, 3).init(&device, 0)?.trainable_params(),
            981_031
        );
        let learned = NetConfig {
            learned_weighting: true,
            ..config(Arch::Small, 1)
        };
        assert_eq!(learned.init(&device, 0)?.trainable_params(), 980_457);
        Ok(())
    }

    #[test]
    fn output_shapes() -> Result<()> {
        let device = Device::flex();
        let small = config(Arch::Small, 1).init(&device, 0)?.valid();
        let y = small.forward(Tensor::zeros([2, 1, 120, 160], &device));
        assert_eq!(y.dims(), [2, 7]);
        let resnet = NetConfig {
            outputs: 4,
            ..config(Arch::Resnet18, 3)
        }
        .init(&device, 0)?
        .valid();
        let y = resnet.forward(Tensor::zeros([1, 3, 64, 64], &device));
        assert_eq!(y.dims(), [1, 4]);
        assert!(config(Arch::Small, 2).init(&device, 0).is_err());
        Ok(())
    }

    #[test]
    fn initialisation_follows_the_seed() -> Result<()> {
        let device = Device::flex();
        let x = Tensor::<4>::ones([1, 1, 32, 32], &device);
        let out = |seed| -> Result<Vec<f32>> {
            let net = config(Arch::Small, 1).init(&device, seed)?.valid();
            net.forward(x.clone())
                .into_data()
                .try_to_vec::<f32>()
                .map_err(|e| LearnError::Input(format!("{e:?}")))
        };
        assert_eq!(out(3)?, out(3)?);
        assert_ne!(out(3)?, out(4)?);
        Ok(())
    }

    #[test]
    fn names_parse() -> Result<()> {
        for name in Arch::NAMES {
            assert_eq!(name.parse::<Arch>()?.to_string(), *name);
        }
        assert!("vgg".parse::<Arch>().is_err());
        Ok(())
    }
}
