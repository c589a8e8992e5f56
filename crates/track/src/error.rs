//! Errors of the live pipeline; every message names the source, model or map it is about.

use std::path::PathBuf;

/// Result type of `track`.
pub type Result<T, E = TrackError> = std::result::Result<T, E>;

/// What can go wrong between a frame source and a pose stream.
#[derive(Debug, thiserror::Error)]
pub enum TrackError {
    /// Reading frames or a dataset.
    #[error(transparent)]
    Data(#[from] data::DataError),
    /// Loading or running the pose network.
    #[error(transparent)]
    Learn(#[from] learn::LearnError),
    /// Reading a marker map or dictionary.
    #[error(transparent)]
    Markers(#[from] markers::MarkersError),
    /// A keyframe map could not be read or used.
    #[error(transparent)]
    Map(#[from] map::MapError),
    /// A keyframe map failed on a frame (a query from another camera, ...): the map named.
    // The cause is in the message (and not a `source`), so that the live pipeline's one-line
    // error events carry it too.
    #[error("{}: {error}", path.display())]
    MapFile {
        /// The map file.
        path: PathBuf,
        /// What went wrong.
        error: map::MapError,
    },
    /// The scene-cut detector.
    #[error(transparent)]
    Cut(#[from] scenecut::CutError),
    /// A frame source that cannot be opened or read.
    #[error("{source_name}: {msg}")]
    Source {
        /// The source as the user named it.
        source_name: String,
        /// What is wrong.
        msg: String,
    },
    /// An I/O error on a named file.
    #[error("{}: {source}", path.display())]
    Io {
        /// The file.
        path: PathBuf,
        /// The error.
        source: std::io::Error,
    },
    /// A stage failed on a frame.
    #[error("frame {name}")]
    Frame {
        /// The frame's name.
        name: String,
        /// What failed.
        #[source]
        source: Box<TrackError>,
    },
    /// Settings that do not fit together.
    #[error("{0}")]
    Config(String),
}

impl TrackError {
    /// A source error.
    pub fn source(name: impl Into<String>, msg: impl Into<String>) -> TrackError {
        TrackError::Source {
            source_name: name.into(),
            msg: msg.into(),
        }
    }
}
