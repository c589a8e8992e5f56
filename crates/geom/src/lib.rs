//! Pose math for indoorloc: camera poses, camera models and the error metrics every evaluation
//! uses. Pure math, no I/O.
//!
//! # Entry points
//! - [`Pose`]: SE(3) camera-to-world pose; [`Pose3`]: x, y, heading on a floor ([`Mount`] says
//!   whether heading is the viewing direction or a ceiling camera's image-up axis).
//! - [`rotation`]: quaternions in `w, x, y, z` and `x, y, z, w` order, matrices, Euler angles.
//! - [`Camera`]: pinhole intrinsics with radial/tangential distortion; project, unproject, undistort.
//! - [`metrics`]: position/rotation/heading errors, statistics, accuracy at thresholds,
//!   smoothness, Pearson correlation.
//! - [`uncertainty`]: coverage of covariance regions, NLL, calibration error, and the
//!   calibration that makes a covariance mean what it claims.
//!
//! # Conventions
//! - Metres; radians inside the code, degrees only in reports.
//! - World: right-handed, z up. Camera: OpenCV (x right, y down, z forward).
//! - A pose maps camera to world: `p_world = R · p_cam + t`, `t` is the camera centre.
//! - Quaternions are Hamilton, stored `w, x, y, z` on the `w ≥ 0` hemisphere.
//! - Rotation error is `2·atan2(|v|, |w|)` of the relative quaternion, never `acos` of a trace.
//!
//! ```
//! use geom::{Pose, metrics::rotation_error_deg};
//! let gt = Pose::from_t_wxyz([1.0, 2.0, 0.5], [1.0, 0.0, 0.0, 0.0])?;
//! let est = Pose::from_euler_ypr(0.01, 0.0, 0.0, [1.0, 2.1, 0.5])?;
//! assert!((rotation_error_deg(&gt, &est) - 0.01f64.to_degrees()).abs() < 1e-9);
//! # Ok::<(), geom::GeomError>(())
//! ```
#![deny(missing_docs)]

mod camera;
mod error;
pub mod metrics;
mod pose;
pub mod rotation;
pub mod uncertainty;

pub use camera::{Camera, Distortion};
pub use error::{GeomError, Result};
pub use pose::{Mount, Pose, Pose3};
