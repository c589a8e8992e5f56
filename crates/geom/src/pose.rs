//! Camera poses: [`Pose`] (SE(3), camera-to-world) and [`Pose3`] (x, y, heading on a floor).

use crate::error::{GeomError, Result};
use crate::rotation::{
    from_euler_ypr, quat_from_wxyz, quat_from_xyzw, quat_to_wxyz, quat_to_xyzw,
    rotation_from_matrix, to_euler_ypr, wrap_angle,
};
use nalgebra::{Matrix3, Matrix4, Point3, UnitQuaternion, Vector3};
use serde::{Deserialize, Serialize};
use std::ops::Mul;

/// A camera pose, camera-to-world: `p_world = R · p_cam + t`, so `t` is the camera centre in the
/// world and the columns of `R` are the camera's x (right), y (down) and z (forward) axes.
#[derive(Clone, Copy, Debug, PartialEq, Serialize, Deserialize)]
pub struct Pose {
    /// Rotation camera → world.
    pub rotation: UnitQuaternion<f64>,
    /// Camera centre in world coordinates, metres.
    pub translation: Vector3<f64>,
}

impl Default for Pose {
    fn default() -> Self {
        Self::identity()
    }
}

impl Pose {
    /// The camera at the world origin, axes aligned with the world's.
    pub fn identity() -> Self {
        Self {
            rotation: UnitQuaternion::identity(),
            translation: Vector3::zeros(),
        }
    }

    /// A pose from its parts.
    pub fn new(rotation: UnitQuaternion<f64>, translation: Vector3<f64>) -> Self {
        Self {
            rotation,
            translation,
        }
    }

    /// From a camera centre and a quaternion stored `w, x, y, z` (validated, then normalised).
    pub fn from_t_wxyz(t: [f64; 3], q: [f64; 4]) -> Result<Self> {
        Ok(Self::new(quat_from_wxyz(q)?, finite_vec(t)?))
    }

    /// From a camera centre and a quaternion stored `x, y, z, w` (TUM order).
    pub fn from_t_xyzw(t: [f64; 3], q: [f64; 4]) -> Result<Self> {
        Ok(Self::new(quat_from_xyzw(q)?, finite_vec(t)?))
    }

    /// From a rotation matrix (validated, projected onto SO(3)) and a translation.
    pub fn from_rt(r: &Matrix3<f64>, t: [f64; 3]) -> Result<Self> {
        Ok(Self::new(rotation_from_matrix(r)?, finite_vec(t)?))
    }

    /// From a homogeneous 4x4 matrix `[R t; 0 0 0 1]`.
    pub fn from_matrix4(m: &Matrix4<f64>) -> Result<Self> {
        let last = [m[(3, 0)], m[(3, 1)], m[(3, 2)], m[(3, 3)]];
        if !last.iter().all(|v| v.is_finite()) {
            return Err(GeomError::NonFinite { what: "4x4 matrix" });
        }
        if (last[0].abs() + last[1].abs() + last[2].abs() + (last[3] - 1.0).abs()) > 1e-6 {
            return Err(GeomError::BadLastRow { row: last });
        }
        let r: Matrix3<f64> = m.fixed_view::<3, 3>(0, 0).into_owned();
        Self::from_rt(&r, [m[(0, 3)], m[(1, 3)], m[(2, 3)]])
    }

    /// From 16 numbers of a 4x4 matrix in row-major order (as text files list them).
    pub fn from_row_major(v: &[f64; 16]) -> Result<Self> {
        Self::from_matrix4(&Matrix4::from_row_slice(v))
    }

    /// The homogeneous 4x4 matrix `[R t; 0 0 0 1]`.
    pub fn to_matrix4(&self) -> Matrix4<f64> {
        let mut m = Matrix4::identity();
        m.fixed_view_mut::<3, 3>(0, 0)
            .copy_from(self.rotation.to_rotation_matrix().matrix());
        m.fixed_view_mut::<3, 1>(0, 3).copy_from(&self.translation);
        m
    }

    /// The 3x3 rotation matrix camera → world.
    pub fn rotation_matrix(&self) -> Matrix3<f64> {
        *self.rotation.to_rotation_matrix().matrix()
    }

    /// Quaternion `w, x, y, z` with `w ≥ 0`.
    pub fn quat_wxyz(&self) -> [f64; 4] {
        quat_to_wxyz(&self.rotation)
    }

    /// Quaternion `x, y, z, w` with `w ≥ 0`.
    pub fn quat_xyzw(&self) -> [f64; 4] {
        quat_to_xyzw(&self.rotation)
    }

    /// Camera centre as an array.
    pub fn position(&self) -> [f64; 3] {
        self.translation.into()
    }

    /// `self ∘ other`: apply `other`, then `self` (for `a_T_b * b_T_c = a_T_c`).
    pub fn compose(&self, other: &Pose) -> Pose {
        Pose::new(
            self.rotation * other.rotation,
            self.rotation * other.translation + self.translation,
        )
    }

    /// The inverse transform (world-to-camera for a camera-to-world pose).
    pub fn inverse(&self) -> Pose {
        let r_inv = self.rotation.inverse();
        Pose::new(r_inv, -(r_inv * self.translation))
    }

    /// Maps a point from this pose's source frame into its target frame.
    pub fn transform_point(&self, p: &Point3<f64>) -> Point3<f64> {
        Point3::from(self.rotation * p.coords + self.translation)
    }

    /// Interpolation at `s ∈ [0, 1]`: linear in position, slerp in rotation (shortest arc).
    pub fn interpolate(&self, other: &Pose, s: f64) -> Pose {
        let rotation = self
            .rotation
            .try_slerp(&other.rotation, s, 1e-12)
            // Antipodal rotations (exactly π apart) have no unique arc; fall back to nlerp.
            .unwrap_or_else(|| self.rotation.nlerp(&other.rotation, s));
        Pose::new(rotation, self.translation.lerp(&other.translation, s))
    }

    /// From yaw, pitch, roll of the rotation (`R = Rz·Ry·Rx`, radians) and a translation.
    pub fn from_euler_ypr(yaw: f64, pitch: f64, roll: f64, t: [f64; 3]) -> Result<Self> {
        Ok(Self::new(from_euler_ypr(yaw, pitch, roll), finite_vec(t)?))
    }

    /// Yaw, pitch, roll of the rotation, radians.
    pub fn euler_ypr(&self) -> (f64, f64, f64) {
        to_euler_ypr(&self.rotation)
    }

    /// The camera's viewing direction (its +z axis) in world coordinates.
    pub fn forward(&self) -> Vector3<f64> {
        self.rotation * Vector3::z()
    }

    /// The 3-DoF pose of this camera on the floor for the given mount.
    pub fn to_pose3(&self, mount: Mount) -> Pose3 {
        let dir = match mount {
            Mount::Forward => self.forward(),
            // Image-up is −y in OpenCV camera axes.
            Mount::Ceiling => self.rotation * -Vector3::y(),
        };
        Pose3 {
            x: self.translation.x,
            y: self.translation.y,
            heading: dir.y.atan2(dir.x),
        }
    }
}

impl Mul for Pose {
    type Output = Pose;
    fn mul(self, rhs: Pose) -> Pose {
        self.compose(&rhs)
    }
}

fn finite_vec(t: [f64; 3]) -> Result<Vector3<f64>> {
    if t.iter().all(|v| v.is_finite()) {
        Ok(Vector3::from(t))
    } else {
        Err(GeomError::NonFinite {
            what: "translation",
        })
    }
}

/// How a camera is mounted, which fixes what "heading" of a 3-DoF pose means.
#[derive(Clone, Copy, Debug, PartialEq, Eq, Serialize, Deserialize, Default)]
#[serde(rename_all = "lowercase")]
pub enum Mount {
    /// Looks horizontally; heading is the yaw of the viewing direction.
    #[default]
    Forward,
    /// Looks straight up at the ceiling; heading is the yaw of the image's up axis.
    Ceiling,
}

/// A 3-DoF pose on a floor: camera centre `x, y` (metres) and heading (radians, (−π, π]).
#[derive(Clone, Copy, Debug, PartialEq, Serialize, Deserialize)]
pub struct Pose3 {
    /// World x of the camera centre, metres.
    pub x: f64,
    /// World y of the camera centre, metres.
    pub y: f64,
    /// Heading, radians, wrapped to (−π, π].
    pub heading: f64,
}

impl Pose3 {
    /// A 3-DoF pose; the heading is wrapped to (−π, π].
    pub fn new(x: f64, y: f64, heading: f64) -> Result<Self> {
        if !(x.is_finite() && y.is_finite() && heading.is_finite()) {
            return Err(GeomError::NonFinite { what: "3-DoF pose" });
        }
        Ok(Self {
            x,
            y,
            heading: wrap_angle(heading),
        })
    }

    /// The level 6-DoF camera pose at height `z` with this heading, for the given mount.
    pub fn to_pose(&self, mount: Mount, z: f64) -> Pose {
        let (s, c) = self.heading.sin_cos();
        // Columns are the camera's x, y, z axes in world coordinates (see the module tests).
        let (x_axis, y_axis, z_axis) = match mount {
            Mount::Forward => (
                Vector3::new(s, -c, 0.0),
                Vector3::new(0.0, 0.0, -1.0),
                Vector3::new(c, s, 0.0),
            ),
            Mount::Ceiling => (
                Vector3::new(-s, c, 0.0),
                Vector3::new(-c, -s, 0.0),
                Vector3::new(0.0, 0.0, 1.0),
            ),
        };
        let r = Matrix3::from_columns(&[x_axis, y_axis, z_axis]);
        Pose::new(
            UnitQuaternion::from_rotation_matrix(&nalgebra::Rotation3::from_matrix_unchecked(r)),
            Vector3::new(self.x, self.y, z),
        )
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::rotation::rotation_angle;
    use std::f64::consts::{FRAC_PI_2, PI};

    fn close(a: &Pose, b: &Pose) -> bool {
        (a.translation - b.translation).norm() < 1e-9
            && rotation_angle(&(a.rotation.inverse() * b.rotation)) < 1e-9
    }

    #[test]
    fn matrix_round_trip() -> Result<()> {
        let p = Pose::from_euler_ypr(0.4, -0.3, 1.2, [1.0, -2.0, 0.5])?;
        let q = Pose::from_matrix4(&p.to_matrix4())?;
        assert!(close(&p, &q));
        Ok(())
    }

    #[test]
    fn hand_checked_pose() -> Result<()> {
        // Camera at (1, 2, 3) looking along world +x, level, OpenCV axes:
        // x_cam → −y_world, y_cam → −z_world, z_cam → +x_world.
        #[rustfmt::skip]
        let rows = [
            0.0, 0.0, 1.0, 1.0,
            -1.0, 0.0, 0.0, 2.0,
            0.0, -1.0, 0.0, 3.0,
            0.0, 0.0, 0.0, 1.0,
        ];
        let p = Pose::from_row_major(&rows)?;
        // A point 2 m in front of the camera lies at (3, 2, 3).
        let w = p.transform_point(&Point3::new(0.0, 0.0, 2.0));
        assert!((w - Point3::new(3.0, 2.0, 3.0)).norm() < 1e-12);
        // The quaternion of that matrix, worked out by hand: w = 0.5, (x, y, z) = (−0.5, 0.5, −0.5).
        let q = p.quat_wxyz();
        for (a, b) in q.iter().zip([0.5, -0.5, 0.5, -0.5]) {
            assert!((a - b).abs() < 1e-12, "{q:?}");
        }
        let p3 = p.to_pose3(Mount::Forward);
        assert!((p3.heading).abs() < 1e-12 && p3.x == 1.0 && p3.y == 2.0);
        assert!(close(&p3.to_pose(Mount::Forward, 3.0), &p));
        Ok(())
    }

    #[test]
    fn compose_and_inverse() -> Result<()> {
        let a = Pose::from_euler_ypr(0.1, 0.2, 0.3, [1.0, 2.0, 3.0])?;
        let b = Pose::from_euler_ypr(-1.0, 0.5, 2.0, [-4.0, 0.0, 1.0])?;
        assert!(close(&(a * a.inverse()), &Pose::identity()));
        let p = Point3::new(0.3, -0.7, 2.0);
        let ab = (a * b).transform_point(&p);
        let a_b = a.transform_point(&b.transform_point(&p));
        assert!((ab - a_b).norm() < 1e-12);
        Ok(())
    }

    #[test]
    fn interpolation_ends_and_middle() -> Result<()> {
        let a = Pose::from_euler_ypr(0.0, 0.0, 0.0, [0.0, 0.0, 0.0])?;
        let b = Pose::from_euler_ypr(FRAC_PI_2, 0.0, 0.0, [2.0, 0.0, 0.0])?;
        assert!(close(&a.interpolate(&b, 0.0), &a));
        assert!(close(&a.interpolate(&b, 1.0), &b));
        let m = a.interpolate(&b, 0.5);
        assert!((m.euler_ypr().0 - FRAC_PI_2 / 2.0).abs() < 1e-12);
        assert!((m.translation.x - 1.0).abs() < 1e-12);
        // antipodal: still a valid rotation
        let c = Pose::from_euler_ypr(PI, 0.0, 0.0, [0.0; 3])?;
        let mid = a.interpolate(&c, 0.5);
        assert!(mid.rotation.w.is_finite());
        Ok(())
    }

    #[test]
    fn pose3_round_trip_both_mounts() -> Result<()> {
        for mount in [Mount::Forward, Mount::Ceiling] {
            for h in [-3.0, -1.0, 0.0, 0.7, 3.1] {
                let p3 = Pose3::new(1.5, -2.0, h)?;
                let back = p3.to_pose(mount, 1.2).to_pose3(mount);
                assert!((back.heading - p3.heading).abs() < 1e-12, "{mount:?} {h}");
                let det = p3.to_pose(mount, 0.0).rotation_matrix().determinant();
                assert!((det - 1.0).abs() < 1e-12);
            }
        }
        // Ceiling camera looks up.
        let up = Pose3::new(0.0, 0.0, 0.3)?
            .to_pose(Mount::Ceiling, 0.0)
            .forward();
        assert!((up - Vector3::z()).norm() < 1e-12);
        Ok(())
    }

    #[test]
    fn bad_matrices_are_errors() {
        let mut rows = [0.0; 16];
        rows[0] = 1.0;
        rows[5] = 1.0;
        rows[10] = 1.0;
        rows[15] = 2.0;
        assert!(matches!(
            Pose::from_row_major(&rows),
            Err(GeomError::BadLastRow { .. })
        ));
        rows[15] = 1.0;
        rows[3] = f64::NAN;
        assert!(Pose::from_row_major(&rows).is_err());
    }
}
