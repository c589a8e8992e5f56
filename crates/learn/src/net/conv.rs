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
use burn::tensor::activation::relu;
use burn::tensor::{Device, Tensor};

use crate::kernels;

/// A bias-free `k x k` convolution with stride and symmetric padding, then BatchNorm
/// (eps 1e-5, momentum 0.1, as PyTorch). [`ConvBn::forward_relu`] adds the ReLU (fused into the
/// BatchNorm in training); residual blocks call [`ConvBn::forward`] and add the shortcut first.
///
/// On `flex` the convolution runs on [`crate::kernels`]: in training with the BatchNorm, folded
/// for inference with the bias and ReLU fused into the pass that writes the output. Otherwise both run on burn's own ops. At one image
/// the kernels take half the time of burn's convolution (`bench infer`, one thread, the same
/// runs alternated: 2.8–3.2 ms against 5.0–5.5 ms at 1x120x160, 9.4–10.3 ms against 21–22 ms
/// at 3x256x256).
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
        Self::grouped(cin, cout, k, s, p, 1, device)
    }

    /// [`ConvBn::new`] with `groups` groups (`groups = cin = cout`: a depthwise convolution).
    /// Grouped layers run on burn's convolution; the kernels take one group only.
    pub fn grouped(
        cin: usize,
        cout: usize,
        k: usize,
        s: usize,
        p: usize,
        groups: usize,
        device: &Device,
    ) -> Self {
        let conv = Conv2dConfig::new([cin, cout], [k, k])
            .with_groups(groups)
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

    /// The layer with pretrained values: the convolution's weight `[cout, cin / groups, k, k]`
    /// and the BatchNorm's scale, shift, running mean and running variance `[cout]` each (in
    /// PyTorch's order). The shapes must be the layer's own.
    pub fn with_values(mut self, weight: Tensor<4>, bn: [Tensor<1>; 4]) -> Self {
        let [gamma, beta, mean, var] = bn;
        self.conv.weight = Param::from_tensor(weight);
        self.bn.gamma = Param::from_tensor(gamma);
        self.bn.beta = Param::from_tensor(beta);
        self.bn.running_mean = burn::module::RunningState::new(mean);
        self.bn.running_var = burn::module::RunningState::new(var);
        self
    }

    /// Shape of the convolution's weight.
    pub fn weight_shape(&self) -> [usize; 4] {
        self.conv.weight.dims()
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
        self.forward_with(x, false)
    }

    /// [`ConvBn::forward`] then ReLU, fused into the BatchNorm when training.
    pub fn forward_relu(&self, x: Tensor<4>) -> Tensor<4> {
        self.forward_with(x, true)
    }

    fn forward_with(&self, x: Tensor<4>, rectify: bool) -> Tensor<4> {
        let training = !self.folded && x.device().is_autodiff() && self.bn.training.is_enabled();
        let unbiased = self.conv.bias.is_none();
        if let Some(padding) = self.fast_padding(&x).filter(|_| training && unbiased) {
            let y = kernels::conv2d(x, self.conv.weight.val(), self.conv.stride, padding);
            return self.batch_norm_train(y, rectify);
        }
        let y = if self.folded {
            match (self.fast_padding(&x), &self.conv.bias) {
                (Some(padding), Some(bias)) => {
                    let (w, stride) = (self.conv.weight.val(), self.conv.stride);
                    return kernels::conv2d_bias(x, w, bias.val(), stride, padding, rectify);
                }
                _ => self.conv.forward(x),
            }
        } else {
            self.bn.forward(self.conv.forward(x))
        };
        if rectify { relu(y) } else { y }
    }

    /// The symmetric padding for [`kernels::conv2d`], when the kernels take this layer and
    /// input (no dilation, one group, f32 on flex).
    fn fast_padding(&self, x: &Tensor<4>) -> Option<[usize; 2]> {
        let conv = &self.conv;
        if conv.dilation != [1, 1] || conv.groups != 1 {
            return None;
        }
        if !kernels::supported(x) {
            return None;
        }
        // Every ConvBn is built with explicit symmetric padding; other configurations take
        // burn's path.
        match conv.padding {
            PaddingConfig2d::Explicit(top, left, bottom, right) => {
                (top == bottom && left == right).then_some([top, left])
            }
            _ => None,
        }
    }

    /// Training-mode BatchNorm (+ ReLU) by [`kernels::batch_norm_train`], updating the running
    /// statistics exactly as burn's `BatchNorm::forward` does.
    fn batch_norm_train(&self, x: Tensor<4>, rectify: bool) -> Tensor<4> {
        let bn = &self.bn;
        let (y, mean, variance) =
            kernels::batch_norm_train(x, bn.gamma.val(), bn.beta.val(), bn.epsilon, rectify);
        let device = y.device();
        let keep = 1.0 - bn.momentum;
        let running_mean = bn
            .running_mean
            .value_sync()
            .to_device(&device)
            .mul_scalar(keep)
            + mean.mul_scalar(bn.momentum);
        let running_var = bn
            .running_var
            .value_sync()
            .to_device(&device)
            .mul_scalar(keep)
            + variance.mul_scalar(bn.momentum);
        bn.running_mean.update(running_mean.detach());
        bn.running_var.update(running_var.detach());
        y
    }
}

#[cfg(test)]
mod tests {
    use burn::tensor::{Distribution, Tensor};

    use super::*;

    /// burn's own convolution, BatchNorm and ReLU: what the fused kernels replace.
    fn reference(layer: &ConvBn, x: Tensor<4>, rectify: bool) -> Tensor<4> {
        let y = layer.bn.forward(layer.conv.forward(x));
        if rectify { relu(y) } else { y }
    }

    fn assert_close<const D: usize>(a: Tensor<D>, b: Tensor<D>, what: &str) {
        let (a, b) = (
            a.into_data().try_to_vec::<f32>().unwrap(),
            b.into_data().try_to_vec::<f32>().unwrap(),
        );
        assert_eq!(a.len(), b.len(), "{what}");
        let scale = b.iter().fold(1e-3f32, |m, v| m.max(v.abs()));
        for (i, (x, y)) in a.iter().zip(&b).enumerate() {
            assert!((x - y).abs() <= 1e-4 * scale, "{what}[{i}]: {x} vs {y}");
        }
    }

    /// Folded for inference, the kernels' convolution plus the bias gives what burn's
    /// convolution and BatchNorm (running statistics) give unfolded.
    #[test]
    fn folded_inference_path_matches_burns_ops() {
        let device = Device::flex();
        for (cin, cout, k, s, p, rectify) in [(3, 8, 3, 2, 1, true), (4, 6, 1, 1, 0, false)] {
            device.seed(3);
            let mut layer = ConvBn::new(cin, cout, k, s, p, &device);
            let random = |lo: f64, hi: f64| {
                Tensor::<1>::random([cout], Distribution::Uniform(lo, hi), &device)
            };
            layer.bn.gamma = Param::from_tensor(random(0.5, 2.0));
            layer.bn.beta = Param::from_tensor(random(-1.0, 1.0));
            layer.bn.running_mean = burn::module::RunningState::new(random(-0.5, 0.5));
            layer.bn.running_var = burn::module::RunningState::new(random(0.5, 2.0));
            let x = Tensor::<4>::random([2, cin, 13, 11], Distribution::Normal(0.0, 1.0), &device);
            let expected = reference(&layer, x.clone(), rectify);
            let folded = layer.fold();
            assert!(folded.fast_padding(&x).is_some(), "the kernels take it");
            assert_close(folded.forward_with(x, rectify), expected, "folded output");
        }
    }

    /// The training path through the hand-written kernels gives burn's outputs, gradients
    /// (input, kernel, γ, β) and running statistics, for a strided and a 1x1 layer, with and
    /// without the ReLU.
    #[test]
    fn fast_training_path_matches_burns_ops() {
        let device = Device::flex().autodiff();
        for (cin, cout, k, s, p, rectify) in [
            (3, 8, 3, 2, 1, true),
            (4, 6, 1, 1, 0, false),
            (2, 5, 7, 2, 3, true),
        ] {
            device.seed(7);
            let fast = ConvBn::new(cin, cout, k, s, p, &device);
            let slow = fast.clone();
            let x = Tensor::<4>::random([3, cin, 13, 11], Distribution::Normal(0.0, 1.0), &device);
            let (xf, xs) = (x.clone().require_grad(), x.require_grad());
            let yf = fast.forward_with(xf.clone(), rectify);
            let ys = reference(&slow, xs.clone(), rectify);
            assert_close(yf.clone(), ys.clone(), "output");
            // A non-uniform output gradient, so that the BatchNorm's gradient is not zero.
            let weights = Tensor::<4>::random(yf.dims(), Distribution::Normal(0.0, 1.0), &device);
            let gf = (yf * weights.clone()).sum().backward();
            let gs = (ys * weights).sum().backward();
            assert_close(
                xf.grad(&gf).unwrap(),
                xs.grad(&gs).unwrap(),
                "input gradient",
            );
            assert_close(
                fast.conv.weight.grad(&gf).unwrap(),
                slow.conv.weight.grad(&gs).unwrap(),
                "kernel gradient",
            );
            assert_close(
                fast.bn.gamma.grad(&gf).unwrap(),
                slow.bn.gamma.grad(&gs).unwrap(),
                "gamma gradient",
            );
            assert_close(
                fast.bn.beta.grad(&gf).unwrap(),
                slow.bn.beta.grad(&gs).unwrap(),
                "beta gradient",
            );
            assert_close(
                fast.bn.running_mean.value(),
                slow.bn.running_mean.value(),
                "running mean",
            );
            assert_close(
                fast.bn.running_var.value(),
                slow.bn.running_var.value(),
                "running variance",
            );
        }
    }
}
