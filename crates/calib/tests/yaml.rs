//! OpenCV YAML: the shared sample files, and a write/read round trip.

use calib::{CalibError, read_camera_yaml, write_opencv_yaml};
use geom::{Camera, Distortion};

const DATA: &str = concat!(env!("CARGO_MANIFEST_DIR"), "/../../../shared/data");

#[test]
fn reads_opencv_samples() {
    let c = read_camera_yaml(format!("{DATA}/aruco_real/tutorial_camera_charuco.yml")).unwrap();
    assert_eq!((c.width, c.height), (640, 480));
    assert!((c.fx - 452.510_722_196_376_7).abs() < 1e-9);
    assert!((c.cy - 277.751_559_191_359_95).abs() < 1e-9);
    assert!((c.dist.k3 - 2.954_258_940_681_008).abs() < 1e-12);

    let c = read_camera_yaml(format!("{DATA}/aruco_real/tutorial_camera_params.yml")).unwrap();
    // no size in the file: twice the principal point
    assert_eq!((c.width, c.height), (648, 522));
    assert_eq!(
        (c.fx, c.fy, c.cx, c.cy),
        (628.158, 628.156, 324.099, 260.908)
    );
    assert_eq!(
        c.dist.to_array(),
        [0.0995485, -0.206384, 0.00754589, 0.00336531, 0.0]
    );

    let c = read_camera_yaml(format!(
        "{DATA}/chessboard_9x6_left/upstream_left_intrinsics.yml"
    ))
    .unwrap();
    assert_eq!((c.width, c.height), (640, 480));
    assert_eq!(c.fx, c.fy);
    assert!((c.fx - 535.915_733_961_632).abs() < 1e-9);
    assert!((c.dist.k1 + 0.266_372_609_096_606_8).abs() < 1e-12);
}

#[test]
fn round_trip_and_errors() {
    let dir = tempfile::tempdir().unwrap();
    let cam = Camera::new(
        640,
        480,
        536.073_453_135_881_7,
        536.016_362_741_665_5,
        342.370_468_272_453_7,
        235.536_870_640_643_3,
        Distortion::from_array([-0.265, -0.0467, 0.001833, -0.000315, 0.2523]),
    )
    .unwrap();
    let path = dir.path().join("cam.yml");
    write_opencv_yaml(&path, &cam, Some(0.4087)).unwrap();
    let text = std::fs::read_to_string(&path).unwrap();
    println!("{text}");
    assert!(text.starts_with("%YAML:1.0\n"));
    assert!(text.contains("camera_matrix: !!opencv-matrix"));
    assert!(text.contains("avg_reprojection_error: 4.08"));
    assert_eq!(read_camera_yaml(&path).unwrap(), cam);
    // only the file itself in the folder (no temporary left behind)
    assert_eq!(std::fs::read_dir(dir.path()).unwrap().count(), 1);

    let bad = dir.path().join("bad.yml");
    std::fs::write(&bad, "%YAML:1.0\nimage_width: 640\n").unwrap();
    let e = read_camera_yaml(&bad).unwrap_err();
    assert!(matches!(&e, CalibError::MissingKey { key, .. } if key == "camera_matrix"));
    assert!(e.to_string().contains("bad.yml") && e.to_string().contains("camera_matrix"));
    let missing = read_camera_yaml(dir.path().join("nope.yml")).unwrap_err();
    assert!(missing.to_string().contains("nope.yml"));
    std::fs::write(
        &bad,
        "%YAML:1.0\ncamera_matrix: !!opencv-matrix\n   rows: 3\n   cols: 3\n   dt: d\n   data: [ 1, 0 ]\n",
    )
    .unwrap();
    println!("{}", read_camera_yaml(&bad).unwrap_err());
    assert!(write_opencv_yaml(dir.path().join("no/such/dir/cam.yml"), &cam, None).is_err());
}
