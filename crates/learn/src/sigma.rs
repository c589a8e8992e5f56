//! The parts of a position's uncertainty and what a checkpoint stores about them: the three
//! covariances inference measures ([`SigmaParts`]), the weights that add them up
//! ([`SigmaWeights`]) and what the sum means as a probability ([`UncertaintyCalibration`]), the
//! last two fitted on the validation frames ([`crate::calibrate`]) and kept in `model.toml`.

use geom::uncertainty::Calibration;
use nalgebra::Matrix3;
use serde::{Deserialize, Serialize};

/// The three covariances (m², world axes) `cov_pos_m2` is made of, before weighing.
#[derive(Clone, Copy, Debug, Default, PartialEq)]
pub struct SigmaParts {
    /// Covariance of the MC samples' positions.
    pub mc: Matrix3<f64>,
    /// Covariance of the TTA views' positions about their mean.
    pub tta: Matrix3<f64>,
    /// The predicted per-image error scale's covariance (isotropic on the position's axes).
    pub scale: Matrix3<f64>,
}

impl SigmaParts {
    /// The traces of the MC, TTA and scale parts, m².
    pub fn traces(&self) -> [f64; 3] {
        [self.mc.trace(), self.tta.trace(), self.scale.trace()]
    }
}

/// The calibration of a model's covariances ([`geom::uncertainty::Calibration`]): its scale
/// multiplies the covariance that leaves the model, its radii give the regions.
#[derive(Clone, Debug, PartialEq, Serialize, Deserialize)]
pub struct UncertaintyCalibration {
    /// Of the position covariance (dims 3, or 2 for a floor position).
    pub position: Calibration,
    /// Of the rotation variance (dims 3, or 1 for a heading); `None` without MC passes, which
    /// give the only rotation spread.
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub rotation: Option<Calibration>,
    /// Of the temporal filter's fused covariance when this model feeds it, fitted by `track`
    /// on the validation walk run through the filter; `None` until then.
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub fused: Option<Calibration>,
}

/// Least variance of a position axis, m² (a millimetre): the parts can all be zero (one
/// deterministic pass, no TTA, no scale output), and a covariance must stay invertible.
pub const COVARIANCE_FLOOR_M2: f64 = 1e-6;

/// Weights of the three variances `sigma_pos_m` adds up ([`SigmaParts`]).
#[derive(Clone, Copy, Debug, PartialEq, Serialize, Deserialize)]
pub struct SigmaWeights {
    /// Weight of the MC spread².
    pub mc: f64,
    /// Weight of the TTA views' spread².
    pub tta: f64,
    /// Weight of the per-image scale's variance.
    pub scale: f64,
}

impl SigmaWeights {
    /// Every part as it is.
    pub const UNIT: SigmaWeights = SigmaWeights {
        mc: 1.0,
        tta: 1.0,
        scale: 1.0,
    };

    /// The weighed sum of `parts`' covariances, m², plus `COVARIANCE_FLOOR_M2` on the
    /// position's `dims` axes so that it is positive definite there.
    pub fn covariance(&self, parts: &SigmaParts, dims: usize) -> Matrix3<f64> {
        let mut cov = parts.mc * self.mc + parts.tta * self.tta + parts.scale * self.scale;
        for k in 0..dims.min(3) {
            cov[(k, k)] += COVARIANCE_FLOOR_M2;
        }
        cov
    }

    pub(crate) fn check(&self) -> std::result::Result<(), String> {
        let ok = [self.mc, self.tta, self.scale]
            .iter()
            .all(|w| w.is_finite() && *w >= 0.0);
        if ok {
            Ok(())
        } else {
            Err(format!(
                "sigma weights {self:?} must be finite and not negative"
            ))
        }
    }
}
