//! Real photos end to end, read where they lie: `train`, `localize` (network and retrieval) and
//! `eval` directly on the 7-Scenes redkitchen sequence (JPEG colour, space-separated poses, no
//! split files) with the block split of its README, and bad datasets refused.

use crate::util::{TestResult, indoorloc, json_of, shared_data};

/// `localize` into `out`, which must succeed; the lines' frame names.
fn localize(args: &[&str], out: &std::path::Path) -> TestResult<Vec<String>> {
    let out_s = out.to_str().ok_or("path")?;
    let mut all = vec!["localize"];
    all.extend_from_slice(args);
    all.extend(["--out", out_s]);
    let run = indoorloc(&all)?;
    assert!(
        run.status.success(),
        "{}",
        String::from_utf8_lossy(&run.stderr)
    );
    std::fs::read_to_string(out)?
        .lines()
        .map(|l| {
            let v: serde_json::Value = serde_json::from_str(l)?;
            Ok(v["frame"].as_str().ok_or("frame")?.to_string())
        })
        .collect()
}

#[test]
fn the_real_kitchen_trains_localizes_and_evaluates_in_place_with_blocks() -> TestResult {
    let kitchen = shared_data("7scenes_redkitchen_seq01");
    if !kitchen.is_dir() {
        eprintln!("skipped: {} is missing", kitchen.display());
        return Ok(());
    }
    let k = kitchen.to_str().ok_or("path")?;
    let dir = tempfile::tempdir()?;
    let model = dir.path().join("model");
    let model_s = model.to_str().ok_or("path")?;
    let t = json_of(&indoorloc(&[
        "train",
        "--data",
        k,
        "--blocks",
        "100:5",
        "--out",
        model_s,
        "--view",
        "resize=32x24,norm=pm1",
        "--epochs",
        "1",
        "--steps-per-epoch",
        "2",
        "--batch",
        "8",
        "--json",
    ])?)?;
    assert_eq!(t["epochs"], 1);

    // The network on the held-out blocks (frames 400-499 and 900-999), paired by `eval`.
    let est = dir.path().join("net.jsonl");
    let frames = localize(
        &[
            "--model", model_s, k, "--split", "test", "--blocks", "100:5", "--mc", "0", "--tta",
            "false",
        ],
        &est,
    )?;
    assert_eq!(frames.len(), 200);
    assert_eq!(frames[0], "frame-000400");
    assert_eq!(frames[100], "frame-000900");
    let est_s = est.to_str().ok_or("path")?;
    let e = json_of(&indoorloc(&["eval", "--gt", k, "--est", est_s, "--json"])?)?;
    assert_eq!(e["frames"].as_u64(), Some(200));

    // Retrieval maps the 800 frames outside the test blocks: 0.381 m / 14.5° measured, the
    // peer sift_pnp.py's thumbnail retrieval 0.385 m / 14.4° on the same split.
    let ret = dir.path().join("retrieval.jsonl");
    localize(
        &["--retrieve", k, k, "--split", "test", "--blocks", "100:5"],
        &ret,
    )?;
    let ret_s = ret.to_str().ok_or("path")?;
    let e = json_of(&indoorloc(&["eval", "--gt", k, "--est", ret_s, "--json"])?)?;
    let (m, r) = (
        e["median_pos_m"].as_f64().ok_or("median")?,
        e["median_rot_deg"].as_f64().ok_or("median")?,
    );
    assert!(m < 0.42 && r < 16.0, "retrieval {m:.3} m / {r:.1}°");
    Ok(())
}

#[test]
fn bad_posed_datasets_exit_2_naming_the_file() -> TestResult {
    let dir = tempfile::tempdir()?;
    let seq = dir.path().join("seq-01");
    std::fs::create_dir_all(&seq)?;
    std::fs::write(
        seq.join("frame-000000.pose.txt"),
        "1 0 0 0\n0 1 0 0\n0 0 1 0\n0 0 0 1\n",
    )?;
    let out = dir.path().join("o");
    let seq_s = seq.to_str().ok_or("path")?;
    let out_s = out.to_str().ok_or("path")?;
    // The colour image of a posed frame is missing.
    let run = indoorloc(&["train", "--data", seq_s, "--out", out_s])?;
    assert_eq!(run.status.code(), Some(2));
    let err = String::from_utf8_lossy(&run.stderr);
    assert!(
        err.contains("frame-000000.color.png") && err.lines().count() == 1,
        "{err}"
    );
    // A folder of nothing indoorloc knows.
    let empty = dir.path().join("empty");
    std::fs::create_dir_all(&empty)?;
    let empty_s = empty.to_str().ok_or("path")?;
    let run = indoorloc(&["localize", "--retrieve", empty_s, seq_s])?;
    assert_eq!(run.status.code(), Some(2));
    let err = String::from_utf8_lossy(&run.stderr);
    assert!(
        err.contains("empty") && err.contains("not a posed image dataset"),
        "{err}"
    );
    // A block split that cannot be.
    let run = indoorloc(&["localize", "--retrieve", seq_s, seq_s, "--blocks", "10:1"])?;
    assert_eq!(run.status.code(), Some(2));
    Ok(())
}
