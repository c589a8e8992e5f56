//! Visual-rhythm scene-cut detection.
//!
//! Localizers that carry state from frame to frame (a CNN+LSTM, a tracking filter) produce wrong
//! poses for many frames after the camera is suddenly somewhere else: an edited video, a stream
//! that dropped, a jump within one camera's view. This crate finds those moments cheaply and
//! streaming, so that the temporal state can be reset.
//!
//! Each frame is shrunk to a small thumbnail, a fixed pixel path is sampled from it (a column of
//! the visual rhythm), consecutive columns are differenced into a time series, and a cut is a
//! frame whose difference stands out from a low-passed baseline of its neighbours
//! ([`Detector`], whose doc comment gives the rule). Fades and dissolves are flagged separately
//! as [`Gradual`] transitions.
//!
//! # Entry points
//! - [`detect_input`]: a video file, image folder or native dataset, start to end.
//! - [`Detector`]: the streaming detector for live sources (push thumbnails, get events).
//! - [`detect_thumbnails`]: the detector over thumbnails already in memory.
//! - [`Gold`], [`score_hard`]: precision, recall and F1 against gold cuts.
//! - [`RhythmImage`]: the visual-rhythm picture for plots.

mod detector;
mod error;
mod motion;
mod path;
mod rhythm;
mod score;
mod source;

pub use detector::{Config, Cut, Detector, Event, Gradual, GradualConfig, Trace, TransitionKind};
pub use error::{CutError, Result};
pub use path::{PathKind, pixel_indices};
pub use rhythm::{MAX_COLUMNS, RhythmImage};
pub use score::{Gold, Score, score_hard};
pub use source::{
    Collect, Decoding, Detection, detect_input, detect_input_decoded, detect_thumbnails,
    frames_path,
};
