//! Where the pipeline's thread and the server's handlers meet: the latest pose and frame, the
//! source's state, the broadcast buffer every WebSocket client reads from, and the counters.

use crate::map::FloorMap;
use axum::extract::ws::Utf8Bytes;
use image::RgbImage;
use serde::Serialize;
use std::sync::atomic::{AtomicU64, Ordering};
use std::sync::{Arc, Mutex, RwLock};
use std::time::Instant;
use tokio::sync::broadcast;
use track::{Event, Metrics, PoseEvent};

/// Messages the broadcast buffer holds: a client more than this far behind is dropped. At
/// 30 poses per second, two seconds.
pub const BROADCAST_CAPACITY: usize = 64;

/// Frames wider than this are shrunk before they are kept for `/frame.jpg`: the dashboard
/// shows a thumbnail, and a full camera frame per pose would be copying for nothing.
const FRAME_MAX_WIDTH: u32 = 320;

/// What the frame source is doing.
#[derive(Clone, Debug, PartialEq, Serialize)]
#[serde(rename_all = "snake_case")]
pub enum SourceState {
    /// No frame yet.
    Starting,
    /// Frames are coming.
    Running,
    /// The source ended normally.
    Ended,
    /// The source or an estimator failed.
    Failed,
}

/// One message for the WebSocket clients.
#[derive(Clone, Debug)]
pub(crate) struct Broadcast {
    /// The event as JSON.
    pub text: Utf8Bytes,
    /// Whether the stream ends with it (`end`, `error`).
    pub terminal: bool,
}

/// The latest pose, in both forms `/pose` serves.
#[derive(Clone, Debug)]
pub(crate) struct Latest {
    pub json: Utf8Bytes,
    pub tum: String,
}

/// A listener for every fused pose (the ROS 2 publisher). It runs on the pipeline's thread, so
/// it must hand the pose on and return at once.
type PoseTap = Box<dyn Fn(&PoseEvent) + Send + Sync>;

/// Shared state of a running server.
pub struct Hub {
    metrics: Arc<Metrics>,
    map: FloorMap,
    latest: RwLock<Option<Latest>>,
    frame: Mutex<Option<Arc<RgbImage>>>,
    state: RwLock<(SourceState, Option<String>)>,
    last_terminal: RwLock<Option<Broadcast>>,
    tx: broadcast::Sender<Broadcast>,
    taps: RwLock<Vec<PoseTap>>,
    /// WebSocket clients connected now.
    pub clients: AtomicU64,
    /// WebSocket clients ever connected.
    pub clients_total: AtomicU64,
    /// Clients dropped for falling behind or not answering.
    pub clients_dropped: AtomicU64,
    started: Instant,
}

impl Hub {
    /// A hub for a pipeline whose figures are `metrics`, drawn on `map`.
    pub fn new(metrics: Arc<Metrics>, map: FloorMap) -> Arc<Hub> {
        let (tx, _) = broadcast::channel(BROADCAST_CAPACITY);
        Arc::new(Hub {
            metrics,
            map,
            latest: RwLock::new(None),
            frame: Mutex::new(None),
            state: RwLock::new((SourceState::Starting, None)),
            last_terminal: RwLock::new(None),
            tx,
            taps: RwLock::new(Vec::new()),
            clients: AtomicU64::new(0),
            clients_total: AtomicU64::new(0),
            clients_dropped: AtomicU64::new(0),
            started: Instant::now(),
        })
    }

    /// Takes one pipeline event (the pipeline's sink calls this from its thread).
    pub fn publish(&self, event: &Event, frame: Option<&RgbImage>) {
        let text: Utf8Bytes = match serde_json::to_string(event) {
            Ok(t) => t.into(),
            // Poses are numbers and names; a failure would be a NaN-free bug, not input.
            Err(e) => format!("{{\"event\":\"error\",\"message\":\"cannot encode: {e}\"}}").into(),
        };
        let terminal = !matches!(event, Event::Pose(_));
        match event {
            Event::Pose(p) => {
                let [x, y, z] = p.position;
                let [w, qx, qy, qz] = p.quaternion;
                *write(&self.latest) = Some(Latest {
                    json: text.clone(),
                    tum: format!(
                        "{:.6} {x:.6} {y:.6} {z:.6} {qx:.6} {qy:.6} {qz:.6} {w:.6}\n",
                        p.t
                    ),
                });
                for tap in read(&self.taps).iter() {
                    tap(p);
                }
                if let Some(f) = frame {
                    *lock(&self.frame) = Some(Arc::new(thumbnail(f)));
                }
                let mut s = write(&self.state);
                if s.0 != SourceState::Running {
                    *s = (SourceState::Running, None);
                    *write(&self.last_terminal) = None;
                }
            }
            Event::End { .. } => *write(&self.state) = (SourceState::Ended, None),
            Event::Error { message, .. } => {
                *write(&self.state) = (SourceState::Failed, Some(message.clone()))
            }
        }
        let msg = Broadcast { text, terminal };
        if terminal {
            *write(&self.last_terminal) = Some(msg.clone());
        }
        // No receivers is fine: nobody is watching.
        let _ = self.tx.send(msg);
    }

    /// Calls `f` with every fused pose from now on, on the pipeline's thread.
    pub fn tap(&self, f: impl Fn(&PoseEvent) + Send + Sync + 'static) {
        write(&self.taps).push(Box::new(f));
    }

    /// The counters and latencies of the pipeline.
    pub fn metrics(&self) -> &Metrics {
        &self.metrics
    }

    /// The floor map.
    pub fn map(&self) -> &FloorMap {
        &self.map
    }

    /// The source's state and, after a failure, its message.
    pub fn source_state(&self) -> (SourceState, Option<String>) {
        read(&self.state).clone()
    }

    /// Seconds since the hub was made.
    pub fn uptime_s(&self) -> f64 {
        self.started.elapsed().as_secs_f64()
    }

    /// Connected WebSocket clients.
    pub fn client_count(&self) -> u64 {
        self.clients.load(Ordering::Relaxed)
    }

    pub(crate) fn latest(&self) -> Option<Latest> {
        read(&self.latest).clone()
    }

    pub(crate) fn frame(&self) -> Option<Arc<RgbImage>> {
        lock(&self.frame).clone()
    }

    /// A new client's feed, and the stream's last event when it has already ended.
    pub(crate) fn subscribe(&self) -> (broadcast::Receiver<Broadcast>, Option<Broadcast>) {
        // Subscribe first, so nothing published between the two reads is missed.
        let rx = self.tx.subscribe();
        (rx, read(&self.last_terminal).clone())
    }
}

fn thumbnail(f: &RgbImage) -> RgbImage {
    if f.width() <= FRAME_MAX_WIDTH {
        return f.clone();
    }
    let h = (f.height() * FRAME_MAX_WIDTH / f.width()).max(1);
    image::imageops::thumbnail(f, FRAME_MAX_WIDTH, h)
}

// A handler that panicked must not take the server down with poisoned locks: the data behind
// them is always whole (plain assignments).
fn read<T>(l: &RwLock<T>) -> std::sync::RwLockReadGuard<'_, T> {
    l.read().unwrap_or_else(|p| p.into_inner())
}

fn write<T>(l: &RwLock<T>) -> std::sync::RwLockWriteGuard<'_, T> {
    l.write().unwrap_or_else(|p| p.into_inner())
}

fn lock<T>(l: &Mutex<T>) -> std::sync::MutexGuard<'_, T> {
    l.lock().unwrap_or_else(|p| p.into_inner())
}
