//! `indoorloc bench serve`: the live pipeline's throughput and latency, and the server under
//! many WebSocket clients.
//!
//! 1. Throughput: the demo's held-out walk (160x120 PNG frames on disk) through the pipeline
//!    of `indoorloc serve` as fast as it goes (read and decode, cut detector, network,
//!    filter), with MC dropout off and on: frames/s end to end and the p50 / p99 latency; and,
//!    when the demo built its keyframe map (`zone.map`), the same walk at 640x480
//!    (`map-data`) through the network and the map's refinement.
//! 2. Load: the server in this process, the walk played in real time at `--load-fps` and
//!    looped, `--clients` WebSocket clients on loopback for `--seconds`: messages per client
//!    (none may starve), clients dropped, and resident memory sampled every second (it must
//!    stay flat: the broadcast buffer is bounded).
//!
//! There is no peer for serving; the figures stand alone.

use crate::{Context, Result, bail};
use data::native::SplitName;
use futures_util::StreamExt;
use serde::Serialize;
use serve::{FloorMap, Hub, ServerConfig};
use std::path::Path;
use std::sync::Arc;
use std::sync::atomic::Ordering;
use std::time::{Duration, Instant};
use track::{Event, NetworkEstimator, Pipeline, PipelineConfig, Stage};

/// Throughput of one pipeline setting.
#[derive(Debug, Serialize)]
pub struct Throughput {
    /// MC-dropout passes per frame.
    pub mc: usize,
    /// `network` (160x120 frames), or `network+map` (640x480 frames, refined against the
    /// demo's keyframe map).
    pub estimators: &'static str,
    /// Share of frames the map refined (`network+map` only).
    #[serde(skip_serializing_if = "Option::is_none")]
    pub refined: Option<f64>,
    /// Frames through the pipeline.
    pub frames: u64,
    /// Frames per second end to end.
    pub fps: f64,
    /// Median read-to-pose latency, ms.
    pub p50_ms: f64,
    /// 99th percentile of the read-to-pose latency, ms.
    pub p99_ms: f64,
    /// Median time in the estimators, ms.
    pub estimate_p50_ms: f64,
}

/// The server under load.
#[derive(Debug, Serialize)]
pub struct Load {
    /// WebSocket clients.
    pub clients: usize,
    /// Seconds they listened.
    pub seconds: f64,
    /// Poses published.
    pub poses: u64,
    /// Fewest and most messages a client received.
    pub min_messages: usize,
    /// Most messages a client received.
    pub max_messages: usize,
    /// Clients the server dropped.
    pub dropped_clients: u64,
    /// Resident memory after the first 5 s, MB.
    pub rss_start_mb: f64,
    /// Resident memory at the end, MB.
    pub rss_end_mb: f64,
    /// Highest resident memory sampled, MB.
    pub rss_peak_mb: f64,
    /// p99 of the pipeline's read-to-pose latency under the load, ms.
    pub p99_ms: f64,
}

/// Everything `bench serve` measured.
#[derive(Debug, Serialize)]
pub struct ServeFigures {
    /// Per MC setting.
    pub throughput: Vec<Throughput>,
    /// The load test.
    pub load: Load,
}

/// Runs the serve benchmark on the demo in `demo_dir`.
pub fn bench(
    demo_dir: &Path,
    mc: usize,
    clients: usize,
    seconds: f64,
    load_fps: f64,
) -> Result<ServeFigures> {
    let (model, data) = (demo_dir.join("model"), demo_dir.join("data"));
    if !model.join("model.toml").is_file() {
        bail!(
            "{}: no trained demo; run `indoorloc demo --quick --out {}` first",
            demo_dir.display(),
            demo_dir.display()
        );
    }
    let data_s = data.to_string_lossy().into_owned();
    let mut throughput = Vec::new();
    let keyframes = demo_dir.join(crate::demo::refine::MAP_FILE);
    let map_data = demo_dir.join(crate::demo::refine::MAP_DATA);
    let mut runs = vec![(0, None, data_s.clone()), (mc, None, data_s.clone())];
    if keyframes.is_file() && map_data.is_dir() {
        runs.push((
            0,
            Some(keyframes.as_path()),
            map_data.to_string_lossy().into_owned(),
        ));
    }
    for (passes, keyframes, data) in runs {
        let mut p = pipeline(&model, &data, passes, None, false)?;
        if let Some(path) = keyframes {
            p = p.with_estimator(Box::new(track::MapEstimator::load(path)?));
        }
        let metrics = p.metrics();
        let t = Instant::now();
        let (mut poses, mut refined) = (0usize, 0usize);
        if let Event::Error { message, .. } = p.run(|e, _| {
            if let Event::Pose(pose) = e {
                poses += 1;
                refined += usize::from(pose.measurements.iter().any(|m| m.estimator == "map"));
            }
        }) {
            bail!("the pipeline failed: {message}");
        }
        let s = t.elapsed().as_secs_f64();
        let snap = metrics.snapshot();
        let stage = |st: Stage| snap.stage(st).cloned().context("stage figures");
        let (total, est) = (stage(Stage::Total)?, stage(Stage::Estimate)?);
        throughput.push(Throughput {
            mc: passes,
            estimators: if keyframes.is_some() {
                "network+map"
            } else {
                "network"
            },
            refined: keyframes.map(|_| refined as f64 / poses.max(1) as f64),
            frames: snap.poses,
            fps: snap.poses as f64 / s,
            p50_ms: total.p50_ms,
            p99_ms: total.p99_ms,
            estimate_p50_ms: est.p50_ms,
        });
    }
    let load = load(&model, &data_s, clients, seconds, load_fps)?;
    Ok(ServeFigures { throughput, load })
}

fn pipeline(
    model: &Path,
    data: &str,
    mc: usize,
    fps: Option<f64>,
    realtime: bool,
) -> Result<Pipeline> {
    let source = track::source::open(data, Some(SplitName::Test), fps)?;
    let net = NetworkEstimator::load(model, mc)?;
    let cfg = PipelineConfig {
        realtime,
        ..PipelineConfig::default()
    };
    Ok(Pipeline::new(source, vec![Box::new(net)], cfg)?)
}

/// Resident memory of this process, MB (Linux; 0 elsewhere).
fn rss_mb() -> f64 {
    std::fs::read_to_string("/proc/self/status")
        .ok()
        .and_then(|s| {
            s.lines()
                .find(|l| l.starts_with("VmRSS:"))
                .and_then(|l| l.split_whitespace().nth(1)?.parse::<f64>().ok())
        })
        .map_or(0.0, |kb| kb / 1024.0)
}

fn load(model: &Path, data: &str, clients: usize, seconds: f64, fps: f64) -> Result<Load> {
    let first = pipeline(model, data, 0, Some(fps), true)?;
    let metrics = first.metrics();
    let hub = Hub::new(Arc::clone(&metrics), FloorMap::default());
    let stop = Arc::new(std::sync::atomic::AtomicBool::new(false));
    let feeder = {
        let (hub, stop, metrics) = (Arc::clone(&hub), Arc::clone(&stop), Arc::clone(&metrics));
        let (model, data) = (model.to_path_buf(), data.to_string());
        std::thread::spawn(move || -> Result<()> {
            let mut p = first.with_stop_flag(Arc::clone(&stop));
            loop {
                p.run(|e, f| {
                    if matches!(e, Event::Pose(_)) {
                        hub.publish(e, f)
                    }
                });
                if stop.load(Ordering::Relaxed) {
                    return Ok(());
                }
                p = pipeline(&model, &data, 0, Some(fps), true)?
                    .with_metrics(Arc::clone(&metrics))
                    .with_stop_flag(Arc::clone(&stop));
            }
        })
    };
    let runtime = tokio::runtime::Builder::new_multi_thread()
        .worker_threads(2)
        .enable_all()
        .build()?;
    let result = runtime.block_on(async {
        let listener = tokio::net::TcpListener::bind("127.0.0.1:0").await?;
        let addr = listener.local_addr()?;
        tokio::spawn(serve::serve(
            listener,
            Arc::clone(&hub),
            ServerConfig::default(),
            std::future::pending(),
        ));
        let url = format!("ws://{addr}/ws");
        let deadline = tokio::time::Instant::now() + Duration::from_secs_f64(seconds);
        let tasks: Vec<_> = (0..clients)
            .map(|_| {
                let url = url.clone();
                tokio::spawn(async move {
                    let Ok((mut ws, _)) = tokio_tungstenite::connect_async(&url).await else {
                        return 0usize;
                    };
                    let mut n = 0;
                    while let Ok(Some(Ok(m))) = tokio::time::timeout_at(deadline, ws.next()).await {
                        if m.is_text() {
                            n += 1;
                        }
                    }
                    n
                })
            })
            .collect();
        let started = Instant::now();
        let (mut rss_start, mut peak) = (0.0f64, 0.0f64);
        while tokio::time::Instant::now() < deadline {
            tokio::time::sleep(Duration::from_secs(1)).await;
            let rss = rss_mb();
            peak = peak.max(rss);
            if rss_start == 0.0 && started.elapsed() >= Duration::from_secs(5) {
                rss_start = rss;
            }
        }
        let mut counts = Vec::new();
        for t in tasks {
            counts.push(t.await.unwrap_or(0));
        }
        Ok::<_, crate::LabError>((counts, rss_start, peak))
    });
    stop.store(true, Ordering::Relaxed);
    let fed = feeder.join();
    let (counts, rss_start, peak) = result?;
    match fed {
        Ok(r) => r?,
        Err(_) => bail!("the pipeline thread panicked"),
    }
    let snap = metrics.snapshot();
    Ok(Load {
        clients,
        seconds,
        poses: snap.poses,
        min_messages: counts.iter().copied().min().unwrap_or(0),
        max_messages: counts.iter().copied().max().unwrap_or(0),
        dropped_clients: hub.clients_dropped.load(Ordering::Relaxed),
        rss_start_mb: rss_start,
        rss_end_mb: rss_mb(),
        rss_peak_mb: peak,
        p99_ms: snap.stage(Stage::Total).map_or(f64::NAN, |t| t.p99_ms),
    })
}

/// The text table.
pub fn table(f: &ServeFigures) -> String {
    let mut t = format!(
        "{:<14}{:>4}{:>8}{:>10}{:>10}{:>10}{:>14}{:>9}\n",
        "serve", "MC", "frames", "frames/s", "p50 ms", "p99 ms", "estimate ms", "refined"
    );
    for r in &f.throughput {
        let refined = r
            .refined
            .map_or("-".to_string(), |v| format!("{:.0} %", 100.0 * v));
        t.push_str(&format!(
            "{:<14}{:>4}{:>8}{:>10.1}{:>10.2}{:>10.2}{:>14.2}{:>9}\n",
            r.estimators, r.mc, r.frames, r.fps, r.p50_ms, r.p99_ms, r.estimate_p50_ms, refined
        ));
    }
    let l = &f.load;
    t.push_str(&format!(
        "load: {} WebSocket clients for {:.0} s, {} poses; messages per client {}..{}; {} dropped; \
         RSS {:.1} MB after 5 s, {:.1} MB at the end, peak {:.1} MB; p99 {:.2} ms\n",
        l.clients,
        l.seconds,
        l.poses,
        l.min_messages,
        l.max_messages,
        l.dropped_clients,
        l.rss_start_mb,
        l.rss_end_mb,
        l.rss_peak_mb,
        l.p99_ms
    ));
    t
}
