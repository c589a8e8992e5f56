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
    assert!(kitchen.is_dir(), "{} is missing", kitchen.display());
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
        "--arch",
        "small",
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

/// A 7-Scenes sequence of the kitchen's first `frames` frames, linked (not copied) from
/// `../shared/data` into `dir`.
fn kitchen_excerpt(
    kitchen: &std::path::Path,
    dir: &std::path::Path,
    frames: usize,
) -> TestResult<std::path::PathBuf> {
    let seq = dir.join("kitchen").join("seq-01");
    std::fs::create_dir_all(&seq)?;
    for i in 0..frames {
        for part in ["color.jpg", "depth.png", "pose.txt"] {
            let name = format!("frame-{i:06}.{part}");
            std::os::unix::fs::symlink(kitchen.join("seq-01").join(&name), seq.join(&name))?;
        }
    }
    Ok(dir.join("kitchen"))
}

/// `study real` runs end to end on real frames (a smoke-scale excerpt: 60 frames, blocks of 10,
/// a few epochs) and reports every row with finite errors, and its report. The figures of the
/// full study are in ARCHITECTURE.md ("Real data").
#[test]
fn study_real_reports_every_row_on_kitchen_frames() -> TestResult {
    let kitchen = shared_data("7scenes_redkitchen_seq01");
    let dir = tempfile::tempdir()?;
    let data = kitchen_excerpt(&kitchen, dir.path(), 60)?;
    let out = dir.path().join("study");
    let run = indoorloc(&[
        "study",
        "real",
        "--data",
        data.to_str().ok_or("path")?,
        "--blocks",
        "10:3",
        "--quick",
        "--epochs",
        "2",
        "--window",
        "4",
        "--mc",
        "2",
        "--out",
        out.to_str().ok_or("path")?,
        "--json",
    ])?;
    let v = json_of(&run)?;
    let methods: Vec<&str> = v["rows"]
        .as_array()
        .ok_or("rows")?
        .iter()
        .map(|r| r["method"].as_str().unwrap_or(""))
        .collect();
    let weights = learn::pretrained::locate(&learn::pretrained::MOBILENET_V2).is_ok();
    let mut expected = vec![
        "mean-pose",
        "retrieval",
        "network",
        "network+sequence",
        "map",
        "network+map",
    ];
    if weights {
        expected.insert(2, "retrieval-features");
    }
    assert_eq!(methods, expected);
    for r in v["rows"].as_array().ok_or("rows")? {
        for key in ["median_pos_m", "median_rot_deg"] {
            let x = r[key].as_f64().ok_or(key)?;
            assert!(x.is_finite() && x >= 0.0, "{r}");
        }
    }
    // The real-photo recipe: the pretrained backbone where its weights are (CI fetches them).
    let network = v["network"].as_str().ok_or("network")?;
    assert_eq!(network.starts_with("mobilenetv2"), weights, "{network}");
    // 60 frames in blocks of 10, every third held out: frames 20-29 and 50-59.
    assert_eq!(v["test_frames"], 20);
    assert!(out.join("report.html").is_file());
    Ok(())
}

/// `map build` then `localize --map` (no network: the map's own retrieval starts each frame) on
/// held-out kitchen frames between mapped ones: every frame refined, centimetres by `eval`, with
/// pooled and with grouped candidates (`--map-groups`); a damaged map exits 2 naming the file.
#[test]
fn map_build_and_localize_with_the_map_refine_held_out_kitchen_frames() -> TestResult {
    let kitchen = shared_data("7scenes_redkitchen_seq01");
    let dir = tempfile::tempdir()?;
    let data = kitchen_excerpt(&kitchen, dir.path(), 100)?;
    let d = data.to_str().ok_or("path")?;
    let map = dir.path().join("kitchen.map");
    let m = map.to_str().ok_or("path")?;
    // Blocks of 20, the second of every four held out: frames 20-39.
    let built = json_of(&indoorloc(&[
        "map", "build", "--data", d, "--blocks", "20:4:1", "--out", m, "--json",
    ])?)?;
    assert!(
        built["keyframes"].as_u64().ok_or("keyframes")? >= 10,
        "{built}"
    );
    assert!(built["points"].as_u64().ok_or("points")? > 5000, "{built}");
    // Pooled candidates, then retrieved keyframes solved as groups of their own: every frame
    // refined to the same centimetres.
    for (name, groups) in [("pooled", None), ("grouped", Some("5"))] {
        let est = dir.path().join(format!("{name}.jsonl"));
        let mut args = vec!["--map", m, d, "--split", "test", "--blocks", "20:4:1"];
        if let Some(k) = groups {
            args.extend(["--map-groups", k]);
        }
        let frames = localize(&args, &est)?;
        assert_eq!(frames.len(), 20, "{name}");
        for line in std::fs::read_to_string(&est)?.lines() {
            let v: serde_json::Value = serde_json::from_str(line)?;
            assert_eq!(v["refined"], true, "{name}: {v}");
            assert_eq!(v["cov_pos_m2"].as_array().ok_or("cov")?.len(), 9);
        }
        let est_s = est.to_str().ok_or("path")?;
        let e = json_of(&indoorloc(&["eval", "--gt", d, "--est", est_s, "--json"])?)?;
        let (p, r) = (
            e["median_pos_m"].as_f64().ok_or("median")?,
            e["median_rot_deg"].as_f64().ok_or("median")?,
        );
        assert!(p < 0.03 && r < 1.5, "{name}: refined {p:.3} m / {r:.2}°");
    }

    // A photo of another camera's shape: refused, naming the map.
    let other = dir.path().join("other");
    std::fs::create_dir_all(&other)?;
    image::RgbImage::new(640, 360).save(other.join("wide.png"))?;
    let run = indoorloc(&["localize", "--map", m, other.to_str().ok_or("path")?])?;
    assert_eq!(run.status.code(), Some(2));
    let err = String::from_utf8_lossy(&run.stderr);
    assert!(
        err.contains("kitchen.map") && err.contains("640x360"),
        "{err}"
    );

    let bytes = std::fs::read(&map)?;
    std::fs::write(&map, &bytes[..bytes.len() - 10])?;
    let run = indoorloc(&[
        "localize", "--map", m, d, "--split", "test", "--blocks", "20:4:1",
    ])?;
    assert_eq!(run.status.code(), Some(2));
    let err = String::from_utf8_lossy(&run.stderr);
    assert!(
        err.contains("kitchen.map") && err.lines().count() == 1,
        "{err}"
    );
    Ok(())
}
