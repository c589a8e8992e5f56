//! Keyframe features lifted to 3-D without depth: matched to neighbouring keyframes and
//! triangulated from the keyframes' known poses. This maps any posed photos (a COLMAP model's
//! images, NeRF transforms, Cambridge lists, a phone's walk) where no depth image exists.
//!
//! Each keyframe's neighbours are keyframes facing within [`TriangulationConfig::max_view_angle_deg`]
//! of it, taken nearest first but each [`TriangulationConfig::baseline_growth`] times as far as the
//! one before, so that a
//! densely sampled walk still gives baselines of several sizes. A feature's observations are its
//! own pixel and its matches in the neighbours; its point is the one nearest all their rays
//! (least squares), and observations that reproject worse than the tolerance are dropped one at
//! a time, worst first. A point is kept with at least two observations left, in front of every
//! camera that sees it, and seen under enough parallax for its depth to mean something.

use crate::keyframes::MappedFeatures;
use features::{Features, MatchConfig};
use geom::{Camera, Pose};
use nalgebra::{Matrix3, Point2, Point3, Vector3};
use rayon::prelude::*;

/// How features are triangulated.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct TriangulationConfig {
    /// Neighbouring keyframes matched against each keyframe.
    pub neighbours: usize,
    /// Neighbours face within this angle of the keyframe, degrees.
    pub max_view_angle_deg: f64,
    /// Each neighbour lies at least this many times as far from the keyframe as the one
    /// before.
    pub baseline_growth: f64,
    /// Least angle between the keyframe's ray and another observation's, degrees.
    pub min_parallax_deg: f64,
    /// Largest reprojection error of a kept observation, pixels at the feature's pyramid level.
    pub max_reprojection_px: f64,
    /// Matching between keyframes.
    pub matching: MatchConfig,
}

impl Default for TriangulationConfig {
    /// Six neighbours within 60°, each twice as far as the last, 2° of parallax, 2 px (chosen
    /// on the kitchen's validation blocks with depth ignored).
    fn default() -> Self {
        TriangulationConfig {
            neighbours: 6,
            max_view_angle_deg: 60.0,
            baseline_growth: 2.0,
            min_parallax_deg: 2.0,
            max_reprojection_px: 2.0,
            matching: MatchConfig::default(),
        }
    }
}

/// A keyframe's features and pose, as triangulation needs them.
pub(crate) struct Viewed<'a> {
    pub features: &'a Features,
    pub pose: &'a Pose,
}

/// The features of each keyframe that triangulate (see the module docs), in keyframe order.
pub(crate) fn triangulate(
    views: &[Viewed],
    camera: &Camera,
    scale_factor: f32,
    cfg: &TriangulationConfig,
    tick: &(dyn Fn() + Sync),
) -> Vec<MappedFeatures> {
    (0..views.len())
        .into_par_iter()
        .map(|i| {
            let out = triangulate_keyframe(views, i, camera, scale_factor, cfg);
            tick();
            out
        })
        .collect()
}

/// The neighbours of keyframe `i` (see the module docs).
fn neighbours(views: &[Viewed], i: usize, cfg: &TriangulationConfig) -> Vec<usize> {
    let pose = views[i].pose;
    let mut near: Vec<(f64, usize)> = views
        .iter()
        .enumerate()
        .filter(|&(j, v)| {
            j != i && geom::metrics::rotation_error_deg(pose, v.pose) < cfg.max_view_angle_deg
        })
        .map(|(j, v)| (geom::metrics::position_error(pose, v.pose), j))
        .filter(|(d, _)| *d > 0.0)
        .collect();
    near.sort_by(|a, b| a.0.total_cmp(&b.0));
    let mut out = Vec::new();
    let mut last = 0.0;
    for (d, j) in near {
        if out.len() == cfg.neighbours {
            break;
        }
        if d >= cfg.baseline_growth * last {
            out.push(j);
            last = d;
        }
    }
    out
}

/// One observation of a feature: the camera's centre, the pixel's ray, the pixel and its
/// tolerance.
struct Observation<'a> {
    pose: &'a Pose,
    centre: Vector3<f64>,
    ray: Vector3<f64>,
    pixel: Point2<f64>,
    tolerance_px: f64,
}

fn observation<'a>(
    camera: &Camera,
    pose: &'a Pose,
    x: f32,
    y: f32,
    level: u8,
    scale_factor: f32,
    cfg: &TriangulationConfig,
) -> Observation<'a> {
    let pixel = Point2::new(f64::from(x), f64::from(y));
    let n = camera.normalized(&pixel);
    Observation {
        pose,
        centre: Vector3::from(pose.position()),
        ray: (pose.rotation_matrix() * Vector3::new(n.x, n.y, 1.0)).normalize(),
        pixel,
        tolerance_px: cfg.max_reprojection_px * f64::from(scale_factor).powi(i32::from(level)),
    }
}

fn triangulate_keyframe(
    views: &[Viewed],
    i: usize,
    camera: &Camera,
    scale_factor: f32,
    cfg: &TriangulationConfig,
) -> MappedFeatures {
    let own = views[i].features;
    let mut matched: Vec<Vec<Observation>> = own
        .keypoints
        .iter()
        .map(|kp| {
            vec![observation(
                camera,
                views[i].pose,
                kp.x,
                kp.y,
                kp.level,
                scale_factor,
                cfg,
            )]
        })
        .collect();
    for j in neighbours(views, i, cfg) {
        let other = views[j].features;
        for m in features::match_descriptors(&own.descriptors, &other.descriptors, &cfg.matching) {
            let kp = &other.keypoints[m.train];
            matched[m.query].push(observation(
                camera,
                views[j].pose,
                kp.x,
                kp.y,
                kp.level,
                scale_factor,
                cfg,
            ));
        }
    }
    let min_parallax_cos = cfg.min_parallax_deg.to_radians().cos();
    let mut out = MappedFeatures::default();
    for (k, mut obs) in matched.into_iter().enumerate() {
        if let Some(p) = point_of(camera, &mut obs, min_parallax_cos) {
            let kp = &own.keypoints[k];
            out.keypoints.push([kp.x, kp.y]);
            out.points.push([p.x as f32, p.y as f32, p.z as f32]);
            out.descriptors.push(own.descriptors[k]);
        }
    }
    out
}

/// The point nearest the rays of `obs` (the first being the keyframe's own), dropping
/// observations that reproject worse than their tolerance, worst first; `None` when fewer
/// than two remain or their parallax is too small.
fn point_of(
    camera: &Camera,
    obs: &mut Vec<Observation>,
    min_parallax_cos: f64,
) -> Option<Point3<f64>> {
    loop {
        if obs.len() < 2
            || !obs[1..]
                .iter()
                .any(|o| o.ray.dot(&obs[0].ray) <= min_parallax_cos)
        {
            return None;
        }
        let p = nearest_to_rays(obs)?;
        let errors: Vec<f64> = obs
            .iter()
            .map(|o| {
                camera
                    .project_world(o.pose, &p)
                    .map_or(f64::INFINITY, |q| (q - o.pixel).norm() / o.tolerance_px)
            })
            .collect();
        let (worst, &err) = errors
            .iter()
            .enumerate()
            .max_by(|a, b| a.1.total_cmp(b.1))
            .expect("two observations or more");
        if err <= 1.0 {
            return Some(p);
        }
        if worst == 0 {
            // The keyframe's own pixel does not fit: its matches disagree.
            return None;
        }
        obs.remove(worst);
    }
}

/// The least-squares point of the rays: Σ (I − d dᵀ) x = Σ (I − d dᵀ) c.
fn nearest_to_rays(obs: &[Observation]) -> Option<Point3<f64>> {
    let mut a = Matrix3::zeros();
    let mut b = Vector3::zeros();
    for o in obs {
        let m = Matrix3::identity() - o.ray * o.ray.transpose();
        a += m;
        b += m * o.centre;
    }
    a.lu().solve(&b).map(Point3::from)
}

#[cfg(test)]
mod tests {
    use super::*;
    use features::Keypoint;

    /// Keyframes on a line looking down +z at points on a plane 2 m away: each point's
    /// triangulation is the point itself, and a feature matched to a wrong pixel is refused.
    #[test]
    fn points_seen_from_several_poses_come_back_and_mismatches_do_not() {
        let camera = Camera::new(640, 480, 500.0, 500.0, 320.0, 240.0, Default::default()).unwrap();
        let truth: Vec<Point3<f64>> = (0..40)
            .map(|k| {
                Point3::new(
                    -0.6 + 0.03 * f64::from(k),
                    0.2 * f64::from(k % 5) - 0.4,
                    2.0,
                )
            })
            .collect();
        let poses: Vec<Pose> = (0..4)
            .map(|k| {
                Pose::new(
                    Default::default(),
                    Vector3::new(0.15 * f64::from(k), 0.0, 0.0),
                )
            })
            .collect();
        // Descriptor k is k's bits; every view sees every point (feature k = point k).
        let descriptor = |k: usize| {
            [
                (k as u64).wrapping_mul(0x9e37_79b9_7f4a_7c15),
                !(k as u64),
                k as u64,
                0,
            ]
        };
        let sets: Vec<Features> = poses
            .iter()
            .map(|pose| {
                let mut f = Features::default();
                for (k, p) in truth.iter().enumerate() {
                    let px = camera.project_world(pose, p).unwrap();
                    f.keypoints.push(Keypoint {
                        x: px.x as f32,
                        y: px.y as f32,
                        level: 0,
                        angle: 0.0,
                        response: 1.0,
                    });
                    f.descriptors.push(descriptor(k));
                }
                f
            })
            .collect();
        let mut sets = sets;
        // In the last view, feature 7 lies 30 px off its epipolar lines: view 0 keeps point 7
        // from the others.
        sets[3].keypoints[7].y += 30.0;
        let views: Vec<Viewed> = sets
            .iter()
            .zip(&poses)
            .map(|(features, pose)| Viewed { features, pose })
            .collect();
        let mapped = triangulate(
            &views,
            &camera,
            1.2,
            &TriangulationConfig::default(),
            &|| {},
        );
        assert_eq!(mapped.len(), 4);
        assert_eq!(mapped[0].len(), truth.len());
        for (p, kp) in mapped[0].points.iter().zip(&mapped[0].keypoints) {
            let k = truth
                .iter()
                .position(|t| {
                    let px = camera.project_world(&poses[0], t).unwrap();
                    (px.x as f32 - kp[0]).abs() < 1e-3 && (px.y as f32 - kp[1]).abs() < 1e-3
                })
                .unwrap();
            let err = (Vector3::new(f64::from(p[0]), f64::from(p[1]), f64::from(p[2]))
                - truth[k].coords)
                .norm();
            assert!(err < 1e-3, "point {k} off by {err} m");
        }
        // In view 3 itself, feature 7's own pixel is wrong: no neighbour agrees, so it is dropped.
        assert_eq!(mapped[3].len(), truth.len() - 1);
    }

    #[test]
    fn views_without_parallax_lift_nothing() {
        let camera = Camera::new(64, 48, 50.0, 50.0, 32.0, 24.0, Default::default()).unwrap();
        let o = |pose| Observation {
            pose,
            centre: Vector3::from(pose.position()),
            ray: Vector3::new(0.0, 0.0, 1.0),
            pixel: Point2::new(32.0, 24.0),
            tolerance_px: 2.0,
        };
        let a = Pose::identity();
        let b = Pose::new(Default::default(), Vector3::new(0.001, 0.0, 0.0));
        let mut obs = vec![o(&a), o(&b)];
        assert!(point_of(&camera, &mut obs, 2f64.to_radians().cos()).is_none());
    }
}
