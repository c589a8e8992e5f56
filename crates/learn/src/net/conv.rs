//! Convolution + BatchNorm, the building block every backbone shares (PyTorch's
//! `Conv2d(bias=False)` followed by `BatchNorm2d`), so that layer counts and parameter counts
//! match `torch_apr.py` one for one.
//!
//! For inference the BatchNorm is folded into the convolution ([`ConvBn::fold`]): with running
//! statistics it is an affine map per channel, `γ·(y − μ)/√(σ² + ε) + β`, so scaling each
//! output channel's kernel by `γ/√(σ² + ε)` and adding the bias `β − μ·γ/√(σ² + ε)` gives the
//! same outputs with one pass over the feature map instead of two.

use burn::module::{Initializer, Module, Param};
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
    /// The BatchNorm has been folded into `conv` and is skipped. Never saved: folding happens
    /// after loading, for inference only.
    folded: bool,
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
        ConvBn {
            conv,
            bn,
            folded: false,
        }
    }

    /// The same layer with the BatchNorm's running statistics folded into the convolution's
    /// weights and bias (see the module docs); for a network in evaluation mode.
    pub fn fold(mut self) -> Self {
        if self.folded {
            return self;
        }
        let bn = &self.bn;
        let scale = bn.gamma.val() / bn.running_var.value().add_scalar(bn.epsilon).sqrt();
        let bias = bn.beta.val() - bn.running_mean.value() * scale.clone();
        let bias = match &self.conv.bias {
            Some(b) => bias + b.val() * scale.clone(),
            None => bias,
        };
        let [cout, ..] = self.conv.weight.dims();
        let weight = self.conv.weight.val() * scale.reshape([cout, 1, 1, 1]);
        // Detached: on an autodiff device the folded weights are new leaves (a parameter must
        // be one), not the end of a graph through the BatchNorm's statistics.
        self.conv.weight = Param::from_tensor(weight.detach());
        self.conv.bias = Some(Param::from_tensor(bias.detach()));
        self.folded = true;
        self
    }

    /// Convolution then BatchNorm (batch statistics on an autodiff device in training mode,
    /// running statistics otherwise).
    pub fn forward(&self, x: Tensor<4>) -> Tensor<4> {
        if self.folded {
            self.conv.forward(x)
        } else {
            self.bn.forward(self.conv.forward(x))
        }
    }
}
