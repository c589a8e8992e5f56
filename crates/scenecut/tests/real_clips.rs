//! Hard cuts on real footage with known cut frames (`../shared/data/scenecut_real/` and
//! `../shared/data/scenecut_pyscenedetect/`), against PySceneDetect's best detector on the same
//! files (the reference figures stored beside the videos): F1 at least as high, and no hard cut
//! on the clips without one.

use scenecut::{Collect, Config, Detection, Gold, detect_input, score_hard};
use std::path::{Path, PathBuf};

type TestResult = Result<(), Box<dyn std::error::Error>>;

fn shared(rel: &str) -> PathBuf {
    Path::new(env!("CARGO_MANIFEST_DIR"))
        .join("../../../shared/data")
        .join(rel)
}

/// PySceneDetect's best hard-cut F1 on `video`, from `pyscenedetect_reference.json`.
fn reference_f1(folder: &Path, video: &str) -> Result<f64, Box<dyn std::error::Error>> {
    let text = std::fs::read_to_string(folder.join("pyscenedetect_reference.json"))?;
    let doc: serde_json::Value = serde_json::from_str(&text)?;
    let videos = doc["videos"].as_array().ok_or("no videos")?;
    let entry = videos
        .iter()
        .find(|v| v["file"] == video)
        .ok_or("video not in the reference")?;
    let detectors = entry["detectors"].as_object().ok_or("no detectors")?;
    detectors
        .values()
        .filter_map(|d| d["hard_cuts_only"]["f1"].as_f64())
        .reduce(f64::max)
        .ok_or_else(|| "no f1".into())
}

/// Detects, scores against the gold and PySceneDetect's best F1; returns what it found.
fn check(
    folder: &str,
    video: &str,
    expect_no_cut: bool,
) -> Result<(Detection, Gold), Box<dyn std::error::Error>> {
    let dir = shared(folder);
    let path = dir.join(video);
    let gold = Gold::read(&dir.join("gold.json"), &path)?;
    let det = detect_input(
        &path,
        &Config::default(),
        Collect::default(),
        &mut |_, _| {},
    )?;
    let cuts = det.cut_frames();
    let score = score_hard(&cuts, &gold, 2);
    let peer = reference_f1(&dir, video)?;
    println!(
        "{video}: cuts {cuts:?} gold {:?} P {:.3} R {:.3} F1 {:.3} (PySceneDetect best {peer:.3}); \
         gradual {:?}",
        gold.hard_cuts,
        score.precision,
        score.recall,
        score.f1,
        det.gradual
            .iter()
            .map(|g| (g.first, g.last))
            .collect::<Vec<_>>()
    );
    assert!(score.f1 >= peer - 1e-9, "{video}: F1 {} < {peer}", score.f1);
    if expect_no_cut {
        assert!(cuts.is_empty(), "{video}: false cuts {cuts:?}");
    }
    assert_eq!(det.skipped, 0);
    Ok((det, gold))
}

#[test]
fn opencv_samples_all_four_cuts_including_the_same_view_jump() -> TestResult {
    let (det, _) = check("scenecut_real", "opencv_samples_cuts.mp4", false)?;
    // beyond the peer: the jump within one static camera's view (frame 217) is found too
    assert_eq!(det.cut_frames(), vec![97, 217, 337, 405]);
    assert_eq!(det.frames, 475);
    Ok(())
}

#[test]
fn no_cut_in_the_unedited_surveillance_clip() -> TestResult {
    check("scenecut_real", "opencv_vtest_nocut.mp4", true).map(|_| ())
}

#[test]
fn pyscenedetect_test_video_hard_cuts_and_its_fades() -> TestResult {
    let (det, gold) = check("scenecut_pyscenedetect", "testvideo.mp4", false)?;
    // every gold fade / dissolve is flagged, within 2 frames at both ends, and nothing else
    assert_eq!(det.gradual.len(), gold.gradual.len(), "{:?}", det.gradual);
    for (found, [a, b]) in det.gradual.iter().zip(&gold.gradual) {
        assert!(found.first.abs_diff(*a) <= 2 && found.last.abs_diff(*b) <= 2);
    }
    Ok(())
}

#[test]
fn variable_frame_rate_movie_clip() -> TestResult {
    check("scenecut_pyscenedetect", "goldeneye-vfr-drop3.mp4", false).map(|_| ())
}

#[test]
fn brightness_ramps_are_not_hard_cuts() -> TestResult {
    check("scenecut_pyscenedetect", "fades.mp4", true).map(|_| ())
}
