//! The live side of indoorloc: per-frame pose estimates in, a smooth, gated, cut-aware pose
//! stream out.
//!
//! So far: [`PoseFilter`], the temporal filter every live pipeline ends in. The frame source,
//! the estimators and the server come on top of it.

mod filter;

pub use filter::{FilterConfig, Fused, Measurement, PoseFilter, Update};
