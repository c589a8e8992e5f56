//! Error metrics and statistics for pose estimates against ground truth.
//!
//! Rotation errors use `2·atan2(|v|, |w|)` of the relative quaternion, accurate at every angle;
//! statistics follow numpy's definitions (median of an even count averages the middle two,
//! percentiles interpolate linearly) so figures agree with the Python tools people check against.

use crate::error::{GeomError, Result};
use crate::pose::{Pose, Pose3};
use crate::rotation::{rotation_angle, wrap_angle};
use serde::{Deserialize, Serialize};

/// The accuracy thresholds reported everywhere: (metres, degrees), a frame counts when both its
/// position and its rotation error are within.
pub const ACCURACY_THRESHOLDS: [(f64, f64); 3] = [(0.25, 2.0), (0.5, 5.0), (5.0, 10.0)];

/// Euclidean distance between the camera centres, metres.
pub fn position_error(gt: &Pose, est: &Pose) -> f64 {
    (est.translation - gt.translation).norm()
}

/// Angle of `R_gtᵀ R_est`, radians in [0, π].
pub fn rotation_error(gt: &Pose, est: &Pose) -> f64 {
    rotation_angle(&(gt.rotation.inverse() * est.rotation))
}

/// [`rotation_error`] in degrees.
pub fn rotation_error_deg(gt: &Pose, est: &Pose) -> f64 {
    rotation_error(gt, est).to_degrees()
}

/// Absolute heading difference wrapped to [0, π], radians.
pub fn heading_error(gt: f64, est: f64) -> f64 {
    wrap_angle(est - gt).abs()
}

/// Summary statistics of a list of non-negative errors.
#[derive(Clone, Copy, Debug, PartialEq, Serialize, Deserialize)]
pub struct Stats {
    /// Number of values.
    pub count: usize,
    /// Median (mean of the middle two for an even count).
    pub median: f64,
    /// Arithmetic mean.
    pub mean: f64,
    /// Root mean square.
    pub rmse: f64,
    /// Mean square.
    pub mse: f64,
    /// Population standard deviation.
    pub std: f64,
    /// Smallest value.
    pub min: f64,
    /// Largest value.
    pub max: f64,
    /// 25th percentile.
    pub p25: f64,
    /// 75th percentile.
    pub p75: f64,
    /// 90th percentile.
    pub p90: f64,
    /// 95th percentile.
    pub p95: f64,
}

impl Stats {
    /// Statistics of `values`; an error for an empty list or a non-finite value.
    pub fn of(values: &[f64]) -> Result<Stats> {
        if values.is_empty() {
            return Err(GeomError::BadInput("statistics of no values".into()));
        }
        if !values.iter().all(|v| v.is_finite()) {
            return Err(GeomError::NonFinite { what: "error list" });
        }
        let mut sorted = values.to_vec();
        sorted.sort_unstable_by(f64::total_cmp);
        let n = values.len() as f64;
        let mean = values.iter().sum::<f64>() / n;
        let mse = values.iter().map(|v| v * v).sum::<f64>() / n;
        let var = values.iter().map(|v| (v - mean) * (v - mean)).sum::<f64>() / n;
        Ok(Stats {
            count: values.len(),
            median: percentile_sorted(&sorted, 50.0),
            mean,
            rmse: mse.sqrt(),
            mse,
            std: var.sqrt(),
            min: sorted[0],
            max: sorted[sorted.len() - 1],
            p25: percentile_sorted(&sorted, 25.0),
            p75: percentile_sorted(&sorted, 75.0),
            p90: percentile_sorted(&sorted, 90.0),
            p95: percentile_sorted(&sorted, 95.0),
        })
    }
}

/// The `p`-th percentile (0–100) of ascending `sorted` values, interpolated linearly between
/// neighbours (numpy's default); NaN for an empty list.
pub fn percentile_sorted(sorted: &[f64], p: f64) -> f64 {
    if sorted.is_empty() {
        return f64::NAN;
    }
    let rank = (p / 100.0).clamp(0.0, 1.0) * (sorted.len() - 1) as f64;
    let lo = rank.floor() as usize;
    let hi = rank.ceil() as usize;
    sorted[lo] + (sorted[hi] - sorted[lo]) * (rank - lo as f64)
}

/// Per-axis errors of signed differences `est − gt`: mean absolute, mean square, root mean square.
#[derive(Clone, Debug, PartialEq, Serialize, Deserialize)]
pub struct AxisErrors {
    /// Mean absolute error per axis.
    pub mae: Vec<f64>,
    /// Mean squared error per axis.
    pub mse: Vec<f64>,
    /// Root mean squared error per axis.
    pub rmse: Vec<f64>,
}

impl AxisErrors {
    /// From per-frame signed differences (one row per frame, one column per axis).
    pub fn of<const D: usize>(diffs: &[[f64; D]]) -> Result<AxisErrors> {
        if diffs.is_empty() {
            return Err(GeomError::BadInput("axis errors of no frames".into()));
        }
        let n = diffs.len() as f64;
        let mut mae = vec![0.0; D];
        let mut mse = vec![0.0; D];
        for row in diffs {
            for (axis, d) in row.iter().enumerate() {
                mae[axis] += d.abs() / n;
                mse[axis] += d * d / n;
            }
        }
        let rmse = mse.iter().map(|v| v.sqrt()).collect();
        Ok(AxisErrors { mae, mse, rmse })
    }
}

/// Fraction (0–1) of frames with position error ≤ `max_m` and rotation error ≤ `max_deg`.
pub fn accuracy(pos_err_m: &[f64], rot_err_deg: &[f64], max_m: f64, max_deg: f64) -> f64 {
    if pos_err_m.is_empty() {
        return 0.0;
    }
    let hits = pos_err_m
        .iter()
        .zip(rot_err_deg)
        .filter(|&(&p, &r)| p <= max_m && r <= max_deg)
        .count();
    hits as f64 / pos_err_m.len() as f64
}

/// Accuracy at one threshold pair.
#[derive(Clone, Copy, Debug, PartialEq, Serialize, Deserialize)]
pub struct AccuracyAt {
    /// Position threshold, metres.
    pub max_m: f64,
    /// Rotation threshold, degrees.
    pub max_deg: f64,
    /// Fraction of frames within both, 0–1.
    pub fraction: f64,
}

/// How a trajectory moves from frame to frame: steadier estimates step like the ground truth.
#[derive(Clone, Copy, Debug, PartialEq, Serialize, Deserialize)]
pub struct Smoothness {
    /// Mean distance between consecutive camera centres, metres.
    pub mean_step_m: f64,
    /// Standard deviation of that distance, metres.
    pub std_step_m: f64,
    /// Mean rotation between consecutive frames, degrees.
    pub mean_step_deg: f64,
    /// Standard deviation of that rotation, degrees.
    pub std_step_deg: f64,
}

impl Smoothness {
    /// Step statistics of consecutive poses; `None` for fewer than two poses.
    pub fn of(poses: &[Pose]) -> Option<Smoothness> {
        if poses.len() < 2 {
            return None;
        }
        let steps: Vec<f64> = poses
            .windows(2)
            .map(|w| position_error(&w[0], &w[1]))
            .collect();
        let turns: Vec<f64> = poses
            .windows(2)
            .map(|w| rotation_error_deg(&w[0], &w[1]))
            .collect();
        let (mean_step_m, std_step_m) = mean_std(&steps);
        let (mean_step_deg, std_step_deg) = mean_std(&turns);
        Some(Smoothness {
            mean_step_m,
            std_step_m,
            mean_step_deg,
            std_step_deg,
        })
    }

    /// `self − reference`, field by field (positive: this trajectory moves more jerkily).
    pub fn minus(&self, reference: &Smoothness) -> Smoothness {
        Smoothness {
            mean_step_m: self.mean_step_m - reference.mean_step_m,
            std_step_m: self.std_step_m - reference.std_step_m,
            mean_step_deg: self.mean_step_deg - reference.mean_step_deg,
            std_step_deg: self.std_step_deg - reference.std_step_deg,
        }
    }
}

fn mean_std(v: &[f64]) -> (f64, f64) {
    let n = v.len() as f64;
    let mean = v.iter().sum::<f64>() / n;
    let var = v.iter().map(|x| (x - mean) * (x - mean)).sum::<f64>() / n;
    (mean, var.sqrt())
}

/// Mean absolute change of an error between consecutive frames (frame-to-frame jitter);
/// 0 for fewer than two values.
pub fn jitter(errors: &[f64]) -> f64 {
    if errors.len() < 2 {
        return 0.0;
    }
    errors.windows(2).map(|w| (w[1] - w[0]).abs()).sum::<f64>() / (errors.len() - 1) as f64
}

/// Pearson correlation of two equally long lists (used for predicted uncertainty against
/// actual error); an error when lengths differ, fewer than two values, or a list is constant.
pub fn pearson(a: &[f64], b: &[f64]) -> Result<f64> {
    if a.len() != b.len() {
        return Err(GeomError::BadInput(format!(
            "pearson: lengths differ ({} vs {})",
            a.len(),
            b.len()
        )));
    }
    if a.len() < 2 {
        return Err(GeomError::BadInput(
            "pearson: needs at least two values".into(),
        ));
    }
    let n = a.len() as f64;
    let ma = a.iter().sum::<f64>() / n;
    let mb = b.iter().sum::<f64>() / n;
    let (mut sab, mut saa, mut sbb) = (0.0, 0.0, 0.0);
    for (x, y) in a.iter().zip(b) {
        let (dx, dy) = (x - ma, y - mb);
        sab += dx * dy;
        saa += dx * dx;
        sbb += dy * dy;
    }
    if saa == 0.0 || sbb == 0.0 {
        return Err(GeomError::BadInput("pearson: a list is constant".into()));
    }
    Ok(sab / (saa.sqrt() * sbb.sqrt()))
}

/// Everything `eval` reports for matched 6-DoF poses, plus the per-frame errors behind it.
#[derive(Clone, Debug, PartialEq, Serialize, Deserialize)]
pub struct PoseEvaluation {
    /// Per-frame position errors, metres.
    pub pos_err_m: Vec<f64>,
    /// Per-frame rotation errors, degrees.
    pub rot_err_deg: Vec<f64>,
    /// Statistics of the position errors, metres.
    pub position: Stats,
    /// Statistics of the rotation errors, degrees.
    pub rotation_deg: Stats,
    /// Per-axis (x, y, z) position errors, metres.
    pub axes: AxisErrors,
    /// Accuracy at [`ACCURACY_THRESHOLDS`].
    pub accuracy: Vec<AccuracyAt>,
    /// Step statistics of the estimate.
    pub smoothness_est: Option<Smoothness>,
    /// Step statistics of the ground truth.
    pub smoothness_gt: Option<Smoothness>,
    /// Frame-to-frame jitter of the position error, metres.
    pub jitter_m: f64,
}

impl PoseEvaluation {
    /// Compares matched lists (`gt[i]` belongs with `est[i]`).
    pub fn of(gt: &[Pose], est: &[Pose]) -> Result<PoseEvaluation> {
        if gt.len() != est.len() {
            return Err(GeomError::BadInput(format!(
                "{} ground-truth poses but {} estimates",
                gt.len(),
                est.len()
            )));
        }
        let pos_err_m: Vec<f64> = gt
            .iter()
            .zip(est)
            .map(|(g, e)| position_error(g, e))
            .collect();
        let rot_err_deg: Vec<f64> = gt
            .iter()
            .zip(est)
            .map(|(g, e)| rotation_error_deg(g, e))
            .collect();
        let diffs: Vec<[f64; 3]> = gt
            .iter()
            .zip(est)
            .map(|(g, e)| (e.translation - g.translation).into())
            .collect();
        Ok(PoseEvaluation {
            position: Stats::of(&pos_err_m)?,
            rotation_deg: Stats::of(&rot_err_deg)?,
            axes: AxisErrors::of(&diffs)?,
            accuracy: accuracy_table(&pos_err_m, &rot_err_deg),
            smoothness_est: Smoothness::of(est),
            smoothness_gt: Smoothness::of(gt),
            jitter_m: jitter(&pos_err_m),
            pos_err_m,
            rot_err_deg,
        })
    }

    /// Accuracy fraction at a threshold pair of [`ACCURACY_THRESHOLDS`] (or any other).
    pub fn accuracy_at(&self, max_m: f64, max_deg: f64) -> f64 {
        accuracy(&self.pos_err_m, &self.rot_err_deg, max_m, max_deg)
    }
}

fn accuracy_table(pos: &[f64], rot: &[f64]) -> Vec<AccuracyAt> {
    ACCURACY_THRESHOLDS
        .iter()
        .map(|&(max_m, max_deg)| AccuracyAt {
            max_m,
            max_deg,
            fraction: accuracy(pos, rot, max_m, max_deg),
        })
        .collect()
}

/// Errors of matched 3-DoF poses: position in the floor plane and wrapped heading.
#[derive(Clone, Debug, PartialEq, Serialize, Deserialize)]
pub struct Pose3Evaluation {
    /// Per-frame planar position errors, metres.
    pub pos_err_m: Vec<f64>,
    /// Per-frame heading errors, degrees.
    pub heading_err_deg: Vec<f64>,
    /// Statistics of the position errors.
    pub position: Stats,
    /// Statistics of the heading errors, degrees.
    pub heading_deg: Stats,
    /// Per-axis errors of (x, y, heading), metres and radians.
    pub axes: AxisErrors,
    /// Accuracy at [`ACCURACY_THRESHOLDS`] with heading error as the angle.
    pub accuracy: Vec<AccuracyAt>,
}

impl Pose3Evaluation {
    /// Compares matched lists of 3-DoF poses.
    pub fn of(gt: &[Pose3], est: &[Pose3]) -> Result<Pose3Evaluation> {
        if gt.len() != est.len() {
            return Err(GeomError::BadInput(format!(
                "{} ground-truth poses but {} estimates",
                gt.len(),
                est.len()
            )));
        }
        let diffs: Vec<[f64; 3]> = gt
            .iter()
            .zip(est)
            .map(|(g, e)| [e.x - g.x, e.y - g.y, wrap_angle(e.heading - g.heading)])
            .collect();
        let pos_err_m: Vec<f64> = diffs.iter().map(|d| d[0].hypot(d[1])).collect();
        let heading_err_deg: Vec<f64> = diffs.iter().map(|d| d[2].abs().to_degrees()).collect();
        Ok(Pose3Evaluation {
            position: Stats::of(&pos_err_m)?,
            heading_deg: Stats::of(&heading_err_deg)?,
            axes: AxisErrors::of(&diffs)?,
            accuracy: accuracy_table(&pos_err_m, &heading_err_deg),
            pos_err_m,
            heading_err_deg,
        })
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use std::f64::consts::PI;

    #[test]
    fn stats_follow_numpy() -> Result<()> {
        let s = Stats::of(&[4.0, 1.0, 3.0, 2.0])?;
        assert_eq!(s.median, 2.5);
        assert_eq!(s.mean, 2.5);
        assert!((s.rmse - 7.5f64.sqrt()).abs() < 1e-15);
        assert_eq!((s.min, s.max), (1.0, 4.0));
        // numpy.percentile([1,2,3,4], 90) = 3.7
        assert!((s.p90 - 3.7).abs() < 1e-12);
        assert!(Stats::of(&[]).is_err());
        assert!(Stats::of(&[f64::NAN]).is_err());
        Ok(())
    }

    #[test]
    fn heading_wraps() {
        assert!((heading_error(PI - 0.1, -PI + 0.1) - 0.2).abs() < 1e-12);
        assert!((heading_error(0.0, 2.0 * PI) - 0.0).abs() < 1e-12);
    }

    #[test]
    fn accuracy_counts_both_thresholds() {
        let pos = [0.1, 0.3, 0.1, 6.0];
        let rot = [1.0, 1.0, 3.0, 1.0];
        assert_eq!(accuracy(&pos, &rot, 0.25, 2.0), 0.25);
        assert_eq!(accuracy(&pos, &rot, 0.5, 5.0), 0.75);
        assert_eq!(accuracy(&pos, &rot, 5.0, 10.0), 0.75);
    }

    #[test]
    fn pearson_hand_checked() -> Result<()> {
        assert!((pearson(&[1.0, 2.0, 3.0], &[2.0, 4.0, 6.0])? - 1.0).abs() < 1e-15);
        assert!((pearson(&[1.0, 2.0, 3.0], &[3.0, 2.0, 1.0])? + 1.0).abs() < 1e-15);
        // x = [1,2,3,4], y = [1,3,2,4]: r = 0.8
        assert!((pearson(&[1.0, 2.0, 3.0, 4.0], &[1.0, 3.0, 2.0, 4.0])? - 0.8).abs() < 1e-12);
        assert!(pearson(&[1.0, 1.0], &[1.0, 2.0]).is_err());
        assert!(pearson(&[1.0], &[1.0, 2.0]).is_err());
        Ok(())
    }

    #[test]
    fn smoothness_of_a_steady_walk() -> Result<()> {
        let poses: Vec<Pose> = (0..5)
            .map(|i| Pose::from_euler_ypr(0.1 * i as f64, 0.0, 0.0, [0.5 * i as f64, 0.0, 0.0]))
            .collect::<Result<_>>()?;
        let s = Smoothness::of(&poses).ok_or(GeomError::BadInput("none".into()))?;
        assert!((s.mean_step_m - 0.5).abs() < 1e-12 && s.std_step_m < 1e-12);
        assert!((s.mean_step_deg - 0.1f64.to_degrees()).abs() < 1e-9);
        assert!(Smoothness::of(&poses[..1]).is_none());
        assert!(s.minus(&s).mean_step_m.abs() < 1e-15);
        Ok(())
    }

    #[test]
    fn jitter_of_errors() {
        assert_eq!(jitter(&[1.0, 2.0, 1.0]), 1.0);
        assert_eq!(jitter(&[1.0]), 0.0);
    }

    #[test]
    fn pose_evaluation_hand_checked() -> Result<()> {
        let gt = vec![Pose::identity(); 2];
        let est = vec![
            Pose::from_euler_ypr(0.0, 0.0, 0.0, [0.3, 0.4, 0.0])?,
            Pose::from_euler_ypr(PI - 1e-7, 0.0, 0.0, [0.0, 0.0, 0.0])?,
        ];
        let ev = PoseEvaluation::of(&gt, &est)?;
        assert!((ev.pos_err_m[0] - 0.5).abs() < 1e-15);
        assert!((ev.rot_err_deg[1] - (PI - 1e-7).to_degrees()).abs() < 1e-9);
        assert_eq!(ev.axes.mae, vec![0.15, 0.2, 0.0]);
        assert!(PoseEvaluation::of(&gt, &est[..1]).is_err());
        Ok(())
    }

    #[test]
    fn pose3_evaluation_wraps_heading() -> Result<()> {
        let gt = [Pose3::new(0.0, 0.0, PI - 0.01)?];
        let est = [Pose3::new(3.0, 4.0, -PI + 0.01)?];
        let ev = Pose3Evaluation::of(&gt, &est)?;
        assert!((ev.pos_err_m[0] - 5.0).abs() < 1e-12);
        assert!((ev.heading_err_deg[0] - 0.02f64.to_degrees()).abs() < 1e-9);
        Ok(())
    }
}
