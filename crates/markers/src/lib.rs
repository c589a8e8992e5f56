//! Fiducial markers: ArUco dictionaries, detection, marker pose, marker maps, printable markers.
//!
//! Conventions: pixels with (0, 0) at the centre of the top-left pixel, x right, y down; a
//! marker's four corners run clockwise from its own top-left (TL, TR, BR, BL), as OpenCV.

mod types;

pub use types::Marker;
