//! The one error type of `geom`.

use thiserror::Error;

/// What can be wrong with numbers handed to `geom`.
#[derive(Debug, Error, Clone, PartialEq)]
pub enum GeomError {
    /// A value that must be finite is NaN or infinite.
    #[error("non-finite value in {what}")]
    NonFinite {
        /// Which quantity held the value.
        what: &'static str,
    },
    /// A quaternion whose norm is too far from 1 to be a rotation written with rounding.
    #[error("quaternion norm {norm:.6} is not 1 (tolerance {tol})")]
    NonUnitQuaternion {
        /// Its Euclidean norm.
        norm: f64,
        /// The tolerance on |norm - 1|.
        tol: f64,
    },
    /// A 3x3 block that is not a rotation (not orthonormal, or a reflection).
    #[error("not a rotation matrix: {reason}")]
    NotRotation {
        /// Orthonormality error or determinant, in words.
        reason: String,
    },
    /// A 4x4 pose matrix whose last row is not `0 0 0 1`.
    #[error("last row of a 4x4 pose must be 0 0 0 1, got {row:?}")]
    BadLastRow {
        /// The row found.
        row: [f64; 4],
    },
    /// Camera intrinsics that cannot describe a camera.
    #[error("invalid camera: {reason}")]
    BadCamera {
        /// What is wrong, in words.
        reason: String,
    },
    /// A statistic asked of no values, or of sequences of different lengths.
    #[error("{0}")]
    BadInput(String),
}

/// `Result` with [`GeomError`].
pub type Result<T, E = GeomError> = std::result::Result<T, E>;
