//! `indoorloc synth` from the outside: a small dataset is written, readable, and reproducible.

use crate::util::{TestResult, indoorloc, json_of};
use std::path::Path;

fn synth(out: &Path, extra: &[&str]) -> TestResult<serde_json::Value> {
    let mut args = vec![
        "synth",
        "--out",
        out.to_str().ok_or("path")?,
        "--frames",
        "12",
        "--sequences",
        "3",
        "--size",
        "64x48",
        "--json",
    ];
    args.extend_from_slice(extra);
    json_of(&indoorloc(&args)?)
}

#[test]
fn writes_a_native_dataset_that_reads_back() -> TestResult {
    let dir = tempfile::tempdir()?;
    let out = dir.path().join("ds");
    let v = synth(&out, &[])?;
    assert_eq!(v["frames"], 12);
    assert!(v["fps"].as_f64().ok_or("fps")? > 0.0);
    let ds = data::native::NativeDataset::open(&out)?;
    assert_eq!(ds.trajectory.len(), 12);
    assert_eq!(ds.sequences().len(), 3);
    assert!(ds.labels.as_ref().is_some_and(|l| !l.is_empty()));
    for frame in 0..12u64 {
        let img = image::open(ds.frame_path(frame))?;
        assert_eq!((img.width(), img.height()), (64, 48));
        assert!(ds.depth_path(frame).is_file() && ds.plane_path(frame).is_file());
    }
    // the dataset is ground truth `eval` understands
    let e = json_of(&indoorloc(&[
        "eval",
        "--gt",
        out.to_str().ok_or("p")?,
        "--est",
        out.to_str().ok_or("p")?,
        "--json",
    ])?)?;
    assert_eq!(e["frames"], 12);
    Ok(())
}

#[test]
fn same_seed_gives_byte_identical_files() -> TestResult {
    let dir = tempfile::tempdir()?;
    let (a, b) = (dir.path().join("a"), dir.path().join("b"));
    synth(&a, &["--seed", "5", "--threads", "1"])?;
    synth(&b, &["--seed", "5"])?;
    for rel in [
        "poses.csv",
        "labels.csv",
        "frames/000007.png",
        "depth/000007.png",
        "planes/000007.png",
    ] {
        assert_eq!(
            std::fs::read(a.join(rel))?,
            std::fs::read(b.join(rel))?,
            "{rel}"
        );
    }
    Ok(())
}

#[test]
fn fps_spaces_the_frames_and_world_seed_keeps_the_building() -> TestResult {
    let dir = tempfile::tempdir()?;
    let (slow, other) = (dir.path().join("slow"), dir.path().join("other"));
    synth(&slow, &["--fps", "2.5", "--seed", "3", "--world-seed", "1"])?;
    let ds = data::native::NativeDataset::open(&slow)?;
    assert_eq!(ds.info.frame_rate, 2.5);
    let t: Vec<f64> = ds.trajectory.frames[..2]
        .iter()
        .map(|f| f.t.unwrap_or(f64::NAN))
        .collect();
    assert!((t[1] - t[0] - 0.4).abs() < 1e-9, "{t:?}");
    // other walks through the same building: seed 1's layout, seed 3's walks
    synth(&other, &["--seed", "1"])?;
    let names = |root: &Path| -> TestResult<String> {
        Ok(data::native::NativeDataset::open(root)?.info.name)
    };
    assert_eq!(names(&slow)?, names(&other)?);
    assert!(names(&slow)?.contains("seed 1"), "{}", names(&slow)?);
    let poses = |root: &Path| std::fs::read(root.join("poses.csv"));
    assert_ne!(poses(&slow)?, poses(&other)?);
    let bad = indoorloc(&[
        "synth",
        "--out",
        dir.path().join("bad").to_str().ok_or("path")?,
        "--fps",
        "0",
    ])?;
    let err = String::from_utf8_lossy(&bad.stderr);
    assert_eq!(bad.status.code(), Some(2), "{err}");
    assert!(err.contains("fps"), "{err}");
    Ok(())
}

#[test]
fn bad_model_file_exits_2_naming_it() -> TestResult {
    let dir = tempfile::tempdir()?;
    let model = dir.path().join("broken.obj");
    std::fs::write(&model, "v 0 0 0\nv 1 0 0\nf 1 2 9\n")?;
    let out = indoorloc(&[
        "synth",
        "--world",
        model.to_str().ok_or("path")?,
        "--out",
        dir.path().join("ds").to_str().ok_or("path")?,
    ])?;
    let err = String::from_utf8(out.stderr)?;
    assert_eq!(out.status.code(), Some(2), "{err}");
    assert!(
        err.contains("broken.obj") && !err.contains("panicked"),
        "{err}"
    );
    assert_eq!(err.trim_end().lines().count(), 1, "{err}");
    Ok(())
}
