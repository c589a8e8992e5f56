//! `indoorloc scenecut`: the contract's JSON keys on real footage, the gold score, the cut list
//! and the plot it writes, and exit code 2 with the file named for bad inputs.

use crate::util::{TestResult, indoorloc, json_of, shared_data};

fn s(p: &std::path::Path) -> &str {
    p.to_str().unwrap_or_default()
}

#[test]
fn cuts_score_list_and_plot_of_a_real_clip() -> TestResult {
    let dir = tempfile::tempdir()?;
    let video = shared_data("scenecut_real/opencv_samples_cuts.mp4");
    let gold = shared_data("scenecut_real/gold.json");
    let (csv, png) = (dir.path().join("cuts.csv"), dir.path().join("rhythm.png"));
    let out = indoorloc(&[
        "scenecut",
        s(&video),
        "--gold",
        s(&gold),
        "--out",
        s(&csv),
        "--plot",
        s(&png),
        "--json",
    ])?;
    let v = json_of(&out)?;
    assert_eq!(v["cuts"], serde_json::json!([97, 217, 337, 405]));
    assert_eq!(v["frames"], 475);
    assert!(v["fps"].as_f64().ok_or("fps")? > 0.0);
    assert_eq!(v["gold"]["f1"], 1.0);
    assert_eq!(std::fs::read_to_string(&csv)?, "frame\n97\n217\n337\n405\n");
    let img = image::open(&png)?;
    assert!(img.width() >= 1000 && img.height() >= 400);
    // the cut list feeds eval --cuts and scenecut --gold alike
    let again = json_of(&indoorloc(&[
        "scenecut",
        s(&video),
        "--gold",
        s(&csv),
        "--json",
    ])?)?;
    assert_eq!(again["gold"]["f1"], 1.0);
    Ok(())
}

#[test]
fn fades_are_listed_apart_from_cuts() -> TestResult {
    let v = json_of(&indoorloc(&[
        "scenecut",
        s(&shared_data("scenecut_pyscenedetect/testvideo.mp4")),
        "--json",
    ])?)?;
    assert_eq!(v["cuts"], serde_json::json!([30, 180]));
    let kinds: Vec<&str> = v["gradual"]
        .as_array()
        .ok_or("gradual")?
        .iter()
        .filter_map(|g| g["kind"].as_str())
        .collect();
    assert_eq!(
        kinds,
        ["fade_in", "fade_out", "fade_in", "dissolve", "fade_out"]
    );
    // hard cuts only on request
    let hard = json_of(&indoorloc(&[
        "scenecut",
        s(&shared_data("scenecut_pyscenedetect/testvideo.mp4")),
        "--no-gradual",
        "--json",
    ])?)?;
    assert_eq!(hard["gradual"], serde_json::json!([]));
    Ok(())
}

#[test]
fn bad_inputs_exit_2_naming_the_file() -> TestResult {
    let dir = tempfile::tempdir()?;
    let junk = dir.path().join("junk.mp4");
    std::fs::write(&junk, b"this is not a video")?;
    let empty = dir.path().join("empty");
    std::fs::create_dir(&empty)?;
    let missing = dir.path().join("missing.mp4");
    for path in [&junk, &empty, &missing] {
        let out = indoorloc(&["scenecut", s(path)])?;
        assert_eq!(out.status.code(), Some(2), "{}", path.display());
        let err = String::from_utf8_lossy(&out.stderr);
        let name = path.file_name().and_then(|n| n.to_str()).unwrap_or("?");
        assert!(err.contains(name) && err.lines().count() == 1, "{err}");
    }
    let out = indoorloc(&["scenecut", s(&junk), "--path", "spiral"])?;
    assert_eq!(out.status.code(), Some(2));
    Ok(())
}
