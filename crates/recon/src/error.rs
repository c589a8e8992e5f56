//! Errors of the scan fusion: each names the dataset, frame or file it is about.

use std::path::PathBuf;

/// What went wrong, and with which file.
#[derive(Debug, thiserror::Error)]
pub enum ReconError {
    /// A dataset, frame or depth image could not be read.
    #[error(transparent)]
    Data(#[from] data::DataError),
    /// The scan cannot be fused: no depth, depth in other units, nothing observed.
    #[error("{}: {msg}", path.display())]
    Scan {
        /// The dataset or frame.
        path: PathBuf,
        /// What is wrong and what to try.
        msg: String,
    },
    /// An output file could not be written.
    #[error("{}: {msg}", path.display())]
    Write {
        /// The file.
        path: PathBuf,
        /// What failed.
        msg: String,
    },
}

impl ReconError {
    /// A scan problem about `path`.
    pub fn scan(path: impl Into<PathBuf>, msg: impl Into<String>) -> Self {
        Self::Scan {
            path: path.into(),
            msg: msg.into(),
        }
    }
}

/// Result of this crate.
pub type Result<T> = std::result::Result<T, ReconError>;
