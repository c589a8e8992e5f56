//! A temporal filter over per-frame camera poses: constant-velocity Kalman filter on the
//! position (one per axis), a variance-weighted slerp on the rotation, Mahalanobis gating of
//! outliers, and [`PoseFilter::reset`] for scene cuts.
//!
//! Written by hand: the state is six numbers per axis pair and a quaternion; a Kalman crate
//! would bring generic matrices and no gating or re-initialisation policy, which are the point.
//!
//! # Why resets matter
//! Gating is what makes the filter robust: a measurement far from the prediction (a wrong
//! network output) is ignored. The same gate makes a scene cut expensive: after the camera
//! jumps, every correct measurement looks like an outlier, and the filter coasts on its old
//! state until `max_rejections` frames in a row have been refused and it starts over. A reset at
//! the cut starts over at once.

use geom::Pose;
use nalgebra::{Matrix3, UnitQuaternion, Vector3};
use serde::{Deserialize, Serialize};

/// Settings of the filter.
#[derive(Clone, Copy, Debug, PartialEq, Serialize, Deserialize)]
pub struct FilterConfig {
    /// Acceleration noise, m/s² (standard deviation of the unmodelled acceleration): how fast
    /// the camera may change velocity. A walking person: about 1.
    pub accel_noise: f64,
    /// Angular random walk, rad/√s: how fast the heading may wander from the last estimate.
    pub rot_noise: f64,
    /// Least position standard deviation of a measurement per axis, metres (estimators that
    /// report no or tiny uncertainty still get this). A centimetre: the map's and the
    /// markers' fixes are that good, and a larger floor let a network 30 cm off pull the
    /// fused track 5 cm from the map's fixes.
    pub min_pos_sigma: f64,
    /// Least rotation standard deviation of a measurement, radians.
    pub min_rot_sigma: f64,
    /// Gate: a measurement whose squared Mahalanobis distance to the prediction exceeds this is
    /// refused (the default is the 99.7 % point of χ² with 3 degrees of freedom).
    pub gate: f64,
    /// After this many refused measurements in a row the filter starts over from the next one.
    pub max_rejections: u32,
    /// Factor of the position covariance the filter reports (not of its state): the fused
    /// calibration's scale ([`crate::calibrate`]), 1 when there is none.
    #[serde(default = "unit")]
    pub cov_scale: f64,
}

fn unit() -> f64 {
    1.0
}

impl Default for FilterConfig {
    fn default() -> Self {
        FilterConfig {
            accel_noise: 1.0,
            rot_noise: 0.5,
            min_pos_sigma: 0.01,
            min_rot_sigma: 0.01,
            gate: 14.16,
            max_rejections: 10,
            cov_scale: 1.0,
        }
    }
}

/// One frame's estimate from an estimator (network, markers).
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct Measurement {
    /// Time, seconds.
    pub t: f64,
    /// The estimated camera-to-world pose.
    pub pose: Pose,
    /// Position covariance of the estimate, m², world axes (0 if unknown); the filter reads
    /// its diagonal.
    pub cov_pos_m2: Matrix3<f64>,
    /// Rotation standard deviation, radians (0 if unknown).
    pub sigma_rot_rad: f64,
}

/// What the filter did with a measurement.
#[derive(Clone, Copy, Debug, PartialEq, Eq, Serialize, Deserialize)]
#[serde(rename_all = "snake_case")]
pub enum Update {
    /// Started (first frame, after a reset, or after too many refusals).
    Started,
    /// Fused into the state.
    Fused,
    /// Refused by the gate; the output is the prediction.
    Rejected,
}

/// The filter's output for one frame.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct Fused {
    /// The fused pose.
    pub pose: Pose,
    /// `sqrt(trace Σ_pos)` of the state, metres.
    pub sigma_pos_m: f64,
    /// Position variance per world axis, m² (the axes are filtered independently, so the
    /// covariance is diagonal).
    pub pos_var: [f64; 3],
    /// Rotation standard deviation of the state, radians.
    pub sigma_rot_rad: f64,
    /// What happened to the measurement.
    pub update: Update,
}

/// Per-axis state: position, velocity and their 2x2 covariance.
#[derive(Clone, Copy, Debug)]
struct Axis {
    x: f64,
    v: f64,
    /// `[[pxx, pxv], [pxv, pvv]]`.
    p: [f64; 3],
}

impl Axis {
    fn start(x: f64, var: f64) -> Axis {
        // Velocity unknown: 1 m/s standard deviation, a walking pace.
        Axis {
            x,
            v: 0.0,
            p: [var, 0.0, 1.0],
        }
    }

    /// Constant-velocity prediction over `dt` with white acceleration noise of density `q`.
    fn predict(&mut self, dt: f64, q: f64) {
        let [pxx, pxv, pvv] = self.p;
        self.x += self.v * dt;
        let (dt2, dt3, dt4) = (dt * dt, dt * dt * dt, dt * dt * dt * dt);
        self.p = [
            pxx + 2.0 * dt * pxv + dt2 * pvv + q * dt4 / 4.0,
            pxv + dt * pvv + q * dt3 / 2.0,
            pvv + q * dt2,
        ];
    }

    fn innovation(&self, z: f64, r: f64) -> (f64, f64) {
        (z - self.x, self.p[0] + r)
    }

    fn update(&mut self, z: f64, r: f64) {
        let (y, s) = self.innovation(z, r);
        let [pxx, pxv, pvv] = self.p;
        let (kx, kv) = (pxx / s, pxv / s);
        self.x += kx * y;
        self.v += kv * y;
        self.p = [(1.0 - kx) * pxx, (1.0 - kx) * pxv, pvv - kv * pxv];
    }
}

/// The state between frames.
#[derive(Clone, Debug)]
struct State {
    t: f64,
    axes: [Axis; 3],
    rotation: UnitQuaternion<f64>,
    rot_var: f64,
    rejections: u32,
}

/// Constant-velocity pose filter with gating and resets.
#[derive(Clone, Debug)]
pub struct PoseFilter {
    cfg: FilterConfig,
    state: Option<State>,
}

impl PoseFilter {
    /// A filter with no state yet.
    pub fn new(cfg: FilterConfig) -> PoseFilter {
        PoseFilter { cfg, state: None }
    }

    /// Forgets the state: the next measurement starts the filter afresh. Call it at a scene cut.
    pub fn reset(&mut self) {
        self.state = None;
    }

    /// Whether the filter holds a state.
    pub fn is_started(&self) -> bool {
        self.state.is_some()
    }

    /// Measurement variance of `m` per world axis: its covariance's diagonal, at least
    /// `min_pos_sigma²`.
    fn pos_var(&self, m: &Measurement) -> [f64; 3] {
        std::array::from_fn(|k| {
            let v = m.cov_pos_m2[(k, k)];
            let v = if v.is_finite() { v.max(0.0) } else { 0.0 };
            v.max(self.cfg.min_pos_sigma.powi(2))
        })
    }

    fn rot_var(&self, m: &Measurement) -> f64 {
        let s = if m.sigma_rot_rad.is_finite() {
            m.sigma_rot_rad
        } else {
            0.0
        };
        s.max(self.cfg.min_rot_sigma).powi(2)
    }

    fn start(&mut self, m: &Measurement) -> Fused {
        let (r, rr) = (self.pos_var(m), self.rot_var(m));
        let t = m.pose.translation;
        self.state = Some(State {
            t: m.t,
            axes: [
                Axis::start(t.x, r[0]),
                Axis::start(t.y, r[1]),
                Axis::start(t.z, r[2]),
            ],
            rotation: m.pose.rotation,
            rot_var: rr,
            rejections: 0,
        });
        let pos_var = r.map(|v| v * self.cfg.cov_scale);
        Fused {
            pose: m.pose,
            sigma_pos_m: pos_var.iter().sum::<f64>().sqrt(),
            pos_var,
            sigma_rot_rad: rr.sqrt(),
            update: Update::Started,
        }
    }

    /// Feeds the next frame's measurement (times increasing); returns the fused pose.
    pub fn push(&mut self, m: &Measurement) -> Fused {
        let cfg = self.cfg;
        let (r, rr) = (self.pos_var(m), self.rot_var(m));
        let Some(state) = self.state.as_mut() else {
            return self.start(m);
        };
        let dt = (m.t - state.t).clamp(0.0, 10.0);
        state.t = m.t;
        let q = cfg.accel_noise * cfg.accel_noise;
        for a in &mut state.axes {
            a.predict(dt, q);
        }
        state.rot_var += cfg.rot_noise * cfg.rot_noise * dt;
        let z = m.pose.translation;
        let d2: f64 = state
            .axes
            .iter()
            .zip([z.x, z.y, z.z])
            .zip(r)
            .map(|((a, z), r)| {
                let (y, s) = a.innovation(z, r);
                y * y / s
            })
            .sum();
        let update = if d2.is_finite() && d2 <= cfg.gate {
            for ((a, z), r) in state.axes.iter_mut().zip([z.x, z.y, z.z]).zip(r) {
                a.update(z, r);
            }
            let k = state.rot_var / (state.rot_var + rr);
            state.rotation = state
                .rotation
                .try_slerp(&m.pose.rotation, k, 1e-12)
                .unwrap_or(m.pose.rotation);
            state.rot_var *= 1.0 - k;
            state.rejections = 0;
            Update::Fused
        } else {
            state.rejections += 1;
            if state.rejections >= cfg.max_rejections {
                return self.start(m);
            }
            Update::Rejected
        };
        state.output(update, cfg.cov_scale)
    }

    /// The state predicted to time `t` without a measurement (a frame no estimator could
    /// read), reported as refused; `None` before the first measurement. The state itself does
    /// not move, so the next measurement is weighed against the last one seen.
    pub fn predict(&self, t: f64) -> Option<Fused> {
        let mut state = self.state.clone()?;
        let dt = (t - state.t).clamp(0.0, 10.0);
        let q = self.cfg.accel_noise * self.cfg.accel_noise;
        for a in &mut state.axes {
            a.predict(dt, q);
        }
        state.rot_var += self.cfg.rot_noise * self.cfg.rot_noise * dt;
        Some(state.output(Update::Rejected, self.cfg.cov_scale))
    }
}

impl State {
    /// The state as reported, its position covariance times `cov_scale`.
    fn output(&self, update: Update, cov_scale: f64) -> Fused {
        let pos_var =
            [self.axes[0].p[0], self.axes[1].p[0], self.axes[2].p[0]].map(|v| v * cov_scale);
        Fused {
            pose: Pose::new(
                self.rotation,
                Vector3::new(self.axes[0].x, self.axes[1].x, self.axes[2].x),
            ),
            sigma_pos_m: pos_var.iter().sum::<f64>().sqrt(),
            pos_var,
            sigma_rot_rad: self.rot_var.sqrt(),
            update,
        }
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use rand::{Rng, SeedableRng};
    use rand_chacha::ChaCha8Rng;

    fn pose(x: f64, y: f64, yaw: f64) -> Pose {
        Pose::from_euler_ypr(yaw, 0.0, 0.0, [x, y, 1.5]).unwrap_or_default()
    }

    fn m(t: f64, p: Pose, sigma: f64) -> Measurement {
        Measurement {
            t,
            pose: p,
            cov_pos_m2: nalgebra::Matrix3::identity() * (sigma * sigma / 3.0),
            sigma_rot_rad: 0.05,
        }
    }

    /// A walk at 1 m/s along x, measured with 0.3 m noise per axis and an occasional wild
    /// outlier: the filter's error is well below the measurements', outliers are refused.
    #[test]
    fn smooths_noise_and_refuses_outliers() {
        let mut rng = ChaCha8Rng::seed_from_u64(3);
        let mut f = PoseFilter::new(FilterConfig::default());
        let (mut raw, mut fused, mut rejected) = (0.0, 0.0, 0);
        let n = 400;
        for i in 0..n {
            let t = 0.1 * i as f64;
            let truth = pose(t, 2.0, 0.3);
            let mut noisy = truth;
            for k in 0..3 {
                noisy.translation[k] += rng.random_range(-0.5..0.5);
            }
            if i % 50 == 25 {
                noisy.translation.y += 15.0;
            }
            let out = f.push(&m(t, noisy, 0.5));
            if i >= 20 {
                raw += (noisy.translation - truth.translation).norm();
                fused += (out.pose.translation - truth.translation).norm();
            }
            if out.update == Update::Rejected {
                rejected += 1;
                assert!((out.pose.translation - truth.translation).norm() < 1.0);
            }
        }
        assert!(fused < 0.5 * raw, "fused {fused} raw {raw}");
        assert_eq!(rejected, n / 50);
    }

    /// After a jump of 10 m the gated filter refuses the new place until `max_rejections`
    /// frames have passed; a reset at the cut follows at once.
    #[test]
    fn reset_at_a_cut_avoids_the_stale_frames() {
        let cfg = FilterConfig::default();
        let run = |reset: bool| -> Vec<f64> {
            let mut f = PoseFilter::new(cfg);
            let mut errs = Vec::new();
            for i in 0..60 {
                let t = 0.1 * i as f64;
                let truth = if i < 30 {
                    pose(0.1 * i as f64, 0.0, 0.0)
                } else {
                    pose(10.0 + 0.1 * i as f64, 5.0, 1.0)
                };
                if reset && i == 30 {
                    f.reset();
                }
                let out = f.push(&m(t, truth, 0.2));
                errs.push((out.pose.translation - truth.translation).norm());
            }
            errs
        };
        let (none, with_reset) = (run(false), run(true));
        let after = |e: &[f64]| {
            e[30..30 + cfg.max_rejections as usize - 1]
                .iter()
                .sum::<f64>()
        };
        assert!(after(&none) > 50.0, "{:?}", &none[28..45]);
        assert!(after(&with_reset) < 1.0, "{:?}", &with_reset[28..45]);
        // the gated filter does start over after max_rejections refusals
        assert!(none[30 + cfg.max_rejections as usize] < 1.0);
    }

    #[test]
    fn rotation_follows_the_measurements() {
        let mut f = PoseFilter::new(FilterConfig::default());
        let mut out = f.push(&m(0.0, pose(0.0, 0.0, 0.0), 0.1));
        for i in 1..50 {
            out = f.push(&m(0.1 * i as f64, pose(0.0, 0.0, 0.8), 0.1));
        }
        let err = geom::metrics::rotation_error_deg(&out.pose, &pose(0.0, 0.0, 0.8));
        assert!(err < 1.0, "{err}");
    }
}
