//! Hand-written CPU kernels for the layers that dominate a training step: convolution
//! (im2col + matrix product, both gradients) and training-mode BatchNorm with an optional fused
//! ReLU. burn-flex 0.22 differentiates both through its generic ops, which made a training step
//! of the small network 2.7x PyTorch's; each module says what it replaces and why.
//!
//! [`conv2d`] and [`batch_norm_train`] take and give burn tensors on a `flex` device, plain or
//! autodiff ([`ext::FastOps`] is a burn backend extension with its own backward steps).

mod batchnorm;
mod conv;
mod ext;
mod gemm;

use burn::backend::{Dispatch, DispatchDevice};
use burn::tensor::{DType, Tensor};

pub use ext::FastOps;

/// Whether the kernels can take these tensors: f32 on a `flex` device. Callers fall back to
/// burn's own ops otherwise, as on a GPU (`crate::device`).
pub fn supported<const D: usize>(x: &Tensor<D>) -> bool {
    x.dtype() == DType::F32
        && matches!(
            x.device().without_autodiff().as_dispatch(),
            DispatchDevice::Flex(_)
        )
}

/// `x * weight` (no bias, dilation 1, one group) with `stride` and symmetric `padding`.
pub fn conv2d(
    x: Tensor<4>,
    weight: Tensor<4>,
    stride: [usize; 2],
    padding: [usize; 2],
) -> Tensor<4> {
    Tensor::from_dispatch(<Dispatch as FastOps>::fast_conv2d(
        x.into_dispatch(),
        weight.into_dispatch(),
        stride,
        padding,
    ))
}

/// [`conv2d`] plus `bias` per output channel, then a ReLU if `relu`, in one pass (a folded
/// BatchNorm at inference).
pub fn conv2d_bias(
    x: Tensor<4>,
    weight: Tensor<4>,
    bias: Tensor<1>,
    stride: [usize; 2],
    padding: [usize; 2],
    relu: bool,
) -> Tensor<4> {
    Tensor::from_dispatch(<Dispatch as FastOps>::fast_conv2d_bias(
        x.into_dispatch(),
        weight.into_dispatch(),
        bias.into_dispatch(),
        stride,
        padding,
        relu,
    ))
}

/// Training-mode BatchNorm of `x` (`[batch, channels, ...]`), then a ReLU if `relu`; returns
/// the output and the batch mean and biased variance per channel (untracked).
pub fn batch_norm_train<const D: usize>(
    x: Tensor<D>,
    gamma: Tensor<1>,
    beta: Tensor<1>,
    epsilon: f64,
    relu: bool,
) -> (Tensor<D>, Tensor<1>, Tensor<1>) {
    let out = <Dispatch as FastOps>::fast_batch_norm_train(
        x.into_dispatch(),
        gamma.into_dispatch(),
        beta.into_dispatch(),
        epsilon,
        relu,
    );
    (
        Tensor::from_dispatch(out.output),
        Tensor::from_dispatch(out.mean),
        Tensor::from_dispatch(out.variance),
    )
}
