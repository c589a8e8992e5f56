//! MobileNetV2 in torchvision's layout (Sandler et al., CVPR 2018), loaded with torchvision's
//! ImageNet weights ([`MobileNetV2::load_torchvision`]): the backbone for real photos.
//!
//! Pose regression from scratch on a thousand real frames learns little more than which image
//! it is looking at; ImageNet features are the usual start (PoseNet, MapNet and the rest fine-
//! tune a pretrained backbone). On a CPU, fine-tuning 3.5 M weights through depthwise
//! convolutions is slow, so the pretrained layers stay frozen and only a small trainable part
//! learns: a `1x1` conv + BatchNorm + ReLU to 32 channels on the stride-32 map (1280 channels),
//! average-pooled to a fixed [`MOBILENET_GRID`] and flattened, so the head still sees *where*
//! things are in the image (global pooling throws that away; measured in ARCHITECTURE.md, "Real
//! data"). The flattened map is returned as a `[B, F, 1, 1]` map, so the network's global
//! pooling passes it through unchanged.
//!
//! Training computes the frozen layers once per frame and feeds their maps (1280 channels,
//! [`MOBILENET_CUT_CHANNELS`]) back in: [`MobileNetV2::forward`] takes either an image or such a
//! map, told apart by the channel count (an image has 3).

use std::path::Path;

use burn::module::Module;
use burn::nn::pool::{AdaptiveAvgPool2d, AdaptiveAvgPool2dConfig};
use burn::tensor::activation::{relu, relu6};
use burn::tensor::{Device, Tensor, TensorData};
use burn_store::pytorch_reader::{DType, PytorchReader};

use super::conv::ConvBn;
use crate::{LearnError, Result};

/// Inverted-residual settings `(expansion t, channels c, repeats n, first stride s)`, torchvision's
/// `inverted_residual_setting`.
const SETTINGS: [(usize, usize, usize, usize); 7] = [
    (1, 16, 1, 1),
    (6, 24, 2, 2),
    (6, 32, 3, 2),
    (6, 64, 4, 2),
    (6, 96, 3, 1),
    (6, 160, 3, 2),
    (6, 320, 1, 1),
];

/// Channels of the stem.
const STEM: usize = 32;

/// Channels of the last pretrained layer (`features.18`): where training caches the maps.
pub const MOBILENET_CUT_CHANNELS: usize = 1280;

/// Channels of the trainable `1x1` reduction.
const REDUCED: usize = 32;

/// The reduced map is average-pooled to this `[rows, columns]` grid (the stride-32 map of a
/// 320x240 image, so there pooling changes nothing).
pub const MOBILENET_GRID: [usize; 2] = [8, 10];

/// Width of the flattened features the head reads.
pub const MOBILENET_FEATURES: usize = REDUCED * MOBILENET_GRID[0] * MOBILENET_GRID[1];

/// Blocks up to the stride-8 map (torchvision's `features.1` to `features.6`).
const MID_BLOCKS: usize = 6;

/// Channels of the stride-8 map.
pub const MOBILENET_MID_CHANNELS: usize = 32;

/// One inverted residual: `1x1` expansion (absent when `t = 1`), `3x3` depthwise, `1x1`
/// linear projection, the input added back when the shape allows.
#[derive(Module, Debug)]
pub struct InvertedResidual {
    expand: Option<ConvBn>,
    depthwise: ConvBn,
    project: ConvBn,
    residual: bool,
}

impl InvertedResidual {
    fn new(cin: usize, cout: usize, stride: usize, t: usize, device: &Device) -> Self {
        let hidden = cin * t;
        InvertedResidual {
            expand: (t != 1).then(|| ConvBn::new(cin, hidden, 1, 1, 0, device)),
            depthwise: ConvBn::grouped(hidden, hidden, 3, stride, 1, hidden, device),
            project: ConvBn::new(hidden, cout, 1, 1, 0, device),
            residual: stride == 1 && cin == cout,
        }
    }

    fn fold(self) -> Self {
        InvertedResidual {
            expand: self.expand.map(ConvBn::fold),
            depthwise: self.depthwise.fold(),
            project: self.project.fold(),
            residual: self.residual,
        }
    }

    fn forward(&self, x: Tensor<4>) -> Tensor<4> {
        let y = match &self.expand {
            Some(expand) => relu6(expand.forward(x.clone())),
            None => x.clone(),
        };
        let y = self.project.forward(relu6(self.depthwise.forward(y)));
        if self.residual { y + x } else { y }
    }
}

/// MobileNetV2's body (torchvision's `features`) and the trainable reduction.
#[derive(Module, Debug)]
pub struct MobileNetV2 {
    stem: ConvBn,
    blocks: Vec<InvertedResidual>,
    last: ConvBn,
    reduce: ConvBn,
    grid: AdaptiveAvgPool2d,
}

impl MobileNetV2 {
    /// The network with fresh weights (load the pretrained ones with
    /// [`MobileNetV2::load_torchvision`]).
    pub fn new(device: &Device) -> Self {
        let mut blocks = Vec::new();
        let mut cin = STEM;
        for (t, c, n, s) in SETTINGS {
            for i in 0..n {
                blocks.push(InvertedResidual::new(
                    cin,
                    c,
                    if i == 0 { s } else { 1 },
                    t,
                    device,
                ));
                cin = c;
            }
        }
        MobileNetV2 {
            stem: ConvBn::new(3, STEM, 3, 2, 1, device),
            blocks,
            last: ConvBn::new(cin, MOBILENET_CUT_CHANNELS, 1, 1, 0, device),
            reduce: ConvBn::new(MOBILENET_CUT_CHANNELS, REDUCED, 1, 1, 0, device),
            grid: AdaptiveAvgPool2dConfig::new(MOBILENET_GRID).init(),
        }
    }

    /// The body with every BatchNorm folded ([`ConvBn::fold`]).
    pub fn fold(self) -> Self {
        MobileNetV2 {
            stem: self.stem.fold(),
            blocks: self
                .blocks
                .into_iter()
                .map(InvertedResidual::fold)
                .collect(),
            last: self.last.fold(),
            reduce: self.reduce.fold(),
            grid: self.grid,
        }
    }

    /// The pretrained layers: `[B, 3, H, W] -> [B, 1280, H/32, W/32]` (torchvision's
    /// `features(x)`; inputs normalised with ImageNet's mean and deviation).
    pub fn frozen(&self, x: Tensor<4>) -> Tensor<4> {
        self.frozen_tail(self.frozen_mid(x))
    }

    fn frozen_mid(&self, x: Tensor<4>) -> Tensor<4> {
        let mut x = relu6(self.stem.forward(x));
        for block in &self.blocks[..MID_BLOCKS] {
            x = block.forward(x);
        }
        x
    }

    fn frozen_tail(&self, mut x: Tensor<4>) -> Tensor<4> {
        for block in &self.blocks[MID_BLOCKS..] {
            x = block.forward(x);
        }
        relu6(self.last.forward(x))
    }

    /// The trainable part on a map at the cut: `[B, 1280, h, w] -> [B, F, 1, 1]`.
    fn trainable(&self, cut: Tensor<4>) -> Tensor<4> {
        let y = self.grid.forward(relu(self.reduce.forward(cut)));
        let [b, c, h, w] = y.dims();
        y.reshape([b, c * h * w, 1, 1])
    }

    /// `[B, 3, H, W]` images, or `[B, 1280, h, w]` maps from [`MobileNetV2::frozen`], to the
    /// flattened features `[B, MOBILENET_FEATURES, 1, 1]`.
    pub fn forward(&self, x: Tensor<4>) -> Tensor<4> {
        if x.dims()[1] == MOBILENET_CUT_CHANNELS {
            self.trainable(x)
        } else {
            self.trainable(self.frozen(x))
        }
    }

    /// The rest from the stride-8 map of [`MobileNetV2::forward_mid`].
    pub fn forward_tail(&self, mid: Tensor<4>) -> Tensor<4> {
        self.trainable(self.frozen_tail(mid))
    }

    /// The stride-8 map (32 channels) and the output of [`MobileNetV2::forward`].
    pub fn forward_mid(&self, x: Tensor<4>) -> (Tensor<4>, Tensor<4>) {
        let mid = self.frozen_mid(x);
        (mid.clone(), self.forward_tail(mid))
    }

    /// The pretrained layers with the values of torchvision's `mobilenet_v2` state dict in
    /// `path` (`features.*`; the classifier is not used). Every tensor must be there with the
    /// layer's shape, in float32.
    pub fn load_torchvision(self, path: &Path, device: &Device) -> Result<Self> {
        let bad = |msg: String| LearnError::Input(format!("{}: {msg}", path.display()));
        let reader = PytorchReader::new(path).map_err(|e| bad(e.to_string()))?;
        let tensor = |key: &str, shape: &[usize]| -> Result<TensorData> {
            let t = reader.get(key).ok_or_else(|| {
                bad(format!(
                    "no tensor '{key}' (not a torchvision MobileNetV2?)"
                ))
            })?;
            if t.shape() != shape || t.dtype() != DType::F32 {
                return Err(bad(format!(
                    "'{key}' is {:?} {:?}, expected F32 {shape:?}",
                    t.dtype(),
                    t.shape()
                )));
            }
            let bytes = t.read().map_err(|e| bad(e.to_string()))?;
            let values: Vec<f32> = bytes
                .chunks_exact(4)
                .map(|b| f32::from_ne_bytes([b[0], b[1], b[2], b[3]]))
                .collect();
            Ok(TensorData::new(values, shape.to_vec()))
        };
        let conv_bn = |layer: ConvBn, conv: &str, bn: &str| -> Result<ConvBn> {
            let shape = layer.weight_shape();
            let weight = Tensor::<4>::from_data(tensor(&format!("{conv}.weight"), &shape)?, device);
            let vector = |name: &str| -> Result<Tensor<1>> {
                Ok(Tensor::from_data(
                    tensor(&format!("{bn}.{name}"), &[shape[0]])?,
                    device,
                ))
            };
            Ok(layer.with_values(
                weight,
                [
                    vector("weight")?,
                    vector("bias")?,
                    vector("running_mean")?,
                    vector("running_var")?,
                ],
            ))
        };
        let stem = conv_bn(self.stem, "features.0.0", "features.0.1")?;
        let mut blocks = Vec::with_capacity(self.blocks.len());
        for (i, block) in self.blocks.into_iter().enumerate() {
            let p = format!("features.{}.conv", i + 1);
            // torchvision numbers the sequence `[expand (conv, bn)], [depthwise (conv, bn)],
            // project conv, project bn`.
            let (expand, first) = match block.expand {
                Some(expand) => (
                    Some(conv_bn(expand, &format!("{p}.0.0"), &format!("{p}.0.1"))?),
                    1,
                ),
                None => (None, 0),
            };
            let depthwise = conv_bn(
                block.depthwise,
                &format!("{p}.{first}.0"),
                &format!("{p}.{first}.1"),
            )?;
            let project = conv_bn(
                block.project,
                &format!("{p}.{}", first + 1),
                &format!("{p}.{}", first + 2),
            )?;
            blocks.push(InvertedResidual {
                expand,
                depthwise,
                project,
                residual: block.residual,
            });
        }
        let last = conv_bn(self.last, "features.18.0", "features.18.1")?;
        Ok(MobileNetV2 {
            stem,
            blocks,
            last,
            reduce: self.reduce,
            grid: self.grid,
        })
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    /// A state dict without the expected tensors is refused with the file named.
    #[test]
    fn a_file_of_other_weights_is_refused() {
        let dir = tempfile::tempdir().unwrap();
        let path = dir.path().join("other.pth");
        std::fs::write(&path, b"PK not a checkpoint").unwrap();
        let device = Device::flex();
        let err = MobileNetV2::new(&device)
            .load_torchvision(&path, &device)
            .unwrap_err()
            .to_string();
        assert!(err.contains("other.pth"), "{err}");
    }
}
