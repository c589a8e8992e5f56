//! The one error type of `data`: every variant names the file, and the line where there is one,
//! so a user can fix the input from the message alone.

use std::path::PathBuf;
use thiserror::Error;

/// What can go wrong reading or writing a dataset.
#[derive(Debug, Error)]
pub enum DataError {
    /// The file or folder could not be read or written.
    #[error("{}: {source}", path.display())]
    Io {
        /// The file.
        path: PathBuf,
        /// The operating system's error.
        source: std::io::Error,
    },
    /// A line of a text file is malformed.
    #[error("{}:{line}: {msg}", path.display())]
    Parse {
        /// The file.
        path: PathBuf,
        /// 1-based line number.
        line: usize,
        /// What is wrong with the line.
        msg: String,
    },
    /// The file is readable but its content is not what the format needs.
    #[error("{}: {msg}", path.display())]
    Invalid {
        /// The file or folder.
        path: PathBuf,
        /// What is wrong.
        msg: String,
    },
    /// A frame source (image folder, video) failed.
    #[error("{}: {msg}", path.display())]
    Frames {
        /// The source.
        path: PathBuf,
        /// What is wrong.
        msg: String,
    },
}

impl DataError {
    /// An I/O error on `path`.
    pub fn io(path: impl Into<PathBuf>, source: std::io::Error) -> Self {
        Self::Io {
            path: path.into(),
            source,
        }
    }

    /// A frame source at `path` that cannot be read as frames.
    pub fn frames(path: impl Into<PathBuf>, msg: impl Into<String>) -> Self {
        Self::Frames {
            path: path.into(),
            msg: msg.into(),
        }
    }

    /// A malformed line `line` (1-based) of `path`.
    pub fn parse(path: impl Into<PathBuf>, line: usize, msg: impl Into<String>) -> Self {
        Self::Parse {
            path: path.into(),
            line,
            msg: msg.into(),
        }
    }

    /// Content of `path` that does not fit its format.
    pub fn invalid(path: impl Into<PathBuf>, msg: impl Into<String>) -> Self {
        Self::Invalid {
            path: path.into(),
            msg: msg.into(),
        }
    }
}

/// `Result` with [`DataError`].
pub type Result<T, E = DataError> = std::result::Result<T, E>;
