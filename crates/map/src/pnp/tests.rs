use super::*;
use rand_chacha::ChaCha8Rng;

fn camera() -> Camera {
    Camera {
        width: 640,
        height: 480,
        fx: 525.0,
        fy: 525.0,
        cx: 320.0,
        cy: 240.0,
        dist: Default::default(),
    }
}

/// A camera 1.5 m up, looking along +y (OpenCV axes: z forward), slightly turned.
fn true_pose() -> Pose {
    let look = UnitQuaternion::from_euler_angles(-std::f64::consts::FRAC_PI_2, 0.1, 0.2);
    Pose::new(look, Vector3::new(0.3, -0.2, 1.5))
}

/// `n` points 1–4 m in front of the camera, seen at their true pixels plus Gaussian-ish noise
/// of `noise` pixels; the first `outliers` pixels replaced by random ones.
fn scene(n: usize, noise: f64, outliers: usize, seed: u64) -> Vec<Correspondence> {
    let cam = camera();
    let pose = true_pose();
    let w2c = WorldToCamera::of_pose(&pose);
    let mut rng = ChaCha8Rng::seed_from_u64(seed);
    (0..n)
        .map(|i| {
            let px = Vector2::new(rng.random_range(10.0..630.0), rng.random_range(10.0..470.0));
            let z = rng.random_range(1.0..4.0);
            let cam_pt = Vector3::new(
                (px.x - cam.cx) / cam.fx * z,
                (px.y - cam.cy) / cam.fy * z,
                z,
            );
            let world = w2c.r.transpose() * (cam_pt - w2c.t);
            let jitter = Vector2::new(
                rng.random_range(-noise..=noise),
                rng.random_range(-noise..=noise),
            );
            let pixel = if i < outliers {
                Vector2::new(rng.random_range(0.0..640.0), rng.random_range(0.0..480.0))
            } else {
                px + jitter
            };
            Correspondence {
                world,
                pixel,
                sigma_px: 1.0,
            }
        })
        .collect()
}

#[test]
fn p3p_recovers_the_pose_among_its_solutions() {
    let corr = scene(3, 0.0, 0, 1);
    let cam = camera();
    let f = [0, 1, 2].map(|i| {
        let c = corr[i];
        Vector3::new(
            (c.pixel.x - cam.cx) / cam.fx,
            (c.pixel.y - cam.cy) / cam.fy,
            1.0,
        )
        .normalize()
    });
    let sols = p3p(f, [0, 1, 2].map(|i| corr[i].world));
    assert!(!sols.is_empty() && sols.len() <= 4, "{}", sols.len());
    let truth = true_pose();
    let best = sols
        .iter()
        .map(|s| geom::metrics::position_error(&truth, &s.to_pose()))
        .fold(f64::INFINITY, f64::min);
    assert!(best < 1e-6, "closest solution {best} m away");
}

#[test]
fn ransac_finds_the_pose_through_half_outliers_and_refines_it() {
    let truth = true_pose();
    let corr = scene(300, 0.5, 150, 2);
    let sol = solve(&camera(), &corr, &PnpConfig::default()).expect("a pose");
    let pos = geom::metrics::position_error(&truth, &sol.pose.to_pose());
    let rot = geom::metrics::rotation_error_deg(&truth, &sol.pose.to_pose());
    assert!(pos < 0.01 && rot < 0.2, "{pos} m, {rot}°");
    // Nearly every true inlier kept, nearly every outlier refused.
    let kept_true = sol.inliers.iter().filter(|&&i| i >= 150).count();
    assert!(kept_true >= 145, "{kept_true}");
    assert!(sol.inliers.len() - kept_true <= 5);
    // Uniform noise of ±0.5 px: σ = 0.29 px per coordinate; the RMS over two coordinates 0.41.
    assert!((0.25..0.6).contains(&sol.rms_px), "{}", sol.rms_px);
    // The covariance is positive and its scale matches the error seen.
    let sd = sol.cov_pos_m2.trace().sqrt();
    assert!(sd > 0.0 && sd < 0.02, "{sd}");
    assert!(pos < 5.0 * sd, "{pos} vs σ {sd}");
}

#[test]
fn too_few_or_random_correspondences_give_no_pose() {
    assert!(solve(&camera(), &scene(3, 0.0, 0, 3), &PnpConfig::default()).is_none());
    let noise = scene(60, 0.0, 60, 4);
    let sol = solve(&camera(), &noise, &PnpConfig::default());
    // Random pixels can be fitted by a few points at most.
    let kept = sol.map_or(0, |s| s.inliers.len());
    assert!(kept < 10, "{kept}");
}

#[test]
fn covariance_shrinks_with_more_points() {
    let few = solve(&camera(), &scene(30, 1.0, 0, 5), &PnpConfig::default()).unwrap();
    let many = solve(&camera(), &scene(600, 1.0, 0, 5), &PnpConfig::default()).unwrap();
    assert!(many.cov_pos_m2.trace() < few.cov_pos_m2.trace() / 5.0);
}

#[test]
fn a_prior_keeps_hypotheses_near_the_coarse_centre() {
    let truth = true_pose();
    let corr = scene(200, 0.5, 0, 6);
    let c = Vector3::from(truth.position());
    let near = PnpConfig {
        prior: Some(Prior {
            centre: c + Vector3::new(0.3, 0.0, 0.0),
            radius_m: 0.5,
        }),
        ..PnpConfig::default()
    };
    let sol = solve(&camera(), &corr, &near).expect("the true pose is inside the ball");
    assert!(geom::metrics::position_error(&truth, &sol.pose.to_pose()) < 0.01);
    let far = PnpConfig {
        prior: Some(Prior {
            centre: c + Vector3::new(3.0, 0.0, 0.0),
            radius_m: 0.5,
        }),
        ..PnpConfig::default()
    };
    assert!(solve(&camera(), &corr, &far).is_none());
}
