//! Which pose format a path holds, told from its content, and one reader for all of them.
//!
//! Detection looks at what is there, not at file names alone, so `eval` can be pointed at any
//! trajectory a user has: folders by the files they hold, text files by their first data line.

use crate::error::{DataError, Result};
use crate::trajectory::Trajectory;
use crate::{cambridge, colmap, jsonl, native, nerf, robotlog, sevenscenes, tum};
use std::fmt;
use std::path::Path;
use std::str::FromStr;

/// A pose format `data` reads.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum Format {
    /// The native dataset folder (`dataset.toml` + `poses.csv`) or its `poses.csv`.
    Native,
    /// A 7-Scenes scene or sequence folder (`frame-NNNNNN.pose.txt`).
    SevenScenes,
    /// A Cambridge Landmarks / PoseNet list (`image X Y Z W P Q R`).
    Cambridge,
    /// A TUM RGB-D trajectory (`timestamp tx ty tz qx qy qz qw`).
    Tum,
    /// A COLMAP text model (`images.txt`, `cameras.txt`).
    Colmap,
    /// A NeRF `transforms.json`.
    Nerf,
    /// A 3-DoF robot log CSV (`t,x,y,theta[,sxx,syy,stt]`).
    RobotLog,
    /// JSON lines as `indoorloc localize` prints them.
    Jsonl,
}

/// Every format with its command-line name.
pub const FORMATS: [(Format, &str); 8] = [
    (Format::Native, "native"),
    (Format::SevenScenes, "7scenes"),
    (Format::Cambridge, "cambridge"),
    (Format::Tum, "tum"),
    (Format::Colmap, "colmap"),
    (Format::Nerf, "nerf"),
    (Format::RobotLog, "robotlog"),
    (Format::Jsonl, "jsonl"),
];

impl fmt::Display for Format {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        let name = FORMATS
            .iter()
            .find(|(fmt, _)| fmt == self)
            .map_or("?", |(_, name)| name);
        f.write_str(name)
    }
}

impl FromStr for Format {
    type Err = String;
    fn from_str(s: &str) -> std::result::Result<Self, String> {
        FORMATS
            .iter()
            .find(|(_, name)| name.eq_ignore_ascii_case(s))
            .map(|(fmt, _)| *fmt)
            .ok_or_else(|| {
                let names: Vec<&str> = FORMATS.iter().map(|(_, n)| *n).collect();
                format!("unknown format '{s}' (one of: {})", names.join(", "))
            })
    }
}

/// Reads poses from `path` in `format`, or in the format [`detect`] finds.
pub fn read(path: &Path, format: Option<Format>) -> Result<Trajectory> {
    let format = match format {
        Some(f) => f,
        None => detect(path)?,
    };
    match format {
        Format::Native => native::read(path),
        Format::SevenScenes => sevenscenes::read(path),
        Format::Cambridge => cambridge::read(path),
        Format::Tum => tum::read(path),
        Format::Colmap => colmap::read(path),
        Format::Nerf => nerf::read(path),
        Format::RobotLog => robotlog::read(path),
        Format::Jsonl => jsonl::read(path),
    }
}

/// Tells the format of a file or folder from its content.
pub fn detect(path: &Path) -> Result<Format> {
    let meta = std::fs::metadata(path).map_err(|e| DataError::io(path, e))?;
    if meta.is_dir() {
        detect_dir(path)
    } else {
        detect_file(path)
    }
}

fn detect_dir(dir: &Path) -> Result<Format> {
    if dir.join("poses.csv").is_file() {
        return Ok(Format::Native);
    }
    if dir.join("images.txt").is_file() {
        return Ok(Format::Colmap);
    }
    if dir.join("transforms.json").is_file() {
        return Ok(Format::Nerf);
    }
    if holds_7scenes_poses(dir)? {
        return Ok(Format::SevenScenes);
    }
    Err(DataError::invalid(
        dir,
        "cannot tell the pose format of this folder (no poses.csv, images.txt, transforms.json \
         or seq-XX/frame-NNNNNN.pose.txt); name it with --gt-format/--est-format",
    ))
}

/// True for a 7-Scenes sequence folder, or a scene folder whose `seq-*` folders hold poses.
fn holds_7scenes_poses(dir: &Path) -> Result<bool> {
    let is_pose = |name: &str| name.starts_with("frame-") && name.ends_with(".pose.txt");
    for entry in std::fs::read_dir(dir).map_err(|e| DataError::io(dir, e))? {
        let entry = entry.map_err(|e| DataError::io(dir, e))?;
        let name = entry.file_name().to_string_lossy().into_owned();
        if is_pose(&name) {
            return Ok(true);
        }
        if name.starts_with("seq") && entry.path().is_dir() {
            let sub = entry.path();
            let mut files = std::fs::read_dir(&sub).map_err(|e| DataError::io(&sub, e))?;
            if files.any(|f| f.is_ok_and(|f| is_pose(&f.file_name().to_string_lossy()))) {
                return Ok(true);
            }
        }
    }
    Ok(false)
}

fn detect_file(path: &Path) -> Result<Format> {
    let name = path
        .file_name()
        .map(|n| n.to_string_lossy().to_ascii_lowercase())
        .unwrap_or_default();
    match name.as_str() {
        "poses.csv" => return Ok(Format::Native),
        "images.txt" => return Ok(Format::Colmap),
        "transforms.json" => return Ok(Format::Nerf),
        _ => {}
    }
    let text = crate::io::read_text(path)?;
    let Some(first) = text
        .lines()
        .map(str::trim)
        .find(|l| !l.is_empty() && !l.starts_with('#'))
    else {
        return Err(DataError::invalid(path, "empty file: no poses"));
    };
    if first.starts_with('{') {
        // One object per line (localize output) or one document holding "frames" (NeRF).
        return Ok(
            if serde_json::from_str::<serde_json::Value>(first).is_ok() {
                Format::Jsonl
            } else {
                Format::Nerf
            },
        );
    }
    if first.starts_with("Visual Landmark Dataset") {
        return Ok(Format::Cambridge);
    }
    let header: Vec<String> = first
        .split(',')
        .map(|f| f.trim().to_ascii_lowercase())
        .collect();
    if ["t", "x", "y", "theta"]
        .iter()
        .all(|c| header.iter().any(|h| h == c))
    {
        return Ok(Format::RobotLog);
    }
    let fields: Vec<&str> = first.split_whitespace().collect();
    if fields.iter().all(|f| f.parse::<f64>().is_ok()) {
        // Only numbers: a TUM trajectory (its reader names the line if the count is wrong).
        return Ok(Format::Tum);
    }
    if fields.len() == 8 {
        return Ok(Format::Cambridge);
    }
    Err(DataError::invalid(
        path,
        format!(
            "cannot tell the pose format from the first line '{}'; name it with \
             --gt-format/--est-format",
            first.chars().take(60).collect::<String>()
        ),
    ))
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::test_util::{put, shared_data};

    #[test]
    fn detects_text_formats_from_content() -> Result<()> {
        let tmp = crate::test_util::tmp()?;
        let d = tmp.path();
        let cases = [
            ("a.txt", "# tum\n1.0 0 0 0 0 0 0 1\n", Format::Tum),
            (
                "b.txt",
                "Visual Landmark Dataset V1\nImageFile\n\nseq1/f.png 0 0 0 1 0 0 0\n",
                Format::Cambridge,
            ),
            ("c.txt", "seq1/f.png 0 0 0 1 0 0 0\n", Format::Cambridge),
            (
                "d.log",
                "t,x,y,theta,sxx,syy,stt\n0,1,2,0,0,0,0\n",
                Format::RobotLog,
            ),
            (
                "e.out",
                "{\"frame\":1,\"position\":[0,0,0],\"quaternion\":[1,0,0,0]}\n",
                Format::Jsonl,
            ),
            ("f.json", "{\n \"frames\": []\n}\n", Format::Nerf),
        ];
        for (name, content, want) in cases {
            let p = put(d, name, content)?;
            assert_eq!(detect(&p)?, want, "{name}");
        }
        let p = put(d, "g.txt", "hello world\n")?;
        assert!(detect(&p).unwrap_err().to_string().contains("g.txt"));
        let p = put(d, "h.txt", "\n# only a comment\n")?;
        assert!(detect(&p).unwrap_err().to_string().contains("empty"));
        Ok(())
    }

    #[test]
    fn detects_real_folders() -> Result<()> {
        assert_eq!(
            detect(&shared_data("7scenes_stairs_sample/7scenes_layout"))?,
            Format::SevenScenes
        );
        assert_eq!(
            detect(&shared_data("7scenes_stairs_sample/7scenes_layout/seq-01"))?,
            Format::SevenScenes
        );
        assert_eq!(detect(&shared_data("fox_posed"))?, Format::Nerf);
        assert!(detect(&shared_data("fox_posed/images")).is_err());
        Ok(())
    }

    #[test]
    fn names_round_trip() {
        for (f, name) in FORMATS {
            assert_eq!(name.parse::<Format>(), Ok(f));
            assert_eq!(f.to_string(), name);
        }
        assert!("xyz".parse::<Format>().is_err());
    }
}
