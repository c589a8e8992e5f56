//! Marker pose from its four corners: IPPE (infinitesimal plane-based pose estimation, Collins
//! and Bartoli 2014), both solutions, each refined by Gauss-Newton on the reprojection error.
//!
//! Written here because no maintained Rust crate solves planar PnP with both IPPE solutions
//! (kornia-rs has EPnP only, which returns one pose and is unstable for four coplanar points).
//! A square seen from far away or nearly head-on has two poses that reproject almost equally
//! well (the marker tilted towards or away from the camera); both are returned and the pose is
//! flagged `ambiguous` when the second one is nearly as good.
//!
//! Marker frame (OpenCV's `estimatePoseSingleMarkers`): origin at the centre, x to the right,
//! y up, z out of the marker towards the viewer; corners TL (-s/2, s/2), TR (s/2, s/2),
//! BR (s/2, -s/2), BL (-s/2, -s/2).

use crate::types::Marker;
use geom::{Camera, Pose};
use nalgebra::{Matrix2, Matrix3, Matrix6, Point2, Point3, Rotation3, Vector2, Vector3, Vector6};
use serde::Serialize;

/// A pose of the marker in the camera frame, with its reprojection error.
#[derive(Clone, Debug, Serialize)]
pub struct MarkerPoseCandidate {
    /// Marker-to-camera transform (the marker's centre and axes in camera coordinates).
    pub marker_in_camera: Pose,
    /// Root-mean-square reprojection error of the four corners, pixels.
    pub rms_px: f64,
}

/// Both IPPE poses of one marker, the better first.
#[derive(Clone, Debug, Serialize)]
pub struct MarkerPose {
    /// The dictionary id of the marker.
    pub id: u32,
    /// The pose with the lower reprojection error.
    pub best: MarkerPoseCandidate,
    /// The flipped pose (the other local minimum of a planar square).
    pub second: MarkerPoseCandidate,
    /// True when the second pose reprojects nearly as well as the best (within 1 px or 2x), so
    /// that which one is right cannot be told from this marker alone.
    pub ambiguous: bool,
}

/// The marker's corners in its own frame (TL, TR, BR, BL), for a black square of side `size`.
pub fn marker_corners_3d(size: f64) -> [Point3<f64>; 4] {
    let h = size / 2.0;
    [
        Point3::new(-h, h, 0.0),
        Point3::new(h, h, 0.0),
        Point3::new(h, -h, 0.0),
        Point3::new(-h, -h, 0.0),
    ]
}

/// Both poses of a marker of side `size` (metres) seen by `camera`; `None` when the corners are
/// degenerate (collinear, or no pose puts the marker in front of the camera).
pub fn estimate_marker_pose(marker: &Marker, size: f64, camera: &Camera) -> Option<MarkerPose> {
    let object = marker_corners_3d(size);
    let normalized: Vec<Vector2<f64>> = marker
        .corners
        .iter()
        .map(|c| camera.normalized(c))
        .collect();
    let plane: Vec<Vector2<f64>> = object.iter().map(|p| Vector2::new(p.x, p.y)).collect();
    let h = homography(&plane, &normalized)?;
    let (ra, rb) = ippe_rotations(&h)?;
    let mut candidates: Vec<MarkerPoseCandidate> = [ra, rb]
        .into_iter()
        .filter_map(|r| {
            let t = planar_translation(&plane, &normalized, &r)?;
            let (r, t) = refine_pose(&object, &normalized, r, t, 20);
            let rotation = Rotation3::from_matrix(&r);
            let pose = Pose::new(nalgebra::UnitQuaternion::from_rotation_matrix(&rotation), t);
            let rms_px = reprojection_rms(camera, &object, &marker.corners, &r, &t)?;
            Some(MarkerPoseCandidate {
                marker_in_camera: pose,
                rms_px,
            })
        })
        .collect();
    if candidates.is_empty() {
        return None;
    }
    candidates.sort_by(|a, b| a.rms_px.total_cmp(&b.rms_px));
    let best = candidates[0].clone();
    let second = candidates.get(1).cloned().unwrap_or_else(|| best.clone());
    let ambiguous = second.rms_px <= (2.0 * best.rms_px).max(best.rms_px + 1.0);
    Some(MarkerPose {
        id: marker.id,
        best,
        second,
        ambiguous,
    })
}

/// Homography from plane points `(x, y)` to normalised image points, by the normalised DLT
/// (exact for four points, least squares for more); `None` for degenerate input.
pub(crate) fn homography(plane: &[Vector2<f64>], image: &[Vector2<f64>]) -> Option<Matrix3<f64>> {
    if plane.len() < 4 || plane.len() != image.len() {
        return None;
    }
    let (tp, pn) = normalize_points(plane)?;
    let (ti, inn) = normalize_points(image)?;
    let mut a = nalgebra::DMatrix::<f64>::zeros(2 * plane.len().max(5), 9);
    for (k, (p, q)) in pn.iter().zip(&inn).enumerate() {
        let (x, y, u, v) = (p.x, p.y, q.x, q.y);
        let r0 = [-x, -y, -1.0, 0.0, 0.0, 0.0, u * x, u * y, u];
        let r1 = [0.0, 0.0, 0.0, -x, -y, -1.0, v * x, v * y, v];
        for c in 0..9 {
            a[(2 * k, c)] = r0[c];
            a[(2 * k + 1, c)] = r1[c];
        }
    }
    // Null vector of A: the eigenvector of AᵀA with the smallest eigenvalue.
    let ata = a.transpose() * &a;
    let eig = nalgebra::SymmetricEigen::new(ata);
    let (imin, _) = eig
        .eigenvalues
        .iter()
        .enumerate()
        .min_by(|a, b| a.1.total_cmp(b.1))?;
    let hv = eig.eigenvectors.column(imin);
    let hn = Matrix3::from_row_slice(hv.as_slice());
    let h = ti.try_inverse()? * hn * tp;
    let s = h[(2, 2)];
    if !s.is_finite() || s.abs() < 1e-12 {
        return None;
    }
    let h = h / s;
    h.iter().all(|v| v.is_finite()).then_some(h)
}

/// Hartley normalisation: centroid to the origin, mean distance √2.
fn normalize_points(points: &[Vector2<f64>]) -> Option<(Matrix3<f64>, Vec<Vector2<f64>>)> {
    let n = points.len() as f64;
    let c = points.iter().fold(Vector2::zeros(), |a, p| a + p) / n;
    let d = points.iter().map(|p| (p - c).norm()).sum::<f64>() / n;
    if d < 1e-12 {
        return None;
    }
    let s = std::f64::consts::SQRT_2 / d;
    let t = Matrix3::new(s, 0.0, -s * c.x, 0.0, s, -s * c.y, 0.0, 0.0, 1.0);
    Some((t, points.iter().map(|p| (p - c) * s).collect()))
}

/// The two IPPE rotations from the homography's first-order behaviour at the plane's origin.
fn ippe_rotations(h: &Matrix3<f64>) -> Option<(Matrix3<f64>, Matrix3<f64>)> {
    // Jacobian of the homography at (0, 0) and the image of (0, 0).
    let j = Matrix2::new(
        h[(0, 0)] - h[(2, 0)] * h[(0, 2)],
        h[(0, 1)] - h[(2, 1)] * h[(0, 2)],
        h[(1, 0)] - h[(2, 0)] * h[(1, 2)],
        h[(1, 1)] - h[(2, 1)] * h[(1, 2)],
    );
    let (p, q) = (h[(0, 2)], h[(1, 2)]);
    // Rv turns the z axis into the viewing ray of the origin's image.
    let rv = rotation_z_to(&Vector3::new(p, q, 1.0));
    let b = Matrix2::new(
        rv[(0, 0)] - p * rv[(2, 0)],
        rv[(0, 1)] - p * rv[(2, 1)],
        rv[(1, 0)] - q * rv[(2, 0)],
        rv[(1, 1)] - q * rv[(2, 1)],
    );
    let a = b.try_inverse()? * j;
    let gamma = a.singular_values().max();
    if !gamma.is_finite() || gamma < f64::from(f32::EPSILON) {
        return None;
    }
    let rt = a / gamma;
    let b0 = (1.0 - rt[(0, 0)].powi(2) - rt[(1, 0)].powi(2))
        .max(0.0)
        .sqrt();
    let mut b1 = (1.0 - rt[(0, 1)].powi(2) - rt[(1, 1)].powi(2))
        .max(0.0)
        .sqrt();
    if rt[(0, 0)] * rt[(0, 1)] + rt[(1, 0)] * rt[(1, 1)] > 0.0 {
        b1 = -b1;
    }
    let build = |b0: f64, b1: f64| {
        let c0 = Vector3::new(rt[(0, 0)], rt[(1, 0)], b0);
        let c1 = Vector3::new(rt[(0, 1)], rt[(1, 1)], b1);
        rv * Matrix3::from_columns(&[c0, c1, c0.cross(&c1)])
    };
    Some((build(b0, b1), build(-b0, -b1)))
}

/// A rotation whose third column is the unit vector along `v` (it maps z onto `v`).
fn rotation_z_to(v: &Vector3<f64>) -> Matrix3<f64> {
    let z = Vector3::z();
    let target = v.normalize();
    Rotation3::rotation_between(&z, &target)
        .unwrap_or_else(|| Rotation3::from_axis_angle(&Vector3::x_axis(), std::f64::consts::PI))
        .into_inner()
}

/// Least-squares translation for a known rotation: `R P + t` projects onto each image point.
fn planar_translation(
    plane: &[Vector2<f64>],
    image: &[Vector2<f64>],
    r: &Matrix3<f64>,
) -> Option<Vector3<f64>> {
    let mut ata = Matrix3::zeros();
    let mut atb = Vector3::zeros();
    for (p, q) in plane.iter().zip(image) {
        let rp = r * Vector3::new(p.x, p.y, 0.0);
        for (axis, coord) in [(0, q.x), (1, q.y)] {
            // (rp[axis] + t[axis]) - coord (rp.z + t.z) = 0
            let mut row = Vector3::zeros();
            row[axis] = 1.0;
            row[2] = -coord;
            let rhs = coord * rp.z - rp[axis];
            ata += row * row.transpose();
            atb += row * rhs;
        }
    }
    let t = ata.try_inverse()? * atb;
    (t.z > 0.0 && t.iter().all(|v| v.is_finite())).then_some(t)
}

/// Gauss-Newton with Levenberg damping on the normalised reprojection error of `object` points
/// under the object-to-camera transform `(r, t)`.
pub(crate) fn refine_pose(
    object: &[Point3<f64>],
    normalized: &[Vector2<f64>],
    mut r: Matrix3<f64>,
    mut t: Vector3<f64>,
    iterations: usize,
) -> (Matrix3<f64>, Vector3<f64>) {
    let cost = |r: &Matrix3<f64>, t: &Vector3<f64>| -> f64 {
        object
            .iter()
            .zip(normalized)
            .map(|(p, q)| {
                let c = r * p.coords + t;
                if c.z <= 1e-9 {
                    return 1e6;
                }
                (Vector2::new(c.x / c.z, c.y / c.z) - q).norm_squared()
            })
            .sum()
    };
    let mut lambda = 1e-3;
    let mut current = cost(&r, &t);
    for _ in 0..iterations {
        let (jtj, jtr) = normal_equations(object, normalized, &r, &t);
        let mut damped = jtj;
        for i in 0..6 {
            damped[(i, i)] += lambda * (jtj[(i, i)] + 1e-12);
        }
        let Some(step) = damped.cholesky().map(|c| c.solve(&(-jtr))) else {
            break;
        };
        let (r_new, t_new) = apply_step(&r, &t, &step);
        let new = cost(&r_new, &t_new);
        if new < current {
            let converged = current - new < 1e-16 + 1e-12 * current;
            (r, t, current) = (r_new, t_new, new);
            lambda = (lambda * 0.3).max(1e-9);
            if converged {
                break;
            }
        } else {
            lambda *= 10.0;
            if lambda > 1e6 {
                break;
            }
        }
    }
    (r, t)
}

/// `JᵀJ` and `Jᵀr` of the normalised reprojection residuals with respect to a left rotation
/// increment ω (`R ← exp(ω) R`) and a translation increment δ (`t ← t + δ`).
pub(crate) fn normal_equations(
    object: &[Point3<f64>],
    normalized: &[Vector2<f64>],
    r: &Matrix3<f64>,
    t: &Vector3<f64>,
) -> (Matrix6<f64>, Vector6<f64>) {
    let mut jtj = Matrix6::zeros();
    let mut jtr = Vector6::zeros();
    for (p, q) in object.iter().zip(normalized) {
        let rp = r * p.coords;
        let c = rp + t;
        if c.z <= 1e-9 {
            continue;
        }
        let iz = 1.0 / c.z;
        let res = Vector2::new(c.x * iz - q.x, c.y * iz - q.y);
        // d(projection)/d(camera point)
        let dproj = nalgebra::Matrix2x3::new(iz, 0.0, -c.x * iz * iz, 0.0, iz, -c.y * iz * iz);
        // d(camera point)/d(ω) = -[R P]×, d/dδ = I
        let dω = -rp.cross_matrix();
        let mut j = nalgebra::Matrix2x6::zeros();
        j.fixed_view_mut::<2, 3>(0, 0).copy_from(&(dproj * dω));
        j.fixed_view_mut::<2, 3>(0, 3).copy_from(&dproj);
        jtj += j.transpose() * j;
        jtr += j.transpose() * res;
    }
    (jtj, jtr)
}

/// The transform after a step `(ω, δ)`.
pub(crate) fn apply_step(
    r: &Matrix3<f64>,
    t: &Vector3<f64>,
    step: &Vector6<f64>,
) -> (Matrix3<f64>, Vector3<f64>) {
    let omega = Vector3::new(step[0], step[1], step[2]);
    let dr = Rotation3::new(omega).into_inner();
    (dr * r, t + Vector3::new(step[3], step[4], step[5]))
}

/// RMS distance in pixels between the projections of `object` and `pixels`; `None` when a point
/// falls behind the camera.
pub(crate) fn reprojection_rms(
    camera: &Camera,
    object: &[Point3<f64>],
    pixels: &[Point2<f64>],
    r: &Matrix3<f64>,
    t: &Vector3<f64>,
) -> Option<f64> {
    let mut sum = 0.0;
    for (p, px) in object.iter().zip(pixels) {
        let proj = camera.project(&Point3::from(r * p.coords + t))?;
        sum += (proj - px).norm_squared();
    }
    Some((sum / object.len() as f64).sqrt())
}

#[cfg(test)]
pub(crate) mod tests {
    use super::*;
    use nalgebra::UnitQuaternion;

    /// A 640x480 pinhole camera without distortion, f = 500 px.
    pub(crate) fn camera() -> Camera {
        Camera::new(
            640,
            480,
            500.0,
            500.0,
            319.5,
            239.5,
            geom::Distortion::default(),
        )
        .unwrap()
    }

    fn project_marker(camera: &Camera, marker_in_camera: &Pose, size: f64) -> Marker {
        let corners = marker_corners_3d(size).map(|p| {
            camera
                .project(&marker_in_camera.transform_point(&p))
                .unwrap()
        });
        Marker { id: 7, corners }
    }

    #[test]
    fn recovers_a_tilted_marker_exactly() {
        let cam = camera();
        let truth = Pose::new(
            UnitQuaternion::from_euler_angles(0.5, -0.3, 0.2)
                * UnitQuaternion::from_euler_angles(std::f64::consts::PI, 0.0, 0.0),
            Vector3::new(0.2, -0.1, 1.5),
        );
        let marker = project_marker(&cam, &truth, 0.15);
        let pose = estimate_marker_pose(&marker, 0.15, &cam).unwrap();
        let got = &pose.best.marker_in_camera;
        let dp = (Vector3::from(got.position()) - Vector3::from(truth.position())).norm();
        let dr = got.rotation.angle_to(&truth.rotation);
        assert!(dp < 1e-6 && dr < 1e-6, "position {dp} m, rotation {dr} rad");
        assert!(pose.best.rms_px < 1e-6);
        assert!(
            !pose.ambiguous,
            "a strongly tilted near marker is not ambiguous"
        );
    }

    #[test]
    fn a_far_frontal_marker_is_flagged_ambiguous() {
        let cam = camera();
        let truth = Pose::new(
            UnitQuaternion::from_euler_angles(std::f64::consts::PI + 0.02, 0.01, 0.0),
            Vector3::new(0.0, 0.0, 8.0),
        );
        let mut marker = project_marker(&cam, &truth, 0.1);
        marker.corners[0].x += 0.3;
        let pose = estimate_marker_pose(&marker, 0.1, &cam).unwrap();
        assert!(pose.ambiguous, "{pose:?}");
        let depth = pose.best.marker_in_camera.position()[2];
        assert!((depth - 8.0).abs() < 0.5, "depth {depth}");
    }

    #[test]
    fn degenerate_corners_give_none() {
        let cam = camera();
        let p = Point2::new(100.0, 100.0);
        let marker = Marker {
            id: 1,
            corners: [p, p, p, p],
        };
        assert!(estimate_marker_pose(&marker, 0.1, &cam).is_none());
    }
}
