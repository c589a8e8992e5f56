//! Explicit dropout masks, for training and for Monte-Carlo dropout at inference.
//!
//! Masks come from a seeded ChaCha generator on the CPU, not from the backend's global random
//! generator, so training and MC inference are reproducible whatever else runs at the same time.

use burn::tensor::{Device, Tensor, TensorData};
use rand::Rng;
use rand_chacha::ChaCha8Rng;

use super::PoseNet;

/// An inverted-dropout mask `[rows, cols]`: each entry is 0 with probability `p`, else
/// `1 / (1 − p)`, so the expected activation is unchanged and no rescaling is needed when
/// dropout is off. `p` is clamped to `[0, 0.99]`.
pub fn dropout_mask(rows: usize, cols: usize, p: f64, rng: &mut ChaCha8Rng) -> Vec<f32> {
    let p = p.clamp(0.0, 0.99);
    let keep = (1.0 / (1.0 - p)) as f32;
    (0..rows * cols)
        .map(|_| if rng.random::<f64>() < p { 0.0 } else { keep })
        .collect()
}

/// One mask `[rows, width]` per layer width in `widths`, drawn `group` rows at a time: for each
/// group, its rows of every layer, then the next group. With `group` = the Monte-Carlo passes
/// per image, an image's masks are the same whatever else is in its batch.
pub fn group_masks(
    rows: usize,
    group: usize,
    widths: &[usize],
    p: f64,
    rng: &mut ChaCha8Rng,
    device: &Device,
) -> Vec<Tensor<2>> {
    let group = group.max(1);
    let mut values: Vec<Vec<f32>> = widths
        .iter()
        .map(|w| Vec::with_capacity(rows * w))
        .collect();
    for start in (0..rows).step_by(group) {
        let n = group.min(rows - start);
        for (layer, &w) in values.iter_mut().zip(widths) {
            layer.extend(dropout_mask(n, w, p, rng));
        }
    }
    values
        .into_iter()
        .zip(widths)
        .map(|(v, &w)| Tensor::from_data(TensorData::new(v, [rows, w]), device))
        .collect()
}

/// `passes` stochastic head outputs per row of pooled `features` `[B, F]`:
/// `[B * passes, outputs]`, rows `b * passes .. (b + 1) * passes` belonging to image `b`. Only
/// the features are repeated and sent through the masked head; the backbone ran once.
pub fn mc_head(
    net: &PoseNet,
    features: Tensor<2>,
    passes: usize,
    p: f64,
    rng: &mut ChaCha8Rng,
) -> Tensor<2> {
    let [b, f] = features.dims();
    let repeated = features
        .unsqueeze_dim::<3>(1)
        .repeat_dim(1, passes)
        .reshape([b * passes, f]);
    net.head(repeated, p, passes, rng)
}

#[cfg(test)]
mod tests {
    use super::*;
    use rand::SeedableRng;

    #[test]
    fn masks_keep_the_expected_value() {
        let mut rng = ChaCha8Rng::seed_from_u64(1);
        let m = dropout_mask(100, 100, 0.25, &mut rng);
        let zeros = m.iter().filter(|&&v| v == 0.0).count() as f64 / m.len() as f64;
        assert!((zeros - 0.25).abs() < 0.02, "{zeros}");
        let mean = m.iter().map(|&v| v as f64).sum::<f64>() / m.len() as f64;
        assert!((mean - 1.0).abs() < 0.03, "{mean}");
        assert!(dropout_mask(3, 4, 0.0, &mut rng).iter().all(|&v| v == 1.0));
    }
}
