//! Calibration of the uncertainty: after training, on the validation frames (which training
//! did not learn from), two fits.
//!
//! 1. The weights of the three covariances `cov_pos_m2` adds ([`crate::SigmaParts`]:
//!    MC spread, TTA spread, the per-image scale), so that the parts that track the error count
//!    for more than those that do not. The fit maximises the Gaussian likelihood of the
//!    validation errors (per frame `ln det Σ + eᵀ Σ⁻¹ e` on the position's axes, with
//!    `Σ = Σ w_k·C_k`) over a grid of weights (0 and 10^(k/4) from 10⁻⁴ to 100 for each). A
//!    grid rather than gradient steps: three weights, a few hundred frames, and the answer must
//!    be the same on every machine.
//! 2. What the weighed covariance means as a probability ([`geom::uncertainty::Calibration`]):
//!    a scale (the likelihood's best, so near 1 after the weights) and the validation frames'
//!    own Mahalanobis quantiles, which give regions that hold what they claim when the errors
//!    are heavier-tailed than a Gaussian. The rotation spread gets the same.
//!
//! Why weights: on the full ceiling demo's validation walk the head's MC spread was about six
//! times the error and hardly tracked it, so added as it was it drowned the other two parts:
//! the held-out walk's 10 % of frames with the largest sigma had 1.4x the median error of the
//! rest. Weighed as fitted (mc 0.018, tta 0.56, scale 0.056), 2.25x and R 0.42.

use std::path::Path;

use geom::Pose;
use geom::uncertainty::{Calibration, Standardised};
use imgproc::view::View;

use crate::Result;
use crate::dataset::Samples;
use crate::head::Task;
use crate::infer::Localizer;
use crate::sigma::{SigmaParts, SigmaWeights, UncertaintyCalibration};

/// MC passes and TTA of the calibration: the defaults of `localize` and `demo`.
pub const CALIBRATION_MC: usize = 16;

/// Fewer validation frames than this leave the model uncalibrated: too few to fit three
/// weights and place a 95 % quantile.
pub const MIN_FRAMES: usize = geom::uncertainty::MIN_CALIBRATION_FRAMES;

/// One validation frame: its error (estimate − truth, world axes), rotation error (radians),
/// covariance parts and MC rotation spread (RMS, radians).
#[derive(Clone, Copy, Debug)]
pub struct ValidationFrame {
    /// Position error vector, metres.
    pub error: nalgebra::Vector3<f64>,
    /// Rotation error (heading error for a 3-DoF model), radians.
    pub rot_error: f64,
    /// The covariance parts before weighing.
    pub parts: SigmaParts,
    /// RMS angle of the MC samples to their mean, radians.
    pub rot_spread: f64,
}

/// What [`calibrate`] fits, with the passes it fitted them on.
pub(crate) struct Calibrated {
    /// The weights of the covariance parts.
    pub weights: SigmaWeights,
    /// What the weighed covariance means as a probability.
    pub calibration: UncertaintyCalibration,
    /// The validation frames through the calibrated model.
    pub passes: ValidationPasses,
}

/// The validation frames as the calibrated model estimates them ([`CALIBRATION_MC`] MC passes
/// and TTA): what the fused track's calibration (`track::calibrate`) runs through its filter.
/// Handed on from training, so that the same backbone passes (a minute or more for a few
/// hundred frames) are not run twice.
#[derive(Clone, Debug, PartialEq)]
pub struct ValidationPasses {
    /// `seq/frame` name of each frame, as the dataset names it.
    pub names: Vec<String>,
    /// Ground truth of each frame.
    pub truth: Vec<Pose>,
    /// The calibrated model's estimate of each frame: what
    /// [`Localizer::predict_batch`] gives it with TTA and [`CALIBRATION_MC`] passes.
    pub estimates: Vec<crate::Estimate>,
}

/// The weights and the calibration fitted for the model in `dir` on `val` (its validation
/// samples, views as the model takes them), with the passes they were fitted on; `None` when
/// there are fewer than [`MIN_FRAMES`].
pub(crate) fn calibrate(dir: &Path, val: &Samples) -> Result<Option<Calibrated>> {
    if val.len() < MIN_FRAMES {
        return Ok(None);
    }
    let loc = Localizer::load(dir)?;
    let coding = loc.meta().coding.clone();
    let (task, mount) = (coding.task, coding.mount);
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
    let outputs = loc.with_tta(true).sigma_parts(&views, CALIBRATION_MC)?;
    let frames: Vec<ValidationFrame> = outputs
        .iter()
        .zip(&val.poses)
        .map(|((pose, parts, rot_spread_deg), truth)| ValidationFrame {
            error: pose.translation - truth.translation,
            rot_error: rotation_error(task, mount, truth, pose),
            parts: *parts,
            rot_spread: rot_spread_deg.to_radians(),
        })
        .collect();
    let Some((weights, calibration)) = fit_all(&frames, task) else {
        return Ok(None);
    };
    let estimates = outputs
        .into_iter()
        .map(|(pose, parts, rot_spread_deg)| {
            crate::infer::weighed(
                &coding,
                &weights,
                Some(&calibration),
                (pose, &parts, rot_spread_deg),
                CALIBRATION_MC,
            )
        })
        .collect();
    Ok(Some(Calibrated {
        weights,
        calibration,
        passes: ValidationPasses {
            names: val.names.clone(),
            truth: val.poses.clone(),
            estimates,
        },
    }))
}

/// The rotation error the study and the calibration use: the heading error for a 3-DoF model,
/// the full rotation angle otherwise (radians).
pub fn rotation_error(task: Task, mount: geom::Mount, truth: &Pose, est: &Pose) -> f64 {
    match task {
        Task::Pose3 => {
            geom::metrics::heading_error(truth.to_pose3(mount).heading, est.to_pose3(mount).heading)
        }
        Task::Pose6 => geom::metrics::rotation_error(truth, est),
    }
}

/// Dimensions of the rotation error: 1 (heading) for a 3-DoF model, else 3.
pub fn rot_dims(task: Task) -> usize {
    match task {
        Task::Pose3 => 1,
        Task::Pose6 => 3,
    }
}

/// Both fits on validation frames of a model for `task`; `None` for fewer than
/// [`MIN_FRAMES`] frames or errors no covariance explains.
pub fn fit_all(
    frames: &[ValidationFrame],
    task: Task,
) -> Option<(SigmaWeights, UncertaintyCalibration)> {
    if frames.len() < MIN_FRAMES {
        return None;
    }
    let dims = task.pos_dims();
    let parts: Vec<SigmaParts> = frames.iter().map(|f| f.parts).collect();
    let errors: Vec<_> = frames.iter().map(|f| f.error).collect();
    let weights = fit(&parts, &errors, dims);
    let standardised: Vec<Standardised> = frames
        .iter()
        .filter_map(|f| Standardised::of(&f.error, &weights.covariance(&f.parts, dims), dims))
        .collect();
    let position = Calibration::fit(&standardised)?;
    let rd = rot_dims(task);
    let rotation = Calibration::fit(
        &frames
            .iter()
            .filter_map(|f| Standardised::isotropic(f.rot_error.powi(2), f.rot_spread.powi(2), rd))
            .collect::<Vec<_>>(),
    );
    Some((
        weights,
        UncertaintyCalibration {
            position,
            rotation,
            fused: None,
        },
    ))
}

/// The grid's weights: 0, then 10^(k/4) for k = −16..=8.
fn grid() -> Vec<f64> {
    std::iter::once(0.0)
        .chain((-16..=8).map(|k| 10f64.powf(f64::from(k) / 4.0)))
        .collect()
}

/// The weights that best explain `errors` (world metres) by `parts` on the first `dims` axes
/// (see the module docs). A part that is zero on every frame keeps weight 1; with no part at
/// all, or no frame, every weight is 1.
pub fn fit(parts: &[SigmaParts], errors: &[nalgebra::Vector3<f64>], dims: usize) -> SigmaWeights {
    let present: Vec<bool> = (0..3)
        .map(|k| parts.iter().any(|p| p.traces()[k] > 0.0))
        .collect();
    if !present.contains(&true) || errors.is_empty() {
        return SigmaWeights::UNIT;
    }
    let nll = |w: &SigmaWeights| -> f64 {
        parts
            .iter()
            .zip(errors)
            .map(|(p, e)| {
                Standardised::of(e, &w.covariance(p, dims), dims)
                    .map_or(f64::INFINITY, |s| s.log_det + s.r2)
            })
            .sum()
    };
    // Absent parts are held at 1; the others run over the grid.
    let axis = |k: usize| if present[k] { grid() } else { vec![1.0] };
    let mut best = (SigmaWeights::UNIT, f64::INFINITY);
    for &mc in &axis(0) {
        for &tta in &axis(1) {
            for &scale in &axis(2) {
                let w = SigmaWeights { mc, tta, scale };
                let cost = nll(&w);
                if cost < best.1 {
                    best = (w, cost);
                }
            }
        }
    }
    best.0
}

#[cfg(test)]
mod tests {
    use super::*;
    use nalgebra::{Matrix3, Vector3};

    fn iso(var: f64) -> Matrix3<f64> {
        Matrix3::identity() * (var / 3.0)
    }

    fn part(mc: f64, tta: f64, scale: f64) -> SigmaParts {
        SigmaParts {
            mc: iso(mc),
            tta: iso(tta),
            scale: iso(scale),
        }
    }

    #[test]
    fn an_informative_part_outweighs_a_noisy_one() {
        // The TTA part's trace is the squared error over 2 (so weight 2 explains it); the MC
        // part is large and unrelated to the error.
        let errors: Vec<Vector3<f64>> = (0..200)
            .map(|i| {
                let e = 0.05 + 0.01 * f64::from(i % 40);
                Vector3::new(e, -e, e) / 3f64.sqrt()
            })
            .collect();
        let parts: Vec<SigmaParts> = errors
            .iter()
            .enumerate()
            .map(|(i, e)| part(1.0 + (i % 7) as f64, e.norm_squared() / 2.0, 0.0))
            .collect();
        let w = fit(&parts, &errors, 3);
        assert!(w.tta > 1.0 && w.tta < 4.0, "{w:?}");
        assert!(w.mc < 0.01, "{w:?}");
        // Absent throughout: left at 1.
        assert_eq!(w.scale, 1.0);
    }

    #[test]
    fn nothing_to_fit_leaves_unit_weights() {
        assert_eq!(fit(&[], &[], 3), SigmaWeights::UNIT);
        assert_eq!(
            fit(&[part(0.0, 0.0, 0.0)], &[Vector3::new(0.3, 0.0, 0.0)], 3),
            SigmaWeights::UNIT
        );
    }

    /// Errors drawn from Gaussians whose spread the MC part knows up to a factor of 3 and the
    /// TTA part not at all: the fit leans on the MC part and the calibrated regions of fresh
    /// frames hold what they claim.
    #[test]
    fn fitted_regions_cover_fresh_gaussian_errors() {
        use geom::uncertainty::UncertaintyFigures;
        use rand::{Rng, SeedableRng};
        let mut rng = rand_chacha::ChaCha8Rng::seed_from_u64(9);
        let mut gaussian = move || {
            let (u, v): (f64, f64) = (rng.random::<f64>().max(1e-300), rng.random());
            (-2.0 * u.ln()).sqrt() * (2.0 * std::f64::consts::PI * v).cos()
        };
        let mut frames = |n: usize| -> Vec<ValidationFrame> {
            (0..n)
                .map(|i| {
                    let s = 0.05 + 0.05 * (i % 10) as f64;
                    let e = Vector3::new(s * gaussian(), s * gaussian(), s * gaussian());
                    ValidationFrame {
                        error: e,
                        rot_error: 0.01,
                        // The MC part's trace s² is a third of the truth's 3 s².
                        parts: part(s * s, 0.04, 0.0),
                        rot_spread: 0.01,
                    }
                })
                .collect()
        };
        let (val, test) = (frames(600), frames(3000));
        let (w, cal) = fit_all(&val, Task::Pose6).unwrap();
        assert!(w.mc > 1.5 && w.mc < 6.0 && w.tta < 0.1, "{w:?}");
        let scored: Vec<Standardised> = test
            .iter()
            .filter_map(|f| Standardised::of(&f.error, &w.covariance(&f.parts, 3), 3))
            .collect();
        let fig =
            UncertaintyFigures::of(&scored, &vec![1.0; scored.len()], Some(&cal.position)).unwrap();
        assert!((fig.coverage[0] - 0.5).abs() < 0.05, "{fig:?}");
        assert!((fig.coverage[2] - 0.95).abs() < 0.025, "{fig:?}");
    }

    #[test]
    fn too_few_frames_fit_no_calibration() {
        let f = ValidationFrame {
            error: Vector3::new(0.1, 0.0, 0.0),
            rot_error: 0.01,
            parts: part(0.01, 0.0, 0.0),
            rot_spread: 0.01,
        };
        assert!(fit_all(&vec![f; MIN_FRAMES - 1], Task::Pose6).is_none());
        assert!(fit_all(&vec![f; MIN_FRAMES], Task::Pose6).is_some());
    }
}
