//! The one error type of the pipelines: every library crate's error, I/O and file formats, or a
//! message, each optionally wrapped in the context that says which file or step failed.
//!
//! The binary prints it as one line (`context: cause: cause`) and exits with code 2; `anyhow`
//! stays in the binary, so the library speaks in a type callers can match on.

use std::fmt::Display;

/// Result of a pipeline.
pub type Result<T, E = LabError> = std::result::Result<T, E>;

/// Why a pipeline failed.
#[derive(Debug, thiserror::Error)]
pub enum LabError {
    /// A problem the pipeline found itself (bad option, empty input, ...).
    #[error("{0}")]
    Message(String),
    /// `context` (which file, which step) around the error that caused it.
    #[error("{context}")]
    Context {
        /// What was being done.
        context: String,
        /// Why it failed.
        #[source]
        source: Box<LabError>,
    },
    /// Reading or writing a file or a stream.
    #[error(transparent)]
    Io(#[from] std::io::Error),
    /// A number in an option or a file.
    #[error(transparent)]
    ParseInt(#[from] std::num::ParseIntError),
    /// A thread pool of the asked size.
    #[error(transparent)]
    ThreadPool(#[from] rayon::ThreadPoolBuildError),
    /// A JSON document.
    #[error(transparent)]
    Json(#[from] serde_json::Error),
    /// A TOML document.
    #[error(transparent)]
    TomlRead(#[from] toml::de::Error),
    /// Writing TOML.
    #[error(transparent)]
    TomlWrite(#[from] toml::ser::Error),
    /// Decoding or encoding an image.
    #[error(transparent)]
    Image(#[from] image::ImageError),
    /// Pose math.
    #[error(transparent)]
    Geom(#[from] geom::GeomError),
    /// Datasets and trajectories.
    #[error(transparent)]
    Data(#[from] data::DataError),
    /// Image preparation.
    #[error(transparent)]
    Imgproc(#[from] imgproc::ImgprocError),
    /// Synthetic buildings and rendering.
    #[error(transparent)]
    Synth(#[from] synth::SynthError),
    /// Networks.
    #[error(transparent)]
    Learn(#[from] learn::LearnError),
    /// Keyframe maps and refinement.
    #[error(transparent)]
    Map(#[from] map::MapError),
    /// The scan fusion failed.
    #[error(transparent)]
    Recon(#[from] recon::ReconError),
    /// Markers.
    #[error(transparent)]
    Markers(#[from] markers::MarkersError),
    /// Camera calibration.
    #[error(transparent)]
    Calib(#[from] calib::CalibError),
    /// Scene cuts.
    #[error(transparent)]
    Scenecut(#[from] scenecut::CutError),
    /// Tables, plots and reports.
    #[error(transparent)]
    Report(#[from] report::ReportError),
    /// The live pipeline.
    #[error(transparent)]
    Track(#[from] track::TrackError),
}

impl LabError {
    /// An error carrying only `message`.
    pub fn msg(message: impl Display) -> LabError {
        LabError::Message(message.to_string())
    }

    /// Whether the root cause is a closed pipe (`indoorloc eval ... | head` is not a failure).
    pub fn is_broken_pipe(&self) -> bool {
        match self {
            LabError::Io(e) => e.kind() == std::io::ErrorKind::BrokenPipe,
            LabError::Context { source, .. } => source.is_broken_pipe(),
            _ => false,
        }
    }
}

/// Adds what was being done to an error, as `anyhow::Context` does.
pub trait Context<T> {
    /// Wraps the error in `context`.
    fn context<C: Display>(self, context: C) -> Result<T>;
    /// Wraps the error in the context `f` makes (only on failure).
    fn with_context<C: Display, F: FnOnce() -> C>(self, f: F) -> Result<T>;
}

impl<T, E: Into<LabError>> Context<T> for std::result::Result<T, E> {
    fn context<C: Display>(self, context: C) -> Result<T> {
        self.map_err(|e| LabError::Context {
            context: context.to_string(),
            source: Box::new(e.into()),
        })
    }

    fn with_context<C: Display, F: FnOnce() -> C>(self, f: F) -> Result<T> {
        self.map_err(|e| LabError::Context {
            context: f().to_string(),
            source: Box::new(e.into()),
        })
    }
}

impl<T> Context<T> for Option<T> {
    fn context<C: Display>(self, context: C) -> Result<T> {
        self.ok_or_else(|| LabError::msg(context))
    }

    fn with_context<C: Display, F: FnOnce() -> C>(self, f: F) -> Result<T> {
        self.ok_or_else(|| LabError::msg(f()))
    }
}

/// An error made of a formatted message.
macro_rules! err {
    ($($arg:tt)*) => { $crate::LabError::Message(format!($($arg)*)) };
}

/// Returns early with a formatted message.
macro_rules! bail {
    ($($arg:tt)*) => { return Err($crate::err!($($arg)*)) };
}

/// Returns early with a formatted message unless `cond` holds.
macro_rules! ensure {
    ($cond:expr, $($arg:tt)*) => {
        let holds: bool = $cond;
        if !holds {
            $crate::bail!($($arg)*);
        }
    };
}

pub(crate) use {bail, ensure, err};

/// `err` and its causes, `: `-separated (as the binary prints an error).
pub fn chain(err: &dyn std::error::Error) -> String {
    let mut text = err.to_string();
    let mut cause = err.source();
    while let Some(c) = cause {
        text.push_str(": ");
        text.push_str(&c.to_string());
        cause = c.source();
    }
    text
}
