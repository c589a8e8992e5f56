//! The dominant-plane branch of a [`super::PoseNet`] with [`super::NetConfig::planes`]: a
//! `3x3` conv + BN + ReLU on the backbone's stride-8 map, then two `1x1` convolutions, one for
//! the class of the dominant plane each cell sees ([`crate::planes::PlaneClass`]) and one for
//! that plane's parameters in the camera frame (unit normal pointing away from the camera, and
//! the log of its distance). The branch's feature map, average-pooled, joins the backbone's
//! pooled features in front of the pose head, so what the plane task learns (where floor, walls
//! and ceiling are, how far) is there for the pose too.

use burn::module::{Initializer, Module};
use burn::nn::conv::{Conv2d, Conv2dConfig};
use burn::tensor::{Device, Tensor};

use super::conv::ConvBn;

/// Classes of the plane a cell sees (index 0: none; [`crate::planes::PlaneClass`]).
pub const PLANE_CLASSES: usize = 6;
/// Plane parameters per cell: the normal's three components and `ln d`.
pub const PLANE_PARAMS: usize = 4;

/// Channels of the branch's feature map (and width it adds to the pooled features).
pub const PLANE_FEATURES: usize = 64;

/// The plane branch.
#[derive(Module, Debug)]
pub struct PlaneBranch {
    conv: ConvBn,
    classes: Conv2d,
    params: Conv2d,
}

impl PlaneBranch {
    /// A branch on a stride-8 map of `cin` channels.
    pub fn new(cin: usize, device: &Device) -> Self {
        let head = |cout: usize| {
            Conv2dConfig::new([PLANE_FEATURES, cout], [1, 1])
                .with_initializer(Initializer::XavierUniform { gain: 1.0 })
                .init(device)
        };
        PlaneBranch {
            conv: ConvBn::new(cin, PLANE_FEATURES, 3, 1, 1, device),
            classes: head(PLANE_CLASSES),
            params: head(PLANE_PARAMS),
        }
    }

    /// The branch with its BatchNorm folded ([`ConvBn::fold`]).
    pub fn fold(self) -> Self {
        PlaneBranch {
            conv: self.conv.fold(),
            ..self
        }
    }

    /// The feature map `[B, PLANE_FEATURES, h, w]` of a stride-8 map `[B, cin, h, w]`.
    pub fn features(&self, mid: Tensor<4>) -> Tensor<4> {
        self.conv.forward_relu(mid)
    }

    /// Class logits `[B, PLANE_CLASSES, h, w]` and raw plane parameters
    /// `[B, PLANE_PARAMS, h, w]` (normal not yet normalised, log distance) of a feature map.
    pub fn outputs(&self, features: Tensor<4>) -> (Tensor<4>, Tensor<4>) {
        (
            self.classes.forward(features.clone()),
            self.params.forward(features),
        )
    }
}
