//! The studies that train models, end to end at a toy size: they run, print the rows their
//! issues name, and write their reports.

use crate::util::{TOY, TestResult, indoorloc, json_of};

#[test]
fn study_sequence_compares_single_frame_and_sequence_models() -> TestResult {
    let dir = tempfile::tempdir()?;
    let out = dir.path().join("seq");
    let mut args = vec!["study", "sequence", "--out", out.to_str().ok_or("path")?];
    args.extend(TOY);
    args.extend([
        "--window",
        "4",
        "--lstm-units",
        "16",
        "--seq-epochs",
        "1",
        "--mc",
        "2",
        "--latency-frames",
        "3",
        "--json",
    ]);
    let o = json_of(&indoorloc(&args)?)?;
    let rows = o["rows"].as_array().ok_or("rows")?;
    let models: Vec<&str> = rows.iter().filter_map(|r| r["model"].as_str()).collect();
    assert_eq!(models, ["single", "sequence"]);
    for r in rows {
        for key in ["median_pos_m", "median_rot_deg", "jitter_m", "latency_ms"] {
            let v = r[key].as_f64().ok_or(key)?;
            assert!(v.is_finite() && v >= 0.0, "{key} = {v}");
        }
    }
    assert_eq!(o["frames"], 24);
    assert!(out.join("model").join("seq.toml").is_file());
    let html = std::fs::read_to_string(out.join("report.html"))?;
    assert!(html.contains("<svg") && html.contains("jitter"));
    Ok(())
}

#[test]
fn study_render_types_trains_per_mode_and_tests_on_photo_like_frames() -> TestResult {
    let dir = tempfile::tempdir()?;
    let out = dir.path().join("rt");
    let mut args = vec![
        "study",
        "render-types",
        "--out",
        out.to_str().ok_or("path")?,
    ];
    args.extend(TOY);
    args.extend(["--modes", "edges,gradmag", "--mc", "0", "--json"]);
    let o = json_of(&indoorloc(&args)?)?;
    let rows = o["rows"].as_array().ok_or("rows")?;
    let modes: Vec<&str> = rows.iter().filter_map(|r| r["mode"].as_str()).collect();
    assert_eq!(modes, ["edges", "gradmag"]);
    for r in rows {
        let m = r["median_pos_m"].as_f64().ok_or("median_pos_m")?;
        assert!(m.is_finite() && m > 0.0, "{m}");
        assert_eq!(r["accuracy"].as_array().ok_or("accuracy")?.len(), 3);
    }
    assert_eq!(o["test_variant"], "texture-swap");
    // the training walks are rendered in the mode, the test walk photo-like
    let plan = std::fs::read_to_string(out.join("edges").join("data").join("demo-plan.toml"))?;
    assert!(plan.contains("train_mode = \"edges\"") && plan.contains("texture-swap"));
    assert!(std::fs::read_to_string(out.join("report.html"))?.contains("<svg"));
    // an unknown mode is refused before anything is rendered
    let bad = indoorloc(&["study", "render-types", "--modes", "sketch"])?;
    assert_eq!(bad.status.code(), Some(2));
    Ok(())
}

/// The guard of the shape-biased path: trained under normal conditions only, at a toy scale
/// (1000 frames, 3 epochs, seconds in a release build), the shape-biased model's error grows far
/// less than the baseline's in the disaster scene (most lights off, smoke, debris), and stays
/// lower there in metres. Deterministic (seeded rendering and training). Measured at this scale:
/// baseline 2.58 m normal, 7.86 m disaster (3.04x); shape 5.65 m, 2.84 m (0.50x). At the quick
/// scale the study gives 10.27x against 1.10x there.
#[test]
fn study_robustness_shape_bias_holds_up_in_the_disaster_scene() -> TestResult {
    let dir = tempfile::tempdir()?;
    let out = dir.path().join("rob");
    let o = json_of(&indoorloc(&[
        "study",
        "robustness",
        "--out",
        out.to_str().ok_or("path")?,
        "--quick",
        "--train-frames",
        "1000",
        "--test-frames",
        "100",
        "--epochs",
        "3",
        "--models",
        "baseline,shape",
        "--variants",
        "disaster",
        "--json",
    ])?)?;
    let models = o["models"].as_array().ok_or("models")?;
    let figure = |m: usize, key: &str| models[m][key].as_f64().ok_or("figure");
    assert_eq!(models[0]["model"], "baseline");
    assert_eq!(models[1]["model"], "shape");
    let (baseline, shape) = (figure(0, "worst_growth")?, figure(1, "worst_growth")?);
    assert!(
        shape < baseline && shape <= 1.5,
        "disaster growth: shape {shape:.2}x, baseline {baseline:.2}x"
    );
    let (baseline_m, shape_m) = (
        figure(0, "worst_median_pos_m")?,
        figure(1, "worst_median_pos_m")?,
    );
    assert!(
        shape_m < baseline_m,
        "disaster median: shape {shape_m:.2} m, baseline {baseline_m:.2} m"
    );
    Ok(())
}

#[test]
fn study_robustness_tests_three_models_under_every_variant_and_explain_draws_their_maps()
-> TestResult {
    let dir = tempfile::tempdir()?;
    let out = dir.path().join("rob");
    let mut args = vec!["study", "robustness", "--out", out.to_str().ok_or("path")?];
    args.extend(TOY);
    args.push("--json");
    let o = json_of(&indoorloc(&args)?)?;
    let rows = o["rows"].as_array().ok_or("rows")?;
    let variants = [
        "normal",
        "some-lights-off",
        "dim",
        "people",
        "furniture-moved",
        "posters-changed",
        "disaster",
        "texture-swap",
    ];
    assert_eq!(rows.len(), 3 * variants.len());
    for (i, r) in rows.iter().enumerate() {
        assert_eq!(
            r["model"],
            ["baseline", "shape", "shape+planes"][i / variants.len()]
        );
        assert_eq!(r["variant"], variants[i % variants.len()]);
        for key in ["median_pos_m", "median_rot_deg"] {
            let v = r[key].as_f64().ok_or(key)?;
            assert!(v.is_finite() && v >= 0.0, "{key} {v}");
        }
    }
    let models = o["models"].as_array().ok_or("models")?;
    assert!(models[2]["val_plane_accuracy"].as_f64().is_some());
    assert!(models[0].get("val_plane_accuracy").is_none());
    // Only the training walks of the shape-biased models are repainted; only the plane model's
    // dataset has depth and plane ids; every variant's walk has the same poses.
    let plan = |m: &str| std::fs::read_to_string(out.join(m).join("data").join("demo-plan.toml"));
    assert!(!plan("baseline")?.contains("random_materials"));
    assert!(plan("shape")?.contains("random_materials = true"));
    assert!(plan("shape-planes")?.contains("depth = true"));
    assert!(out.join("shape-planes/data/planes/000000.png").is_file());
    assert!(!out.join("shape/data/depth").exists());
    let walks = data::native::NativeDataset::open(&out.join("test-walks"))?;
    let poses = |seq: &str| -> Vec<[f64; 3]> {
        walks
            .trajectory
            .frames
            .iter()
            .filter(|f| f.seq == seq)
            .map(|f| f.pose.position())
            .collect()
    };
    assert_eq!(poses("test-normal").len(), 24);
    assert_eq!(poses("test-normal"), poses("test-disaster"));
    assert!(std::fs::read_to_string(out.join("report.html"))?.contains("Error CDF: people"));

    // Grad-CAM of a trained model over the test walk's frames.
    let pictures = dir.path().join("cam");
    let o = json_of(&indoorloc(&[
        "explain",
        "--model",
        out.join("shape-planes/model").to_str().ok_or("path")?,
        out.join("test-walks/frames").to_str().ok_or("path")?,
        "--out",
        pictures.to_str().ok_or("path")?,
        "--every",
        "10",
        "--max",
        "3",
        "--json",
    ])?)?;
    let rows = o.as_array().ok_or("explain rows")?;
    assert_eq!(rows.len(), 3);
    assert_eq!(rows[1]["frame"], "000010");
    for r in rows {
        let picture = std::path::PathBuf::from(r["picture"].as_str().ok_or("picture")?);
        let img = image::open(&picture)?;
        assert_eq!((img.width(), img.height()), (160, 120));
        let peak = r["peak"].as_array().ok_or("peak")?;
        assert!(
            peak.iter()
                .all(|p| p.as_f64().is_some_and(|v| (0.0..=1.0).contains(&v)))
        );
    }
    let bad = indoorloc(&["explain", "--model", "/nonexistent", "x.png"])?;
    assert_eq!(bad.status.code(), Some(2));
    Ok(())
}

#[test]
fn study_place_split_reports_both_splits_and_confusion_matrices() -> TestResult {
    let dir = tempfile::tempdir()?;
    let out = dir.path().join("places");
    let o = json_of(&indoorloc(&[
        "study",
        "place-split",
        "--quick",
        "--out",
        out.to_str().ok_or("path")?,
        "--frames",
        "240",
        "--heldout-frames",
        "80",
        "--view",
        "resize=32x32,norm=imagenet",
        "--epochs",
        "1",
        "--hierarchical",
        "--json",
    ])?)?;
    let modes: Vec<&str> = o["hierarchy"]
        .as_array()
        .ok_or("hierarchy")?
        .iter()
        .filter_map(|r| r["mode"].as_str())
        .collect();
    assert_eq!(modes, ["global", "routed", "oracle"]);
    assert!(out.join("data-B0").join("poses.csv").is_file());
    // training walks under four appearances, each walk its own session; none under the
    // held-out appearance
    let seqs = data::native::NativeDataset::open(&out.join("data"))?.sequences();
    for look in ["normal-", "dim-", "daylight-", "furniture-moved-"] {
        assert!(seqs.iter().any(|s| s.starts_with(look)), "{look}: {seqs:?}");
    }
    assert!(!seqs.iter().any(|s| s.starts_with("some-lights-off")));
    assert_eq!(seqs.len(), 24, "240 frames in walks of 10");
    let rows = o["rows"].as_array().ok_or("rows")?;
    let splits: Vec<&str> = rows.iter().filter_map(|r| r["split"].as_str()).collect();
    assert_eq!(splits, ["random", "session"]);
    for r in rows {
        for key in [
            "building_acc",
            "floor_acc",
            "corridor_acc",
            "heldout_corridor_acc",
            "heldout_walk_corridor_acc",
            "heldout_smooth_corridor_acc",
        ] {
            let a = r[key].as_f64().ok_or(key)?;
            assert!((0.0..=1.0).contains(&a), "{key} = {a}");
        }
        assert!(r["model_mb"].as_f64().ok_or("model_mb")? > 0.0);
    }
    for level in ["building", "floor", "corridor"] {
        assert!(out.join(format!("confusion-{level}.png")).is_file());
    }
    let html = std::fs::read_to_string(out.join("report.html"))?;
    assert!(html.contains("data:image/png;base64") && html.contains("precision"));
    Ok(())
}
