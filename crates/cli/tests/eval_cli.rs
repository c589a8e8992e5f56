//! `indoorloc eval` from the outside: formats, real data, reports, and bad input.

use crate::util::{TestResult, indoorloc, json_of, shared_data, test_data};
use std::path::Path;

fn s(p: &Path) -> &str {
    p.to_str().unwrap_or_default()
}

#[test]
fn help_and_version() -> TestResult {
    let out = indoorloc(&["--version"])?;
    assert!(out.status.success());
    assert!(String::from_utf8(out.stdout)?.starts_with("indoorloc "));
    for sub in [&["eval", "--help"][..], &["help", "eval"]] {
        let out = indoorloc(sub)?;
        assert!(out.status.success(), "{sub:?}");
        assert!(String::from_utf8(out.stdout)?.contains("--gt"));
    }
    Ok(())
}

#[test]
fn real_7scenes_against_itself_is_exact() -> TestResult {
    let scene = shared_data("7scenes_stairs_sample/7scenes_layout");
    let out = indoorloc(&["eval", "--gt", s(&scene), "--est", s(&scene), "--json"])?;
    let v = json_of(&out)?;
    assert_eq!(v["frames"], 12);
    assert!(v["max_pos_m"].as_f64().ok_or("max")? < 1e-12);
    assert!(v["max_rot_deg"].as_f64().ok_or("max")? < 1e-9);
    assert_eq!(v["acc_25cm_2deg"], 1.0);
    Ok(())
}

#[test]
fn formats_cross_check_on_shared_trajectory() -> TestResult {
    // The peers' test trajectory in TUM and in Cambridge layout: both must give the same figures.
    let traj =
        Path::new(env!("CARGO_MANIFEST_DIR")).join("../../../shared/tools/peers/testdata/traj");
    let tum = json_of(&indoorloc(&[
        "eval",
        "--gt",
        s(&traj.join("gt.tum")),
        "--est",
        s(&traj.join("est.tum")),
        "--json",
    ])?)?;
    let cam = json_of(&indoorloc(&[
        "eval",
        "--gt",
        s(&traj.join("gt_posenet.txt")),
        "--est",
        s(&traj.join("est_posenet.txt")),
        "--json",
    ])?)?;
    assert_eq!(cam["matched_by"], "name");
    assert_eq!(tum["matched_by"], "time");
    let a = tum["median_pos_m"].as_f64().ok_or("m")?;
    let b = cam["median_pos_m"].as_f64().ok_or("m")?;
    assert!(
        tum["frames"].as_u64().ok_or("f")? > 0 && (a - b).abs() < 1e-6,
        "{a} {b}"
    );
    Ok(())
}

#[test]
fn report_and_cuts() -> TestResult {
    let dir = tempfile::tempdir()?;
    let cuts = dir.path().join("cuts.csv");
    std::fs::write(&cuts, "frame\n100\n500\n")?;
    let report = dir.path().join("report");
    let out = indoorloc(&[
        "eval",
        "--gt",
        s(&test_data("metrics_ref/gt.tum")),
        "--est",
        s(&test_data("metrics_ref/est.tum")),
        "--cuts",
        s(&cuts),
        "--report",
        s(&report),
        "--json",
    ])?;
    let v = json_of(&out)?;
    // frames 100..=110 and 500..=510 are within 10 frames after a cut
    assert_eq!(v["near_cuts"]["frames"], 22);
    assert_eq!(v["away_from_cuts"]["frames"], 978);
    let html = std::fs::read_to_string(report.join("report.html"))?;
    assert!(html.contains("<svg") || html.contains("data:image/png;base64"));
    for png in ["cdf.png", "errors_over_time.png", "trajectory.png"] {
        let img = image::open(report.join(png))?;
        assert!(img.width() > 300, "{png}");
    }
    Ok(())
}

/// Each malformed input exits with code 2 and one line naming the file (and line).
#[test]
fn malformed_inputs_exit_2_with_one_line() -> TestResult {
    let dir = tempfile::tempdir()?;
    let gt = test_data("metrics_ref/gt.tum");
    let cases: &[(&str, &[u8], &str)] = &[
        (
            "missing_col.tum",
            b"# t\n1.0 0 0 0 0 0 1\n",
            "missing_col.tum:2",
        ),
        ("nan.tum", b"1.0 0 0 NaN 0 0 0 1\n", "nan.tum:1"),
        ("nonunit.tum", b"1.0 0 0 0 0 0 0 2\n", "nonunit.tum:1"),
        ("empty.tum", b"", "empty.tum"),
        (
            "garbage.bin",
            &[0xde, 0xad, 0xbe, 0xef, 0x00, 0xff, 0x10],
            "garbage.bin",
        ),
        (
            "bad.jsonl",
            b"{\"frame\":1,\"position\":[0,0,0],\"quaternion\":[1,0,0,0]}\n{\"frame\":2}\n",
            "bad.jsonl:2",
        ),
    ];
    for (name, content, needle) in cases {
        let p = dir.path().join(name);
        std::fs::write(&p, content)?;
        let out = indoorloc(&["eval", "--gt", s(&gt), "--est", s(&p)])?;
        let err = String::from_utf8(out.stderr)?;
        assert_eq!(out.status.code(), Some(2), "{name}: {err}");
        assert_eq!(err.trim_end().lines().count(), 1, "{name}: {err}");
        assert!(err.contains(name) && err.contains(needle), "{name}: {err}");
        assert!(!err.contains("panicked"), "{name}: {err}");
    }
    // a frame name the ground truth does not have
    let scene = shared_data("7scenes_stairs_sample/7scenes_layout");
    let p = dir.path().join("unknown.jsonl");
    std::fs::write(
        &p,
        "{\"frame\":\"frame-000001\",\"seq\":\"seq-01\",\"position\":[0,0,0],\"quaternion\":[1,0,0,0]}\n\
         {\"frame\":\"nope\",\"position\":[0,0,0],\"quaternion\":[1,0,0,0]}\n",
    )?;
    let out = indoorloc(&["eval", "--gt", s(&scene), "--est", s(&p)])?;
    let err = String::from_utf8(out.stderr)?;
    assert_eq!(out.status.code(), Some(2), "{err}");
    assert!(
        err.contains("unknown.jsonl") && err.contains("unknown frame 'nope'"),
        "{err}"
    );
    // a wrong-size 7-Scenes matrix
    let seq = dir.path().join("scene/seq-01");
    std::fs::create_dir_all(&seq)?;
    std::fs::write(
        seq.join("frame-000000.pose.txt"),
        "1 0 0 0\n0 1 0 0\n0 0 1 0\n",
    )?;
    let out = indoorloc(&[
        "eval",
        "--gt",
        s(&dir.path().join("scene")),
        "--est",
        s(&gt),
    ])?;
    let err = String::from_utf8(out.stderr)?;
    assert_eq!(out.status.code(), Some(2), "{err}");
    assert!(err.contains("frame-000000.pose.txt"), "{err}");
    // a missing file
    let out = indoorloc(&["eval", "--gt", "/nonexistent/gt.tum", "--est", s(&gt)])?;
    assert_eq!(out.status.code(), Some(2));
    assert!(String::from_utf8(out.stderr)?.contains("/nonexistent/gt.tum"));
    Ok(())
}
