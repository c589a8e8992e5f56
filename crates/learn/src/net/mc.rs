//! Explicit dropout masks, for training and for Monte-Carlo dropout at inference.
//!
//! Masks come from a seeded ChaCha generator on the CPU, not from the backend's global random
//! generator, so training and MC inference are reproducible whatever else runs at the same time.

use burn::tensor::{Device, Tensor, TensorData};
use rand::{Rng, SeedableRng};
use rand_chacha::ChaCha8Rng;

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

/// One mask `[rows, width]` per layer width in `widths`, drawn row by row (each row's masks of
/// every layer, then the next row's): training's dropout.
pub fn row_masks(
    rows: usize,
    widths: &[usize],
    p: f64,
    rng: &mut ChaCha8Rng,
    device: &Device,
) -> Vec<Tensor<2>> {
    let mut values: Vec<Vec<f32>> = widths
        .iter()
        .map(|w| Vec::with_capacity(rows * w))
        .collect();
    for _ in 0..rows {
        for (layer, &w) in values.iter_mut().zip(widths) {
            layer.extend(dropout_mask(1, w, p, rng));
        }
    }
    to_tensors(values, widths, device)
}

/// The Monte-Carlo ensemble: one mask `[passes, width]` per layer width in `widths`, layer by
/// layer from a generator seeded with `seed`. Every image is seen through these same
/// `passes` thinned networks, so an image's sigma does not depend on the other images of its
/// batch or on its place among them, and images are compared through the same networks
/// (common random numbers: the spread of two images differs because the images do, not
/// because their masks do).
pub fn ensemble_masks(
    passes: usize,
    widths: &[usize],
    p: f64,
    seed: u64,
    device: &Device,
) -> Vec<Tensor<2>> {
    let mut rng = ChaCha8Rng::seed_from_u64(seed);
    let values = widths
        .iter()
        .map(|&w| dropout_mask(passes, w, p, &mut rng))
        .collect();
    to_tensors(values, widths, device)
}

fn to_tensors(values: Vec<Vec<f32>>, widths: &[usize], device: &Device) -> Vec<Tensor<2>> {
    values
        .into_iter()
        .zip(widths)
        .map(|(v, &w)| {
            let rows = v.len() / w.max(1);
            Tensor::from_data(TensorData::new(v, [rows, w]), device)
        })
        .collect()
}

#[cfg(test)]
mod tests {
    use super::*;

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
