//! The one error type of `learn`. Every variant that concerns a file names it, so the command
//! line can print one line that tells the user what to fix.

use std::path::PathBuf;

use thiserror::Error;

/// What can go wrong training or using a pose network.
#[derive(Debug, Error)]
pub enum LearnError {
    /// Reading the dataset failed (the message names the file).
    #[error(transparent)]
    Data(#[from] data::DataError),
    /// An image could not be read, decoded or turned into the network's view.
    #[error("{path}: {msg}")]
    Image {
        /// The image file.
        path: PathBuf,
        /// What went wrong.
        msg: String,
    },
    /// A file or folder could not be read or written.
    #[error("{path}: {source}")]
    Io {
        /// The file or folder.
        path: PathBuf,
        /// The underlying error.
        source: std::io::Error,
    },
    /// A checkpoint file is unreadable or inconsistent with the rest of the checkpoint.
    #[error("{path}: corrupt checkpoint: {msg}")]
    Corrupt {
        /// The offending file.
        path: PathBuf,
        /// What is wrong with it.
        msg: String,
    },
    /// A checkpoint that does not fit what it is used for (another dataset, architecture, ...).
    #[error("{path}: checkpoint does not match: {msg}")]
    Mismatch {
        /// The checkpoint's `model.toml`.
        path: PathBuf,
        /// What differs.
        msg: String,
    },
    /// A training or network configuration outside its valid range.
    #[error("invalid configuration: {0}")]
    Config(String),
    /// Input that the model cannot take (wrong view size, no images, ...).
    #[error("invalid input: {0}")]
    Input(String),
    /// The compute device asked for is not built in or does not answer.
    #[error("device {0}")]
    Device(String),
    /// Training produced a non-finite loss.
    #[error("training diverged: {0}")]
    Diverged(String),
}

impl LearnError {
    /// An [`LearnError::Io`] naming `path`.
    pub fn io(path: impl Into<PathBuf>, source: std::io::Error) -> Self {
        LearnError::Io {
            path: path.into(),
            source,
        }
    }

    /// A [`LearnError::Corrupt`] naming `path`.
    pub fn corrupt(path: impl Into<PathBuf>, msg: impl Into<String>) -> Self {
        LearnError::Corrupt {
            path: path.into(),
            msg: msg.into(),
        }
    }
}

/// `Result` with [`LearnError`].
pub type Result<T, E = LearnError> = std::result::Result<T, E>;
