//! COLMAP text models: a folder with `cameras.txt`, `images.txt` and `points3D.txt` (the points
//! are not read). Binary models (`images.bin`) must first be converted with
//! `colmap model_converter --output_type TXT`.
//!
//! # Format
//! `cameras.txt`: one camera per line, `CAMERA_ID MODEL WIDTH HEIGHT PARAMS...`.
//! `images.txt`: two lines per image, `IMAGE_ID QW QX QY QZ TX TY TZ CAMERA_ID NAME`, then the
//! image's 2D points `X Y POINT3D_ID ...` (a line that may be empty, but is always there).
//! Lines starting with `#` and blank lines *between* images are skipped, as COLMAP does.
//!
//! # Conversion
//! COLMAP's camera axes are OpenCV's (x right, y down, z forward), but its pose is
//! **world-to-camera**: `x_cam = R(q)·x_world + t`. The camera-to-world pose of DESIGN.md is the
//! inverse: rotation `R(q)ᵀ` (the conjugate quaternion), centre `c = −R(q)ᵀ·t`. The world frame
//! and its units are COLMAP's (arbitrary scale unless the model was geo-registered).
//!
//! COLMAP puts the *centre* of the top-left pixel at (0.5, 0.5); OpenCV and [`geom::Camera`] put
//! it at (0, 0). So `cx = cx_colmap − 0.5`, `cy = cy_colmap − 0.5`; the writer adds 0.5 back.
//! Camera models map to [`geom::Camera`] with OpenCV distortion `k1, k2, p1, p2, k3`:
//! `SIMPLE_PINHOLE f cx cy`, `PINHOLE fx fy cx cy`, `SIMPLE_RADIAL f cx cy k` (k1 = k),
//! `RADIAL f cx cy k1 k2`, `OPENCV fx fy cx cy k1 k2 p1 p2`, and `FULL_OPENCV` when its rational
//! terms k4, k5, k6 are zero. The fisheye and thin-prism models are read (poses stay usable) but
//! have no [`geom::Camera`]; an unknown model name or a wrong parameter count is an error.
//!
//! # What a [`Trajectory`] holds
//! Frames in file order (COLMAP writes them by `IMAGE_ID`); `name` = `NAME` (the image path
//! relative to the image folder, names with spaces are read whole); `seq` = the folder part of
//! `NAME` (`seq-01/frame-000000.png` → `seq-01`), or `"colmap"` when it has none; `t` = `None`.
//! `camera` = the camera when every image uses the same one and it has a [`geom::Camera`], else
//! `None`. A missing `cameras.txt` is allowed (camera `None`) so bare `images.txt` files can be
//! evaluated.
//!
//! # Writing
//! [`write()`] writes all three files (COLMAP refuses a model without `points3D.txt`): camera 1 is
//! `PINHOLE` without distortion, `OPENCV` with distortion and `k3 = 0`, `FULL_OPENCV` otherwise.
//! Without a camera it writes a placeholder (`PINHOLE 1 1 1 1 0.5 0.5`) marked by a comment that
//! this reader recognises, so the camera reads back as `None`. Image ids count from 1 in frame
//! order; names are written as they are (they must be non-empty and without whitespace, as COLMAP
//! splits on spaces). Seq and time stamps are not stored. Rotations round-trip exactly; centres
//! pass through one rotation each way, so they agree to about 1e-15 relative, not bit for bit.

use crate::error::{DataError, Result};
use crate::io::{parse_numbers, read_text, require_finite, write_text_atomic};
use crate::trajectory::{PoseFrame, Trajectory};
use geom::{Camera, Distortion, Pose};
use std::collections::{HashMap, HashSet};
use std::fmt::Write as _;
use std::path::{Path, PathBuf};

/// File name of the camera list.
pub const CAMERAS_TXT: &str = "cameras.txt";
/// File name of the image list.
pub const IMAGES_TXT: &str = "images.txt";
/// File name of the point list (written empty, never read).
pub const POINTS3D_TXT: &str = "points3D.txt";

/// Sequence name of images whose name has no folder part.
pub const DEFAULT_SEQ: &str = "colmap";

/// Comment that marks the placeholder camera [`write()`] emits for a trajectory without one.
const PLACEHOLDER: &str = "# indoorloc: placeholder camera, intrinsics unknown";

/// COLMAP's camera models and their parameter counts (colmap/src/colmap/sensor/models.h).
const MODELS: [(&str, usize); 12] = [
    ("SIMPLE_PINHOLE", 3),
    ("PINHOLE", 4),
    ("SIMPLE_RADIAL", 4),
    ("RADIAL", 5),
    ("OPENCV", 8),
    ("OPENCV_FISHEYE", 8),
    ("FULL_OPENCV", 12),
    ("FOV", 5),
    ("SIMPLE_RADIAL_FISHEYE", 4),
    ("RADIAL_FISHEYE", 5),
    ("THIN_PRISM_FISHEYE", 12),
    ("RAD_TAN_THIN_PRISM_FISHEYE", 16),
];

/// One line of `cameras.txt`, parameters as COLMAP stores them.
#[derive(Clone, Debug, PartialEq)]
pub struct ColmapCamera {
    /// `CAMERA_ID`.
    pub id: u32,
    /// Model name, e.g. `PINHOLE`.
    pub model: String,
    /// Image width, pixels.
    pub width: u32,
    /// Image height, pixels.
    pub height: u32,
    /// The model's parameters (principal point in COLMAP's pixel convention).
    pub params: Vec<f64>,
}

impl ColmapCamera {
    /// The camera in OpenCV conventions, or `None` for a model [`geom::Camera`] cannot express
    /// (fisheye, thin prism, rational `FULL_OPENCV`) or invalid intrinsics.
    pub fn to_camera(&self) -> Option<Camera> {
        self.convert().and_then(|r| r.ok())
    }

    /// `None` when the model has no [`geom::Camera`]; `Some(Err)` when its numbers are invalid.
    fn convert(&self) -> Option<geom::Result<Camera>> {
        let p = &self.params;
        // (fx, fy, cx, cy, [k1, k2, p1, p2, k3]) in COLMAP's pixel convention.
        let (fx, fy, cx, cy, d) = match (self.model.as_str(), p.len()) {
            ("SIMPLE_PINHOLE", 3) => (p[0], p[0], p[1], p[2], [0.0; 5]),
            ("PINHOLE", 4) => (p[0], p[1], p[2], p[3], [0.0; 5]),
            ("SIMPLE_RADIAL", 4) => (p[0], p[0], p[1], p[2], [p[3], 0.0, 0.0, 0.0, 0.0]),
            ("RADIAL", 5) => (p[0], p[0], p[1], p[2], [p[3], p[4], 0.0, 0.0, 0.0]),
            ("OPENCV", 8) => (p[0], p[1], p[2], p[3], [p[4], p[5], p[6], p[7], 0.0]),
            ("FULL_OPENCV", 12) if p[9..].iter().all(|&k| k == 0.0) => {
                (p[0], p[1], p[2], p[3], [p[4], p[5], p[6], p[7], p[8]])
            }
            _ => return None,
        };
        Some(Camera::new(
            self.width,
            self.height,
            fx,
            fy,
            cx - 0.5,
            cy - 0.5,
            Distortion::from_array(d),
        ))
    }

    /// The COLMAP camera (model and parameters) of a [`geom::Camera`].
    pub fn from_camera(id: u32, cam: &Camera) -> Self {
        let [k1, k2, p1, p2, k3] = cam.dist.to_array();
        let (fx, fy, cx, cy) = (cam.fx, cam.fy, cam.cx + 0.5, cam.cy + 0.5);
        let (model, params) = if cam.dist.is_zero() {
            ("PINHOLE", vec![fx, fy, cx, cy])
        } else if k3 == 0.0 {
            ("OPENCV", vec![fx, fy, cx, cy, k1, k2, p1, p2])
        } else {
            let zero = 0.0;
            (
                "FULL_OPENCV",
                vec![fx, fy, cx, cy, k1, k2, p1, p2, k3, zero, zero, zero],
            )
        };
        Self {
            id,
            model: model.to_string(),
            width: cam.width,
            height: cam.height,
            params,
        }
    }
}

/// Reads a COLMAP text model (`path` = the model folder or its `images.txt`); see the module doc
/// for the conversion.
pub fn read(path: &Path) -> Result<Trajectory> {
    let (dir, images_path) = model_paths(path)?;
    let images = read_images(&images_path)?;
    let cameras_path = dir.join(CAMERAS_TXT);
    let cameras = if cameras_path.exists() {
        Some(read_cameras(&cameras_path)?)
    } else {
        None
    };
    let camera = match &cameras {
        Some(cams) => shared_camera(&images_path, &images, cams)?,
        None => None,
    };
    let frames = images
        .into_iter()
        .map(|im| PoseFrame {
            seq: seq_of(&im.name),
            name: im.name,
            t: None,
            pose: im.pose,
        })
        .collect();
    Ok(Trajectory { frames, camera })
}

/// Reads `cameras.txt` (`path` = the file or the model folder). Unknown model names, wrong
/// parameter counts and invalid intrinsics are errors naming the line. Cameras of the placeholder
/// [`write()`] emits come back with model `"PLACEHOLDER"`.
pub fn read_cameras(path: &Path) -> Result<Vec<ColmapCamera>> {
    let path = if path.is_dir() {
        path.join(CAMERAS_TXT)
    } else {
        path.to_path_buf()
    };
    let text = read_text(&path)?;
    let placeholder = text.lines().any(|l| l.trim() == PLACEHOLDER);
    let mut cameras: Vec<ColmapCamera> = Vec::new();
    for (i, line) in text.lines().enumerate() {
        let line = line.trim();
        if line.is_empty() || line.starts_with('#') {
            continue;
        }
        let mut cam = parse_camera(&path, i + 1, line)?;
        if cameras.iter().any(|c| c.id == cam.id) {
            return Err(DataError::parse(
                &path,
                i + 1,
                format!("camera {} appears twice", cam.id),
            ));
        }
        if placeholder {
            cam.model = "PLACEHOLDER".to_string();
        }
        cameras.push(cam);
    }
    Ok(cameras)
}

/// Writes `traj` as a COLMAP text model into `dir` (see the module doc).
pub fn write(traj: &Trajectory, dir: &Path) -> Result<()> {
    let images_path = dir.join(IMAGES_TXT);
    let images = images_text(&images_path, traj)?;
    let cameras = cameras_text(traj.camera.as_ref());
    write_text_atomic(&dir.join(CAMERAS_TXT), &cameras)?;
    write_text_atomic(&images_path, &images)?;
    write_text_atomic(
        &dir.join(POINTS3D_TXT),
        "# 3D point list with one line of data per point:\n\
         #   POINT3D_ID, X, Y, Z, R, G, B, ERROR, TRACK[] as (IMAGE_ID, POINT2D_IDX)\n\
         # Number of points: 0, mean track length: 0\n",
    )
}

/// The model folder and its `images.txt` for a folder or file argument.
fn model_paths(path: &Path) -> Result<(PathBuf, PathBuf)> {
    if !path.is_dir() {
        let dir = path.parent().map(Path::to_path_buf).unwrap_or_default();
        return Ok((dir, path.to_path_buf()));
    }
    let images = path.join(IMAGES_TXT);
    if !images.exists() && path.join("images.bin").exists() {
        return Err(DataError::invalid(
            path,
            "binary COLMAP model; convert it with `colmap model_converter --input_path DIR \
             --output_path DIR --output_type TXT`",
        ));
    }
    Ok((path.to_path_buf(), images))
}

/// An image of `images.txt`, pose already camera-to-world.
struct Image {
    line: usize,
    camera_id: u32,
    name: String,
    pose: Pose,
}

fn read_images(path: &Path) -> Result<Vec<Image>> {
    let text = read_text(path)?;
    let lines: Vec<&str> = text.lines().collect();
    let mut images: Vec<Image> = Vec::new();
    let mut ids: HashMap<u32, usize> = HashMap::new();
    let mut names: HashMap<String, usize> = HashMap::new();
    let mut i = 0;
    while i < lines.len() {
        let (line_no, line) = (i + 1, lines[i].trim());
        i += 1;
        if line.is_empty() || line.starts_with('#') {
            continue;
        }
        let (id, image) = parse_image(path, line_no, line)?;
        // The next line is always the image's 2D points, even when empty.
        if let Some(points) = lines.get(i) {
            check_points(path, i + 1, points, line_no)?;
            i += 1;
        }
        if let Some(first) = ids.insert(id, line_no) {
            let msg = format!("image id {id} appears twice (also on line {first})");
            return Err(DataError::parse(path, line_no, msg));
        }
        if let Some(first) = names.insert(image.name.clone(), line_no) {
            let msg = format!(
                "image name '{}' appears twice (also on line {first})",
                image.name
            );
            return Err(DataError::parse(path, line_no, msg));
        }
        images.push(image);
    }
    if images.is_empty() {
        return Err(DataError::invalid(path, "no images"));
    }
    Ok(images)
}

/// Parses `IMAGE_ID QW QX QY QZ TX TY TZ CAMERA_ID NAME` into the camera-to-world pose.
fn parse_image(path: &Path, line_no: usize, line: &str) -> Result<(u32, Image)> {
    let f: Vec<&str> = line.split_whitespace().collect();
    if f.len() < 10 {
        return Err(DataError::parse(
            path,
            line_no,
            format!(
                "expected IMAGE_ID QW QX QY QZ TX TY TZ CAMERA_ID NAME, found {} fields",
                f.len()
            ),
        ));
    }
    let id = parse_id(path, line_no, "IMAGE_ID", f[0])?;
    let v = parse_numbers(path, line_no, &f[1..8])?;
    let camera_id = parse_id(path, line_no, "CAMERA_ID", f[8])?;
    let world_to_camera = Pose::from_t_wxyz([v[4], v[5], v[6]], [v[0], v[1], v[2], v[3]])
        .map_err(|e| DataError::parse(path, line_no, e.to_string()))?;
    let image = Image {
        line: line_no,
        camera_id,
        name: f[9..].join(" "),
        pose: world_to_camera.inverse(),
    };
    Ok((id, image))
}

/// A 2D-points line holds `X Y POINT3D_ID` triples; anything else means the file does not have
/// two lines per image (a common mistake of hand-made files), which would drop every other image.
fn check_points(path: &Path, line_no: usize, line: &str, image_line: usize) -> Result<()> {
    let n = line.split_whitespace().count();
    if !n.is_multiple_of(3) {
        return Err(DataError::parse(
            path,
            line_no,
            format!(
                "expected the 2D points of the image on line {image_line} (X Y POINT3D_ID \
                 triples, possibly none), found {n} fields; images.txt has two lines per image"
            ),
        ));
    }
    Ok(())
}

fn parse_id(path: &Path, line_no: usize, what: &str, text: &str) -> Result<u32> {
    text.parse()
        .map_err(|_| DataError::parse(path, line_no, format!("{what} '{text}' is not an id")))
}

/// Parses `CAMERA_ID MODEL WIDTH HEIGHT PARAMS...`.
fn parse_camera(path: &Path, line_no: usize, line: &str) -> Result<ColmapCamera> {
    let f: Vec<&str> = line.split_whitespace().collect();
    if f.len() < 4 {
        let msg = format!(
            "expected CAMERA_ID MODEL WIDTH HEIGHT PARAMS..., found {} fields",
            f.len()
        );
        return Err(DataError::parse(path, line_no, msg));
    }
    let id = parse_id(path, line_no, "CAMERA_ID", f[0])?;
    let model = f[1].to_ascii_uppercase();
    let Some(&(_, count)) = MODELS.iter().find(|(name, _)| *name == model) else {
        let known: Vec<&str> = MODELS.iter().map(|(n, _)| *n).collect();
        let msg = format!(
            "unknown camera model '{}' (COLMAP models: {})",
            f[1],
            known.join(", ")
        );
        return Err(DataError::parse(path, line_no, msg));
    };
    let size = |s: &str| {
        s.parse::<u32>().map_err(|_| {
            DataError::parse(
                path,
                line_no,
                format!("image size '{s}' is not a whole number"),
            )
        })
    };
    let (width, height) = (size(f[2])?, size(f[3])?);
    let params = parse_numbers(path, line_no, &f[4..])?;
    if params.len() != count {
        let msg = format!("{model} has {count} parameters, found {}", params.len());
        return Err(DataError::parse(path, line_no, msg));
    }
    let cam = ColmapCamera {
        id,
        model,
        width,
        height,
        params,
    };
    if let Some(Err(e)) = cam.convert() {
        return Err(DataError::parse(path, line_no, e.to_string()));
    }
    Ok(cam)
}

/// The camera all images share, when it has a [`geom::Camera`]; errors on an image whose camera
/// `cameras.txt` lacks.
fn shared_camera(
    path: &Path,
    images: &[Image],
    cameras: &[ColmapCamera],
) -> Result<Option<Camera>> {
    for im in images {
        if !cameras.iter().any(|c| c.id == im.camera_id) {
            let msg = format!("camera {} is not in {CAMERAS_TXT}", im.camera_id);
            return Err(DataError::parse(path, im.line, msg));
        }
    }
    let ids: HashSet<u32> = images.iter().map(|im| im.camera_id).collect();
    if ids.len() != 1 {
        return Ok(None);
    }
    Ok(cameras
        .iter()
        .find(|c| ids.contains(&c.id))
        .and_then(ColmapCamera::to_camera))
}

fn seq_of(name: &str) -> String {
    match name.rsplit_once('/') {
        Some((dir, _)) if !dir.is_empty() => dir.to_string(),
        _ => DEFAULT_SEQ.to_string(),
    }
}

fn cameras_text(camera: Option<&Camera>) -> String {
    let mut s = String::from(
        "# Camera list with one line of data per camera:\n\
         #   CAMERA_ID, MODEL, WIDTH, HEIGHT, PARAMS[]\n\
         # Number of cameras: 1\n",
    );
    let cam = match camera {
        Some(c) => ColmapCamera::from_camera(1, c),
        None => {
            s.push_str(PLACEHOLDER);
            s.push('\n');
            ColmapCamera {
                id: 1,
                model: "PINHOLE".into(),
                width: 1,
                height: 1,
                params: vec![1.0, 1.0, 0.5, 0.5],
            }
        }
    };
    let _ = write!(s, "{} {} {} {}", cam.id, cam.model, cam.width, cam.height);
    for p in &cam.params {
        let _ = write!(s, " {p}");
    }
    s.push('\n');
    s
}

fn images_text(path: &Path, traj: &Trajectory) -> Result<String> {
    if traj.is_empty() {
        return Err(DataError::invalid(path, "no frames to write"));
    }
    let mut s = format!(
        "# Image list with two lines of data per image:\n\
         #   IMAGE_ID, QW, QX, QY, QZ, TX, TY, TZ, CAMERA_ID, NAME\n\
         #   POINTS2D[] as (X, Y, POINT3D_ID)\n\
         # Number of images: {}, mean observations per image: 0\n",
        traj.len()
    );
    let mut names = HashSet::new();
    for (i, f) in traj.frames.iter().enumerate() {
        if f.name.is_empty() || f.name.contains(char::is_whitespace) {
            let msg = format!(
                "frame name '{}' must be non-empty without whitespace",
                f.name
            );
            return Err(DataError::invalid(path, msg));
        }
        if !names.insert(f.name.as_str()) {
            return Err(DataError::invalid(
                path,
                format!("frame name '{}' appears twice", f.name),
            ));
        }
        require_finite(path, f)?;
        let w2c = f.pose.inverse();
        let [qw, qx, qy, qz] = w2c.quat_wxyz();
        let [tx, ty, tz] = w2c.position();
        let _ = writeln!(
            s,
            "{} {qw} {qx} {qy} {qz} {tx} {ty} {tz} 1 {}\n",
            i + 1,
            f.name
        );
    }
    Ok(s)
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::test_util::{geo, put, tmp};
    use nalgebra::Vector3;

    fn err_text<T>(r: Result<T>) -> String {
        r.err().map(|e| e.to_string()).unwrap_or_default()
    }

    const CAMERAS: &str = "# Camera list with one line of data per camera:\n\
                           #   CAMERA_ID, MODEL, WIDTH, HEIGHT, PARAMS[]\n\
                           1 PINHOLE 640 480 500 510 320 240\n";

    #[test]
    fn hand_checked_model() -> Result<()> {
        let dir = tmp()?;
        put(dir.path(), CAMERAS_TXT, CAMERAS)?;
        // Image 1: R = I, t = (0, 0, −2): x_cam = x_world + t is 0 at the centre, so c = (0, 0, 2).
        // Image 2: R = Ry(90°) = [0 0 1; 0 1 0; −1 0 0] (q = (cos 45°, 0, sin 45°, 0)),
        // t = (1, 0, 0): c = −Rᵀt = −(0, 0, 1) = (0, 0, −1); the camera looks along
        // Rᵀ·(0, 0, 1) = (−1, 0, 0), so the world point (−2, 0, −1) lies 2 m in front of it:
        // R·(−2, 0, −1) + t = (−1, 0, 2) + (1, 0, 0) = (0, 0, 2).
        // Its 2D-points line is empty; image 2 has one observation.
        let h = std::f64::consts::FRAC_1_SQRT_2;
        put(
            dir.path(),
            IMAGES_TXT,
            &format!(
                "# Image list with two lines of data per image:\n\
                 1 1 0 0 0 0 0 -2 1 seqA/img1.png\n\
                 \n\
                 2 {h} 0 {h} 0 1 0 0 1 img2.png\n\
                 100.5 200.5 -1\n"
            ),
        )?;
        let traj = read(dir.path())?;
        assert_eq!(traj.len(), 2);
        let (a, b) = (&traj.frames[0], &traj.frames[1]);
        assert_eq!(
            (a.name.as_str(), a.seq.as_str(), a.t),
            ("seqA/img1.png", "seqA", None)
        );
        assert_eq!((b.name.as_str(), b.seq.as_str()), ("img2.png", DEFAULT_SEQ));
        assert_eq!(a.pose.position(), [0.0, 0.0, 2.0]);
        assert_eq!(a.pose.quat_wxyz(), [1.0, 0.0, 0.0, 0.0]);
        assert!((b.pose.translation - Vector3::new(0.0, 0.0, -1.0)).norm() < 1e-15);
        assert!((b.pose.forward() - Vector3::new(-1.0, 0.0, 0.0)).norm() < 1e-15);
        let p = b
            .pose
            .inverse()
            .transform_point(&nalgebra::Point3::new(-2.0, 0.0, -1.0));
        assert!((p.coords - Vector3::new(0.0, 0.0, 2.0)).norm() < 1e-15);
        // Principal point moves by half a pixel into OpenCV's convention.
        let cam = geo(Camera::new(
            640,
            480,
            500.0,
            510.0,
            319.5,
            239.5,
            Distortion::default(),
        ))?;
        assert_eq!(traj.camera, Some(cam));
        // images.txt itself works as the path too.
        assert_eq!(read(&dir.path().join(IMAGES_TXT))?, traj);
        Ok(())
    }

    #[test]
    fn camera_models() -> Result<()> {
        let dir = tmp()?;
        let cases = [
            (
                "SIMPLE_PINHOLE 100 80 50 40.5 30.5",
                [50.0, 50.0, 40.0, 30.0],
                [0.0; 5],
            ),
            (
                "SIMPLE_RADIAL 100 80 50 40.5 30.5 0.1",
                [50.0, 50.0, 40.0, 30.0],
                [0.1, 0.0, 0.0, 0.0, 0.0],
            ),
            (
                "RADIAL 100 80 50 40.5 30.5 0.1 0.2",
                [50.0, 50.0, 40.0, 30.0],
                [0.1, 0.2, 0.0, 0.0, 0.0],
            ),
            (
                "OPENCV 100 80 50 60 40.5 30.5 0.1 0.2 0.3 0.4",
                [50.0, 60.0, 40.0, 30.0],
                [0.1, 0.2, 0.3, 0.4, 0.0],
            ),
            (
                "FULL_OPENCV 100 80 50 60 40.5 30.5 0.1 0.2 0.3 0.4 0.5 0 0 0",
                [50.0, 60.0, 40.0, 30.0],
                [0.1, 0.2, 0.3, 0.4, 0.5],
            ),
        ];
        for (line, [fx, fy, cx, cy], d) in cases {
            let p = put(dir.path(), CAMERAS_TXT, &format!("7 {line}\n"))?;
            let cams = read_cameras(&p)?;
            let want = geo(Camera::new(
                100,
                80,
                fx,
                fy,
                cx,
                cy,
                Distortion::from_array(d),
            ))?;
            assert_eq!(cams[0].to_camera(), Some(want), "{line}");
        }
        // A fisheye is read, but has no pinhole camera: poses still work.
        put(
            dir.path(),
            CAMERAS_TXT,
            "1 OPENCV_FISHEYE 100 80 50 60 40 30 0.1 0.2 0.3 0.4\n",
        )?;
        put(dir.path(), IMAGES_TXT, "1 1 0 0 0 0 0 0 1 a.png\n\n")?;
        let traj = read(dir.path())?;
        assert!(traj.camera.is_none() && traj.len() == 1);
        // Two cameras: no shared camera.
        put(
            dir.path(),
            CAMERAS_TXT,
            &format!("{CAMERAS}2 PINHOLE 64 48 50 50 32 24\n"),
        )?;
        put(
            dir.path(),
            IMAGES_TXT,
            "1 1 0 0 0 0 0 0 1 a.png\n\n2 1 0 0 0 0 0 0 2 b.png\n",
        )?;
        assert!(read(dir.path())?.camera.is_none());
        Ok(())
    }

    #[test]
    fn round_trip() -> Result<()> {
        let dists = [
            [0.0; 5],
            [0.1, -0.02, 0.001, 0.002, 0.0],
            [0.1, -0.02, 0.001, 0.002, 0.003],
        ];
        let mut cameras: Vec<Option<Camera>> = vec![None];
        for d in dists {
            let cam = Camera::new(
                1080,
                1920,
                1375.52,
                1374.49,
                554.058,
                964.768,
                Distortion::from_array(d),
            );
            cameras.push(Some(geo(cam)?));
        }
        for camera in cameras {
            let mut frames = Vec::new();
            for i in 0..5 {
                let a = i as f64 * 1.1 - 2.0;
                let pose = geo(Pose::from_euler_ypr(
                    a,
                    0.3 * a,
                    -0.5 * a,
                    [3.0 * a, -a, 0.25 * a],
                ))?;
                let pose = Pose::new(geom::rotation::canonical(&pose.rotation), pose.translation);
                let seq = if i < 3 { "day1" } else { "day2/cam0" };
                let name = format!("{seq}/{i:04}.jpg");
                frames.push(PoseFrame {
                    name,
                    seq: seq.into(),
                    t: None,
                    pose,
                });
            }
            let traj = Trajectory { frames, camera };
            let dir = tmp()?;
            write(&traj, dir.path())?;
            assert!(dir.path().join(POINTS3D_TXT).is_file());
            let back = read(dir.path())?;
            assert_eq!(back.camera, traj.camera);
            for (a, b) in traj.frames.iter().zip(&back.frames) {
                assert_eq!((&a.name, &a.seq, a.t), (&b.name, &b.seq, b.t));
                assert_eq!(a.pose.rotation, b.pose.rotation);
                assert!((a.pose.translation - b.pose.translation).norm() < 1e-14);
            }
        }
        Ok(())
    }

    #[test]
    fn malformed_models_are_errors() -> Result<()> {
        let dir = tmp()?;
        put(dir.path(), CAMERAS_TXT, CAMERAS)?;
        let images = |text: &str| -> Result<String> {
            put(dir.path(), IMAGES_TXT, text)?;
            Ok(err_text(read(dir.path())))
        };
        let cases = [
            (
                "1 1 0 0 0 0 0 0 1 a.png\n\n2 1 1 0 0 0 0 0 1 b.png\n\n",
                ":3:",
                "quaternion norm",
            ),
            ("1 1 0 0 0 NaN 0 0 1 a.png\n\n", ":1:", "non-finite"),
            ("1 1 0 0 0 0 0 0 1\n\n", ":1:", "found 9 fields"),
            (
                "1 1 0 0 0 0 0 0 1 a.png\n2 1 0 0 0 0 0 0 1 b.png\n",
                ":2:",
                "two lines per image",
            ),
            ("1 1 0 0 0 0 0 0 9 a.png\n\n", ":1:", "camera 9 is not in"),
            (
                "1 1 0 0 0 0 0 0 1 a.png\n\n1 1 0 0 0 0 0 0 1 b.png\n\n",
                ":3:",
                "appears twice",
            ),
            ("x 1 0 0 0 0 0 0 1 a.png\n\n", ":1:", "IMAGE_ID 'x'"),
        ];
        for (text, line, msg) in cases {
            let e = images(text)?;
            assert!(
                e.contains(&format!("{IMAGES_TXT}{line}")) && e.contains(msg),
                "{text:?}: {e}"
            );
        }
        let e = images("")?;
        assert!(e.contains(IMAGES_TXT) && e.contains("no images"), "{e}");
        let p = dir.path().join(IMAGES_TXT);
        std::fs::write(&p, [0u8, 159, 146, 150, 255]).map_err(|e| DataError::io(&p, e))?;
        let e = err_text(read(dir.path()));
        assert!(
            e.contains(IMAGES_TXT) && e.contains("not a text file"),
            "{e}"
        );
        put(dir.path(), IMAGES_TXT, "1 1 0 0 0 0 0 0 1 a.png\n\n")?;
        let cams = [
            ("1 FOOBAR 640 480 1 2 3\n", "unknown camera model 'FOOBAR'"),
            (
                "1 PINHOLE 640 480 500 500 320\n",
                "PINHOLE has 4 parameters, found 3",
            ),
            ("1 PINHOLE 640 480 -500 500 320 240\n", "invalid camera"),
            ("1 PINHOLE 640.5 480 500 500 320 240\n", "'640.5'"),
        ];
        for (text, msg) in cams {
            put(dir.path(), CAMERAS_TXT, &format!("# c\n{text}"))?;
            let e = err_text(read(dir.path()));
            assert!(
                e.contains(&format!("{CAMERAS_TXT}:2:")) && e.contains(msg),
                "{text:?}: {e}"
            );
        }
        // Binary models are pointed at the converter.
        let bin = tmp()?;
        put(bin.path(), "images.bin", "\0")?;
        assert!(err_text(read(bin.path())).contains("model_converter"));
        // The writer refuses names COLMAP would split.
        let f = PoseFrame {
            name: "a b.png".into(),
            seq: "s".into(),
            t: None,
            pose: Pose::identity(),
        };
        assert!(write(&Trajectory::new(vec![f]), bin.path()).is_err());
        Ok(())
    }
}
