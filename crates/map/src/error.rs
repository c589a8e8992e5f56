//! Errors of the map crate: each names the file it is about.

use std::path::PathBuf;

/// What went wrong, and with which file.
#[derive(Debug, thiserror::Error)]
pub enum MapError {
    /// An image could not be read or decoded.
    #[error("{path}: {msg}")]
    Image {
        /// The image file.
        path: PathBuf,
        /// What the decoder or the view said.
        msg: String,
    },
    /// A map file that cannot be written or read (missing, not a map, another version,
    /// truncated, corrupt).
    #[error("{path}: {msg}")]
    File {
        /// The map file.
        path: PathBuf,
        /// What is wrong with it.
        msg: String,
    },
    /// Input that cannot be used (an empty map, images of different sizes).
    #[error("{0}")]
    Input(String),
}

/// Result of this crate.
pub type Result<T> = std::result::Result<T, MapError>;
