//! Dataset formats of indoorloc: readers and writers that convert to and from the conventions of
//! DESIGN.md at the border, splits by sequence, and frame sources.
//!
//! # Conventions
//! Every reader returns a [`Trajectory`] of camera-to-world poses in OpenCV camera axes
//! (x right, y down, z forward), metres where the format has metres, quaternions `w, x, y, z`.
//! Every writer converts back to the format's own convention. Errors name the file and, for text
//! formats, the line.
#![deny(missing_docs)]

pub mod cambridge;
pub mod colmap;
mod csv_table;
pub mod cuts;
mod error;
pub mod formats;
pub mod frames;
pub mod io;
pub mod jsonl;
pub mod matching;
pub mod native;
pub mod nerf;
pub mod robotlog;
pub mod sevenscenes;
mod trajectory;
pub mod tum;

pub use error::{DataError, Result};
pub use trajectory::{PoseFrame, Trajectory};
