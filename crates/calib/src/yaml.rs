//! OpenCV `FileStorage` YAML for cameras: the subset calibration files use.
//!
//! The reader is hand-written: `%YAML:1.0` and the `!!opencv-matrix` tag are not YAML 1.2,
//! which serde YAML readers refuse. It understands top-level `key: scalar` lines and
//! `key: !!opencv-matrix` blocks (`rows`, `cols`, `dt`, `data: [ ... ]` over several lines),
//! ignores everything else, and needs `camera_matrix`. `distortion_coefficients` may be a row
//! or a column of 4, 5 or more values (missing: no distortion; beyond the fifth they must be
//! zero, as [`geom::Distortion`] has five). When `image_width` / `image_height` are missing
//! the size is taken as twice the principal point, rounded (the principal point of a real
//! lens is near the centre; OpenCV's ArUco tutorial files carry no size).

use crate::calibrate::Calibration;
use crate::error::{CalibError, Result};
use geom::{Camera, Distortion};
use std::collections::HashMap;
use std::io::Write;
use std::path::{Path, PathBuf};

/// Formats like OpenCV: `5.3591573396163199e+02`.
fn fmt_num(v: f64) -> String {
    if v == 0.0 {
        return "0.".into();
    }
    let s = format!("{v:.16e}");
    match s.split_once('e') {
        Some((m, e)) => {
            let e: i32 = e.parse().unwrap_or(0);
            let sign = if e < 0 { '-' } else { '+' };
            format!("{m}e{sign}{:02}", e.abs())
        }
        None => s,
    }
}

fn matrix_block(name: &str, rows: usize, cols: usize, data: &[f64]) -> String {
    let values: Vec<String> = data.iter().map(|&v| fmt_num(v)).collect();
    let mut lines = Vec::new();
    for chunk in values.chunks(3) {
        lines.push(chunk.join(", "));
    }
    format!(
        "{name}: !!opencv-matrix\n   rows: {rows}\n   cols: {cols}\n   dt: d\n   data: [ {} ]\n",
        lines.join(",\n       ")
    )
}

/// Writes `camera` as OpenCV `FileStorage` YAML (`image_width`, `image_height`,
/// `camera_matrix`, `distortion_coefficients` as a 1x5 matrix, and `avg_reprojection_error`
/// when `rms` is given), atomically: a temporary file in the same folder, then a rename.
pub fn write_opencv_yaml(path: impl AsRef<Path>, camera: &Camera, rms: Option<f64>) -> Result<()> {
    let path = path.as_ref();
    let k = [
        camera.fx, 0.0, camera.cx, 0.0, camera.fy, camera.cy, 0.0, 0.0, 1.0,
    ];
    let mut text = String::from("%YAML:1.0\n---\n");
    text += &format!(
        "image_width: {}\nimage_height: {}\n",
        camera.width, camera.height
    );
    text += &matrix_block("camera_matrix", 3, 3, &k);
    text += &matrix_block("distortion_coefficients", 1, 5, &camera.dist.to_array());
    if let Some(rms) = rms {
        text += &format!("avg_reprojection_error: {}\n", fmt_num(rms));
    }
    write_atomic(path, text.as_bytes())
}

impl Calibration {
    /// Writes this calibration with [`write_opencv_yaml`] (camera and RMS).
    pub fn write_opencv_yaml(&self, path: impl AsRef<Path>) -> Result<()> {
        write_opencv_yaml(path, &self.camera, Some(self.rms))
    }
}

fn write_atomic(path: &Path, bytes: &[u8]) -> Result<()> {
    let io = |source| CalibError::Io {
        path: path.to_path_buf(),
        source,
    };
    let dir = match path.parent() {
        Some(d) if !d.as_os_str().is_empty() => d.to_path_buf(),
        _ => PathBuf::from("."),
    };
    let name = path
        .file_name()
        .map(|n| n.to_string_lossy().into_owned())
        .unwrap_or_else(|| "calib.yml".into());
    let tmp = dir.join(format!(".{name}.{}.tmp", std::process::id()));
    let result = (|| {
        let mut f = std::fs::File::create(&tmp)?;
        f.write_all(bytes)?;
        f.sync_all()?;
        std::fs::rename(&tmp, path)
    })();
    if result.is_err() {
        let _ = std::fs::remove_file(&tmp);
    }
    result.map_err(io)
}

/// A parsed top-level value.
#[derive(Debug)]
enum Value {
    Scalar(String),
    Matrix {
        rows: usize,
        cols: usize,
        data: Vec<f64>,
    },
}

fn strip_comment(s: &str) -> &str {
    if s.trim_start().starts_with('"') {
        return s;
    }
    match s.find(" #") {
        Some(i) => &s[..i],
        None if s.trim_start().starts_with('#') => "",
        None => s,
    }
}

fn parse(path: &Path, text: &str) -> Result<HashMap<String, Value>> {
    let err = |line: usize, reason: &str| CalibError::Parse {
        path: path.to_path_buf(),
        reason: format!("line {}: {reason}", line + 1),
    };
    let lines: Vec<&str> = text.lines().collect();
    let mut out = HashMap::new();
    let mut i = 0;
    while i < lines.len() {
        let line = lines[i];
        let trimmed = line.trim();
        if trimmed.is_empty()
            || trimmed.starts_with('#')
            || trimmed.starts_with('%')
            || trimmed == "---"
            || trimmed == "..."
            || line.starts_with(' ')
            || line.starts_with('\t')
        {
            i += 1;
            continue;
        }
        let Some((key, rest)) = line.split_once(':') else {
            i += 1;
            continue;
        };
        let key = key.trim().to_string();
        let rest = strip_comment(rest).trim();
        if rest.starts_with("!!opencv-matrix") {
            // indented block below
            let (mut rows, mut cols, mut data) = (None, None, None);
            let start = i;
            i += 1;
            while i < lines.len() && (lines[i].starts_with(' ') || lines[i].starts_with('\t')) {
                let l = lines[i].trim();
                if let Some((k, v)) = l.split_once(':') {
                    let v = v.trim();
                    match k.trim() {
                        "rows" => rows = v.parse::<usize>().ok(),
                        "cols" => cols = v.parse::<usize>().ok(),
                        "data" => {
                            let mut buf = v.to_string();
                            while !buf.contains(']') {
                                i += 1;
                                if i >= lines.len() {
                                    return Err(err(start, "unterminated data of a matrix"));
                                }
                                buf.push(' ');
                                buf.push_str(lines[i].trim());
                            }
                            let inner = buf
                                .trim()
                                .trim_start_matches('[')
                                .split(']')
                                .next()
                                .unwrap_or("");
                            let values: std::result::Result<Vec<f64>, _> = inner
                                .split(',')
                                .map(str::trim)
                                .filter(|s| !s.is_empty())
                                .map(|s| s.parse::<f64>())
                                .collect();
                            data = Some(
                                values
                                    .map_err(|e| err(i, &format!("bad number in `{key}`: {e}")))?,
                            );
                        }
                        _ => {}
                    }
                }
                i += 1;
            }
            let (Some(rows), Some(cols), Some(data)) = (rows, cols, data) else {
                return Err(err(
                    start,
                    &format!("matrix `{key}` lacks rows, cols or data"),
                ));
            };
            if rows * cols != data.len() {
                return Err(err(
                    start,
                    &format!(
                        "matrix `{key}` is {rows}x{cols} but has {} values",
                        data.len()
                    ),
                ));
            }
            out.insert(key, Value::Matrix { rows, cols, data });
        } else {
            out.insert(key, Value::Scalar(rest.trim_matches('"').to_string()));
            i += 1;
        }
    }
    Ok(out)
}

/// Reads a camera from OpenCV `FileStorage` YAML (`camera_matrix`,
/// `distortion_coefficients`, `image_width`, `image_height`; see the module notes for what
/// may be missing). Errors name the file and the missing or bad key.
pub fn read_camera_yaml(path: impl AsRef<Path>) -> Result<Camera> {
    let path = path.as_ref();
    let text = std::fs::read_to_string(path).map_err(|source| CalibError::Io {
        path: path.to_path_buf(),
        source,
    })?;
    let map = parse(path, &text)?;
    let missing = |key: &str| CalibError::MissingKey {
        path: path.to_path_buf(),
        key: key.into(),
    };
    let bad = |reason: String| CalibError::Parse {
        path: path.to_path_buf(),
        reason,
    };
    let k = match map.get("camera_matrix") {
        Some(Value::Matrix {
            rows: 3,
            cols: 3,
            data,
        }) => data.clone(),
        Some(_) => return Err(bad("`camera_matrix` is not a 3x3 matrix".into())),
        None => return Err(missing("camera_matrix")),
    };
    let dist = match map.get("distortion_coefficients") {
        None => Distortion::default(),
        Some(Value::Matrix { rows, cols, data }) if (*rows == 1 || *cols == 1) => {
            if data.len() < 4 {
                return Err(bad(format!(
                    "`distortion_coefficients` has {} values, need 4 or more",
                    data.len()
                )));
            }
            if data.iter().skip(5).any(|&v| v != 0.0) {
                return Err(bad(format!(
                    "`distortion_coefficients` has {} non-zero terms; only k1, k2, p1, p2, k3 are supported",
                    data.len()
                )));
            }
            let k3 = data.get(4).copied().unwrap_or(0.0);
            Distortion::from_array([data[0], data[1], data[2], data[3], k3])
        }
        Some(_) => {
            return Err(bad(
                "`distortion_coefficients` is not a row or column matrix".into(),
            ));
        }
    };
    let (fx, cx, fy, cy) = (k[0], k[2], k[4], k[5]);
    if k[1] != 0.0 || k[3] != 0.0 || k[6] != 0.0 || k[7] != 0.0 || k[8] != 1.0 {
        return Err(bad(format!(
            "`camera_matrix` {k:?} is not [fx 0 cx; 0 fy cy; 0 0 1] (skew is not supported)"
        )));
    }
    let size = |key: &str, fallback: f64| -> Result<u32> {
        match map.get(key) {
            Some(Value::Scalar(s)) => s
                .parse::<u32>()
                .map_err(|e| bad(format!("`{key}` = `{s}`: {e}"))),
            Some(Value::Matrix { .. }) => Err(bad(format!("`{key}` is a matrix"))),
            None => {
                let v = (2.0 * fallback).round();
                if v.is_finite() && v >= 1.0 && v < u32::MAX as f64 {
                    Ok(v as u32)
                } else {
                    Err(missing(key))
                }
            }
        }
    };
    let width = size("image_width", cx)?;
    let height = size("image_height", cy)?;
    Ok(Camera::new(width, height, fx, fy, cx, cy, dist)?)
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn number_format_is_opencv_like() {
        assert_eq!(fmt_num(535.915_733_961_632), "5.3591573396163199e+02");
        assert_eq!(fmt_num(-0.000_281), "-2.8100000000000000e-04");
        assert_eq!(fmt_num(0.0), "0.");
        assert_eq!(
            "5.3591573396163199e+02".parse::<f64>().ok(),
            Some(535.915_733_961_632)
        );
    }
}
