//! The one error type of `synth`.

use std::path::PathBuf;
use thiserror::Error;

/// What can go wrong building, importing, rendering or exporting a synthetic world.
#[derive(Debug, Error)]
pub enum SynthError {
    /// A model file could not be read or is not supported.
    #[error("{}: {msg}", path.display())]
    Model {
        /// The file.
        path: PathBuf,
        /// What is wrong, in words.
        msg: String,
    },
    /// A file could not be read or written.
    #[error("{}: {source}", path.display())]
    Io {
        /// The file.
        path: PathBuf,
        /// The operating system's error.
        source: std::io::Error,
    },
    /// A setting that cannot work (a zero-size image, no walkable space, ...).
    #[error("{0}")]
    Config(String),
    /// Writing the dataset failed.
    #[error(transparent)]
    Data(#[from] data::DataError),
    /// A camera or pose was invalid.
    #[error(transparent)]
    Geom(#[from] geom::GeomError),
}

/// `Result` with [`SynthError`].
pub type Result<T, E = SynthError> = std::result::Result<T, E>;
