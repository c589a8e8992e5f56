//! Calibration of the fused track's covariance: the filter's own covariance assumes that the
//! measurements' errors are independent from frame to frame, and a network's are not (a walk
//! past the same wall is wrong the same way for a second), so the fused covariance claims more
//! than it holds. The fix is fitted like the network's own ([`geom::uncertainty::Calibration`]):
//! the model's validation walk localized with the calibrated settings (test-time augmentation
//! and [`CALIBRATION_MC`] MC passes), run through the filter, the fused errors against the
//! fused covariances. [`calibrate_model`] stores it in the model's `model.toml`
//! (`uncertainty.fused`); [`FilterConfig::cov_scale`] applies its scale to what the filter
//! reports.

use std::collections::HashMap;
use std::path::Path;

use data::native::SplitName;
use data::posed::{self, SplitPlan};
use geom::Pose;
use geom::uncertainty::{Calibration, Standardised};
use learn::calibrate::{CALIBRATION_MC, ValidationPasses};
use learn::checkpoint::ModelMeta;
use learn::{Estimate, Localizer};
use nalgebra::Matrix3;

use crate::error::{Result, TrackError};
use crate::filter::{FilterConfig, Fused, Measurement, PoseFilter};

/// Frames of a walk in time order with the network's estimates.
pub struct Walk<'a> {
    /// The network's estimate of each frame.
    pub estimates: &'a [Estimate],
    /// Ground truth.
    pub truth: &'a [Pose],
    /// Time, seconds.
    pub t: &'a [f64],
    /// Run of consecutive frames each belongs to: the filter starts over where it changes.
    pub run: &'a [usize],
}

/// The filter (settings `cfg`) over a walk's estimates, started over at each new run.
pub fn fuse(walk: &Walk<'_>, cfg: FilterConfig) -> Vec<Fused> {
    let mut filter = PoseFilter::new(cfg);
    walk.estimates
        .iter()
        .enumerate()
        .map(|(k, e)| {
            if k > 0 && walk.run[k] != walk.run[k - 1] {
                filter.reset();
            }
            filter.push(&Measurement {
                t: walk.t[k],
                pose: e.pose,
                cov_pos_m2: e.cov_pos_m2,
                sigma_rot_rad: e.sigma_rot_deg.to_radians(),
            })
        })
        .collect()
}

/// Fused errors against their covariances on the first `dims` axes, with each σ (metres).
pub fn standardised(fused: &[Fused], truth: &[Pose], dims: usize) -> (Vec<Standardised>, Vec<f64>) {
    fused
        .iter()
        .zip(truth)
        .filter_map(|(f, truth)| {
            let cov = Matrix3::from_diagonal(&f.pos_var.into());
            let s = Standardised::of(&(f.pose.translation - truth.translation), &cov, dims)?;
            Some((s, f.pos_var[..dims].iter().sum::<f64>().sqrt()))
        })
        .unzip()
}

/// The fused track's calibration on a validation walk (position dimensions `dims`), with the
/// filter at its defaults; `None` for too short a walk.
pub fn fit_fused(walk: &Walk<'_>, dims: usize) -> Option<Calibration> {
    let fused = fuse(walk, FilterConfig::default());
    Calibration::fit(&standardised(&fused, walk.truth, dims).0)
}

/// Fits the fused calibration of the model in `dir` on the validation part of `data` (split
/// by `plan`, as training split it) and stores it in `dir/model.toml`. `passes`: the
/// validation frames as training's own calibration estimated them
/// ([`learn::TrainSummary::validation`]), used as they are rather than run through the
/// network again; without them the frames of the `plan`'s validation part are localized now.
/// Returns the calibration; `None` (nothing written) when the model has no network
/// calibration or too few validation frames.
pub fn calibrate_model(
    dir: &Path,
    data: &Path,
    plan: SplitPlan,
    passes: Option<&ValidationPasses>,
) -> Result<Option<Calibration>> {
    let meta = ModelMeta::read(dir)?;
    if meta.uncertainty.is_none() {
        return Ok(None);
    }
    let ds = posed::open(data)?;
    let (index, estimates) = match passes {
        Some(p) => passes_in_order(&ds, p, data)?,
        // The network is loaded only to localize the frames again.
        None => {
            let loc = Localizer::load(dir)?.with_tta(true);
            let parts = ds.parts(plan);
            let index: Vec<usize> = (0..ds.images.len())
                .filter(|&i| parts[i] == Some(SplitName::Val))
                .collect();
            if index.len() < geom::uncertainty::MIN_CALIBRATION_FRAMES {
                return Ok(None);
            }
            let views = index
                .iter()
                .map(|&i| {
                    let img = data::frames::decode_image(&ds.images[i].image)?;
                    Ok(loc.view(&img)?)
                })
                .collect::<Result<Vec<_>>>()?;
            let estimates = loc.predict_batch(&views, CALIBRATION_MC)?;
            (index, estimates)
        }
    };
    let truth: Vec<Pose> = index.iter().map(|&i| ds.images[i].frame.pose).collect();
    // 7-Scenes and most posed sets carry no clock: 30 frames per second, Kinect's rate.
    let rate = ds.info.as_ref().map_or(30.0, |i| i.frame_rate);
    let t: Vec<f64> = index
        .iter()
        .map(|&i| ds.images[i].frame.t.unwrap_or(i as f64 / rate))
        .collect();
    let run = runs(&index, |i| ds.images[i].frame.seq.as_str());
    let dims = meta.coding.task.pos_dims();
    let walk = Walk {
        estimates: &estimates,
        truth: &truth,
        t: &t,
        run: &run,
    };
    let Some(cal) = fit_fused(&walk, dims) else {
        return Ok(None);
    };
    let mut meta = ModelMeta::read(dir)?;
    let Some(u) = meta.uncertainty.as_mut() else {
        return Err(TrackError::Config(format!(
            "{}: the model lost its calibration while the fused one was fitted",
            dir.display()
        )));
    };
    u.fused = Some(cal.clone());
    meta.write(dir)?;
    Ok(Some(cal))
}

/// The dataset index of each frame of `passes` with its estimate, in the dataset's order (the
/// filter walks them in time). A name the dataset (`root`) lacks is an error: the passes come
/// from another dataset.
fn passes_in_order(
    ds: &posed::PosedDataset,
    passes: &ValidationPasses,
    root: &Path,
) -> Result<(Vec<usize>, Vec<Estimate>)> {
    let by_name: HashMap<String, usize> = ds
        .images
        .iter()
        .enumerate()
        .map(|(i, img)| (format!("{}/{}", img.frame.seq, img.frame.name), i))
        .collect();
    let mut frames = passes
        .names
        .iter()
        .zip(&passes.estimates)
        .map(|(name, e)| match by_name.get(name) {
            Some(&i) => Ok((i, e.clone())),
            None => Err(TrackError::Config(format!(
                "{}: no frame `{name}`, which the model was validated on",
                root.display()
            ))),
        })
        .collect::<Result<Vec<_>>>()?;
    frames.sort_by_key(|&(i, _)| i);
    Ok(frames.into_iter().unzip())
}

/// Run ids of frames `index` (ascending): a new run where the sequence changes or a frame is
/// skipped.
pub fn runs<'a>(index: &[usize], seq: impl Fn(usize) -> &'a str) -> Vec<usize> {
    let mut run = 0;
    index
        .iter()
        .enumerate()
        .map(|(k, &i)| {
            if k > 0 && (i != index[k - 1] + 1 || seq(i) != seq(index[k - 1])) {
                run += 1;
            }
            run
        })
        .collect()
}

#[cfg(test)]
mod tests {
    use super::*;
    use rand::{Rng, SeedableRng};

    fn gaussian(rng: &mut impl Rng) -> f64 {
        let (u, v): (f64, f64) = (rng.random::<f64>().max(1e-300), rng.random());
        (-2.0 * u.ln()).sqrt() * (2.0 * std::f64::consts::PI * v).cos()
    }

    /// A walk whose measurement errors drift slowly (correlated from frame to frame) while
    /// each claims its true per-frame spread: the filter averages them as if independent and
    /// claims too much; the fitted calibration grows the covariance.
    #[test]
    fn correlated_errors_make_the_fused_track_overconfident_and_the_fit_says_so() {
        let mut rng = rand_chacha::ChaCha8Rng::seed_from_u64(3);
        let n = 600;
        let sigma = 0.3;
        let mut drift = nalgebra::Vector3::zeros();
        let (mut estimates, mut truth, mut t) = (Vec::new(), Vec::new(), Vec::new());
        for k in 0..n {
            let time = k as f64 * 0.1;
            let p = Pose::new(
                nalgebra::UnitQuaternion::identity(),
                nalgebra::Vector3::new(time, 0.0, 1.5),
            );
            // AR(1) with a 5 s correlation time, stationary spread `sigma` per axis.
            let a: f64 = 0.98;
            let noise = nalgebra::Vector3::from_fn(|_, _| gaussian(&mut rng));
            drift = drift * a + noise * (sigma * (1.0 - a * a).sqrt());
            let mut est = p;
            est.translation += drift;
            estimates.push(Estimate {
                pose: est,
                pose3: None,
                sigma_pos_m: sigma * 3f64.sqrt(),
                cov_pos_m2: Matrix3::identity() * sigma * sigma,
                sigma_rot_deg: 1.0,
                passes: 16,
            });
            truth.push(p);
            t.push(time);
        }
        let run = vec![0; n];
        let walk = Walk {
            estimates: &estimates,
            truth: &truth,
            t: &t,
            run: &run,
        };
        let fused = fuse(&walk, FilterConfig::default());
        let (s, sig) = standardised(&fused, &truth, 3);
        let raw = geom::uncertainty::UncertaintyFigures::of(&s, &sig, None).unwrap();
        assert!(raw.coverage[2] < 0.85, "{raw:?}");
        let cal = fit_fused(&walk, 3).unwrap();
        assert!(cal.scale > 1.5, "{cal:?}");
    }

    #[test]
    fn runs_split_at_gaps_and_sequences() {
        let seqs = ["a", "a", "a", "b", "b", "b", "b"];
        assert_eq!(
            runs(&[0, 1, 2, 3, 5, 6], |i| seqs[i]),
            vec![0, 0, 0, 1, 2, 2]
        );
    }
}
