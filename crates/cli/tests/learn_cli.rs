//! `indoorloc train` → `localize` → `eval` from the outside, on a tiny rendered dataset: the
//! checkpoint's stored validation error is what `localize` + `eval` measure again.

use crate::util::{TestResult, indoorloc, json_of, shared_data};

/// Renders a small native dataset of `frames` frames in `sequences` sequences into `out`.
fn synth_dataset(out: &str, frames: usize, sequences: usize) -> TestResult {
    let (frames, sequences) = (frames.to_string(), sequences.to_string());
    json_of(&indoorloc(&[
        "synth",
        "--out",
        out,
        "--frames",
        &frames,
        "--sequences",
        &sequences,
        "--size",
        "64x48",
        "--no-depth",
        "--no-planes",
        "--json",
    ])?)?;
    Ok(())
}

#[test]
fn train_localize_eval_agree_on_the_validation_error() -> TestResult {
    let dir = tempfile::tempdir()?;
    let (ds, model) = (dir.path().join("ds"), dir.path().join("model"));
    let (ds_s, model_s) = (ds.to_str().ok_or("path")?, model.to_str().ok_or("path")?);
    synth_dataset(ds_s, 48, 6)?;
    let train = |extra: &[&str]| -> TestResult<serde_json::Value> {
        let mut args = vec![
            "train",
            "--data",
            ds_s,
            "--out",
            model_s,
            "--batch",
            "8",
            "--view",
            "resize=64x48,norm=pm1",
            "--seed",
            "3",
            "--json",
        ];
        args.extend_from_slice(extra);
        json_of(&indoorloc(&args)?)
    };
    let t = train(&["--epochs", "1"])?;
    assert_eq!(t["epochs"], 1);
    // Resuming continues from the stored epoch.
    let t = train(&["--epochs", "2", "--resume"])?;
    assert_eq!(t["epochs"], 2);
    let val_median = t["val_median_pos_m"].as_f64().ok_or("val_median_pos_m")?;
    assert!(val_median.is_finite() && val_median > 0.0);

    // Deterministic poses of the validation frames, as JSON lines in a file.
    let est = dir.path().join("val.jsonl");
    let out = indoorloc(&[
        "localize",
        "--model",
        model_s,
        ds_s,
        "--split",
        "val",
        "--mc",
        "0",
        "--tta",
        "false",
        "--out",
        est.to_str().ok_or("path")?,
    ])?;
    assert!(
        out.status.success(),
        "{}",
        String::from_utf8_lossy(&out.stderr)
    );
    let lines = std::fs::read_to_string(&est)?;
    let first: serde_json::Value = serde_json::from_str(lines.lines().next().ok_or("no lines")?)?;
    for key in [
        "frame",
        "position",
        "quaternion",
        "sigma_pos_m",
        "latency_ms",
    ] {
        assert!(!first[key].is_null(), "{key} missing in {first}");
    }
    let e = json_of(&indoorloc(&[
        "eval",
        "--gt",
        ds_s,
        "--est",
        est.to_str().ok_or("path")?,
        "--json",
    ])?)?;
    assert_eq!(e["frames"].as_u64(), Some(lines.lines().count() as u64));
    let measured = e["median_pos_m"].as_f64().ok_or("median_pos_m")?;
    assert!(
        (measured - val_median).abs() < 1e-3,
        "eval {measured} vs checkpoint {val_median}"
    );

    // MC dropout gives an uncertainty, on stdout as JSON lines.
    let out = indoorloc(&[
        "localize", "--model", model_s, ds_s, "--split", "val", "--mc", "4",
    ])?;
    assert!(out.status.success());
    let line: serde_json::Value = serde_json::from_slice(
        out.stdout
            .split(|&b| b == b'\n')
            .next()
            .ok_or("no output")?,
    )?;
    assert!(line["sigma_pos_m"].as_f64().ok_or("sigma")? > 0.0);

    // Other tools' layouts: the 7-Scenes sample's test split (sequences 1 and 4, three frames
    // each) and a Cambridge list, both paired again by `eval`.
    let scene = shared_data("7scenes_stairs_sample/7scenes_layout");
    let scene_s = scene.to_str().ok_or("path")?;
    let seven = dir.path().join("7scenes.jsonl");
    let seven_s = seven.to_str().ok_or("path")?;
    let out = indoorloc(&[
        "localize", "--model", model_s, scene_s, "--split", "test", "--mc", "0", "--out", seven_s,
    ])?;
    assert!(
        out.status.success(),
        "{}",
        String::from_utf8_lossy(&out.stderr)
    );
    let seqs: Vec<String> = std::fs::read_to_string(&seven)?
        .lines()
        .map(|l| serde_json::from_str::<serde_json::Value>(l).map(|v| v["seq"].to_string()))
        .collect::<Result<_, _>>()?;
    assert_eq!(seqs.len(), 6);
    assert!(
        seqs.iter().all(|s| s == "\"seq-01\"" || s == "\"seq-04\""),
        "{seqs:?}"
    );
    let e = json_of(&indoorloc(&[
        "eval", "--gt", scene_s, "--est", seven_s, "--json",
    ])?)?;
    assert_eq!(e["frames"].as_u64(), Some(6));
    let list = ds.join("dataset_test.txt");
    std::fs::write(
        &list,
        "Visual Landmark Dataset V1\nImageFile, Camera Position [X Y Z W P Q R]\n\n\
         frames/000000.png 1 2 1.5 1 0 0 0\nframes/000001.png 1.5 2 1.5 1 0 0 0\n",
    )?;
    let list_s = list.to_str().ok_or("path")?;
    let cam = dir.path().join("cambridge.jsonl");
    let cam_s = cam.to_str().ok_or("path")?;
    let out = indoorloc(&[
        "localize", "--model", model_s, list_s, "--mc", "0", "--out", cam_s,
    ])?;
    assert!(
        out.status.success(),
        "{}",
        String::from_utf8_lossy(&out.stderr)
    );
    let e = json_of(&indoorloc(&[
        "eval", "--gt", list_s, "--est", cam_s, "--json",
    ])?)?;
    assert_eq!(e["frames"].as_u64(), Some(2));

    // A corrupt checkpoint is a one-line error naming the file, exit code 2.
    std::fs::write(model.join("model.toml"), "arch = 7\n")?;
    let out = indoorloc(&["localize", "--model", model_s, ds_s])?;
    assert_eq!(out.status.code(), Some(2));
    let stderr = String::from_utf8_lossy(&out.stderr);
    assert!(stderr.contains("model.toml"), "{stderr}");
    Ok(())
}

#[test]
fn bench_infer_reports_each_input_and_thread_count() -> TestResult {
    let out = std::process::Command::new(env!("CARGO_BIN_EXE_indoorloc"))
        .args(["bench", "infer", "--infer-runs", "1", "--json"])
        .env("PEERS_VENV", "/nonexistent-peers-venv")
        .output()?;
    let v = json_of(&out)?;
    let rows = v["learn"].as_array().ok_or("no learn rows")?;
    let of = |what: &str| {
        rows.iter()
            .filter(|r| r["what"] == what)
            .collect::<Vec<_>>()
    };
    let (infer, localize) = (of("infer"), of("localize"));
    assert!(infer.len() >= 2, "{rows:?}");
    // each input and thread count: a plain frame, then TTA + 16 MC passes as a multiple of it
    assert_eq!(localize.len(), 2 * infer.len(), "{rows:?}");
    assert_eq!(infer.len() + localize.len(), rows.len(), "{rows:?}");
    for r in rows {
        let ms = r["ms"].as_f64().ok_or("ms")?;
        assert!(ms.is_finite() && ms > 0.0, "{r}");
        // Without the peers' venv (or scripts) the ratio is absent and the note says why.
        assert!(r["ratio_vs_peer"].is_null());
        assert!(
            r["peer_note"].as_str().is_some_and(|n| !n.is_empty()),
            "{r}"
        );
    }
    for pair in localize.chunks(2) {
        let (plain, full) = (pair[0], pair[1]);
        assert_eq!(
            (plain["mc"].as_u64(), plain["tta"].as_bool()),
            (Some(0), Some(false))
        );
        assert_eq!(
            (full["mc"].as_u64(), full["tta"].as_bool()),
            (Some(16), Some(true))
        );
        assert_eq!(plain["x_plain"].as_f64(), Some(1.0), "{plain}");
        let x = full["x_plain"].as_f64().ok_or("x_plain")?;
        let ratio = full["ms"].as_f64().ok_or("ms")? / plain["ms"].as_f64().ok_or("ms")?;
        assert!((x - ratio).abs() < 1e-9, "{full}");
    }
    Ok(())
}

/// `train --window` adds a sequence model; `localize` then runs it over each recording (state
/// carried, started over per sequence) and `eval` measures the stored validation error again;
/// `--single` uses the single-frame network alone.
#[test]
fn a_sequence_model_localizes_recordings_as_it_was_validated() -> TestResult {
    let dir = tempfile::tempdir()?;
    let (ds, model) = (dir.path().join("ds"), dir.path().join("model"));
    let (ds_s, model_s) = (ds.to_str().ok_or("path")?, model.to_str().ok_or("path")?);
    synth_dataset(ds_s, 60, 5)?;
    let t = json_of(&indoorloc(&[
        "train",
        "--data",
        ds_s,
        "--out",
        model_s,
        "--batch",
        "8",
        "--view",
        "resize=32x24,norm=pm1",
        "--epochs",
        "1",
        "--window",
        "4",
        "--lstm-units",
        "16",
        "--seq-epochs",
        "2",
        "--json",
    ])?)?;
    assert_eq!(t["sequence"]["window"], 4);
    assert!(t["sequence"]["windows"].as_u64().ok_or("windows")? > 0);
    let median_of = |extra: &[&str]| -> TestResult<f64> {
        let est = dir.path().join("val.jsonl");
        let est_s = est.to_str().ok_or("path")?;
        let mut args = vec![
            "localize", "--model", model_s, ds_s, "--split", "val", "--mc", "0", "--out", est_s,
        ];
        args.extend_from_slice(extra);
        let out = indoorloc(&args)?;
        assert!(
            out.status.success(),
            "{}",
            String::from_utf8_lossy(&out.stderr)
        );
        let e = json_of(&indoorloc(&[
            "eval", "--gt", ds_s, "--est", est_s, "--json",
        ])?)?;
        Ok(e["median_pos_m"].as_f64().ok_or("median_pos_m")?)
    };
    let stored = |key: &str| t[key]["val_median_pos_m"].as_f64();
    let sequence = median_of(&[])?;
    let want = stored("sequence").ok_or("sequence median")?;
    assert!((sequence - want).abs() < 1e-3, "{sequence} vs {want}");
    let single = median_of(&["--single", "--tta", "false"])?;
    let want = t["val_median_pos_m"].as_f64().ok_or("median")?;
    assert!((single - want).abs() < 1e-3, "{single} vs {want}");
    Ok(())
}

/// `train --task place` learns the place labels of a rendered dataset; the JSON carries the
/// accuracy per level and the split; the model files are written.
#[test]
fn a_place_classifier_trains_from_the_command_line() -> TestResult {
    let dir = tempfile::tempdir()?;
    let (ds, model) = (dir.path().join("ds"), dir.path().join("model"));
    let (ds_s, model_s) = (ds.to_str().ok_or("path")?, model.to_str().ok_or("path")?);
    synth_dataset(ds_s, 60, 5)?;
    assert!(ds.join("labels.csv").is_file());
    for split in ["session", "random"] {
        let t = json_of(&indoorloc(&[
            "train",
            "--data",
            ds_s,
            "--out",
            model_s,
            "--task",
            "place",
            "--place-split",
            split,
            "--view",
            "resize=32x24,norm=pm1",
            "--batch",
            "8",
            "--epochs",
            "1",
            // the second split replaces the first's model
            "--force",
            "--json",
        ])?)?;
        assert_eq!(t["split"], split);
        for level in ["building", "floor", "corridor"] {
            let a = t["val_accuracy"][level].as_f64().ok_or("accuracy")?;
            assert!((0.0..=1.0).contains(&a), "{level} {a}");
        }
        assert!(model.join("place.toml").is_file() && model.join("place.bpk").is_file());
    }
    let bad = indoorloc(&[
        "train", "--data", ds_s, "--out", model_s, "--task", "place", "--window", "4",
    ])?;
    assert_eq!(bad.status.code(), Some(2));

    // localize: places alone from a place-only folder, then beside the pose once a pose model
    // shares the folder
    let lines = |extra: &[&str]| -> TestResult<Vec<serde_json::Value>> {
        let mut args = vec![
            "localize", "--model", model_s, ds_s, "--split", "val", "--mc", "0",
        ];
        args.extend_from_slice(extra);
        let out = indoorloc(&args)?;
        assert!(
            out.status.success(),
            "{}",
            String::from_utf8_lossy(&out.stderr)
        );
        out.stdout
            .split(|&b| b == b'\n')
            .filter(|l| !l.is_empty())
            .map(|l| Ok(serde_json::from_slice(l)?))
            .collect()
    };
    let first_line = |extra: &[&str]| -> TestResult<serde_json::Value> {
        lines(extra)?
            .into_iter()
            .next()
            .ok_or_else(|| "no output".into())
    };
    let smoothed = lines(&[])?;
    let line = &smoothed[0];
    assert!(line["position"].is_null(), "{line}");
    for key in ["building", "floor", "corridor", "direction", "p"] {
        assert!(!line["place"][key].is_null(), "{key} missing in {line}");
    }
    // Told late (the default lag) or at once, every frame comes out once and in order.
    let alone = lines(&["--single"])?;
    let frames = |ls: &[serde_json::Value]| -> Vec<String> {
        ls.iter().map(|l| l["frame"].to_string()).collect()
    };
    assert_eq!(frames(&smoothed), frames(&alone));
    assert_eq!(frames(&lines(&["--place-lag", "inf"])?), frames(&alone));
    // With no lag, the first frame of a walk has nothing around it: the filter and `--single`
    // agree.
    let live = first_line(&["--place-lag", "0"])?;
    for key in ["building", "floor", "corridor", "direction"] {
        assert_eq!(live["place"][key], alone[0]["place"][key], "{key}");
    }
    for lag in ["--place-lag=-1", "--place-lag=nan"] {
        let bad = indoorloc(&["localize", "--model", model_s, ds_s, lag])?;
        assert_eq!(bad.status.code(), Some(2));
        assert!(String::from_utf8_lossy(&bad.stderr).contains("must be 0 or more seconds"));
    }
    let tum = indoorloc(&["localize", "--model", model_s, ds_s, "--format", "tum"])?;
    assert_eq!(tum.status.code(), Some(2));
    json_of(&indoorloc(&[
        "train",
        "--data",
        ds_s,
        "--out",
        model_s,
        "--view",
        "resize=32x24,norm=pm1",
        "--batch",
        "8",
        "--epochs",
        "1",
        "--json",
    ])?)?;
    let line = first_line(&[])?;
    assert!(
        line["position"].is_array() && line["place"]["p"].is_number(),
        "{line}"
    );
    Ok(())
}

/// Exit code and stderr of a run that must fail with code 2 within 10 s.
fn refused(args: &[&str]) -> TestResult<String> {
    let t = std::time::Instant::now();
    let out = indoorloc(args)?;
    let err = String::from_utf8_lossy(&out.stderr).into_owned();
    assert_eq!(out.status.code(), Some(2), "{args:?}: {err}");
    assert_eq!(err.lines().count(), 1, "{args:?}: {err}");
    assert!(
        t.elapsed().as_secs() < 10,
        "{args:?} took {:?}",
        t.elapsed()
    );
    Ok(err)
}

/// A second `train` into a trained folder, a model file asking for gigabytes, a view past the
/// bound, and a ceiling camera's model on a forward camera's frames: each refused by name.
#[test]
fn models_are_not_overwritten_oversized_or_run_on_another_camera() -> TestResult {
    let dir = tempfile::tempdir()?;
    let (ds, model) = (dir.path().join("ds"), dir.path().join("model"));
    let (ds_s, model_s) = (ds.to_str().ok_or("path")?, model.to_str().ok_or("path")?);
    synth_dataset(ds_s, 24, 3)?;
    let train = [
        "train",
        "--data",
        ds_s,
        "--out",
        model_s,
        "--batch",
        "8",
        "--epochs",
        "1",
        "--view",
        "gray,resize=32x24,norm=pm1",
        "--json",
    ];
    json_of(&indoorloc(&train)?)?;
    let bpk = std::fs::read(model.join("model.bpk"))?;
    let err = refused(&train)?;
    assert!(err.contains("--resume") && err.contains("--force"), "{err}");
    assert_eq!(std::fs::read(model.join("model.bpk"))?, bpk);
    let mut forced = train.to_vec();
    forced.push("--force");
    json_of(&indoorloc(&forced)?)?;
    // a view past the bound, before any frame is read
    let mut huge = train.to_vec();
    huge[10] = "gray,resize=32768x32768";
    huge.push("--force");
    assert!(refused(&huge)?.contains("2048"));
    // hand-edited model files
    let toml = std::fs::read_to_string(model.join("model.toml"))?;
    for (from, to, bound) in [
        ("hidden = 1024", "hidden = 1000000000", "16384"),
        ("resize=32x24", "resize=32768x32768", "2048"),
    ] {
        assert!(toml.contains(from), "{from} not in model.toml");
        let edited = dir.path().join("edited");
        std::fs::create_dir_all(&edited)?;
        std::fs::copy(model.join("model.bpk"), edited.join("model.bpk"))?;
        std::fs::write(edited.join("model.toml"), toml.replace(from, to))?;
        let err = refused(&["localize", "--model", edited.to_str().ok_or("p")?, ds_s])?;
        assert!(err.contains("model.toml") && err.contains(bound), "{err}");
    }
    // the forward camera's model on a ceiling camera's frames
    let ceiling = dir.path().join("ceiling");
    json_of(&indoorloc(&[
        "synth",
        "--out",
        ceiling.to_str().ok_or("p")?,
        "--camera",
        "ceiling",
        "--frames",
        "4",
        "--sequences",
        "1",
        "--size",
        "32x24",
        "--json",
    ])?)?;
    let err = refused(&["localize", "--model", model_s, ceiling.to_str().ok_or("p")?])?;
    assert!(
        err.contains("dataset.toml") && err.contains("Ceiling"),
        "{err}"
    );
    Ok(())
}
