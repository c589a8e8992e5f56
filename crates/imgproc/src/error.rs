//! The one error type of `imgproc`.

use thiserror::Error;

/// What can go wrong preparing an image.
#[derive(Debug, Error)]
pub enum ImgprocError {
    /// Source and destination sizes do not fit the operation.
    #[error("size mismatch: {0}")]
    Size(String),
    /// A parameter outside its valid range (clip limit ≤ 0, zero-size output, ...).
    #[error("invalid parameter: {0}")]
    Param(String),
    /// A view spec that cannot be parsed.
    #[error("invalid view spec '{spec}': {msg}")]
    Spec {
        /// The spec text.
        spec: String,
        /// What is wrong.
        msg: String,
    },
}

/// `Result` with [`ImgprocError`].
pub type Result<T, E = ImgprocError> = std::result::Result<T, E>;
