//! Local image features: where a picture has corners, what each looks like as 256 bits, and
//! which corners of two pictures are the same point of the world.
//!
//! The detector and descriptor are ORB's design (Rublee et al., ICCV 2011): FAST-9 corners on
//! an image pyramid, ranked by the Harris response and spread over a grid, oriented by the
//! intensity centroid, described by 256 grey-level comparisons (a fixed Gaussian pattern,
//! rotated to the corner's orientation) on a smoothed image, and matched by Hamming distance.
//! Positions are refined to a fraction of a pixel on the Harris response, because the pose that
//! [`map`](../map/index.html) solves from them is only as good as they are.
//!
//! # Why ORB, and why written here
//! - **Choice**: refinement matches a query against a handful of retrieved keyframes of the same
//!   building, taken from nearby viewpoints: scale changes of a few tens of percent and in-plane
//!   rotations of a few degrees. ORB holds across those, and a 256-bit descriptor is compared in
//!   a few instructions (four `popcnt`), where SIFT's 128 floats need a 128-wide dot product and a
//!   scale space that costs tens of milliseconds per 640x480 frame. Measured on the kitchen
//!   frames (`indoorloc bench refine`, ARCHITECTURE.md has the figures), it reaches SIFT + PnP's
//!   accuracy at a fraction of its time.
//! - **By hand**: no maintained Rust crate detects and describes oriented multi-scale binary
//!   features. `imageproc` has FAST-9 and an unoriented BRIEF at one scale, without sub-pixel
//!   positions or a spread over the image; the `akaze` crate (rust-cv) is a float descriptor at
//!   several times ORB's cost and no longer maintained. The smoothing and pyramid reuse
//!   [`imgproc`]'s area resize.
#![deny(missing_docs)]

mod describe;
mod detect;
mod error;
pub mod matching;
mod pyramid;

pub use describe::{DESCRIPTOR_BYTES, Descriptor};
pub use error::{FeatureError, Result};
pub use matching::{Match, MatchConfig, match_descriptors};

use image::GrayImage;

/// A corner found in an image.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct Keypoint {
    /// Column in the full-resolution image, pixels, sub-pixel (pixel centres at integers).
    pub x: f32,
    /// Row in the full-resolution image, pixels, sub-pixel.
    pub y: f32,
    /// Pyramid level it was found on (0 = full resolution).
    pub level: u8,
    /// Orientation, radians (intensity centroid direction).
    pub angle: f32,
    /// Harris response at the corner (larger = stronger).
    pub response: f32,
}

/// The features of one image: keypoints and their descriptors, index for index.
#[derive(Clone, Debug, Default, PartialEq)]
pub struct Features {
    /// The keypoints.
    pub keypoints: Vec<Keypoint>,
    /// Their descriptors.
    pub descriptors: Vec<Descriptor>,
}

impl Features {
    /// Number of features.
    pub fn len(&self) -> usize {
        self.keypoints.len()
    }

    /// True when the image had no features.
    pub fn is_empty(&self) -> bool {
        self.keypoints.is_empty()
    }
}

/// How many features to find, and where.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct ExtractConfig {
    /// Features wanted over all levels (fewer on a textureless image).
    pub max_features: usize,
    /// Pyramid levels (1 = full resolution only).
    pub levels: usize,
    /// Scale between levels (ORB: 1.2).
    pub scale_factor: f32,
    /// FAST threshold, grey levels; a level with too few corners is searched again at
    /// [`ExtractConfig::min_threshold`].
    pub threshold: u8,
    /// The lower FAST threshold for low-contrast images.
    pub min_threshold: u8,
    /// Side of the grid cells features are spread over, pixels of the level.
    pub cell: u32,
}

impl Default for ExtractConfig {
    /// 1500 features on 6 levels 1.2 apart, FAST 20 (7 where too few), 32-pixel cells.
    fn default() -> Self {
        ExtractConfig {
            max_features: 1500,
            levels: 6,
            scale_factor: 1.2,
            threshold: 20,
            min_threshold: 7,
            cell: 32,
        }
    }
}

impl ExtractConfig {
    fn validate(&self) -> Result<()> {
        if self.max_features == 0 || self.levels == 0 || self.levels > 16 {
            return Err(FeatureError::Config(format!(
                "max_features {} and levels {} must be ≥ 1 (levels ≤ 16)",
                self.max_features, self.levels
            )));
        }
        if !(self.scale_factor > 1.0 && self.scale_factor < 4.0) {
            return Err(FeatureError::Config(format!(
                "scale_factor {} must lie in (1, 4)",
                self.scale_factor
            )));
        }
        if self.cell < 8 {
            return Err(FeatureError::Config(format!(
                "cell {} must be ≥ 8 pixels",
                self.cell
            )));
        }
        Ok(())
    }
}

/// Finds and describes the features of a grey image (see the crate docs). An image smaller
/// than a descriptor's patch has none; that is not an error.
pub fn extract(img: &GrayImage, cfg: &ExtractConfig) -> Result<Features> {
    cfg.validate()?;
    let levels = pyramid::Pyramid::build(img, cfg.levels, cfg.scale_factor)?;
    let quotas = pyramid::quotas(cfg.max_features, levels.levels.len(), cfg.scale_factor);
    let mut out = Features::default();
    for (level, (image, quota)) in levels.levels.iter().zip(quotas).enumerate() {
        if quota == 0 {
            continue;
        }
        let corners = detect::corners(image, quota, cfg);
        if corners.is_empty() {
            continue;
        }
        let smooth = describe::smooth(image);
        let scale = levels.scales[level];
        for c in corners {
            let angle = describe::orientation(image, c.x, c.y);
            let descriptor = describe::describe(&smooth, c.x, c.y, angle);
            out.keypoints.push(Keypoint {
                // Pixel centres: a level pixel x covers [x, x+1) scaled, whose centre is
                // (x + 0.5) * scale - 0.5 in full-resolution pixels.
                x: (c.x as f32 + c.dx + 0.5) * scale - 0.5,
                y: (c.y as f32 + c.dy + 0.5) * scale - 0.5,
                level: level as u8,
                angle,
                response: c.response,
            });
            out.descriptors.push(descriptor);
        }
    }
    Ok(out)
}
