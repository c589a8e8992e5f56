//! Microsoft 7-Scenes (Shotton et al., CVPR 2013) and datasets in its layout (12-Scenes, many
//! exports of SLAM and rendering tools).
//!
//! # Layout
//! ```text
//! SCENE/
//!   TrainSplit.txt, TestSplit.txt     one sequence per line: `sequence1`, `sequence3`, …
//!   seq-01/
//!     frame-000000.color.png          RGB image
//!     frame-000000.depth.png          16-bit depth, millimetres
//!     frame-000000.pose.txt           4x4 camera-to-world matrix
//! ```
//! A pose file holds 16 numbers, the matrix `[R t; 0 0 0 1]` row by row (4 per line, tab or
//! space separated, in the shipped files written like ` 9.38227673e-01\t`), mapping camera
//! coordinates to world coordinates in metres, with the camera's x right, y down, z forward.
//!
//! # Conversion
//! That is DESIGN.md's convention (camera-to-world, OpenCV axes, metres), so the conversion is
//! the identity. 7-Scenes' rotation blocks are orthonormal only to about 1e-4 (they come from
//! KinectFusion in single precision), so the reader projects each one onto the nearest rotation
//! ([`geom::Pose::from_row_major`]); a block further than geom's tolerance from a rotation, a
//! reflection, or a last row other than `0 0 0 1` is an error. Note that 7-Scenes' world is
//! KinectFusion's (y down at the start of each scene), not z up: a reader converts conventions
//! of the camera and the pose, it does not re-level a world.
//!
//! # Frames
//! [`read`] names each frame by its file name without `.pose.txt` (`frame-000012`), `seq` is its
//! folder (`seq-01`), `t` is `None`. Sequences and frames are sorted by the number in their names.
//! The camera is [`rgb_camera`]: the files store no intrinsics, and 640x480, f = 525,
//! c = (320, 240) is the value customarily used for the RGB images.
//!
//! [`write()`] writes `DIR/<seq>/<name>.pose.txt` for each frame: the name is kept when it starts
//! with `frame-`, and is otherwise replaced with `frame-NNNNNN`, the frame's index (from 0) among
//! the frames of its sequence in trajectory order. Time stamps and intrinsics are not stored.
//! Numbers are printed in their shortest form that parses back to the same `f64`, so positions
//! survive a round trip bit for bit; rotations pass through a matrix and back and agree to about
//! 1e-15.
//!
//! Splits are by sequence, never by frame: [`read_split`] maps the split files' `sequenceN` to
//! the folder name `seq-0N` (two digits at least, as the folders are named).

use crate::io::{fmt_f64, parse_numbers, read_text, require_finite, write_text_atomic};
use crate::{DataError, PoseFrame, Result, Trajectory};
use geom::{Camera, Distortion, GeomError, Pose};
use std::collections::{HashMap, HashSet};
use std::path::{Path, PathBuf};

/// Suffix of a pose file; the frame name is the file name without it.
pub const POSE_SUFFIX: &str = ".pose.txt";

/// The intrinsics customarily used for 7-Scenes RGB images (640x480, f = 525, c = (320, 240),
/// no distortion). The dataset's files do not store them; its authors give only the depth
/// camera's (f = 585).
pub fn rgb_camera() -> Camera {
    Camera {
        width: 640,
        height: 480,
        fx: 525.0,
        fy: 525.0,
        cx: 320.0,
        cy: 240.0,
        dist: Distortion::default(),
    }
}

/// The sequences of a scene used for training and for testing (folder names, `seq-01`).
#[derive(Clone, Debug, Default, PartialEq, Eq)]
pub struct Split {
    /// Sequences of `TrainSplit.txt`, in file order.
    pub train: Vec<String>,
    /// Sequences of `TestSplit.txt`, in file order.
    pub test: Vec<String>,
}

/// Reads the poses of a 7-Scenes scene folder (all its sequences) or of one sequence folder
/// (see the module documentation for the layout and conversion).
///
/// A folder holding `*.pose.txt` files is one sequence, named after the folder; otherwise each
/// of its sub-folders holding `*.pose.txt` files is a sequence. Errors name the file and line: a
/// file without exactly 16 numbers, a non-finite or non-numeric value, a last row other than
/// `0 0 0 1`, a rotation block that is not a rotation; a folder without pose files is an error.
pub fn read(path: &Path) -> Result<Trajectory> {
    let meta = std::fs::metadata(path).map_err(|e| DataError::io(path, e))?;
    if !meta.is_dir() {
        return Err(DataError::invalid(
            path,
            "expected a 7-Scenes scene folder or a seq-XX folder",
        ));
    }
    let mut frames = Vec::new();
    for (seq, files) in sequences(path)? {
        for (name, file) in files {
            frames.push(PoseFrame {
                pose: read_pose_file(&file)?,
                name,
                seq: seq.clone(),
                t: None,
            });
        }
    }
    if frames.is_empty() {
        return Err(DataError::invalid(
            path,
            "no poses: expected seq-XX/ folders of frame-NNNNNN.pose.txt files",
        ));
    }
    Ok(Trajectory {
        frames,
        camera: Some(rgb_camera()),
    })
}

/// A pose file and the frame name it gives.
type PoseFile = (String, PathBuf);

/// The sequences under `path`, each with its pose files, both sorted numerically.
fn sequences(path: &Path) -> Result<Vec<(String, Vec<PoseFile>)>> {
    let own = pose_files(path)?;
    if !own.is_empty() {
        return Ok(vec![(folder_name(path), own)]);
    }
    let mut seqs = Vec::new();
    for entry in list_dir(path)? {
        if entry.is_dir() {
            let files = pose_files(&entry)?;
            if !files.is_empty() {
                seqs.push((folder_name(&entry), files));
            }
        }
    }
    seqs.sort_by_cached_key(|(name, _)| numeric_key(name));
    Ok(seqs)
}

/// The `*.pose.txt` files directly in `dir`, sorted by frame number.
fn pose_files(dir: &Path) -> Result<Vec<PoseFile>> {
    let mut files: Vec<PoseFile> = list_dir(dir)?
        .into_iter()
        .filter(|p| p.is_file())
        .filter_map(|p| {
            let name = p
                .file_name()?
                .to_str()?
                .strip_suffix(POSE_SUFFIX)?
                .to_string();
            Some((name, p))
        })
        .collect();
    files.sort_by_cached_key(|(name, _)| numeric_key(name));
    Ok(files)
}

fn list_dir(dir: &Path) -> Result<Vec<PathBuf>> {
    std::fs::read_dir(dir)
        .map_err(|e| DataError::io(dir, e))?
        .map(|entry| entry.map(|e| e.path()).map_err(|e| DataError::io(dir, e)))
        .collect()
}

/// The folder's own name, also for paths like `.` or `seq-01/..`.
fn folder_name(dir: &Path) -> String {
    let named = dir.file_name().map(|n| n.to_string_lossy().into_owned());
    named
        .or_else(|| {
            let full = dir.canonicalize().ok()?;
            Some(full.file_name()?.to_string_lossy().into_owned())
        })
        .unwrap_or_default()
}

/// Sort key: the number the name ends with (`seq-10` after `seq-9`), then the name; names
/// without a number come last.
fn numeric_key(name: &str) -> (bool, u64, String) {
    let digits = name.len() - name.trim_end_matches(|c: char| c.is_ascii_digit()).len();
    let number: Option<u64> = name.get(name.len() - digits..).and_then(|d| d.parse().ok());
    (number.is_none(), number.unwrap_or(0), name.to_string())
}

/// One `frame-NNNNNN.pose.txt`: 16 numbers, row-major, camera-to-world.
fn read_pose_file(path: &Path) -> Result<Pose> {
    let text = read_text(path)?;
    // Each number with its 1-based line, so errors can point at the line.
    let mut values = Vec::with_capacity(16);
    let mut lines = Vec::with_capacity(16);
    for (i, line) in text.lines().enumerate() {
        let fields: Vec<&str> = line.split_whitespace().collect();
        for v in parse_numbers(path, i + 1, &fields)? {
            values.push(v);
            lines.push(i + 1);
        }
    }
    let Ok(matrix) = <[f64; 16]>::try_from(values.as_slice()) else {
        return Err(size_error(path, &lines));
    };
    Pose::from_row_major(&matrix).map_err(|e| {
        // The last row starts at number 13; anything else is about the rotation block.
        let at = if matches!(e, GeomError::BadLastRow { .. }) {
            12
        } else {
            0
        };
        let line = lines.get(at).copied().unwrap_or(1);
        DataError::parse(path, line, format!("not a camera-to-world pose: {e}"))
    })
}

fn size_error(path: &Path, lines: &[usize]) -> DataError {
    let what = "a 7-Scenes pose is a 4x4 matrix (16 numbers)";
    match (lines.get(16), lines.last()) {
        (Some(&line), _) => DataError::parse(path, line, format!("more than 16 numbers: {what}")),
        (None, Some(&line)) => {
            DataError::parse(path, line, format!("only {} numbers: {what}", lines.len()))
        }
        (None, None) => DataError::invalid(path, format!("no numbers: {what}")),
    }
}

/// Reads `TrainSplit.txt` and `TestSplit.txt` of a scene folder, mapping `sequenceN` to
/// `seq-0N` (at least two digits: `sequence12` → `seq-12`). Blank lines are skipped; any other
/// line is an error naming the file and line, and so is a sequence listed in both files (a
/// leak of test frames into training).
pub fn read_split(scene_dir: &Path) -> Result<Split> {
    let split = Split {
        train: read_split_file(&scene_dir.join("TrainSplit.txt"))?,
        test: read_split_file(&scene_dir.join("TestSplit.txt"))?,
    };
    if let Some(seq) = split.train.iter().find(|s| split.test.contains(s)) {
        return Err(DataError::invalid(
            scene_dir,
            format!("{seq} is listed in both TrainSplit.txt and TestSplit.txt"),
        ));
    }
    Ok(split)
}

fn read_split_file(path: &Path) -> Result<Vec<String>> {
    let text = read_text(path)?;
    let mut seqs = Vec::new();
    for (i, line) in text.lines().enumerate() {
        let s = line.trim();
        if s.is_empty() {
            continue;
        }
        let number = s
            .strip_prefix("sequence")
            .filter(|n| !n.is_empty() && n.bytes().all(|b| b.is_ascii_digit()))
            .and_then(|n| n.parse::<u32>().ok())
            .ok_or_else(|| {
                DataError::parse(path, i + 1, format!("expected 'sequenceN', got '{s}'"))
            })?;
        seqs.push(format!("seq-{number:02}"));
    }
    Ok(seqs)
}

/// Writes `traj` in the 7-Scenes layout under `dir`: one `DIR/<seq>/<name>.pose.txt` per frame
/// (names as described in the module documentation), each written atomically. Split files,
/// images and intrinsics are not written.
///
/// Errors, reported before any file is written: an empty trajectory, a sequence name that is
/// not a plain folder name, two frames that would share a file, a non-finite value.
pub fn write(traj: &Trajectory, dir: &Path) -> Result<()> {
    if traj.is_empty() {
        return Err(DataError::invalid(dir, "no frames to write"));
    }
    let mut files = Vec::with_capacity(traj.len());
    let mut taken = HashSet::new();
    let mut index_in_seq: HashMap<&str, usize> = HashMap::new();
    for frame in &traj.frames {
        let index = index_in_seq.entry(frame.seq.as_str()).or_insert(0);
        let path = frame_path(dir, frame, *index)?;
        *index += 1;
        require_finite(&path, frame)?;
        if !taken.insert(path.clone()) {
            return Err(DataError::invalid(
                path,
                "two frames of the trajectory would be written to this file",
            ));
        }
        files.push((path, matrix_text(&frame.pose)));
    }
    for (path, text) in files {
        write_text_atomic(&path, &text)?;
    }
    Ok(())
}

/// `dir/<seq>/<name>.pose.txt`, the name replaced by `frame-{index:06}` unless it is a plain
/// file name starting with `frame-`.
fn frame_path(dir: &Path, frame: &PoseFrame, index: usize) -> Result<PathBuf> {
    if !is_plain_name(&frame.seq) {
        return Err(DataError::invalid(
            dir,
            format!(
                "frame '{}': sequence '{}' is not a plain folder name",
                frame.name, frame.seq
            ),
        ));
    }
    let name = if frame.name.starts_with("frame-") && is_plain_name(&frame.name) {
        frame.name.clone()
    } else {
        format!("frame-{index:06}")
    };
    Ok(dir.join(&frame.seq).join(format!("{name}{POSE_SUFFIX}")))
}

/// A single non-empty path component: no separators, not `.` or `..`.
fn is_plain_name(s: &str) -> bool {
    !s.is_empty() && s != "." && s != ".." && !s.contains(['/', '\\'])
}

/// The 4x4 matrix, a row per line, tab-separated.
fn matrix_text(pose: &Pose) -> String {
    let m = pose.to_matrix4();
    let mut out = String::with_capacity(16 * 24);
    for row in m.row_iter() {
        let fields: Vec<String> = row.iter().map(|&v| fmt_f64(v)).collect();
        out.push_str(&fields.join("\t"));
        out.push('\n');
    }
    out
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::test_util::{put, shared_data, tmp};
    use geom::rotation::rotation_angle;
    use nalgebra::{Matrix3, Point3, Vector3};

    const STAIRS: &str = "7scenes_stairs_sample/7scenes_layout";

    /// A camera at (1, 2, 3) looking along world +x, level, in 7-Scenes' own text layout.
    /// Its axes in the world are the columns of R: x_cam = −y, y_cam = −z, z_cam = +x.
    const LOOKING_ALONG_X: &str = " 0.00000000e+00\t 0.00000000e+00\t 1.00000000e+00\t 1.00000000e+00\t\n\
        -1.00000000e+00\t 0.00000000e+00\t 0.00000000e+00\t 2.00000000e+00\t\n\
         0.00000000e+00\t-1.00000000e+00\t 0.00000000e+00\t 3.00000000e+00\t\n\
         0.00000000e+00\t 0.00000000e+00\t 0.00000000e+00\t 1.00000000e+00\t\n";

    #[test]
    fn hand_written_scene() -> Result<()> {
        let dir = tmp()?;
        let scene = dir.path();
        put(scene, "seq-02/frame-000000.pose.txt", LOOKING_ALONG_X)?;
        put(scene, "seq-02/frame-000000.color.png", "not read")?;
        put(scene, "seq-10/frame-000000.pose.txt", LOOKING_ALONG_X)?;
        put(scene, "seq-02/frame-000010.pose.txt", LOOKING_ALONG_X)?;
        put(scene, "seq-02/frame-000009.pose.txt", LOOKING_ALONG_X)?;
        put(scene, "TrainSplit.txt", "sequence2\r\n")?;
        put(scene, "TestSplit.txt", "sequence10\n\n")?;
        std::fs::create_dir_all(scene.join("empty")).map_err(|e| DataError::io("d", e))?;

        let traj = read(scene)?;
        let names: Vec<(&str, &str)> = traj
            .frames
            .iter()
            .map(|f| (f.seq.as_str(), f.name.as_str()))
            .collect();
        // Numerical order: seq-02 before seq-10, frame 9 before frame 10.
        assert_eq!(
            names,
            [
                ("seq-02", "frame-000000"),
                ("seq-02", "frame-000009"),
                ("seq-02", "frame-000010"),
                ("seq-10", "frame-000000"),
            ]
        );
        assert_eq!(traj.camera, Some(rgb_camera()));
        let f = &traj.frames[0];
        assert_eq!(f.t, None);
        assert_eq!(f.pose.position(), [1.0, 2.0, 3.0]);
        // Identity conversion: forward is world +x, a point 2 m ahead is at (3, 2, 3), and the
        // quaternion (worked out by hand from R) is w x y z = (½, −½, ½, −½).
        assert!((f.pose.forward() - Vector3::x()).norm() < 1e-15);
        let ahead = f.pose.transform_point(&Point3::new(0.0, 0.0, 2.0));
        assert!((ahead - Point3::new(3.0, 2.0, 3.0)).norm() < 1e-12);
        for (a, b) in f.pose.quat_wxyz().iter().zip([0.5, -0.5, 0.5, -0.5]) {
            assert!((a - b).abs() < 1e-15);
        }
        // One sequence folder on its own.
        let one = read(&scene.join("seq-10"))?;
        assert_eq!((one.len(), one.frames[0].seq.as_str()), (1, "seq-10"));
        assert_eq!(
            read_split(scene)?,
            Split {
                train: vec!["seq-02".into()],
                test: vec!["seq-10".into()],
            }
        );
        Ok(())
    }

    #[test]
    fn reads_stairs_sample() -> Result<()> {
        let scene = &shared_data(STAIRS);
        let traj = read(scene)?;
        assert_eq!(traj.len(), 12);
        let seqs: Vec<&str> = traj.frames.iter().map(|f| f.seq.as_str()).collect();
        assert_eq!(seqs.iter().filter(|s| **s == "seq-03").count(), 3);
        assert_eq!(seqs.first(), Some(&"seq-01"));
        assert_eq!(seqs.last(), Some(&"seq-04"));
        // seq-01/frame-000000.pose.txt:
        //  9.38227673e-01 -2.68622986e-01  2.18106680e-01 -1.49033770e+00
        //  1.67976557e-01  9.04666384e-01  3.91615386e-01 -4.97377960e-01
        // -3.02510676e-01 -3.30787583e-01  8.93905401e-01 -5.46947830e-02
        let f = &traj.frames[0];
        assert_eq!(f.name, "frame-000000");
        assert_eq!(
            f.pose.position(),
            [-1.49033770, -0.497377960, -0.0546947830]
        );
        #[rustfmt::skip]
        let r = Matrix3::new(
            9.38227673e-01, -2.68622986e-01, 2.18106680e-01,
            1.67976557e-01, 9.04666384e-01, 3.91615386e-01,
            -3.02510676e-01, -3.30787583e-01, 8.93905401e-01,
        );
        // Projected onto SO(3): the file's block is orthonormal only to ~1e-4.
        assert!((f.pose.rotation_matrix() - r).amax() < 1e-4);
        let seq = read(&scene.join("seq-03"))?;
        assert_eq!(seq.len(), 3);
        assert!(seq.frames.iter().all(|f| f.seq == "seq-03"));
        assert_eq!(
            read_split(scene)?,
            Split {
                train: vec!["seq-02".into(), "seq-03".into()],
                test: vec!["seq-01".into(), "seq-04".into()],
            }
        );
        Ok(())
    }

    #[test]
    fn round_trip() -> Result<()> {
        let dir = tmp()?;
        let stairs = read(&shared_data(STAIRS))?;
        let mut frames = stairs.frames.clone();
        for (i, pose) in crate::tum::tests::awkward_poses()?.into_iter().enumerate() {
            frames.push(PoseFrame {
                name: format!("img{i}"),
                seq: "synthetic".into(),
                t: Some(i as f64),
                pose,
            });
        }
        let traj = Trajectory::new(frames);
        write(&traj, dir.path())?;
        let back = read(dir.path())?;
        assert_eq!(back.len(), traj.len());
        // The stairs frames keep their names; the others become frame-NNNNNN in order.
        let mut synthetic = 0;
        for (a, b) in traj.frames.iter().zip(&back.frames) {
            assert_eq!(a.seq, b.seq);
            if a.seq == "synthetic" {
                assert_eq!(b.name, format!("frame-{synthetic:06}"));
                synthetic += 1;
            } else {
                assert_eq!(a.name, b.name);
            }
            assert_eq!(b.t, None);
            // Positions: bit for bit. Rotations go matrix → quaternion → matrix → quaternion,
            // which cannot be bit exact: equal to 1e-12 rad.
            assert_eq!(
                a.pose.position().map(f64::to_bits),
                b.pose.position().map(f64::to_bits)
            );
            assert!(rotation_angle(&(a.pose.rotation.inverse() * b.pose.rotation)) < 1e-12);
        }
        assert!(dir.path().join("seq-04/frame-000002.pose.txt").is_file());
        assert!(dir.path().join("synthetic/frame-000040.pose.txt").is_file());
        Ok(())
    }

    #[test]
    fn writer_refuses_unsafe_or_clashing_names() -> Result<()> {
        let dir = tmp()?;
        let frame = |seq: &str, name: &str| PoseFrame {
            name: name.into(),
            seq: seq.into(),
            t: None,
            pose: Pose::identity(),
        };
        for bad in ["", "..", "a/b"] {
            let traj = Trajectory::new(vec![frame(bad, "frame-000001")]);
            assert!(write(&traj, dir.path()).is_err(), "{bad:?}");
        }
        // "x" becomes frame-000001 (its index), clashing with the name kept before it.
        let clash = Trajectory::new(vec![frame("s", "frame-000001"), frame("s", "x")]);
        let msg = write(&clash, dir.path())
            .map(|_| ())
            .unwrap_err()
            .to_string();
        assert!(msg.contains("frame-000001.pose.txt"), "{msg}");
        assert!(write(&Trajectory::default(), dir.path()).is_err());
        // Nothing was written by the refused calls.
        assert_eq!(list_dir(dir.path())?.len(), 0);
        Ok(())
    }

    #[test]
    fn malformed_pose_files_name_file_and_line() -> Result<()> {
        let dir = tmp()?;
        let id = "1 0 0 0\n0 1 0 0\n0 0 1 0\n0 0 0 1\n";
        let cases = [
            (
                "short",
                "1 0 0 0\n0 1 0 0\n0 0 1 0\n",
                ":3: only 12 numbers",
            ),
            (
                "long",
                "1 0 0 0\n0 1 0 0\n0 0 1 0\n0 0 0 1\n7\n",
                ":5: more than 16 numbers",
            ),
            (
                "nan",
                "1 0 0 0\n0 1 0 nan\n0 0 1 0\n0 0 0 1\n",
                ":2: non-finite value 'nan'",
            ),
            (
                "word",
                "1 0 0 0\n0 1 0 0\n0 0 1 x\n0 0 0 1\n",
                ":3: 'x' is not a number",
            ),
            (
                "row",
                "1 0 0 0\n0 1 0 0\n0 0 1 0\n0 0 1 1\n",
                ":4: not a camera-to-world pose: last row",
            ),
            (
                "scaled",
                "2 0 0 0\n0 2 0 0\n0 0 2 0\n0 0 0 1\n",
                ":1: not a camera-to-world pose: not a rotation",
            ),
            (
                "mirror",
                "1 0 0 0\n0 1 0 0\n0 0 -1 0\n0 0 0 1\n",
                ":1: not a camera-to-world pose: not a rotation",
            ),
            ("junk", "\u{1}\u{2}\n", ":1: '\u{1}\u{2}' is not a number"),
        ];
        for (name, text, want) in cases {
            let p = put(
                dir.path(),
                &format!("{name}/seq-01/frame-000000.pose.txt"),
                text,
            )?;
            put(
                dir.path(),
                &format!("{name}/seq-01/frame-000001.pose.txt"),
                id,
            )?;
            let msg = read(&dir.path().join(name))
                .map(|_| ())
                .unwrap_err()
                .to_string();
            assert!(msg.starts_with(&p.display().to_string()), "{msg}");
            assert!(msg.contains(want), "{name}: {msg}");
        }
        put(dir.path(), "empty/seq-01/frame-000000.pose.txt", "")?;
        let msg = read(&dir.path().join("empty"))
            .map(|_| ())
            .unwrap_err()
            .to_string();
        assert!(msg.contains("frame-000000.pose.txt: no numbers"), "{msg}");
        let bin = dir.path().join("bin/seq-01/frame-000000.pose.txt");
        std::fs::create_dir_all(dir.path().join("bin/seq-01"))
            .map_err(|e| DataError::io("d", e))?;
        std::fs::write(&bin, [0xff, 0x00, 0xfe]).map_err(|e| DataError::io(&bin, e))?;
        let msg = read(&dir.path().join("bin"))
            .map(|_| ())
            .unwrap_err()
            .to_string();
        assert!(msg.contains("not a text file"), "{msg}");
        // A folder without pose files, a file instead of a folder, a missing path.
        std::fs::create_dir_all(dir.path().join("nothing/seq-01"))
            .map_err(|e| DataError::io("d", e))?;
        assert!(
            read(&dir.path().join("nothing"))
                .unwrap_err()
                .to_string()
                .contains("no poses")
        );
        assert!(read(&dir.path().join("short/seq-01/frame-000000.pose.txt")).is_err());
        assert!(read(&dir.path().join("missing")).is_err());
        Ok(())
    }

    #[test]
    fn malformed_split_files() -> Result<()> {
        let dir = tmp()?;
        put(dir.path(), "TrainSplit.txt", "sequence1\nseq2\n")?;
        put(dir.path(), "TestSplit.txt", "sequence3\n")?;
        let msg = read_split(dir.path()).unwrap_err().to_string();
        assert!(
            msg.contains("TrainSplit.txt:2: expected 'sequenceN'"),
            "{msg}"
        );
        put(dir.path(), "TrainSplit.txt", "sequence1\nsequence3\n")?;
        let msg = read_split(dir.path()).unwrap_err().to_string();
        assert!(msg.contains("seq-03 is listed in both"), "{msg}");
        std::fs::remove_file(dir.path().join("TestSplit.txt"))
            .map_err(|e| DataError::io("d", e))?;
        assert!(
            read_split(dir.path())
                .unwrap_err()
                .to_string()
                .contains("TestSplit.txt")
        );
        Ok(())
    }
}
