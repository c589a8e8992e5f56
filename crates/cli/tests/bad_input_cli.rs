//! The promise every command keeps on bad input, held over a small corpus: exit code 2, one
//! line naming the problem, no panic, within 10 s.

use crate::util::{TestResult, indoorloc};
use std::path::Path;

/// Files no command can use, each named for what is wrong with it.
fn corpus(dir: &Path) -> TestResult<Vec<String>> {
    let mut png = Vec::new();
    image::RgbImage::from_pixel(64, 48, image::Rgb([90, 120, 200]))
        .write_to(&mut std::io::Cursor::new(&mut png), image::ImageFormat::Png)?;
    let mut jpeg = Vec::new();
    image::RgbImage::from_fn(64, 48, |x, y| {
        image::Rgb([(x * 4) as u8, (y * 5) as u8, 77])
    })
    .write_to(
        &mut std::io::Cursor::new(&mut jpeg),
        image::ImageFormat::Jpeg,
    )?;
    let files: [(&str, Vec<u8>); 6] = [
        ("empty.png", Vec::new()),
        ("garbage.jpg", b"\x00\x01not an image at all\xff".to_vec()),
        ("truncated.png", png[..png.len() / 2].to_vec()),
        ("truncated.jpg", jpeg[..jpeg.len() / 2].to_vec()),
        ("binary.txt", vec![0xff, 0xfe, 0x00, 0x80, 0x81]),
        (
            "poses.csv",
            b"frame,seq,t,x,y,z,qw,qx,qy,qz\n0,a,0,1e999,0,0,1,0,0,0\n".to_vec(),
        ),
    ];
    let mut paths = Vec::new();
    for (name, bytes) in files {
        let path = dir.join(name);
        std::fs::write(&path, bytes)?;
        paths.push(path.to_string_lossy().into_owned());
    }
    paths.push(dir.join("missing.png").to_string_lossy().into_owned());
    Ok(paths)
}

#[test]
fn every_command_refuses_every_bad_input_with_exit_2_and_one_line() -> TestResult {
    let dir = tempfile::tempdir()?;
    let out = dir.path().join("out");
    let out = out.to_str().ok_or("path")?;
    let yml = dir.path().join("cam.yml");
    let yml = yml.to_str().ok_or("path")?;
    let inputs = corpus(dir.path())?;
    // `{}` is the bad input
    let commands: [&[&str]; 11] = [
        &["eval", "--gt", "{}", "--est", "{}"],
        &["preprocess", "{}", "--out", out],
        &["scenecut", "{}"],
        &["markers", "detect", "{}"],
        &[
            "calibrate",
            "{}",
            "--board",
            "9x6",
            "--square",
            "1",
            "--out",
            yml,
        ],
        &["localize", "--model", "{}", "{}"],
        &["explain", "--model", "{}", "{}", "--out", out],
        &["train", "--data", "{}", "--out", out],
        &[
            "synth",
            "--world",
            "{}",
            "--out",
            out,
            "--frames",
            "2",
            "--sequences",
            "1",
        ],
        &["markers", "locate", "{}", "--map", "{}", "--camera", "{}"],
        &[
            "serve", "--model", "{}", "--source", "{}", "--port", "0", "--jsonl",
        ],
    ];
    for command in commands {
        for input in &inputs {
            let args: Vec<&str> = command
                .iter()
                .map(|a| if *a == "{}" { input.as_str() } else { a })
                .collect();
            let t = std::time::Instant::now();
            let o = indoorloc(&args)?;
            let err = String::from_utf8_lossy(&o.stderr);
            assert_eq!(o.status.code(), Some(2), "{args:?}: {err}");
            assert!(!err.contains("panicked"), "{args:?}: {err}");
            assert_eq!(err.trim_end().lines().count(), 1, "{args:?}: {err}");
            assert!(t.elapsed().as_secs() < 10, "{args:?}: {:?}", t.elapsed());
        }
    }
    Ok(())
}

/// `--device` names what is missing: a GPU in a build without the feature (this one, as CI
/// builds it), a device indoorloc has no backend for, or no device at all.
#[cfg(not(feature = "wgpu"))]
#[test]
fn a_device_this_build_lacks_is_refused_with_exit_2_and_the_reason() -> TestResult {
    let dir = tempfile::tempdir()?;
    let model = dir.path().join("model");
    let model = model.to_str().ok_or("path")?;
    for (args, reason) in [
        (
            vec!["--device", "wgpu", "bench", "infer"],
            "--features wgpu",
        ),
        (
            vec!["localize", "--device", "wgpu:1", "--model", model, model],
            "--features wgpu",
        ),
        (vec!["train", "--device", "cuda", "--data", model], "Vulkan"),
        (
            vec!["bench", "train", "--device", "tpu"],
            "cpu, wgpu or wgpu:N",
        ),
    ] {
        let o = indoorloc(&args)?;
        let err = String::from_utf8_lossy(&o.stderr);
        assert_eq!(o.status.code(), Some(2), "{args:?}: {err}");
        assert!(err.contains(reason), "{args:?}: {err}");
        assert!(!err.contains("panicked"), "{args:?}: {err}");
    }
    Ok(())
}
