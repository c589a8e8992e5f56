//! Training-mode BatchNorm, optionally followed by a ReLU, and its gradient, in two passes over
//! the feature map each way.
//!
//! Written by hand because burn's default `batch_norm_train` (which burn-flex 0.22 keeps) builds
//! the statistics and the gradient out of a dozen generic ops, several of them swapping the
//! batch and channel axes into copies; on the small network's first stage (32 x 32 x 60 x 80)
//! BatchNorm and ReLU took longer than the convolution. Sums are accumulated in f64 so that
//! a channel of a few hundred thousand values keeps f32 precision.

use rayon::prelude::*;

/// Sizes of a `[batch, channels, plane]` feature map (`plane` = height x width).
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub struct MapShape {
    /// Images.
    pub batch: usize,
    /// Channels.
    pub channels: usize,
    /// Values per channel and image.
    pub plane: usize,
}

impl MapShape {
    fn len(&self) -> usize {
        self.batch * self.channels * self.plane
    }

    /// Values per channel over the whole batch.
    fn count(&self) -> f64 {
        (self.batch * self.plane) as f64
    }

    /// The planes of channel `c`, one per image.
    fn planes<'a>(&self, map: &'a [f32], c: usize) -> impl Iterator<Item = &'a [f32]> {
        (0..self.batch).map(move |b| {
            let start = (b * self.channels + c) * self.plane;
            &map[start..start + self.plane]
        })
    }
}

/// The batch statistics of a forward pass: per channel mean and biased variance (what burn's
/// `BatchNorm` feeds its running statistics).
#[derive(Clone, Debug, PartialEq)]
pub struct BatchStats {
    /// Mean per channel.
    pub mean: Vec<f32>,
    /// Biased variance per channel.
    pub variance: Vec<f32>,
}

/// Mean and biased variance of every channel (two passes: the mean, then squared deviations).
pub fn stats(shape: &MapShape, x: &[f32]) -> BatchStats {
    assert_eq!(x.len(), shape.len(), "feature map size");
    let (mean, variance) = (0..shape.channels)
        .into_par_iter()
        .map(|c| {
            let sum = blocked_sum(shape.planes(x, c), |v| v);
            let mean = sum / shape.count();
            let m = mean as f32;
            let squares = blocked_sum(shape.planes(x, c), |v| (v - m) * (v - m));
            (mean as f32, (squares / shape.count()) as f32)
        })
        .unzip();
    BatchStats { mean, variance }
}

/// `Σ f(v)` over the planes: f32 sums of blocks of [`BLOCK`] values, added up in f64.
fn blocked_sum<'a>(planes: impl Iterator<Item = &'a [f32]>, f: impl Fn(f32) -> f32) -> f64 {
    planes
        .flat_map(|p| p.chunks(BLOCK))
        .map(|block| lane_sums(block, block, |v, _| [f(v), 0.0])[0] as f64)
        .sum()
}

/// Lanes of the running sums in [`lane_sums`]: one AVX register of f32.
const LANES: usize = 8;

/// `(Σ f(a, b)[0], Σ f(a, b)[1])` over the pairs of `a` and `b`, summed in [`LANES`]
/// interleaved running sums. A single running sum is a chain of dependent additions that the
/// compiler may not reorder, one value per addition's latency; eight independent sums become
/// vector additions. (Training's BatchNorm statistics and gradient sums took a sixth of a
/// step that way.)
fn lane_sums(a: &[f32], b: &[f32], f: impl Fn(f32, f32) -> [f32; 2]) -> [f32; 2] {
    let mut acc = [[0.0f32; LANES]; 2];
    let (pairs_a, pairs_b) = (a.chunks_exact(LANES), b.chunks_exact(LANES));
    let (rest_a, rest_b) = (pairs_a.remainder(), pairs_b.remainder());
    for (ca, cb) in pairs_a.zip(pairs_b) {
        for i in 0..LANES {
            let [u, v] = f(ca[i], cb[i]);
            acc[0][i] += u;
            acc[1][i] += v;
        }
    }
    let mut total = acc.map(|lanes| lanes.iter().sum::<f32>());
    for (&x, &y) in rest_a.iter().zip(rest_b) {
        let [u, v] = f(x, y);
        total[0] += u;
        total[1] += v;
    }
    total
}

/// Values summed in f32 before the running sum in f64: short enough to keep f32's rounding
/// error near 1e-5 relative.
const BLOCK: usize = 256;

/// Per channel scale `γ/√(σ² + ε)` and shift `β − μ·scale` of the affine map BatchNorm is.
fn affine(stats: &BatchStats, gamma: &[f32], beta: &[f32], epsilon: f64) -> Vec<(f32, f32)> {
    (0..gamma.len())
        .map(|c| {
            let scale = gamma[c] / (stats.variance[c] as f64 + epsilon).sqrt() as f32;
            (scale, beta[c] - stats.mean[c] * scale)
        })
        .collect()
}

/// `y = γ·(x − μ)/√(σ² + ε) + β` with the batch statistics `stats`, then `max(y, 0)` if `relu`.
pub fn forward(
    shape: &MapShape,
    x: &[f32],
    stats: &BatchStats,
    gamma: &[f32],
    beta: &[f32],
    epsilon: f64,
    relu: bool,
) -> Vec<f32> {
    assert_eq!(x.len(), shape.len(), "feature map size");
    assert!(gamma.len() == shape.channels && beta.len() == shape.channels);
    let affine = affine(stats, gamma, beta, epsilon);
    let mut y = vec![0.0; x.len()];
    y.par_chunks_exact_mut(shape.plane)
        .zip(x.par_chunks_exact(shape.plane))
        .enumerate()
        .for_each(|(i, (out, input))| {
            let (scale, shift) = affine[i % shape.channels];
            for (o, &v) in out.iter_mut().zip(input) {
                let n = v * scale + shift;
                *o = if relu { n.max(0.0) } else { n };
            }
        });
    y
}

/// Gradients of [`forward`] with respect to its input, `γ` and `β`.
#[derive(Clone, Debug, PartialEq)]
pub struct BatchNormGrads {
    /// Input gradient, the feature map's shape.
    pub x: Vec<f32>,
    /// Per channel.
    pub gamma: Vec<f32>,
    /// Per channel.
    pub beta: Vec<f32>,
}

/// Gradients of [`forward`] (the batch statistics differentiated too) for output gradient
/// `dy`: `dβ = Σ g`, `dγ = Σ g·x̂`, `dx = γ/√(σ² + ε) · (g − mean(g) − x̂·mean(g·x̂))`, where
/// `g` is `dy` masked by the ReLU (recomputed from `x`) and `x̂` the normalised input.
#[allow(clippy::too_many_arguments)]
pub fn backward(
    shape: &MapShape,
    x: &[f32],
    stats: &BatchStats,
    gamma: &[f32],
    beta: &[f32],
    epsilon: f64,
    relu: bool,
    dy: &[f32],
) -> BatchNormGrads {
    assert_eq!(x.len(), shape.len(), "feature map size");
    assert_eq!(dy.len(), shape.len(), "output gradient size");
    let affine = affine(stats, gamma, beta, epsilon);
    let inv_std: Vec<f32> = stats
        .variance
        .iter()
        .map(|&v| (1.0 / (v as f64 + epsilon).sqrt()) as f32)
        .collect();
    // The ReLU's gate, recomputed from the input: the gradient passes where the output was
    // positive. Per channel constants are read once per plane, so the loops below are plain
    // element-wise arithmetic that vectorises.
    let gate = move |v: f32, g: f32, (scale, shift): (f32, f32)| {
        if relu && v * scale + shift <= 0.0 {
            0.0
        } else {
            g
        }
    };
    let (dbeta, dgamma): (Vec<f32>, Vec<f32>) = (0..shape.channels)
        .into_par_iter()
        .map(|c| {
            let (mut sum_g, mut sum_gx) = (0.0f64, 0.0f64);
            let (affine, mean) = (affine[c], stats.mean[c]);
            let blocks = |planes| shape.planes(planes, c).flat_map(|p| p.chunks(BLOCK));
            for (xb, gb) in blocks(x).zip(blocks(dy)) {
                let [sg, sgx] = lane_sums(xb, gb, |v, g| {
                    let g = gate(v, g, affine);
                    [g, g * (v - mean)]
                });
                sum_g += sg as f64;
                sum_gx += sgx as f64 * inv_std[c] as f64;
            }
            (sum_g as f32, sum_gx as f32)
        })
        .unzip();
    let n = shape.count() as f32;
    let mut dx = vec![0.0; x.len()];
    dx.par_chunks_exact_mut(shape.plane)
        .zip(
            x.par_chunks_exact(shape.plane)
                .zip(dy.par_chunks_exact(shape.plane)),
        )
        .enumerate()
        .for_each(|(i, (out, (xp, gp)))| {
            let c = i % shape.channels;
            let (affine, mean, inv_std) = (affine[c], stats.mean[c], inv_std[c]);
            let k = gamma[c] * inv_std;
            let (mean_g, mean_gx) = (dbeta[c] / n, dgamma[c] / n);
            for (o, (&v, &g)) in out.iter_mut().zip(xp.iter().zip(gp)) {
                let xhat = (v - mean) * inv_std;
                *o = k * (gate(v, g, affine) - mean_g - xhat * mean_gx);
            }
        });
    BatchNormGrads {
        x: dx,
        gamma: dgamma,
        beta: dbeta,
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    const SHAPE: MapShape = MapShape {
        batch: 3,
        channels: 2,
        plane: 5,
    };
    const EPS: f64 = 1e-5;

    fn values(n: usize, seed: f32) -> Vec<f32> {
        (0..n).map(|i| ((i as f32 + seed) * 0.618).sin()).collect()
    }

    /// `Σ dy · forward(x)` with statistics recomputed from `x`: the scalar whose gradient
    /// [`backward`] returns.
    fn objective(x: &[f32], gamma: &[f32], beta: &[f32], dy: &[f32], relu: bool) -> f64 {
        let y = forward(&SHAPE, x, &stats(&SHAPE, x), gamma, beta, EPS, relu);
        y.iter().zip(dy).map(|(a, b)| (a * b) as f64).sum()
    }

    #[test]
    fn statistics_are_numpys_mean_and_biased_variance() {
        let x = values(SHAPE.len(), 1.0);
        let s = stats(&SHAPE, &x);
        for c in 0..2 {
            let v: Vec<f64> = SHAPE.planes(&x, c).flatten().map(|&v| v as f64).collect();
            let mean = v.iter().sum::<f64>() / v.len() as f64;
            let var = v.iter().map(|a| (a - mean).powi(2)).sum::<f64>() / v.len() as f64;
            assert!((s.mean[c] as f64 - mean).abs() < 1e-6);
            assert!((s.variance[c] as f64 - var).abs() < 1e-6);
        }
    }

    #[test]
    fn gradients_match_central_differences() {
        let x = values(SHAPE.len(), 1.0);
        let gamma = vec![1.3, -0.7];
        let beta = vec![0.2, 0.1];
        let dy = values(SHAPE.len(), 4.0);
        for relu in [false, true] {
            let g = backward(
                &SHAPE,
                &x,
                &stats(&SHAPE, &x),
                &gamma,
                &beta,
                EPS,
                relu,
                &dy,
            );
            let h = 1e-2f32;
            let numeric = |f: &dyn Fn(f32) -> f64| (f(h) - f(-h)) / (2.0 * h as f64);
            for i in 0..x.len() {
                let d = numeric(&|e| {
                    let mut x = x.clone();
                    x[i] += e;
                    objective(&x, &gamma, &beta, &dy, relu)
                });
                assert!(
                    (g.x[i] as f64 - d).abs() < 2e-3,
                    "relu {relu} x[{i}]: {} vs {d}",
                    g.x[i]
                );
            }
            for c in 0..2 {
                let dg = numeric(&|e| {
                    let mut gm = gamma.clone();
                    gm[c] += e;
                    objective(&x, &gm, &beta, &dy, relu)
                });
                let db = numeric(&|e| {
                    let mut bt = beta.clone();
                    bt[c] += e;
                    objective(&x, &gamma, &bt, &dy, relu)
                });
                assert!(
                    (g.gamma[c] as f64 - dg).abs() < 2e-3,
                    "relu {relu} gamma[{c}]"
                );
                assert!(
                    (g.beta[c] as f64 - db).abs() < 2e-3,
                    "relu {relu} beta[{c}]"
                );
            }
        }
    }
}
