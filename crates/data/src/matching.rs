//! Pairs estimated frames with their ground truth: by frame name where the two share names, by
//! nearest timestamp (TUM, robot logs) otherwise.
//!
//! Names are looked up as `seq/name` first and as the bare name second, because 7-Scenes repeats
//! `frame-000000` in every sequence while a localizer's output often knows only the file stem.

use crate::error::{DataError, Result};
use crate::trajectory::{PoseFrame, Trajectory};
use std::collections::HashMap;
use std::path::Path;

/// How frames were paired.
#[derive(Clone, Copy, Debug, PartialEq, Eq, serde::Serialize)]
#[serde(rename_all = "lowercase")]
pub enum MatchedBy {
    /// Identical frame names.
    Name,
    /// Nearest timestamps within a tolerance.
    Time,
}

/// Index pairs `(gt, est)` into the two trajectories, in ground-truth order.
#[derive(Clone, Debug, PartialEq)]
pub struct Matching {
    /// `(index into gt, index into est)`, sorted by the ground-truth index.
    pub pairs: Vec<(usize, usize)>,
    /// How the pairs were found.
    pub by: MatchedBy,
    /// Estimates without a partner (only in time matching; in name matching they are an error).
    pub unmatched_est: usize,
}

/// Pairs the frames of `est` with those of `gt`. With `prefer_time` (time-keyed formats such as
/// TUM) frames are paired by nearest timestamp within `max_dt` seconds; otherwise by name, where
/// every estimate must name a ground-truth frame.
pub fn match_frames(
    gt: &Trajectory,
    gt_path: &Path,
    est: &Trajectory,
    est_path: &Path,
    prefer_time: bool,
    max_dt: f64,
) -> Result<Matching> {
    let timed = |t: &Trajectory| !t.is_empty() && t.frames.iter().all(|f| f.t.is_some());
    if prefer_time && timed(gt) && timed(est) {
        return match_by_time(gt, est, est_path, max_dt);
    }
    let index = NameIndex::new(gt);
    let any_shared = est.frames.iter().any(|f| index.lookup(f).is_some());
    if !any_shared {
        if timed(gt) && timed(est) {
            return match_by_time(gt, est, est_path, max_dt);
        }
        return Err(DataError::invalid(
            est_path,
            format!(
                "no frame name matches a frame of {} (first estimate '{}'), and there are no \
                 timestamps to match by",
                gt_path.display(),
                est.frames.first().map_or("", |f| f.name.as_str())
            ),
        ));
    }
    let mut seen = vec![false; gt.len()];
    let mut pairs = Vec::with_capacity(est.len());
    for (i, f) in est.frames.iter().enumerate() {
        let g = match index.lookup(f) {
            Some(Some(g)) => g,
            Some(None) => {
                return Err(DataError::invalid(
                    est_path,
                    format!(
                        "frame '{}' (entry {}) is ambiguous: several sequences of {} have it; \
                         give its sequence",
                        f.name,
                        i + 1,
                        gt_path.display()
                    ),
                ));
            }
            None => {
                return Err(DataError::invalid(
                    est_path,
                    format!(
                        "unknown frame '{}' (entry {}): not in the ground truth {}",
                        f.name,
                        i + 1,
                        gt_path.display()
                    ),
                ));
            }
        };
        if std::mem::replace(&mut seen[g], true) {
            return Err(DataError::invalid(
                est_path,
                format!("frame '{}' (entry {}) is estimated twice", f.name, i + 1),
            ));
        }
        pairs.push((g, i));
    }
    pairs.sort_unstable();
    Ok(Matching {
        pairs,
        by: MatchedBy::Name,
        unmatched_est: 0,
    })
}

fn match_by_time(
    gt: &Trajectory,
    est: &Trajectory,
    est_path: &Path,
    max_dt: f64,
) -> Result<Matching> {
    let times = |t: &Trajectory| -> Vec<f64> { t.frames.iter().filter_map(|f| f.t).collect() };
    let mut pairs = crate::tum::associate(&times(gt), &times(est), max_dt);
    if pairs.is_empty() {
        return Err(DataError::invalid(
            est_path,
            format!("no estimate lies within {max_dt} s of a ground-truth timestamp"),
        ));
    }
    pairs.sort_unstable();
    Ok(Matching {
        unmatched_est: est.len() - pairs.len(),
        pairs,
        by: MatchedBy::Time,
    })
}

/// Ground-truth frames by `seq/name` and by bare name (`None` marks a bare name that several
/// sequences share).
struct NameIndex<'a> {
    qualified: HashMap<(&'a str, &'a str), usize>,
    bare: HashMap<&'a str, Option<usize>>,
}

impl<'a> NameIndex<'a> {
    fn new(gt: &'a Trajectory) -> Self {
        let mut qualified = HashMap::with_capacity(gt.len());
        let mut bare: HashMap<&str, Option<usize>> = HashMap::with_capacity(gt.len());
        for (i, f) in gt.frames.iter().enumerate() {
            qualified
                .entry((f.seq.as_str(), f.name.as_str()))
                .or_insert(i);
            bare.entry(f.name.as_str())
                .and_modify(|slot| *slot = None)
                .or_insert(Some(i));
        }
        Self { qualified, bare }
    }

    /// `Some(Some(i))`: found; `Some(None)`: ambiguous bare name; `None`: unknown.
    fn lookup(&self, f: &PoseFrame) -> Option<Option<usize>> {
        if let Some(&i) = self.qualified.get(&(f.seq.as_str(), f.name.as_str())) {
            return Some(Some(i));
        }
        self.bare.get(f.name.as_str()).copied()
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use geom::Pose;

    fn traj(frames: &[(&str, &str, Option<f64>)]) -> Trajectory {
        Trajectory::new(
            frames
                .iter()
                .map(|&(seq, name, t)| PoseFrame {
                    name: name.into(),
                    seq: seq.into(),
                    t,
                    pose: Pose::identity(),
                })
                .collect(),
        )
    }

    #[test]
    fn by_name_with_sequences() -> Result<()> {
        let gt = traj(&[
            ("seq-01", "frame-0", None),
            ("seq-02", "frame-0", None),
            ("seq-02", "frame-1", None),
        ]);
        let est = traj(&[("seq-02", "frame-0", None), ("", "frame-1", None)]);
        let m = match_frames(&gt, Path::new("gt"), &est, Path::new("est"), false, 0.01)?;
        assert_eq!(m.pairs, vec![(1, 0), (2, 1)]);
        assert_eq!(m.by, MatchedBy::Name);
        let ambiguous = traj(&[("", "frame-0", None)]);
        let e = match_frames(
            &gt,
            Path::new("gt"),
            &ambiguous,
            Path::new("est"),
            false,
            0.01,
        );
        assert!(e.unwrap_err().to_string().contains("ambiguous"));
        Ok(())
    }

    #[test]
    fn unknown_and_twice_are_errors() {
        let gt = traj(&[("", "a", None), ("", "b", None)]);
        let est = traj(&[("", "a", None), ("", "zz", None)]);
        let msg = match_frames(
            &gt,
            Path::new("gt"),
            &est,
            Path::new("est.jsonl"),
            false,
            0.01,
        )
        .unwrap_err()
        .to_string();
        assert!(
            msg.starts_with("est.jsonl: unknown frame 'zz' (entry 2)"),
            "{msg}"
        );
        let twice = traj(&[("", "a", None), ("", "a", None)]);
        assert!(match_frames(&gt, Path::new("gt"), &twice, Path::new("e"), false, 0.01).is_err());
        let none = traj(&[("", "q", None)]);
        assert!(match_frames(&gt, Path::new("gt"), &none, Path::new("e"), false, 0.01).is_err());
    }

    #[test]
    fn by_time_when_names_differ() -> Result<()> {
        let gt = traj(&[
            ("", "0.0", Some(0.0)),
            ("", "0.1", Some(0.1)),
            ("", "0.2", Some(0.2)),
        ]);
        let est = traj(&[
            ("", "0.099", Some(0.099)),
            ("", "0.203", Some(0.203)),
            ("", "0.5", Some(0.5)),
        ]);
        let m = match_frames(&gt, Path::new("gt"), &est, Path::new("est"), true, 0.01)?;
        assert_eq!(m.pairs, vec![(1, 0), (2, 1)]);
        assert_eq!((m.by, m.unmatched_est), (MatchedBy::Time, 1));
        Ok(())
    }
}
