//! Convolution + BatchNorm, the building block both backbones share (PyTorch's
//! `Conv2d(bias=False)` followed by `BatchNorm2d`), so that layer counts and parameter counts
//! match `torch_apr.py` one for one.

use burn::module::{Initializer, Module};
use burn::nn::conv::{Conv2d, Conv2dConfig};
use burn::nn::{BatchNorm, BatchNormConfig, PaddingConfig2d};
use burn::tensor::{Device, Tensor};

/// A bias-free `k x k` convolution with stride and symmetric padding, then BatchNorm
/// (eps 1e-5, momentum 0.1, as PyTorch). The ReLU is left to the caller because residual blocks
/// add the shortcut before it.
#[derive(Module, Debug)]
pub struct ConvBn {
    conv: Conv2d,
    bn: BatchNorm,
}

impl ConvBn {
    /// `cin -> cout`, kernel `k`, stride `s`, padding `p`. Weights are Kaiming-normal with
    /// fan-out and ReLU gain, torchvision's initialisation.
    pub fn new(cin: usize, cout: usize, k: usize, s: usize, p: usize, device: &Device) -> Self {
        let conv = Conv2dConfig::new([cin, cout], [k, k])
            .with_stride([s, s])
            .with_padding(PaddingConfig2d::Explicit(p, p, p, p))
            .with_bias(false)
            .with_initializer(Initializer::KaimingNormal {
                gain: std::f64::consts::SQRT_2,
                fan_out_only: true,
            })
            .init(device);
        let bn = BatchNormConfig::new(cout).init(device);
        ConvBn { conv, bn }
    }

    /// Convolution then BatchNorm (batch statistics on an autodiff device in training mode,
    /// running statistics otherwise).
    pub fn forward(&self, x: Tensor<4>) -> Tensor<4> {
        self.bn.forward(self.conv.forward(x))
    }
}
