//! ResNet-18 and ResNet-34 in torchvision's layout (BasicBlock, `[2, 2, 2, 2]` and
//! `[3, 4, 6, 3]`; ResNet-18 as `torch_apr.py --arch resnet18`): a `7x7/2` stem, `3x3/2` max
//! pool, four stages of basic blocks, 512 features.

use burn::module::Module;
use burn::nn::PaddingConfig2d;
use burn::nn::pool::{MaxPool2d, MaxPool2dConfig};
use burn::tensor::activation::relu;
use burn::tensor::{Device, Tensor};

use super::conv::ConvBn;

/// Output channels and stride of the first block of each stage.
const STAGES: [(usize, usize); 4] = [(64, 1), (128, 2), (256, 2), (512, 2)];

/// Basic blocks per stage of ResNet-18.
pub const RESNET18_BLOCKS: [usize; 4] = [2, 2, 2, 2];
/// Basic blocks per stage of ResNet-34.
pub const RESNET34_BLOCKS: [usize; 4] = [3, 4, 6, 3];

/// Features after the last stage.
pub const RESNET_FEATURES: usize = 512;

/// torchvision's BasicBlock: two `3x3` conv + BN, the shortcut added before the last ReLU; a
/// `1x1` conv + BN shortcut ("downsample") where the shape changes.
#[derive(Module, Debug)]
pub struct BasicBlock {
    conv1: ConvBn,
    conv2: ConvBn,
    downsample: Option<ConvBn>,
}

impl BasicBlock {
    fn new(cin: usize, cout: usize, stride: usize, device: &Device) -> Self {
        let downsample =
            (stride != 1 || cin != cout).then(|| ConvBn::new(cin, cout, 1, stride, 0, device));
        BasicBlock {
            conv1: ConvBn::new(cin, cout, 3, stride, 1, device),
            conv2: ConvBn::new(cout, cout, 3, 1, 1, device),
            downsample,
        }
    }

    fn fold(self) -> Self {
        BasicBlock {
            conv1: self.conv1.fold(),
            conv2: self.conv2.fold(),
            downsample: self.downsample.map(ConvBn::fold),
        }
    }

    fn forward(&self, x: Tensor<4>) -> Tensor<4> {
        let y = self.conv2.forward(self.conv1.forward_relu(x.clone()));
        let shortcut = match &self.downsample {
            Some(d) => d.forward(x),
            None => x,
        };
        relu(y + shortcut)
    }
}

/// The ResNet body (pooling and head live in [`super::PoseNet`]).
#[derive(Module, Debug)]
pub struct ResNet {
    stem: ConvBn,
    pool: MaxPool2d,
    blocks: Vec<BasicBlock>,
    /// Blocks up to the end of the second stage (the stride-8 map).
    mid_blocks: usize,
}

/// Channels of the stride-8 map (after the second stage).
pub const RESNET_MID_CHANNELS: usize = STAGES[1].0;

impl ResNet {
    /// A ResNet with `per_stage` basic blocks in each of the four stages
    /// ([`RESNET18_BLOCKS`], [`RESNET34_BLOCKS`]) for `channels` input channels.
    pub fn new(channels: usize, per_stage: [usize; 4], device: &Device) -> Self {
        let mut blocks = Vec::with_capacity(per_stage.iter().sum());
        let mut cin = 64;
        for ((cout, stride), count) in STAGES.into_iter().zip(per_stage) {
            blocks.push(BasicBlock::new(cin, cout, stride, device));
            for _ in 1..count {
                blocks.push(BasicBlock::new(cout, cout, 1, device));
            }
            cin = cout;
        }
        ResNet {
            stem: ConvBn::new(channels, 64, 7, 2, 3, device),
            pool: MaxPool2dConfig::new([3, 3])
                .with_strides([2, 2])
                .with_padding(PaddingConfig2d::Explicit(1, 1, 1, 1))
                .init(),
            blocks,
            mid_blocks: per_stage[0] + per_stage[1],
        }
    }

    /// The body with every BatchNorm folded ([`ConvBn::fold`]).
    pub fn fold(self) -> Self {
        ResNet {
            stem: self.stem.fold(),
            pool: self.pool,
            blocks: self.blocks.into_iter().map(BasicBlock::fold).collect(),
            mid_blocks: self.mid_blocks,
        }
    }

    /// `[B, C, H, W] -> [B, 512, H/32, W/32]` (sizes rounded up at each stride).
    pub fn forward(&self, x: Tensor<4>) -> Tensor<4> {
        self.forward_mid(x).1
    }

    /// The rest of the body from the stride-8 map of [`ResNet::forward_mid`].
    pub fn forward_tail(&self, mut x: Tensor<4>) -> Tensor<4> {
        for block in &self.blocks[self.mid_blocks.min(self.blocks.len())..] {
            x = block.forward(x);
        }
        x
    }

    /// The stride-8 map (after the second stage, 128 channels) and the output of
    /// [`ResNet::forward`].
    pub fn forward_mid(&self, x: Tensor<4>) -> (Tensor<4>, Tensor<4>) {
        let mut x = self.pool.forward(self.stem.forward_relu(x));
        let (head, tail) = self.blocks.split_at(self.mid_blocks.min(self.blocks.len()));
        for block in head {
            x = block.forward(x);
        }
        let mid = x.clone();
        for block in tail {
            x = block.forward(x);
        }
        (mid, x)
    }
}
