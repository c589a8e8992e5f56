//! JSON lines of poses, as `indoorloc localize` prints them: one object per line with
//! `frame` (image file stem or frame index), `position` `[x, y, z]` (metres, camera centre),
//! `quaternion` `[w, x, y, z]` (camera-to-world, DESIGN.md's conventions, so no conversion), and
//! optionally `t` (seconds), `seq`, `cov_pos_m2` (3x3 position covariance, m², row-major; read
//! by [`read_with_covariance`]), `sigma_pos_m`, `latency_ms` and more, which this reader
//! ignores.

use crate::error::{DataError, Result};
use crate::io::{read_text, write_atomic};
use crate::trajectory::{PoseFrame, Trajectory};
use geom::Pose;
use serde::{Deserialize, Serialize};
use std::path::Path;

/// The fields of one line that carry a pose.
#[derive(Debug, Serialize, Deserialize)]
struct PoseLine {
    /// A number (frame index) or a string (file stem).
    frame: serde_json::Value,
    position: [f64; 3],
    quaternion: [f64; 4],
    #[serde(default, skip_serializing_if = "Option::is_none")]
    t: Option<f64>,
    #[serde(default, skip_serializing_if = "Option::is_none")]
    seq: Option<String>,
    #[serde(default, skip_serializing_if = "Option::is_none")]
    cov_pos_m2: Option<[f64; 9]>,
}

/// Reads pose JSON lines; blank lines are skipped, any other line must be a pose object.
pub fn read(path: &Path) -> Result<Trajectory> {
    read_with_covariance(path).map(|(t, _)| t)
}

/// [`read`], with each frame's `cov_pos_m2` where its line has one (row-major, m²). A
/// covariance that is not symmetric with a non-negative, finite diagonal is an error naming
/// the line.
pub fn read_with_covariance(path: &Path) -> Result<(Trajectory, Vec<Option<[f64; 9]>>)> {
    let text = read_text(path)?;
    let mut frames = Vec::new();
    let mut covariances = Vec::new();
    for (i, line) in text.lines().enumerate() {
        let line_no = i + 1;
        if line.trim().is_empty() {
            continue;
        }
        let p: PoseLine = serde_json::from_str(line)
            .map_err(|e| DataError::parse(path, line_no, format!("not a pose JSON line: {e}")))?;
        let name = match &p.frame {
            serde_json::Value::String(s) => s.clone(),
            serde_json::Value::Number(n) => n.to_string(),
            other => {
                return Err(DataError::parse(
                    path,
                    line_no,
                    format!("'frame' must be a string or a number, got {other}"),
                ));
            }
        };
        let pose = Pose::from_t_wxyz(p.position, p.quaternion)
            .map_err(|e| DataError::parse(path, line_no, e.to_string()))?;
        if let Some(c) = &p.cov_pos_m2 {
            // Symmetric up to rounding: a covariance from a Jacobian differs by 1e-24 m².
            let scale = (0..3)
                .map(|i| c[4 * i].abs())
                .fold(f64::MIN_POSITIVE, f64::max);
            let symmetric =
                (0..3).all(|i| (0..3).all(|j| (c[3 * i + j] - c[3 * j + i]).abs() <= 1e-9 * scale));
            let diagonal = (0..3).all(|i| c[4 * i].is_finite() && c[4 * i] >= 0.0);
            if !(symmetric && diagonal && c.iter().all(|v| v.is_finite())) {
                return Err(DataError::parse(
                    path,
                    line_no,
                    format!(
                        "'cov_pos_m2' must be a symmetric 3x3 matrix with a finite, \
                         non-negative diagonal: {c:?}"
                    ),
                ));
            }
        }
        covariances.push(p.cov_pos_m2);
        frames.push(PoseFrame {
            name,
            seq: p.seq.unwrap_or_default(),
            t: p.t,
            pose,
        });
    }
    if frames.is_empty() {
        return Err(DataError::invalid(path, "no poses"));
    }
    Ok((Trajectory::new(frames), covariances))
}

/// Writes one pose object per line (`frame`, `position`, `quaternion`, `t` and `seq` where known).
pub fn write(traj: &Trajectory, path: &Path) -> Result<()> {
    write_atomic(path, |w| {
        for f in &traj.frames {
            let line = PoseLine {
                frame: serde_json::Value::String(f.name.clone()),
                position: f.pose.position(),
                quaternion: f.pose.quat_wxyz(),
                t: f.t,
                seq: (!f.seq.is_empty()).then(|| f.seq.clone()),
                cov_pos_m2: None,
            };
            serde_json::to_writer(&mut *w, &line)?;
            w.write_all(b"\n")?;
        }
        Ok(())
    })
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn reads_localize_output_and_round_trips() -> Result<()> {
        let dir = crate::test_util::tmp()?;
        let p = dir.path().join("est.jsonl");
        std::fs::write(
            &p,
            "{\"frame\":12,\"position\":[1,2,3],\"quaternion\":[0,0,0,1],\"sigma_pos_m\":0.2,\"latency_ms\":3.1}\n\n\
             {\"frame\":\"000013\",\"position\":[1.5,2,3],\"quaternion\":[1,0,0,0],\"t\":0.5}\n",
        )
        .map_err(|e| DataError::io(&p, e))?;
        let t = read(&p)?;
        assert_eq!(t.len(), 2);
        assert_eq!(t.frames[0].name, "12");
        // quaternion [w=0, x=0, y=0, z=1]: 180° about z
        let r = t.frames[0].pose.rotation_matrix();
        assert!((r[(0, 0)] + 1.0).abs() < 1e-12 && (r[(1, 1)] + 1.0).abs() < 1e-12);
        assert_eq!(t.frames[1].t, Some(0.5));
        let (_, cov) = read_with_covariance(&p)?;
        assert_eq!(cov, vec![None, None]);
        std::fs::write(
            &p,
            "{\"frame\":1,\"position\":[1,2,3],\"quaternion\":[1,0,0,0],\"cov_pos_m2\":[1,0.5,0,0.5000000000000001,2,0,0,0,3]}\n",
        )
        .map_err(|e| DataError::io(&p, e))?;
        let (_, cov) = read_with_covariance(&p)?;
        assert_eq!(
            cov,
            vec![Some([
                1.0,
                0.5,
                0.0,
                0.5000000000000001,
                2.0,
                0.0,
                0.0,
                0.0,
                3.0
            ])]
        );
        let out = dir.path().join("out.jsonl");
        write(&t, &out)?;
        let back = read(&out)?;
        assert_eq!(back.frames[1].pose, t.frames[1].pose);
        assert_eq!(back.frames[0].name, "12");
        Ok(())
    }

    #[test]
    fn bad_lines_name_the_line() -> Result<()> {
        let dir = crate::test_util::tmp()?;
        let p = dir.path().join("bad.jsonl");
        for (content, needle) in [
            (
                "{\"frame\":1,\"position\":[1,2],\"quaternion\":[1,0,0,0]}\n",
                ":1:",
            ),
            (
                "\n{\"frame\":1,\"position\":[1,2,3],\"quaternion\":[2,0,0,0]}\n",
                ":2: quaternion norm",
            ),
            (
                "{\"frame\":null,\"position\":[1,2,3],\"quaternion\":[1,0,0,0]}\n",
                "'frame'",
            ),
            ("", "no poses"),
            (
                "{\"frame\":1,\"position\":[1,2,3],\"quaternion\":[1,0,0,0],\"cov_pos_m2\":[1,2,0,0,1,0,0,0,1]}\n",
                ":1: 'cov_pos_m2' must be a symmetric",
            ),
        ] {
            std::fs::write(&p, content).map_err(|e| DataError::io(&p, e))?;
            let msg = read(&p).unwrap_err().to_string();
            assert!(msg.contains("bad.jsonl") && msg.contains(needle), "{msg}");
        }
        Ok(())
    }
}
