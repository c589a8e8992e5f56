//! The keyframe map of a building and what refines a pose against it (hierarchical
//! localization, as hloc does it, on a CPU):
//! - [`retrieval`]: a global descriptor per frame and nearest-neighbour search, a localizer of
//!   its own (the pose of the most similar mapped frame) and the candidates refinement starts
//!   from;
//! - [`keyframes`]: keyframes every few centimetres of a posed dataset, their local features
//!   ([`features`]) lifted to 3-D with the frame's depth ([`depth`]) or, for photos without
//!   depth, triangulated between keyframes ([`triangulate`]);
//! - [`lines`]: a camera's roll from the building's straight lines (the vanishing points of its
//!   three directions), which pose networks hardly see;
//! - [`file`](mod@file): the map on disk (versioned, checksummed, written atomically);
//! - [`pnp`]: P3P + RANSAC + Levenberg-Marquardt with a covariance;
//! - [`refine`]: a query image's pose from the map, starting from a coarse pose or retrieval,
//!   falling back to the coarse pose when the geometry does not hold.
#![deny(missing_docs)]

pub mod depth;
mod error;
pub mod file;
pub mod keyframes;
pub mod lines;
pub mod pnp;
pub mod refine;
pub mod retrieval;
pub mod triangulate;

pub use error::{MapError, Result};
pub use keyframes::{BuildConfig, KeyframeMap, Lifting};
pub use refine::{Coarse, Fallback, RefineConfig, Refinement};
