//! What the network's outputs mean: the [`Task`], the position standardisation stored in every
//! checkpoint, and the conversions between poses and output rows.
//!
//! - `pose6`: `[x, y, z, qw, qx, qy, qz]`. The position is standardised (`(p − mean) / std` per
//!   axis) so that buildings of any size give outputs of order one; the quaternion is left raw
//!   and normalised by the loss and the decoder. Targets are put on the `w ≥ 0` hemisphere, since
//!   `q` and `−q` are the same rotation and the network can only learn one of them.
//! - `pose3`: `[x, y, sin θ, cos θ]` for a level camera (heading θ as DESIGN.md defines it for the
//!   dataset's [`Mount`]): the sine/cosine pair has no wrap-around at ±π.

use std::fmt;
use std::str::FromStr;

use geom::{Mount, Pose, Pose3};
use nalgebra::{Quaternion, UnitQuaternion, Vector3};
use serde::{Deserialize, Serialize};

use crate::{LearnError, Result};

/// Smallest position standard deviation used for standardising: an axis that never changes
/// (the camera height of a walk) must not divide by zero.
const MIN_STD: f64 = 1e-3;

/// What the network regresses.
#[derive(Clone, Copy, Debug, PartialEq, Eq, Serialize, Deserialize)]
#[serde(rename_all = "lowercase")]
pub enum Task {
    /// Full 6-DoF pose: position and quaternion.
    Pose6,
    /// 3-DoF pose of a level camera: x, y and heading.
    Pose3,
}

impl Task {
    /// Names accepted by [`Task::from_str`].
    pub const NAMES: &'static [&'static str] = &["pose6", "pose3"];

    /// The task a dataset is made for: `dof = 3` means [`Task::Pose3`].
    pub fn for_dof(dof: u8) -> Task {
        if dof == 3 { Task::Pose3 } else { Task::Pose6 }
    }

    /// The view preset a task trains on when none is given: the ceiling-camera literature's
    /// `gray160` for 3-DoF, `rgb256` (PoseNet's input) for 6-DoF.
    pub fn default_view(self) -> &'static str {
        match self {
            Task::Pose3 => "gray160",
            Task::Pose6 => "rgb256",
        }
    }

    /// Number of network outputs.
    pub fn outputs(self) -> usize {
        match self {
            Task::Pose6 => 7,
            Task::Pose3 => 4,
        }
    }

    /// Number of position outputs (they come first).
    pub fn pos_dims(self) -> usize {
        match self {
            Task::Pose6 => 3,
            Task::Pose3 => 2,
        }
    }

    /// Number of rotation outputs (after the position).
    pub fn rot_dims(self) -> usize {
        self.outputs() - self.pos_dims()
    }
}

impl fmt::Display for Task {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        f.write_str(match self {
            Task::Pose6 => "pose6",
            Task::Pose3 => "pose3",
        })
    }
}

impl FromStr for Task {
    type Err = LearnError;
    fn from_str(s: &str) -> Result<Self> {
        match s.trim() {
            "pose6" => Ok(Task::Pose6),
            "pose3" => Ok(Task::Pose3),
            other => Err(LearnError::Config(format!(
                "unknown task '{other}'; known: {}",
                Task::NAMES.join(", ")
            ))),
        }
    }
}

/// How outputs map to poses: the task, the position standardisation fitted on the training set,
/// the mount of the camera and, for 3-DoF, the height at which decoded poses are placed.
#[derive(Clone, Debug, PartialEq, Serialize, Deserialize)]
pub struct PoseCoding {
    /// The task.
    pub task: Task,
    /// Mean training position per position output, metres.
    pub pos_mean: Vec<f64>,
    /// Standard deviation of training positions per position output, metres (at least 1 mm).
    pub pos_std: Vec<f64>,
    /// How the camera is mounted (what a 3-DoF heading means).
    pub mount: Mount,
    /// Camera height given to decoded 3-DoF poses: the mean training height.
    pub z: f64,
}

impl PoseCoding {
    /// Fits the standardisation to training poses; an error for an empty or non-finite set.
    pub fn fit(task: Task, mount: Mount, poses: &[Pose]) -> Result<PoseCoding> {
        if poses.is_empty() {
            return Err(LearnError::Input("no training poses".into()));
        }
        let d = task.pos_dims();
        let n = poses.len() as f64;
        let mut mean = vec![0.0; d];
        for p in poses {
            for (m, v) in mean.iter_mut().zip(p.translation.iter()) {
                *m += v / n;
            }
        }
        let mut std = vec![0.0; d];
        for p in poses {
            for ((s, v), m) in std.iter_mut().zip(p.translation.iter()).zip(&mean) {
                *s += (v - m) * (v - m) / n;
            }
        }
        let std: Vec<f64> = std.iter().map(|v| v.sqrt().max(MIN_STD)).collect();
        let z = poses.iter().map(|p| p.translation.z).sum::<f64>() / n;
        if !mean.iter().chain(&std).all(|v| v.is_finite()) || !z.is_finite() {
            return Err(LearnError::Input("training poses are not finite".into()));
        }
        Ok(PoseCoding {
            task,
            pos_mean: mean,
            pos_std: std,
            mount,
            z,
        })
    }

    /// Checks the stored values (a hand-edited or damaged `model.toml`).
    pub fn validate(&self) -> std::result::Result<(), String> {
        let d = self.task.pos_dims();
        if self.pos_mean.len() != d || self.pos_std.len() != d {
            return Err(format!(
                "{} needs {d} position means and standard deviations",
                self.task
            ));
        }
        let finite = self.pos_mean.iter().all(|v| v.is_finite()) && self.z.is_finite();
        if !finite || !self.pos_std.iter().all(|v| v.is_finite() && *v > 0.0) {
            return Err("position standardisation is not finite and positive".into());
        }
        Ok(())
    }

    /// The training target of a pose, in metres for the position (the loss de-standardises the
    /// prediction, so position errors are measured in metres and β keeps its meaning).
    pub fn target(&self, pose: &Pose) -> Vec<f32> {
        let t = pose.translation;
        match self.task {
            Task::Pose6 => {
                let q = pose.rotation.quaternion();
                let s = if q.w < 0.0 { -1.0 } else { 1.0 };
                [t.x, t.y, t.z, s * q.w, s * q.i, s * q.j, s * q.k]
                    .iter()
                    .map(|&v| v as f32)
                    .collect()
            }
            Task::Pose3 => {
                let h = pose.to_pose3(self.mount).heading;
                vec![t.x as f32, t.y as f32, h.sin() as f32, h.cos() as f32]
            }
        }
    }

    /// The pose of one output row (`task.outputs()` values). A rotation part of length zero
    /// decodes as the identity (6-DoF) or heading 0 (3-DoF) instead of failing.
    pub fn decode(&self, row: &[f32]) -> Pose {
        let d = self.task.pos_dims();
        let pos: Vec<f64> = (0..d)
            .map(|i| self.pos_mean[i] + self.pos_std[i] * row[i] as f64)
            .collect();
        match self.task {
            Task::Pose6 => {
                let q = Quaternion::new(row[3] as f64, row[4] as f64, row[5] as f64, row[6] as f64);
                let q = if q.norm() > 1e-12 && q.coords.iter().all(|v| v.is_finite()) {
                    let u = UnitQuaternion::from_quaternion(q);
                    if u.w < 0.0 {
                        UnitQuaternion::from_quaternion(-u.into_inner())
                    } else {
                        u
                    }
                } else {
                    UnitQuaternion::identity()
                };
                Pose::new(q, Vector3::new(pos[0], pos[1], pos[2]))
            }
            Task::Pose3 => {
                let (s, c) = (row[2] as f64, row[3] as f64);
                let heading = if s.is_finite() && c.is_finite() {
                    s.atan2(c)
                } else {
                    0.0
                };
                // `Pose3::new` only fails for non-finite input, handled here by the fallback.
                let p3 = Pose3::new(pos[0], pos[1], heading).unwrap_or(Pose3 {
                    x: pos[0],
                    y: pos[1],
                    heading: 0.0,
                });
                p3.to_pose(self.mount, self.z)
            }
        }
    }

    /// The output row that decodes to `pose` (standardised position, unit rotation part): the
    /// inverse of [`PoseCoding::decode`], used by tests and to check a checkpoint's coding.
    pub fn encode(&self, pose: &Pose) -> Vec<f32> {
        let mut row = self.target(pose);
        for ((v, m), s) in row.iter_mut().zip(&self.pos_mean).zip(&self.pos_std) {
            *v = ((*v as f64 - m) / s) as f32;
        }
        row
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn encode_then_decode_is_the_pose() -> Result<()> {
        let poses = [
            Pose::from_euler_ypr(0.3, -0.2, 0.1, [1.0, 2.0, 1.5]).map_err(cfg)?,
            Pose::from_euler_ypr(-2.0, 0.4, 0.0, [3.0, -1.0, 1.6]).map_err(cfg)?,
        ];
        let coding = PoseCoding::fit(Task::Pose6, Mount::Forward, &poses)?;
        for p in &poses {
            let back = coding.decode(&coding.encode(p));
            assert!(geom::metrics::position_error(p, &back) < 1e-5);
            assert!(geom::metrics::rotation_error_deg(p, &back) < 1e-3);
        }
        let level: Vec<Pose> = [(1.0, 2.0, 0.5), (4.0, -3.0, -2.9)]
            .iter()
            .map(|&(x, y, h)| Pose3::new(x, y, h).map(|p| p.to_pose(Mount::Ceiling, 2.5)))
            .collect::<geom::Result<_>>()
            .map_err(cfg)?;
        let coding = PoseCoding::fit(Task::Pose3, Mount::Ceiling, &level)?;
        assert_eq!(coding.pos_mean, vec![2.5, -0.5]);
        for p in &level {
            let back = coding.decode(&coding.encode(p));
            assert!(geom::metrics::position_error(p, &back) < 1e-5);
            assert!(geom::metrics::rotation_error_deg(p, &back) < 1e-3);
        }
        Ok(())
    }

    #[test]
    fn degenerate_rows_decode_without_panicking() -> Result<()> {
        let coding = PoseCoding::fit(Task::Pose6, Mount::Forward, &[Pose::identity()])?;
        assert_eq!(coding.pos_std, vec![MIN_STD; 3]);
        let p = coding.decode(&[0.0; 7]);
        assert_eq!(p.rotation, UnitQuaternion::identity());
        let p = coding.decode(&[f32::NAN; 7]);
        assert_eq!(p.rotation, UnitQuaternion::identity());
        Ok(())
    }

    fn cfg(e: geom::GeomError) -> LearnError {
        LearnError::Input(e.to_string())
    }
}
