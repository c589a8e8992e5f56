//! TUM RGB-D trajectory files (also written by evo, ORB-SLAM and most SLAM evaluation tools).
//!
//! # Format
//! One pose per line, `timestamp tx ty tz qx qy qz qw`, fields separated by spaces (commas are
//! accepted too, as evo and the reference `metrics.py` accept them); lines starting with `#` and
//! blank lines are skipped. `timestamp` is in seconds, `tx ty tz` in metres, and `qx qy qz qw` is
//! a Hamilton quaternion with the scalar **last**.
//!
//! # Conversion
//! A TUM pose is the pose of the camera's optical centre in the world: it maps camera
//! coordinates to world coordinates (`p_world = R(q)·p_cam + t`, `t` the camera centre), and for
//! TUM RGB-D the camera axes are the sensor's optical frame, x right, y down, z forward. That is
//! DESIGN.md's convention already, so the conversion is the identity; only the quaternion's
//! component order changes (`x y z w` in the file, `w x y z` in [`geom::Pose::quat_wxyz`]).
//!
//! # Frames
//! [`read`] names each frame by its timestamp **exactly as written** (`1305031102.175304`, not a
//! reprinted number) so that names match between files written by the same tool; `seq` is the
//! file stem and `t` the timestamp. TUM files hold no intrinsics (`camera` is `None`).
//!
//! [`write()`] writes the header comment `# timestamp tx ty tz qx qy qz qw`, then one line per
//! frame. The timestamp is the frame's `t`; where the frame's name is the same number as its `t`
//! (a frame read from a TUM file), the name's text is written instead so names survive a round
//! trip. A frame without `t` gets its index in the trajectory (0, 1, 2, …) as timestamp. Numbers
//! are printed in their shortest form that parses back to the same `f64`, and the quaternion is
//! written on the `w ≥ 0` hemisphere, so write → read gives back positions, timestamps and
//! quaternion components bit for bit.
//!
//! [`associate`] matches two trajectories by nearest timestamp, as evo does.

use crate::io::{fixed_numbers, fmt_f64, read_text, require_finite, write_text_atomic};
use crate::{DataError, PoseFrame, Result, Trajectory};
use geom::Pose;
use nalgebra::Vector3;
use std::path::Path;

/// The comment line [`write()`] puts at the top of a file.
pub const HEADER: &str = "# timestamp tx ty tz qx qy qz qw";

/// Reads a TUM trajectory file (see the module documentation for the format and conversion).
///
/// Errors name the file and line: a line without exactly 8 fields, a field that is not a finite
/// number, a quaternion whose norm is not 1 (within rounding). A file with no pose lines is an
/// error ("no poses").
pub fn read(path: &Path) -> Result<Trajectory> {
    let text = read_text(path)?;
    let seq = path
        .file_stem()
        .map(|s| s.to_string_lossy().into_owned())
        .unwrap_or_default();
    let mut frames = Vec::new();
    let mut seen = crate::trajectory::FirstSeen::default();
    for (i, line) in text.lines().enumerate() {
        let s = line.trim();
        if s.is_empty() || s.starts_with('#') {
            continue;
        }
        let frame = parse_line(path, i + 1, s, &seq)?;
        seen.check(path, &frame.name, i + 1, &frame.pose, "line")?;
        frames.push(frame);
    }
    if frames.is_empty() {
        return Err(DataError::invalid(
            path,
            "no poses (expected lines 'timestamp tx ty tz qx qy qz qw')",
        ));
    }
    Ok(Trajectory::new(frames))
}

/// One pose line `timestamp tx ty tz qx qy qz qw`.
fn parse_line(path: &Path, line_no: usize, s: &str, seq: &str) -> Result<PoseFrame> {
    let fields: Vec<&str> = s
        .split(|c: char| c.is_whitespace() || c == ',')
        .filter(|f| !f.is_empty())
        .collect();
    let [stamp, tx, ty, tz, qx, qy, qz, qw] = fixed_numbers::<8>(path, line_no, &fields, || {
        format!(
            "a TUM line needs 8 fields (timestamp tx ty tz qx qy qz qw), got {}",
            fields.len()
        )
    })?;
    let rotation = geom::rotation::quat_from_wxyz([qw, qx, qy, qz])
        .map_err(|e| DataError::parse(path, line_no, e.to_string()))?;
    Ok(PoseFrame {
        name: fields.first().map(|f| f.to_string()).unwrap_or_default(),
        seq: seq.to_string(),
        t: Some(stamp),
        pose: Pose::new(rotation, Vector3::new(tx, ty, tz)),
    })
}

/// Writes `traj` as a TUM trajectory file, atomically (see the module documentation).
///
/// Errors: an empty trajectory (the file could not be read back), or a non-finite value in a
/// frame, named by the frame.
pub fn write(traj: &Trajectory, path: &Path) -> Result<()> {
    if traj.is_empty() {
        return Err(DataError::invalid(path, "no frames to write"));
    }
    let mut out = String::with_capacity(96 * (traj.len() + 1));
    out.push_str(HEADER);
    out.push('\n');
    for (i, frame) in traj.frames.iter().enumerate() {
        require_finite(path, frame)?;
        let [x, y, z] = frame.pose.position();
        let [qx, qy, qz, qw] = frame.pose.quat_xyzw();
        let mut fields = vec![timestamp_text(frame, i)];
        fields.extend([x, y, z, qx, qy, qz, qw].map(fmt_f64));
        out.push_str(&fields.join(" "));
        out.push('\n');
    }
    write_text_atomic(path, &out)
}

/// The timestamp field of frame number `index`: the name's own text when it is the same number
/// as `t` (keeps `1700000000.000000` as written), else `t`, else the index.
fn timestamp_text(frame: &PoseFrame, index: usize) -> String {
    match frame.t {
        Some(t) if frame.name.parse::<f64>().map(f64::to_bits) == Ok(t.to_bits()) => {
            frame.name.clone()
        }
        Some(t) => fmt_f64(t),
        None => index.to_string(),
    }
}

/// Pairs of `(gt_index, est_index)` whose timestamps are nearest each other within `max_diff`
/// seconds, exactly as the reference `tools/peers/metrics.py::associate_time` does it (evo's
/// `associate_trajectories` rule; the two agree whenever the stamps are sorted):
///
/// - the **shorter** list is iterated (the estimate's when both have the same length), in its
///   own order, which is the order of the returned pairs;
/// - each of its stamps takes the nearest stamp of the other list; of two equally near stamps
///   the earlier one wins (for identical duplicate stamps, the last of them in the input, as
///   numpy's stable `argsort` + `searchsorted(side="right")` does);
/// - the pair is kept when `|Δt| ≤ max_diff`. A stamp of the longer list may be used by several
///   pairs; pairs are not made one-to-one (evo does not either). Non-finite stamps never match.
pub fn associate(gt_times: &[f64], est_times: &[f64], max_diff: f64) -> Vec<(usize, usize)> {
    // evo: when the estimate is longer, the ground truth is the short list that is iterated.
    let gt_short = gt_times.len() < est_times.len();
    let (short, long) = if gt_short {
        (gt_times, est_times)
    } else {
        (est_times, gt_times)
    };
    let mut order: Vec<usize> = (0..long.len()).collect();
    // Stable, with NaN last, like numpy's argsort(kind="stable").
    order.sort_by(|&i, &j| cmp_nan_last(long[i], long[j]));
    let sorted: Vec<f64> = order.iter().map(|&k| long[k]).collect();
    let mut pairs = Vec::new();
    for (i, &s) in short.iter().enumerate() {
        let Some(k) = nearest_sorted(&sorted, s) else {
            continue;
        };
        if (sorted[k] - s).abs() <= max_diff {
            pairs.push(if gt_short {
                (i, order[k])
            } else {
                (order[k], i)
            });
        }
    }
    pairs
}

/// Index in `sorted` of the value nearest `s`, the earlier on a tie; `None` when empty.
fn nearest_sorted(sorted: &[f64], s: f64) -> Option<usize> {
    // numpy's searchsorted(side="right"): the first index whose value is greater than `s`.
    let j = sorted.partition_point(|&v| v <= s);
    let below = j.checked_sub(1);
    let above = (j < sorted.len()).then_some(j);
    match (below, above) {
        // min over (|Δ|, index): the later candidate wins only when strictly nearer.
        (Some(b), Some(a)) if (sorted[a] - s).abs() < (sorted[b] - s).abs() => Some(a),
        (Some(b), _) => Some(b),
        (None, a) => a,
    }
}

fn cmp_nan_last(a: f64, b: f64) -> std::cmp::Ordering {
    use std::cmp::Ordering;
    match (a.is_nan(), b.is_nan()) {
        (false, false) => a.partial_cmp(&b).unwrap_or(Ordering::Equal),
        (true, true) => Ordering::Equal,
        (true, false) => Ordering::Greater,
        (false, true) => Ordering::Less,
    }
}

#[cfg(test)]
pub(crate) mod tests {
    use super::*;
    use crate::test_util::{put, shared, tmp};
    use geom::rotation::rotation_angle;
    use nalgebra::UnitQuaternion;

    const PEER_GT: &str = "tools/peers/testdata/traj/gt.tum";

    #[test]
    fn hand_written_tum_file() -> Result<()> {
        let dir = tmp()?;
        // As the TUM benchmark ships them: comments, then stamp, position, quaternion x y z w.
        // Line 4 is a camera at (1, 2, 3) looking along world +x, level: its axes in the world
        // are x_cam = −y, y_cam = −z, z_cam = +x, i.e. R = [0 0 1; −1 0 0; 0 −1 0], whose
        // quaternion (worked out by hand: w = ½·√(1 + trace) = ½, x = (R32 − R23)/4w = −½,
        // y = (R13 − R31)/4w = ½, z = (R21 − R12)/4w = −½) is x y z w = −0.5 0.5 −0.5 0.5.
        let p = put(
            dir.path(),
            "groundtruth.txt",
            "# ground truth trajectory\n# file: 'rgbd_dataset_freiburg1_xyz.bag'\n\
             # timestamp tx ty tz qx qy qz qw\n\
             1305031102.175304 1 2 3 -0.5 0.5 -0.5 0.5\n\
             \n\
             1305031102.211214 1.3434 0.6126 1.6597 0.6583 0.6112 -0.2938 -0.3266\n",
        )?;
        let traj = read(&p)?;
        assert_eq!(traj.len(), 2);
        assert!(traj.camera.is_none());
        let f = &traj.frames[0];
        assert_eq!(f.name, "1305031102.175304");
        assert_eq!(f.seq, "groundtruth");
        assert_eq!(f.t, Some(1305031102.175304));
        assert_eq!(f.pose.position(), [1.0, 2.0, 3.0]);
        // Identity conversion: the camera looks along +x, its right is −y and its down is −z.
        let r = f.pose.rotation_matrix();
        assert!((f.pose.forward() - Vector3::x()).norm() < 1e-15);
        assert!((r * Vector3::x() + Vector3::y()).norm() < 1e-15);
        assert!((r * Vector3::y() + Vector3::z()).norm() < 1e-15);
        assert_eq!(f.pose.quat_wxyz(), [0.5, -0.5, 0.5, -0.5]);
        Ok(())
    }

    #[test]
    fn reads_peer_reference_file() -> Result<()> {
        let traj = read(&shared(PEER_GT))?;
        assert_eq!(traj.len(), 120);
        let f = &traj.frames[0];
        assert_eq!(f.name, "1700000000.000000");
        assert_eq!(f.seq, "gt");
        assert_eq!(f.t, Some(1.7e9));
        assert_eq!(f.pose.position(), [3.0, 0.0, 1.5]);
        // The file's first quaternion x y z w = 0.010606204 −0.010606204 0.707027233 0.707027233
        // (9 decimals, normalised on reading): about 90° of yaw.
        let q = f.pose.quat_xyzw();
        let written = [0.010606204, -0.010606204, 0.707027233, 0.707027233];
        for (a, b) in q.iter().zip(written) {
            assert!((a - b).abs() < 1e-9, "{q:?}");
        }
        assert_eq!(traj.frames[119].name, "1700000011.900000");
        Ok(())
    }

    /// Poses covering the awkward cases: w < 0 (the writer flips to w ≥ 0), tiny and huge
    /// numbers, negative zero, many irrational components.
    pub(crate) fn awkward_poses() -> Result<Vec<Pose>> {
        let mut poses = Vec::new();
        for k in 0..40 {
            let a = k as f64 * 0.77;
            let mut p = Pose::from_euler_ypr(
                a - 15.0,
                (a * 0.3).sin(),
                a.cos() * 3.0,
                [a.sin() * 1e3, -a / 7.0, 1e-300 * a],
            )
            .map_err(|e| DataError::invalid("test", e.to_string()))?;
            if k % 3 == 0 {
                p.rotation = UnitQuaternion::new_unchecked(-p.rotation.into_inner());
            }
            poses.push(p);
        }
        poses.push(Pose::new(
            UnitQuaternion::identity(),
            Vector3::new(-0.0, 1e20, 5e-324),
        ));
        Ok(poses)
    }

    #[test]
    fn round_trip_is_bit_exact() -> Result<()> {
        let dir = tmp()?;
        let frames = awkward_poses()?
            .into_iter()
            .enumerate()
            .map(|(i, pose)| PoseFrame {
                name: format!("{:.6}", 1.7e9 + i as f64 * 0.1),
                seq: "walk".into(),
                t: Some(1.7e9 + i as f64 * 0.1),
                pose,
            })
            .collect();
        let traj = Trajectory::new(frames);
        let p = dir.path().join("walk.tum");
        write(&traj, &p)?;
        let back = read(&p)?;
        assert_eq!(back.len(), traj.len());
        for (a, b) in traj.frames.iter().zip(&back.frames) {
            // Names that are the timestamp's own text are kept (as are the `t` values).
            assert_eq!(a.name, b.name);
            assert_eq!(b.seq, "walk");
            assert_eq!(a.t.map(f64::to_bits), b.t.map(f64::to_bits));
            // Positions and quaternion components (as written, w ≥ 0): bit for bit.
            assert_eq!(
                a.pose.position().map(f64::to_bits),
                b.pose.position().map(f64::to_bits)
            );
            assert_eq!(
                a.pose.quat_xyzw().map(f64::to_bits),
                b.pose.quat_xyzw().map(f64::to_bits)
            );
        }
        // Writing what was read gives the same file again.
        let again = dir.path().join("again.tum");
        write(&back, &again)?;
        assert_eq!(read_text(&p)?, read_text(&again)?);
        assert!(read_text(&p)?.starts_with(HEADER));
        Ok(())
    }

    #[test]
    fn names_and_missing_timestamps() -> Result<()> {
        let dir = tmp()?;
        let pose = Pose::identity();
        let frame = |name: &str, t| PoseFrame {
            name: name.into(),
            seq: "s".into(),
            t,
            pose,
        };
        let traj = Trajectory::new(vec![
            frame("1700000000.000000", Some(1.7e9)),
            frame("000001", None),
            frame("img.png", Some(0.25)),
        ]);
        let p = dir.path().join("x.txt");
        write(&traj, &p)?;
        let text = read_text(&p)?;
        let stamps: Vec<&str> = text
            .lines()
            .skip(1)
            .filter_map(|l| l.split(' ').next())
            .collect();
        // name kept as written; the frame index where t is missing; else t.
        assert_eq!(stamps, ["1700000000.000000", "1", "0.25"]);
        Ok(())
    }

    #[test]
    fn malformed_files_name_file_and_line() -> Result<()> {
        let dir = tmp()?;
        let cases = [
            (
                "cols.txt",
                "# c\n1 2 3 4 5 6 7\n",
                ":2: a TUM line needs 8 fields",
            ),
            (
                "nan.txt",
                "0 0 0 0 0 0 0 1\n1 NaN 0 0 0 0 0 1\n",
                ":2: non-finite value 'NaN'",
            ),
            (
                "word.txt",
                "\n\n0 0 0 zero 0 0 0 1\n",
                ":3: 'zero' is not a number",
            ),
            ("unit.txt", "0 0 0 0 0 0 0 2\n", ":1: quaternion norm"),
            ("zero.txt", "0 0 0 0 0 0 0 0\n", ":1: quaternion norm"),
            (
                "junk.txt",
                "\u{1}\u{2}garbage\u{7f}\n",
                ":1: a TUM line needs 8 fields",
            ),
            ("empty.txt", "", ": no poses"),
            ("comments.txt", "# only\n\n", ": no poses"),
        ];
        for (name, text, want) in cases {
            let p = put(dir.path(), name, text)?;
            let msg = read(&p).map(|_| ()).unwrap_err().to_string();
            assert!(msg.starts_with(&p.display().to_string()), "{msg}");
            assert!(msg.contains(want), "{name}: {msg}");
        }
        let bin = dir.path().join("bin.tum");
        std::fs::write(&bin, [0x00, 0xff, 0xfe, 0x80, 0x12]).map_err(|e| DataError::io(&bin, e))?;
        let msg = read(&bin).map(|_| ()).unwrap_err().to_string();
        assert!(
            msg.contains("bin.tum") && msg.contains("not a text file"),
            "{msg}"
        );
        assert!(read(&dir.path().join("missing.tum")).is_err());
        Ok(())
    }

    #[test]
    fn writer_refuses_what_it_cannot_read_back() -> Result<()> {
        let dir = tmp()?;
        let p = dir.path().join("o.tum");
        assert!(write(&Trajectory::default(), &p).is_err());
        let mut pose = Pose::identity();
        pose.translation.x = f64::NAN;
        let traj = Trajectory::new(vec![PoseFrame {
            name: "a".into(),
            seq: "s".into(),
            t: Some(0.0),
            pose,
        }]);
        let msg = write(&traj, &p).map(|_| ()).unwrap_err().to_string();
        assert!(msg.contains("non-finite") && msg.contains("'a'"), "{msg}");
        assert!(!p.exists());
        Ok(())
    }

    #[test]
    fn associate_matches_evo_by_hand() {
        // Estimate shorter → the estimate is iterated, in its own order; gt may be unsorted.
        // est 1.04 → gt 1.0 (index 1, Δ 0.04); est 2.96 → gt 3.0 (index 0, Δ 0.04);
        // est 7.0 → nearest gt 3.0 is 4 s away → no pair.
        let gt = [3.0, 1.0, 2.0, 0.0];
        let est = [1.04, 2.96, 7.0];
        assert_eq!(associate(&gt, &est, 0.05), vec![(1, 0), (0, 1)]);
        // Tie: est 2.5 is 0.5 from gt 2.0 and 3.0 → the earlier stamp (2.0, index 2) wins;
        // |Δ| ≤ max_diff is inclusive.
        assert_eq!(associate(&gt, &[2.5], 0.5), vec![(2, 0)]);
        assert_eq!(associate(&gt, &[2.5], 0.49), vec![]);
        // Ground truth shorter → gt is iterated: gt 1.0 between est 0.5 and 1.5 → earlier (0).
        assert_eq!(associate(&[1.0], &[0.5, 1.5, 9.0], 0.5), vec![(0, 0)]);
        // Same length → the estimate is iterated, so two estimates may share one gt stamp:
        // est 0.01 and 0.02 both → gt 0.0; gt 1.0 stays unmatched. (Iterating gt instead
        // would give only (0, 0).)
        assert_eq!(
            associate(&[0.0, 1.0], &[0.01, 0.02], 0.1),
            vec![(0, 0), (0, 1)]
        );
        // Duplicate stamps in the long list: numpy's searchsorted(side="right") lands after
        // them, so the last duplicate is taken.
        assert_eq!(associate(&[5.0, 5.0, 6.0], &[5.0], 0.1), vec![(1, 0)]);
        // Empty lists and non-finite stamps give no pairs.
        assert_eq!(associate(&[], &[1.0], 1.0), vec![]);
        assert_eq!(associate(&[f64::NAN, 1.0], &[f64::NAN], 1.0), vec![]);
    }

    #[test]
    fn associate_peer_files() -> Result<()> {
        let gt = read(&shared(PEER_GT))?;
        let est = read(&shared(&PEER_GT.replace("gt.tum", "est.tum")))?;
        let times = |t: &Trajectory| t.frames.iter().filter_map(|f| f.t).collect::<Vec<_>>();
        let pairs = associate(&times(&gt), &times(&est), 0.01);
        // est.tum holds 114 of the 120 frames, stamps jittered by < 4 ms: all of them match,
        // each to the gt frame it was made from (its name ends in the same tenth of a second).
        assert_eq!(est.len(), 114);
        assert_eq!(pairs.len(), 114);
        for (g, e) in pairs {
            let dt = gt.frames[g].t.unwrap_or(f64::NAN) - est.frames[e].t.unwrap_or(f64::NAN);
            assert!(dt.abs() < 0.005, "{g} {e}");
        }
        Ok(())
    }

    #[test]
    fn quaternion_kept_as_written_only_at_machine_precision() -> Result<()> {
        let geom_err = |e: geom::GeomError| DataError::invalid("q", e.to_string());
        // 0.6² + 0.8² is 1 to the last bit or two: kept exactly as written.
        let q = geom::rotation::quat_from_wxyz([0.6, 0.8, 0.0, 0.0]).map_err(geom_err)?;
        assert_eq!(q.coords.as_slice(), &[0.8, 0.0, 0.0, 0.6]);
        // Rounded to 4 decimals elsewhere: normalised.
        let rounded = geom::rotation::quat_from_wxyz([0.6, 0.8001, 0.0, 0.0]).map_err(geom_err)?;
        assert_ne!(rounded.i, 0.8001);
        assert!((rounded.norm() - 1.0).abs() < 1e-15);
        assert!(rotation_angle(&(q.inverse() * rounded)) < 1e-3);
        for v in [0.1, -0.0, 1e-7, 1e16, 5e-324, f64::MAX, 1.7e9 + 0.1] {
            assert_eq!(
                fmt_f64(v).parse::<f64>().map(f64::to_bits),
                Ok(v.to_bits()),
                "{v}"
            );
        }
        assert_eq!(fmt_f64(0.25), "0.25");
        assert_eq!(fmt_f64(1e-300), "1e-300");
        Ok(())
    }
}
