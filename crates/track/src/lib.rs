//! Frames in, poses out: the live pipeline and its file counterpart.
//!
//! [`source`] opens what live frames come from (folders, videos, cameras, stdin, datasets),
//! [`estimator`] turns a frame into a pose measurement (the pose network, a sequence model,
//! retrieval, ArUco markers, a keyframe map), [`PoseFilter`] fuses measurements over time, and
//! [`Stages`] is what one frame goes through (cut detector, estimators, filter). [`Pipeline`]
//! runs the stages live, on two threads joined by a bounded queue that drops stale frames of
//! live sources, measuring every stage ([`Metrics`]); [`Recorded`] runs them over a recording
//! ([`frames`]: any image, folder, video or posed dataset), frame after frame, with the place
//! model along the walk. [`calibrate`] fits what the fused covariance means on a model's
//! validation walk.

pub mod calibrate;
mod error;
pub mod estimator;
mod filter;
mod pipeline;
mod queue;
mod recorded;
pub mod source;
mod stages;
mod stats;

pub use error::{Result, TrackError};
pub use estimator::{
    BoxedEstimator, Estimation, Estimator, MapEstimator, MarkerEstimator, NetworkEstimator,
    RefinementNote, RetrievalEstimator, SequenceEstimator, Stated,
};
pub use filter::{FilterConfig, Fused, Measurement, PoseFilter, Update};
pub use pipeline::{Event, Latency, Pipeline, PipelineConfig, PoseEvent, RawEstimate, Truth};
pub use queue::{FrameQueue, Overflow};
pub use recorded::{Recorded, RecordedFrame, RecordedOutput, RunSummary, Split, frames};
pub use source::{Source, SourceFrame};
pub use stages::{Processed, Stages};
pub use stats::{BUCKETS_S, Metrics, MetricsSnapshot, Stage, StageSnapshot};
