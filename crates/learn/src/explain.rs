//! Grad-CAM saliency (Selvaraju et al., 2017): where in the image the evidence for a pose lies.
//!
//! Grad-CAM weighs each channel `k` of the last feature map `A` by the mean gradient of a score
//! `s` over the map, `α_k = mean_ij ∂s/∂A_k(i,j)`, and draws `ReLU(Σ_k α_k A_k)`. Every network
//! here average-pools that map into the head, so `∂s/∂A_k(i,j) = ∂s/∂f_k / (h·w)` with `f` the
//! pooled features: the gradient is the same at every cell, and Grad-CAM needs only `∂s/∂f`.
//! The head is linear layers and a ReLU, so that gradient is computed here in closed form from
//! the layer weights, on the inference network, with no autodiff pass (and no BatchNorm in
//! training mode); a test checks it against finite differences.
//!
//! The score is the position: `s = ½‖x̂‖²` of the standardised position outputs, whose gradient
//! `x̂·∂x̂/∂f` is the evidence that moves the estimate from the centre of the training poses to
//! where it is. With two networks the position network is explained; with a plane branch, its
//! pooled features enter the head as they are (they do not come from the last map).

use burn::nn::Linear;
use burn::tensor::{Tensor, TensorData};
use imgproc::view::View;

use crate::infer::Localizer;
use crate::net::PoseNet;
use crate::{LearnError, Result};

/// A saliency map on the network's last feature map.
#[derive(Clone, Debug, PartialEq)]
pub struct Saliency {
    /// Map width, cells.
    pub width: usize,
    /// Map height, cells.
    pub height: usize,
    /// Row-major values in `[0, 1]` (1 at the strongest cell; all 0 when nothing supports the
    /// estimate).
    pub values: Vec<f32>,
    /// The score explained, `½‖x̂‖²` of the standardised position outputs.
    pub score: f64,
}

impl Saliency {
    /// The cell with the highest value, `(x, y)` as fractions of the image's width and height
    /// (cell centres).
    pub fn peak(&self) -> (f64, f64) {
        let (i, _) =
            self.values
                .iter()
                .enumerate()
                .fold((0, f32::NEG_INFINITY), |best, (i, &v)| {
                    if v > best.1 { (i, v) } else { best }
                });
        let (x, y) = (i % self.width.max(1), i / self.width.max(1));
        (
            (x as f64 + 0.5) / self.width.max(1) as f64,
            (y as f64 + 0.5) / self.height.max(1) as f64,
        )
    }
}

/// The values of a tensor.
fn values<const D: usize>(t: Tensor<D>) -> Result<Vec<f32>> {
    t.into_data()
        .try_to_vec::<f32>()
        .map_err(|e| LearnError::Input(format!("{e:?}")))
}

/// A linear layer's weight `[inputs, outputs]` (burn's layout: `y = x·W + b`) and bias.
fn layer(l: &Linear) -> Result<(Vec<f32>, Vec<f32>, usize)> {
    let [_, outputs] = l.weight.dims();
    let w = values(l.weight.val())?;
    let b = match &l.bias {
        Some(b) => values(b.val())?,
        None => vec![0.0; outputs],
    };
    Ok((w, b, outputs))
}

/// `x·W + b` for a weight `[x.len(), outputs]`.
fn affine(x: &[f32], w: &[f32], b: &[f32], outputs: usize) -> Vec<f32> {
    let mut y = b.to_vec();
    for (i, &xi) in x.iter().enumerate() {
        if xi != 0.0 {
            for (o, &wij) in y.iter_mut().zip(&w[i * outputs..(i + 1) * outputs]) {
                *o += xi * wij;
            }
        }
    }
    y
}

/// `W·g` for a weight `[inputs, outputs]` and `g` of length `outputs`: the gradient with
/// respect to a layer's input.
fn back(w: &[f32], g: &[f32], inputs: usize) -> Vec<f32> {
    let outputs = g.len();
    (0..inputs)
        .map(|i| {
            w[i * outputs..(i + 1) * outputs]
                .iter()
                .zip(g)
                .map(|(a, b)| a * b)
                .sum()
        })
        .collect()
}

/// The score `½‖x̂‖²` and its gradient with respect to the head's input `u` (the first
/// network's pooled features, then its plane features), through the first network's head.
pub(crate) fn score_gradient(net: &PoseNet, u: &[f32]) -> Result<(f64, Vec<f32>)> {
    let (hidden, head) = net.head_layers();
    let pos = net.pos_dims();
    let (w2, b2, outputs) = layer(head)?;
    let (score, grad) = match hidden {
        None => {
            let y = affine(u, &w2, &b2, outputs);
            let mut g = vec![0.0; outputs];
            g[..pos].copy_from_slice(&y[..pos]);
            (
                y[..pos].iter().map(|v| v * v).sum::<f32>(),
                back(&w2, &g, u.len()),
            )
        }
        Some(hidden) => {
            let (w1, b1, width) = layer(hidden)?;
            let h = affine(u, &w1, &b1, width);
            let a: Vec<f32> = h.iter().map(|&v| v.max(0.0)).collect();
            let y = affine(&a, &w2, &b2, outputs);
            let mut g = vec![0.0; outputs];
            g[..pos].copy_from_slice(&y[..pos]);
            let mut ga = back(&w2, &g, width);
            for (gi, &hi) in ga.iter_mut().zip(&h) {
                if hi <= 0.0 {
                    *gi = 0.0;
                }
            }
            (
                y[..pos].iter().map(|v| v * v).sum::<f32>(),
                back(&w1, &ga, u.len()),
            )
        }
    };
    Ok((0.5 * f64::from(score), grad))
}

impl Localizer {
    /// The Grad-CAM map of one view made with [`Localizer::view_spec`] (see the module docs).
    pub fn grad_cam(&self, view: &View) -> Result<Saliency> {
        let packed = self.pack(std::slice::from_ref(view))?;
        let [c, h, w] = self.meta().input;
        let x = Tensor::<4>::from_data(TensorData::new(packed, [1, c, h, w]), self.device());
        let net = self.net();
        let map = net.feature_map(x.clone());
        let [_, f, mh, mw] = map.dims();
        let a = values(map)?;
        let cells = mh * mw;
        let mut u: Vec<f32> = (0..f)
            .map(|k| a[k * cells..(k + 1) * cells].iter().sum::<f32>() / cells as f32)
            .collect();
        if let Some(p) = net.plane_features(x) {
            u.extend(values(p)?);
        }
        let (score, grad) = score_gradient(net, &u)?;
        let mut cam = vec![0f32; cells];
        for (k, &alpha) in grad.iter().take(f).enumerate() {
            for (v, &ak) in cam.iter_mut().zip(&a[k * cells..(k + 1) * cells]) {
                *v += alpha * ak;
            }
        }
        let top = cam.iter().fold(0f32, |m, &v| m.max(v));
        let values = cam
            .iter()
            .map(|&v| if top > 0.0 { v.max(0.0) / top } else { 0.0 })
            .collect();
        Ok(Saliency {
            width: mw,
            height: mh,
            values,
            score,
        })
    }
}

/// The score `½‖x̂‖²` of the head's outputs for input features `u`, through the network's own
/// head (for the finite-difference test).
#[cfg(test)]
fn score_of(net: &PoseNet, u: &[f32]) -> f64 {
    let x = Tensor::<2>::from_data(
        TensorData::new(u.to_vec(), [1, u.len()]),
        &burn::tensor::Device::flex(),
    );
    let mut rng = <rand_chacha::ChaCha8Rng as rand::SeedableRng>::seed_from_u64(0);
    let y = values(net.head(x, 0.0, 1, &mut rng)).unwrap_or_default();
    0.5 * y[..net.pos_dims()]
        .iter()
        .map(|&v| f64::from(v) * f64::from(v))
        .sum::<f64>()
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::net::{Arch, HeadConfig, NetConfig};
    use burn::tensor::Device;

    fn net(hidden: usize, planes: bool) -> PoseNet {
        NetConfig {
            arch: Arch::Small,
            channels: 1,
            outputs: 7,
            learned_weighting: false,
            head: HeadConfig {
                hidden,
                aleatoric: true,
            },
            split: false,
            planes,
        }
        .init(&Device::flex(), 3)
        .unwrap()
    }

    #[test]
    fn the_gradient_matches_finite_differences() {
        for (hidden, planes) in [(0, false), (32, false), (32, true)] {
            let net = net(hidden, planes);
            let width = 256 + if planes { 64 } else { 0 };
            let u: Vec<f32> = (0..width)
                .map(|i| ((i * 7919) % 97) as f32 / 97.0)
                .collect();
            let (score, grad) = score_gradient(&net, &u).unwrap();
            assert!((score - score_of(&net, &u)).abs() < 1e-4 * (1.0 + score));
            let eps = 1e-2f32;
            for k in [0, 5, 77, width - 1] {
                let mut up = u.clone();
                up[k] += eps;
                let mut down = u.clone();
                down[k] -= eps;
                let numeric =
                    (score_of(&net, &up) - score_of(&net, &down)) / (2.0 * f64::from(eps));
                let analytic = f64::from(grad[k]);
                assert!(
                    (numeric - analytic).abs() <= 2e-3 + 0.02 * analytic.abs(),
                    "hidden {hidden}, planes {planes}, feature {k}: {numeric} vs {analytic}"
                );
            }
        }
    }

    #[test]
    fn the_peak_is_the_strongest_cell() {
        let s = Saliency {
            width: 4,
            height: 2,
            values: vec![0.0, 0.1, 0.2, 0.0, 0.0, 0.0, 1.0, 0.3],
            score: 1.0,
        };
        assert_eq!(s.peak(), (2.5 / 4.0, 1.5 / 2.0));
    }
}
