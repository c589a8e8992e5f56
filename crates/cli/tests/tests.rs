//! Integration tests of the `indoorloc` binary, one module per theme.

mod bad_input_cli;
mod demo_cli;
mod eval_cli;
mod learn_cli;
mod markers_cli;
mod metrics_reference;
mod preprocess_cli;
mod real_data_cli;
mod scenecut_cli;
mod serve_cli;
mod study_cli;
mod synth_cli;
mod util;
