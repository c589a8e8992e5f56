//! The pose losses (PoseNet, Kendall et al. 2015; learned weighting, Kendall & Cipolla 2017).
//!
//! `L = mean‖x − x̂‖ + β·mean‖r̂/‖r̂‖ − r‖`, with `r` the quaternion (6-DoF) or `(sin θ, cos θ)`
//! (3-DoF), and the position error in metres: predictions are de-standardised before the
//! difference, so β means "metres per unit of rotation error" whatever the building's size.
//! With learned weighting, `L = Lx·exp(−s_x) + s_x + Lq·exp(−s_q) + s_q` and β is not used.
//!
//! With a per-image scale output `s = ln b` ([`crate::net::HeadConfig::aleatoric`]), the
//! position term becomes the negative log-likelihood of the error `e` under the density
//! `∝ exp(−‖e‖ / b)` in `d` dimensions: `mean(‖e‖·exp(−s) + d·s)`, minimised by `b = ‖e‖ / d`.

use burn::tensor::{Tensor, TensorData};

use crate::head::PoseCoding;

/// Added under square roots so that a zero difference has a finite gradient.
const SQRT_EPS: f32 = 1e-9;

/// Bounds of the predicted log scale `s = ln b` (b from 0.3 mm to 3 km), so that one wild
/// output cannot overflow `exp(−s)`.
pub const LOG_SCALE_RANGE: (f32, f32) = (-8.0, 8.0);

/// The loss of a batch and its two parts (for progress reports).
#[derive(Debug, Clone)]
pub struct LossParts {
    /// The total to minimise, shape `[1]`.
    pub total: Tensor<1>,
    /// Mean position error, metres, shape `[1]`.
    pub pos: Tensor<1>,
    /// Mean rotation-part distance (normalised prediction to target), shape `[1]`.
    #[cfg_attr(not(test), expect(dead_code, reason = "only the tests read it"))]
    pub rot: Tensor<1>,
}

/// Row-wise Euclidean norm `[B, D] -> [B, 1]`.
fn row_norm(x: Tensor<2>) -> Tensor<2> {
    x.square().sum_dim(1).add_scalar(SQRT_EPS).sqrt()
}

/// The loss of network outputs `[B, outputs]` against targets from [`PoseCoding::target`]:
/// `Lx + β·Lq`, or with `log_vars = [s_x, s_q]` (trained with the network)
/// `Lx·exp(−s_x) + s_x + Lq·exp(−s_q) + s_q`. An output column beyond the task's is the
/// per-image log scale, and `Lx` is then its negative log-likelihood (see the module docs).
pub fn pose_loss(
    coding: &PoseCoding,
    outputs: Tensor<2>,
    targets: Tensor<2>,
    beta: f64,
    log_vars: Option<Tensor<1>>,
) -> LossParts {
    let device = outputs.device();
    let d = coding.task.pos_dims();
    let r = coding.task.rot_dims();
    let row = |v: &[f64]| {
        let v: Vec<f32> = v.iter().map(|&x| x as f32).collect();
        Tensor::<2>::from_data(TensorData::new(v, [1, d]), &device)
    };
    let pos_hat = outputs.clone().narrow(1, 0, d) * row(&coding.pos_std) + row(&coding.pos_mean);
    let pos = targets.clone().narrow(1, 0, d);
    let dist = row_norm(pos_hat - pos);
    let [_, columns] = outputs.dims();
    let (lx, pos_loss) = if columns > coding.task.outputs() {
        let (lo, hi) = LOG_SCALE_RANGE;
        let s = outputs.clone().narrow(1, d + r, 1).clamp(lo, hi);
        let nll = (dist.clone() * s.clone().neg().exp() + s.mul_scalar(d as f32)).mean();
        (dist.mean(), nll)
    } else {
        let lx = dist.mean();
        (lx.clone(), lx)
    };
    let rot_hat = outputs.narrow(1, d, r);
    let rot_hat = rot_hat.clone() / row_norm(rot_hat);
    let lq = row_norm(rot_hat - targets.narrow(1, d, r)).mean();
    let total = match log_vars {
        None => pos_loss + lq.clone().mul_scalar(beta),
        Some(s) => {
            let sx = s.clone().narrow(0, 0, 1);
            let sq = s.narrow(0, 1, 1);
            pos_loss * sx.clone().neg().exp() + sx + lq.clone() * sq.clone().neg().exp() + sq
        }
    };
    LossParts {
        total,
        pos: lx,
        rot: lq,
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::head::Task;
    use burn::tensor::Device;
    use geom::Mount;

    fn scalar(t: Tensor<1>) -> f32 {
        t.into_scalar::<f32>()
    }

    #[test]
    fn loss_is_the_posenet_formula() {
        let device = Device::flex();
        let coding = PoseCoding {
            task: Task::Pose6,
            pos_mean: vec![1.0, 0.0, 0.0],
            pos_std: vec![2.0, 1.0, 1.0],
            mount: Mount::Forward,
            z: 0.0,
        };
        // Prediction: position (1 + 2·1, 0, 0) = (3, 0, 0); quaternion (2, 0, 0, 0) -> identity.
        let out = Tensor::<2>::from_data(
            TensorData::new(vec![1.0f32, 0., 0., 2., 0., 0., 0.], [1, 7]),
            &device,
        );
        // Target: position (0, 4, 0) at distance 5; rotation 180° about z, |(1,0,0,0)-(0,0,0,1)| = √2.
        let tgt = Tensor::<2>::from_data(
            TensorData::new(vec![0.0f32, 4., 0., 0., 0., 0., 1.], [1, 7]),
            &device,
        );
        let parts = pose_loss(&coding, out.clone(), tgt.clone(), 10.0, None);
        assert!((scalar(parts.pos) - 5.0).abs() < 1e-5);
        assert!((scalar(parts.rot) - 2f32.sqrt()).abs() < 1e-5);
        assert!((scalar(parts.total) - (5.0 + 10.0 * 2f32.sqrt())).abs() < 1e-4);
        let s = Tensor::<1>::from_floats([0.5, -1.0], &device);
        let parts = pose_loss(&coding, out, tgt.clone(), 10.0, Some(s));
        let expect = 5.0 * (-0.5f32).exp() + 0.5 + 2f32.sqrt() * 1f32.exp() - 1.0;
        assert!((scalar(parts.total) - expect).abs() < 1e-4);
        // With a log-scale column s = ln 2: 5 / 2 + 3 ln 2 for the position.
        let out = Tensor::<2>::from_data(
            TensorData::new(vec![1.0f32, 0., 0., 2., 0., 0., 0., 2f32.ln()], [1, 8]),
            &device,
        );
        let parts = pose_loss(&coding, out, tgt, 10.0, None);
        assert!((scalar(parts.pos) - 5.0).abs() < 1e-5);
        let expect = 2.5 + 3.0 * 2f32.ln() + 10.0 * 2f32.sqrt();
        assert!((scalar(parts.total) - expect).abs() < 1e-4);
    }
}
