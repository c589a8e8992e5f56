//! The networks: a backbone ([`Arch`]), global average pooling, and a head ([`HeadConfig`]):
//! one linear layer (as `torch_apr.py`), or a hidden fully connected layer before it, with an
//! optional extra output for a per-image position scale (aleatoric uncertainty).
//!
//! Dropout is an explicit inverted-Bernoulli mask ([`mc`]) on the pooled features and on the
//! hidden layer, rather than burn's `Dropout`, which is a no-op outside autodiff training: the
//! same mask code serves training and Monte-Carlo inference, and N stochastic passes run as one
//! batch (the pooled features are computed once, repeated N times, and sent through the masked
//! head together).

mod conv;
mod inception;
pub mod mc;
pub(crate) mod mobilenet;
mod planes;
mod resnet;
mod small;

use std::fmt;
use std::str::FromStr;
use std::sync::Mutex;

use burn::module::{Module, ModuleVisitor, Param};
use burn::nn::pool::{AdaptiveAvgPool2d, AdaptiveAvgPool2dConfig};
use burn::nn::{Linear, LinearConfig};
use burn::tensor::activation::relu;
use burn::tensor::{Device, Tensor};
use serde::{Deserialize, Serialize};

use rand_chacha::ChaCha8Rng;

use crate::head::Task;
use crate::{LearnError, Result};

pub use inception::{INCEPTION_FEATURES, INCEPTION_MID_CHANNELS, InceptionNet};
pub use mobilenet::{MOBILENET_FEATURES, MOBILENET_MID_CHANNELS, MobileNetV2};
pub use planes::{PLANE_CLASSES, PLANE_FEATURES, PLANE_PARAMS, PlaneBranch};
pub use resnet::{RESNET_FEATURES, RESNET_MID_CHANNELS, RESNET18_BLOCKS, RESNET34_BLOCKS, ResNet};
pub use small::{SMALL_CHANNELS, SMALL_MID_CHANNELS, SmallNet};

/// Which backbone a [`PoseNet`] uses.
#[derive(Clone, Copy, Debug, PartialEq, Eq, Serialize, Deserialize)]
#[serde(rename_all = "lowercase")]
pub enum Arch {
    /// Five conv stages, 32-64-128-256-256 (fast; the default).
    Small,
    /// torchvision's ResNet-18 layout.
    Resnet18,
    /// torchvision's ResNet-34 layout.
    Resnet34,
    /// GoogLeNet with BatchNorm, cut at its first auxiliary classifier (after inception 4a).
    Googlenet,
    /// torchvision's MobileNetV2 with its ImageNet weights, frozen, and a small trainable
    /// reduction that keeps the image layout (RGB only; see `net/mobilenet.rs`).
    Mobilenetv2,
}

impl Arch {
    /// Every backbone.
    pub const ALL: [Arch; 5] = [
        Arch::Small,
        Arch::Resnet18,
        Arch::Resnet34,
        Arch::Googlenet,
        Arch::Mobilenetv2,
    ];

    /// Whether the backbone starts from pretrained weights (which must be fetched, see
    /// [`crate::pretrained`]) and keeps them frozen.
    pub fn pretrained(self) -> bool {
        self == Arch::Mobilenetv2
    }

    /// Width of the pooled feature vector.
    pub fn features(self) -> usize {
        match self {
            Arch::Small => SMALL_CHANNELS[SMALL_CHANNELS.len() - 1],
            Arch::Resnet18 | Arch::Resnet34 => RESNET_FEATURES,
            Arch::Googlenet => INCEPTION_FEATURES,
            Arch::Mobilenetv2 => MOBILENET_FEATURES,
        }
    }

    /// Channels of the stride-8 map the plane branch reads (`Backbone::forward_mid`).
    pub fn mid_features(self) -> usize {
        match self {
            Arch::Small => SMALL_MID_CHANNELS,
            Arch::Resnet18 | Arch::Resnet34 => RESNET_MID_CHANNELS,
            Arch::Googlenet => INCEPTION_MID_CHANNELS,
            Arch::Mobilenetv2 => MOBILENET_MID_CHANNELS,
        }
    }

    /// The name [`Arch::from_str`] accepts.
    pub fn name(self) -> &'static str {
        match self {
            Arch::Small => "small",
            Arch::Resnet18 => "resnet18",
            Arch::Resnet34 => "resnet34",
            Arch::Googlenet => "googlenet",
            Arch::Mobilenetv2 => "mobilenetv2",
        }
    }
}

impl fmt::Display for Arch {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        f.write_str(self.name())
    }
}

impl FromStr for Arch {
    type Err = LearnError;
    fn from_str(s: &str) -> Result<Self> {
        let name = s.trim();
        Arch::ALL
            .into_iter()
            .find(|a| a.name() == name)
            .ok_or_else(|| {
                let known: Vec<&str> = Arch::ALL.iter().map(|a| a.name()).collect();
                LearnError::Config(format!(
                    "unknown architecture '{name}'; known: {}",
                    known.join(", ")
                ))
            })
    }
}

/// What a [`PoseNet`] is built from; stored in the checkpoint so it can be rebuilt for loading.
#[derive(Clone, Debug, PartialEq, Serialize, Deserialize)]
pub struct NetConfig {
    /// Backbone.
    pub arch: Arch,
    /// Input channels: 1 (grey) or 3 (RGB).
    pub channels: usize,
    /// Pose outputs (7 for 6-DoF poses, 4 for 3-DoF); the head may add one
    /// ([`HeadConfig::aleatoric`]).
    pub outputs: usize,
    /// With the learned loss weighting, the network also holds the two log-variances
    /// `s_x, s_q` (trained with it, saved with it).
    pub learned_weighting: bool,
    /// The head on the pooled features.
    #[serde(default)]
    pub head: HeadConfig,
    /// Two networks of the same layout, one for the position (and its scale) and one for the
    /// rotation, as the ceiling-camera literature trains a position net and a heading net; the
    /// two parts then cannot compete for one network's features.
    #[serde(default)]
    pub split: bool,
    /// A dominant-plane branch on the (first) backbone's stride-8 map (`PlaneBranch`),
    /// trained on plane classes, parameters and the depth they induce; its pooled features
    /// join the pose head's input.
    #[serde(default)]
    pub planes: bool,
}

impl NetConfig {
    /// Position outputs: 2 (x, y) for a 3-DoF head, else up to 3; the rest are the rotation.
    fn pos_dims(&self) -> usize {
        if self.outputs == Task::Pose3.outputs() {
            Task::Pose3.pos_dims()
        } else {
            Task::Pose6.pos_dims().min(self.outputs)
        }
    }
}

/// The head of a [`PoseNet`].
#[derive(Clone, Copy, Debug, Default, PartialEq, Eq, Serialize, Deserialize)]
pub struct HeadConfig {
    /// Width of a hidden fully connected layer (ReLU, dropout) between the pooled features and
    /// the outputs, as PoseNet's 2048-wide layer; 0: none, a single linear layer as
    /// `torch_apr.py` has.
    #[serde(default)]
    pub hidden: usize,
    /// One more output, `s = ln b`: the scale of the image's position error (a Laplace-like
    /// density `∝ exp(−‖e‖ / b)`), trained by its negative log-likelihood. The network says how
    /// sure it is of each image (aleatoric uncertainty: repeated doors, blank walls), which
    /// Monte-Carlo dropout alone, measuring only the model's own spread, does not see.
    #[serde(default)]
    pub aleatoric: bool,
}

impl HeadConfig {
    /// Outputs of the last layer for a task with `outputs` pose outputs.
    pub fn outputs(&self, outputs: usize) -> usize {
        outputs + usize::from(self.aleatoric)
    }
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
        if self.arch.pretrained() && self.channels != 3 {
            return Err(LearnError::Config(format!(
                "{} was pretrained on colour images; it needs an RGB view, not {} channel(s)",
                self.arch, self.channels
            )));
        }
        Ok(seeded_init(device, seed, || self.build(device)))
    }

    fn build(&self, device: &Device) -> PoseNet {
        let Branch {
            backbone,
            pool,
            hidden,
            head,
        } = Branch::new(self, if self.planes { PLANE_FEATURES } else { 0 }, device);
        PoseNet {
            backbone,
            pool,
            hidden,
            head,
            planes: self
                .planes
                .then(|| PlaneBranch::new(self.arch.mid_features(), device)),
            rotation: self.split.then(|| Branch::new(self, 0, device)),
            pos_dims: self.pos_dims(),
            rot_dims: self.outputs - self.pos_dims(),
            // Kendall & Cipolla (2017) start at s_x = 0, s_q = -3.
            log_vars: self
                .learned_weighting
                .then(|| Param::from_tensor(Tensor::from_floats([0.0, -3.0], device))),
        }
    }
}

/// The `[gh, gw]` grid of the plane branch (the stride-8 map) for inputs `[C, H, W]` on the
/// backbone `arch`, found by running a fresh backbone once on zeros.
pub fn plane_grid(arch: Arch, input: [usize; 3]) -> Result<[usize; 2]> {
    let [c, h, w] = input;
    if c != 1 && c != 3 {
        return Err(LearnError::Config(format!(
            "input channels must be 1 or 3, not {c}"
        )));
    }
    let device = crate::device::inference();
    let backbone = Backbone::new(arch, c, &device);
    let (mid, _) = backbone.forward_mid(Tensor::zeros([1, c, h, w], &device));
    let [_, _, gh, gw] = mid.dims();
    Ok([gh, gw])
}

/// A module built by `build` with every parameter initialised from `seed`: the same seed gives
/// the same weights.
///
/// burn's random initialisers draw from one generator per backend, seeded globally, and
/// parameters are initialised lazily on first use. Seeding and forcing every parameter under
/// one lock keeps two models built at the same time (tests, threads) from interleaving their
/// draws.
pub(crate) fn seeded_init<M: Module>(device: &Device, seed: u64, build: impl FnOnce() -> M) -> M {
    static INIT: Mutex<()> = Mutex::new(());
    let _guard = INIT.lock().unwrap_or_else(|e| e.into_inner());
    device.seed(seed);
    let module = build();
    module.visit(&mut Materialize);
    module
}

/// Forces lazily initialised parameters (see [`seeded_init`]).
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
    /// ResNet-18 or ResNet-34.
    ResNet(ResNet),
    /// The GoogLeNet-style network.
    Inception(InceptionNet),
    /// MobileNetV2 (pretrained, frozen) and its trainable reduction.
    MobileNet(MobileNetV2),
}

impl Backbone {
    /// A freshly initialised backbone of `arch` for `channels` input channels.
    pub(crate) fn new(arch: Arch, channels: usize, device: &Device) -> Backbone {
        match arch {
            Arch::Small => Backbone::Small(SmallNet::new(channels, device)),
            Arch::Resnet18 => Backbone::ResNet(ResNet::new(channels, RESNET18_BLOCKS, device)),
            Arch::Resnet34 => Backbone::ResNet(ResNet::new(channels, RESNET34_BLOCKS, device)),
            Arch::Googlenet => Backbone::Inception(InceptionNet::new(channels, device)),
            Arch::Mobilenetv2 => Backbone::MobileNet(MobileNetV2::new(device)),
        }
    }

    pub(crate) fn fold(self) -> Self {
        match self {
            Backbone::Small(n) => Backbone::Small(n.fold()),
            Backbone::ResNet(n) => Backbone::ResNet(n.fold()),
            Backbone::Inception(n) => Backbone::Inception(n.fold()),
            Backbone::MobileNet(n) => Backbone::MobileNet(n.fold()),
        }
    }

    pub(crate) fn forward(&self, x: Tensor<4>) -> Tensor<4> {
        match self {
            Backbone::Small(n) => n.forward(x),
            Backbone::ResNet(n) => n.forward(x),
            Backbone::Inception(n) => n.forward(x),
            Backbone::MobileNet(n) => n.forward(x),
        }
    }

    /// The final map from the stride-8 map.
    pub(crate) fn forward_tail(&self, mid: Tensor<4>) -> Tensor<4> {
        match self {
            Backbone::Small(n) => n.forward_tail(mid),
            Backbone::ResNet(n) => n.forward_tail(mid),
            Backbone::Inception(n) => n.forward_tail(mid),
            Backbone::MobileNet(n) => n.forward_tail(mid),
        }
    }

    /// The stride-8 map and the final map.
    pub(crate) fn forward_mid(&self, x: Tensor<4>) -> (Tensor<4>, Tensor<4>) {
        match self {
            Backbone::Small(n) => n.forward_mid(x),
            Backbone::ResNet(n) => n.forward_mid(x),
            Backbone::Inception(n) => n.forward_mid(x),
            Backbone::MobileNet(n) => n.forward_mid(x),
        }
    }
}

/// One network: backbone, global average pool, optional hidden layer, linear output layer.
#[derive(Module, Debug)]
pub struct Branch {
    backbone: Backbone,
    pool: AdaptiveAvgPool2d,
    hidden: Option<Linear>,
    head: Linear,
}

impl Branch {
    /// A network of `cfg`'s layout whose head also reads `extra` features (the plane
    /// branch's).
    fn new(cfg: &NetConfig, extra: usize, device: &Device) -> Branch {
        let backbone = Backbone::new(cfg.arch, cfg.channels, device);
        let features = cfg.arch.features() + extra;
        let hidden = cfg.head.hidden;
        Branch {
            backbone,
            pool: AdaptiveAvgPool2dConfig::new([1, 1]).init(),
            hidden: (hidden > 0).then(|| LinearConfig::new(features, hidden).init(device)),
            head: LinearConfig::new(
                if hidden > 0 { hidden } else { features },
                cfg.head.outputs(cfg.outputs),
            )
            .init(device),
        }
    }

    fn parts(&self) -> Parts<'_> {
        Parts {
            backbone: &self.backbone,
            pool: &self.pool,
            hidden: &self.hidden,
            head: &self.head,
        }
    }
}

/// The layers of one network, borrowed: a [`Branch`], or the first network, whose layers sit
/// directly in [`PoseNet`] so that its weights keep the names of single-network checkpoints.
struct Parts<'a> {
    backbone: &'a Backbone,
    pool: &'a AdaptiveAvgPool2d,
    hidden: &'a Option<Linear>,
    head: &'a Linear,
}

impl Parts<'_> {
    fn features(&self, x: Tensor<4>) -> Tensor<2> {
        self.pool.forward(self.backbone.forward(x)).flatten(1, 3)
    }

    /// Width of the pooled features.
    fn backbone_width(&self) -> usize {
        match self.hidden {
            Some(hidden) => hidden.weight.dims()[0],
            None => self.head.weight.dims()[0],
        }
    }

    /// Width of the hidden layer, if there is one.
    fn hidden_width(&self) -> Option<usize> {
        self.hidden.as_ref().map(|h| h.weight.dims()[1])
    }

    /// The head on (already masked) features, with `mask` on the hidden layer.
    fn head(&self, x: Tensor<2>, mask: Option<Tensor<2>>) -> Tensor<2> {
        let x = match self.hidden {
            Some(hidden) => {
                let y = relu(hidden.forward(x));
                match mask {
                    Some(mask) => y * mask,
                    None => y,
                }
            }
            None => x,
        };
        self.head.forward(x)
    }
}

/// What the plane branch says of each cell of the stride-8 map.
#[derive(Clone, Debug)]
pub struct PlaneOutputs {
    /// Class logits `[B, PLANE_CLASSES, h, w]`.
    pub classes: Tensor<4>,
    /// Raw plane parameters `[B, PLANE_PARAMS, h, w]`: normal (not normalised), log distance.
    pub params: Tensor<4>,
}

/// A pose-regression network: one network (backbone, pool, optional hidden layer, output
/// layer), or two with [`NetConfig::split`], the second (`Branch`) for the rotation. Each
/// network computes every output and the unused ones are dropped (a few hundred weights, for
/// one code path). Outputs: the position, the rotation, then the scale when the head has one.
#[derive(Module, Debug)]
pub struct PoseNet {
    backbone: Backbone,
    pool: AdaptiveAvgPool2d,
    hidden: Option<Linear>,
    head: Linear,
    planes: Option<PlaneBranch>,
    rotation: Option<Branch>,
    pos_dims: usize,
    rot_dims: usize,
    log_vars: Option<Param<Tensor<1>>>,
}

impl PoseNet {
    /// The first (or only) network.
    fn main(&self) -> Parts<'_> {
        Parts {
            backbone: &self.backbone,
            pool: &self.pool,
            hidden: &self.hidden,
            head: &self.head,
        }
    }

    /// The networks, the rotation network last.
    fn branches(&self) -> impl Iterator<Item = Parts<'_>> {
        std::iter::once(self.main()).chain(self.rotation.as_ref().map(Branch::parts))
    }

    /// The (first) backbone's feature map `[B, F, h, w]` of a batch `[B, C, H, W]`.
    pub fn feature_map(&self, x: Tensor<4>) -> Tensor<4> {
        self.backbone.forward(x)
    }

    /// Pooled features `[B, F]` of a batch `[B, C, H, W]` (with the plane branch, its pooled
    /// features after the backbone's; with two networks, the rotation network's last).
    pub fn features(&self, x: Tensor<4>) -> Tensor<2> {
        self.features_and_planes(x, false).0
    }

    /// [`PoseNet::features`] and, when `outputs` is set and the network has a plane branch,
    /// its class logits and plane parameters ([`PlaneBranch::outputs`]).
    fn features_and_planes(
        &self,
        x: Tensor<4>,
        outputs: bool,
    ) -> (Tensor<2>, Option<PlaneOutputs>) {
        let rotation = self
            .rotation
            .as_ref()
            .map(|r| r.parts().features(x.clone()));
        let (main, planes) = match &self.planes {
            None => (self.main().features(x), None),
            Some(branch) => {
                let (mid, map) = self.backbone.forward_mid(x);
                let plane_map = branch.features(mid);
                let pooled = Tensor::cat(
                    vec![
                        self.pool.forward(map).flatten(1, 3),
                        self.pool.forward(plane_map.clone()).flatten(1, 3),
                    ],
                    1,
                );
                let outputs = outputs.then(|| {
                    let (classes, params) = branch.outputs(plane_map);
                    PlaneOutputs { classes, params }
                });
                (pooled, outputs)
            }
        };
        let features = match rotation {
            None => main,
            Some(rotation) => Tensor::cat(vec![main, rotation], 1),
        };
        (features, planes)
    }

    /// The stride-8 map `[B, F8, h, w]` of the (first) backbone.
    pub(crate) fn mid_map(&self, x: Tensor<4>) -> Tensor<4> {
        self.backbone.forward_mid(x).0
    }

    /// The outputs from the first backbone's stride-8 map `mid` (and, with two networks, the
    /// input `x` for the rotation network), without dropout: Grad-CAM differentiates them
    /// with respect to `mid` or to the final map on the way.
    pub(crate) fn forward_from_mid(
        &self,
        mid: Tensor<4>,
        x: Tensor<4>,
        last: &mut dyn FnMut(Tensor<4>) -> Tensor<4>,
    ) -> Tensor<2> {
        let map = last(self.backbone.forward_tail(mid.clone()));
        let mut parts = vec![self.pool.forward(map).flatten(1, 3)];
        if let Some(branch) = &self.planes {
            parts.push(self.pool.forward(branch.features(mid)).flatten(1, 3));
        }
        if let Some(rotation) = &self.rotation {
            parts.push(rotation.parts().features(x));
        }
        self.head_plain(Tensor::cat(parts, 1))
    }

    /// The first network's hidden layer (if any) and output layer.
    #[cfg(test)]
    pub(crate) fn head_layers(&self) -> (Option<&Linear>, &Linear) {
        (self.hidden.as_ref(), &self.head)
    }

    /// Position outputs (the first ones).
    pub(crate) fn pos_dims(&self) -> usize {
        self.pos_dims
    }

    /// The head applied to features `[B, F] -> [B, outputs]`, with dropout of probability `p`
    /// on the features and on the hidden layers, masks drawn from `rng` row by row
    /// (`mc::row_masks`); `p = 0` draws nothing.
    pub fn head(&self, features: Tensor<2>, p: f64, rng: &mut ChaCha8Rng) -> Tensor<2> {
        let [rows, width] = features.dims();
        if p <= 0.0 {
            return self.head_plain(features);
        }
        let masks = mc::row_masks(rows, &self.mask_widths(width), p, rng, &features.device());
        self.head_masked(features, masks)
    }

    /// `passes` stochastic head outputs per row of pooled `features` `[B, F]`:
    /// `[B * passes, outputs]`, rows `b * passes .. (b + 1) * passes` belonging to image `b`,
    /// seen through the ensemble of `seed` (`mc::ensemble_masks`). Only the features are
    /// repeated and sent through the masked head; the backbone ran once.
    pub fn mc_head(&self, features: Tensor<2>, passes: usize, p: f64, seed: u64) -> Tensor<2> {
        let [b, f] = features.dims();
        let repeated = features
            .unsqueeze_dim::<3>(1)
            .repeat_dim(1, passes)
            .reshape([b * passes, f]);
        let masks = mc::ensemble_masks(passes, &self.mask_widths(f), p, seed, &repeated.device())
            .into_iter()
            .map(|m| m.repeat_dim(0, b))
            .collect();
        self.head_masked(repeated, masks)
    }

    /// The head without dropout.
    pub fn head_plain(&self, features: Tensor<2>) -> Tensor<2> {
        self.head_masked(features, Vec::new())
    }

    /// Widths of the head's dropout masks for features `width` wide: the features', then each
    /// hidden layer's.
    pub(crate) fn mask_widths(&self, width: usize) -> Vec<usize> {
        let mut widths = vec![width];
        widths.extend(self.branches().filter_map(|b| b.hidden_width()));
        widths
    }

    /// The head with `masks` (none, or one for the features then one per hidden layer).
    pub(crate) fn head_masked(&self, features: Tensor<2>, masks: Vec<Tensor<2>>) -> Tensor<2> {
        let mut masks = masks.into_iter();
        let features = match masks.next() {
            Some(mask) => features * mask,
            None => features,
        };
        let main = self.main();
        let Some(rotation) = &self.rotation else {
            return main.head(features, masks.next());
        };
        let split = main.backbone_width();
        let [_, width] = features.dims();
        let pos = main.head(features.clone().narrow(1, 0, split), masks.next());
        let rot = rotation
            .parts()
            .head(features.narrow(1, split, width - split), masks.next());
        let [_, outputs] = pos.dims();
        let (d, r) = (self.pos_dims, self.rot_dims);
        let mut parts = vec![pos.clone().narrow(1, 0, d), rot.narrow(1, d, r)];
        if outputs > d + r {
            parts.push(pos.narrow(1, d + r, outputs - d - r));
        }
        Tensor::cat(parts, 1)
    }

    /// Outputs without dropout, `[B, C, H, W] -> [B, outputs]`.
    pub fn forward(&self, x: Tensor<4>) -> Tensor<2> {
        self.head_plain(self.features(x))
    }

    /// Outputs with dropout of probability `p` in the head, masks drawn row by row (see
    /// [`PoseNet::head`]).
    pub fn forward_dropout(&self, x: Tensor<4>, p: f64, rng: &mut ChaCha8Rng) -> Tensor<2> {
        self.head(self.features(x), p, rng)
    }

    /// [`PoseNet::forward_dropout`] and the plane branch's outputs (none without a branch),
    /// for training.
    pub fn forward_dropout_planes(
        &self,
        x: Tensor<4>,
        p: f64,
        rng: &mut ChaCha8Rng,
    ) -> (Tensor<2>, Option<PlaneOutputs>) {
        let (features, planes) = self.features_and_planes(x, true);
        (self.head(features, p, rng), planes)
    }

    /// The plane branch's outputs of a batch (none without a branch).
    pub fn plane_outputs(&self, x: Tensor<4>) -> Option<PlaneOutputs> {
        self.planes.as_ref()?;
        self.features_and_planes(x, true).1
    }

    /// The network with every BatchNorm folded into its convolution (see `conv.rs`): the same
    /// outputs in evaluation mode, faster. For inference only; never train or save the result.
    pub fn fold_batchnorm(self) -> Self {
        PoseNet {
            backbone: self.backbone.fold(),
            planes: self.planes.map(PlaneBranch::fold),
            rotation: self.rotation.map(|b| Branch {
                backbone: b.backbone.fold(),
                ..b
            }),
            ..self
        }
    }

    /// The network with the pretrained backbone's weights read from `path` (see
    /// `MobileNetV2::load_torchvision`); other backbones have none and are refused.
    pub fn load_pretrained(self, path: &std::path::Path, device: &Device) -> Result<Self> {
        if self.rotation.is_some() || self.planes.is_some() {
            return Err(LearnError::Config(
                "a pretrained backbone takes neither a split network nor a plane branch".into(),
            ));
        }
        match self.backbone {
            Backbone::MobileNet(n) => Ok(PoseNet {
                backbone: Backbone::MobileNet(n.load_torchvision(path, device)?),
                ..self
            }),
            _ => Err(LearnError::Config(
                "only a pretrained backbone loads pretrained weights".into(),
            )),
        }
    }

    /// The frozen pretrained layers' maps of a batch of images (see `net/mobilenet.rs`), which
    /// [`PoseNet::forward`] also takes in place of the images; `None` when nothing is frozen.
    pub fn frozen_maps(&self, x: Tensor<4>) -> Option<Tensor<4>> {
        match &self.backbone {
            Backbone::MobileNet(n) => Some(n.frozen(x)),
            _ => None,
        }
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

    /// The values of a network's outputs.
    fn values(y: Tensor<2>) -> Result<Vec<f32>> {
        y.into_data()
            .try_to_vec::<f32>()
            .map_err(|e| LearnError::Input(format!("{e:?}")))
    }

    fn config(arch: Arch, channels: usize) -> NetConfig {
        NetConfig {
            arch,
            channels,
            outputs: 7,
            learned_weighting: false,
            head: HeadConfig::default(),
            split: false,
            planes: false,
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
        // torchvision's resnet34 has 21,797,672 with 3 channels and 1000 classes: less the
        // classifier (513,000) and two stem input channels (6,272), plus a 7-output head.
        assert_eq!(
            config(Arch::Resnet34, 1)
                .init(&device, 0)?
                .trainable_params(),
            21_281_991
        );
        // The same layers built in PyTorch (BN after every conv, 5x5 branches): 1,048,704 in
        // the body, plus the head.
        assert_eq!(
            config(Arch::Googlenet, 1)
                .init(&device, 0)?
                .trainable_params(),
            1_052_295
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
        let googlenet = config(Arch::Googlenet, 1).init(&device, 0)?.valid();
        let y = googlenet.forward(Tensor::zeros([2, 1, 60, 80], &device));
        assert_eq!(y.dims(), [2, 7]);
        // Max pools round up as PyTorch's ceil_mode: the same layers there give
        // [1, 512, 7, 10] and [2, 512, 3, 5].
        let map = |h, w, b| {
            googlenet
                .feature_map(Tensor::zeros([b, 1, h, w], &device))
                .dims()
        };
        assert_eq!(map(120, 160, 1), [1, 512, 7, 10]);
        assert_eq!(map(60, 80, 2), [2, 512, 3, 5]);
        let head = NetConfig {
            head: HeadConfig {
                hidden: 16,
                aleatoric: true,
            },
            ..config(Arch::Small, 1)
        }
        .init(&device, 0)?
        .valid();
        let y = head.forward(Tensor::zeros([3, 1, 32, 32], &device));
        assert_eq!(y.dims(), [3, 8]);
        // Two networks: the same outputs, twice the weights.
        let split = NetConfig {
            outputs: 4,
            head: HeadConfig {
                hidden: 16,
                aleatoric: true,
            },
            split: true,
            ..config(Arch::Small, 1)
        };
        let single = NetConfig {
            split: false,
            ..split.clone()
        };
        let net = split.init(&device, 0)?;
        assert_eq!(
            net.trainable_params(),
            2 * single.init(&device, 0)?.trainable_params()
        );
        let net = net.valid();
        let x = Tensor::zeros([2, 1, 32, 32], &device);
        assert_eq!(net.features(x.clone()).dims(), [2, 2 * 256]);
        assert_eq!(net.forward(x.clone()).dims(), [2, 5]);
        let features = net.features(x);
        assert_eq!(net.mc_head(features, 3, 0.2, 1).dims(), [6, 5]);
        assert!(config(Arch::Small, 2).init(&device, 0).is_err());
        Ok(())
    }

    #[test]
    fn initialisation_follows_the_seed() -> Result<()> {
        let device = Device::flex();
        let x = Tensor::<4>::ones([1, 1, 32, 32], &device);
        let out = |seed| -> Result<Vec<f32>> {
            let net = config(Arch::Small, 1).init(&device, seed)?.valid();
            values(net.forward(x.clone()))
        };
        assert_eq!(out(3)?, out(3)?);
        assert_ne!(out(3)?, out(4)?);
        Ok(())
    }

    #[test]
    fn folded_batchnorm_gives_the_same_outputs() -> Result<()> {
        let train = Device::flex().autodiff();
        let x = |device: &Device, c: usize| {
            let v: Vec<f32> = (0..2 * c * 24 * 32)
                .map(|i| ((i * 37) % 101) as f32 / 50.0 - 1.0)
                .collect();
            Tensor::<4>::from_data(burn::tensor::TensorData::new(v, [2, c, 24, 32]), device)
        };
        for arch in Arch::ALL {
            // A pretrained backbone takes colour only.
            let c = if arch.pretrained() { 3 } else { 1 };
            let net = NetConfig {
                split: arch == Arch::Small,
                ..config(arch, c)
            }
            .init(&train, 1)?;
            // Training-mode passes move the running statistics away from (0, 1).
            for _ in 0..3 {
                let _ = net.forward(x(&train, c) * 3.0 + 0.5);
            }
            let plain = net.valid();
            let device = Device::flex();
            let want = values(plain.forward(x(&device, c)))?;
            let got = values(plain.fold_batchnorm().forward(x(&device, c)))?;
            let fresh = NetConfig {
                split: arch == Arch::Small,
                ..config(arch, c)
            }
            .init(&device, 1)?;
            let fresh = values(fresh.forward(x(&device, c)))?;
            assert_ne!(want, fresh, "{arch}: the running statistics moved");
            assert_eq!(want.len(), got.len());
            for (a, b) in want.iter().zip(&got) {
                assert!(
                    (a - b).abs() <= 1e-4 * (1.0 + a.abs()),
                    "{arch}: {a} vs {b}"
                );
            }
        }
        Ok(())
    }

    #[test]
    fn names_parse() -> Result<()> {
        for arch in Arch::ALL {
            assert_eq!(arch.name().parse::<Arch>()?, arch);
        }
        assert!("vgg".parse::<Arch>().is_err());
        Ok(())
    }
}
