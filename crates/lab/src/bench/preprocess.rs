//! `indoorloc bench preprocess`: milliseconds per image of the two views networks use most, on
//! one thread, beside OpenCV doing the same work in the same run.
//!
//! - `gray160`: grey → 160x120 `INTER_AREA` → CLAHE(2.0, 8x8), 8-bit out; the peer is
//!   `clahe.py` (the same pipeline, its own timer around it, decoding excluded).
//! - `rgb256`: 256x256 `INTER_AREA` → `x / 127.5 - 1` as a CHW `f32` tensor; the peer is OpenCV's
//!   `resize` plus NumPy's scaling and transpose (a short inline script run by the peers' Python).
//!
//! Both sides time the view alone (no decoding, no writing), take the median of many runs, and
//! run OpenCV with one thread.

use super::peer::{Peer, VsPeer};
use crate::{Context, Result, bail};
use imgproc::view::{Scratch, ViewSpec, gray_clahe_view_into};
use serde::Serialize;
use std::path::{Path, PathBuf};
use std::process::Command;
use std::time::Instant;

/// Timed runs per view (after a warm-up).
const RUNS: usize = 500;
const WARMUP: usize = 20;

/// Figures of one view.
#[derive(Debug, Serialize)]
pub struct ViewFigures {
    /// Preset name.
    view: &'static str,
    /// Spec text.
    spec: String,
    /// The photo.
    image: PathBuf,
    /// Its size, `[width, height]`.
    input_size: [u32; 2],
    /// indoorloc, median ms per image, one thread.
    ms: f64,
    /// The peer's median ms per image beside ours.
    #[serde(flatten)]
    vs: VsPeer,
}

/// OpenCV resize + NumPy normalisation to a CHW tensor, timed like `clahe.py` times its pipeline.
const RGB256_PEER: &str = r#"
import json, sys, time
import cv2, numpy as np
cv2.setNumThreads(1)
bgr = cv2.imread(sys.argv[1], cv2.IMREAD_COLOR)
if bgr is None:
    sys.exit(f"{sys.argv[1]}: unreadable")
rgb = cv2.cvtColor(bgr, cv2.COLOR_BGR2RGB)
runs, warmup = int(sys.argv[2]), int(sys.argv[3])
ms = []
for i in range(warmup + runs):
    t0 = time.perf_counter_ns()
    small = cv2.resize(rgb, (256, 256), interpolation=cv2.INTER_AREA)
    x = np.ascontiguousarray((small.astype(np.float32) * np.float32(1 / 127.5) - np.float32(1)).transpose(2, 0, 1))
    t1 = time.perf_counter_ns()
    if i >= warmup:
        ms.append((t1 - t0) / 1e6)
ms.sort()
print(json.dumps({"median_ms": ms[len(ms) // 2], "opencv": cv2.__version__}))
"#;

/// Runs the benchmark on `image` (or the default photo) with the peer where it is installed.
pub fn bench(image: Option<&Path>, peer: Result<Peer>) -> Result<Vec<ViewFigures>> {
    let tmp = tempfile::tempdir().context("creating a temporary folder")?;
    let path = match image {
        Some(p) => p.to_path_buf(),
        None => default_photo().map_or_else(|| rendered_photo(tmp.path()), Ok)?,
    };
    let rgb = image::open(&path)
        .with_context(|| format!("{}: not a readable image", path.display()))?
        .to_rgb8();
    let input_size = [rgb.width(), rgb.height()];
    let mut scratch = Scratch::new();

    let mut gray = image::GrayImage::new(160, 120);
    let gray_ms = time_median(|| gray_clahe_view_into(&rgb, &mut gray, 2.0, 8, &mut scratch))?;
    let rgb256 = ViewSpec::preset("rgb256")?;
    let rgb_ms = time_median(|| rgb256.apply_rgb(&rgb, 0, &mut scratch).map(|_| ()))?;

    let peer_of = |run: &dyn Fn(&Peer) -> Result<f64>| match &peer {
        Ok(p) => match run(p) {
            Ok(ms) => (Some(ms), None),
            Err(e) => (None, Some(format!("{e:#}"))),
        },
        Err(e) => (None, Some(format!("{e:#}"))),
    };
    let (gray_peer, gray_note) = peer_of(&|p| clahe_py(p, &path));
    let (rgb_peer, rgb_note) = peer_of(&|p| rgb256_py(p, &path));
    let figures = |view, spec: String, ms: f64, peer_ms: Option<f64>, peer, note| ViewFigures {
        view,
        spec,
        image: path.clone(),
        input_size,
        ms,
        vs: VsPeer::new(peer, ms, peer_ms, note),
    };
    Ok(vec![
        figures(
            "gray160",
            ViewSpec::preset("gray160")?.to_string(),
            gray_ms,
            gray_peer,
            "OpenCV clahe.py",
            gray_note,
        ),
        figures(
            "rgb256",
            rgb256.to_string(),
            rgb_ms,
            rgb_peer,
            "OpenCV resize + NumPy",
            rgb_note,
        ),
    ])
}

/// The table printed without `--json`.
pub fn table(rows: &[ViewFigures]) -> String {
    let Some(first) = rows.first() else {
        return String::new();
    };
    let mut t = format!(
        "preprocess: {} ({}x{}), one thread, median of {RUNS} runs\n{:<10}{:>10}{:>12}{:>10}\n",
        first.image.display(),
        first.input_size[0],
        first.input_size[1],
        "view",
        "ms",
        "peer ms",
        "ratio"
    );
    for r in rows {
        let opt = |v: Option<f64>, d: usize| v.map_or("-".into(), |v| format!("{v:.d$}"));
        t.push_str(&format!(
            "{:<10}{:>10.3}{:>12}{:>10}\n",
            r.view,
            r.ms,
            opt(r.vs.peer_ms, 3),
            opt(r.vs.ratio_vs_peer, 2)
        ));
        if let Some(note) = &r.vs.peer_note {
            t.push_str(&format!("  {}: {note}\n", r.vs.peer));
        }
    }
    t
}

/// Median milliseconds of `f` over [`RUNS`] runs after [`WARMUP`] untimed ones.
fn time_median<E>(mut f: impl FnMut() -> std::result::Result<(), E>) -> Result<f64>
where
    E: Into<crate::LabError>,
{
    for _ in 0..WARMUP {
        f().map_err(Into::into)?;
    }
    let mut ms = Vec::with_capacity(RUNS);
    for _ in 0..RUNS {
        let t = Instant::now();
        f().map_err(Into::into)?;
        ms.push(t.elapsed().as_secs_f64() * 1e3);
    }
    Ok(crate::output::median(&ms))
}

/// A real 640x480 photo from the shared data, when it is beside the checkout.
fn default_photo() -> Option<PathBuf> {
    let rel = "data/aruco_real/img_00.jpg";
    [
        std::env::var_os("INDOORLOC_SHARED").map(|d| Path::new(&d).join(rel)),
        Some(Path::new("../shared").join(rel)),
        Some(Path::new("shared").join(rel)),
    ]
    .into_iter()
    .flatten()
    .find(|p| p.is_file())
}

/// Without the shared data: a 640x480 textured render of the default building, as a PNG in `dir`.
fn rendered_photo(dir: &Path) -> Result<PathBuf> {
    use synth::render::{RenderMode, RenderOptions, RenderScene, Renderer};
    let cfg = synth::dataset::SynthConfig::default();
    let (world, _) = synth::dataset::build_world(&cfg)?;
    let scene = RenderScene::new(&world)?;
    let rig = synth::dataset::rig_of(cfg.camera);
    let walk_cfg = synth::trajectory::WalkConfig::for_rig(rig.clone());
    let walk = synth::trajectory::walk(&world, &walk_cfg, 1, cfg.seed)?;
    let camera = synth::trajectory::camera_for(&rig, 640, 480, cfg.seed)?;
    let opts = RenderOptions {
        mode: RenderMode::Textured,
        ..RenderOptions::default()
    };
    let mut renderer = Renderer::new();
    let frame = renderer.render(&scene, &camera, &walk[0].pose, &opts, &[])?;
    let path = dir.join("render_640x480.png");
    frame
        .rgb
        .save(&path)
        .with_context(|| format!("{}: cannot write", path.display()))?;
    Ok(path)
}

/// `clahe.py IMAGE --repeat RUNS`: its median of the whole gray → resize → CLAHE pipeline.
fn clahe_py(peer: &Peer, image: &Path) -> Result<f64> {
    let out = Command::new(&peer.python)
        .arg(peer.dir.join("clahe.py"))
        .arg(image)
        .args(["--repeat", &RUNS.to_string(), "--threads", "1"])
        .output()
        .context("running clahe.py")?;
    json_number(&out, "clahe.py", "median_ms_per_image")
}

/// The inline OpenCV + NumPy script for the `rgb256` view.
fn rgb256_py(peer: &Peer, image: &Path) -> Result<f64> {
    let out = Command::new(&peer.python)
        .args(["-c", RGB256_PEER])
        .arg(image)
        .args([RUNS.to_string(), WARMUP.to_string()])
        .output()
        .context("running OpenCV")?;
    json_number(&out, "OpenCV script", "median_ms")
}

fn json_number(out: &std::process::Output, what: &str, key: &str) -> Result<f64> {
    if !out.status.success() {
        bail!(
            "{what} failed: {}",
            String::from_utf8_lossy(&out.stderr).trim()
        );
    }
    let v: serde_json::Value =
        serde_json::from_slice(&out.stdout).with_context(|| format!("{what} output"))?;
    v[key]
        .as_f64()
        .with_context(|| format!("{what} printed no {key}"))
}
