//! Errors of the features crate.

/// What went wrong.
#[derive(Debug, thiserror::Error)]
pub enum FeatureError {
    /// Settings that cannot work.
    #[error("feature settings: {0}")]
    Config(String),
    /// The image could not be resampled.
    #[error("image pyramid: {0}")]
    Pyramid(String),
}

/// Result of this crate.
pub type Result<T> = std::result::Result<T, FeatureError>;
