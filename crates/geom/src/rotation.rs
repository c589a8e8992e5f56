//! Rotations from and to the forms datasets store them in: quaternions in `w, x, y, z` or
//! `x, y, z, w` order, 3x3 matrices, and yaw-pitch-roll Euler angles.
//!
//! Files hold rotations rounded to a few decimals, so every constructor accepts a small error,
//! rejects anything beyond it (a wrong column order or garbage shows up as a norm far from 1), and
//! returns an exact rotation.

use crate::error::{GeomError, Result};
use nalgebra::{Matrix3, Quaternion, Rotation3, UnitQuaternion};

/// Largest accepted `|‖q‖ − 1|` for a quaternion read from a file; within it the quaternion is
/// normalised, beyond it the input is rejected.
pub const QUAT_NORM_TOL: f64 = 1e-2;

/// Largest accepted `max |RᵀR − I|` for a rotation matrix read from a file (7-Scenes stores
/// blocks that are orthonormal only to about 1e-4); within it the matrix is projected onto SO(3).
pub const ROTATION_ORTHO_TOL: f64 = 1e-2;

/// A unit quaternion from Hamilton components stored `w, x, y, z`, on the `w ≥ 0` hemisphere.
pub fn quat_from_wxyz(q: [f64; 4]) -> Result<UnitQuaternion<f64>> {
    let [w, x, y, z] = q;
    unit_quaternion(Quaternion::new(w, x, y, z))
}

/// A unit quaternion from Hamilton components stored `x, y, z, w` (TUM, ROS, scipy), on the
/// `w ≥ 0` hemisphere.
pub fn quat_from_xyzw(q: [f64; 4]) -> Result<UnitQuaternion<f64>> {
    let [x, y, z, w] = q;
    unit_quaternion(Quaternion::new(w, x, y, z))
}

fn unit_quaternion(q: Quaternion<f64>) -> Result<UnitQuaternion<f64>> {
    if !q.coords.iter().all(|c| c.is_finite()) {
        return Err(GeomError::NonFinite { what: "quaternion" });
    }
    let norm = q.norm();
    if (norm - 1.0).abs() > QUAT_NORM_TOL {
        return Err(GeomError::NonUnitQuaternion {
            norm,
            tol: QUAT_NORM_TOL,
        });
    }
    // A quaternion printed with all its digits from a unit one is as unit as normalisation can
    // make it; normalising again would move its last bits and break exact write → read round
    // trips, so it is kept as written.
    let unit = if (norm - 1.0).abs() <= AS_WRITTEN_TOL {
        UnitQuaternion::new_unchecked(q)
    } else {
        UnitQuaternion::new_normalize(q)
    };
    Ok(canonical(&unit))
}

/// Largest `|‖q‖ − 1|` at which a quaternion is taken as written, without normalising.
const AS_WRITTEN_TOL: f64 = 8.0 * f64::EPSILON;

/// Components `w, x, y, z` on the `w ≥ 0` hemisphere (the stored form of DESIGN.md).
pub fn quat_to_wxyz(q: &UnitQuaternion<f64>) -> [f64; 4] {
    let c = canonical(q);
    [c.w, c.i, c.j, c.k]
}

/// Components `x, y, z, w` on the `w ≥ 0` hemisphere.
pub fn quat_to_xyzw(q: &UnitQuaternion<f64>) -> [f64; 4] {
    let [w, x, y, z] = quat_to_wxyz(q);
    [x, y, z, w]
}

/// The same rotation with `w ≥ 0`: `q` and `−q` are one rotation, and storing one of them keeps
/// files comparable and regression targets continuous.
pub fn canonical(q: &UnitQuaternion<f64>) -> UnitQuaternion<f64> {
    if q.w < 0.0 {
        UnitQuaternion::new_unchecked(-q.into_inner())
    } else {
        *q
    }
}

/// A rotation from a 3x3 matrix that is orthonormal up to [`ROTATION_ORTHO_TOL`] with
/// determinant +1; the result is the nearest exact rotation.
pub fn rotation_from_matrix(m: &Matrix3<f64>) -> Result<UnitQuaternion<f64>> {
    if !m.iter().all(|v| v.is_finite()) {
        return Err(GeomError::NonFinite {
            what: "rotation matrix",
        });
    }
    let ortho = (m.transpose() * m - Matrix3::identity()).amax();
    if ortho > ROTATION_ORTHO_TOL {
        return Err(GeomError::NotRotation {
            reason: format!("max |RᵀR − I| = {ortho:.3e} (tolerance {ROTATION_ORTHO_TOL})"),
        });
    }
    let det = m.determinant();
    if det < 0.0 {
        return Err(GeomError::NotRotation {
            reason: format!("determinant {det:.4} (a reflection)"),
        });
    }
    // Nearest rotation in the Frobenius sense via polar decomposition (SVD): exact for noisy input,
    // unlike reading a quaternion off the diagonal.
    let svd = m.svd(true, true);
    let (u, v_t) = match (svd.u, svd.v_t) {
        (Some(u), Some(v_t)) => (u, v_t),
        _ => {
            return Err(GeomError::NotRotation {
                reason: "SVD did not converge".into(),
            });
        }
    };
    let r = u * v_t;
    Ok(UnitQuaternion::from_rotation_matrix(
        &Rotation3::from_matrix_unchecked(r),
    ))
}

/// Yaw-pitch-roll (`z`, then `y`, then `x`, intrinsic; `R = Rz(yaw)·Ry(pitch)·Rx(roll)`), radians.
pub fn from_euler_ypr(yaw: f64, pitch: f64, roll: f64) -> UnitQuaternion<f64> {
    UnitQuaternion::from_euler_angles(roll, pitch, yaw)
}

/// The inverse of [`from_euler_ypr`]: `(yaw, pitch, roll)` in radians, pitch in [−π/2, π/2].
pub fn to_euler_ypr(q: &UnitQuaternion<f64>) -> (f64, f64, f64) {
    let (roll, pitch, yaw) = q.euler_angles();
    (yaw, pitch, roll)
}

/// The angle of a rotation in [0, π], as `2·atan2(|v|, |w|)`: accurate near 0 and near π, where
/// `acos` of the trace loses half the digits.
pub fn rotation_angle(q: &UnitQuaternion<f64>) -> f64 {
    2.0 * q.imag().norm().atan2(q.w.abs())
}

/// Wraps an angle to (−π, π].
pub fn wrap_angle(a: f64) -> f64 {
    use std::f64::consts::PI;
    let r = a.rem_euclid(2.0 * PI); // [0, 2π)
    if r > PI { r - 2.0 * PI } else { r }
}

#[cfg(test)]
mod tests {
    use super::*;
    use std::f64::consts::PI;

    #[test]
    fn orders_agree() -> Result<()> {
        // 90° about z: w = cos 45°, z = sin 45°.
        let h = std::f64::consts::FRAC_1_SQRT_2;
        let a = quat_from_wxyz([h, 0.0, 0.0, h])?;
        let b = quat_from_xyzw([0.0, 0.0, h, h])?;
        assert!(a.angle_to(&b) < 1e-12);
        let r = a.to_rotation_matrix();
        // x axis goes to y axis.
        assert!((r * nalgebra::Vector3::x() - nalgebra::Vector3::y()).norm() < 1e-12);
        assert_eq!(quat_to_xyzw(&a), [0.0, 0.0, h, h]);
        Ok(())
    }

    #[test]
    fn hemisphere_is_canonical() -> Result<()> {
        let q = quat_from_wxyz([-0.5, 0.5, 0.5, 0.5])?;
        let [w, x, y, z] = quat_to_wxyz(&q);
        assert!(w >= 0.0);
        assert_eq!([w, x, y, z], [0.5, -0.5, -0.5, -0.5]);
        Ok(())
    }

    #[test]
    fn rejects_non_unit_and_nan() {
        assert!(matches!(
            quat_from_wxyz([1.0, 1.0, 0.0, 0.0]),
            Err(GeomError::NonUnitQuaternion { .. })
        ));
        assert!(matches!(
            quat_from_wxyz([f64::NAN, 0.0, 0.0, 0.0]),
            Err(GeomError::NonFinite { .. })
        ));
        assert!(quat_from_wxyz([1.001, 0.0, 0.0, 0.0]).is_ok());
    }

    #[test]
    fn matrix_projection_and_reflection() -> Result<()> {
        let mut m = Matrix3::identity();
        m[(0, 1)] = 1e-4; // slightly off, as 7-Scenes stores them
        let q = rotation_from_matrix(&m)?;
        assert!(rotation_angle(&q) < 1e-4);
        let reflection = Matrix3::from_diagonal(&nalgebra::Vector3::new(1.0, 1.0, -1.0));
        assert!(rotation_from_matrix(&reflection).is_err());
        assert!(rotation_from_matrix(&(m * 2.0)).is_err());
        Ok(())
    }

    #[test]
    fn euler_round_trip() {
        let q = from_euler_ypr(0.3, -0.2, 0.1);
        let (y, p, r) = to_euler_ypr(&q);
        assert!((y - 0.3).abs() < 1e-12 && (p + 0.2).abs() < 1e-12 && (r - 0.1).abs() < 1e-12);
        // yaw alone is a rotation about world z
        let yaw_only = from_euler_ypr(PI / 2.0, 0.0, 0.0);
        let v = yaw_only * nalgebra::Vector3::x();
        assert!((v - nalgebra::Vector3::y()).norm() < 1e-12);
    }

    #[test]
    fn angle_is_accurate_near_zero_and_pi() {
        let tiny = UnitQuaternion::from_axis_angle(&nalgebra::Vector3::x_axis(), 1e-9);
        assert!((rotation_angle(&tiny) - 1e-9).abs() < 1e-20);
        let near_pi = UnitQuaternion::from_axis_angle(&nalgebra::Vector3::y_axis(), PI - 1e-9);
        assert!((rotation_angle(&near_pi) - (PI - 1e-9)).abs() < 1e-15);
        // q and -q give the same angle
        let neg = UnitQuaternion::new_unchecked(-near_pi.into_inner());
        assert!((rotation_angle(&neg) - rotation_angle(&near_pi)).abs() < 1e-15);
    }

    #[test]
    fn wraps() {
        assert!((wrap_angle(3.0 * PI) - PI).abs() < 1e-12);
        assert!((wrap_angle(-PI) - PI).abs() < 1e-12);
        assert!((wrap_angle(0.5) - 0.5).abs() < 1e-15);
        assert!((wrap_angle(-0.5 - 2.0 * PI) + 0.5).abs() < 1e-12);
    }
}
