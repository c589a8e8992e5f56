//! Image retrieval: a global descriptor per mapped frame and nearest-neighbour search, as a
//! localizer (the pose of the most similar mapped frame) and as the candidates of refinement.
//!
//! # The descriptor
//! A thumbnail: the frame in grey, area-averaged down to [`THUMB_W`] x [`THUMB_H`] (OpenCV's
//! `INTER_AREA`, [`imgproc::view::resize_gray`]), minus its mean and scaled to unit length, so
//! that similarity is the cosine of two thumbnails (normalised cross-correlation) and a global
//! change of exposure or gain does not move it. This is the baseline of the 7-Scenes literature
//! (the "nearest training frame by a tiny image" of Sattler et al. 2019) and what
//! `../shared/tools/peers/sift_pnp.py` retrieves with, so the two are compared like for like.
//! Measured on `7scenes_redkitchen_seq01` (`indoorloc study real`, ARCHITECTURE.md has the
//! figures): it is within a few percent of larger thumbnails, and costs 768 floats and about a
//! microsecond per mapped frame per query, so a brute-force scan of thousands of frames is
//! cheaper than decoding the query image; an index structure would only add code.
//!
//! Written here rather than taken from a crate: no maintained crate computes image
//! thumbnails-as-descriptors, and the search is one dot product per mapped frame.

use crate::{MapError, Result};
use data::posed::PosedImage;
use geom::Pose;
use image::{DynamicImage, GrayImage};
use rayon::prelude::*;
use std::path::{Path, PathBuf};

/// Thumbnail width, pixels.
pub const THUMB_W: u32 = 32;
/// Thumbnail height, pixels (4:3, as the cameras indoorloc meets).
pub const THUMB_H: u32 = 24;

/// The global descriptor of an image (see the module docs): `THUMB_W * THUMB_H` values, zero
/// mean, unit length (all zeros for a flat image, which then matches nothing better than
/// anything else).
pub fn descriptor(img: &DynamicImage) -> Result<Vec<f32>> {
    let gray = img.to_luma8();
    let mut thumb = GrayImage::new(THUMB_W, THUMB_H);
    imgproc::view::resize_gray(&gray, &mut thumb)
        .map_err(|e| MapError::Input(format!("thumbnail: {e}")))?;
    let n = thumb.len() as f32;
    let mean = thumb.iter().map(|&v| f32::from(v)).sum::<f32>() / n;
    let mut d: Vec<f32> = thumb.iter().map(|&v| f32::from(v) - mean).collect();
    let norm = d.iter().map(|v| v * v).sum::<f32>().sqrt();
    if norm > 1e-6 {
        d.iter_mut().for_each(|v| *v /= norm);
    }
    Ok(d)
}

/// Reads and describes one image file.
pub fn describe_file(path: &Path) -> Result<Vec<f32>> {
    let img = image::open(path).map_err(|e| MapError::Image {
        path: path.to_path_buf(),
        msg: e.to_string(),
    })?;
    descriptor(&img)
}

/// One mapped frame.
#[derive(Clone, Debug, PartialEq)]
pub struct Keyframe {
    /// The frame's `seq/name`.
    pub name: String,
    /// Its camera-to-world pose.
    pub pose: Pose,
}

/// A retrieval index: the descriptors of the mapped frames, searched by brute force.
#[derive(Clone, Debug, Default)]
pub struct RetrievalIndex {
    /// The mapped frames, in the order they were given.
    pub keyframes: Vec<Keyframe>,
    /// Their descriptors, one after the other.
    descriptors: Vec<f32>,
}

/// A retrieved frame: its index among the keyframes and the similarity (cosine, 1 = same).
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct Hit {
    /// Index into [`RetrievalIndex::keyframes`].
    pub index: usize,
    /// Cosine similarity of the two descriptors.
    pub score: f32,
}

impl Keyframe {
    /// The keyframe of a posed image: its `seq/name` and pose.
    pub fn of(img: &PosedImage) -> Keyframe {
        Keyframe {
            name: format!("{}/{}", img.frame.seq, img.frame.name),
            pose: img.frame.pose,
        }
    }
}

impl RetrievalIndex {
    /// An index of posed images ([`RetrievalIndex::build`] on their colour files).
    pub fn of_images(images: &[&PosedImage]) -> Result<Self> {
        let frames: Vec<(PathBuf, Keyframe)> = images
            .iter()
            .map(|img| (img.image.clone(), Keyframe::of(img)))
            .collect();
        Self::build(&frames)
    }

    /// An index of keyframes with descriptors computed elsewhere (e.g. a network's features),
    /// one per keyframe, all of the same width and unit length; searched as thumbnails are.
    pub fn from_descriptors(keyframes: Vec<Keyframe>, descriptors: Vec<Vec<f32>>) -> Result<Self> {
        let width = descriptors.first().map_or(0, Vec::len);
        if keyframes.is_empty() || keyframes.len() != descriptors.len() || width == 0 {
            return Err(MapError::Input(format!(
                "{} keyframes and {} descriptors: an index needs one non-empty descriptor per keyframe",
                keyframes.len(),
                descriptors.len()
            )));
        }
        if let Some(i) = descriptors.iter().position(|d| d.len() != width) {
            return Err(MapError::Input(format!(
                "descriptor {i} has {} values, the first has {width}",
                descriptors[i].len()
            )));
        }
        Ok(RetrievalIndex {
            keyframes,
            descriptors: descriptors.concat(),
        })
    }

    /// An index of posed image files (`(image, keyframe)`), described in parallel. Errors name
    /// the first image that cannot be read; an empty list is an error.
    pub fn build(frames: &[(PathBuf, Keyframe)]) -> Result<Self> {
        if frames.is_empty() {
            return Err(MapError::Input("no frames to map".into()));
        }
        let descriptors: Vec<Vec<f32>> = frames
            .par_iter()
            .map(|(path, _)| describe_file(path))
            .collect::<Result<_>>()?;
        Ok(RetrievalIndex {
            keyframes: frames.iter().map(|(_, k)| k.clone()).collect(),
            descriptors: descriptors.concat(),
        })
    }

    /// Adds `other`'s keyframes after these; their descriptors must be of the same width.
    pub fn extend(&mut self, other: RetrievalIndex) -> Result<()> {
        if !self.is_empty() && !other.is_empty() && self.width() != other.width() {
            return Err(MapError::Input(format!(
                "descriptors of {} and {} values cannot share an index",
                self.width(),
                other.width()
            )));
        }
        self.keyframes.extend(other.keyframes);
        self.descriptors.extend(other.descriptors);
        Ok(())
    }

    /// The descriptor of keyframe `i`.
    pub fn descriptor(&self, i: usize) -> &[f32] {
        let w = self.width();
        &self.descriptors[i * w..(i + 1) * w]
    }

    /// Values per descriptor.
    fn width(&self) -> usize {
        self.descriptors.len() / self.keyframes.len().max(1)
    }

    /// Number of mapped frames.
    pub fn len(&self) -> usize {
        self.keyframes.len()
    }

    /// True when nothing is mapped.
    pub fn is_empty(&self) -> bool {
        self.keyframes.is_empty()
    }

    /// The `k` mapped frames most similar to `query` (a [`descriptor`]), best first.
    pub fn query(&self, query: &[f32], k: usize) -> Vec<Hit> {
        let n = query.len();
        let mut hits: Vec<Hit> = self
            .descriptors
            .chunks_exact(n.max(1))
            .enumerate()
            .map(|(index, d)| Hit {
                index,
                score: d.iter().zip(query).map(|(a, b)| a * b).sum(),
            })
            .collect();
        let k = k.min(hits.len());
        if k == 0 {
            return Vec::new();
        }
        hits.select_nth_unstable_by(k - 1, |a, b| b.score.total_cmp(&a.score));
        hits.truncate(k);
        hits.sort_by(|a, b| b.score.total_cmp(&a.score));
        hits
    }

    /// The pose of the mapped frame most similar to `img`, with a spread: the RMS distance and
    /// angle of the next [`SPREAD_K`] - 1 most similar frames to it (near-twins agree; a frame
    /// that looks like several places does not).
    pub fn localize(&self, img: &DynamicImage) -> Result<Retrieved> {
        self.localize_descriptor(&descriptor(img)?)
    }

    /// [`Self::localize`] of an image's descriptor ([`descriptor`]).
    pub fn localize_descriptor(&self, d: &[f32]) -> Result<Retrieved> {
        let hits = self.query(d, SPREAD_K);
        let best = *hits
            .first()
            .ok_or_else(|| MapError::Input("the retrieval index is empty".into()))?;
        let pose = self.keyframes[best.index].pose;
        let rms = |f: &dyn Fn(&Pose) -> f64| {
            let sum: f64 = hits
                .iter()
                .map(|h| f(&self.keyframes[h.index].pose).powi(2))
                .sum();
            (sum / hits.len() as f64).sqrt()
        };
        Ok(Retrieved {
            pose,
            best,
            sigma_pos_m: rms(&|p| geom::metrics::position_error(&pose, p)),
            sigma_rot_deg: rms(&|p| geom::metrics::rotation_error_deg(&pose, p)),
        })
    }
}

/// Frames [`RetrievalIndex::localize`] measures its spread over.
pub const SPREAD_K: usize = 5;

/// What [`RetrievalIndex::localize`] answers.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct Retrieved {
    /// The pose of the most similar mapped frame.
    pub pose: Pose,
    /// That frame.
    pub best: Hit,
    /// RMS distance of the [`SPREAD_K`] most similar frames to it, metres.
    pub sigma_pos_m: f64,
    /// RMS angle of those frames to it, degrees.
    pub sigma_rot_deg: f64,
}

#[cfg(test)]
mod tests {
    use super::*;
    use image::{Rgb, RgbImage};

    /// A 64x48 image with a bright square at `x`.
    fn square_at(x: u32) -> DynamicImage {
        let mut img = RgbImage::from_pixel(64, 48, Rgb([40, 40, 40]));
        for yy in 10..30 {
            for xx in x..x + 16 {
                img.put_pixel(xx, yy, Rgb([220, 200, 180]));
            }
        }
        DynamicImage::ImageRgb8(img)
    }

    #[test]
    fn the_most_similar_frame_is_found_whatever_the_exposure() -> Result<()> {
        let dir = tempfile::tempdir().unwrap();
        let mut frames = Vec::new();
        for (i, x) in [0u32, 16, 32, 46].into_iter().enumerate() {
            let path = dir.path().join(format!("{i}.png"));
            square_at(x).save(&path).unwrap();
            let pose = Pose::from_t_wxyz([i as f64, 0.0, 0.0], [1.0, 0.0, 0.0, 0.0])
                .map_err(|e| MapError::Input(e.to_string()))?;
            frames.push((
                path,
                Keyframe {
                    name: format!("s/{i}"),
                    pose,
                },
            ));
        }
        let index = RetrievalIndex::build(&frames)?;
        assert_eq!(index.len(), 4);
        // The square at 30 lies nearest the one at 32; a darker exposure changes nothing.
        let mut query = square_at(30).to_rgb8();
        query.pixels_mut().for_each(|p| p.0 = p.0.map(|v| v / 2));
        let found = index.localize(&DynamicImage::ImageRgb8(query))?;
        assert_eq!(found.best.index, 2);
        assert_eq!(found.pose.position(), [2.0, 0.0, 0.0]);
        // Four frames 1 m apart around frame 2: distances 0, 1, 1, 2.
        assert!((found.sigma_pos_m - (6.0f64 / 4.0).sqrt()).abs() < 1e-9);
        let d = descriptor(&square_at(30))?;
        let hits = index.query(&d, 3);
        assert_eq!(hits.len(), 3);
        assert!(hits.windows(2).all(|w| w[0].score >= w[1].score));
        assert!(index.query(&d, 10).len() == 4);
        Ok(())
    }

    #[test]
    fn a_flat_image_has_a_zero_descriptor_and_bad_files_are_named() {
        let flat = DynamicImage::ImageRgb8(RgbImage::from_pixel(64, 48, Rgb([9, 9, 9])));
        assert!(descriptor(&flat).unwrap().iter().all(|&v| v == 0.0));
        let dir = tempfile::tempdir().unwrap();
        let bad = dir.path().join("bad.png");
        std::fs::write(&bad, b"not a png").unwrap();
        let e = describe_file(&bad).unwrap_err().to_string();
        assert!(e.contains("bad.png"), "{e}");
        assert!(RetrievalIndex::build(&[]).is_err());
    }
}
