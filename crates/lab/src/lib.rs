//! The pipelines of indoorloc as a library: every command of the `indoorloc` binary (render,
//! train, localize, evaluate, markers, calibration, maps, serving), the `demo`, every `study` and
//! every `bench`, each a function over a typed config.
//!
//! A config is a plain struct (it also derives clap's `Args`, so the binary parses its command
//! line straight into it); results go to an [`Output`] (one JSON document or text for people);
//! long work shows progress through the [`progress::Reporter`] the program installs, if any.
//! Errors are [`LabError`]s carrying which file or step failed.

pub mod bench;
pub mod calibrate;
pub mod demo;
pub mod device;
pub mod error;
pub mod eval;
pub mod explain;
pub mod localize;
pub mod map;
pub mod markers;
pub mod mesh;
pub mod output;
pub mod parse;
pub mod preprocess;
pub mod progress;
pub mod scenecut;
pub mod serve;
pub mod study;
pub mod synth;
pub mod train;
pub mod weights;

pub use error::{Context, LabError, Result};
pub(crate) use error::{bail, ensure, err};
pub use output::{Collected, Output};
