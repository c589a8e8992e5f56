//! `indoorloc bench scenecut`: frames per second of scene-cut detection on a 320x240 video,
//! decoding included, beside PySceneDetect (`scenecut.py`, ContentDetector and
//! AdaptiveDetector) and beside decoding alone (`ffmpeg -threads 1 -i V -f null -`, the limit for
//! a detector that sees every frame); the detector alone on thumbnails already in memory, one
//! thread; and hard-cut precision / recall / F1 on every clip of `../shared/data/scenecut_*`
//! beside PySceneDetect's on the same clips, all in the same run.
//!
//! Two ratios, each labelled: indoorloc as it runs (decoders side by side on the cores, the
//! loop filter skipped) and indoorloc with the peers' resources (one decoding thread, every
//! filter on), so that neither a second core nor a cheaper decode is taken for a faster
//! detector.

use super::peer::{Peer, VsPeer};
use crate::{Context, Result, bail};
use scenecut::{Collect, Config, Decoding, Gold, score_hard};
use serde::Serialize;
use std::path::{Path, PathBuf};
use std::process::Command;
use std::time::Instant;

/// The clips with gold cuts, relative to the shared folder.
const CLIPS: &[(&str, &str)] = &[
    ("data/scenecut_real", "opencv_samples_cuts.mp4"),
    ("data/scenecut_real", "opencv_vtest_nocut.mp4"),
    ("data/scenecut_pyscenedetect", "testvideo.mp4"),
    ("data/scenecut_pyscenedetect", "goldeneye-vfr-drop3.mp4"),
    ("data/scenecut_pyscenedetect", "fades.mp4"),
];

/// Speed figures.
#[derive(Debug, Serialize)]
pub struct SpeedFigures {
    video: PathBuf,
    frames: u64,
    /// indoorloc end to end (open, decode, detect), frames/s, median of the repeats.
    fps: f64,
    /// indoorloc's milliseconds for the whole video (median), the figure the ratio compares.
    ms: f64,
    /// The detector alone on thumbnails in memory, one thread, frames/s.
    detector_fps: f64,
    /// indoorloc end to end with the peers' resources (one decoding thread, the loop filter
    /// on), frames/s and ms (median of the repeats).
    equal_resources_fps: f64,
    equal_resources_ms: f64,
    /// `peer_ms / equal_resources_ms`.
    equal_resources_ratio_vs_peer: Option<f64>,
    /// `ffmpeg -threads 1 -i V -f null -`, frames/s, when ffmpeg is installed.
    decode_only_fps: Option<f64>,
    /// `fps / decode_only_fps`.
    fraction_of_decode: Option<f64>,
    /// Why there is no decode-only figure, when there is none.
    #[serde(skip_serializing_if = "Option::is_none")]
    decode_only_note: Option<String>,
    /// PySceneDetect's frames/s per detector, when it ran.
    peer_fps: Vec<(String, f64)>,
    /// Beside the faster PySceneDetect detector.
    #[serde(flatten)]
    vs: VsPeer,
}

/// Accuracy on one clip.
#[derive(Debug, Serialize)]
pub struct AccuracyRow {
    video: String,
    gold: Vec<u64>,
    cuts: Vec<u64>,
    precision: f64,
    recall: f64,
    f1: f64,
    /// PySceneDetect's best hard-cut F1 on the clip (of its two detectors), when it ran.
    peer_f1: Option<f64>,
    peer_cuts: Option<Vec<u64>>,
}

/// All figures of the stage.
#[derive(Debug, Serialize)]
pub struct ScenecutFigures {
    speed: SpeedFigures,
    accuracy: Vec<AccuracyRow>,
}

/// Runs the benchmark on `video` (default: the shared 320x240 clip).
pub fn bench(video: Option<&Path>, repeat: usize, peer: Result<Peer>) -> Result<ScenecutFigures> {
    let shared = shared_dir();
    let video = match video {
        Some(v) => v.to_path_buf(),
        None => shared
            .as_ref()
            .map(|s| s.join(CLIPS[0].0).join(CLIPS[0].1))
            .filter(|p| p.is_file())
            .context("no video to time: pass --video FILE (the default is ../shared/data/scenecut_real/opencv_samples_cuts.mp4)")?,
    };
    let cfg = Config::default();
    let (frames, ms) = timed(&video, &cfg, Decoding::default(), repeat)?;
    let fps = frames as f64 / (ms / 1e3);
    let (_, equal_ms) = timed(&video, &cfg, Decoding::FULL_ONE_THREAD, repeat)?;
    let detector_fps = detector_only(&video, &cfg)?;
    let (decode_only_fps, decode_only_note) = match ffmpeg_decode_fps(&video, frames) {
        Ok(f) => (Some(f), None),
        Err(e) => (None, Some(format!("{e:#}"))),
    };
    let (peer_fps, peer_note) = match &peer {
        Ok(p) => match peer_runs(p, &video, repeat) {
            Ok(v) => (v, None),
            Err(e) => (Vec::new(), Some(format!("{e:#}"))),
        },
        Err(e) => (Vec::new(), Some(format!("{e:#}"))),
    };
    let best_peer = peer_fps.iter().map(|(_, f)| *f).reduce(f64::max);
    let peer_ms = best_peer.map(|f| frames as f64 / f * 1e3);
    let speed = SpeedFigures {
        video: video.clone(),
        frames,
        fps,
        ms,
        detector_fps,
        equal_resources_fps: frames as f64 / (equal_ms / 1e3),
        equal_resources_ms: equal_ms,
        equal_resources_ratio_vs_peer: peer_ms.map(|p| p / equal_ms),
        fraction_of_decode: decode_only_fps.map(|d| fps / d),
        decode_only_fps,
        decode_only_note,
        vs: VsPeer::new(
            "PySceneDetect (faster of content / adaptive)",
            ms,
            peer_ms,
            peer_note,
        ),
        peer_fps,
    };
    let accuracy = match &shared {
        Some(dir) => accuracy(dir, &cfg, peer.as_ref().ok())?,
        None => Vec::new(),
    };
    Ok(ScenecutFigures { speed, accuracy })
}

/// Frames of `video` and the median ms of `repeat` end-to-end detections decoded as `decoding`.
fn timed(video: &Path, cfg: &Config, decoding: Decoding, repeat: usize) -> Result<(u64, f64)> {
    let mut runs = Vec::with_capacity(repeat);
    let mut frames = 0;
    for _ in 0..repeat.max(1) {
        let det = scenecut::detect_input_decoded(
            video,
            cfg,
            decoding,
            Collect::default(),
            &mut |_, _| {},
        )?;
        frames = det.frames;
        runs.push(det.seconds * 1e3);
    }
    Ok((frames, crate::output::median(&runs)))
}

/// The shared folder (`$INDOORLOC_SHARED`, `../shared` or `shared`) if it has the clips.
fn shared_dir() -> Option<PathBuf> {
    [
        std::env::var_os("INDOORLOC_SHARED").map(PathBuf::from),
        Some(PathBuf::from("../shared")),
        Some(PathBuf::from("shared")),
    ]
    .into_iter()
    .flatten()
    .find(|d| d.join(CLIPS[0].0).join(CLIPS[0].1).is_file())
}

/// Frames/s of the detector alone: the video's thumbnails decoded into memory first, then the
/// detector run over them (repeated for at least half a second), one thread.
fn detector_only(video: &Path, cfg: &Config) -> Result<f64> {
    let mut source = data::frames::VideoFile::open_fast(video)?;
    let (w, h) = source.frame_size();
    let size = cfg.thumb_size(w, h);
    source.set_output_size(Some(size))?;
    let thumbs: Vec<(u64, Vec<u8>)> = source
        .filter_map(|f| f.ok())
        .map(|f| (f.index, f.image.into_raw()))
        .collect();
    if thumbs.is_empty() {
        bail!("{}: no frame decoded", video.display());
    }
    let start = Instant::now();
    let mut done = 0usize;
    while done == 0 || start.elapsed().as_secs_f64() < 0.5 {
        scenecut::detect_thumbnails(cfg, size, thumbs.iter().map(|(i, t)| (*i, t.as_slice())))?;
        done += thumbs.len();
    }
    Ok(done as f64 / start.elapsed().as_secs_f64())
}

/// `ffmpeg -threads 1 -benchmark -i V -f null -`: frames / its reported real time.
fn ffmpeg_decode_fps(video: &Path, frames: u64) -> Result<f64> {
    let mut best = f64::INFINITY;
    for _ in 0..3 {
        let out = Command::new("ffmpeg")
            .args([
                "-hide_banner",
                "-nostats",
                "-benchmark",
                "-threads",
                "1",
                "-i",
            ])
            .arg(video)
            .args(["-f", "null", "-"])
            .output()
            .context("running ffmpeg (install the ffmpeg package for the decode-only figure)")?;
        let text = String::from_utf8_lossy(&out.stderr);
        let rtime = text
            .split_whitespace()
            .find_map(|w| {
                w.strip_prefix("rtime=")?
                    .strip_suffix('s')?
                    .parse::<f64>()
                    .ok()
            })
            .context("ffmpeg printed no rtime")?;
        best = best.min(rtime);
    }
    Ok(frames as f64 / best)
}

/// PySceneDetect's frames/s per detector on `video`.
fn peer_runs(peer: &Peer, video: &Path, repeat: usize) -> Result<Vec<(String, f64)>> {
    ["content", "adaptive"]
        .iter()
        .map(|d| {
            let v = run_peer(peer, video, d, repeat)?;
            let fps = v["fps_processed"]
                .as_f64()
                .context("scenecut.py printed no fps")?;
            Ok((d.to_string(), fps))
        })
        .collect()
}

fn run_peer(peer: &Peer, video: &Path, detector: &str, repeat: usize) -> Result<serde_json::Value> {
    let out = Command::new(&peer.python)
        .arg(peer.dir.join("scenecut.py"))
        .arg(video)
        .args([
            "--detector",
            detector,
            "--repeat",
            &repeat.max(1).to_string(),
        ])
        .output()
        .context("running scenecut.py")?;
    if !out.status.success() {
        bail!(
            "scenecut.py failed: {}",
            String::from_utf8_lossy(&out.stderr).trim()
        );
    }
    serde_json::from_slice(&out.stdout).context("scenecut.py output")
}

/// Hard-cut scores on every shared clip, ours and PySceneDetect's.
fn accuracy(shared: &Path, cfg: &Config, peer: Option<&Peer>) -> Result<Vec<AccuracyRow>> {
    let mut rows = Vec::new();
    for (folder, file) in CLIPS {
        let video = shared.join(folder).join(file);
        if !video.is_file() {
            continue;
        }
        let gold = Gold::read(&shared.join(folder).join("gold.json"), &video)?;
        let det = scenecut::detect_input(&video, cfg, Collect::default(), &mut |_, _| {})?;
        let cuts = det.cut_frames();
        let s = score_hard(&cuts, &gold, 2);
        let mut peer_best: Option<(f64, Vec<u64>)> = None;
        if let Some(p) = peer {
            for d in ["content", "adaptive"] {
                let Ok(v) = run_peer(p, &video, d, 1) else {
                    continue;
                };
                let pc: Vec<u64> = v["cuts"]
                    .as_array()
                    .map(|a| a.iter().filter_map(|c| c.as_u64()).collect())
                    .unwrap_or_default();
                let f1 = score_hard(&pc, &gold, 2).f1;
                if peer_best.as_ref().is_none_or(|(b, _)| f1 > *b) {
                    peer_best = Some((f1, pc));
                }
            }
        }
        rows.push(AccuracyRow {
            video: file.to_string(),
            gold: gold.hard_cuts.clone(),
            cuts,
            precision: s.precision,
            recall: s.recall,
            f1: s.f1,
            peer_f1: peer_best.as_ref().map(|(f, _)| *f),
            peer_cuts: peer_best.map(|(_, c)| c),
        });
    }
    Ok(rows)
}

/// The figures as text.
pub fn table(f: &ScenecutFigures) -> String {
    let s = &f.speed;
    let opt = |v: Option<f64>, d: usize| v.map_or("-".into(), |v| format!("{v:.d$}"));
    let mut t = format!(
        "scenecut on {} ({} frames)\n  indoorloc end to end, as it runs (decoders on every core, loop filter skipped) {:.0} frames/s\n  \
         indoorloc end to end, the peers' resources (one decoding thread, every filter) {:.0} frames/s\n  \
         detector alone {:.0} frames/s (1 thread)\n  \
         ffmpeg decode only (-threads 1) {} frames/s → indoorloc (as it runs) at {} of it\n",
        s.video.display(),
        s.frames,
        s.fps,
        s.equal_resources_fps,
        s.detector_fps,
        opt(s.decode_only_fps, 0),
        s.fraction_of_decode
            .map_or("-".into(), |v| format!("{:.0} %", 100.0 * v)),
    );
    if let Some(n) = &s.decode_only_note {
        t.push_str(&format!("  decode only: {n}\n"));
    }
    for (d, fps) in &s.peer_fps {
        t.push_str(&format!("  PySceneDetect {d}: {fps:.0} frames/s\n"));
    }
    t.push_str(&format!(
        "  ratio vs PySceneDetect: {} as it runs, {} with the peers' resources\n",
        opt(s.vs.ratio_vs_peer, 2),
        opt(s.equal_resources_ratio_vs_peer, 2)
    ));
    if let Some(n) = &s.vs.peer_note {
        t.push_str(&format!("  peer: {n}\n"));
    }
    if !f.accuracy.is_empty() {
        t.push_str(&format!(
            "{:<26}{:>6}{:>6}{:>6}{:>10}  cuts\n",
            "hard cuts (±2)", "P", "R", "F1", "peer F1"
        ));
        for r in &f.accuracy {
            t.push_str(&format!(
                "{:<26}{:>6.2}{:>6.2}{:>6.2}{:>10}  {:?} (gold {:?}, peer {:?})\n",
                r.video,
                r.precision,
                r.recall,
                r.f1,
                opt(r.peer_f1, 2),
                r.cuts,
                r.gold,
                r.peer_cuts.as_deref().unwrap_or(&[])
            ));
        }
    }
    t
}
