//! Estimators: what turns one frame into a pose measurement for the filter.
//!
//! - [`NetworkEstimator`]: the pose network of a checkpoint folder, with Monte-Carlo-dropout
//!   passes for its uncertainty (or one deterministic pass plus the network's own error scale).
//! - [`MarkerEstimator`]: ArUco markers of a marker map seen by a calibrated camera: a metric
//!   fix whenever a mapped marker is in view, with the covariance of the corner fit.
//! - [`MapEstimator`]: a keyframe map (`indoorloc map build`): the frame's local features
//!   matched to the map's keyframes and the pose from PnP, starting from the estimate the
//!   estimators before it gave (or the filter's prediction); a centimetre fix whenever the
//!   geometry holds, nothing when it does not (the coarse pose then stands alone).
//!
//! - [`SequenceEstimator`]: a sequence model's live tracker (CNN + LSTM), its history
//!   forgotten at every scene start.
//! - [`RetrievalEstimator`]: the pose of the most similar mapped frame (no network).
//!
//! Each estimator reports what it measured and how sure it is; the filter weighs them by that.
//! Estimators see frames as decoded ([`DynamicImage`]), so a recorded grey or RGBA image
//! reaches the network as it did before it went through a pipeline.

use crate::error::Result;
use crate::filter::Measurement;
use geom::{Camera, Pose, Pose3};
use image::{DynamicImage, GrayImage};
use learn::Localizer;
use learn::seq::{SeqLocalizer, SeqTracker};
use map::retrieval::RetrievalIndex;
use markers::{DetectParams, Dictionary, MarkerMap};
use nalgebra::Matrix3;
use std::path::Path;

/// One estimator's output for a frame (time is the pipeline's to fill in).
#[derive(Clone, Debug, PartialEq)]
pub struct Estimation {
    /// The estimated camera-to-world pose.
    pub pose: Pose,
    /// Position covariance, m², world axes.
    pub cov_pos_m2: Matrix3<f64>,
    /// Rotation standard deviation, radians.
    pub sigma_rot_rad: f64,
    /// The figures as the estimator stated them, where it states more than the above (a
    /// network's own sigmas and 3-DoF pose): what `localize` writes, unrounded by conversions.
    pub stated: Option<Stated>,
    /// What a keyframe map made of the frame, when one saw it.
    pub refinement: Option<RefinementNote>,
    /// Whether this is a measurement. False for an estimate handed on unchanged with a note
    /// (a map that could not refine the frame passes on the coarse pose it was given): the
    /// filter takes measurements only.
    pub measured: bool,
}

/// An estimator's own figures (see [`Estimation::stated`]).
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct Stated {
    /// The 3-DoF pose of a 3-DoF model.
    pub pose3: Option<Pose3>,
    /// `sqrt(trace Σ_pos)`, metres.
    pub sigma_pos_m: f64,
    /// Rotation spread, degrees.
    pub sigma_rot_deg: f64,
}

/// What a keyframe map made of a frame.
#[derive(Clone, Debug, PartialEq)]
pub struct RefinementNote {
    /// Whether the pose is the map's (PnP held).
    pub refined: bool,
    /// PnP inliers.
    pub inliers: usize,
    /// Why the coarse pose was kept.
    pub fallback: Option<String>,
}

impl Estimation {
    /// An estimate whose position uncertainty is known only as `sigma_pos_m`
    /// (`sqrt(trace Σ_pos)`, metres): spread evenly over the three axes.
    pub fn isotropic(pose: Pose, sigma_pos_m: f64, sigma_rot_rad: f64) -> Estimation {
        Estimation::plain(pose, isotropic_cov(sigma_pos_m), sigma_rot_rad)
    }

    /// A measurement with nothing stated beyond its pose and uncertainty.
    pub fn plain(pose: Pose, cov_pos_m2: Matrix3<f64>, sigma_rot_rad: f64) -> Estimation {
        Estimation {
            pose,
            cov_pos_m2,
            sigma_rot_rad,
            stated: None,
            refinement: None,
            measured: true,
        }
    }

    /// A network's estimate, its own figures kept.
    pub fn of_network(e: &learn::Estimate) -> Estimation {
        Estimation {
            stated: Some(Stated {
                pose3: e.pose3,
                sigma_pos_m: e.sigma_pos_m,
                sigma_rot_deg: e.sigma_rot_deg,
            }),
            ..Estimation::plain(e.pose, e.cov_pos_m2, e.sigma_rot_deg.to_radians())
        }
    }

    /// `sqrt(trace Σ_pos)`, metres.
    pub fn sigma_pos_m(&self) -> f64 {
        self.cov_pos_m2.trace().max(0.0).sqrt()
    }

    /// The filter's measurement at time `t`.
    pub fn at(&self, t: f64) -> Measurement {
        Measurement {
            t,
            pose: self.pose,
            cov_pos_m2: self.cov_pos_m2,
            sigma_rot_rad: self.sigma_rot_rad,
        }
    }
}

/// The frame as 8-bit RGB: borrowed when it is decoded as such (every live frame), converted
/// otherwise (a grey or RGBA file).
pub(crate) fn rgb_of(image: &DynamicImage) -> std::borrow::Cow<'_, image::RgbImage> {
    match image.as_rgb8() {
        Some(rgb) => std::borrow::Cow::Borrowed(rgb),
        None => std::borrow::Cow::Owned(image.to_rgb8()),
    }
}

/// The covariance `sigma_pos_m² / 3 · I` (m²).
pub fn isotropic_cov(sigma_pos_m: f64) -> Matrix3<f64> {
    Matrix3::identity() * (sigma_pos_m * sigma_pos_m / 3.0)
}

/// Something that estimates the camera pose from one frame.
pub trait Estimator {
    /// Short name for the pose stream and the metrics (`network`, `markers`).
    fn name(&self) -> &'static str;
    /// The pose seen in `image`, or `None` when this estimator sees nothing to go on (no marker
    /// in view). `prior`: what is already known of this frame's pose, the last estimate an
    /// estimator before this one gave for it, else the filter's prediction for its time.
    fn estimate(
        &mut self,
        image: &DynamicImage,
        prior: Option<&Estimation>,
    ) -> Result<Option<Estimation>>;
    /// A new scene starts with the next frame (a cut, a new recording, a gap): forget what
    /// earlier frames taught (a sequence model's history). Nothing for single-frame estimators.
    fn reset(&mut self) {}
}

/// An estimator the live pipeline can run on its own thread.
pub type BoxedEstimator = Box<dyn Estimator + Send>;

/// The pose network of a checkpoint folder.
pub struct NetworkEstimator {
    loc: Localizer,
    mc_passes: usize,
}

impl NetworkEstimator {
    /// Loads the model in `dir`; `mc_passes` dropout passes per frame (0: one deterministic
    /// pass).
    pub fn load(dir: &Path, mc_passes: usize) -> Result<NetworkEstimator> {
        Ok(NetworkEstimator {
            loc: Localizer::load(dir)?,
            mc_passes,
        })
    }

    /// An estimator over a loaded model.
    pub fn from_localizer(loc: Localizer, mc_passes: usize) -> NetworkEstimator {
        NetworkEstimator { loc, mc_passes }
    }

    /// The same estimator with test-time augmentation on or off (off by default; see
    /// [`Localizer::with_tta`]).
    pub fn with_tta(mut self, tta: bool) -> NetworkEstimator {
        self.loc = self.loc.with_tta(tta);
        self
    }

    /// The factor of the filter's covariance that the model's fused calibration gives for
    /// this estimator's settings ([`crate::calibrate`]): `None` when the model has none, or
    /// when it was fitted with other MC passes or TTA than this estimator runs.
    pub fn fused_cov_scale(&self) -> Option<f64> {
        let calibrated = self.mc_passes == learn::calibrate::CALIBRATION_MC && self.loc.tta();
        let fused = self.loc.meta().uncertainty.as_ref()?.fused.as_ref()?;
        calibrated.then_some(fused.scale)
    }

    /// The loaded model.
    pub fn localizer(&self) -> &Localizer {
        &self.loc
    }
}

impl Estimator for NetworkEstimator {
    fn name(&self) -> &'static str {
        "network"
    }

    fn estimate(
        &mut self,
        image: &DynamicImage,
        _prior: Option<&Estimation>,
    ) -> Result<Option<Estimation>> {
        let e = self.loc.predict(image, self.mc_passes)?;
        Ok(Some(Estimation::of_network(&e)))
    }
}

/// A sequence model's live tracker: one frame at a time, the LSTM state carried from frame to
/// frame until a scene starts.
pub struct SequenceEstimator<'a> {
    seq: &'a SeqLocalizer,
    tracker: SeqTracker<'a>,
}

impl<'a> SequenceEstimator<'a> {
    /// The tracker of `seq` with `mc_passes` Monte-Carlo streams beside the plain one.
    pub fn new(seq: &'a SeqLocalizer, mc_passes: usize) -> SequenceEstimator<'a> {
        SequenceEstimator {
            seq,
            tracker: seq.tracker(mc_passes),
        }
    }
}

impl Estimator for SequenceEstimator<'_> {
    fn name(&self) -> &'static str {
        "sequence"
    }

    fn estimate(
        &mut self,
        image: &DynamicImage,
        _prior: Option<&Estimation>,
    ) -> Result<Option<Estimation>> {
        let view = self.seq.base().view(image)?;
        Ok(Some(Estimation::of_network(&self.tracker.step(&view)?)))
    }

    fn reset(&mut self) {
        self.tracker.reset();
    }
}

/// The pose of the most similar mapped frame, with the spread of the five most similar as its
/// uncertainty.
pub struct RetrievalEstimator {
    index: RetrievalIndex,
}

impl RetrievalEstimator {
    /// Answers from `index`.
    pub fn new(index: RetrievalIndex) -> RetrievalEstimator {
        RetrievalEstimator { index }
    }
}

impl Estimator for RetrievalEstimator {
    fn name(&self) -> &'static str {
        "retrieval"
    }

    fn estimate(
        &mut self,
        image: &DynamicImage,
        _prior: Option<&Estimation>,
    ) -> Result<Option<Estimation>> {
        let r = self
            .index
            .localize(image)
            .map_err(|e| learn::LearnError::Input(e.to_string()))?;
        Ok(Some(Estimation {
            stated: Some(Stated {
                pose3: None,
                sigma_pos_m: r.sigma_pos_m,
                sigma_rot_deg: r.sigma_rot_deg,
            }),
            ..Estimation::plain(
                r.pose,
                Matrix3::identity() * (r.sigma_pos_m.powi(2) / 3.0),
                r.sigma_rot_deg.to_radians(),
            )
        }))
    }
}

/// Metric fixes from the mapped ArUco markers in view.
pub struct MarkerEstimator {
    map: MarkerMap,
    camera: Camera,
    dict: Dictionary,
    params: DetectParams,
    gray: GrayImage,
}

impl MarkerEstimator {
    /// Markers of `map` (of dictionary `dict`, else the map's own, else `4x4_50`) seen by
    /// `camera`.
    pub fn new(map: MarkerMap, camera: Camera, dict: Option<&str>) -> Result<MarkerEstimator> {
        let name = dict
            .map(str::to_string)
            .or_else(|| map.dictionary.clone())
            .unwrap_or_else(|| "4x4_50".to_string());
        Ok(MarkerEstimator {
            dict: Dictionary::predefined(&name)?,
            map,
            camera,
            // Poses need the sub-pixel corners.
            params: DetectParams {
                refine_edges: true,
                ..DetectParams::default()
            },
            gray: GrayImage::new(1, 1),
        })
    }
}

impl Estimator for MarkerEstimator {
    fn name(&self) -> &'static str {
        "markers"
    }

    fn estimate(
        &mut self,
        image: &DynamicImage,
        _prior: Option<&Estimation>,
    ) -> Result<Option<Estimation>> {
        if self.gray.dimensions() != (image.width(), image.height()) {
            self.gray = GrayImage::new(image.width(), image.height());
        }
        let rgb = rgb_of(image);
        imgproc::view::rgb_to_gray(&rgb, &mut self.gray)
            .map_err(|e| crate::TrackError::Config(format!("marker view: {e}")))?;
        let found = markers::detect(&self.gray, &self.dict, &self.params);
        Ok(markers::locate(&found, &self.map, &self.camera)
            .map(|l| Estimation::isotropic(l.pose, l.sigma_pos_m, l.sigma_rot_deg.to_radians())))
    }
}

/// Centimetre fixes from a keyframe map (see the module docs).
pub struct MapEstimator {
    map: map::KeyframeMap,
    cfg: map::RefineConfig,
    alone: bool,
    /// The map file, named in errors.
    path: Option<std::path::PathBuf>,
}

impl MapEstimator {
    /// Loads the map file at `path` (errors name it).
    pub fn load(path: &Path) -> Result<MapEstimator> {
        Ok(MapEstimator::new(map::file::load(path)?, map::RefineConfig::default()).named(path))
    }

    /// A loaded map with refinement settings.
    pub fn new(map: map::KeyframeMap, cfg: map::RefineConfig) -> MapEstimator {
        MapEstimator {
            map,
            cfg,
            alone: false,
            path: None,
        }
    }

    /// Names the map's file in errors.
    pub fn named(mut self, path: &Path) -> MapEstimator {
        self.path = Some(path.to_path_buf());
        self
    }

    /// The map as the only estimator: a frame with no prior gets the map's own answer even
    /// when PnP fails (its retrieval's pose, with the spread of the most similar keyframes as
    /// covariance), instead of nothing.
    pub fn alone(mut self) -> MapEstimator {
        self.alone = true;
        self
    }
}

impl Estimator for MapEstimator {
    fn name(&self) -> &'static str {
        "map"
    }

    fn estimate(
        &mut self,
        image: &DynamicImage,
        prior: Option<&Estimation>,
    ) -> Result<Option<Estimation>> {
        let coarse = prior.map(|p| map::Coarse {
            pose: p.pose,
            sigma_pos_m: p.stated.map_or_else(|| p.sigma_pos_m(), |s| s.sigma_pos_m),
        });
        let r =
            self.map
                .refine(image, coarse.as_ref(), &self.cfg)
                .map_err(|error| match &self.path {
                    Some(path) => crate::TrackError::MapFile {
                        path: path.clone(),
                        error,
                    },
                    None => error.into(),
                })?;
        let note = RefinementNote {
            refined: r.refined,
            inliers: r.inliers,
            fallback: r.fallback.as_ref().map(ToString::to_string),
        };
        Ok(match (prior, r.refined) {
            // The coarse pose stands, with the map's note; not a new measurement.
            (Some(p), false) => Some(Estimation {
                refinement: Some(note),
                measured: false,
                ..p.clone()
            }),
            (None, false) if !self.alone => None,
            _ => {
                let rot = r.cov_rot_rad2.map_or(0.0, |c| c.trace());
                Some(Estimation {
                    refinement: Some(note),
                    ..Estimation::plain(
                        r.pose,
                        r.cov_pos_m2.unwrap_or_else(Matrix3::zeros),
                        rot.max(0.0).sqrt(),
                    )
                })
            }
        })
    }
}
