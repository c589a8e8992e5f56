//! The place classifier's network: a backbone, an average pool to a small grid, one linear
//! head per level.

use burn::module::Module;
use burn::nn::pool::{AdaptiveAvgPool2d, AdaptiveAvgPool2dConfig};
use burn::nn::{Linear, LinearConfig};
use burn::tensor::{Device, Tensor};
use serde::{Deserialize, Serialize};

use crate::net::{Arch, Backbone, seeded_init};
use crate::{LearnError, Result};

/// What a [`PlaceNet`] is built from.
#[derive(Clone, Debug, PartialEq, Eq, Serialize, Deserialize)]
pub struct PlaceNetConfig {
    /// Backbone.
    pub arch: Arch,
    /// Input channels: 1 or 3.
    pub channels: usize,
    /// Classes per level (building, floor, corridor).
    pub classes: [usize; 3],
    /// Side of the grid the last feature map is averaged to before the heads: 1 is global
    /// average pooling; 2 keeps which quarter of the view a feature is in, which helps to tell
    /// which way along a corridor the camera faces (the two views share their features, not
    /// their layout): on the place-split study's held-out walks, 69.5 % corridor and direction
    /// right against 66.2 % with global pooling. Models from before the grid read as 1.
    #[serde(default = "global_pool")]
    pub grid: usize,
}

pub(super) fn global_pool() -> usize {
    1
}

impl PlaceNetConfig {
    /// A network with freshly initialised weights; the same seed gives the same weights.
    pub fn init(&self, device: &Device, seed: u64) -> Result<PlaceNet> {
        if self.channels != 1 && self.channels != 3 {
            return Err(LearnError::Config(format!(
                "input channels must be 1 or 3, not {}",
                self.channels
            )));
        }
        if self.classes.contains(&0) {
            return Err(LearnError::Config("a level without classes".into()));
        }
        if !(1..=4).contains(&self.grid) {
            return Err(LearnError::Config(format!(
                "pooling grid {} must be 1 to 4",
                self.grid
            )));
        }
        let features = self.arch.features() * self.grid * self.grid;
        let head = |n: usize| LinearConfig::new(features, n).init(device);
        Ok(seeded_init(device, seed, || PlaceNet {
            backbone: Backbone::new(self.arch, self.channels, device),
            pool: AdaptiveAvgPool2dConfig::new([self.grid, self.grid]).init(),
            building: head(self.classes[0]),
            floor: head(self.classes[1]),
            corridor: head(self.classes[2]),
        }))
    }
}

/// Backbone, average pool to a small grid (1x1: global), one linear head per level.
#[derive(Module, Debug)]
pub struct PlaceNet {
    backbone: Backbone,
    pool: AdaptiveAvgPool2d,
    building: Linear,
    floor: Linear,
    corridor: Linear,
}

impl PlaceNet {
    /// Pooled features `[B, F · grid²]` of a batch `[B, C, H, W]`.
    pub fn features(&self, x: Tensor<4>) -> Tensor<2> {
        self.pool.forward(self.backbone.forward(x)).flatten(1, 3)
    }

    /// Logits of each level, `[B, classes]`, from (masked) features.
    pub fn logits(&self, features: Tensor<2>) -> [Tensor<2>; 3] {
        [
            self.building.forward(features.clone()),
            self.floor.forward(features.clone()),
            self.corridor.forward(features),
        ]
    }

    /// The network with BatchNorm folded into the convolutions (inference only).
    pub fn fold_batchnorm(self) -> PlaceNet {
        PlaceNet {
            backbone: self.backbone.fold(),
            ..self
        }
    }
}
