//! NeRF `transforms.json` (instant-ngp, nerfstudio, the Blender synthetic scenes).
//!
//! # Format
//! A JSON object with a `frames` array; each frame has `file_path` (image path relative to the
//! JSON file, sometimes without extension, then `.png` is meant) and `transform_matrix`, a 4x4
//! **camera-to-world** matrix given as 4 rows of 4 numbers, in **OpenGL camera axes**: x right,
//! y up, z backward (the camera looks along −z). Intrinsics sit at the top level: `w`, `h`,
//! `fl_x`, `fl_y`, `cx`, `cy` and OpenCV distortion `k1`, `k2`, `p1`, `p2`, `k3`; or only
//! `camera_angle_x` (horizontal field of view, radians). nerfstudio may repeat any of these keys
//! per frame to override them.
//!
//! # Conversion
//! OpenCV camera-to-world = `M · diag(1, −1, −1, 1)`: the camera's x column stays, its y and z
//! columns flip sign (OpenGL up → OpenCV down, backward → forward); the camera centre (last
//! column) is unchanged. The world frame and units are the file's: `colmap2nerf.py` rotates the
//! world so that +z is up and scales it to a mean camera distance of about 4, so units are not
//! metres. instant-ngp's load-time `scale` and `offset`, `aabb_scale` and nerfstudio's
//! `applied_transform` are ignored (not applied).
//!
//! Intrinsics: `fl_x` missing → `w / 2 / tan(camera_angle_x / 2)`; `fl_y` missing →
//! from `camera_angle_y`, else `fl_x`; `cx`, `cy` missing → `w / 2`, `h / 2`. NeRF tools cast
//! rays through pixel centres at `+0.5` (instant-ngp, nerfstudio), like COLMAP, so the principal
//! point moves by half a pixel into OpenCV's convention: `cx = cx_file − 0.5`. Without `w`/`h`, or
//! with a nerfstudio `camera_model` other than `OPENCV`/`PINHOLE`/`SIMPLE_PINHOLE` (fisheye,
//! equirectangular), the trajectory has no camera. With per-frame intrinsics, the trajectory's
//! camera is the one all frames share, else `None`.
//!
//! # What a [`Trajectory`] holds
//! Every frame the JSON lists, in file order, whether or not its image exists ([`read_existing`]
//! keeps those whose image does, as instant-ngp does). `name` = file stem of `file_path`
//! (`./images/0001.jpg` → `0001`), `seq` = its folder part without a leading `./` (`images`), or
//! `"nerf"` when there is none; `t` = `None`.
//!
//! # Writing
//! [`write()`] stores `file_path = "{seq}/{name}.png"` ([`write_with`] chooses other paths), the
//! intrinsics (with `camera_model = "OPENCV"` and both `camera_angle_x`/`_y`, for loaders that
//! want them) when the trajectory has a camera, and each pose as `M = P · diag(1, −1, −1, 1)`.
//! Positions and intrinsics round-trip exactly; rotations pass through a matrix and agree to
//! about 1e-15. Time stamps are not stored.

use crate::error::{DataError, Result};
use crate::io::{read_text, require_finite, write_text_atomic};
use crate::trajectory::{PoseFrame, Trajectory};
use geom::{Camera, Distortion, Pose};
use nalgebra::Matrix4;
use serde_json::{Map, Value, json};
use std::path::{Path, PathBuf};

/// The usual file name.
pub const TRANSFORMS_JSON: &str = "transforms.json";
/// Sequence name of frames whose `file_path` has no folder part.
pub const DEFAULT_SEQ: &str = "nerf";

/// Keys that describe the camera; a frame holding any of them overrides the top level.
const CAMERA_KEYS: [&str; 14] = [
    "w",
    "h",
    "fl_x",
    "fl_y",
    "cx",
    "cy",
    "k1",
    "k2",
    "p1",
    "p2",
    "k3",
    "camera_angle_x",
    "camera_angle_y",
    "camera_model",
];

/// Reads a `transforms.json` (`path` = the file or a folder holding `transforms.json`): every
/// listed frame, converted to OpenCV axes (see the module doc).
pub fn read(path: &Path) -> Result<Trajectory> {
    Ok(read_with_images(path)?.0)
}

/// Like [`read()`], plus each frame's image path: `file_path` resolved against the JSON file's
/// folder, with `.png` added when `file_path` has no extension and the bare path does not exist.
pub fn read_with_images(path: &Path) -> Result<(Trajectory, Vec<PathBuf>)> {
    let path = json_path(path);
    let text = read_text(&path)?;
    let root: Value = serde_json::from_str(&text)
        .map_err(|e| DataError::parse(&path, e.line().max(1), e.to_string()))?;
    let top = root
        .as_object()
        .ok_or_else(|| DataError::invalid(&path, "expected a JSON object at the top level"))?;
    let frames = top
        .get("frames")
        .and_then(Value::as_array)
        .ok_or_else(|| DataError::invalid(&path, "missing 'frames' array"))?;
    if frames.is_empty() {
        return Err(DataError::invalid(&path, "'frames' is empty"));
    }
    let dir = path.parent().map(Path::to_path_buf).unwrap_or_default();
    let top_camera = camera(&path, "top level", &|k| top.get(k))?;
    let mut out = Vec::with_capacity(frames.len());
    let mut images = Vec::with_capacity(frames.len());
    let mut cameras = Vec::with_capacity(frames.len());
    let mut seen = crate::trajectory::FirstSeen::default();
    for (i, frame) in frames.iter().enumerate() {
        let ctx = format!("frames[{i}]");
        let obj = frame
            .as_object()
            .ok_or_else(|| DataError::invalid(&path, format!("{ctx} is not an object")))?;
        let (pose_frame, file_path) = parse_frame(&path, &ctx, obj)?;
        seen.check(&path, file_path, i, &pose_frame.pose, "frame")?;
        cameras.push(if CAMERA_KEYS.iter().any(|k| obj.contains_key(*k)) {
            camera(&path, &ctx, &|k| obj.get(k).or_else(|| top.get(k)))?
        } else {
            top_camera
        });
        images.push(image_path(&dir, file_path));
        out.push(pose_frame);
    }
    let camera = cameras
        .iter()
        .all(|c| *c == cameras[0])
        .then_some(cameras[0])
        .flatten();
    Ok((
        Trajectory {
            frames: out,
            camera,
        },
        images,
    ))
}

/// Like [`read()`], keeping only the frames whose image file exists (instant-ngp skips the others;
/// the fox scene lists 67 frames but ships 50 images).
pub fn read_existing(path: &Path) -> Result<Trajectory> {
    let (mut traj, images) = read_with_images(path)?;
    let mut keep = images.iter().map(|p| p.is_file());
    traj.frames.retain(|_| keep.next().unwrap_or(false));
    Ok(traj)
}

/// Writes `traj` as a `transforms.json` at `path` (a file path, or an existing folder to write
/// `transforms.json` into), each frame's `file_path` being `"{seq}/{name}.png"`.
pub fn write(traj: &Trajectory, path: &Path) -> Result<()> {
    write_with(traj, path, |f| format!("{}/{}.png", f.seq, f.name))
}

/// Like [`write()`], with each frame's `file_path` (relative to the JSON file) chosen by `file_path`.
pub fn write_with(
    traj: &Trajectory,
    path: &Path,
    file_path: impl Fn(&PoseFrame) -> String,
) -> Result<()> {
    let path = json_path(path);
    if traj.is_empty() {
        return Err(DataError::invalid(&path, "no frames to write"));
    }
    for f in &traj.frames {
        require_finite(&path, f)?;
    }
    let mut top = traj.camera.as_ref().map(camera_json).unwrap_or_default();
    let frames: Vec<Value> = traj
        .frames
        .iter()
        .map(|f| {
            json!({
                "file_path": file_path(f),
                "transform_matrix": matrix_json(&opengl_matrix(&f.pose)),
            })
        })
        .collect();
    top.insert("frames".into(), Value::Array(frames));
    let text = serde_json::to_string_pretty(&Value::Object(top))
        .map_err(|e| DataError::invalid(&path, e.to_string()))?;
    write_text_atomic(&path, &(text + "\n"))
}

/// `path` itself, or `path/transforms.json` for a folder.
fn json_path(path: &Path) -> PathBuf {
    if path.is_dir() {
        path.join(TRANSFORMS_JSON)
    } else {
        path.to_path_buf()
    }
}

/// One frame's pose, name and sequence, plus its `file_path` as written.
fn parse_frame<'a>(
    path: &Path,
    ctx: &str,
    obj: &'a Map<String, Value>,
) -> Result<(PoseFrame, &'a str)> {
    let file_path = obj
        .get("file_path")
        .and_then(Value::as_str)
        .ok_or_else(|| DataError::invalid(path, format!("{ctx}: missing 'file_path' string")))?;
    let name = Path::new(file_path)
        .file_stem()
        .map(|s| s.to_string_lossy().into_owned())
        .filter(|s| !s.is_empty())
        .ok_or_else(|| {
            DataError::invalid(
                path,
                format!("{ctx}: file_path '{file_path}' names no file"),
            )
        })?;
    let ctx_m = format!("{ctx}.transform_matrix");
    let m = matrix(path, &ctx_m, obj.get("transform_matrix"))?;
    let pose = Pose::from_matrix4(&flip_yz(&m))
        .map_err(|e| DataError::invalid(path, format!("{ctx_m}: {e}")))?;
    let frame = PoseFrame {
        name,
        seq: seq_of(file_path),
        t: None,
        pose,
    };
    Ok((frame, file_path))
}

/// A 4x4 matrix from 4 rows of 4 numbers.
fn matrix(path: &Path, ctx: &str, value: Option<&Value>) -> Result<Matrix4<f64>> {
    let bad = |what: String| {
        DataError::invalid(path, format!("{ctx}: expected 4 rows of 4 numbers, {what}"))
    };
    let rows = value
        .and_then(Value::as_array)
        .ok_or_else(|| bad("found none".into()))?;
    if rows.len() != 4 {
        return Err(bad(format!("found {} rows", rows.len())));
    }
    let mut m = Matrix4::zeros();
    for (r, row) in rows.iter().enumerate() {
        let row = row
            .as_array()
            .ok_or_else(|| bad(format!("row {r} is not an array")))?;
        if row.len() != 4 {
            return Err(bad(format!("row {r} has {} entries", row.len())));
        }
        for (c, v) in row.iter().enumerate() {
            m[(r, c)] = v
                .as_f64()
                .ok_or_else(|| bad(format!("row {r} column {c} is {v}")))?;
        }
    }
    Ok(m)
}

/// `M · diag(1, −1, −1, 1)`: OpenGL ↔ OpenCV camera axes (its own inverse).
fn flip_yz(m: &Matrix4<f64>) -> Matrix4<f64> {
    let mut out = *m;
    for c in [1, 2] {
        out.column_mut(c).neg_mut();
    }
    out
}

/// The OpenGL-axes camera-to-world matrix of a pose, with an exact last row `0 0 0 1`.
fn opengl_matrix(pose: &Pose) -> Matrix4<f64> {
    let mut m = flip_yz(&pose.to_matrix4());
    // Flipping turned the last row's zeros into −0; write plain zeros.
    m[(3, 1)] = 0.0;
    m[(3, 2)] = 0.0;
    m
}

fn matrix_json(m: &Matrix4<f64>) -> Value {
    Value::Array(
        (0..4)
            .map(|r| Value::Array((0..4).map(|c| Value::from(m[(r, c)])).collect()))
            .collect(),
    )
}

/// The folder part of `file_path` without leading `./`, or [`DEFAULT_SEQ`].
fn seq_of(file_path: &str) -> String {
    let mut dir = match file_path.rsplit_once('/') {
        Some((dir, _)) => dir,
        None => "",
    };
    while let Some(rest) = dir.strip_prefix("./") {
        dir = rest;
    }
    if dir.is_empty() || dir == "." {
        DEFAULT_SEQ.to_string()
    } else {
        dir.to_string()
    }
}

fn image_path(dir: &Path, file_path: &str) -> PathBuf {
    let p = dir.join(file_path);
    if p.extension().is_none() && !p.exists() {
        // The Blender scenes write `./train/r_0` for `./train/r_0.png`.
        p.with_extension("png")
    } else {
        p
    }
}

/// The camera described by the keys `get` finds, `None` when the keys do not describe a
/// perspective camera (see the module doc); errors name `ctx`.
fn camera<'a>(
    path: &Path,
    ctx: &str,
    get: &dyn Fn(&str) -> Option<&'a Value>,
) -> Result<Option<Camera>> {
    let num = |key: &str| -> Result<Option<f64>> {
        match get(key) {
            None | Some(Value::Null) => Ok(None),
            Some(v) => v.as_f64().map(Some).ok_or_else(|| {
                DataError::invalid(path, format!("{ctx}: '{key}' must be a number, found {v}"))
            }),
        }
    };
    if let Some(model) = get("camera_model").and_then(Value::as_str)
        && !["OPENCV", "PINHOLE", "SIMPLE_PINHOLE"].contains(&model)
    {
        return Ok(None);
    }
    let (Some(w), Some(h)) = (num("w")?, num("h")?) else {
        return Ok(None);
    };
    let (width, height) = (pixels(path, ctx, "w", w)?, pixels(path, ctx, "h", h)?);
    let from_angle = |size: f64, angle: Option<f64>| angle.map(|a| size / 2.0 / (a / 2.0).tan());
    let Some(fx) = num("fl_x")?.or(from_angle(w, num("camera_angle_x")?)) else {
        return Ok(None);
    };
    let fy = num("fl_y")?
        .or(from_angle(h, num("camera_angle_y")?))
        .unwrap_or(fx);
    let cx = num("cx")?.unwrap_or(w / 2.0) - 0.5;
    let cy = num("cy")?.unwrap_or(h / 2.0) - 0.5;
    let mut d = [0.0; 5];
    for (slot, key) in d.iter_mut().zip(["k1", "k2", "p1", "p2", "k3"]) {
        *slot = num(key)?.unwrap_or(0.0);
    }
    Camera::new(width, height, fx, fy, cx, cy, Distortion::from_array(d))
        .map(Some)
        .map_err(|e| DataError::invalid(path, format!("{ctx}: {e}")))
}

/// An image size in pixels: a positive whole number (files write `1080.0` as often as `1080`).
fn pixels(path: &Path, ctx: &str, key: &str, v: f64) -> Result<u32> {
    if v.fract() == 0.0 && v >= 1.0 && v <= f64::from(u32::MAX) {
        Ok(v as u32)
    } else {
        Err(DataError::invalid(
            path,
            format!("{ctx}: '{key}' = {v} is not an image size"),
        ))
    }
}

fn camera_json(c: &Camera) -> Map<String, Value> {
    let [k1, k2, p1, p2, k3] = c.dist.to_array();
    let angle = |size: u32, f: f64| 2.0 * (f64::from(size) / 2.0 / f).atan();
    let v = json!({
        "camera_model": "OPENCV",
        "w": c.width,
        "h": c.height,
        "fl_x": c.fx,
        "fl_y": c.fy,
        "cx": c.cx + 0.5,
        "cy": c.cy + 0.5,
        "k1": k1,
        "k2": k2,
        "p1": p1,
        "p2": p2,
        "k3": k3,
        "camera_angle_x": angle(c.width, c.fx),
        "camera_angle_y": angle(c.height, c.fy),
    });
    match v {
        Value::Object(m) => m,
        _ => Map::new(),
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::test_util::{geo, put, shared_data, tmp};
    use nalgebra::{Matrix3, Vector3};

    #[test]
    fn hand_checked_frames() -> Result<()> {
        let dir = tmp()?;
        // Frame 0: identity in OpenGL axes, at (0, 0, 4): looks along world −z (down at the
        // origin), image up = world +y. OpenCV: x = (1, 0, 0), y (down) = (0, −1, 0),
        // z (forward) = (0, 0, −1), so R = diag(1, −1, −1).
        // Frame 1: at (4, 0, 0) looking at the origin (along −x) with up +z: OpenGL right =
        // forward × up = (0, 1, 0), up = (0, 0, 1), backward = (1, 0, 0) are the matrix columns.
        // OpenCV: x = (0, 1, 0), y = (0, 0, −1), z = (−1, 0, 0).
        let p = put(
            dir.path(),
            TRANSFORMS_JSON,
            r#"{
              "camera_angle_x": 1.5707963267948966, "w": 200, "h": 100,
              "aabb_scale": 16, "scale": 0.33, "offset": [0.5, 0.5, 0.5],
              "frames": [
                {"file_path": "./images/0001.jpg",
                 "transform_matrix": [[1,0,0,0],[0,1,0,0],[0,0,1,4],[0,0,0,1]]},
                {"file_path": "r_1", "sharpness": 30.5,
                 "transform_matrix": [[0,0,1,4],[1,0,0,0],[0,1,0,0],[0,0,0,1]]}
              ]
            }"#,
        )?;
        let traj = read(&p)?;
        let (a, b) = (&traj.frames[0], &traj.frames[1]);
        assert_eq!(
            (a.name.as_str(), a.seq.as_str(), a.t),
            ("0001", "images", None)
        );
        assert_eq!((b.name.as_str(), b.seq.as_str()), ("r_1", DEFAULT_SEQ));
        let diag = Matrix3::from_diagonal(&Vector3::new(1.0, -1.0, -1.0));
        assert!((a.pose.rotation_matrix() - diag).amax() < 1e-15);
        assert_eq!(a.pose.position(), [0.0, 0.0, 4.0]);
        let r = b.pose.rotation_matrix();
        assert!((r.column(0) - Vector3::new(0.0, 1.0, 0.0)).amax() < 1e-15);
        assert!((r.column(1) - Vector3::new(0.0, 0.0, -1.0)).amax() < 1e-15);
        assert!((b.pose.forward() - Vector3::new(-1.0, 0.0, 0.0)).amax() < 1e-15);
        // 90° field of view over 200 px: f = 100 / tan 45° = 100; centre (100, 50) − 0.5.
        let cam = traj
            .camera
            .ok_or_else(|| DataError::invalid(&p, "no camera"))?;
        assert!((cam.fx - 100.0).abs() < 1e-12 && (cam.fy - cam.fx).abs() < 1e-15);
        assert_eq!(
            (cam.cx, cam.cy, cam.width, cam.height),
            (99.5, 49.5, 200, 100)
        );
        // A folder works as the path too.
        assert_eq!(read(dir.path())?, traj);
        Ok(())
    }

    #[test]
    fn fox_scene_in_place() -> Result<()> {
        let path = &shared_data("fox_posed/transforms.json");
        let traj = read(path)?;
        assert_eq!(traj.len(), 67);
        assert_eq!(traj.frames[0].name, "0001");
        assert_eq!(traj.frames[0].seq, "images");
        let cam = traj
            .camera
            .ok_or_else(|| DataError::invalid(path, "no camera"))?;
        assert_eq!(
            (cam.width, cam.height, cam.fx, cam.fy),
            (1080, 1920, 1375.52, 1374.49)
        );
        assert!((cam.cx - 554.058).abs() < 1e-9 && (cam.cy - 964.768).abs() < 1e-9);
        assert_eq!(
            cam.dist.to_array(),
            [0.0578421, -0.0805099, -0.000980296, 0.00015575, 0.0]
        );
        // The cameras circle the figurine at the origin: OpenCV +z must point at it.
        let mean_cos = traj
            .frames
            .iter()
            .map(|f| f.pose.forward().dot(&(-f.pose.translation.normalize())))
            .sum::<f64>()
            / traj.len() as f64;
        assert!(mean_cos > 0.95, "mean cosine {mean_cos}");
        // 17 images were removed upstream.
        let existing = read_existing(path)?;
        assert_eq!(existing.len(), 50);
        assert!(
            !existing
                .frames
                .iter()
                .any(|f| f.name == "0005" || f.name == "0113")
        );
        Ok(())
    }

    #[test]
    fn round_trip() -> Result<()> {
        let dist = Distortion::from_array([0.0578421, -0.0805099, -0.000980296, 0.00015575, 0.01]);
        let cam = geo(Camera::new(
            1080, 1920, 1375.52, 1374.49, 554.058, 964.768, dist,
        ))?;
        for camera in [Some(cam), None] {
            let mut frames = Vec::new();
            for i in 0..4 {
                let a = i as f64 * 0.9 - 1.5;
                let pose = geo(Pose::from_euler_ypr(
                    a,
                    -0.4 * a,
                    0.7 * a,
                    [a, 1.0 / 3.0, -a],
                ))?;
                let seq = if i < 2 { "images" } else { "day2" };
                frames.push(PoseFrame {
                    name: format!("{i:04}"),
                    seq: seq.into(),
                    t: None,
                    pose,
                });
            }
            let traj = Trajectory { frames, camera };
            let dir = tmp()?;
            let p = dir.path().join("out.json");
            write(&traj, &p)?;
            let back = read(&p)?;
            assert_eq!(back.camera, traj.camera);
            for (a, b) in traj.frames.iter().zip(&back.frames) {
                assert_eq!((&a.name, &a.seq, a.t), (&b.name, &b.seq, b.t));
                assert_eq!(a.pose.translation, b.pose.translation);
                assert!(a.pose.rotation.angle_to(&b.pose.rotation) < 1e-14);
            }
        }
        Ok(())
    }

    #[test]
    fn per_frame_intrinsics() -> Result<()> {
        let dir = tmp()?;
        let frame = |fl: f64| {
            format!(
                r#"{{"file_path": "a/{fl}.png", "fl_x": {fl},
                   "transform_matrix": [[1,0,0,0],[0,1,0,0],[0,0,1,0],[0,0,0,1]]}}"#
            )
        };
        let text = |a: f64, b: f64| {
            format!(
                r#"{{"w": 64, "h": 48, "fl_x": 50, "frames": [{}, {}]}}"#,
                frame(a),
                frame(b)
            )
        };
        let p = put(dir.path(), TRANSFORMS_JSON, &text(60.0, 60.0))?;
        assert_eq!(read(&p)?.camera.map(|c| c.fx), Some(60.0));
        put(dir.path(), TRANSFORMS_JSON, &text(60.0, 70.0))?;
        assert!(read(&p)?.camera.is_none());
        put(
            dir.path(),
            TRANSFORMS_JSON,
            r#"{"camera_model": "OPENCV_FISHEYE", "w": 6, "h": 4, "fl_x": 5,
            "frames": [{"file_path": "x", "transform_matrix": [[1,0,0,0],[0,1,0,0],[0,0,1,0],[0,0,0,1]]}]}"#,
        )?;
        assert!(read(&p)?.camera.is_none());
        Ok(())
    }

    #[test]
    fn malformed_files_are_errors() -> Result<()> {
        let dir = tmp()?;
        let id = "[[1,0,0,0],[0,1,0,0],[0,0,1,0],[0,0,0,1]]";
        let cases = [
            (
                r#"{"frames": [{"file_path": "a.png", "transform_matrix": [[1,0,0,0],[0,1,0,0],[0,0,1,0]]}]}"#.to_string(),
                "frames[0].transform_matrix: expected 4 rows of 4 numbers, found 3 rows",
            ),
            (
                r#"{"frames": [{"file_path": "a.png", "transform_matrix": [[2,0,0,0],[0,1,0,0],[0,0,1,0],[0,0,0,1]]}]}"#.to_string(),
                "not a rotation",
            ),
            (
                r#"{"frames": [{"file_path": "a.png", "transform_matrix": [[1,0,0,0],[0,1,0,0],[0,0,1,0],[0,0,1,1]]}]}"#.to_string(),
                "last row",
            ),
            (format!(r#"{{"frames": [{{"transform_matrix": {id}}}]}}"#), "missing 'file_path'"),
            (format!(r#"{{"w": 4, "h": 3, "fl_x": "big", "frames": [{{"file_path": "a", "transform_matrix": {id}}}]}}"#), "'fl_x' must be a number"),
            (format!(r#"{{"w": 4.5, "h": 3, "fl_x": 1, "frames": [{{"file_path": "a", "transform_matrix": {id}}}]}}"#), "'w' = 4.5"),
            (format!(r#"{{"w": 4, "h": 3, "fl_x": -1, "frames": [{{"file_path": "a", "transform_matrix": {id}}}]}}"#), "invalid camera"),
            (r#"{"fl_x": 1}"#.to_string(), "missing 'frames'"),
            (r#"{"frames": []}"#.to_string(), "'frames' is empty"),
            ("[1, 2]".to_string(), "JSON object"),
            ("{\n  \"fl_x\": NaN\n}".to_string(), "transforms.json:2:"),
            (String::new(), "transforms.json:1:"),
        ];
        for (text, msg) in cases {
            let p = put(dir.path(), TRANSFORMS_JSON, &text)?;
            let e = read(&p).err().map(|e| e.to_string()).unwrap_or_default();
            assert!(
                e.contains(TRANSFORMS_JSON) && e.contains(msg),
                "{text}: {e}"
            );
        }
        let p = dir.path().join(TRANSFORMS_JSON);
        std::fs::write(&p, [0x7b, 0xff, 0xfe]).map_err(|e| DataError::io(&p, e))?;
        let e = read(&p).err().map(|e| e.to_string()).unwrap_or_default();
        assert!(e.contains("not a text file"), "{e}");
        Ok(())
    }
}
