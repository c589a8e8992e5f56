//! Dataset formats of indoorloc.
#![deny(missing_docs)]

mod error;
mod trajectory;

pub use error::{DataError, Result};
pub use trajectory::{PoseFrame, Trajectory};
