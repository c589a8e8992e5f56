//! Cambridge Landmarks pose lists, as PoseNet and its successors read them
//! (`dataset_train.txt`, `dataset_test.txt`).
//!
//! # Format
//! Three header lines, then one image per line:
//! ```text
//! Visual Landmark Dataset V1
//! ImageFile, Camera Position [X Y Z W P Q R]
//!
//! seq1/frame00001.png 1.0 2.0 3.0 0.5 0.5 -0.5 0.5
//! ```
//! `X Y Z` is the camera centre in the world (the reconstruction's units, which the dataset gives
//! as metres) and `W P Q R` a Hamilton quaternion `w, x, y, z`.
//!
//! # Which rotation the quaternion is
//! The **world-to-camera** rotation `R_cw` (`p_cam = R_cw · (p_world − C)`), with OpenCV camera
//! axes (x right, y down, z forward). The lists were exported from each scene's VisualSFM model
//! (`reconstruction.nvm`, whose cameras are `file focal qw qx qy qz cx cy cz radial 0` with exactly
//! this meaning) and keep its quaternion and camera centre as they are. Two loaders that combine
//! the lists with the model's 3D points confirm it, and would produce garbage otherwise:
//! - `vislearn/dsacstar`, `datasets/setup_cambridge.py` (commit `1b0a915`): reads `W P Q R` of
//!   `dataset_{train,test}.txt` as the rotation "scene to camera", sets `t = −R·C`, projects the
//!   model's points with `[R | t]` (pixel = `f·(x, y)/z` + image centre, so y down, z forward)
//!   to build its training targets, and saves the inverse of `[R | t]` as its camera-to-world pose.
//! - `clementinboittiaux/homography-loss-function`, `datasets.py`, class `CambridgeDataset`
//!   (commit `1606114`): names `X Y Z` `w_t_c` and `W P Q R` `c_q_w` ("world-to-camera
//!   quaternion"), and keeps the model's points with `c_R_w · (w_P − w_t_c)` at depth `z > 0.2`
//!   and inside the 1920x1080 image.
//!
//! # Conversion
//! [`read`]: pose rotation (camera-to-world) = `q⁻¹`, translation = `(X, Y, Z)`.
//! [`write()`]: `q = rotation⁻¹`, stored on the `w ≥ 0` hemisphere, `(X, Y, Z)` = translation.
//!
//! # Frames
//! The name is the image path as written (`seq1/frame00001.png`, matching between lists); `seq`
//! is its first path component (`seq1`), or the list's file stem for a name without a folder;
//! `t` is `None`. The lists hold no intrinsics (`camera` is `None`).
//!
//! Header lines are skipped the way PoseNet readers skip them: any of the first three lines that
//! is not a pose line (not 8 fields, or fields 2–8 not numbers). Blank lines and `#` comments are
//! skipped anywhere. After line 3, a malformed line is an error naming the line.

use crate::io::{fixed_numbers, fmt_f64, read_text, require_finite, write_text_atomic};
use crate::{DataError, PoseFrame, Result, Trajectory};
use geom::Pose;
use nalgebra::Vector3;
use std::path::Path;

/// The three header lines [`write()`] puts at the top of a list (the last one blank).
pub const HEADER: [&str; 3] = [
    "Visual Landmark Dataset V1",
    "ImageFile, Camera Position [X Y Z W P Q R]",
    "",
];

/// Lines this far into the file may be headers (PoseNet's readers skip the first three).
const HEADER_LINES: usize = 3;

/// Reads a Cambridge Landmarks / PoseNet list (see the module documentation for the convention).
///
/// Errors name the file and line: a pose line without 8 fields, a field that is not a finite
/// number, a quaternion whose norm is not 1 (within rounding). A list with no pose lines is an
/// error ("no poses").
pub fn read(path: &Path) -> Result<Trajectory> {
    let text = read_text(path)?;
    let stem = path
        .file_stem()
        .map(|s| s.to_string_lossy().into_owned())
        .unwrap_or_default();
    let mut frames = Vec::new();
    let mut seen = crate::trajectory::FirstSeen::default();
    for (i, line) in text.lines().enumerate() {
        let line_no = i + 1;
        let fields: Vec<&str> = line.split_whitespace().collect();
        let skip = fields.is_empty()
            || fields.first().is_some_and(|f| f.starts_with('#'))
            || (line_no <= HEADER_LINES && !looks_like_pose(&fields));
        if !skip {
            let frame = parse_line(path, line_no, &fields, &stem)?;
            seen.check(path, &frame.name, line_no, &frame.pose, "line")?;
            frames.push(frame);
        }
    }
    if frames.is_empty() {
        return Err(DataError::invalid(
            path,
            "no poses (expected lines 'image X Y Z W P Q R' after the header)",
        ));
    }
    Ok(Trajectory::new(frames))
}

/// A pose line as PoseNet readers recognise one: 8 fields, the last 7 numbers.
fn looks_like_pose(fields: &[&str]) -> bool {
    fields.len() == 8 && fields.iter().skip(1).all(|f| f.parse::<f64>().is_ok())
}

/// One line `image X Y Z W P Q R`.
fn parse_line(path: &Path, line_no: usize, fields: &[&str], stem: &str) -> Result<PoseFrame> {
    let count_msg = || {
        format!(
            "a pose line needs 8 fields (image X Y Z W P Q R), got {}",
            fields.len()
        )
    };
    let (name, numbers) = match fields.split_first() {
        Some((name, numbers)) if fields.len() == 8 => (*name, numbers),
        _ => return Err(DataError::parse(path, line_no, count_msg())),
    };
    let [x, y, z, w, p, q, r] = fixed_numbers::<7>(path, line_no, numbers, count_msg)?;
    let world_to_camera = geom::rotation::quat_from_wxyz([w, p, q, r])
        .map_err(|e| DataError::parse(path, line_no, e.to_string()))?;
    Ok(PoseFrame {
        name: name.to_string(),
        seq: sequence_of(name, stem),
        t: None,
        // The centre is stored as is; only the rotation is the other way round.
        pose: Pose::new(world_to_camera.inverse(), Vector3::new(x, y, z)),
    })
}

/// `seq1` of `seq1/frame00001.png`; the list's stem for a name without a folder.
fn sequence_of(name: &str, stem: &str) -> String {
    match name.split_once('/') {
        Some((first, _)) if !first.is_empty() => first.to_string(),
        _ => stem.to_string(),
    }
}

/// Writes `traj` as a Cambridge Landmarks list, atomically: the three header lines, then
/// `name X Y Z W P Q R` per frame with the world-to-camera quaternion (module documentation).
///
/// Errors: an empty trajectory, a frame name that is empty or holds whitespace (the list could
/// not be read back), a non-finite value.
pub fn write(traj: &Trajectory, path: &Path) -> Result<()> {
    if traj.is_empty() {
        return Err(DataError::invalid(path, "no frames to write"));
    }
    let mut out = HEADER.join("\n");
    out.push('\n');
    for frame in &traj.frames {
        out.push_str(&pose_line(path, frame)?);
        out.push('\n');
    }
    write_text_atomic(path, &out)
}

fn pose_line(path: &Path, frame: &PoseFrame) -> Result<String> {
    if frame.name.is_empty() || frame.name.contains(char::is_whitespace) {
        return Err(DataError::invalid(
            path,
            format!(
                "frame name '{}' is empty or holds whitespace, which a list cannot store",
                frame.name
            ),
        ));
    }
    require_finite(path, frame)?;
    let [x, y, z] = frame.pose.position();
    let q = geom::rotation::quat_to_wxyz(&frame.pose.rotation.inverse());
    let mut fields = vec![frame.name.clone()];
    fields.extend([x, y, z].into_iter().chain(q).map(fmt_f64));
    Ok(fields.join(" "))
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::test_util::{put, shared, tmp};
    use geom::rotation::rotation_angle;
    use nalgebra::{Matrix3, Point3};

    #[test]
    fn stored_quaternion_is_world_to_camera() -> Result<()> {
        let dir = tmp()?;
        // A camera at C = (1, 2, 3) looking along world +x, level, OpenCV axes. Camera-to-world
        // R_wc has the camera's axes as columns: x_cam = −y, y_cam = −z, z_cam = +x:
        //   R_wc = [0 0 1; −1 0 0; 0 −1 0],  quaternion w x y z = (½, −½, ½, −½).
        // The list stores R_cw = R_wcᵀ = [0 −1 0; 0 0 −1; 1 0 0], whose quaternion is the
        // conjugate (½, ½, −½, ½). Check by hand: R_cw maps world +x to camera (0, 0, 1), i.e.
        // straight ahead. Read as camera-to-world instead, the camera would look along world −y.
        let p = put(
            dir.path(),
            "dataset_test.txt",
            "Visual Landmark Dataset V1\nImageFile, Camera Position [X Y Z W P Q R]\n\n\
             seq3/frame00007.png 1 2 3 0.5 0.5 -0.5 0.5\n\
             seq3/frame00008.png -14.83 0.10 13.25 0.1 0.8 0.0 0.59\n",
        )?;
        let traj = read(&p)?;
        assert_eq!(traj.len(), 2);
        assert!(traj.camera.is_none());
        let f = &traj.frames[0];
        assert_eq!(f.name, "seq3/frame00007.png");
        assert_eq!(f.seq, "seq3");
        assert_eq!(f.t, None);
        assert_eq!(f.pose.position(), [1.0, 2.0, 3.0]);
        #[rustfmt::skip]
        let r_wc = Matrix3::new(
            0.0, 0.0, 1.0,
            -1.0, 0.0, 0.0,
            0.0, -1.0, 0.0,
        );
        assert!((f.pose.rotation_matrix() - r_wc).amax() < 1e-15);
        assert!((f.pose.forward() - Vector3::x()).norm() < 1e-15);
        // A landmark 4 m ahead, at world (5, 2, 3), is at camera (0, 0, 4), as the loaders
        // above compute it: R_cw · (p − C).
        let in_cam = f
            .pose
            .inverse()
            .transform_point(&Point3::new(5.0, 2.0, 3.0));
        assert!((in_cam - Point3::new(0.0, 0.0, 4.0)).norm() < 1e-12);
        Ok(())
    }

    #[test]
    fn reads_peer_reference_list() -> Result<()> {
        let traj = read(&shared("tools/peers/testdata/traj/gt_posenet.txt"))?;
        assert_eq!(traj.len(), 120);
        let f = &traj.frames[0];
        assert_eq!(f.name, "seq1/frame00000.png");
        assert_eq!(f.seq, "seq1");
        assert_eq!(f.pose.position(), [3.0, 0.0, 1.5]);
        // First line stores W P Q R = 0.707027233 0.010606204 −0.010606204 0.707027233 (9
        // decimals, normalised on reading); the pose's rotation is its inverse.
        let stored = geom::rotation::quat_to_wxyz(&f.pose.rotation.inverse());
        for (a, b) in stored
            .iter()
            .zip([0.707027233, 0.010606204, -0.010606204, 0.707027233])
        {
            assert!((a - b).abs() < 1e-9, "{stored:?}");
        }
        // The peers' generator (gen_testdata.py) wrote the same camera-to-world quaternions into
        // gt.tum and gt_posenet.txt, so read as a Cambridge list its rotations are the inverses
        // of gt.tum's. metrics.py compares gt and estimate lists in one convention, and the
        // angle of R_gtᵀ R_est equals that of R_gt R_estᵀ, so its error figures are unaffected.
        let tum = crate::tum::read(&shared("tools/peers/testdata/traj/gt.tum"))?;
        for (a, b) in traj.frames.iter().zip(&tum.frames) {
            assert_eq!(a.pose.position(), b.pose.position());
            assert!(rotation_angle(&(a.pose.rotation * b.pose.rotation)) < 1e-9);
        }
        Ok(())
    }

    #[test]
    fn round_trip_is_bit_exact() -> Result<()> {
        let dir = tmp()?;
        let frames: Vec<PoseFrame> = crate::tum::tests::awkward_poses()?
            .into_iter()
            .enumerate()
            .map(|(i, pose)| PoseFrame {
                name: format!("seq{}/frame{i:05}.png", i % 3 + 1),
                seq: format!("seq{}", i % 3 + 1),
                t: None,
                pose,
            })
            .collect();
        let traj = Trajectory::new(frames);
        let p = dir.path().join("dataset_train.txt");
        write(&traj, &p)?;
        let text = read_text(&p)?;
        assert!(text.starts_with(
            "Visual Landmark Dataset V1\nImageFile, Camera Position [X Y Z W P Q R]\n\nseq1/"
        ));
        let back = read(&p)?;
        assert_eq!(back.len(), traj.len());
        for (a, b) in traj.frames.iter().zip(&back.frames) {
            assert_eq!((&a.name, &a.seq, a.t), (&b.name, &b.seq, b.t));
            assert_eq!(
                a.pose.position().map(f64::to_bits),
                b.pose.position().map(f64::to_bits)
            );
            assert_eq!(
                a.pose.quat_wxyz().map(f64::to_bits),
                b.pose.quat_wxyz().map(f64::to_bits)
            );
        }
        // Stored with w ≥ 0, and writing what was read gives the same file again.
        for line in text.lines().skip(3) {
            let w: f64 = line.split(' ').nth(4).unwrap_or("").parse().unwrap_or(-1.0);
            assert!(w >= 0.0, "{line}");
        }
        let again = dir.path().join("again.txt");
        write(&back, &again)?;
        assert_eq!(text, read_text(&again)?);
        Ok(())
    }

    #[test]
    fn headers_are_tolerated_pose_lines_are_not() -> Result<()> {
        let dir = tmp()?;
        // No header at all, and a header with a blank line missing: both fine.
        let bare = put(dir.path(), "bare.txt", "a.png 0 0 0 1 0 0 0\n")?;
        assert_eq!(read(&bare)?.frames[0].seq, "bare");
        let short = put(
            dir.path(),
            "short.txt",
            "Visual Landmark Dataset V1\nImageFile, Camera Position [X Y Z W P Q R]\nb/c.png 0 0 0 1 0 0 0\n",
        )?;
        assert_eq!(read(&short)?.len(), 1);
        // A pose-looking line among the first three is a pose line: a bad quaternion there is
        // an error, not a header.
        let bad_first = put(dir.path(), "bad_first.txt", "a.png 0 0 0 2 0 0 0\n")?;
        let msg = read(&bad_first).map(|_| ()).unwrap_err().to_string();
        assert!(msg.contains("bad_first.txt:1: quaternion norm"), "{msg}");
        Ok(())
    }

    #[test]
    fn malformed_lists_name_file_and_line() -> Result<()> {
        let dir = tmp()?;
        let head = "Visual Landmark Dataset V1\nImageFile, Camera Position [X Y Z W P Q R]\n\n";
        let cases = [
            (
                "cols.txt",
                "s/a.png 1 2 3 1 0 0\n",
                ":4: a pose line needs 8 fields",
            ),
            (
                "nan.txt",
                "s/a.png 1 NaN 3 1 0 0 0\n",
                ":4: non-finite value 'NaN'",
            ),
            (
                "word.txt",
                "s/a.png 0 0 0 1 0 0 0\ns/b.png 1 2 x 1 0 0 0\n",
                ":5: 'x' is not a number",
            ),
            (
                "unit.txt",
                "s/a.png 1 2 3 0.5 0 0 0\n",
                ":4: quaternion norm",
            ),
            (
                "junk.txt",
                "\u{1}\u{3}\u{7f}garbage\n",
                ":4: a pose line needs 8 fields",
            ),
        ];
        for (name, body, want) in cases {
            let p = put(dir.path(), name, &format!("{head}{body}"))?;
            let msg = read(&p).map(|_| ()).unwrap_err().to_string();
            assert!(msg.starts_with(&p.display().to_string()), "{msg}");
            assert!(msg.contains(want), "{name}: {msg}");
        }
        for (name, text) in [("empty.txt", ""), ("header_only.txt", head)] {
            let p = put(dir.path(), name, text)?;
            let msg = read(&p).map(|_| ()).unwrap_err().to_string();
            assert!(msg.contains(name) && msg.contains("no poses"), "{msg}");
        }
        let bin = dir.path().join("bin.txt");
        std::fs::write(&bin, [0x89, b'P', b'N', b'G', 0x00, 0xff])
            .map_err(|e| DataError::io(&bin, e))?;
        let msg = read(&bin).map(|_| ()).unwrap_err().to_string();
        assert!(
            msg.contains("bin.txt") && msg.contains("not a text file"),
            "{msg}"
        );
        Ok(())
    }

    #[test]
    fn writer_refuses_names_it_cannot_store() -> Result<()> {
        let dir = tmp()?;
        let p = dir.path().join("o.txt");
        let frame = |name: &str| PoseFrame {
            name: name.into(),
            seq: "s".into(),
            t: None,
            pose: Pose::identity(),
        };
        for name in ["", "my image.png"] {
            let traj = Trajectory::new(vec![frame(name)]);
            assert!(write(&traj, &p).is_err(), "{name:?}");
        }
        assert!(write(&Trajectory::default(), &p).is_err());
        assert!(!p.exists());
        Ok(())
    }
}
