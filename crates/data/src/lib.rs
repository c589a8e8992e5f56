//! Dataset formats of indoorloc: readers and writers that convert to and from the conventions of
//! DESIGN.md at the border, splits by sequence, and frame sources.
//!
//! # Conventions
//! Every reader returns a [`Trajectory`] of camera-to-world poses in OpenCV camera axes
//! (x right, y down, z forward), metres where the format has metres, quaternions `w, x, y, z`.
//! Every writer converts back to the format's own convention. Errors name the file and, for text
//! formats, the line.
//!
//! # Entry points
//! - [`posed::open`]: any posed image collection (images, poses, depth) for training and
//!   localizing, with splits per frame ([`blocks::BlockSplit`] for single recordings).
//! - [`formats::read`] / [`formats::detect`]: any supported format, told from its content.
//! - One module per format with `read` and `write`: [`native`], [`sevenscenes`], [`cambridge`],
//!   [`tum`], [`colmap`], [`nerf`], [`robotlog`], [`jsonl`].
//! - [`matching::match_frames`]: pairs estimates with ground truth by name or time.
//! - [`frames::open`]: image folders and video files as streams of frames.
//!
//! ```
//! use data::formats::{self, Format};
//! let dir = tempfile::tempdir()?;
//! let path = dir.path().join("groundtruth.txt");
//! // TUM: timestamp tx ty tz qx qy qz qw, camera-to-world.
//! std::fs::write(&path, "# tum\n0.5 1 2 3 0 0 0 1\n")?;
//! assert_eq!(formats::detect(&path)?, Format::Tum);
//! let traj = formats::read(&path, None)?;
//! assert_eq!(traj.frames[0].pose.position(), [1.0, 2.0, 3.0]);
//! assert_eq!(traj.frames[0].t, Some(0.5));
//! # Ok::<(), Box<dyn std::error::Error>>(())
//! ```
#![deny(missing_docs)]

pub mod blocks;
pub mod cambridge;
pub mod colmap;
pub mod concat;
mod csv_table;
pub mod cuts;
pub mod depth;
mod error;
pub mod formats;
pub mod frames;
pub mod io;
pub mod jsonl;
pub mod matching;
pub mod native;
pub mod nerf;
pub mod posed;
pub mod robotlog;
pub mod sevenscenes;
#[cfg(test)]
mod test_util;
mod trajectory;
pub mod tum;

pub use error::{DataError, Result};
pub use trajectory::{PoseFrame, Trajectory};
