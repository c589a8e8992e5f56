//! Fiducial markers: ArUco dictionaries, detection, marker pose, marker maps, printable markers.
//!
//! Conventions: pixels with (0, 0) at the centre of the top-left pixel, x right, y down; a
//! marker's four corners run clockwise from its own top-left (TL, TR, BR, BL), as OpenCV.

pub mod detect;
pub mod dictionary;
mod error;
pub mod generate;
mod io;
pub mod map;
pub mod pose;
mod types;

pub use detect::{DetectParams, detect, detect_file, load_gray};
pub use dictionary::{Dictionary, Identified};
pub use error::MarkersError;
pub use map::{Located, MapMarker, MarkerMap, locate};
pub use pose::{MarkerPose, MarkerPoseCandidate, estimate_marker_pose, marker_corners_3d};
pub use types::Marker;
