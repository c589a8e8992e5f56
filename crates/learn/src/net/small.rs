//! The small default network: five stride-2 `3x3` conv + BN + ReLU stages, 32-64-128-256-256
//! channels, exactly `torch_apr.py --arch small` (980,455 parameters with a 7-output head on one
//! input channel), so its speed can be compared with PyTorch's like for like.

use burn::module::Module;
use burn::tensor::activation::relu;
use burn::tensor::{Device, Tensor};

use super::conv::ConvBn;

/// Channels of the five stages.
pub const SMALL_CHANNELS: [usize; 5] = [32, 64, 128, 256, 256];

/// The convolutional body of the small network (pooling and head live in
/// [`super::PoseNet`]).
#[derive(Module, Debug)]
pub struct SmallNet {
    stages: Vec<ConvBn>,
}

impl SmallNet {
    /// The body for `channels` input channels.
    pub fn new(channels: usize, device: &Device) -> Self {
        let mut cin = channels;
        let stages = SMALL_CHANNELS
            .iter()
            .map(|&cout| {
                let stage = ConvBn::new(cin, cout, 3, 2, 1, device);
                cin = cout;
                stage
            })
            .collect();
        SmallNet { stages }
    }

    /// The body with every BatchNorm folded ([`ConvBn::fold`]).
    pub fn fold(self) -> Self {
        SmallNet {
            stages: self.stages.into_iter().map(ConvBn::fold).collect(),
        }
    }

    /// `[B, C, H, W] -> [B, 256, H/32, W/32]` (sizes rounded up at each stage).
    pub fn forward(&self, mut x: Tensor<4>) -> Tensor<4> {
        for stage in &self.stages {
            x = relu(stage.forward(x));
        }
        x
    }
}
