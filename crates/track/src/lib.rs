//! The live side of indoorloc: frames in, a smooth, gated, cut-aware pose stream with
//! uncertainty out.
//!
//! [`source`] opens what the frames come from (folders, videos, cameras, stdin, datasets),
//! [`estimator`] turns a frame into a pose measurement (the pose network, ArUco markers),
//! [`PoseFilter`] fuses measurements over time, and [`Pipeline`] runs them on two threads
//! joined by a bounded queue that drops stale frames of live sources, measuring every stage
//! ([`Metrics`]). [`calibrate`] fits what the fused covariance means on a model's validation
//! walk.

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
