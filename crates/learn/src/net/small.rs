//! The small default network: five stride-2 `3x3` conv + BN + ReLU stages, 32-64-128-256-256
//! channels, exactly `torch_apr.py --arch small` (980,455 parameters with a 7-output head on one
//! input channel), so its speed can be compared with PyTorch's like for like.

use burn::module::Module;
use burn::tensor::{Device, Tensor};

use super::conv::ConvBn;

/// Channels of the five stages.
pub const SMALL_CHANNELS: [usize; 5] = [32, 64, 128, 256, 256];

/// Stages before the stride-8 map [`SmallNet::forward_mid`] returns.
const MID_STAGES: usize = 3;

/// Channels of the stride-8 map.
pub const SMALL_MID_CHANNELS: usize = SMALL_CHANNELS[MID_STAGES - 1];

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
    pub fn forward(&self, x: Tensor<4>) -> Tensor<4> {
        self.forward_mid(x).1
    }

    /// The rest of the body from the stride-8 map of [`SmallNet::forward_mid`].
    pub fn forward_tail(&self, mut x: Tensor<4>) -> Tensor<4> {
        for stage in &self.stages[MID_STAGES..] {
            x = stage.forward_relu(x);
        }
        x
    }

    /// The stride-8 map (after the third stage, 128 channels) and the output of
    /// [`SmallNet::forward`].
    pub fn forward_mid(&self, mut x: Tensor<4>) -> (Tensor<4>, Tensor<4>) {
        let (head, tail) = self.stages.split_at(MID_STAGES);
        for stage in head {
            x = stage.forward_relu(x);
        }
        let mid = x.clone();
        for stage in tail {
            x = stage.forward_relu(x);
        }
        (mid, x)
    }
}
