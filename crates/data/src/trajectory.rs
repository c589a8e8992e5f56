//! The in-memory form every reader produces and every writer consumes: a list of posed frames
//! in the conventions of DESIGN.md (camera-to-world, OpenCV camera axes, metres).

use geom::{Camera, Pose};
use serde::{Deserialize, Serialize};

/// One posed frame.
#[derive(Clone, Debug, PartialEq, Serialize, Deserialize)]
pub struct PoseFrame {
    /// The frame's name, used to match ground truth with estimates: the image file stem
    /// (`frame-000012`, `0001`), a relative image path (Cambridge, COLMAP), or the frame number
    /// of a native dataset (`000012`).
    pub name: String,
    /// The sequence (recording session) the frame belongs to; splits are made of these.
    pub seq: String,
    /// Time stamp in seconds, where the format has one.
    pub t: Option<f64>,
    /// Camera-to-world pose.
    pub pose: Pose,
}

/// Frames with poses, in file order, plus what the format tells about the camera.
#[derive(Clone, Debug, Default, PartialEq, Serialize, Deserialize)]
pub struct Trajectory {
    /// The frames.
    pub frames: Vec<PoseFrame>,
    /// Intrinsics where the format stores them (native, COLMAP, NeRF).
    pub camera: Option<Camera>,
}

impl Trajectory {
    /// A trajectory of these frames without camera information.
    pub fn new(frames: Vec<PoseFrame>) -> Self {
        Self {
            frames,
            camera: None,
        }
    }

    /// Number of frames.
    pub fn len(&self) -> usize {
        self.frames.len()
    }

    /// True when there are no frames.
    pub fn is_empty(&self) -> bool {
        self.frames.is_empty()
    }

    /// The poses in order.
    pub fn poses(&self) -> Vec<Pose> {
        self.frames.iter().map(|f| f.pose).collect()
    }
}
