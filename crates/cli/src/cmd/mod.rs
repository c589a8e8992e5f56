//! One module per subcommand: a clap `Args` struct and a `run` function.

pub mod bench;
pub mod calibrate;
pub mod demo;
pub mod eval;
pub mod explain;
pub mod localize;
pub mod map;
pub mod markers;
pub mod parse;
pub mod preprocess;
pub mod scenecut;
pub mod serve;
pub mod study;
pub mod synth;
pub mod train;
pub mod weights;
