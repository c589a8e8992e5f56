//! `indoorloc bench markers`: ArUco detection milliseconds per image on the real photos of
//! `../shared/data/aruco_real` (DICT_6X6_250), one thread and all threads, beside OpenCV's
//! `ArucoDetector` with default parameters (`aruco.py`, one thread) in the same run; with the
//! markers found by each against the gold where there is gold.

use super::peer::{Peer, VsPeer};
use crate::{Context, Result, bail};
use markers::{DetectParams, Dictionary};
use serde::Serialize;
use std::path::{Path, PathBuf};
use std::process::Command;
use std::time::Instant;

/// The photos timed: OpenCV's tutorial images of DICT_6X6_250 markers and ChArUco boards.
const IMAGES: &[&str] = &[
    "singlemarkersoriginal.jpg",
    "choriginal.jpg",
    "chocclusion_original.jpg",
    "img_00.jpg",
    "img_02.jpg",
    "img_03.jpg",
];

/// Timed runs per image (median reported), after one untimed run.
const RUNS: usize = 30;

/// Figures for one photo.
#[derive(Debug, Serialize)]
pub struct MarkerFigures {
    image: PathBuf,
    /// Markers indoorloc finds.
    markers: usize,
    /// Markers OpenCV finds, when it ran.
    peer_markers: Option<usize>,
    /// indoorloc on one thread, ms (median of the runs): the figure the ratio compares.
    ms: f64,
    /// indoorloc on all of rayon's threads, ms.
    ms_all_threads: f64,
    /// OpenCV on one thread beside ours.
    #[serde(flatten)]
    vs: VsPeer,
}

/// Runs the benchmark where the shared photos are.
pub fn bench(peer: Result<Peer>) -> Result<Vec<MarkerFigures>> {
    let dir = super::peer::shared_data("data/aruco_real", "gold.json", Path::is_file)
        .context("../shared/data/aruco_real not found beside the checkout")?;
    let dict = Dictionary::predefined("6x6_250")?;
    let params = DetectParams::default();
    let one = rayon::ThreadPoolBuilder::new().num_threads(1).build()?;
    let mut rows = Vec::new();
    for name in IMAGES {
        let path = dir.join(name);
        let gray = markers::load_gray(&path)?;
        let found = markers::detect(&gray, &dict, &params).len();
        let ms = one.install(|| time_median(|| markers::detect(&gray, &dict, &params).len()));
        let ms_all = time_median(|| markers::detect(&gray, &dict, &params).len());
        let (peer_ms, peer_markers, note) = match &peer {
            Ok(p) => match opencv(p, &path) {
                Ok((ms, n)) => (Some(ms), Some(n), None),
                Err(e) => (None, None, Some(format!("{e:#}"))),
            },
            Err(e) => (None, None, Some(format!("{e:#}"))),
        };
        rows.push(MarkerFigures {
            image: path,
            markers: found,
            peer_markers,
            ms,
            ms_all_threads: ms_all,
            vs: VsPeer::new("OpenCV ArucoDetector (aruco.py)", ms, peer_ms, note),
        });
    }
    Ok(rows)
}

/// The table printed without `--json`.
pub fn table(rows: &[MarkerFigures]) -> String {
    if rows.is_empty() {
        return String::new();
    }
    let mut t = format!(
        "markers: DICT_6X6_250, median of {RUNS} runs\n{:<28}{:>8}{:>8}{:>10}{:>10}{:>10}{:>8}\n",
        "image", "found", "opencv", "ms 1thr", "ms all", "opencv ms", "ratio"
    );
    for r in rows {
        let opt = |v: Option<f64>, d: usize| v.map_or("-".into(), |v| format!("{v:.d$}"));
        let name = r
            .image
            .file_name()
            .map_or_else(String::new, |n| n.to_string_lossy().into_owned());
        t.push_str(&format!(
            "{:<28}{:>8}{:>8}{:>10.2}{:>10.2}{:>10}{:>8}\n",
            name,
            r.markers,
            r.peer_markers.map_or("-".into(), |n| n.to_string()),
            r.ms,
            r.ms_all_threads,
            opt(r.vs.peer_ms, 2),
            opt(r.vs.ratio_vs_peer, 2)
        ));
    }
    if let Some(note) = rows.iter().find_map(|r| r.vs.peer_note.as_ref()) {
        t.push_str(&format!("  {}: {note}\n", rows[0].vs.peer));
    }
    t
}

/// Median milliseconds of `f` over [`RUNS`] runs after one untimed run.
fn time_median(mut f: impl FnMut() -> usize) -> f64 {
    std::hint::black_box(f());
    let mut ms: Vec<f64> = (0..RUNS)
        .map(|_| {
            let t = Instant::now();
            std::hint::black_box(f());
            t.elapsed().as_secs_f64() * 1e3
        })
        .collect();
    ms.sort_by(f64::total_cmp);
    ms[ms.len() / 2]
}

/// `aruco.py IMAGE --dict DICT_6X6_250 --repeat RUNS --threads 1`: its median ms and markers.
fn opencv(peer: &Peer, image: &Path) -> Result<(f64, usize)> {
    let out = Command::new(&peer.python)
        .arg(peer.dir.join("aruco.py"))
        .arg(image)
        .args([
            "--dict",
            "DICT_6X6_250",
            "--repeat",
            &RUNS.to_string(),
            "--threads",
            "1",
        ])
        .output()
        .context("running aruco.py")?;
    if !out.status.success() {
        bail!(
            "aruco.py failed: {}",
            String::from_utf8_lossy(&out.stderr).trim()
        );
    }
    let v: serde_json::Value = serde_json::from_slice(&out.stdout).context("aruco.py output")?;
    let ms = v["median_ms_per_image"]
        .as_f64()
        .context("aruco.py printed no median_ms_per_image")?;
    let n = v["n_markers"]
        .as_u64()
        .context("aruco.py printed no n_markers")? as usize;
    Ok((ms, n))
}
