//! `indoorloc bench refine`: centimetre refinement on real photos (`map` + `features`), beside
//! OpenCV's SIFT + PnP (`sift_pnp.py`) on the same split in the same run: the map built from the
//! mapped (training and validation) blocks, each held-out frame refined from retrieval alone on
//! one thread; accuracy, ms per query and the map's build time and size. A second map of the
//! same frames with the depth images ignored (features triangulated between keyframes) shows
//! what photos alone give.

use super::peer::{Peer, VsPeer};
use crate::{Context, Result, bail};
use data::blocks::BlockSplit;
use data::native::SplitName;
use data::posed::{self, SplitPlan};
use geom::metrics::{Stats, position_error, rotation_error_deg};
use map::{BuildConfig, RefineConfig};
use rayon::prelude::*;
use serde::Serialize;
use std::path::Path;
use std::process::Command;
use std::time::Instant;

/// The splits measured when none is given: the kitchen README's and its shorter blocks.
pub const DEFAULT_SPLITS: [&str; 2] = ["100:5", "40:4"];

/// Figures of one split.
#[derive(Debug, Serialize)]
pub struct RefineFigures {
    dataset: String,
    split: String,
    /// Frames the map was built from, keyframes kept, 3-D points.
    mapped_frames: usize,
    keyframes: usize,
    points: usize,
    /// Map build time on all threads, seconds; its size on disk, bytes.
    map_build_s: f64,
    map_bytes: u64,
    frames: usize,
    median_pos_m: f64,
    median_rot_deg: f64,
    /// Share within (5 cm, 5°).
    acc_5cm_5deg: f64,
    /// Share refined (the rest kept retrieval's pose).
    refined: f64,
    /// ms per query on one thread (median): grey, retrieval, features, matching, PnP.
    ms: f64,
    ms_features: f64,
    ms_matching: f64,
    ms_pnp: f64,
    /// The same queries against a map of the same frames with their depth ignored
    /// (triangulated features): median errors, share within (5 cm, 5°), points.
    triangulated_median_pos_m: f64,
    triangulated_median_rot_deg: f64,
    triangulated_acc_5cm_5deg: f64,
    triangulated_points: usize,
    peer_median_pos_m: Option<f64>,
    peer_median_rot_deg: Option<f64>,
    peer_acc_5cm_5deg: Option<f64>,
    #[serde(flatten)]
    vs: VsPeer,
}

/// Runs the benchmark on `data` (default: the shared kitchen frames) for each split.
pub fn bench(
    data: Option<&Path>,
    splits: &[BlockSplit],
    peer: Result<Peer>,
) -> Result<Vec<RefineFigures>> {
    let data = match data {
        Some(d) => d.to_path_buf(),
        None => super::peer::shared_data("data/7scenes_redkitchen_seq01", "seq-01", Path::is_dir).context(
            "../shared/data/7scenes_redkitchen_seq01 not found beside the checkout (pass --refine-data)",
        )?,
    };
    let splits: Vec<BlockSplit> = if splits.is_empty() {
        DEFAULT_SPLITS
            .iter()
            .map(|s| s.parse().map_err(crate::LabError::msg))
            .collect::<Result<_>>()?
    } else {
        splits.to_vec()
    };
    splits
        .iter()
        .map(|&split| bench_split(&data, split, &peer))
        .collect()
}

fn bench_split(data: &Path, split: BlockSplit, peer: &Result<Peer>) -> Result<RefineFigures> {
    let ds = posed::open(data)?;
    let plan = SplitPlan::Blocks(split);
    let camera = ds.require_camera()?;
    let mapped = ds.mapped(plan);
    let parts = ds.parts(plan);
    let tests: Vec<usize> = (0..ds.images.len())
        .filter(|&i| parts[i] == Some(SplitName::Test))
        .collect();
    if mapped.is_empty() || tests.is_empty() {
        bail!(
            "{}: split {split} leaves no map or no test frames",
            data.display()
        );
    }
    let t = Instant::now();
    let km = map::keyframes::build(
        &mapped,
        &camera,
        &map::Lifting::depth_of(&ds, &camera),
        &BuildConfig::default(),
        &|| {},
    )?;
    let map_build_s = t.elapsed().as_secs_f64();
    let tmp = tempfile::tempdir()?;
    let path = tmp.path().join("bench.map");
    map::file::save(&km, &path)?;
    let map_bytes = std::fs::metadata(&path)?.len();
    let images: Vec<image::DynamicImage> = tests
        .par_iter()
        .map(|&i| data::frames::decode_image(&ds.images[i].image))
        .collect::<std::result::Result<_, _>>()?;
    let truth: Vec<&geom::Pose> = tests.iter().map(|&i| &ds.images[i].frame.pose).collect();
    let Queried {
        results,
        ms,
        pos,
        rot,
    } = query_all(&km, &images, &truth)?;
    let triangulated = map::keyframes::build(
        &mapped,
        &camera,
        &map::Lifting::Triangulation(map::triangulate::TriangulationConfig::default()),
        &BuildConfig::default(),
        &|| {},
    )?;
    let Queried {
        pos: tri_pos,
        rot: tri_rot,
        ..
    } = query_all(&triangulated, &images, &truth)?;
    let median = |v: Vec<f64>| Stats::of(&v).map(|s| s.median).unwrap_or(f64::NAN);
    let ours_ms = median(ms.clone());
    let peer_out = match peer {
        Ok(p) => sift_pnp(p, data, &ds, &mapped_indices(&ds, &parts), &tests),
        Err(e) => Err(crate::err!("{e:#}")),
    };
    let (peer_fig, note) = match peer_out {
        Ok(v) => (Some(v), None),
        Err(e) => (None, Some(format!("{e:#}"))),
    };
    Ok(RefineFigures {
        dataset: ds.name(),
        split: split.to_string(),
        mapped_frames: mapped.len(),
        keyframes: km.len(),
        points: km.points(),
        map_build_s,
        map_bytes,
        frames: tests.len(),
        median_pos_m: median(pos.clone()),
        median_rot_deg: median(rot.clone()),
        acc_5cm_5deg: geom::metrics::accuracy(&pos, &rot, 0.05, 5.0),
        refined: results.iter().filter(|r| r.refined).count() as f64 / results.len() as f64,
        ms: ours_ms,
        ms_features: median(results.iter().map(|r| r.timings.features_ms).collect()),
        ms_matching: median(results.iter().map(|r| r.timings.matching_ms).collect()),
        ms_pnp: median(results.iter().map(|r| r.timings.pnp_ms).collect()),
        triangulated_median_pos_m: median(tri_pos.clone()),
        triangulated_median_rot_deg: median(tri_rot.clone()),
        triangulated_acc_5cm_5deg: geom::metrics::accuracy(&tri_pos, &tri_rot, 0.05, 5.0),
        triangulated_points: triangulated.points(),
        peer_median_pos_m: peer_fig.as_ref().map(|p| p.median_pos_m),
        peer_median_rot_deg: peer_fig.as_ref().map(|p| p.median_rot_deg),
        peer_acc_5cm_5deg: peer_fig.as_ref().map(|p| p.acc_5cm_5deg),
        vs: VsPeer::new(
            "OpenCV SIFT + PnP RANSAC (sift_pnp.py)",
            ours_ms,
            peer_fig.as_ref().map(|p| p.ms_per_query),
            note,
        ),
    })
}

/// What [`query_all`] measured, query by query.
struct Queried {
    results: Vec<map::Refinement>,
    ms: Vec<f64>,
    pos: Vec<f64>,
    rot: Vec<f64>,
}

/// Each image refined from retrieval alone on one thread, timed, and its errors against
/// `truth`.
fn query_all(
    km: &map::KeyframeMap,
    images: &[image::DynamicImage],
    truth: &[&geom::Pose],
) -> Result<Queried> {
    let one = rayon::ThreadPoolBuilder::new().num_threads(1).build()?;
    let cfg = RefineConfig::default();
    let mut results = Vec::with_capacity(images.len());
    let mut ms = Vec::with_capacity(images.len());
    one.install(|| -> Result<()> {
        for img in images {
            let t = Instant::now();
            let r = km.refine(img, None, &cfg)?;
            ms.push(t.elapsed().as_secs_f64() * 1e3);
            results.push(r);
        }
        Ok(())
    })?;
    let pos = results
        .iter()
        .zip(truth)
        .map(|(r, t)| position_error(t, &r.pose))
        .collect();
    let rot = results
        .iter()
        .zip(truth)
        .map(|(r, t)| rotation_error_deg(t, &r.pose))
        .collect();
    Ok(Queried {
        results,
        ms,
        pos,
        rot,
    })
}

fn mapped_indices(ds: &posed::PosedDataset, parts: &[Option<SplitName>]) -> Vec<usize> {
    (0..ds.images.len())
        .filter(|&i| matches!(parts[i], Some(SplitName::Train | SplitName::Val)))
        .collect()
}

/// What `sift_pnp.py --json` prints that the table uses.
#[derive(Debug, serde::Deserialize)]
struct PeerFigures {
    median_pos_m: f64,
    median_rot_deg: f64,
    acc_5cm_5deg: f64,
    ms_per_query: f64,
}

/// Runs `sift_pnp.py` on the same frames (a single 7-Scenes sequence folder).
fn sift_pnp(
    peer: &Peer,
    data: &Path,
    ds: &posed::PosedDataset,
    mapped: &[usize],
    tests: &[usize],
) -> Result<PeerFigures> {
    let seqs: std::collections::BTreeSet<&str> =
        ds.images.iter().map(|i| i.frame.seq.as_str()).collect();
    if ds.layout != data::posed::Layout::SevenScenes || seqs.len() != 1 {
        bail!("sift_pnp.py reads one 7-Scenes sequence folder");
    }
    let seq_dir = ds.images[0]
        .image
        .parent()
        .context("frame without a folder")?
        .to_path_buf();
    let numbers = |idx: &[usize]| -> Result<Vec<u64>> {
        idx.iter()
            .map(|&i| {
                let name = &ds.images[i].frame.name;
                name.trim_start_matches("frame-")
                    .parse::<u64>()
                    .with_context(|| format!("{}: frame name {name} has no number", data.display()))
            })
            .collect()
    };
    let out = Command::new(&peer.python)
        .arg(peer.dir.join("sift_pnp.py"))
        .arg(&seq_dir)
        .args(["--map", &ranges(&numbers(mapped)?)])
        .args(["--query", &ranges(&numbers(tests)?)])
        .arg("--json")
        .output()
        .context("running sift_pnp.py")?;
    if !out.status.success() {
        bail!(
            "sift_pnp.py failed: {}",
            String::from_utf8_lossy(&out.stderr).trim()
        );
    }
    serde_json::from_slice(&out.stdout).context("sift_pnp.py printed no figures")
}

/// `0-399,500-899` for sorted frame numbers.
fn ranges(numbers: &[u64]) -> String {
    let mut parts: Vec<String> = Vec::new();
    let mut i = 0;
    while i < numbers.len() {
        let start = numbers[i];
        let mut end = start;
        while i + 1 < numbers.len() && numbers[i + 1] == end + 1 {
            i += 1;
            end = numbers[i];
        }
        parts.push(if start == end {
            start.to_string()
        } else {
            format!("{start}-{end}")
        });
        i += 1;
    }
    parts.join(",")
}

/// The table printed without `--json`.
pub fn table(rows: &[RefineFigures]) -> String {
    if rows.is_empty() {
        return String::new();
    }
    let mut s = format!(
        "{:<8}{:>7}{:>10}{:>10}{:>9}{:>9}{:>11}{:>11}{:>10}{:>9}{:>9}\n",
        "split",
        "frames",
        "median m",
        "median °",
        "≤5cm,5°",
        "ms",
        "peer m",
        "peer °",
        "peer ≤5cm",
        "peer ms",
        "ratio"
    );
    let opt = |v: Option<f64>, p: usize| v.map_or("-".to_string(), |v| format!("{v:.p$}"));
    for r in rows {
        s.push_str(&format!(
            "{:<8}{:>7}{:>10.4}{:>10.2}{:>9.2}{:>9.1}{:>11}{:>11}{:>10}{:>9}{:>9}\n",
            r.split,
            r.frames,
            r.median_pos_m,
            r.median_rot_deg,
            r.acc_5cm_5deg,
            r.ms,
            opt(r.peer_median_pos_m, 4),
            opt(r.peer_median_rot_deg, 2),
            opt(r.peer_acc_5cm_5deg, 2),
            opt(r.vs.peer_ms, 1),
            opt(r.vs.ratio_vs_peer, 2),
        ));
        s.push_str(&format!(
            "        map: {} frames → {} keyframes, {} points, {:.1} MB, built in {:.1} s; query: features {:.1} ms, matching {:.1} ms, PnP {:.1} ms; refined {:.0} %\n",
            r.mapped_frames,
            r.keyframes,
            r.points,
            r.map_bytes as f64 / 1e6,
            r.map_build_s,
            r.ms_features,
            r.ms_matching,
            r.ms_pnp,
            100.0 * r.refined
        ));
        s.push_str(&format!(
            "        photos alone (depth ignored, {} triangulated points): {:.4} m, {:.2}°, {:.2} within (5 cm, 5°)\n",
            r.triangulated_points,
            r.triangulated_median_pos_m,
            r.triangulated_median_rot_deg,
            r.triangulated_acc_5cm_5deg
        ));
        if let Some(n) = &r.vs.peer_note {
            s.push_str(&format!("        peer: {n}\n"));
        }
    }
    s
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn frame_numbers_become_ranges() {
        assert_eq!(ranges(&[0, 1, 2, 5, 7, 8]), "0-2,5,7-8");
        assert_eq!(ranges(&[]), "");
    }
}
