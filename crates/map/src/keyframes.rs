//! The keyframe map: frames of a posed dataset kept every few centimetres of the camera's path,
//! each with its retrieval descriptor and its local features lifted to 3-D by its depth or, where
//! the frames have none, by triangulation between keyframes.

use crate::depth::{DepthModel, read_depth};
use crate::retrieval::{self, Keyframe, RetrievalIndex};
use crate::triangulate::{self, TriangulationConfig, Viewed};
use crate::{MapError, Result};
use data::posed::{PosedDataset, PosedImage};
use features::{Descriptor, ExtractConfig, Features};
use geom::{Camera, Pose};
use image::{DynamicImage, GrayImage};
use rayon::prelude::*;

/// The local features of a keyframe that have a 3-D point.
#[derive(Clone, Debug, Default, PartialEq)]
pub struct MappedFeatures {
    /// Keypoint pixels in the keyframe.
    pub keypoints: Vec<[f32; 2]>,
    /// Their world points, metres.
    pub points: Vec<[f32; 3]>,
    /// Their descriptors.
    pub descriptors: Vec<Descriptor>,
}

impl MappedFeatures {
    /// Number of features.
    pub fn len(&self) -> usize {
        self.points.len()
    }

    /// True when none was lifted.
    pub fn is_empty(&self) -> bool {
        self.points.is_empty()
    }
}

/// The map of a building (see the module docs).
#[derive(Clone, Debug)]
pub struct KeyframeMap {
    /// The camera of the mapped (and queried) images.
    pub camera: Camera,
    /// The feature settings the map was built with (queries use the same).
    pub extract: ExtractConfig,
    /// Keyframe names, poses and retrieval descriptors.
    pub retrieval: RetrievalIndex,
    /// Each keyframe's lifted features, in keyframe order.
    pub features: Vec<MappedFeatures>,
}

impl KeyframeMap {
    /// Number of keyframes.
    pub fn len(&self) -> usize {
        self.features.len()
    }

    /// True when nothing is mapped.
    pub fn is_empty(&self) -> bool {
        self.features.is_empty()
    }

    /// Number of 3-D points over all keyframes.
    pub fn points(&self) -> usize {
        self.features.iter().map(MappedFeatures::len).sum()
    }

    /// Adds `other`'s keyframes after this map's (e.g. renders near a path beside renders at
    /// it). Errors when the two were built with another camera or other feature settings.
    pub fn extend(&mut self, other: KeyframeMap) -> Result<()> {
        if other.camera != self.camera || other.extract != self.extract {
            return Err(MapError::Input(
                "maps of another camera or other feature settings cannot be joined".into(),
            ));
        }
        self.retrieval.extend(other.retrieval)?;
        self.features.extend(other.features);
        Ok(())
    }
}

/// How a map is built.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct BuildConfig {
    /// Local features of each keyframe.
    pub extract: ExtractConfig,
    /// A frame becomes a keyframe when the camera has moved this far since the last one…
    pub spacing_m: f64,
    /// …or turned this many degrees.
    pub spacing_deg: f64,
}

impl Default for BuildConfig {
    /// Default features; a keyframe every 2 cm or 2°.
    fn default() -> Self {
        BuildConfig {
            extract: ExtractConfig::default(),
            spacing_m: 0.02,
            spacing_deg: 2.0,
        }
    }
}

/// The frames kept as keyframes: the first of each sequence, then each that has moved or
/// turned past the spacing since the last kept one.
pub fn select_keyframes<'a>(images: &[&'a PosedImage], cfg: &BuildConfig) -> Vec<&'a PosedImage> {
    let mut out: Vec<&PosedImage> = Vec::new();
    for img in images {
        let keep = match out.last() {
            Some(last) if last.frame.seq == img.frame.seq => {
                geom::metrics::position_error(&last.frame.pose, &img.frame.pose) >= cfg.spacing_m
                    || geom::metrics::rotation_error_deg(&last.frame.pose, &img.frame.pose)
                        >= cfg.spacing_deg
            }
            _ => true,
        };
        if keep {
            out.push(img);
        }
    }
    out
}

/// The grey image features are found on (OpenCV's weights, [`imgproc::view::rgb_to_gray`]).
pub fn gray_of(img: &DynamicImage) -> Result<GrayImage> {
    if let DynamicImage::ImageLuma8(g) = img {
        return Ok(g.clone());
    }
    let rgb = img.to_rgb8();
    let mut gray = GrayImage::new(rgb.width(), rgb.height());
    imgproc::view::rgb_to_gray(&rgb, &mut gray)
        .map_err(|e| MapError::Input(format!("grey conversion: {e}")))?;
    Ok(gray)
}

/// How keyframe features get their 3-D points.
#[derive(Clone, Copy, Debug, PartialEq)]
pub enum Lifting {
    /// From each frame's depth image.
    Depth(DepthModel),
    /// Triangulated between keyframes from their poses ([`crate::triangulate`]).
    Triangulation(TriangulationConfig),
}

impl Lifting {
    /// Lifting by a dataset's depth images, as its layout stores them
    /// ([`DepthModel::for_dataset`]).
    pub fn depth_of(ds: &PosedDataset, camera: &Camera) -> Lifting {
        Lifting::Depth(DepthModel::for_dataset(ds, camera))
    }

    /// [`Self::depth_of`] where every one of `images` (of `ds`) has depth, triangulation
    /// otherwise.
    pub fn for_images(images: &[&PosedImage], ds: &PosedDataset, camera: &Camera) -> Lifting {
        if !images.is_empty() && images.iter().all(|i| i.depth.is_some()) {
            Lifting::depth_of(ds, camera)
        } else {
            Lifting::Triangulation(TriangulationConfig::default())
        }
    }

    /// `depth` or `triangulation`.
    pub fn name(&self) -> &'static str {
        match self {
            Lifting::Depth(_) => "depth",
            Lifting::Triangulation(_) => "triangulation",
        }
    }
}

/// Builds the map of posed images (keyframes chosen by [`select_keyframes`], described in
/// parallel; `tick` is called once per keyframe described and, when triangulating, once more
/// per keyframe triangulated). Errors name the first frame without depth (when lifting by
/// depth) or whose image cannot be read, or of another size than `camera`.
pub fn build(
    images: &[&PosedImage],
    camera: &Camera,
    lifting: &Lifting,
    cfg: &BuildConfig,
    tick: &(dyn Fn() + Sync),
) -> Result<KeyframeMap> {
    let chosen = select_keyframes(images, cfg);
    if chosen.is_empty() {
        return Err(MapError::Input("no frames to map".into()));
    }
    if let Lifting::Depth(_) = lifting
        && let Some(img) = chosen.iter().find(|i| i.depth.is_none())
    {
        return Err(MapError::Image {
            path: img.image.clone(),
            msg: "this frame has no depth image: lift by triangulation instead".into(),
        });
    }
    let described: Vec<(Vec<f32>, Features)> = chosen
        .par_iter()
        .map(|img| {
            let out = describe_keyframe(img, camera, &cfg.extract);
            tick();
            out
        })
        .collect::<Result<_>>()?;
    let (thumbs, found): (Vec<_>, Vec<_>) = described.into_iter().unzip();
    let features = match lifting {
        Lifting::Depth(model) => chosen
            .par_iter()
            .zip(&found)
            .map(|(img, f)| lift_by_depth(img, f, camera, model))
            .collect::<Result<_>>()?,
        Lifting::Triangulation(t) => {
            let views: Vec<Viewed> = chosen
                .iter()
                .zip(&found)
                .map(|(img, features)| Viewed {
                    features,
                    pose: &img.frame.pose,
                })
                .collect();
            triangulate::triangulate(&views, camera, cfg.extract.scale_factor, t, tick)
        }
    };
    let keyframes = chosen.iter().map(|i| Keyframe::of(i)).collect();
    Ok(KeyframeMap {
        camera: *camera,
        extract: cfg.extract,
        retrieval: RetrievalIndex::from_descriptors(keyframes, thumbs)?,
        features,
    })
}

/// One keyframe's retrieval descriptor and local features.
fn describe_keyframe(
    img: &PosedImage,
    camera: &Camera,
    extract: &ExtractConfig,
) -> Result<(Vec<f32>, Features)> {
    let image_err = |msg: String| MapError::Image {
        path: img.image.clone(),
        msg,
    };
    let colour = data::frames::decode_image(&img.image).map_err(|e| image_err(e.to_string()))?;
    if (colour.width(), colour.height()) != (camera.width, camera.height) {
        return Err(image_err(format!(
            "{}x{} image, the dataset's camera is {}x{}",
            colour.width(),
            colour.height(),
            camera.width,
            camera.height
        )));
    }
    let gray = gray_of(&colour)?;
    let found = features::extract(&gray, extract).map_err(|e| image_err(e.to_string()))?;
    Ok((retrieval::descriptor(&colour)?, found))
}

/// The features of a keyframe that its depth image lifts to 3-D.
fn lift_by_depth(
    img: &PosedImage,
    found: &Features,
    camera: &Camera,
    model: &DepthModel,
) -> Result<MappedFeatures> {
    let depth_path = img.depth.as_deref().expect("checked by build");
    let depth = read_depth(depth_path).map_err(|e| MapError::Input(e.to_string()))?;
    let pose: &Pose = &img.frame.pose;
    let mut out = MappedFeatures::default();
    for (kp, d) in found.keypoints.iter().zip(&found.descriptors) {
        if let Some(p) = model.lift(&depth, camera, pose, f64::from(kp.x), f64::from(kp.y)) {
            out.keypoints.push([kp.x, kp.y]);
            out.points.push([p.x as f32, p.y as f32, p.z as f32]);
            out.descriptors.push(*d);
        }
    }
    Ok(out)
}
