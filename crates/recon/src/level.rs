//! Which way is up in a scan: building models have z up (DESIGN.md), but an RGB-D dataset's
//! world frame is wherever its tracker started (7-Scenes' y points roughly down).
//!
//! A hand-held or head-mounted camera is held upright: its image's down axis (OpenCV y) points
//! down on average, however it pans and tilts — but a short walk that looks down the whole way
//! tilts that average by its pitch. So the cameras give a first guess, and the scan's own
//! horizontal surfaces (floor, table tops, ceiling: triangles within 20° of that guess, facing
//! up or down) give the answer, their area-weighted mean normal. The levelling rotation takes
//! up to +z by the smallest rotation, keeping the dataset's origin, so the transform is a pure
//! rotation that `synth` walks and renders can be mapped back through.

use crate::mesh::ColoredMesh;
use geom::Pose;
use nalgebra::{Unit, UnitQuaternion, Vector3};

/// The rotation from the dataset's frame to a levelled one (z up), as a rigid transform
/// (`p_world = R·p_dataset`), from the cameras' `poses` and the scan's `mesh` (in the dataset's
/// frame); the identity when the cameras give no direction.
pub fn leveling(poses: &[Pose], mesh: &ColoredMesh) -> Pose {
    let up: Vector3<f64> = poses.iter().map(|p| -(p.rotation * Vector3::y())).sum();
    let Some(mut up) = Unit::try_new(up, 1e-9) else {
        return Pose::identity();
    };
    // Twice: the second pass gathers the surfaces the first guess missed.
    for _ in 0..2 {
        let cos_max = 20f64.to_radians().cos();
        let mut sum = Vector3::zeros();
        for t in 0..mesh.triangle_count() {
            let [a, b, c] = mesh
                .triangle(t)
                .map(|p| Vector3::new(f64::from(p[0]), f64::from(p[1]), f64::from(p[2])));
            // Length: twice the area.
            let n = (b - a).cross(&(c - a));
            let len = n.norm();
            if len <= 0.0 {
                continue;
            }
            let cos = n.dot(&up) / len;
            if cos.abs() >= cos_max {
                sum += n * cos.signum();
            }
        }
        match Unit::try_new(sum, 1e-12) {
            Some(refined) => up = refined,
            None => break,
        }
    }
    let rotation =
        UnitQuaternion::rotation_between_axis(&up, &Vector3::z_axis()).unwrap_or_else(|| {
            // Pointing straight down: half a turn about x.
            UnitQuaternion::from_axis_angle(&Vector3::x_axis(), std::f64::consts::PI)
        });
    Pose::new(rotation, Vector3::zeros())
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn upright_cameras_in_a_tilted_frame_are_levelled() {
        // Cameras whose down axis is the frame's +y (7-Scenes-like), panning about it.
        let tilt = UnitQuaternion::from_axis_angle(&Vector3::x_axis(), -0.5 * std::f64::consts::PI);
        let poses: Vec<Pose> = (0..12)
            .map(|i| {
                let pan = UnitQuaternion::from_axis_angle(&Vector3::y_axis(), 0.5 * f64::from(i));
                Pose::new(pan, Vector3::new(f64::from(i), 0.0, 0.0))
            })
            .collect();
        let level = leveling(&poses, &ColoredMesh::default());
        for p in &poses {
            let down = level.rotation * (p.rotation * Vector3::y());
            assert!((down + Vector3::z()).norm() < 1e-9, "{down}");
        }
        // A frame that is already z up (cameras' down = −z) stays as it is.
        let upright: Vec<Pose> = poses
            .iter()
            .map(|p| Pose::new(tilt * p.rotation, p.translation))
            .collect();
        assert!(leveling(&upright, &ColoredMesh::default()).rotation.angle() < 1e-9);
    }

    #[test]
    fn a_tilted_floor_corrects_the_cameras_pitch() {
        // Cameras all pitched 10° down; a floor tilted 3° about x in the dataset's frame.
        let pitch =
            UnitQuaternion::from_axis_angle(&Vector3::x_axis(), -0.5 * std::f64::consts::PI - 0.17);
        let poses = vec![Pose::new(pitch, Vector3::zeros()); 4];
        let tilt = UnitQuaternion::from_axis_angle(&Vector3::x_axis(), 3f64.to_radians());
        let corner = |x: f64, y: f64| {
            let p = tilt * Vector3::new(x, y, 0.0);
            [p.x as f32, p.y as f32, p.z as f32]
        };
        let floor = ColoredMesh {
            positions: vec![
                corner(0.0, 0.0),
                corner(4.0, 0.0),
                corner(4.0, 4.0),
                corner(0.0, 4.0),
            ],
            colors: vec![[0; 3]; 4],
            indices: vec![0, 1, 2, 0, 2, 3],
        };
        let level = leveling(&poses, &floor);
        let up = level.rotation * (tilt * Vector3::z());
        assert!((up - Vector3::z()).norm() < 1e-9, "{up}");
    }
}
