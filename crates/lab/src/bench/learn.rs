//! `indoorloc bench train` and `indoorloc bench infer`: a network's training step (batch 32, at
//! 1x120x160 and 3x256x256) and single-image inference (1x120x160 and 3x256x256, one thread
//! and all threads), beside PyTorch running `torch_apr.py --arch ARCH` with the same settings
//! in the same run (the small network by default; `--arch` picks another). `bench infer` also
//! times a frame as `localize` runs it (`learn::bench::localize_ms`): one plain pass, and
//! with test-time augmentation and 16 MC passes, as a multiple of the plain pass.
//!
//! On a GPU (`--device wgpu`) each input is measured once, as CPU threads do not count there,
//! and the CPU peer is not run: PyTorch on the same GPU is `scripts/gpu/torch_gpu.py`, which
//! `scripts/gpu/check.sh` runs beside this benchmark.

use super::peer::{Peer, VsPeer};
use crate::{Context, Result};
use learn::bench::{infer_ms, localize_ms, train_step_ms};
use learn::{Arch, ComputeDevice};
use serde::Serialize;
use std::process::Command;

/// Inputs measured, `[C, H, W]`: the ceiling camera's view and PoseNet's.
const INPUTS: [[usize; 3]; 2] = [[1, 120, 160], [3, 256, 256]];
/// Images per training step.
const BATCH: usize = 32;
/// Untimed repetitions first.
const WARMUP: usize = 3;
/// MC-dropout passes per frame in the `localize` rows, as `localize` runs by default.
const LOCALIZE_MC: usize = 16;

/// One measured row.
#[derive(Debug, Serialize)]
pub struct LearnFigures {
    /// `train` (ms per step of a batch), `infer` (ms per image) or `localize` (ms per frame).
    what: &'static str,
    arch: String,
    /// `cpu`, or the GPU's name (`wgpu: NVIDIA H100 80GB HBM3`).
    device: String,
    /// `[C, H, W]`.
    input: [usize; 3],
    /// Batch size (1 for inference).
    batch: usize,
    threads: usize,
    /// indoorloc, median milliseconds.
    ms: f64,
    /// `localize` rows: MC-dropout passes per frame (0: the plain pass alone).
    #[serde(skip_serializing_if = "Option::is_none")]
    mc: Option<usize>,
    /// `localize` rows: whether the frame's test-time copies ran too.
    #[serde(skip_serializing_if = "Option::is_none")]
    tta: Option<bool>,
    /// `localize` rows: `ms` over the plain pass's in the same run.
    #[serde(skip_serializing_if = "Option::is_none")]
    x_plain: Option<f64>,
    /// PyTorch's median milliseconds in the same run beside ours.
    #[serde(flatten)]
    vs: VsPeer,
}

fn median(mut v: Vec<f64>) -> f64 {
    v.sort_by(f64::total_cmp);
    v.get(v.len() / 2).copied().unwrap_or(f64::NAN)
}

/// Runs `f` on a rayon pool of `threads` threads (burn's `flex` backend parallelises on the
/// current rayon pool).
fn on_threads<T: Send>(threads: usize, f: impl FnOnce() -> T + Send) -> Result<T> {
    let pool = rayon::ThreadPoolBuilder::new()
        .num_threads(threads)
        .build()
        .context("cannot start a thread pool")?;
    Ok(pool.install(f))
}

/// `torch_apr.py`'s JSON for one input shape and thread count.
fn torch(
    peer: &Peer,
    arch: Arch,
    input: [usize; 3],
    threads: usize,
    steps: usize,
    runs: usize,
) -> Result<serde_json::Value> {
    let [c, h, w] = input;
    let out = Command::new(&peer.python)
        .arg(peer.dir.join("torch_apr.py"))
        .args(["--arch", arch.name(), "--batch", &BATCH.to_string()])
        .args([
            "--channels",
            &c.to_string(),
            "--height",
            &h.to_string(),
            "--width",
            &w.to_string(),
        ])
        .args([
            "--steps",
            &steps.to_string(),
            "--infer-runs",
            &runs.to_string(),
        ])
        .args([
            "--threads",
            &threads.to_string(),
            "--warmup",
            &WARMUP.to_string(),
        ])
        .output()
        .context("cannot run torch_apr.py")?;
    crate::ensure!(
        out.status.success(),
        "torch_apr.py failed: {}",
        String::from_utf8_lossy(&out.stderr)
            .lines()
            .last()
            .unwrap_or("")
    );
    serde_json::from_slice(&out.stdout).context("torch_apr.py printed no JSON")
}

/// The networks `torch_apr.py` builds.
const PEER_ARCHS: [Arch; 2] = [Arch::Small, Arch::Resnet18];

/// Measures `train` rows (`with_train`) and `infer` rows (`with_infer`) of `arch` with `steps`
/// timed training steps and `runs` timed inferences each, on the process's device.
pub fn bench(
    arch: Arch,
    with_train: bool,
    with_infer: bool,
    steps: usize,
    runs: usize,
    peer: Result<Peer>,
) -> Result<Vec<LearnFigures>> {
    let all = std::thread::available_parallelism().map_or(1, |n| n.get());
    let compute = learn::device::selected();
    let on_gpu = compute != ComputeDevice::Cpu;
    let mut thread_counts = if on_gpu { vec![all] } else { vec![1, all] };
    thread_counts.dedup();
    let device = learn::device::describe();
    let peer = if on_gpu {
        Err(crate::err!(
            "torch_apr.py runs on the CPU; PyTorch on this GPU is scripts/gpu/torch_gpu.py"
        ))
    } else if !PEER_ARCHS.contains(&arch) {
        Err(crate::err!("torch_apr.py has no {arch}"))
    } else {
        peer
    };
    let mut rows = Vec::new();
    for input in INPUTS {
        for &threads in &thread_counts {
            // Training is measured with every thread only, as PyTorch trains by default.
            let train = with_train && threads == all;
            let (peer_json, peer_note) = match &peer {
                Ok(p) if train || with_infer => {
                    match torch(p, arch, input, threads, if train { steps } else { 1 }, runs) {
                        Ok(v) => (Some(v), None),
                        Err(e) => (None, Some(format!("{e:#}"))),
                    }
                }
                Ok(_) => (None, None),
                Err(e) => (None, Some(format!("{e:#}"))),
            };
            let peer_ms = |key: &str| peer_json.as_ref().and_then(|v| v[key].as_f64());
            let mut row = |what, batch, ms: f64, peer: Option<f64>| {
                rows.push(LearnFigures {
                    what,
                    arch: arch.to_string(),
                    device: device.clone(),
                    input,
                    batch,
                    threads,
                    ms,
                    mc: None,
                    tta: None,
                    x_plain: None,
                    vs: VsPeer::new("PyTorch torch_apr.py", ms, peer, peer_note.clone()),
                });
            };
            if train {
                let ms = median(on_threads(threads, || {
                    train_step_ms(arch, input, BATCH, WARMUP, steps)
                })??);
                row("train", BATCH, ms, peer_ms("train_ms_per_step"));
            }
            if with_infer {
                let ms = median(on_threads(threads, || {
                    infer_ms(arch, input, WARMUP, runs)
                })??);
                row("infer", 1, ms, peer_ms("infer_ms_per_image"));
                rows.extend(localize_rows(arch, input, threads, runs, &device)?);
            }
        }
    }
    Ok(rows)
}

/// The `localize` rows of one input and thread count: the plain pass, then TTA and
/// [`LOCALIZE_MC`] MC passes as a multiple of it.
fn localize_rows(
    arch: Arch,
    input: [usize; 3],
    threads: usize,
    runs: usize,
    device: &str,
) -> Result<[LearnFigures; 2]> {
    let time = |tta, mc| -> Result<f64> {
        Ok(median(on_threads(threads, || {
            localize_ms(arch, input, tta, mc, WARMUP, runs)
        })??))
    };
    let plain = time(false, 0)?;
    let full = time(true, LOCALIZE_MC)?;
    let row = |ms: f64, tta, mc| LearnFigures {
        what: "localize",
        arch: arch.to_string(),
        device: device.to_string(),
        input,
        batch: 1,
        threads,
        ms,
        mc: Some(mc),
        tta: Some(tta),
        x_plain: Some(ms / plain),
        vs: VsPeer::new(
            "PyTorch torch_apr.py",
            ms,
            None,
            Some("torch_apr.py has no MC or TTA passes".into()),
        ),
    };
    Ok([row(plain, false, 0), row(full, true, LOCALIZE_MC)])
}

/// The rows as a table for people.
pub fn table(rows: &[LearnFigures]) -> String {
    if rows.is_empty() {
        return String::new();
    }
    let mut text = format!("{} on {}\n", rows[0].arch, rows[0].device);
    text.push_str(&format!(
        "{:<14}{:>12}{:>7}{:>9}{:>11}{:>11}{:>9}\n",
        "learn", "input", "batch", "threads", "ms", "PyTorch", "ratio"
    ));
    for r in rows {
        let [c, h, w] = r.input;
        let what = match (r.mc, r.tta) {
            (Some(mc), Some(true)) if mc > 0 => format!("loc+{mc}mc+tta"),
            (Some(_), _) => "loc plain".into(),
            _ => r.what.into(),
        };
        let ratio = match r.x_plain {
            Some(x) => format!("{x:.2}x pl"),
            None => {
                r.vs.ratio_vs_peer
                    .map_or("–".into(), |x| format!("{x:.2}x"))
            }
        };
        text.push_str(&format!(
            "{:<14}{:>12}{:>7}{:>9}{:>11.2}{:>11}{:>9}\n",
            what,
            format!("{c}x{h}x{w}"),
            r.batch,
            r.threads,
            r.ms,
            r.vs.peer_ms.map_or("–".into(), |p| format!("{p:.2}")),
            ratio,
        ));
    }
    if rows.iter().any(|r| r.x_plain.is_some()) {
        text.push_str(&format!(
            "loc: a frame as `localize` runs it; \"x pl\": times its plain pass ({LOCALIZE_MC} MC \
             passes reuse the frame's features, TTA runs the backbone on 5 views)\n"
        ));
    }
    if let Some(note) = rows
        .iter()
        .filter(|r| r.x_plain.is_none())
        .find_map(|r| r.vs.peer_note.as_ref())
    {
        text.push_str(&format!("PyTorch not measured: {note}\n"));
    }
    text
}
