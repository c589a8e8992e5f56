//! 3-DoF robot logs: a CSV of floor poses with the localizer's covariance, recorded by robots
//! whose camera looks straight up at the ceiling.
//!
//! # Format
//! A header naming the columns (any order, extra columns ignored, names case-insensitive):
//! `t,x,y,theta` required, `sxx,syy,stt` optional (all three or none). `t` is seconds, `x, y`
//! metres, `theta` the heading in radians, `sxx, syy` the variances of x and y (m²) and `stt` the
//! variance of theta (rad²), the diagonal of the pose covariance. A row whose three covariance
//! cells are empty has no covariance. Variances must be finite and ≥ 0.
//!
//! # Conversion
//! `theta` is the heading of the *ceiling* camera ([`Mount::Ceiling`]): the yaw of the image's up
//! axis, as DESIGN.md defines it; it is wrapped to (−π, π] (a value already there is kept bit for
//! bit). [`read()`] turns each entry into the level 6-DoF pose `Pose3::to_pose(Mount::Ceiling, 0.0)`:
//! the camera looks along world +z and, as the log has no height, sits at z = 0.
//! In the [`Trajectory`], `name` is the `t` cell exactly as written (so frames match other files
//! by the same text), `seq` is `"robotlog"`, `t` the parsed time. Time stamps must be unique.
//!
//! # Filtering
//! Localizer fixes with a large covariance are unreliable ground truth. [`CovarianceFilter`]
//! drops an entry when `sxx` or `syy` exceeds 0.15 m² or `stt` exceeds 0.1 rad² (defaults);
//! entries without covariance are kept, since nothing says they are bad.

use crate::csv_table::{CsvTable, cell, csv_bytes};
use crate::error::{DataError, Result};
use crate::io::{parse_numbers, write_atomic};
use crate::trajectory::{PoseFrame, Trajectory};
use geom::{Mount, Pose3};
use std::collections::HashMap;
use std::path::Path;

/// Sequence name of the frames of a robot log.
pub const SEQ: &str = "robotlog";

/// One row of a robot log.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct RobotLogEntry {
    /// Time stamp, seconds.
    pub t: f64,
    /// Floor pose; the heading is the ceiling camera's (see the module doc).
    pub pose: Pose3,
    /// Variances `[sxx (m²), syy (m²), stt (rad²)]`, when logged.
    pub cov: Option<[f64; 3]>,
}

/// Drops entries whose covariance says the localizer was unsure.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct CovarianceFilter {
    /// Largest accepted variance of x, m².
    pub max_sxx: f64,
    /// Largest accepted variance of y, m².
    pub max_syy: f64,
    /// Largest accepted variance of the heading, rad².
    pub max_stt: f64,
}

impl Default for CovarianceFilter {
    /// 0.15 m², 0.15 m², 0.1 rad².
    fn default() -> Self {
        Self {
            max_sxx: 0.15,
            max_syy: 0.15,
            max_stt: 0.1,
        }
    }
}

impl CovarianceFilter {
    /// True when the entry is kept: no covariance, or every variance at most its maximum.
    pub fn keep(&self, e: &RobotLogEntry) -> bool {
        match e.cov {
            None => true,
            Some([sxx, syy, stt]) => {
                sxx <= self.max_sxx && syy <= self.max_syy && stt <= self.max_stt
            }
        }
    }
}

/// Reads a robot log; errors name the file and line.
pub fn read_log(path: &Path) -> Result<Vec<RobotLogEntry>> {
    Ok(read_rows(path)?.into_iter().map(|(_, e)| e).collect())
}

/// Reads a robot log as a trajectory of every entry (see the module doc for the conversion).
pub fn read(path: &Path) -> Result<Trajectory> {
    Ok(read_filtered(path, &keep_all())?.0)
}

/// Reads a robot log as a trajectory of the entries `filter` keeps, and how many it dropped.
pub fn read_filtered(path: &Path, filter: &CovarianceFilter) -> Result<(Trajectory, usize)> {
    let rows = read_rows(path)?;
    let total = rows.len();
    let frames: Vec<PoseFrame> = rows
        .into_iter()
        .filter(|(_, e)| filter.keep(e))
        .map(|(name, e)| PoseFrame {
            name,
            seq: SEQ.to_string(),
            t: Some(e.t),
            pose: e.pose.to_pose(Mount::Ceiling, 0.0),
        })
        .collect();
    let dropped = total - frames.len();
    Ok((Trajectory::new(frames), dropped))
}

/// Writes a robot log atomically: `t,x,y,theta`, plus `sxx,syy,stt` when any entry has a
/// covariance (empty cells for those without). Numbers use shortest round-trip formatting, so
/// [`read_log`] gives the entries back exactly.
pub fn write_log(entries: &[RobotLogEntry], path: &Path) -> Result<()> {
    for e in entries {
        let cov = e.cov.unwrap_or_default();
        let values = [e.t, e.pose.x, e.pose.y, e.pose.heading];
        if !values.iter().chain(&cov).all(|v| v.is_finite()) {
            let msg = format!("entry at t = {} holds a non-finite number", e.t);
            return Err(DataError::invalid(path, msg));
        }
    }
    let with_cov = entries.iter().any(|e| e.cov.is_some());
    let header: &[&str] = if with_cov {
        &["t", "x", "y", "theta", "sxx", "syy", "stt"]
    } else {
        &["t", "x", "y", "theta"]
    };
    let rows = entries
        .iter()
        .map(|e| {
            let mut row: Vec<String> = [e.t, e.pose.x, e.pose.y, e.pose.heading]
                .iter()
                .map(f64::to_string)
                .collect();
            if with_cov {
                match e.cov {
                    Some(c) => row.extend(c.iter().map(f64::to_string)),
                    None => row.extend(std::iter::repeat_n(String::new(), 3)),
                }
            }
            row
        })
        .collect();
    let bytes = csv_bytes(path, header, rows)?;
    write_atomic(path, |w| w.write_all(&bytes))
}

/// A filter that keeps everything.
fn keep_all() -> CovarianceFilter {
    CovarianceFilter {
        max_sxx: f64::INFINITY,
        max_syy: f64::INFINITY,
        max_stt: f64::INFINITY,
    }
}

/// The entries with their `t` cell as written.
fn read_rows(path: &Path) -> Result<Vec<(String, RobotLogEntry)>> {
    let table = CsvTable::read(path)?;
    let cols = table.columns(&["t", "x", "y", "theta"])?;
    let cov_cols = covariance_columns(&table)?;
    let mut first_line: HashMap<String, usize> = HashMap::new();
    let mut rows = Vec::with_capacity(table.rows.len());
    for (line, row) in &table.rows {
        let line = *line;
        let fields: Vec<&str> = cols.iter().map(|&c| cell(row, c)).collect();
        let v = parse_numbers(path, line, &fields)?;
        let t_text = fields[0].to_string();
        if let Some(first) = first_line.insert(t_text.clone(), line) {
            let msg = format!("time stamp {t_text} appears twice (also on line {first})");
            return Err(DataError::parse(path, line, msg));
        }
        let cov = match &cov_cols {
            Some(c) => covariance(
                path,
                line,
                [cell(row, c[0]), cell(row, c[1]), cell(row, c[2])],
            )?,
            None => None,
        };
        let entry = RobotLogEntry {
            t: v[0],
            pose: pose3(v[1], v[2], v[3])
                .map_err(|e| DataError::parse(path, line, e.to_string()))?,
            cov,
        };
        rows.push((t_text, entry));
    }
    if rows.is_empty() {
        return Err(DataError::invalid(path, "no entries"));
    }
    Ok(rows)
}

/// The three covariance columns, all or none.
fn covariance_columns(table: &CsvTable) -> Result<Option<Vec<usize>>> {
    let names = ["sxx", "syy", "stt"];
    let present = names
        .iter()
        .filter(|n| table.optional_column(n).is_some())
        .count();
    match present {
        0 => Ok(None),
        _ => table.columns(&names).map(Some),
    }
}

/// A row's variances: three empty cells are `None`; otherwise three finite numbers ≥ 0.
fn covariance(path: &Path, line: usize, cells: [&str; 3]) -> Result<Option<[f64; 3]>> {
    if cells.iter().all(|c| c.is_empty()) {
        return Ok(None);
    }
    let v = parse_numbers(path, line, &cells)?;
    if let Some(neg) = v.iter().find(|&&s| s < 0.0) {
        return Err(DataError::parse(
            path,
            line,
            format!("negative variance {neg}"),
        ));
    }
    Ok(Some([v[0], v[1], v[2]]))
}

/// A floor pose; a heading already in (−π, π] is kept as written so write → read is exact
/// (wrapping it again could move its last bit).
fn pose3(x: f64, y: f64, heading: f64) -> geom::Result<Pose3> {
    use std::f64::consts::PI;
    let p = Pose3::new(x, y, heading)?;
    if heading > -PI && heading <= PI {
        Ok(Pose3 { x, y, heading })
    } else {
        Ok(p)
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::test_util::{put, tmp};
    use nalgebra::Vector3;

    #[test]
    fn hand_checked_log() -> Result<()> {
        let dir = tmp()?;
        // Columns out of order. Row 1: heading π/2 for a ceiling camera means the image's up
        // axis (OpenCV −y) points along world +y, so y = (0, −1, 0); the camera looks up,
        // z = (0, 0, 1); and x = y × z = (−1, 0, 0). Row 2 has a large x variance; row 3 has
        // no covariance and a heading of 4 rad, wrapped to 4 − 2π.
        let p = put(
            dir.path(),
            "log.csv",
            "x,theta,t,y,stt,sxx,syy\n\
             1.5,1.5707963267948966,0.10,2,0.01,0.02,0.03\n\
             3,0,0.20,4,0.01,0.2,0.01\n\
             5,4,0.30,6,,,\n",
        )?;
        let log = read_log(&p)?;
        assert_eq!(log.len(), 3);
        assert_eq!(log[0].cov, Some([0.02, 0.03, 0.01]));
        assert_eq!(log[2].cov, None);
        assert!((log[2].pose.heading - (4.0 - 2.0 * std::f64::consts::PI)).abs() < 1e-15);
        let traj = read(&p)?;
        let f = &traj.frames[0];
        assert_eq!(
            (f.name.as_str(), f.seq.as_str(), f.t),
            ("0.10", SEQ, Some(0.1))
        );
        assert_eq!(f.pose.position(), [1.5, 2.0, 0.0]);
        let r = f.pose.rotation_matrix();
        assert!((r.column(0) - Vector3::new(-1.0, 0.0, 0.0)).amax() < 1e-15);
        assert!((r.column(1) - Vector3::new(0.0, -1.0, 0.0)).amax() < 1e-15);
        assert!((f.pose.forward() - Vector3::z()).amax() < 1e-15);
        // The default filter drops row 2 (sxx 0.2 > 0.15 m²) and keeps row 3 (no covariance).
        let (kept, dropped) = read_filtered(&p, &CovarianceFilter::default())?;
        assert_eq!(dropped, 1);
        let names: Vec<&str> = kept.frames.iter().map(|f| f.name.as_str()).collect();
        assert_eq!(names, ["0.10", "0.30"]);
        Ok(())
    }

    #[test]
    fn filter_thresholds() {
        let f = CovarianceFilter::default();
        let e = |cov| RobotLogEntry {
            t: 0.0,
            pose: Pose3 {
                x: 0.0,
                y: 0.0,
                heading: 0.0,
            },
            cov,
        };
        assert!(f.keep(&e(Some([0.15, 0.15, 0.1]))));
        assert!(!f.keep(&e(Some([0.151, 0.0, 0.0]))));
        assert!(!f.keep(&e(Some([0.0, 0.16, 0.0]))));
        assert!(!f.keep(&e(Some([0.0, 0.0, 0.11]))));
        assert!(f.keep(&e(None)));
    }

    #[test]
    fn round_trip_is_exact() -> Result<()> {
        let mut entries = Vec::new();
        for i in 0..7 {
            let a = i as f64;
            entries.push(RobotLogEntry {
                t: 1.0e9 + a / 30.0,
                pose: Pose3::new(a / 7.0, -a * 0.1, a - 3.0)
                    .map_err(|e| DataError::invalid("test", e.to_string()))?,
                cov: (i % 3 != 0).then_some([a * 0.01, 1.0 / 3.0, 1e-7]),
            });
        }
        let dir = tmp()?;
        let p = dir.path().join("out/log.csv");
        write_log(&entries, &p)?;
        assert_eq!(read_log(&p)?, entries);
        let no_cov: Vec<RobotLogEntry> = entries
            .iter()
            .map(|e| RobotLogEntry { cov: None, ..*e })
            .collect();
        write_log(&no_cov, &p)?;
        assert_eq!(read_log(&p)?, no_cov);
        let mut bad = no_cov.clone();
        bad[2].cov = Some([0.1, f64::NAN, 0.1]);
        assert!(write_log(&bad, &p).is_err());
        assert_eq!(read_log(&p)?, no_cov, "a refused write leaves the old file");
        Ok(())
    }

    #[test]
    fn malformed_logs_are_errors() -> Result<()> {
        let dir = tmp()?;
        let cases = [
            ("t,x,y\n0,1,2\n", ":1:", "missing column(s) theta"),
            ("t,x,y,theta,sxx\n0,1,2,3,0.1\n", ":1:", "syy,stt"),
            ("t,x,y,theta\n0,1,2,3\n1,1,NaN,3\n", ":3:", "non-finite"),
            ("t,x,y,theta\n0,1,2,3\n0,1,2,3\n", ":3:", "appears twice"),
            (
                "t,x,y,theta,sxx,syy,stt\n0,1,2,3,0.1,,0.1\n",
                ":2:",
                "'' is not a number",
            ),
            (
                "t,x,y,theta,sxx,syy,stt\n0,1,2,3,0.1,-1,0.1\n",
                ":2:",
                "negative variance",
            ),
            ("t,x,y,theta\n0,1,2\n", ":2:", "3 fields"),
            ("", ":1:", "empty file"),
            ("t,x,y,theta\n", "", "no entries"),
        ];
        for (text, line, msg) in cases {
            let p = put(dir.path(), "log.csv", text)?;
            let e = read_log(&p)
                .err()
                .map(|e| e.to_string())
                .unwrap_or_default();
            assert!(
                e.contains(&format!("log.csv{line}")) && e.contains(msg),
                "{text:?}: {e}"
            );
        }
        let p = dir.path().join("log.csv");
        std::fs::write(&p, [b't', 0xff, 0x00, 0x80]).map_err(|e| DataError::io(&p, e))?;
        let e = read(&p).err().map(|e| e.to_string()).unwrap_or_default();
        assert!(
            e.contains("log.csv") && e.contains("not a text file"),
            "{e}"
        );
        Ok(())
    }
}
