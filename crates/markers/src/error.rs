//! The crate's error type.

use std::path::PathBuf;

/// Everything that can go wrong in `markers`; every variant that concerns a file names it.
#[derive(Debug, thiserror::Error)]
pub enum MarkersError {
    /// A file could not be read.
    #[error("{path}: {source}")]
    Io {
        /// The file.
        path: PathBuf,
        /// What the operating system said.
        source: std::io::Error,
    },
    /// A file is not an image the decoder can read (the error names it).
    #[error(transparent)]
    Image(#[from] data::DataError),
    /// A dictionary file is malformed.
    #[error("{path}: {message}")]
    Dictionary {
        /// The file.
        path: PathBuf,
        /// What is wrong, with the line number where there is one.
        message: String,
    },
    /// A dictionary name that is not one of OpenCV's predefined ones.
    #[error("unknown ArUco dictionary '{name}'; choose one of {known}")]
    UnknownDictionary {
        /// The name given.
        name: String,
        /// The accepted names, comma-separated.
        known: String,
    },
    /// A dictionary built in code has inconsistent fields.
    #[error("invalid dictionary '{name}': {message}")]
    InvalidDictionary {
        /// The dictionary's name.
        name: String,
        /// What is wrong.
        message: String,
    },
    /// A marker map is malformed or cannot be written.
    #[error("{path}: {problem}")]
    Map {
        /// The map file.
        path: PathBuf,
        /// What is wrong.
        problem: String,
    },
    /// An output file could not be written.
    #[error("{path}: cannot write: {source}")]
    Write {
        /// The file.
        path: PathBuf,
        /// What the operating system said.
        source: std::io::Error,
    },
}
