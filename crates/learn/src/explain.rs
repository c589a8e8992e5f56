//! Grad-CAM saliency (Selvaraju et al., 2017): where in the image the evidence for a pose lies.
//!
//! Grad-CAM weighs each channel `k` of a feature map `A` by the mean gradient of a score `s`
//! over the map, `α_k = mean_ij ∂s/∂A_k(i,j)`, and draws `ReLU(Σ_k α_k A_k)`. The score is the
//! position: `s = ½‖x̂‖²` of the standardised position outputs, whose gradient `x̂·∂x̂/∂A` is the
//! evidence that moves the estimate from the centre of the training poses to where it is.
//!
//! The map is the backbone's stride-8 map by default ([`CamLayer::Mid`]: 8x6 cells for a 64x48
//! view, where the last map has 2x2) or its last map ([`CamLayer::Last`]). The gradient comes
//! from burn's autodiff on the inference network with its BatchNorms folded into the
//! convolutions ([`Explainer`]), so no layer switches to batch statistics. With two networks the
//! position network is explained; a plane branch, which reads the stride-8 map, is part of the
//! path from that map to the pose. A test checks the last-layer weights against the closed
//! form that average pooling before a linear head gives (`∂s/∂A_k(i,j) = ∂s/∂f_k / (h·w)`).

use std::path::Path;

use burn::tensor::{Device, Tensor, TensorData};
use image::DynamicImage;
use imgproc::view::{View, ViewSpec};

use crate::checkpoint::{self, MODEL_BPK, ModelMeta};
use crate::net::PoseNet;
use crate::{LearnError, Result};

/// Which feature map Grad-CAM weighs.
#[derive(Clone, Copy, Debug, Default, PartialEq, Eq)]
pub enum CamLayer {
    /// The backbone's stride-8 map (finer; the default).
    #[default]
    Mid,
    /// The backbone's last map (stride 32 for the small network and ResNets).
    Last,
}

impl std::str::FromStr for CamLayer {
    type Err = LearnError;
    fn from_str(s: &str) -> Result<Self> {
        match s {
            "mid" => Ok(CamLayer::Mid),
            "last" => Ok(CamLayer::Last),
            _ => Err(LearnError::Config(format!(
                "unknown Grad-CAM layer '{s}' (mid or last)"
            ))),
        }
    }
}

/// A model loaded for explaining: the network on an autodiff device, BatchNorms folded.
#[derive(Debug)]
pub struct Explainer {
    net: PoseNet,
    meta: ModelMeta,
    spec: ViewSpec,
    device: Device,
}

impl Explainer {
    /// Loads the checkpoint folder `dir` (as [`crate::Localizer::load`] does).
    pub fn load(dir: &Path) -> Result<Explainer> {
        let device = crate::device::training();
        let meta = ModelMeta::read(dir)?;
        let bytes = checkpoint::read_checked(dir, MODEL_BPK, &meta.weights_hash)?;
        let net = checkpoint::load_weights(&meta.net, bytes, &device, &dir.join(MODEL_BPK))?;
        let spec = ViewSpec::resolve(&meta.view)
            .map_err(|e| LearnError::corrupt(dir.join(checkpoint::MODEL_TOML), e.to_string()))?;
        Ok(Explainer {
            net: net.fold_batchnorm(),
            meta,
            spec,
            device,
        })
    }

    /// The network's view of an image.
    pub fn view(&self, img: &DynamicImage) -> Result<View> {
        self.spec
            .apply(img, 0)
            .map_err(|e| LearnError::Input(e.to_string()))
    }

    /// The Grad-CAM map of one view on `layer` (see the module docs).
    pub fn grad_cam(&self, view: &View, layer: CamLayer) -> Result<Saliency> {
        let packed =
            crate::infer::pack_views(std::slice::from_ref(view), self.meta.input, &self.meta.view)?;
        let [c, h, w] = self.meta.input;
        let x = Tensor::<4>::from_data(TensorData::new(packed, [1, c, h, w]), &self.device);
        Ok(gradients(&self.net, x, layer)?.saliency())
    }
}

/// A feature map `[1, F, h, w]`, the score's gradient on it, and the score.
struct MapGradient {
    dims: [usize; 4],
    map: Vec<f32>,
    grad: Vec<f32>,
    score: f64,
}

impl MapGradient {
    /// `α_k` per channel: the gradient's mean over the map.
    fn weights(&self) -> Vec<f32> {
        let [_, f, h, w] = self.dims;
        let cells = h * w;
        (0..f)
            .map(|k| self.grad[k * cells..(k + 1) * cells].iter().sum::<f32>() / cells as f32)
            .collect()
    }

    fn saliency(&self) -> Saliency {
        let [_, _, h, w] = self.dims;
        let cells = h * w;
        let mut cam = vec![0f32; cells];
        for (k, alpha) in self.weights().into_iter().enumerate() {
            for (v, &a) in cam.iter_mut().zip(&self.map[k * cells..(k + 1) * cells]) {
                *v += alpha * a;
            }
        }
        let top = cam.iter().fold(0f32, |m, &v| m.max(v));
        Saliency {
            width: w,
            height: h,
            values: cam
                .iter()
                .map(|&v| if top > 0.0 { v.max(0.0) / top } else { 0.0 })
                .collect(),
            score: self.score,
        }
    }
}

/// The score of one image `x` (on `net`'s autodiff device) and its gradient on `layer`.
fn gradients(net: &PoseNet, x: Tensor<4>, layer: CamLayer) -> Result<MapGradient> {
    let mid = net.mid_map(x.clone()).detach();
    let mut last = None;
    let (target, outputs) = match layer {
        CamLayer::Mid => {
            let mid = mid.require_grad();
            (Some(mid.clone()), net.forward_from_mid(mid, x, &mut |m| m))
        }
        CamLayer::Last => {
            let outputs = net.forward_from_mid(mid, x, &mut |m| {
                let m = m.detach().require_grad();
                last = Some(m.clone());
                m
            });
            (last, outputs)
        }
    };
    let target = target.ok_or_else(|| LearnError::Input("no feature map to explain".into()))?;
    let dims = target.dims();
    let map = values(target.clone())?;
    let pos = outputs.clone().narrow(1, 0, net.pos_dims());
    let score = pos.square().sum().mul_scalar(0.5);
    let grads = score.backward();
    let grad = target
        .grad(&grads)
        .ok_or_else(|| LearnError::Input("the score does not depend on the feature map".into()))?;
    Ok(MapGradient {
        dims,
        map,
        grad: values(grad)?,
        score: f64::from(score.into_scalar::<f32>()),
    })
}

/// A Grad-CAM map on one of the backbone's feature maps ([`CamLayer`]).
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

/// The closed form of the score's gradient with respect to the pooled features, for the tests.
#[cfg(test)]
mod closed_form {
    use super::*;
    use burn::nn::Linear;

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
    pub fn score_gradient(net: &PoseNet, u: &[f32]) -> Result<(f64, Vec<f32>)> {
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
}

/// The score `½‖x̂‖²` of the head's outputs for input features `u`, through the network's own
/// head (for the finite-difference test).
#[cfg(test)]
fn score_of(net: &PoseNet, u: &[f32]) -> f64 {
    let x = Tensor::<2>::from_data(
        TensorData::new(u.to_vec(), [1, u.len()]),
        &burn::tensor::Device::flex(),
    );
    let y = values(net.head_plain(x)).unwrap_or_default();
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
            let (score, grad) = closed_form::score_gradient(&net, &u).unwrap();
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
    fn autodiff_weights_on_the_last_map_are_the_closed_form_and_the_mid_map_is_finer() {
        let device = Device::flex().autodiff();
        for planes in [false, true] {
            let net = NetConfig {
                arch: Arch::Small,
                channels: 1,
                outputs: 7,
                learned_weighting: false,
                head: HeadConfig {
                    hidden: 32,
                    aleatoric: true,
                },
                split: false,
                planes,
            }
            .init(&device, 5)
            .unwrap()
            .fold_batchnorm();
            let pixels: Vec<f32> = (0..48 * 64)
                .map(|i| ((i * 37) % 101) as f32 / 50.0 - 1.0)
                .collect();
            let x = Tensor::<4>::from_data(TensorData::new(pixels, [1, 1, 48, 64]), &device);
            let last = gradients(&net, x.clone(), CamLayer::Last).unwrap();
            assert_eq!(last.dims, [1, 256, 2, 2]);
            let u = values(net.features(x.clone())).unwrap();
            let (score, grad) = closed_form::score_gradient(&net, &u).unwrap();
            assert!((last.score - score).abs() < 1e-3 * (1.0 + score));
            for (k, alpha) in last.weights().into_iter().enumerate() {
                // Average pooling spreads ∂s/∂f_k evenly over the 4 cells.
                let want = grad[k] / 4.0;
                assert!(
                    (alpha - want).abs() <= 1e-5 + 1e-3 * want.abs(),
                    "{k}: {alpha} vs {want}"
                );
            }
            let mid = gradients(&net, x, CamLayer::Mid).unwrap();
            assert_eq!(mid.dims, [1, 128, 6, 8]);
            assert!((mid.score - last.score).abs() < 1e-6 * (1.0 + score));
            let map = mid.saliency();
            assert_eq!((map.width, map.height), (8, 6));
            assert!(map.values.iter().all(|v| (0.0..=1.0).contains(v)));
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
