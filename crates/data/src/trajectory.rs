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

/// Where each frame key (an image name, a timestamp) was first given and at which pose, so that
/// a reader refuses a frame given twice with two poses: which one is the truth cannot be told,
/// and the first silently won before. The same frame repeated at the same pose is harmless.
#[derive(Debug, Default)]
pub(crate) struct FirstSeen(std::collections::HashMap<String, (usize, Pose)>);

impl FirstSeen {
    /// Records `key` at `place` (a line number, or a frame index for JSON) with `pose`, or an
    /// error naming `path`, the key and both places when it was given before at another pose
    /// (`what`: "line", "frame").
    pub(crate) fn check(
        &mut self,
        path: &std::path::Path,
        key: &str,
        place: usize,
        pose: &Pose,
        what: &str,
    ) -> crate::Result<()> {
        match self.0.get(key) {
            Some((first, before))
                if geom::metrics::position_error(before, pose) > 1e-9
                    || geom::metrics::rotation_error_deg(before, pose) > 1e-6 =>
            {
                Err(crate::DataError::invalid(
                    path,
                    format!(
                        "frame '{key}' is given twice with different poses ({what}s {first} and {place})"
                    ),
                ))
            }
            Some(_) => Ok(()),
            None => {
                self.0.insert(key.to_string(), (place, *pose));
                Ok(())
            }
        }
    }
}

#[cfg(test)]
mod duplicate_tests {
    use std::path::Path;

    fn refused(path: &Path, read: fn(&Path) -> crate::Result<super::Trajectory>) {
        let err = read(path).unwrap_err().to_string();
        assert!(
            err.contains(&path.display().to_string()) && err.contains("given twice"),
            "{err}"
        );
    }

    #[test]
    fn a_frame_given_twice_with_another_pose_is_refused_by_every_reader() {
        let dir = tempfile::tempdir().unwrap();
        let cambridge = dir.path().join("dataset_train.txt");
        std::fs::write(
            &cambridge,
            "Visual Landmark Dataset V1\nImageFile, Camera Position [X Y Z W P Q R]\n\n\
             seq1/a.png 1 2 3 1 0 0 0\nseq1/b.png 1 2 3 1 0 0 0\nseq1/a.png 5 2 3 1 0 0 0\n",
        )
        .unwrap();
        refused(&cambridge, crate::cambridge::read);
        let tum = dir.path().join("gt.txt");
        std::fs::write(
            &tum,
            "1.0 0 0 0 0 0 0 1\n2.0 0 0 0 0 0 0 1\n1.0 4 0 0 0 0 0 1\n",
        )
        .unwrap();
        refused(&tum, crate::tum::read);
        let nerf = dir.path().join("transforms.json");
        let frame = |x: f64| {
            format!(
                r#"{{"file_path": "images/a.png", "transform_matrix": [[1,0,0,{x}],[0,1,0,0],[0,0,1,0],[0,0,0,1]]}}"#
            )
        };
        std::fs::write(
            &nerf,
            format!(
                r#"{{"camera_angle_x": 1.0, "w": 32, "h": 24, "frames": [{}, {}]}}"#,
                frame(0.0),
                frame(1.0)
            ),
        )
        .unwrap();
        refused(&nerf, crate::nerf::read);
    }
}
