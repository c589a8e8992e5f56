//! The live pipeline: a reader thread pulls frames from the [`Source`] (at their own pace when
//! `realtime`), a bounded [`FrameQueue`] hands them over (dropping stale frames of live
//! sources), and the estimation thread runs the cut detector, every [`Estimator`] and the
//! [`PoseFilter`], and hands each fused pose to a sink.
//!
//! The sink sees [`Event`]s: a pose per processed frame, then `end` or `error`. Every stage's
//! time goes into the shared [`Metrics`].

use crate::error::{Result, TrackError};
use crate::estimator::BoxedEstimator;
use crate::filter::FilterConfig;
use crate::queue::{FrameQueue, Overflow};
use crate::source::{Source, SourceFrame};
use crate::stages::Stages;
use crate::stats::{Metrics, Stage};
use geom::Pose;
use image::{DynamicImage, RgbImage};
use serde::Serialize;
use std::sync::Arc;
use std::sync::atomic::{AtomicBool, Ordering};
use std::time::{Duration, Instant};

/// Settings of a pipeline run.
#[derive(Clone, Debug)]
pub struct PipelineConfig {
    /// The temporal filter.
    pub filter: FilterConfig,
    /// Frames that may wait for the estimators.
    pub queue: usize,
    /// What a full queue does; `None`: drop stale frames of live or real-time sources, wait
    /// for file sources read as fast as possible.
    pub overflow: Option<Overflow>,
    /// Read frames at their recorded pace (a file played as if live).
    pub realtime: bool,
    /// Detect scene cuts and reset the filter at each.
    pub detect_cuts: bool,
    /// Stop after this many frames.
    pub max_frames: Option<u64>,
}

impl Default for PipelineConfig {
    fn default() -> Self {
        PipelineConfig {
            filter: FilterConfig::default(),
            queue: 2,
            overflow: None,
            realtime: false,
            detect_cuts: true,
            max_frames: None,
        }
    }
}

/// One estimator's raw output for a frame.
#[derive(Clone, Debug, PartialEq, Serialize)]
pub struct RawEstimate {
    /// Which estimator.
    pub estimator: &'static str,
    /// Camera centre, metres.
    pub position: [f64; 3],
    /// Rotation, `w, x, y, z`.
    pub quaternion: [f64; 4],
    /// `sqrt(trace Σ_pos)`, metres.
    pub sigma_pos_m: f64,
    /// Rotation standard deviation, degrees.
    pub sigma_rot_deg: f64,
    /// Position covariance, m², row-major 3x3.
    pub cov_pos_m2: [f64; 9],
}

/// Milliseconds each stage took for one frame.
#[derive(Clone, Copy, Debug, Default, PartialEq, Serialize)]
pub struct Latency {
    /// Reading and decoding.
    pub read: f64,
    /// Waiting for the estimators.
    pub queue: f64,
    /// Estimators and cut detector.
    pub estimate: f64,
    /// The filter.
    pub filter: f64,
    /// Read to output.
    pub total: f64,
}

/// A ground-truth pose, where the source has one.
#[derive(Clone, Copy, Debug, PartialEq, Serialize)]
pub struct Truth {
    /// Camera centre, metres.
    pub position: [f64; 3],
    /// Rotation, `w, x, y, z`.
    pub quaternion: [f64; 4],
}

/// The fused pose of one frame.
#[derive(Clone, Debug, PartialEq, Serialize)]
pub struct PoseEvent {
    /// The frame's index in the source.
    pub frame: u64,
    /// The frame's name (file stem, dataset frame name).
    pub name: String,
    /// Time of the frame, seconds from the first.
    pub t: f64,
    /// Fused camera centre, metres.
    pub position: [f64; 3],
    /// Fused rotation, `w, x, y, z`.
    pub quaternion: [f64; 4],
    /// `sqrt(trace Σ_pos)` of the fused state, metres.
    pub sigma_pos_m: f64,
    /// Rotation standard deviation of the fused state, degrees.
    pub sigma_rot_deg: f64,
    /// Position covariance (row-major 3x3, m²).
    pub covariance_pos: [f64; 9],
    /// What the filter did with the last measurement: `started`, `fused`, `rejected`; `coasted`
    /// when no estimator saw anything.
    pub update: &'static str,
    /// Whether a scene cut was detected at this frame (the filter started over).
    pub cut: bool,
    /// Every estimator's own output.
    pub measurements: Vec<RawEstimate>,
    /// Ground truth, for sources that have it.
    #[serde(skip_serializing_if = "Option::is_none")]
    pub truth: Option<Truth>,
    /// Per-stage latency.
    pub latency_ms: Latency,
    /// Frames dropped so far (live sources under load).
    pub dropped: u64,
}

impl PoseEvent {
    /// The fused pose (`None` only for a quaternion of zero length, which the filter never
    /// makes).
    pub fn pose(&self) -> Option<Pose> {
        Pose::from_t_wxyz(self.position, self.quaternion).ok()
    }

    /// The first estimator's raw pose, if any estimator saw the frame.
    pub fn raw_pose(&self) -> Option<Pose> {
        let m = self.measurements.first()?;
        Pose::from_t_wxyz(m.position, m.quaternion).ok()
    }

    /// The true pose.
    pub fn truth_pose(&self) -> Option<Pose> {
        let t = self.truth?;
        Pose::from_t_wxyz(t.position, t.quaternion).ok()
    }
}

/// What the pipeline tells its sink.
#[derive(Clone, Debug, PartialEq, Serialize)]
#[serde(tag = "event", rename_all = "snake_case")]
pub enum Event {
    /// A fused pose (boxed: it is ten times the size of the other events).
    Pose(Box<PoseEvent>),
    /// The source ended normally.
    End {
        /// Frames processed.
        frames: u64,
        /// Frames dropped under load.
        dropped: u64,
    },
    /// The source or an estimator failed; the stream ends.
    Error {
        /// The frame the failure came at, where known.
        frame: Option<u64>,
        /// What went wrong.
        message: String,
    },
}

/// What travels from the reader to the estimators.
enum Item {
    Frame {
        frame: SourceFrame,
        read_at: Instant,
        read_s: f64,
    },
    Failed(TrackError),
}

/// A source, its estimators and the filter, ready to run.
pub struct Pipeline {
    source: Box<dyn Source>,
    estimators: Vec<BoxedEstimator>,
    cfg: PipelineConfig,
    metrics: Arc<Metrics>,
    stop: Arc<AtomicBool>,
}

impl Pipeline {
    /// A pipeline from `source` through `estimators` (at least one).
    pub fn new(
        source: Box<dyn Source>,
        estimators: Vec<BoxedEstimator>,
        cfg: PipelineConfig,
    ) -> Result<Pipeline> {
        if estimators.is_empty() {
            return Err(TrackError::Config(
                "the pipeline needs an estimator (a model, a marker map or both)".into(),
            ));
        }
        Ok(Pipeline {
            source,
            estimators,
            cfg,
            metrics: Arc::new(Metrics::default()),
            stop: Arc::new(AtomicBool::new(false)),
        })
    }

    /// The pipeline with one more estimator after the others (it sees their estimate of each
    /// frame as its prior).
    pub fn with_estimator(mut self, estimator: BoxedEstimator) -> Pipeline {
        self.estimators.push(estimator);
        self
    }

    /// Counts into `metrics` instead of the pipeline's own (a server that runs one pipeline
    /// after another keeps one set of figures).
    pub fn with_metrics(mut self, metrics: Arc<Metrics>) -> Pipeline {
        self.metrics = metrics;
        self
    }

    /// Stops on `stop` instead of the pipeline's own flag (one flag for a run of pipelines).
    pub fn with_stop_flag(mut self, stop: Arc<AtomicBool>) -> Pipeline {
        self.stop = stop;
        self
    }

    /// The run's counters and latencies, to read while it runs.
    pub fn metrics(&self) -> Arc<Metrics> {
        Arc::clone(&self.metrics)
    }

    /// Setting this flag stops the run after the frame in hand.
    pub fn stop_flag(&self) -> Arc<AtomicBool> {
        Arc::clone(&self.stop)
    }

    /// Runs to the end of the source (or the stop flag), handing every event and the frame it
    /// belongs to to `sink`. The last event is `End` or `Error`, which is also returned.
    pub fn run(self, mut sink: impl FnMut(&Event, Option<&RgbImage>)) -> Event {
        let Pipeline {
            mut source,
            estimators,
            cfg,
            metrics,
            stop,
        } = self;
        let overflow = cfg.overflow.unwrap_or(if source.is_live() || cfg.realtime {
            Overflow::DropOldest
        } else {
            Overflow::Block
        });
        let queue = Arc::new(FrameQueue::new(cfg.queue, overflow));
        let reader = {
            let (queue, metrics, stop) =
                (Arc::clone(&queue), Arc::clone(&metrics), Arc::clone(&stop));
            let (realtime, max_frames) = (cfg.realtime, cfg.max_frames);
            std::thread::spawn(move || {
                read_frames(&mut *source, &queue, &metrics, &stop, realtime, max_frames);
            })
        };
        let mut worker = Worker::new(&cfg, estimators, &metrics);
        let mut last = None;
        while let Some(item) = queue.pop() {
            match item {
                Item::Frame {
                    frame,
                    read_at,
                    read_s,
                } => {
                    let SourceFrame { frame, truth } = frame;
                    let index = frame.index;
                    let image = DynamicImage::ImageRgb8(frame.image);
                    let meta = FrameMeta {
                        index,
                        name: frame.name,
                        t: frame.t.unwrap_or(0.0),
                        truth,
                    };
                    match worker.process(&meta, &image, read_at, read_s) {
                        Ok(event) => {
                            last = Some(index);
                            sink(&event, image.as_rgb8());
                        }
                        Err(e) => {
                            worker.failure = Some(Event::Error {
                                frame: Some(index),
                                message: e.to_string(),
                            });
                            break;
                        }
                    }
                }
                Item::Failed(e) => {
                    worker.failure = Some(Event::Error {
                        frame: last.map(|f| f + 1),
                        message: e.to_string(),
                    });
                    break;
                }
            }
            if stop.load(Ordering::Relaxed) {
                break;
            }
        }
        queue.close();
        if reader.join().is_err() && worker.failure.is_none() {
            worker.failure = Some(Event::Error {
                frame: None,
                message: "the frame reader stopped unexpectedly".into(),
            });
        }
        let end = worker.failure.take().unwrap_or(Event::End {
            frames: worker.processed,
            dropped: metrics.frames_dropped.load(Ordering::Relaxed),
        });
        sink(&end, None);
        end
    }
}

/// The reader thread's loop.
fn read_frames(
    source: &mut dyn Source,
    queue: &FrameQueue<Item>,
    metrics: &Metrics,
    stop: &AtomicBool,
    realtime: bool,
    max_frames: Option<u64>,
) {
    let start = Instant::now();
    let mut first_t = None;
    let mut n = 0u64;
    while !stop.load(Ordering::Relaxed) && max_frames.is_none_or(|m| n < m) {
        let read_at = Instant::now();
        let item = match source.next_frame() {
            None => break,
            Some(Err(e)) => Item::Failed(e),
            Some(Ok(frame)) => {
                let read_s = read_at.elapsed().as_secs_f64();
                if realtime {
                    let t = frame.frame.t.unwrap_or(0.0);
                    let due =
                        start + Duration::from_secs_f64((t - *first_t.get_or_insert(t)).max(0.0));
                    if let Some(wait) = due.checked_duration_since(Instant::now()) {
                        std::thread::sleep(wait);
                    }
                }
                metrics.record(Stage::Read, read_s);
                Metrics::count(&metrics.frames_read);
                n += 1;
                Item::Frame {
                    frame,
                    // A paced frame counts from when it is due, not from when it was decoded.
                    read_at: Instant::now() - Duration::from_secs_f64(read_s),
                    read_s,
                }
            }
        };
        let failed = matches!(item, Item::Failed(_));
        match queue.push(item) {
            None => break,
            Some(dropped) => {
                metrics
                    .frames_dropped
                    .fetch_add(dropped as u64, Ordering::Relaxed);
            }
        }
        if failed {
            break;
        }
    }
    queue.close();
}

/// What the worker needs of a frame besides its pixels.
struct FrameMeta {
    index: u64,
    name: String,
    t: f64,
    truth: Option<Pose>,
}

/// The estimation side: the frame's stages, and the counts of the run.
struct Worker<'a> {
    stages: Stages<'static>,
    metrics: &'a Metrics,
    processed: u64,
    failure: Option<Event>,
}

impl<'a> Worker<'a> {
    fn new(
        cfg: &PipelineConfig,
        estimators: Vec<BoxedEstimator>,
        metrics: &'a Metrics,
    ) -> Worker<'a> {
        Worker {
            stages: Stages::new(estimators, Some(cfg.filter), cfg.detect_cuts),
            metrics,
            processed: 0,
            failure: None,
        }
    }

    fn process(
        &mut self,
        frame: &FrameMeta,
        image: &DynamicImage,
        read_at: Instant,
        read_s: f64,
    ) -> Result<Event> {
        let started = Instant::now();
        let queue_s = (started - read_at).as_secs_f64() - read_s;
        let t = frame.t;
        let p = self.stages.process(frame.index, image, t, false)?;
        if p.cut {
            Metrics::count(&self.metrics.cuts);
        }
        for _ in 0..p.rejected {
            Metrics::count(&self.metrics.rejected);
        }
        let done = Instant::now();
        let total_s = (done - read_at).as_secs_f64();
        for (stage, s) in [
            (Stage::Queue, queue_s.max(0.0)),
            (Stage::Estimate, p.estimate_s),
            (Stage::Filter, p.filter_s),
            (Stage::Total, total_s),
        ] {
            self.metrics.record(stage, s);
        }
        self.processed += 1;
        Metrics::count(&self.metrics.poses);
        let Some((fused, update)) = p.fused else {
            return Err(TrackError::Config(format!(
                "frame {}: no estimator saw anything and the filter has no state yet",
                frame.index
            )));
        };
        let ms = |s: f64| s * 1e3;
        Ok(Event::Pose(Box::new(PoseEvent {
            frame: frame.index,
            name: frame.name.clone(),
            t,
            position: fused.pose.position(),
            quaternion: fused.pose.quat_wxyz(),
            sigma_pos_m: fused.sigma_pos_m,
            sigma_rot_deg: fused.sigma_rot_rad.to_degrees(),
            covariance_pos: diag(fused.pos_var),
            update,
            cut: p.cut,
            measurements: p
                .measurements()
                .map(|(name, e)| RawEstimate {
                    estimator: name,
                    position: e.pose.position(),
                    quaternion: e.pose.quat_wxyz(),
                    sigma_pos_m: e.sigma_pos_m(),
                    sigma_rot_deg: e.sigma_rot_rad.to_degrees(),
                    cov_pos_m2: std::array::from_fn(|k| e.cov_pos_m2[(k / 3, k % 3)]),
                })
                .collect(),
            truth: frame.truth.map(|p| Truth {
                position: p.position(),
                quaternion: p.quat_wxyz(),
            }),
            latency_ms: Latency {
                read: ms(read_s),
                queue: ms(queue_s.max(0.0)),
                estimate: ms(p.estimate_s),
                filter: ms(p.filter_s),
                total: ms(total_s),
            },
            dropped: self.metrics.frames_dropped.load(Ordering::Relaxed),
        })))
    }
}

fn diag(v: [f64; 3]) -> [f64; 9] {
    [v[0], 0.0, 0.0, 0.0, v[1], 0.0, 0.0, 0.0, v[2]]
}
