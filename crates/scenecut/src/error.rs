//! Errors of scene-cut detection: a bad configuration, or a frame source that fails.

use std::path::PathBuf;

/// What can go wrong while detecting cuts.
#[derive(Debug, thiserror::Error)]
pub enum CutError {
    /// A setting out of range (the message says which and why).
    #[error("scene-cut settings: {0}")]
    Config(String),
    /// A frame that does not fit the detector (size changed mid-stream, short buffer).
    #[error("frame {frame}: {msg}")]
    Frame {
        /// Index of the frame.
        frame: u64,
        /// What is wrong with it.
        msg: String,
    },
    /// The frame source failed (the message names the file).
    #[error(transparent)]
    Data(#[from] data::DataError),
    /// A gold file that cannot be read.
    #[error("{}: {msg}", path.display())]
    Gold {
        /// The file.
        path: PathBuf,
        /// What is wrong with it.
        msg: String,
    },
    /// Resizing a frame to the detector's thumbnail failed.
    #[error("resizing a frame: {0}")]
    Resize(#[from] imgproc::ImgprocError),
}

/// Result with [`CutError`].
pub type Result<T> = std::result::Result<T, CutError>;
