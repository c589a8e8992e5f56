//! `indoorloc demo` end to end at a toy size: it renders, trains, localizes the held-out walk
//! and writes the report; a second run reuses the frames and the finished checkpoint.

use crate::util::{TOY, TestResult, indoorloc, json_of};

#[test]
fn demo_runs_end_to_end_and_resumes() -> TestResult {
    let dir = tempfile::tempdir()?;
    let out = dir.path().join("demo");
    let out_s = out.to_str().ok_or("path")?;
    let run = || -> TestResult<serde_json::Value> {
        let mut args = vec!["demo", "--out", out_s];
        args.extend(TOY);
        args.extend([
            "--view",
            "gray,resize=40x30,norm=pm1",
            "--mc",
            "4",
            "--cut-segments",
            "2",
            "--map-frames",
            "60",
            "--json",
        ]);
        json_of(&indoorloc(&args)?)
    };
    let first = run()?;
    assert_eq!(first["frames"], serde_json::json!([48, 12, 24]));
    assert_eq!(first["reused_frames"], false);
    assert_eq!(first["epochs"][0], 1);
    let median = first["median_pos_m"].as_f64().ok_or("median_pos_m")?;
    assert!(median.is_finite() && median > 0.0, "median {median}");
    let r = first["uncertainty"]["pearson_r"]
        .as_f64()
        .ok_or("pearson_r")?;
    assert!((-1.0..=1.0).contains(&r), "R {r}");
    let html = std::fs::read_to_string(out.join("report").join("report.html"))?;
    let after_cut = first["cuts"]["median_pos_m_after_cut_gold"]
        .as_f64()
        .ok_or("cuts")?;
    assert!(after_cut.is_finite(), "{after_cut}");
    for needle in [
        "<svg",
        "data:image/png;base64",
        "median position error",
        "Scene cuts",
        "What the network looks at",
        "Refined against the keyframe map",
    ] {
        assert!(html.contains(needle), "report lacks {needle}");
    }
    // The map stage ran: a map of the survey, each test frame refined or kept.
    let refined = &first["refined"];
    assert!(
        refined["keyframes"].as_u64().ok_or("keyframes")? > 10,
        "{refined}"
    );
    let share = refined["refined"].as_f64().ok_or("refined")?;
    assert!((0.0..=1.0).contains(&share), "{refined}");
    assert!(out.join("zone.map").is_file());
    assert!(out.join("report").join("frames.png").is_file());
    assert!(out.join("report").join("saliency.png").is_file());

    let second = run()?;
    assert_eq!(second["reused_frames"], true);
    assert_eq!(second["epochs"][0], 1);
    assert_eq!(second["median_pos_m"], first["median_pos_m"]);
    Ok(())
}
