//! Calibration of `sigma_pos_m`: after training, the weights of its three variances (MC spread²,
//! TTA spread², the per-image scale's variance; [`crate::infer::SigmaParts`]) are fitted on the
//! validation frames, so that sigma is in metres that mean something and the parts that track
//! the error count for more than those that do not.
//!
//! The fit maximises the likelihood of the validation errors under an isotropic Gaussian whose
//! trace is the weighed sum (per frame, `d·ln v + d·‖e‖² / v` with `v = Σ w_k·part_k`, `d` the
//! position dimensions), over a grid of weights (0 and 10^(k/4) from 10⁻⁴ to 100 for each).
//! A grid rather than gradient steps: three weights, a few hundred frames, and the answer must
//! be the same on every machine.
//!
//! Why: on the full ceiling demo's validation walk the head's MC spread was about six times the
//! error and hardly tracked it, so added as it was it drowned the other two parts: the held-out
//! walk's 10 % of frames with the largest sigma had 1.4x the median error of the rest. Weighed
//! as fitted (mc 0.018, tta 0.56, scale 0.056), 2.25x and R 0.42.

use std::path::Path;

use imgproc::view::View;

use crate::Result;
use crate::checkpoint::SigmaWeights;
use crate::dataset::Samples;
use crate::infer::{Localizer, SigmaParts};

/// MC passes and TTA of the calibration: the defaults of `localize` and `demo`.
pub const CALIBRATION_MC: usize = 16;

/// Fewer validation frames than this leave the weights at 1: too few to fit three numbers.
pub const MIN_FRAMES: usize = 20;

/// The weights fitted for the model in `dir` on `val` (its validation samples, views as the
/// model takes them); `None` when there are fewer than [`MIN_FRAMES`].
pub fn calibrate(dir: &Path, val: &Samples) -> Result<Option<SigmaWeights>> {
    if val.len() < MIN_FRAMES {
        return Ok(None);
    }
    let loc = Localizer::load(dir)?;
    let dims = loc.meta().coding.task.pos_dims();
    let per = val.view_len();
    let views: Vec<View> = val
        .inputs
        .chunks_exact(per)
        .map(|data| View {
            channels: val.channels as u32,
            width: val.width as u32,
            height: val.height as u32,
            data: data.to_vec(),
            norm: None,
        })
        .collect();
    let (parts, errors): (Vec<SigmaParts>, Vec<f64>) = loc
        .with_tta(true)
        .sigma_parts(&views, CALIBRATION_MC)?
        .into_iter()
        .zip(&val.poses)
        .map(|((pose, parts), truth)| (parts, geom::metrics::position_error(truth, &pose)))
        .unzip();
    Ok(Some(fit(&parts, &errors, dims)))
}

/// The grid's weights: 0, then 10^(k/4) for k = −16..=8.
fn grid() -> Vec<f64> {
    std::iter::once(0.0)
        .chain((-16..=8).map(|k| 10f64.powf(f64::from(k) / 4.0)))
        .collect()
}

/// The weights that best explain `errors` (metres) by `parts` in `dims` dimensions (see the
/// module docs). A part that is zero on every frame keeps weight 1; with no part at all, or
/// no frame, every weight is 1.
pub fn fit(parts: &[SigmaParts], errors: &[f64], dims: usize) -> SigmaWeights {
    let columns = |p: &SigmaParts| [p.mc, p.tta, p.scale];
    let present: Vec<bool> = (0..3)
        .map(|k| parts.iter().any(|p| columns(p)[k] > 0.0))
        .collect();
    if !present.contains(&true) || errors.is_empty() {
        return SigmaWeights::UNIT;
    }
    let d = dims.max(1) as f64;
    let nll = |w: [f64; 3]| -> f64 {
        parts
            .iter()
            .zip(errors)
            .map(|(p, e)| {
                let v: f64 = columns(p).iter().zip(w).map(|(x, w)| x * w).sum();
                if v <= 0.0 {
                    return f64::INFINITY;
                }
                d * v.ln() + d * e * e / v
            })
            .sum()
    };
    // Absent parts are held at 1; the others run over the grid.
    let axis = |k: usize| if present[k] { grid() } else { vec![1.0] };
    let mut best = ([1.0; 3], f64::INFINITY);
    for &a in &axis(0) {
        for &b in &axis(1) {
            for &c in &axis(2) {
                let cost = nll([a, b, c]);
                if cost < best.1 {
                    best = ([a, b, c], cost);
                }
            }
        }
    }
    let [mc, tta, scale] = best.0;
    SigmaWeights { mc, tta, scale }
}

#[cfg(test)]
mod tests {
    use super::*;

    fn part(mc: f64, tta: f64, scale: f64) -> SigmaParts {
        SigmaParts { mc, tta, scale }
    }

    #[test]
    fn an_informative_part_outweighs_a_noisy_one() {
        // The TTA spread² is the squared error over 2 (so weight 2 explains it); the MC part is
        // large and unrelated to the error.
        let errors: Vec<f64> = (0..200).map(|i| 0.05 + 0.01 * f64::from(i % 40)).collect();
        let parts: Vec<SigmaParts> = errors
            .iter()
            .enumerate()
            .map(|(i, e)| part(1.0 + (i % 7) as f64, e * e / 2.0, 0.0))
            .collect();
        let w = fit(&parts, &errors, 2);
        assert!(w.tta > 1.0 && w.tta < 4.0, "{w:?}");
        assert!(w.mc < 0.01, "{w:?}");
        // Absent throughout: left at 1.
        assert_eq!(w.scale, 1.0);
    }

    #[test]
    fn nothing_to_fit_leaves_unit_weights() {
        assert_eq!(fit(&[], &[], 3), SigmaWeights::UNIT);
        assert_eq!(fit(&[part(0.0, 0.0, 0.0)], &[0.3], 3), SigmaWeights::UNIT);
    }
}
