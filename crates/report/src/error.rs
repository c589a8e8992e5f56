//! The one error type of `report`.

use std::path::PathBuf;
use thiserror::Error;

/// What can go wrong while drawing or writing a report.
#[derive(Debug, Error)]
pub enum ReportError {
    /// Reading or writing a file or folder failed.
    #[error("{}: {source}", path.display())]
    Io {
        /// The file or folder involved.
        path: PathBuf,
        /// The underlying I/O error.
        source: std::io::Error,
    },
    /// plotters or the PNG encoder failed while drawing a figure.
    #[error("{}: cannot draw figure: {msg}", path.display())]
    Plot {
        /// The file being drawn (`<memory>` when rendering to a buffer).
        path: PathBuf,
        /// The drawing library's message.
        msg: String,
    },
    /// Input that cannot make a figure or report (no values, mismatched lengths, ...).
    #[error("{0}")]
    BadInput(String),
}

/// `Result` with [`ReportError`].
pub type Result<T, E = ReportError> = std::result::Result<T, E>;
