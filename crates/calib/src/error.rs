//! The crate's error type.

use std::path::PathBuf;

/// Everything that can go wrong while calibrating or reading / writing calibration files.
#[derive(Debug, thiserror::Error)]
pub enum CalibError {
    /// Fewer usable views than calibration needs.
    #[error("calibration needs at least {needed} usable views of the board, got {got}")]
    TooFewViews {
        /// Views required.
        needed: usize,
        /// Views available (after rejection).
        got: usize,
    },
    /// A view does not have one image point per board corner.
    #[error("view {view} has {got} points but the {cols}x{rows} board has {expected} corners")]
    PointCount {
        /// Index of the view.
        view: usize,
        /// Points in the view.
        got: usize,
        /// Inner corners along a row.
        cols: usize,
        /// Inner corner rows.
        rows: usize,
        /// `cols * rows`.
        expected: usize,
    },
    /// The input cannot define a calibration (bad board, image size, non-finite points,
    /// collinear corners, a solve that broke down).
    #[error("degenerate calibration input: {reason}")]
    Degenerate {
        /// What was wrong.
        reason: String,
    },
    /// Reading or writing a file failed.
    #[error("{path}: {source}")]
    Io {
        /// The file.
        path: PathBuf,
        /// The underlying error.
        source: std::io::Error,
    },
    /// A calibration file lacks a key this reader needs.
    #[error("{path}: missing key `{key}`")]
    MissingKey {
        /// The file.
        path: PathBuf,
        /// The key.
        key: String,
    },
    /// A calibration file could not be parsed.
    #[error("{path}: {reason}")]
    Parse {
        /// The file.
        path: PathBuf,
        /// What was wrong.
        reason: String,
    },
    /// The camera that was read or computed is invalid.
    #[error(transparent)]
    Geom(#[from] geom::GeomError),
}

/// Result with [`CalibError`].
pub type Result<T, E = CalibError> = std::result::Result<T, E>;
