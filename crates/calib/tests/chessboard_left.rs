//! OpenCV's `left01..left14` chessboard sample against OpenCV's own corners and calibration
//! (`../shared/data/chessboard_9x6_left/reference.json`).

use calib::{Board, CalibOptions, calibrate, find_chessboard};
use nalgebra::Point2;
use std::time::Instant;

const DIR: &str = concat!(
    env!("CARGO_MANIFEST_DIR"),
    "/../../../shared/data/chessboard_9x6_left"
);

struct RefImage {
    name: String,
    corners: Vec<Point2<f64>>,
}

fn reference() -> (serde_json::Value, Vec<RefImage>) {
    let text = std::fs::read_to_string(format!("{DIR}/reference.json")).expect("reference.json");
    let json: serde_json::Value = serde_json::from_str(&text).expect("json");
    let images = json["images"]
        .as_array()
        .expect("images")
        .iter()
        .map(|im| RefImage {
            name: im["image"].as_str().expect("name").to_string(),
            corners: im["corners_subpix"]
                .as_array()
                .expect("corners")
                .iter()
                .map(|c| Point2::new(c[0].as_f64().unwrap(), c[1].as_f64().unwrap()))
                .collect(),
        })
        .collect();
    (json, images)
}

/// Largest distance to OpenCV's corners, in the same order or reversed (the same board
/// turned by 180°).
fn max_error(ours: &[Point2<f64>], theirs: &[Point2<f64>]) -> f64 {
    let same = ours
        .iter()
        .zip(theirs)
        .map(|(a, b)| (a - b).norm())
        .fold(0.0, f64::max);
    let reversed = ours
        .iter()
        .rev()
        .zip(theirs)
        .map(|(a, b)| (a - b).norm())
        .fold(0.0, f64::max);
    same.min(reversed)
}

#[test]
fn corners_and_calibration_match_opencv() {
    let (json, refs) = reference();
    let mut views = Vec::new();
    let mut times = Vec::new();
    let mut worst: f64 = 0.0;
    let mut sum_err = 0.0;
    let mut count = 0.0;
    for r in &refs {
        let img = image::open(format!("{DIR}/{}", r.name))
            .expect("image")
            .to_luma8();
        let t = Instant::now();
        let corners = find_chessboard(&img, 9, 6);
        times.push(t.elapsed().as_secs_f64() * 1e3);
        let corners = corners.unwrap_or_else(|| panic!("{}: board not found", r.name));
        assert_eq!(corners.len(), 54);
        let err = max_error(&corners, &r.corners);
        let mean = {
            let a: f64 = corners
                .iter()
                .zip(&r.corners)
                .map(|(a, b)| (a - b).norm())
                .sum();
            let b: f64 = corners
                .iter()
                .rev()
                .zip(&r.corners)
                .map(|(a, b)| (a - b).norm())
                .sum();
            a.min(b) / 54.0
        };
        println!(
            "{}: max corner error {err:.3} px, mean {mean:.3} px",
            r.name
        );
        worst = worst.max(err);
        sum_err += mean;
        count += 1.0;
        views.push(corners);
    }
    times.sort_by(f64::total_cmp);
    println!(
        "find_chessboard: median {:.2} ms, max {:.2} ms per image",
        times[times.len() / 2],
        times[times.len() - 1]
    );
    println!(
        "corners vs OpenCV: worst {worst:.3} px, mean {:.3} px",
        sum_err / count
    );
    assert!(worst < 0.5, "corner error {worst} px");

    let board = Board::new(9, 6, 1.0);
    let t = Instant::now();
    let cal = calibrate(&views, &board, 640, 480, &CalibOptions::default()).expect("calibration");
    let c = cal.camera;
    println!(
        "calibrate: {:.1} ms; rms {:.4} (OpenCV 0.4087); fx {:.3} fy {:.3} cx {:.3} cy {:.3}",
        t.elapsed().as_secs_f64() * 1e3,
        cal.rms,
        c.fx,
        c.fy,
        c.cx,
        c.cy
    );
    println!(
        "k1 {:.5} k2 {:.5} p1 {:.6} p2 {:.6} k3 {:.5}; used {:?}",
        c.dist.k1, c.dist.k2, c.dist.p1, c.dist.p2, c.dist.k3, cal.used
    );
    println!("per-view rms {:?}", cal.per_view_rms);
    let k = &json["K"];
    let rel =
        |ours: f64, key: &str| (ours - k[key].as_f64().unwrap()).abs() / k[key].as_f64().unwrap();
    let rms_ref = json["rms_reprojection_error_px"].as_f64().unwrap();
    assert!((cal.rms - rms_ref).abs() < 0.1 * rms_ref, "rms {}", cal.rms);
    for (v, key) in [(c.fx, "fx"), (c.fy, "fy"), (c.cx, "cx"), (c.cy, "cy")] {
        assert!(rel(v, key) < 0.01, "{key} {v}");
    }
    assert!(cal.used.iter().all(|&u| u));
}
