//! The keyframe map of a building: what indoorloc keeps of posed frames to find a new frame
//! among them. Today: a global descriptor per frame and nearest-neighbour retrieval
//! ([`retrieval`]), a localizer of its own (the pose of the most similar mapped frame) and the
//! candidates later stages refine.
#![deny(missing_docs)]

mod error;
pub mod pnp;
pub mod retrieval;

pub use error::{MapError, Result};
