//! `indoorloc preprocess` from the outside: OpenCV's pixels on real photos, bad images listed
//! while the rest is written.

use crate::util::{TestResult, indoorloc, json_of, shared_data};
use std::path::{Path, PathBuf};

/// `crates/imgproc/tests/data/clahe/<name>`: OpenCV-made references.
fn clahe_fixture(name: &str) -> PathBuf {
    Path::new(env!("CARGO_MANIFEST_DIR"))
        .join("../imgproc/tests/data/clahe")
        .join(name)
}

fn gray(path: &Path) -> TestResult<image::GrayImage> {
    Ok(image::open(path)?.to_luma8())
}

/// From the pixels OpenCV decoded, the written view is OpenCV's gray → INTER_AREA → CLAHE, bit
/// for bit.
#[test]
fn ceiling_view_equals_opencv_bit_for_bit() -> TestResult {
    let dir = tempfile::tempdir()?;
    let input = clahe_fixture("img_00.rgb.png");
    let out = dir.path().join("views");
    let v = json_of(&indoorloc(&[
        "preprocess",
        input.to_str().ok_or("path")?,
        "--out",
        out.to_str().ok_or("path")?,
        "--size",
        "160x120",
        "--gray",
        "--clahe",
        "2.0,8",
        "--json",
    ])?)?;
    assert_eq!(v["view"], "gray,resize=160x120,clahe=2.0/8");
    assert_eq!(v["images"].as_array().ok_or("images")?.len(), 1);
    assert!(v["ms_per_image"].as_f64().ok_or("ms_per_image")? > 0.0);
    let ours = gray(&out.join("img_00.rgb.png"))?;
    let opencv = gray(&clahe_fixture("img_00.clahe.png"))?;
    assert_eq!(ours, opencv);
    Ok(())
}

/// A folder of real photos with a truncated JPEG and a text file named like an image: the good
/// ones are written (and agree with OpenCV), the bad ones are listed, the exit code is 2.
#[test]
fn bad_images_are_listed_and_the_rest_written() -> TestResult {
    let photos = shared_data("aruco_real");
    assert!(photos.is_dir(), "{} not present", photos.display());
    let dir = tempfile::tempdir()?;
    let input = dir.path().join("in");
    std::fs::create_dir(&input)?;
    let good = ["img_00.jpg", "singlemarkersoriginal.jpg", "gboriginal.png"];
    for name in good {
        // Symbolic links: real data stays in ../shared and is never copied.
        std::os::unix::fs::symlink(photos.join(name), input.join(name))?;
    }
    let jpeg = std::fs::read(photos.join("img_02.jpg"))?;
    std::fs::write(input.join("truncated.jpg"), &jpeg[..jpeg.len() / 3])?;
    std::fs::write(input.join("notes.png"), b"not an image")?;
    let out = dir.path().join("out");
    let run = indoorloc(&[
        "preprocess",
        input.to_str().ok_or("path")?,
        "--out",
        out.to_str().ok_or("path")?,
        "--json",
    ])?;
    assert_eq!(run.status.code(), Some(2));
    let stderr = String::from_utf8_lossy(&run.stderr);
    assert_eq!(stderr.trim().lines().count(), 1, "{stderr}");
    assert!(stderr.contains("2 of 5 images"), "{stderr}");
    let v: serde_json::Value = serde_json::from_slice(&run.stdout)?;
    let mut bad: Vec<String> = v["bad"]
        .as_array()
        .ok_or("bad")?
        .iter()
        .filter_map(|b| b["image"].as_str())
        .map(|p| {
            Path::new(p)
                .file_name()
                .unwrap_or_default()
                .to_string_lossy()
                .into_owned()
        })
        .collect();
    bad.sort();
    assert_eq!(bad, ["notes.png", "truncated.jpg"]);
    assert_eq!(v["images"].as_array().ok_or("images")?.len(), 3);
    // The default view is gray160; JPEG decoders differ by a level here and there (the `image`
    // crate against libjpeg-turbo), which CLAHE amplifies on a few pixels only.
    for name in good {
        let stem = Path::new(name).file_stem().ok_or("stem")?.to_string_lossy();
        let ours = gray(&out.join(format!("{stem}.png")))?;
        let opencv = gray(&clahe_fixture(&format!("{stem}.clahe.png")))?;
        let close = ours
            .as_raw()
            .iter()
            .zip(opencv.as_raw())
            .filter(|(a, b)| a.abs_diff(**b) <= 1)
            .count() as f64
            / ours.as_raw().len() as f64;
        assert!(close >= 0.97, "{name}: {close}");
    }
    // Nothing half-written is left behind.
    let mut names: Vec<String> = std::fs::read_dir(&out)?
        .map(|e| e.map(|e| e.file_name().to_string_lossy().into_owned()))
        .collect::<Result<_, _>>()?;
    names.sort();
    assert_eq!(
        names,
        ["gboriginal.png", "img_00.png", "singlemarkersoriginal.png"]
    );
    Ok(())
}

/// A missing input is a one-line error naming it, exit code 2, before anything is written.
#[test]
fn missing_input_is_a_clear_error() -> TestResult {
    let dir = tempfile::tempdir()?;
    let out = dir.path().join("out");
    let run = indoorloc(&[
        "preprocess",
        "/no/such/image.png",
        "--out",
        out.to_str().ok_or("path")?,
    ])?;
    assert_eq!(run.status.code(), Some(2));
    let stderr = String::from_utf8_lossy(&run.stderr);
    assert!(stderr.contains("/no/such/image.png"), "{stderr}");
    assert!(!out.exists());
    Ok(())
}
