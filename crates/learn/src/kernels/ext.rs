//! The kernels as a burn backend extension: [`FastOps`] on `Flex` runs them forward, and on
//! `Autodiff<Flex>` it also records a backward step that runs their gradients.

use burn::backend::autodiff::Autodiff;
use burn::backend::autodiff::checkpoint::base::Checkpointer;
use burn::backend::autodiff::checkpoint::strategy::CheckpointStrategy;
use burn::backend::autodiff::grads::Gradients;
use burn::backend::autodiff::ops::{Backward, Ops, OpsKind};
use burn::backend::ops::{ActivationOps, FloatTensorOps};
use burn::backend::tensor::FloatTensor;
use burn::backend::{
    Backend, Bytes, DType, ExtensionType, Flex, TensorMetadata, backend_extension,
};
use burn_flex::{FlexTensor, Layout};

use super::batchnorm::{self, BatchStats, MapShape};
use super::conv::{self, ConvGeometry};

/// A training-mode BatchNorm's output with the batch statistics it used.
#[derive(ExtensionType)]
pub struct BatchNormOutput<B: Backend> {
    /// The normalised (and rectified, if asked) map.
    pub output: FloatTensor<B>,
    /// Mean per channel.
    pub mean: FloatTensor<B>,
    /// Biased variance per channel.
    pub variance: FloatTensor<B>,
}

/// Convolution and BatchNorm (+ ReLU) by the hand-written kernels.
#[backend_extension(Flex, Autodiff)]
pub trait FastOps: Backend {
    /// `[B, Cin, H, W] * [Cout, Cin, KH, KW] -> [B, Cout, OH, OW]`, no bias, dilation 1, one
    /// group.
    fn fast_conv2d(
        x: FloatTensor<Self>,
        weight: FloatTensor<Self>,
        stride: [usize; 2],
        padding: [usize; 2],
    ) -> FloatTensor<Self>;

    /// [`FastOps::fast_conv2d`] plus a bias per output channel (`[Cout]`), then `max(., 0)` if
    /// `relu`, in one pass over the output: a folded BatchNorm and its activation at inference.
    fn fast_conv2d_bias(
        x: FloatTensor<Self>,
        weight: FloatTensor<Self>,
        bias: FloatTensor<Self>,
        stride: [usize; 2],
        padding: [usize; 2],
        relu: bool,
    ) -> FloatTensor<Self>;

    /// BatchNorm with the statistics of the batch, then `max(., 0)` if `relu`.
    fn fast_batch_norm_train(
        x: FloatTensor<Self>,
        gamma: FloatTensor<Self>,
        beta: FloatTensor<Self>,
        epsilon: f64,
        relu: bool,
    ) -> BatchNormOutput<Self>;
}

/// The f32 values of a tensor in row-major order (copied only when it is a strided view).
fn contiguous(t: &FlexTensor) -> FlexTensor {
    assert_eq!(t.dtype(), DType::F32, "the fast kernels take f32 tensors");
    t.to_contiguous()
}

fn values(t: &FlexTensor) -> &[f32] {
    t.as_slice::<f32>().expect("a contiguous f32 tensor")
}

fn tensor(values: Vec<f32>, shape: &[usize]) -> FlexTensor {
    FlexTensor::new(
        Bytes::from_elems(values),
        Layout::contiguous(shape.into()),
        DType::F32,
    )
}

fn dims4(t: &FlexTensor) -> [usize; 4] {
    let shape = t.shape();
    assert_eq!(shape.num_dims(), 4, "a 4-D tensor");
    [shape[0], shape[1], shape[2], shape[3]]
}

fn geometry(
    x: &FlexTensor,
    weight: &FlexTensor,
    stride: [usize; 2],
    padding: [usize; 2],
) -> ConvGeometry {
    let [batch, cin, h, w] = dims4(x);
    let [cout, wcin, kh, kw] = dims4(weight);
    assert_eq!(cin, wcin, "input channels of the input and the weight");
    ConvGeometry {
        batch,
        cin,
        input: [h, w],
        cout,
        kernel: [kh, kw],
        stride,
        padding,
    }
}

fn map_shape(x: &FlexTensor) -> MapShape {
    let shape = x.shape();
    assert!(shape.num_dims() >= 2, "a [batch, channels, ...] tensor");
    MapShape {
        batch: shape[0],
        channels: shape[1],
        plane: shape.num_elements() / (shape[0] * shape[1]).max(1),
    }
}

fn conv_forward(
    g: &ConvGeometry,
    x: &FlexTensor,
    weight: &FlexTensor,
    epilogue: conv::Epilogue,
) -> FlexTensor {
    let [oh, ow] = g.output();
    let y = conv::forward(g, values(x), values(weight), epilogue);
    tensor(y, &[g.batch, g.cout, oh, ow])
}

fn stats_of(stats: &BatchStats) -> (FlexTensor, FlexTensor) {
    let c = stats.mean.len();
    (
        tensor(stats.mean.clone(), &[c]),
        tensor(stats.variance.clone(), &[c]),
    )
}

/// BatchNorm (+ ReLU) of contiguous tensors: the output and the batch statistics it used.
fn batch_norm_forward(
    x: &FlexTensor,
    gamma: &FlexTensor,
    beta: &FlexTensor,
    epsilon: f64,
    relu: bool,
) -> (FlexTensor, BatchStats) {
    let shape = map_shape(x);
    let stats = batchnorm::stats(&shape, values(x));
    let y = batchnorm::forward(
        &shape,
        values(x),
        &stats,
        values(gamma),
        values(beta),
        epsilon,
        relu,
    );
    (tensor(y, &x.shape()), stats)
}

impl FastOps for Flex {
    fn fast_conv2d(
        x: FlexTensor,
        weight: FlexTensor,
        stride: [usize; 2],
        padding: [usize; 2],
    ) -> FlexTensor {
        let (x, weight) = (contiguous(&x), contiguous(&weight));
        let g = geometry(&x, &weight, stride, padding);
        conv_forward(&g, &x, &weight, conv::Epilogue::default())
    }

    fn fast_conv2d_bias(
        x: FlexTensor,
        weight: FlexTensor,
        bias: FlexTensor,
        stride: [usize; 2],
        padding: [usize; 2],
        relu: bool,
    ) -> FlexTensor {
        let (x, weight, bias) = (contiguous(&x), contiguous(&weight), contiguous(&bias));
        let g = geometry(&x, &weight, stride, padding);
        let epilogue = conv::Epilogue {
            bias: Some(values(&bias)),
            relu,
        };
        conv_forward(&g, &x, &weight, epilogue)
    }

    fn fast_batch_norm_train(
        x: FlexTensor,
        gamma: FlexTensor,
        beta: FlexTensor,
        epsilon: f64,
        relu: bool,
    ) -> BatchNormOutput<Flex> {
        let (x, gamma, beta) = (contiguous(&x), contiguous(&gamma), contiguous(&beta));
        let (output, stats) = batch_norm_forward(&x, &gamma, &beta, epsilon, relu);
        let (mean, variance) = stats_of(&stats);
        BatchNormOutput {
            output,
            mean,
            variance,
        }
    }
}

/// The backward step of [`FastOps::fast_conv2d`]: the input (contiguous), the weight and the
/// shapes. The input gradient is skipped when the input is not tracked (a network's images).
#[derive(Debug)]
struct ConvBackward;

impl Backward<Flex, 2> for ConvBackward {
    type State = (FlexTensor, FlexTensor, ConvGeometry);

    fn backward(self, ops: Ops<Self::State, 2>, grads: &mut Gradients, _: &mut Checkpointer) {
        let [node_x, node_w] = ops.parents;
        let dy = contiguous(&grads.consume::<Flex>(&ops.node));
        let (x, weight, g) = ops.state;
        if let Some(node) = node_w {
            let dw = conv::backward_weight(&g, values(&x), values(&dy));
            grads.register::<Flex>(node.id, tensor(dw, &weight.shape()));
        }
        if let Some(node) = node_x {
            let dx = conv::backward_input(&g, values(&weight), values(&dy));
            grads.register::<Flex>(node.id, tensor(dx, &x.shape()));
        }
    }
}

/// The backward step of [`FastOps::fast_batch_norm_train`]: input, γ, β (all contiguous), the
/// batch statistics, ε and whether a ReLU followed.
#[derive(Debug)]
struct BatchNormBackward;

impl Backward<Flex, 3> for BatchNormBackward {
    type State = (FlexTensor, FlexTensor, FlexTensor, BatchStats, f64, bool);

    fn backward(self, ops: Ops<Self::State, 3>, grads: &mut Gradients, _: &mut Checkpointer) {
        let [node_x, node_gamma, node_beta] = ops.parents;
        let dy = contiguous(&grads.consume::<Flex>(&ops.node));
        let (x, gamma, beta, stats, epsilon, relu) = ops.state;
        let shape = map_shape(&x);
        let d = batchnorm::backward(
            &shape,
            values(&x),
            &stats,
            values(&gamma),
            values(&beta),
            epsilon,
            relu,
            values(&dy),
        );
        let c = shape.channels;
        if let Some(node) = node_x {
            grads.register::<Flex>(node.id, tensor(d.x, &x.shape()));
        }
        if let Some(node) = node_gamma {
            grads.register::<Flex>(node.id, tensor(d.gamma, &[c]));
        }
        if let Some(node) = node_beta {
            grads.register::<Flex>(node.id, tensor(d.beta, &[c]));
        }
    }
}

impl<C: CheckpointStrategy> FastOps for Autodiff<Flex, C> {
    fn fast_conv2d(
        x: FloatTensor<Self>,
        weight: FloatTensor<Self>,
        stride: [usize; 2],
        padding: [usize; 2],
    ) -> FloatTensor<Self> {
        match ConvBackward
            .prepare::<C>([x.node(), weight.node()])
            .compute_bound()
            .stateful()
        {
            OpsKind::Tracked(prep) => {
                let (xp, wp) = (contiguous(x.primitive()), contiguous(weight.primitive()));
                let g = geometry(&xp, &wp, stride, padding);
                let y = conv_forward(&g, &xp, &wp, conv::Epilogue::default());
                prep.finish((xp, wp, g), y)
            }
            OpsKind::UnTracked(prep) => prep.finish(Flex::fast_conv2d(
                x.into_primitive(),
                weight.into_primitive(),
                stride,
                padding,
            )),
        }
    }

    /// Tracked: the convolution above, then burn's own bias add and ReLU, so gradients flow
    /// as for any layer (a folded network is for inference; this keeps it correct anywhere).
    fn fast_conv2d_bias(
        x: FloatTensor<Self>,
        weight: FloatTensor<Self>,
        bias: FloatTensor<Self>,
        stride: [usize; 2],
        padding: [usize; 2],
        relu: bool,
    ) -> FloatTensor<Self> {
        let cout = bias.shape()[0];
        let y = Self::fast_conv2d(x, weight, stride, padding);
        let y = Self::float_add(y, Self::float_reshape(bias, [1, cout, 1, 1].into()));
        if relu { Self::relu(y) } else { y }
    }

    fn fast_batch_norm_train(
        x: FloatTensor<Self>,
        gamma: FloatTensor<Self>,
        beta: FloatTensor<Self>,
        epsilon: f64,
        relu: bool,
    ) -> BatchNormOutput<Self> {
        let prepared = BatchNormBackward
            .prepare::<C>([x.node(), gamma.node(), beta.node()])
            .compute_bound()
            .stateful();
        let (xp, gp, bp) = (
            contiguous(x.primitive()),
            contiguous(gamma.primitive()),
            contiguous(beta.primitive()),
        );
        let (y, stats) = batch_norm_forward(&xp, &gp, &bp, epsilon, relu);
        let (mean, variance) = stats_of(&stats);
        let output = match prepared {
            OpsKind::Tracked(prep) => prep.finish((xp, gp, bp, stats, epsilon, relu), y),
            OpsKind::UnTracked(prep) => prep.finish(y),
        };
        BatchNormOutput {
            output,
            mean: FloatTensor::<Self>::new(mean),
            variance: FloatTensor::<Self>::new(variance),
        }
    }
}
