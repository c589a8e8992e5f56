//! A GoogLeNet-style backbone cut at its first auxiliary classifier, with BatchNorm after every
//! convolution: the ceiling-camera localization literature's network (GoogLeNet's stem,
//! inception 3a, 3b and 4a, 512 features at stride 16). Layout as torchvision's `GoogLeNet`
//! (bias-free conv + BN + ReLU, max pools rounding up), except that the "5x5" branch uses a
//! `5x5` kernel as in the paper, where torchvision's uses `3x3`.

use burn::module::Module;
use burn::nn::PaddingConfig2d;
use burn::nn::pool::{MaxPool2d, MaxPool2dConfig};
use burn::tensor::{Device, Tensor};

use super::conv::ConvBn;

/// Features after inception 4a.
pub const INCEPTION_FEATURES: usize = 512;

/// Channels of the stride-8 map (after inception 3b).
pub const INCEPTION_MID_CHANNELS: usize = 480;

/// `k x k` max pool, stride `s`, padding `p`, sizes rounded up (GoogLeNet's `ceil_mode`).
fn max_pool(k: usize, s: usize, p: usize) -> MaxPool2d {
    MaxPool2dConfig::new([k, k])
        .with_strides([s, s])
        .with_padding(PaddingConfig2d::Explicit(p, p, p, p))
        .with_ceil_mode(true)
        .init()
}

/// Conv + BN + ReLU.
#[derive(Module, Debug)]
struct ConvBnRelu {
    inner: ConvBn,
}

impl ConvBnRelu {
    fn new(cin: usize, cout: usize, k: usize, s: usize, device: &Device) -> Self {
        ConvBnRelu {
            inner: ConvBn::new(cin, cout, k, s, k / 2, device),
        }
    }

    fn fold(self) -> Self {
        ConvBnRelu {
            inner: self.inner.fold(),
        }
    }

    fn forward(&self, x: Tensor<4>) -> Tensor<4> {
        self.inner.forward_relu(x)
    }
}

/// An inception module: `1x1`, `1x1 → 3x3`, `1x1 → 5x5` and `3x3 max pool → 1x1` branches,
/// concatenated along channels.
#[derive(Module, Debug)]
struct Inception {
    b1: ConvBnRelu,
    b3_reduce: ConvBnRelu,
    b3: ConvBnRelu,
    b5_reduce: ConvBnRelu,
    b5: ConvBnRelu,
    pool: MaxPool2d,
    pool_proj: ConvBnRelu,
}

impl Inception {
    /// `cin` input channels; branch widths `[1x1, 3x3 reduce, 3x3, 5x5 reduce, 5x5, pool proj]`.
    fn new(cin: usize, w: [usize; 6], device: &Device) -> Self {
        Inception {
            b1: ConvBnRelu::new(cin, w[0], 1, 1, device),
            b3_reduce: ConvBnRelu::new(cin, w[1], 1, 1, device),
            b3: ConvBnRelu::new(w[1], w[2], 3, 1, device),
            b5_reduce: ConvBnRelu::new(cin, w[3], 1, 1, device),
            b5: ConvBnRelu::new(w[3], w[4], 5, 1, device),
            pool: max_pool(3, 1, 1),
            pool_proj: ConvBnRelu::new(cin, w[5], 1, 1, device),
        }
    }

    fn fold(self) -> Self {
        Inception {
            b1: self.b1.fold(),
            b3_reduce: self.b3_reduce.fold(),
            b3: self.b3.fold(),
            b5_reduce: self.b5_reduce.fold(),
            b5: self.b5.fold(),
            pool: self.pool,
            pool_proj: self.pool_proj.fold(),
        }
    }

    fn forward(&self, x: Tensor<4>) -> Tensor<4> {
        let branches = vec![
            self.b1.forward(x.clone()),
            self.b3.forward(self.b3_reduce.forward(x.clone())),
            self.b5.forward(self.b5_reduce.forward(x.clone())),
            self.pool_proj.forward(self.pool.forward(x)),
        ];
        Tensor::cat(branches, 1)
    }
}

/// The GoogLeNet body up to inception 4a (pooling and head live in [`super::PoseNet`]).
#[derive(Module, Debug)]
pub struct InceptionNet {
    conv1: ConvBnRelu,
    pool1: MaxPool2d,
    conv2: ConvBnRelu,
    conv3: ConvBnRelu,
    pool2: MaxPool2d,
    inception3a: Inception,
    inception3b: Inception,
    pool3: MaxPool2d,
    inception4a: Inception,
}

impl InceptionNet {
    /// The body for `channels` input channels.
    pub fn new(channels: usize, device: &Device) -> Self {
        InceptionNet {
            conv1: ConvBnRelu::new(channels, 64, 7, 2, device),
            pool1: max_pool(3, 2, 0),
            conv2: ConvBnRelu::new(64, 64, 1, 1, device),
            conv3: ConvBnRelu::new(64, 192, 3, 1, device),
            pool2: max_pool(3, 2, 0),
            inception3a: Inception::new(192, [64, 96, 128, 16, 32, 32], device),
            inception3b: Inception::new(256, [128, 128, 192, 32, 96, 64], device),
            pool3: max_pool(3, 2, 0),
            inception4a: Inception::new(480, [192, 96, 208, 16, 48, 64], device),
        }
    }

    /// The body with every BatchNorm folded ([`ConvBn::fold`]).
    pub fn fold(self) -> Self {
        InceptionNet {
            conv1: self.conv1.fold(),
            pool1: self.pool1,
            conv2: self.conv2.fold(),
            conv3: self.conv3.fold(),
            pool2: self.pool2,
            inception3a: self.inception3a.fold(),
            inception3b: self.inception3b.fold(),
            pool3: self.pool3,
            inception4a: self.inception4a.fold(),
        }
    }

    /// `[B, C, H, W] -> [B, 512, H/16, W/16]` (sizes rounded up).
    pub fn forward(&self, x: Tensor<4>) -> Tensor<4> {
        self.forward_mid(x).1
    }

    /// The rest of the body from the stride-8 map of [`InceptionNet::forward_mid`].
    pub fn forward_tail(&self, mid: Tensor<4>) -> Tensor<4> {
        self.inception4a.forward(self.pool3.forward(mid))
    }

    /// The stride-8 map (after inception 3b, 480 channels) and the output of
    /// [`InceptionNet::forward`].
    pub fn forward_mid(&self, x: Tensor<4>) -> (Tensor<4>, Tensor<4>) {
        let x = self.pool1.forward(self.conv1.forward(x));
        let x = self
            .pool2
            .forward(self.conv3.forward(self.conv2.forward(x)));
        let mid = self.inception3b.forward(self.inception3a.forward(x));
        let out = self.inception4a.forward(self.pool3.forward(mid.clone()));
        (mid, out)
    }
}
