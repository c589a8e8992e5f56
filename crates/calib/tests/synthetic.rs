//! Calibration of a known camera from synthetic views, and the error paths.

use calib::{Board, CalibError, CalibOptions, calibrate};
use geom::{Camera, Distortion};
use nalgebra::{Point2, Rotation3, Vector3};
use rand::{Rng, SeedableRng};
use rand_chacha::ChaCha8Rng;

fn truth() -> Camera {
    Camera::new(
        640,
        480,
        520.0,
        518.0,
        318.0,
        244.0,
        Distortion::from_array([-0.21, 0.08, 0.0012, -0.0007, -0.01]),
    )
    .unwrap()
}

/// Board-to-camera poses looking at a 9x6 board of 25 mm squares from 0.3-0.5 m.
fn poses() -> Vec<(Vector3<f64>, Vector3<f64>)> {
    let tilts = [
        (0.0, 0.0, 0.0),
        (0.35, 0.0, 0.1),
        (-0.35, 0.1, -0.1),
        (0.0, 0.4, 0.2),
        (0.1, -0.4, -0.2),
        (0.3, 0.3, 1.4),
        (-0.3, -0.25, -1.2),
        (0.2, -0.2, 3.0),
    ];
    tilts
        .iter()
        .enumerate()
        .map(|(k, &(rx, ry, rz))| {
            let r = Rotation3::from_euler_angles(rx, ry, rz);
            // put the board centre on the optical axis, then shift it a little
            let centre = Vector3::new(0.1, 0.0625, 0.0);
            let depth = 0.3 + 0.03 * k as f64;
            let shift = Vector3::new(0.02 * (k as f64 - 3.5), 0.01 * ((k % 3) as f64 - 1.0), 0.0);
            let t = Vector3::new(0.0, 0.0, depth) + shift - r * centre;
            (r.scaled_axis(), t)
        })
        .collect()
}

fn project(cam: &Camera, pose: &(Vector3<f64>, Vector3<f64>), board: &Board) -> Vec<Point2<f64>> {
    let r = Rotation3::from_scaled_axis(pose.0);
    board
        .object_points()
        .iter()
        .map(|x| {
            let p = r * x + pose.1;
            let n = cam.dist.apply(nalgebra::Vector2::new(p.x / p.z, p.y / p.z));
            Point2::new(cam.fx * n.x + cam.cx, cam.fy * n.y + cam.cy)
        })
        .collect()
}

#[test]
fn recovers_known_camera_and_poses() {
    let cam = truth();
    let board = Board::new(9, 6, 0.025);
    let mut rng = ChaCha8Rng::seed_from_u64(7);
    let poses = poses();
    let views: Vec<Vec<Point2<f64>>> = poses
        .iter()
        .map(|p| {
            project(&cam, p, &board)
                .into_iter()
                .map(|q| {
                    assert!(
                        q.x > 0.0 && q.y > 0.0 && q.x < 640.0 && q.y < 480.0,
                        "{q:?}"
                    );
                    Point2::new(
                        q.x + rng.random_range(-0.1..0.1),
                        q.y + rng.random_range(-0.1..0.1),
                    )
                })
                .collect()
        })
        .collect();
    let cal = calibrate(&views, &board, 640, 480, &CalibOptions::default()).unwrap();
    let c = cal.camera;
    println!(
        "synthetic: rms {:.4} fx {:.3} fy {:.3} cx {:.3} cy {:.3} dist {:?}",
        cal.rms,
        c.fx,
        c.fy,
        c.cx,
        c.cy,
        c.dist.to_array()
    );
    for (got, want) in [
        (c.fx, cam.fx),
        (c.fy, cam.fy),
        (c.cx, cam.cx),
        (c.cy, cam.cy),
    ] {
        assert!((got - want).abs() / want < 0.005, "{got} vs {want}");
    }
    assert!(cal.rms < 0.1, "rms {}", cal.rms);
    assert!(cal.used.iter().all(|&u| u));
    for (p, (rvec, tvec)) in cal.poses.iter().zip(&poses) {
        let p = p.expect("pose");
        let dr = (Rotation3::from_scaled_axis(p.rvec).inverse()
            * Rotation3::from_scaled_axis(*rvec))
        .angle();
        assert!(
            dr.to_degrees() < 0.2,
            "rotation off by {} deg",
            dr.to_degrees()
        );
        assert!((p.tvec - tvec).norm() < 0.002, "{:?} vs {tvec:?}", p.tvec);
        // the camera centre in board coordinates is consistent with the pose
        let centre = p.camera_in_board().translation;
        assert!((p.rotation() * centre + p.tvec).norm() < 1e-9);
    }
}

#[test]
fn drops_a_bad_view() {
    let cam = truth();
    let board = Board::new(9, 6, 0.025);
    let mut views: Vec<Vec<Point2<f64>>> =
        poses().iter().map(|p| project(&cam, p, &board)).collect();
    // a view whose corners were mismatched: shuffle some points
    views[3].swap(0, 40);
    views[3].swap(5, 20);
    views[3].swap(10, 53);
    let cal = calibrate(&views, &board, 640, 480, &CalibOptions::default()).unwrap();
    println!("per-view rms with a bad view: {:?}", cal.per_view_rms);
    assert!(!cal.used[3]);
    assert_eq!(cal.used.iter().filter(|&&u| u).count(), 7);
    assert!((cal.camera.fx - cam.fx).abs() / cam.fx < 0.005);
    assert!(cal.rms < 0.01, "rms {}", cal.rms);
}

#[test]
fn clear_errors() {
    let cam = truth();
    let board = Board::new(9, 6, 0.025);
    let views: Vec<Vec<Point2<f64>>> = poses().iter().map(|p| project(&cam, p, &board)).collect();
    let opts = CalibOptions::default();
    assert!(matches!(
        calibrate(&views[..2], &board, 640, 480, &opts),
        Err(CalibError::TooFewViews { got: 2, .. })
    ));
    let mut short = views.clone();
    short[1].pop();
    let e = calibrate(&short, &board, 640, 480, &opts).unwrap_err();
    assert!(
        matches!(
            e,
            CalibError::PointCount {
                view: 1,
                got: 53,
                ..
            }
        ),
        "{e}"
    );
    println!("{e}");
    let mut collinear = views.clone();
    for (i, p) in collinear[0].iter_mut().enumerate() {
        *p = Point2::new(i as f64, 2.0 * i as f64);
    }
    let e = calibrate(&collinear, &board, 640, 480, &opts).unwrap_err();
    assert!(matches!(e, CalibError::Degenerate { .. }), "{e}");
    println!("{e}");
    let mut nan = views.clone();
    nan[2][3].x = f64::NAN;
    assert!(matches!(
        calibrate(&nan, &board, 640, 480, &opts),
        Err(CalibError::Degenerate { .. })
    ));
    // three copies of the same view: no intrinsics
    let same = vec![views[0].clone(), views[0].clone(), views[0].clone()];
    let e = calibrate(&same, &board, 640, 480, &opts).unwrap_err();
    println!("{e}");
    assert!(calibrate(&views, &Board::new(9, 6, 0.0), 640, 480, &opts).is_err());
    assert!(calibrate(&views, &board, 0, 480, &opts).is_err());
}
