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

/// Stderr and exit code of a run that must fail.
fn failure(args: &[&str]) -> TestResult<(i32, String)> {
    let o = indoorloc(args)?;
    Ok((
        o.status.code().ok_or("killed")?,
        String::from_utf8_lossy(&o.stderr).into_owned(),
    ))
}

#[test]
fn counts_and_rates_past_their_bounds_exit_2_naming_the_bound() -> TestResult {
    let dir = tempfile::tempdir()?;
    let out = dir.path().join("x");
    let out = out.to_str().ok_or("path")?;
    let base = ["synth", "--out", out, "--sequences", "1", "--size", "32x24"];
    for (extra, bound) in [
        (&["--frames", "18446744073709551615"][..], "2000000"),
        (&["--frames", "6", "--fps", "1e-6"][..], "[0.1, 1000]"),
        (&["--frames", "6", "--fps", "1e-300"][..], "[0.1, 1000]"),
    ] {
        let mut args = base.to_vec();
        args.extend_from_slice(extra);
        let t = std::time::Instant::now();
        let (code, err) = failure(&args)?;
        assert_eq!(code, 2, "{extra:?}: {err}");
        assert!(
            err.contains(bound) && err.lines().count() == 1,
            "{extra:?}: {err}"
        );
        assert!(t.elapsed().as_secs() < 10, "{extra:?}");
    }
    Ok(())
}

#[test]
fn a_used_folder_is_kept_unless_resumed_with_its_settings_or_forced() -> TestResult {
    let dir = tempfile::tempdir()?;
    let out = dir.path().join("ds");
    let o = out.to_str().ok_or("path")?;
    synth(&out, &[])?;
    // another run into it: refused, nothing touched
    let before = std::fs::read(out.join("poses.csv"))?;
    let (code, err) = failure(&[
        "synth",
        "--out",
        o,
        "--frames",
        "6",
        "--sequences",
        "2",
        "--size",
        "32x24",
    ])?;
    assert!(code == 2 && err.contains("--force"), "{err}");
    // a resume with another size: refused (it would mix image sizes)
    let (code, err) = failure(&[
        "synth",
        "--out",
        o,
        "--frames",
        "12",
        "--sequences",
        "3",
        "--size",
        "32x24",
        "--resume",
    ])?;
    assert!(code == 2 && err.contains("other settings"), "{err}");
    assert_eq!(std::fs::read(out.join("poses.csv"))?, before);
    // an interrupted run: a plane image lost, a temporary file left; resume completes it
    std::fs::remove_file(out.join("planes").join("000007.png"))?;
    std::fs::write(out.join("frames").join(".000008.png.1-0.tmp"), b"half")?;
    let v = synth(&out, &["--resume"])?;
    assert_eq!(v["rendered"], 1);
    assert!(out.join("planes").join("000007.png").is_file());
    let tmp = std::fs::read_dir(out.join("frames"))?
        .filter_map(|e| e.ok())
        .filter(|e| e.file_name().to_string_lossy().ends_with(".tmp"))
        .count();
    assert_eq!(tmp, 0);
    // --force replaces it: no frame of the old dataset is left
    let v = json_of(&indoorloc(&[
        "synth",
        "--out",
        o,
        "--frames",
        "4",
        "--sequences",
        "1",
        "--size",
        "32x24",
        "--force",
        "--json",
    ])?)?;
    assert_eq!(v["frames"], 4);
    assert_eq!(std::fs::read_dir(out.join("frames"))?.count(), 4);
    Ok(())
}
