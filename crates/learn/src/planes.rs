//! Dominant-plane targets and loss for the auxiliary task of [`crate::net::NetConfig::planes`].
//!
//! # Targets
//! Each frame needs a depth image (`depth/NNNNNN.png`, 16-bit millimetres) and, when the
//! dataset has them, the renderer's plane ids (`planes/NNNNNN.png`, 8-bit, the frame's planes
//! ranked by size). Without plane ids (a real RGB-D dataset) the dominant planes are found in
//! the depth by sequential RANSAC ([`ransac_planes`]). Every plane is fitted to its pixels'
//! back-projected points by least squares (the smallest eigenvector of their covariance) and
//! written as `n·X = d` in the camera frame, `n` the unit normal pointing away from the camera
//! and `d > 0` the plane's distance.
//!
//! The targets live on the network's stride-8 grid. A cell takes the plane most of its pixels
//! show (none when most show no plane or clutter) and gets
//! - its class: the camera axis `n` is closest to ([`PlaneClass`]; the camera frame, not the
//!   world's, so real datasets need no gravity direction),
//! - its parameters `(n, ln d)`,
//! - its measured depth (mean over the plane's pixels in the cell) and the ray through them.
//!
//! # Loss
//! Cross-entropy of the classes over every cell, then over the cells with a plane: the L1 error
//! of the normal and of `ln d`, and the **depth-induced consistency** term, the relative error of
//! the depth the predicted plane induces along the cell's ray, `z = d / (n·r)`, against the
//! measured depth. The last ties the two parameters together as geometry does: a plane that is
//! a little off in both can still put the surface in the right place.
//!
//! Written by hand: no crate fits planes to depth images or makes these targets.

use std::path::Path;

use burn::tensor::activation::log_softmax;
use burn::tensor::{Device, Tensor, TensorData};
use data::native::{self, CameraInfo};
use nalgebra::{Matrix3, SymmetricEigen, Vector3};
use rand::{Rng, SeedableRng};
use rand_chacha::ChaCha8Rng;
use rayon::prelude::*;

use crate::dataset::Samples;
use crate::hash::Fnv64;
pub use crate::net::{PLANE_CLASSES, PLANE_PARAMS, PlaneOutputs};
use crate::{LearnError, Result};

/// The class of a plane: the camera axis its normal (pointing away from the camera) is
/// closest to. With OpenCV axes (x right, y down, z ahead) a floor in front of a level camera
/// is `Below`, a ceiling `Above`, side walls `Left` / `Right`, the wall faced `Ahead`.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum PlaneClass {
    /// No dominant plane (clutter, people, nothing seen).
    None = 0,
    /// Normal along +y: floor-like.
    Below = 1,
    /// Normal along −y: ceiling-like.
    Above = 2,
    /// Normal along −x.
    Left = 3,
    /// Normal along +x.
    Right = 4,
    /// Normal along +z: faced.
    Ahead = 5,
}

impl PlaneClass {
    /// The class of a unit normal pointing away from the camera.
    pub fn of_normal(n: Vector3<f64>) -> PlaneClass {
        let (ax, ay, az) = (n.x.abs(), n.y.abs(), n.z.abs());
        if az >= ax && az >= ay {
            PlaneClass::Ahead
        } else if ay >= ax {
            if n.y > 0.0 {
                PlaneClass::Below
            } else {
                PlaneClass::Above
            }
        } else if n.x > 0.0 {
            PlaneClass::Right
        } else {
            PlaneClass::Left
        }
    }
}

/// A plane `n·X = d` in the camera frame.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct Plane {
    /// Unit normal, pointing away from the camera.
    pub normal: Vector3<f64>,
    /// Distance from the camera, metres (> 0).
    pub distance: f64,
    /// RMS distance of the fitted points from the plane, metres.
    pub rms: f64,
}

/// Pinhole intrinsics of the depth and plane images.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct Intrinsics {
    /// Focal lengths, pixels.
    pub fx: f64,
    /// Focal length along y, pixels.
    pub fy: f64,
    /// Principal point, pixels.
    pub cx: f64,
    /// Principal point y, pixels.
    pub cy: f64,
}

impl Intrinsics {
    /// The intrinsics of a dataset camera scaled to images of `width` pixels (depth images
    /// may be smaller than the colour images).
    pub fn of(camera: &CameraInfo, width: u32, height: u32) -> Intrinsics {
        let sx = f64::from(width) / f64::from(camera.width.max(1));
        let sy = f64::from(height) / f64::from(camera.height.max(1));
        Intrinsics {
            fx: camera.fx * sx,
            fy: camera.fy * sy,
            cx: (camera.cx + 0.5) * sx - 0.5,
            cy: (camera.cy + 0.5) * sy - 0.5,
        }
    }

    /// The ray `(x/z, y/z)` through pixel `(u, v)`.
    fn ray(&self, u: f64, v: f64) -> (f64, f64) {
        ((u - self.cx) / self.fx, (v - self.cy) / self.fy)
    }
}

/// A depth image in metres (0: no depth), row-major.
#[derive(Clone, Debug, PartialEq)]
pub struct DepthImage {
    /// Width, pixels.
    pub width: usize,
    /// Height, pixels.
    pub height: usize,
    /// Depth along the optical axis, metres.
    pub depth: Vec<f32>,
}

impl DepthImage {
    /// The camera-frame point of pixel `i`, if it has depth.
    fn point(&self, intr: &Intrinsics, i: usize) -> Option<Vector3<f64>> {
        let z = f64::from(self.depth[i]);
        (z > 0.0).then(|| {
            let (x, y) = intr.ray((i % self.width) as f64, (i / self.width) as f64);
            Vector3::new(x * z, y * z, z)
        })
    }
}

/// Least-squares plane through `points` (at least 3, not all on a line), oriented away from
/// the camera.
pub fn fit_plane(points: &[Vector3<f64>]) -> Option<Plane> {
    if points.len() < 3 {
        return None;
    }
    let n = points.len() as f64;
    let centroid = points.iter().sum::<Vector3<f64>>() / n;
    let mut cov = Matrix3::zeros();
    for p in points {
        let d = p - centroid;
        cov += d * d.transpose();
    }
    let eigen = SymmetricEigen::new(cov / n);
    let (k, &smallest) = eigen
        .eigenvalues
        .iter()
        .enumerate()
        .min_by(|a, b| a.1.total_cmp(b.1))?;
    let mut normal: Vector3<f64> = eigen.eigenvectors.column(k).into_owned();
    if !normal.iter().all(|v| v.is_finite()) || normal.norm() < 0.5 {
        return None;
    }
    normal.normalize_mut();
    let mut distance = normal.dot(&centroid);
    if distance < 0.0 {
        normal = -normal;
        distance = -distance;
    }
    // A plane through the camera is seen edge-on: no use as a target.
    (distance > 1e-3).then_some(Plane {
        normal,
        distance,
        rms: smallest.max(0.0).sqrt(),
    })
}

/// Dominant planes found in a depth image without plane ids: up to `max_planes` planes by
/// sequential RANSAC on every 4th pixel of every 4th row, each holding at least 5 % of the
/// pixels with depth, inliers within 2 cm + 1 % of the depth; then every pixel goes to the
/// first plane it lies on. Returns ids per pixel (1 = the first plane found, 0 = none) for
/// [`frame_planes`]. Deterministic per `seed`.
pub fn ransac_planes(
    depth: &DepthImage,
    intr: &Intrinsics,
    max_planes: usize,
    seed: u64,
) -> Vec<u8> {
    const ITERATIONS: usize = 200;
    let tol = |p: &Vector3<f64>| 0.02 + 0.01 * p.z;
    let mut pts: Vec<Vector3<f64>> = (0..depth.height)
        .step_by(4)
        .flat_map(|y| {
            (0..depth.width)
                .step_by(4)
                .map(move |x| y * depth.width + x)
        })
        .filter_map(|i| depth.point(intr, i))
        .collect();
    let min_support = (pts.len() / 20).max(3);
    let mut rng = ChaCha8Rng::seed_from_u64(seed);
    let mut planes: Vec<Plane> = Vec::new();
    while planes.len() < max_planes.min(254) && pts.len() >= min_support {
        let mut best: Option<(usize, Plane)> = None;
        for _ in 0..ITERATIONS {
            let sample: Vec<Vector3<f64>> = (0..3)
                .map(|_| pts[rng.random_range(0..pts.len())])
                .collect();
            let normal = (sample[1] - sample[0]).cross(&(sample[2] - sample[0]));
            if normal.norm() < 1e-9 {
                continue;
            }
            let normal = normal.normalize();
            let distance = normal.dot(&sample[0]);
            let count = pts
                .iter()
                .filter(|p| (normal.dot(p) - distance).abs() < tol(p))
                .count();
            if best.as_ref().is_none_or(|(c, _)| count > *c) {
                let plane = Plane {
                    normal,
                    distance,
                    rms: 0.0,
                };
                best = Some((count, plane));
            }
        }
        let Some((count, guess)) = best else { break };
        if count < min_support {
            break;
        }
        let (inliers, rest): (Vec<Vector3<f64>>, Vec<Vector3<f64>>) = pts
            .iter()
            .partition(|p| (guess.normal.dot(p) - guess.distance).abs() < tol(p));
        let Some(plane) = fit_plane(&inliers) else {
            break;
        };
        planes.push(plane);
        pts = rest;
    }
    (0..depth.width * depth.height)
        .map(|i| {
            depth
                .point(intr, i)
                .and_then(|p| {
                    planes
                        .iter()
                        .position(|pl| (pl.normal.dot(&p) - pl.distance).abs() < tol(&p))
                })
                .map_or(0, |k| (k + 1) as u8)
        })
        .collect()
}

/// The planes of one frame, index `id − 1` for plane id `id` (`None`: too few points with
/// depth, or not flat: RMS over 5 cm + 5 % of its distance).
pub fn frame_planes(depth: &DepthImage, ids: &[u8], intr: &Intrinsics) -> Vec<Option<Plane>> {
    let top = ids.iter().copied().max().unwrap_or(0) as usize;
    let mut points: Vec<Vec<Vector3<f64>>> = vec![Vec::new(); top];
    for (i, &id) in ids.iter().enumerate() {
        // Every other pixel of every other row is plenty for a least-squares fit.
        let (x, y) = (i % depth.width, i / depth.width);
        if id == 0 || x % 2 == 1 || y % 2 == 1 {
            continue;
        }
        if let Some(p) = depth.point(intr, i) {
            points[usize::from(id) - 1].push(p);
        }
    }
    points
        .iter()
        .map(|pts| {
            if pts.len() < 12 {
                return None;
            }
            fit_plane(pts).filter(|p| p.rms <= 0.05 + 0.05 * p.distance)
        })
        .collect()
}

/// The targets of one frame on a `[gh, gw]` grid (see the module docs).
#[derive(Clone, Debug, PartialEq)]
pub struct FrameTargets {
    /// Class per cell ([`PlaneClass`] as a number).
    pub classes: Vec<u8>,
    /// `[nx, ny, nz, ln d]` per cell (zeros where no plane).
    pub params: Vec<[f32; 4]>,
    /// Measured depth per cell, metres (0 where no plane).
    pub depth: Vec<f32>,
    /// Ray `(x/z, y/z)` per cell through the pixels of its plane.
    pub rays: Vec<[f32; 2]>,
}

/// Targets of one frame from its depth and plane ids (same size), on a `grid` of `[gh, gw]`
/// cells spanning the image.
pub fn frame_targets(
    depth: &DepthImage,
    ids: &[u8],
    intr: &Intrinsics,
    grid: [usize; 2],
) -> FrameTargets {
    let planes = frame_planes(depth, ids, intr);
    let [gh, gw] = grid;
    let (w, h) = (depth.width, depth.height);
    let mut out = FrameTargets {
        classes: vec![0; gh * gw],
        params: vec![[0.0; 4]; gh * gw],
        depth: vec![0.0; gh * gw],
        rays: vec![[0.0; 2]; gh * gw],
    };
    let mut counts = vec![0usize; planes.len() + 1];
    for cy in 0..gh {
        for cx in 0..gw {
            let (y0, y1) = (cy * h / gh, ((cy + 1) * h / gh).max(cy * h / gh + 1).min(h));
            let (x0, x1) = (cx * w / gw, ((cx + 1) * w / gw).max(cx * w / gw + 1).min(w));
            counts.iter_mut().for_each(|c| *c = 0);
            for y in y0..y1 {
                for &id in &ids[y * w + x0..y * w + x1] {
                    counts[usize::from(id).min(planes.len())] += 1;
                }
            }
            let (best, &n) = counts
                .iter()
                .enumerate()
                .max_by(|a, b| a.1.cmp(b.1).then(b.0.cmp(&a.0)))
                .unwrap_or((0, &0));
            let Some(plane) = (best > 0).then(|| planes[best - 1]).flatten() else {
                continue;
            };
            let (mut z, mut rx, mut ry, mut m) = (0.0, 0.0, 0.0, 0usize);
            for y in y0..y1 {
                for x in x0..x1 {
                    let i = y * w + x;
                    if usize::from(ids[i]) == best && depth.depth[i] > 0.0 {
                        let (a, b) = intr.ray(x as f64, y as f64);
                        z += f64::from(depth.depth[i]);
                        rx += a;
                        ry += b;
                        m += 1;
                    }
                }
            }
            if m == 0 || n == 0 {
                continue;
            }
            let c = cy * gw + cx;
            let m = m as f64;
            out.classes[c] = PlaneClass::of_normal(plane.normal) as u8;
            let nn = plane.normal;
            out.params[c] = [nn.x, nn.y, nn.z, plane.distance.ln()].map(|v| v as f32);
            out.depth[c] = (z / m) as f32;
            out.rays[c] = [(rx / m) as f32, (ry / m) as f32];
        }
    }
    out
}

/// The plane targets of every sample of a split, on one grid.
#[derive(Clone, Debug, Default, PartialEq)]
pub struct PlaneTargets {
    /// `[gh, gw]`.
    pub grid: [usize; 2],
    /// One per sample, in the samples' order.
    pub frames: Vec<FrameTargets>,
}

impl PlaneTargets {
    /// Share of cells of all frames with a plane class other than none.
    pub fn coverage(&self) -> f64 {
        let (mut with, mut all) = (0usize, 0usize);
        for f in &self.frames {
            with += f.classes.iter().filter(|&&c| c != 0).count();
            all += f.classes.len();
        }
        with as f64 / all.max(1) as f64
    }
}

/// Reads an image file, adding its bytes to `hash`.
fn read_image(path: &Path, hash: &mut Fnv64) -> Result<image::DynamicImage> {
    let bytes = std::fs::read(path).map_err(|e| LearnError::io(path, e))?;
    hash.update(&bytes);
    image::load_from_memory(&bytes).map_err(|e| LearnError::Image {
        path: path.to_path_buf(),
        msg: e.to_string(),
    })
}

/// Reads a 16-bit millimetre depth PNG.
fn read_depth(path: &Path, hash: &mut Fnv64) -> Result<DepthImage> {
    let img = read_image(path, hash)?.into_luma16();
    Ok(DepthImage {
        width: img.width() as usize,
        height: img.height() as usize,
        depth: img.pixels().map(|p| f32::from(p.0[0]) / 1000.0).collect(),
    })
}

/// Reads an 8-bit plane-id PNG of `width x height`.
fn read_ids(path: &Path, width: usize, height: usize, hash: &mut Fnv64) -> Result<Vec<u8>> {
    let img = read_image(path, hash)?.into_luma8();
    if (img.width() as usize, img.height() as usize) != (width, height) {
        return Err(LearnError::Image {
            path: path.to_path_buf(),
            msg: format!(
                "plane ids are {}x{}, the depth image {width}x{height}",
                img.width(),
                img.height()
            ),
        });
    }
    Ok(img.into_raw())
}

/// Plane targets of `samples` (frames of the native dataset at `root`, named `seq/NNNNNN`) on
/// `grid`, in parallel, and a hash of the files read. Errors name the file: a frame without
/// `depth/`, an unreadable image.
pub(crate) fn load(
    root: &Path,
    camera: &CameraInfo,
    samples: &Samples,
    grid: [usize; 2],
) -> Result<(PlaneTargets, u64)> {
    // The files are checked in order first, so a missing one is named the same way every run.
    let mut names = Vec::with_capacity(samples.len());
    for i in 0..samples.len() {
        let (_, number) = samples.frame_key(i).ok_or_else(|| {
            LearnError::Input(format!(
                "{}: frame '{}' is not numbered; plane targets need a native dataset",
                root.display(),
                samples.names[i]
            ))
        })?;
        let name = format!("{}.png", native::frame_name(number));
        let depth_path = root.join("depth").join(&name);
        if !depth_path.is_file() {
            return Err(LearnError::Input(format!(
                "{}: missing; the plane task needs a depth image for every frame (render with depth, or train without planes)",
                depth_path.display()
            )));
        }
        names.push((number, name));
    }
    let frames = names
        .par_iter()
        .map(|(number, name)| -> Result<(FrameTargets, u64)> {
            let (number, name) = (*number, name.as_str());
            let depth_path = root.join("depth").join(name);
            let mut hash = Fnv64::new();
            let depth = read_depth(&depth_path, &mut hash)?;
            let (w, h) = (depth.width as u32, depth.height as u32);
            let intr = Intrinsics::of(camera, w, h);
            let ids_path = root.join("planes").join(name);
            let ids = if ids_path.is_file() {
                read_ids(&ids_path, depth.width, depth.height, &mut hash)?
            } else {
                ransac_planes(&depth, &intr, 4, number)
            };
            Ok((frame_targets(&depth, &ids, &intr, grid), hash.finish()))
        })
        .collect::<Result<Vec<_>>>()?;
    let mut hash = Fnv64::new();
    let mut targets = PlaneTargets {
        grid,
        frames: Vec::with_capacity(frames.len()),
    };
    for (t, h) in frames {
        hash.update(&h.to_le_bytes());
        targets.frames.push(t);
    }
    Ok((targets, hash.finish()))
}

/// The targets of a batch, packed as the loss takes them.
#[derive(Clone, Debug, Default, PartialEq)]
pub struct PlaneBatch {
    /// One-hot classes `[B, PLANE_CLASSES, gh, gw]`.
    pub one_hot: Vec<f32>,
    /// 1 where a cell has a plane, `[B, 1, gh, gw]`.
    pub mask: Vec<f32>,
    /// `[B, 4, gh, gw]`: normal and `ln d`.
    pub params: Vec<f32>,
    /// Measured depth `[B, 1, gh, gw]` (1 where no plane, to keep divisions finite).
    pub depth: Vec<f32>,
    /// Rays `[B, 3, gh, gw]`: `(x/z, y/z, 1)`.
    pub rays: Vec<f32>,
}

impl PlaneBatch {
    /// The targets of `indices` of `targets`.
    pub fn of(targets: &PlaneTargets, indices: &[usize]) -> PlaneBatch {
        let cells = targets.grid[0] * targets.grid[1];
        let mut b = PlaneBatch::default();
        for &i in indices {
            let f = &targets.frames[i];
            for k in 0..PLANE_CLASSES {
                b.one_hot
                    .extend(f.classes.iter().map(|&c| f32::from(usize::from(c) == k)));
            }
            b.mask
                .extend(f.classes.iter().map(|&c| f32::from(u8::from(c != 0))));
            for k in 0..PLANE_PARAMS {
                b.params.extend(f.params.iter().map(|p| p[k]));
            }
            b.depth
                .extend(f.depth.iter().map(|&z| if z > 0.0 { z } else { 1.0 }));
            b.rays.extend(f.rays.iter().map(|r| r[0]));
            b.rays.extend(f.rays.iter().map(|r| r[1]));
            b.rays.extend(std::iter::repeat_n(1.0, cells));
        }
        b
    }
}

/// The plane loss of a batch and its parts (means over the batch).
#[derive(Clone, Debug)]
pub struct PlaneLoss {
    /// Sum of the three parts, shape `[1]`.
    pub total: Tensor<1>,
    /// Class cross-entropy over every cell.
    pub classes: Tensor<1>,
    /// L1 of the normal plus L1 of `ln d`, over the cells with a plane.
    pub params: Tensor<1>,
    /// Relative error of the induced depth, over the cells with a plane.
    pub depth: Tensor<1>,
}

/// Lowest `n·r` the induced depth divides by: a plane seen nearly edge-on would otherwise
/// send the depth (and its gradient) to infinity.
const MIN_INCIDENCE: f32 = 0.05;

/// The loss of the plane branch's outputs against a batch of targets (see the module docs).
pub fn plane_loss(out: &PlaneOutputs, batch: &PlaneBatch, device: &Device) -> PlaneLoss {
    let [b, k, gh, gw] = out.classes.dims();
    let t = |v: &[f32], c: usize| {
        Tensor::<4>::from_data(TensorData::new(v.to_vec(), [b, c, gh, gw]), device)
    };
    let (one_hot, mask) = (t(&batch.one_hot, k), t(&batch.mask, 1));
    let (params, depth, rays) = (
        t(&batch.params, PLANE_PARAMS),
        t(&batch.depth, 1),
        t(&batch.rays, 3),
    );
    let cells = (b * gh * gw) as f32;
    let classes = (one_hot * log_softmax(out.classes.clone(), 1))
        .sum()
        .neg()
        .div_scalar(cells);
    // One more than the labelled cells: a batch without any plane gives 0, not 0 / 0.
    let labelled = mask.clone().sum().add_scalar(1.0);
    let raw = out.params.clone();
    let normal = raw.clone().narrow(1, 0, 3);
    let normal = normal.clone() / normal.square().sum_dim(1).add_scalar(1e-9).sqrt();
    let log_d = raw.narrow(1, 3, 1).clamp(-4.0, 5.0);
    let normal_err = (normal.clone() - params.clone().narrow(1, 0, 3))
        .abs()
        .sum_dim(1);
    let dist_err = (log_d.clone() - params.narrow(1, 3, 1)).abs();
    let params_loss = ((normal_err + dist_err) * mask.clone()).sum() / labelled.clone();
    let incidence = (normal * rays).sum_dim(1).clamp_min(MIN_INCIDENCE);
    let induced = log_d.exp() / incidence;
    let depth_loss = (((induced - depth.clone()).abs() / depth) * mask).sum() / labelled;
    let classes = classes.reshape([1]);
    let params_loss = params_loss.reshape([1]);
    let depth_loss = depth_loss.reshape([1]);
    PlaneLoss {
        total: classes.clone() + params_loss.clone() + depth_loss.clone(),
        classes,
        params: params_loss,
        depth: depth_loss,
    }
}

/// Share of cells whose predicted class (arg max) is the target's, over `targets`' frames.
pub fn class_accuracy(classes: &[u8], logits: &[f32], cells: usize) -> f64 {
    let frames = classes.len() / cells.max(1);
    let mut right = 0usize;
    for f in 0..frames {
        for c in 0..cells {
            let best = (0..PLANE_CLASSES)
                .max_by(|&a, &b| {
                    let at = |k: usize| logits[(f * PLANE_CLASSES + k) * cells + c];
                    at(a).total_cmp(&at(b))
                })
                .unwrap_or(0);
            right += usize::from(best == usize::from(classes[f * cells + c]));
        }
    }
    right as f64 / classes.len().max(1) as f64
}

#[cfg(test)]
mod tests {
    use super::*;

    const INTR: Intrinsics = Intrinsics {
        fx: 40.0,
        fy: 40.0,
        cx: 31.5,
        cy: 23.5,
    };

    /// A level camera 1.5 m above a floor, facing a wall 4 m ahead: plane 1 the floor, plane
    /// 2 the wall.
    fn corridor() -> (DepthImage, Vec<u8>) {
        let (w, h) = (64, 48);
        let mut depth = Vec::new();
        let mut ids = Vec::new();
        for v in 0..h {
            for u in 0..w {
                let (_, ry) = INTR.ray(u as f64, v as f64);
                if ry > 1.5 / 4.0 {
                    depth.push((1.5 / ry) as f32);
                    ids.push(1);
                } else {
                    depth.push(4.0);
                    ids.push(2);
                }
            }
        }
        (
            DepthImage {
                width: w,
                height: h,
                depth,
            },
            ids,
        )
    }

    #[test]
    fn planes_fitted_from_depth_are_the_true_ones() {
        let (depth, ids) = corridor();
        let planes = frame_planes(&depth, &ids, &INTR);
        let floor = planes[0].unwrap();
        assert!((floor.normal - Vector3::new(0.0, 1.0, 0.0)).norm() < 1e-3);
        assert!((floor.distance - 1.5).abs() < 1e-3);
        let wall = planes[1].unwrap();
        assert!((wall.normal - Vector3::new(0.0, 0.0, 1.0)).norm() < 1e-6);
        assert!((wall.distance - 4.0).abs() < 1e-4);
        assert_eq!(PlaneClass::of_normal(floor.normal), PlaneClass::Below);
        assert_eq!(PlaneClass::of_normal(wall.normal), PlaneClass::Ahead);
        assert_eq!(
            PlaneClass::of_normal(Vector3::new(0.1, -0.9, 0.2)),
            PlaneClass::Above
        );
        assert_eq!(
            PlaneClass::of_normal(Vector3::new(-0.8, 0.1, 0.5)),
            PlaneClass::Left
        );
    }

    #[test]
    fn ransac_finds_the_planes_without_ids() {
        let (depth, truth) = corridor();
        let ids = ransac_planes(&depth, &INTR, 4, 1);
        let planes = frame_planes(&depth, &ids, &INTR);
        assert_eq!(planes.iter().flatten().count(), 2, "{planes:?}");
        // Every pixel is given to a plane, the two found are the floor and the wall, and the
        // labelling agrees with the truth but for the seam where the two planes meet.
        assert!(ids.iter().all(|&i| i != 0));
        let agree = |map: [u8; 3]| {
            ids.iter()
                .zip(&truth)
                .filter(|&(&a, &t)| map[usize::from(a)] == t)
                .count() as f64
                / ids.len() as f64
        };
        let best = agree([0, 1, 2]).max(agree([0, 2, 1]));
        assert!(best > 0.97, "{best}");
    }

    #[test]
    fn targets_follow_the_cells_and_the_loss_is_zero_only_for_the_truth() {
        let (depth, ids) = corridor();
        let grid = [6, 8];
        let t = frame_targets(&depth, &ids, &INTR, grid);
        // The horizon (ry = 0.375) is at row 38.5 of 48: the last row of cells is floor.
        assert!(
            t.classes[..40]
                .iter()
                .all(|&c| c == PlaneClass::Ahead as u8)
        );
        assert!(
            t.classes[40..]
                .iter()
                .all(|&c| c == PlaneClass::Below as u8)
        );
        for c in 0..48 {
            let [nx, ny, nz, ln_d] = t.params[c];
            let ray = [t.rays[c][0], t.rays[c][1], 1.0];
            let induced = ln_d.exp() / (nx * ray[0] + ny * ray[1] + nz * ray[2]);
            assert!((induced - t.depth[c]).abs() < 0.02 * t.depth[c], "cell {c}");
        }
        let targets = PlaneTargets {
            grid,
            frames: vec![t.clone(), t],
        };
        let batch = PlaneBatch::of(&targets, &[0, 1]);
        let device = Device::flex();
        let shape = |c: usize| [2, c, grid[0], grid[1]];
        let logits: Vec<f32> = batch.one_hot.iter().map(|&v| 30.0 * v).collect();
        let truth = PlaneOutputs {
            classes: Tensor::from_data(TensorData::new(logits, shape(PLANE_CLASSES)), &device),
            params: Tensor::from_data(
                TensorData::new(batch.params.clone(), shape(PLANE_PARAMS)),
                &device,
            ),
        };
        let value = |t: Tensor<1>| t.into_scalar::<f32>();
        let loss = plane_loss(&truth, &batch, &device);
        assert!(value(loss.classes) < 1e-6);
        assert!(value(loss.params) < 1e-5);
        assert!(value(loss.depth) < 0.02);
        let off = PlaneOutputs {
            classes: Tensor::zeros(shape(PLANE_CLASSES), &device),
            params: truth.params.clone().add_scalar(0.3),
        };
        let loss = plane_loss(&off, &batch, &device);
        assert!((value(loss.classes) - (PLANE_CLASSES as f32).ln()).abs() < 1e-4);
        assert!(value(loss.params) > 0.3);
        assert!(value(loss.depth) > 0.1);
    }
}
