//! Scoring detected hard cuts against gold ones, the way the reference figures in
//! `../shared/data/scenecut_*` were made: a detection within ±`tol` frames of an unmatched gold
//! cut is a true positive (one-to-one, nearest pairs first); an unmatched detection inside a gold
//! gradual transition (widened by `tol`) is ignored; other detections are false positives. With
//! no detections precision is 1, with no gold cuts recall is 1.

use crate::error::{CutError, Result};
use serde::{Deserialize, Serialize};
use std::path::Path;

/// Gold transitions of one video.
#[derive(Clone, Debug, Default, PartialEq, Serialize, Deserialize)]
pub struct Gold {
    /// First frames of new shots after hard cuts.
    pub hard_cuts: Vec<u64>,
    /// Gradual transitions, `[first, last]` frames.
    pub gradual: Vec<[u64; 2]>,
}

impl Gold {
    /// Reads gold cuts for `video` from `path`: a `gold.json` of `../shared/data/scenecut_*`
    /// (a `videos` list; the entry whose `file` is `video`'s file name), or any cut list
    /// `data::cuts::read` takes (`cuts.csv`, one number per line, `{"cuts": [...]}`).
    ///
    /// # Errors
    /// Unreadable or malformed files, or a `videos` list without this video.
    pub fn read(path: &Path, video: &Path) -> Result<Gold> {
        let gold_err = |msg: String| CutError::Gold {
            path: path.to_path_buf(),
            msg,
        };
        let text = std::fs::read_to_string(path).map_err(|e| gold_err(e.to_string()))?;
        let doc: Option<serde_json::Value> = serde_json::from_str(&text).ok();
        let Some(videos) = doc.as_ref().and_then(|d| d.get("videos")) else {
            return Ok(Gold {
                hard_cuts: data::cuts::read(path)?,
                gradual: Vec::new(),
            });
        };
        #[derive(Deserialize)]
        struct Span {
            first_frame: u64,
            last_frame: u64,
        }
        #[derive(Deserialize)]
        struct Entry {
            file: String,
            hard_cuts: Vec<u64>,
            #[serde(default)]
            gradual_transitions: Vec<Span>,
        }
        let entries: Vec<Entry> = serde_json::from_value(videos.clone())
            .map_err(|e| gold_err(format!("bad 'videos' list: {e}")))?;
        let name = video.file_name().and_then(|n| n.to_str()).unwrap_or("");
        let entry = entries
            .into_iter()
            .find(|e| e.file == name)
            .ok_or_else(|| gold_err(format!("no entry for '{name}' in 'videos'")))?;
        let mut hard_cuts = entry.hard_cuts;
        hard_cuts.sort_unstable();
        Ok(Gold {
            hard_cuts,
            gradual: entry
                .gradual_transitions
                .iter()
                .map(|s| [s.first_frame, s.last_frame])
                .collect(),
        })
    }
}

/// Precision, recall and F1 of hard cuts.
#[derive(Clone, Debug, PartialEq, Serialize, Deserialize)]
pub struct Score {
    /// Detections matched to a gold cut.
    pub tp: usize,
    /// Detections matched to nothing (outside gradual spans).
    pub fp: usize,
    /// Gold cuts not found.
    #[serde(rename = "fn")]
    pub fn_: usize,
    /// `tp / (tp + fp)`, 1 with no detections.
    pub precision: f64,
    /// `tp / gold`, 1 with no gold cuts.
    pub recall: f64,
    /// Harmonic mean of the two.
    pub f1: f64,
    /// Gold cuts not found.
    pub missed: Vec<u64>,
    /// Detections that count as false positives.
    pub false_positives: Vec<u64>,
}

/// Scores `detected` hard cuts against `gold` with a tolerance of `tol` frames.
pub fn score_hard(detected: &[u64], gold: &Gold, tol: u64) -> Score {
    let mut pairs: Vec<(u64, usize, usize)> = Vec::new();
    for (i, &d) in detected.iter().enumerate() {
        for (j, &g) in gold.hard_cuts.iter().enumerate() {
            if d.abs_diff(g) <= tol {
                pairs.push((d.abs_diff(g), i, j));
            }
        }
    }
    pairs.sort_unstable();
    let (mut det_used, mut gold_used) = (
        vec![false; detected.len()],
        vec![false; gold.hard_cuts.len()],
    );
    let mut tp = 0;
    for (_, i, j) in pairs {
        if !det_used[i] && !gold_used[j] {
            det_used[i] = true;
            gold_used[j] = true;
            tp += 1;
        }
    }
    let in_gradual = |d: u64| {
        gold.gradual
            .iter()
            .any(|&[a, b]| d + tol >= a && d <= b + tol)
    };
    let false_positives: Vec<u64> = detected
        .iter()
        .zip(&det_used)
        .filter(|&(&d, &used)| !used && !in_gradual(d))
        .map(|(&d, _)| d)
        .collect();
    let missed: Vec<u64> = gold
        .hard_cuts
        .iter()
        .zip(&gold_used)
        .filter(|&(_, &used)| !used)
        .map(|(&g, _)| g)
        .collect();
    let fp = false_positives.len();
    let precision = if tp + fp == 0 {
        1.0
    } else {
        tp as f64 / (tp + fp) as f64
    };
    let recall = if gold.hard_cuts.is_empty() {
        1.0
    } else {
        tp as f64 / gold.hard_cuts.len() as f64
    };
    let f1 = if precision + recall > 0.0 {
        2.0 * precision * recall / (precision + recall)
    } else {
        0.0
    };
    Score {
        tp,
        fp,
        fn_: missed.len(),
        precision,
        recall,
        f1,
        missed,
        false_positives,
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    fn gold(cuts: &[u64], gradual: &[[u64; 2]]) -> Gold {
        Gold {
            hard_cuts: cuts.to_vec(),
            gradual: gradual.to_vec(),
        }
    }

    #[test]
    fn matches_like_the_reference_scoring() {
        // PySceneDetect on opencv_samples_cuts.mp4: [97, 337, 405] against 4 gold cuts
        let s = score_hard(&[97, 337, 405], &gold(&[97, 217, 337, 405], &[]), 2);
        assert_eq!((s.tp, s.fp, s.fn_), (3, 0, 1));
        assert!((s.f1 - 0.857_142_857).abs() < 1e-6);
        assert_eq!(s.missed, vec![217]);
        // detections inside gradual spans are ignored; one-to-one matching
        let s = score_hard(
            &[30, 31, 180, 394, 691],
            &gold(&[30, 180], &[[394, 423], [664, 693]]),
            2,
        );
        assert_eq!((s.tp, s.fp, s.fn_), (2, 1, 0));
        assert_eq!(s.false_positives, vec![31]);
        // nearest pair first: 141 goes to 140, not to 139's neighbour
        let s = score_hard(&[138, 141], &gold(&[140], &[]), 2);
        assert_eq!((s.tp, s.fp), (1, 1));
        assert_eq!(s.false_positives, vec![138]);
        // empty conventions
        let s = score_hard(&[], &gold(&[], &[]), 2);
        assert_eq!((s.precision, s.recall, s.f1), (1.0, 1.0, 1.0));
        let s = score_hard(&[], &gold(&[5], &[]), 2);
        assert_eq!((s.precision, s.recall, s.f1), (1.0, 0.0, 0.0));
    }

    #[test]
    fn reads_gold_json_and_cut_lists() -> Result<()> {
        let dir = tempfile::tempdir().map_err(|e| CutError::Config(e.to_string()))?;
        let json = dir.path().join("gold.json");
        std::fs::write(
            &json,
            r#"{"videos": [{"file": "a.mp4", "hard_cuts": [40, 10],
                "gradual_transitions": [{"first_frame": 50, "last_frame": 60, "type": "fade_in"}]},
                {"file": "b.mp4", "hard_cuts": []}]}"#,
        )
        .map_err(|e| CutError::Config(e.to_string()))?;
        let g = Gold::read(&json, Path::new("/x/a.mp4"))?;
        assert_eq!(g.hard_cuts, vec![10, 40]);
        assert_eq!(g.gradual, vec![[50, 60]]);
        assert!(Gold::read(&json, Path::new("c.mp4")).is_err());
        let csv = dir.path().join("cuts.csv");
        std::fs::write(&csv, "frame\n7\n3\n").map_err(|e| CutError::Config(e.to_string()))?;
        assert_eq!(Gold::read(&csv, Path::new("v.mp4"))?.hard_cuts, vec![3, 7]);
        Ok(())
    }
}
