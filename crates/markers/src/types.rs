//! The detection result shared by detection, pose and maps.

use nalgebra::Point2;
use serde::{Deserialize, Serialize};

/// One detected marker: its dictionary id and its four corners in pixels, in OpenCV's order
/// (the marker's own top-left, top-right, bottom-right, bottom-left).
#[derive(Clone, Debug, PartialEq, Serialize, Deserialize)]
pub struct Marker {
    /// Index of the marker in its dictionary.
    pub id: u32,
    /// TL, TR, BR, BL in pixels.
    pub corners: [Point2<f64>; 4],
}
