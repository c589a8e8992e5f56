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
//! Each estimator reports what it measured and how sure it is; the filter weighs them by that.

use crate::error::Result;
use crate::filter::Measurement;
use geom::{Camera, Pose};
use image::{DynamicImage, GrayImage, RgbImage};
use learn::Localizer;
use markers::{DetectParams, Dictionary, MarkerMap};
use nalgebra::Matrix3;
use std::path::Path;

/// One estimator's output for a frame (time is the pipeline's to fill in).
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct Estimation {
    /// The estimated camera-to-world pose.
    pub pose: Pose,
    /// Position covariance, m², world axes.
    pub cov_pos_m2: Matrix3<f64>,
    /// Rotation standard deviation, radians.
    pub sigma_rot_rad: f64,
}

impl Estimation {
    /// An estimate whose position uncertainty is known only as `sigma_pos_m`
    /// (`sqrt(trace Σ_pos)`, metres): spread evenly over the three axes.
    pub fn isotropic(pose: Pose, sigma_pos_m: f64, sigma_rot_rad: f64) -> Estimation {
        Estimation {
            pose,
            cov_pos_m2: isotropic_cov(sigma_pos_m),
            sigma_rot_rad,
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

/// The covariance `sigma_pos_m² / 3 · I` (m²).
pub fn isotropic_cov(sigma_pos_m: f64) -> Matrix3<f64> {
    Matrix3::identity() * (sigma_pos_m * sigma_pos_m / 3.0)
}

/// Something that estimates the camera pose from one frame.
pub trait Estimator: Send {
    /// Short name for the pose stream and the metrics (`network`, `markers`).
    fn name(&self) -> &'static str;
    /// The pose seen in `image`, or `None` when this estimator sees nothing to go on (no marker
    /// in view). `prior`: what is already known of this frame's pose, the last estimate an
    /// estimator before this one gave for it, else the filter's prediction for its time.
    fn estimate(
        &mut self,
        image: &RgbImage,
        prior: Option<&Estimation>,
    ) -> Result<Option<Estimation>>;
}

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
        image: &RgbImage,
        _prior: Option<&Estimation>,
    ) -> Result<Option<Estimation>> {
        // The view wants a DynamicImage; the clone of a 160x120 frame costs microseconds.
        let e = self
            .loc
            .predict(&DynamicImage::ImageRgb8(image.clone()), self.mc_passes)?;
        Ok(Some(Estimation {
            pose: e.pose,
            cov_pos_m2: e.cov_pos_m2,
            sigma_rot_rad: e.sigma_rot_deg.to_radians(),
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
        image: &RgbImage,
        _prior: Option<&Estimation>,
    ) -> Result<Option<Estimation>> {
        if self.gray.dimensions() != image.dimensions() {
            self.gray = GrayImage::new(image.width(), image.height());
        }
        imgproc::view::rgb_to_gray(image, &mut self.gray)
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
}

impl MapEstimator {
    /// Loads the map file at `path` (errors name it).
    pub fn load(path: &Path) -> Result<MapEstimator> {
        Ok(MapEstimator::new(
            map::file::load(path)?,
            map::RefineConfig::default(),
        ))
    }

    /// A loaded map with refinement settings.
    pub fn new(map: map::KeyframeMap, cfg: map::RefineConfig) -> MapEstimator {
        MapEstimator { map, cfg }
    }
}

impl Estimator for MapEstimator {
    fn name(&self) -> &'static str {
        "map"
    }

    fn estimate(
        &mut self,
        image: &RgbImage,
        prior: Option<&Estimation>,
    ) -> Result<Option<Estimation>> {
        let coarse = prior.map(|p| map::Coarse {
            pose: p.pose,
            sigma_pos_m: p.sigma_pos_m(),
        });
        // The refinement reads a DynamicImage; the copy costs well under a millisecond.
        let img = DynamicImage::ImageRgb8(image.clone());
        let r = self.map.refine(&img, coarse.as_ref(), &self.cfg)?;
        Ok(r.refined.then(|| {
            let rot = r.cov_rot_rad2.map_or(0.0, |c| c.trace());
            Estimation {
                pose: r.pose,
                cov_pos_m2: r.cov_pos_m2.unwrap_or_else(Matrix3::zeros),
                sigma_rot_rad: rot.max(0.0).sqrt(),
            }
        }))
    }
}
