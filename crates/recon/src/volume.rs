//! The truncated signed distance volume: posed depth frames fused into voxels near surfaces.
//!
//! Storage is sparse: blocks of 16³ voxels, allocated where a depth sample's truncation band
//! passes (KinectFusion's volume with voxel hashing, Nießner et al. 2013), so a room at 1 cm
//! costs memory in proportion to its surface, not its volume. Voxel `g` (integer lattice
//! coordinates) sits at `g · voxel` metres in the dataset's frame.
//!
//! Each frame updates every voxel of every block in its view by projection: the depth at the
//! voxel's pixel minus the voxel's depth along the optical axis is the signed distance
//! (positive in front of the surface), truncated to ±1 in units of the truncation distance and
//! averaged with weight one per frame. Voxels more than the truncation distance behind the
//! surface are hidden from the camera and are left alone. Colours are averaged per voxel from the
//! colour frame, only for voxels within the truncation band.
//!
//! Depth and colour cameras: a dataset's [`DepthModel`] gives the depth image's intrinsics and
//! units. 7-Scenes' Kinect depth is not registered to its colour (f = 585 against 525, about
//! 2.5 cm apart): the two are taken to share an optical centre and axes, as the 7-Scenes
//! literature and the keyframe map do. Checked on the kitchen: the edges of renders of the fused
//! mesh correlate best with the photos when colours are fused and rendered at f = 525 (0.12
//! against 0.08 at 555 and 0.07 at 585, mean of three frames); the lenses' offset is not
//! modelled and shifts colours by up to a centimetre or two at object silhouettes.
//!
//! Why hand-written: the Rust TSDF crates found either need a GPU or keep a dense grid; the
//! sparse update is a hundred lines.

use crate::{ReconError, Result};
use data::depth::{DepthModel, read_depth};
use data::posed::{PosedDataset, PosedImage};
use geom::{Camera, Pose};
use nalgebra::{Point3, Vector3};
use rayon::prelude::*;
use std::collections::HashMap;
use std::ops::Range;

/// Voxels along each edge of a block.
pub const BLOCK: usize = 16;
/// Voxels in a block.
const BLOCK_VOXELS: usize = BLOCK * BLOCK * BLOCK;
/// Bins of 1/64 of the truncation distance for the residual histogram.
const RESIDUAL_BINS: usize = 64;

/// How frames are fused.
#[derive(Clone, Debug, PartialEq)]
pub struct FuseConfig {
    /// Voxel edge, metres.
    pub voxel_m: f64,
    /// Truncation distance in voxels: the band around a surface that a depth sample updates.
    pub truncation_voxels: f64,
    /// Depth beyond this is ignored, metres (a Kinect's depth is poor past 4–5 m).
    pub max_depth_m: f64,
    /// Which frames of the given list to fuse (all when `None`).
    pub frames: Option<Range<usize>>,
    /// Fuse every n-th frame of that range.
    pub stride: usize,
}

impl Default for FuseConfig {
    fn default() -> Self {
        Self {
            voxel_m: 0.01,
            truncation_voxels: 4.0,
            max_depth_m: 5.0,
            frames: None,
            stride: 1,
        }
    }
}

impl FuseConfig {
    /// The truncation distance, metres.
    pub fn truncation_m(&self) -> f64 {
        self.voxel_m * self.truncation_voxels
    }
}

/// What fusing found, for the user to judge the scan.
#[derive(Clone, Debug, Default, PartialEq, serde::Serialize)]
pub struct FuseReport {
    /// Frames fused.
    pub frames: usize,
    /// Blocks of 16³ voxels allocated.
    pub blocks: usize,
    /// Median depth of the valid samples, metres.
    pub median_depth_m: f64,
    /// Share of depth pixels with a usable value.
    pub valid_depth_share: f64,
    /// Median disagreement of a frame's depth with the surface fused so far, metres, over voxels
    /// within the truncation band that earlier frames had seen: small (a few millimetres) for a
    /// consistent scan, near the truncation distance when poses do not fit the depth.
    pub median_residual_m: f64,
    /// Share of those disagreements larger than half the truncation distance: surfaces a frame
    /// puts where the others saw free space or none (a few per cent for a consistent scan).
    pub inconsistent_share: f64,
    /// Problems the scan survives (poses that do not fit the depth, sparse depth).
    pub warnings: Vec<String>,
}

/// One block of voxels.
#[derive(Clone)]
struct Block {
    /// Signed distance in truncation units, −1 to 1.
    tsdf: Vec<f32>,
    /// Frames that updated the distance.
    weight: Vec<f32>,
    /// Average colour, 0–255 per channel.
    color: Vec<[f32; 3]>,
    /// Frames that updated the colour.
    color_weight: Vec<f32>,
}

impl Block {
    fn new() -> Block {
        Block {
            tsdf: vec![1.0; BLOCK_VOXELS],
            weight: vec![0.0; BLOCK_VOXELS],
            color: vec![[0.0; 3]; BLOCK_VOXELS],
            color_weight: vec![0.0; BLOCK_VOXELS],
        }
    }
}

/// One voxel's fused state.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct Voxel {
    /// Signed distance in truncation units, −1 (behind the surface) to 1 (in front).
    pub tsdf: f32,
    /// Frames that saw it (0: never observed).
    pub weight: f32,
    /// Average colour, 0–255.
    pub color: [f32; 3],
    /// Frames that coloured it.
    pub color_weight: f32,
}

/// The fused volume.
pub struct Volume {
    /// Voxel edge, metres.
    pub voxel_m: f64,
    /// Truncation distance, metres.
    pub truncation_m: f64,
    index: HashMap<[i32; 3], usize>,
    keys: Vec<[i32; 3]>,
    blocks: Vec<Block>,
}

/// A depth frame ready to fuse: depth in metres (0 where missing), the colour frame, both
/// cameras and the pose.
pub struct Frame {
    /// Depth, metres, row-major; 0 = no depth.
    pub depth: Vec<f32>,
    /// Intrinsics of the depth image.
    pub depth_camera: Camera,
    /// The colour image.
    pub color: image::RgbImage,
    /// Intrinsics of the colour image (sharing the depth camera's centre and axes).
    pub color_camera: Camera,
    /// Camera-to-world pose.
    pub pose: Pose,
}

impl Volume {
    /// An empty volume.
    pub fn new(voxel_m: f64, truncation_m: f64) -> Volume {
        Volume {
            voxel_m,
            truncation_m,
            index: HashMap::new(),
            keys: Vec::new(),
            blocks: Vec::new(),
        }
    }

    /// Blocks allocated.
    pub fn block_count(&self) -> usize {
        self.blocks.len()
    }

    /// Lattice coordinates of every allocated block's first voxel.
    pub fn block_origins(&self) -> impl Iterator<Item = [i32; 3]> + '_ {
        self.keys.iter().map(|k| k.map(|c| c * BLOCK as i32))
    }

    /// The voxel at lattice coordinates `g`, `None` where no block is allocated.
    pub fn voxel(&self, g: [i32; 3]) -> Option<Voxel> {
        let key = g.map(|c| c.div_euclid(BLOCK as i32));
        let b = &self.blocks[*self.index.get(&key)?];
        let l = g.map(|c| c.rem_euclid(BLOCK as i32) as usize);
        let i = (l[2] * BLOCK + l[1]) * BLOCK + l[0];
        Some(Voxel {
            tsdf: b.tsdf[i],
            weight: b.weight[i],
            color: b.color[i],
            color_weight: b.color_weight[i],
        })
    }

    /// The fused colour at `p` (metres, the dataset's frame): the trilinear blend of the
    /// coloured voxels around it, `None` when none of the eight is coloured.
    pub fn color_at(&self, p: [f64; 3]) -> Option<[f32; 3]> {
        let q = p.map(|c| c / self.voxel_m);
        let base = q.map(|c| c.floor() as i32);
        let f = [0, 1, 2].map(|k| (q[k] - f64::from(base[k])) as f32);
        let (mut sum, mut total) = ([0.0f32; 3], 0.0f32);
        for corner in 0..8 {
            let d = [corner & 1, (corner >> 1) & 1, (corner >> 2) & 1];
            let g = [0, 1, 2].map(|k| base[k] + d[k]);
            let Some(v) = self.voxel(g) else { continue };
            if v.color_weight <= 0.0 {
                continue;
            }
            let w: f32 = (0..3)
                .map(|k| if d[k] == 1 { f[k] } else { 1.0 - f[k] })
                .product::<f32>()
                .max(1e-6);
            for (s, c) in sum.iter_mut().zip(v.color) {
                *s += w * c;
            }
            total += w;
        }
        (total > 0.0).then(|| sum.map(|s| s / total))
    }

    /// Fuses one frame; returns the histogram of its residuals against the surface fused
    /// before (bins of 1/64 of the truncation distance).
    pub fn integrate(&mut self, frame: &Frame) -> [u64; RESIDUAL_BINS] {
        self.allocate(frame);
        let trunc = self.truncation_m as f32;
        let voxel = self.voxel_m;
        let world_to_cam = frame.pose.inverse();
        let r = world_to_cam.rotation.to_rotation_matrix();
        let (rm, t) = (r.matrix(), world_to_cam.translation);
        let dc = frame.depth_camera;
        let cc = frame.color_camera;
        let (w, h) = (dc.width as i64, dc.height as i64);
        let (cw, ch) = (cc.width as i64, cc.height as i64);
        let max_depth = frame.depth.iter().cloned().fold(0.0f32, f32::max) + trunc;
        let half_block = (BLOCK as f64 * voxel) * 3f64.sqrt() / 2.0;
        let keys = &self.keys;
        let in_view = |key: &[i32; 3]| -> bool {
            let centre = key.map(|c| (f64::from(c) + 0.5) * BLOCK as f64 * voxel);
            let pc = rm * Vector3::from(centre) + t;
            if pc.z + half_block <= 0.05 || pc.z - half_block > f64::from(max_depth) {
                return false;
            }
            let z = pc.z.max(0.05);
            let margin_x = half_block * dc.fx / z;
            let margin_y = half_block * dc.fy / z;
            let u = dc.fx * pc.x / z + dc.cx;
            let v = dc.fy * pc.y / z + dc.cy;
            u > -margin_x && u < w as f64 + margin_x && v > -margin_y && v < h as f64 + margin_y
        };
        let step = [0, 1, 2].map(|k| (rm.column(k) * voxel).map(|c| c as f32));
        self.blocks
            .par_iter_mut()
            .zip(keys.par_iter())
            .filter(|(_, key)| in_view(key))
            .map(|(block, key)| {
                let mut hist = [0u64; RESIDUAL_BINS];
                let origin = key.map(|c| f64::from(c * BLOCK as i32) * voxel);
                let o = rm * Vector3::from(origin) + t;
                let o = [o.x as f32, o.y as f32, o.z as f32];
                for zi in 0..BLOCK {
                    for yi in 0..BLOCK {
                        for xi in 0..BLOCK {
                            let (fx, fy, fz) = (xi as f32, yi as f32, zi as f32);
                            let p = [0, 1, 2].map(|k| {
                                o[k] + fx * step[0][k] + fy * step[1][k] + fz * step[2][k]
                            });
                            if p[2] <= 0.05 {
                                continue;
                            }
                            let u = (dc.fx as f32 * p[0] / p[2] + dc.cx as f32).round() as i64;
                            let v = (dc.fy as f32 * p[1] / p[2] + dc.cy as f32).round() as i64;
                            if u < 0 || v < 0 || u >= w || v >= h {
                                continue;
                            }
                            let d = frame.depth[(v * w + u) as usize];
                            if d <= 0.0 {
                                continue;
                            }
                            let sdf = d - p[2];
                            if sdf < -trunc {
                                continue;
                            }
                            let i = (zi * BLOCK + yi) * BLOCK + xi;
                            let value = (sdf / trunc).min(1.0);
                            let old = block.weight[i];
                            if old > 0.0 && sdf.abs() < trunc {
                                let res = (value - block.tsdf[i]).abs();
                                let bin =
                                    ((res * RESIDUAL_BINS as f32) as usize).min(RESIDUAL_BINS - 1);
                                hist[bin] += 1;
                            }
                            block.tsdf[i] = (block.tsdf[i] * old + value) / (old + 1.0);
                            block.weight[i] = old + 1.0;
                            if sdf.abs() < trunc {
                                let uc = (cc.fx as f32 * p[0] / p[2] + cc.cx as f32).round() as i64;
                                let vc = (cc.fy as f32 * p[1] / p[2] + cc.cy as f32).round() as i64;
                                if uc >= 0 && vc >= 0 && uc < cw && vc < ch {
                                    let c = frame.color.get_pixel(uc as u32, vc as u32).0;
                                    let cw_old = block.color_weight[i];
                                    let acc = &mut block.color[i];
                                    for (a, &b) in acc.iter_mut().zip(&c) {
                                        *a = (*a * cw_old + f32::from(b)) / (cw_old + 1.0);
                                    }
                                    block.color_weight[i] = cw_old + 1.0;
                                }
                            }
                        }
                    }
                }
                hist
            })
            .reduce(
                || [0u64; RESIDUAL_BINS],
                |mut a, b| {
                    for (x, y) in a.iter_mut().zip(b) {
                        *x += y;
                    }
                    a
                },
            )
    }

    /// Allocates the blocks that the truncation band of every 4th depth sample (in x and y)
    /// passes through: the sample's point and the two ends of the band along its ray.
    fn allocate(&mut self, frame: &Frame) {
        let dc = frame.depth_camera;
        let block_m = BLOCK as f64 * self.voxel_m;
        let mut last = None;
        for v in (0..dc.height as usize).step_by(4) {
            for u in (0..dc.width as usize).step_by(4) {
                let d = f64::from(frame.depth[v * dc.width as usize + u]);
                if d <= 0.0 {
                    continue;
                }
                let ray = Vector3::new((u as f64 - dc.cx) / dc.fx, (v as f64 - dc.cy) / dc.fy, 1.0);
                for z in [d - self.truncation_m, d, d + self.truncation_m] {
                    let p = frame.pose.transform_point(&Point3::from(ray * z));
                    let key = [p.x, p.y, p.z].map(|c| (c / block_m).floor() as i32);
                    if last == Some(key) {
                        continue;
                    }
                    last = Some(key);
                    if !self.index.contains_key(&key) {
                        self.index.insert(key, self.blocks.len());
                        self.keys.push(key);
                        self.blocks.push(Block::new());
                    }
                }
            }
        }
    }
}

/// Median of a residual histogram, in truncation units (`None` when empty).
fn histogram_median(hist: &[u64; RESIDUAL_BINS]) -> Option<f64> {
    let total: u64 = hist.iter().sum();
    if total == 0 {
        return None;
    }
    let mut seen = 0;
    for (i, &n) in hist.iter().enumerate() {
        if 2 * (seen + n) >= total {
            let inside = (total as f64 / 2.0 - seen as f64) / n.max(1) as f64;
            return Some((i as f64 + inside) / RESIDUAL_BINS as f64);
        }
        seen += n;
    }
    Some(1.0)
}

/// The frames of `images` that `cfg` selects.
pub fn selected<'a>(images: &[&'a PosedImage], cfg: &FuseConfig) -> Vec<&'a PosedImage> {
    let range = cfg.frames.clone().unwrap_or(0..images.len());
    let range = range.start.min(images.len())..range.end.min(images.len());
    images[range]
        .iter()
        .step_by(cfg.stride.max(1))
        .copied()
        .collect()
}

/// Reads one posed image as a [`Frame`]: the depth through the dataset's depth model.
pub fn read_frame(
    img: &PosedImage,
    model: &DepthModel,
    color_camera: &Camera,
    max_depth_m: f64,
) -> Result<Frame> {
    let Some(depth_path) = &img.depth else {
        return Err(ReconError::scan(
            &img.image,
            "this frame has no depth image: a scan needs depth for every fused frame",
        ));
    };
    let raw = read_depth(depth_path)?;
    let mut depth_camera = model.camera;
    if (raw.width(), raw.height()) != (depth_camera.width, depth_camera.height) {
        let s = f64::from(raw.width()) / f64::from(depth_camera.width);
        depth_camera.fx *= s;
        depth_camera.fy *= s;
        depth_camera.cx *= s;
        depth_camera.cy *= s;
        depth_camera.width = raw.width();
        depth_camera.height = raw.height();
    }
    let max = max_depth_m.min(model.max_m);
    let depth = raw
        .as_raw()
        .iter()
        .map(|&r| {
            let z = f64::from(r) * model.metres_per_unit;
            if r == 0 || r == u16::MAX || z < model.min_m || z > max {
                0.0
            } else {
                z as f32
            }
        })
        .collect();
    let color = data::frames::decode_image(&img.image)?.to_rgb8();
    let mut color_camera = *color_camera;
    if (color.width(), color.height()) != (color_camera.width, color_camera.height) {
        let s = f64::from(color.width()) / f64::from(color_camera.width);
        color_camera.fx *= s;
        color_camera.fy *= s;
        color_camera.cx *= s;
        color_camera.cy *= s;
        color_camera.width = color.width();
        color_camera.height = color.height();
    }
    Ok(Frame {
        depth,
        depth_camera,
        color,
        color_camera,
        pose: img.frame.pose,
    })
}

/// Checks that depth exists and is in plausible units, from the median raw value of a few
/// frames: a room's depth is 0.3–10 m.
fn check_depth_units(ds: &PosedDataset, frames: &[&PosedImage], model: &DepthModel) -> Result<()> {
    if let Some(missing) = frames.iter().find(|i| i.depth.is_none()) {
        return Err(ReconError::scan(
            &ds.root,
            format!(
                "frame {} has no depth image: a scan needs posed depth frames (7-Scenes \
                 `*.depth.png`, TUM `depth.txt`, native `depth/`)",
                missing.frame.name
            ),
        ));
    }
    let step = (frames.len() / 5).max(1);
    let mut raw: Vec<u16> = Vec::new();
    let mut first = None;
    for img in frames.iter().step_by(step).take(5) {
        let path = img.depth.as_deref().expect("checked above");
        first.get_or_insert(path.to_path_buf());
        let d = read_depth(path)?;
        raw.extend(
            d.as_raw()
                .iter()
                .step_by(7)
                .filter(|&&r| r != 0 && r != u16::MAX),
        );
    }
    let path = first.unwrap_or_else(|| ds.root.clone());
    if raw.is_empty() {
        return Err(ReconError::scan(
            path,
            "the depth images hold no depth (every pixel 0 or 65535)",
        ));
    }
    raw.sort_unstable();
    let median_m = f64::from(raw[raw.len() / 2]) * model.metres_per_unit;
    if !(0.3..=10.0).contains(&median_m) {
        return Err(ReconError::scan(
            path,
            format!(
                "median depth {median_m:.3} m at {} m per depth unit: a room's depth is 0.3–10 m, \
                 so the depth is probably in other units (7-Scenes and native datasets store \
                 millimetres, TUM 1/5000 m)",
                model.metres_per_unit
            ),
        ));
    }
    Ok(())
}

/// Fuses `frames` of `ds` (see [`selected`] for the choice) into a new volume; `tick` is
/// called once per frame fused.
pub fn fuse(
    ds: &PosedDataset,
    frames: &[&PosedImage],
    cfg: &FuseConfig,
    tick: &(dyn Fn() + Sync),
) -> Result<(Volume, FuseReport)> {
    if !(cfg.voxel_m.is_finite() && cfg.voxel_m >= 0.002 && cfg.voxel_m <= 0.2) {
        return Err(ReconError::scan(
            &ds.root,
            format!("voxel {} m: use 0.002–0.2 m", cfg.voxel_m),
        ));
    }
    if frames.is_empty() {
        return Err(ReconError::scan(&ds.root, "no frames to fuse"));
    }
    let color_camera = ds.require_camera()?;
    let model = DepthModel::for_dataset(ds, &color_camera);
    check_depth_units(ds, frames, &model)?;
    let mut volume = Volume::new(cfg.voxel_m, cfg.truncation_m());
    let mut hist_all = [0u64; RESIDUAL_BINS];
    let mut frame_medians = Vec::new();
    let (mut valid, mut pixels) = (0usize, 0usize);
    let mut depth_sample: Vec<f32> = Vec::new();
    // Decode a few frames at a time in parallel, fuse them in order.
    for chunk in frames.chunks(8) {
        let decoded = chunk
            .par_iter()
            .map(|img| read_frame(img, &model, &color_camera, cfg.max_depth_m))
            .collect::<Result<Vec<_>>>()?;
        for frame in &decoded {
            pixels += frame.depth.len();
            valid += frame.depth.iter().filter(|&&d| d > 0.0).count();
            depth_sample.extend(frame.depth.iter().step_by(97).filter(|&&d| d > 0.0));
            let hist = volume.integrate(frame);
            if let Some(m) = histogram_median(&hist) {
                frame_medians.push(m);
            }
            for (a, b) in hist_all.iter_mut().zip(hist) {
                *a += b;
            }
            tick();
        }
    }
    depth_sample.sort_unstable_by(f32::total_cmp);
    let median_residual_m = histogram_median(&hist_all).unwrap_or(0.0) * volume.truncation_m;
    let total: u64 = hist_all.iter().sum();
    let inconsistent_share =
        hist_all[RESIDUAL_BINS / 2..].iter().sum::<u64>() as f64 / total.max(1) as f64;
    let mut report = FuseReport {
        frames: frames.len(),
        blocks: volume.block_count(),
        median_depth_m: depth_sample
            .get(depth_sample.len() / 2)
            .map_or(0.0, |&d| f64::from(d)),
        valid_depth_share: valid as f64 / pixels.max(1) as f64,
        median_residual_m,
        inconsistent_share,
        warnings: Vec::new(),
    };
    if median_residual_m > 0.3 * volume.truncation_m || inconsistent_share > 0.4 {
        report.warnings.push(format!(
            "median TSDF residual {:.1} mm is {:.0} % of the truncation distance ({:.0} mm), and \
             {:.0} % of the observations disagree by more than half of it: the poses probably do \
             not fit the depth (world-to-camera instead of camera-to-world, another unit, drift)",
            1e3 * median_residual_m,
            100.0 * median_residual_m / volume.truncation_m,
            1e3 * volume.truncation_m,
            100.0 * inconsistent_share
        ));
    }
    let bad = frame_medians.iter().filter(|&&m| m > 0.5).count();
    if bad * 10 > frame_medians.len() && report.warnings.is_empty() {
        report.warnings.push(format!(
            "{bad} of {} frames disagree with the fused surface by more than half the \
             truncation distance (median residual): some poses do not fit the depth",
            frame_medians.len()
        ));
    }
    if report.valid_depth_share < 0.2 {
        report.warnings.push(format!(
            "only {:.0} % of the depth pixels hold usable depth (0.1–{} m)",
            100.0 * report.valid_depth_share,
            cfg.max_depth_m
        ));
    }
    Ok((volume, report))
}
