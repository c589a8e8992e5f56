//! Inference: [`Localizer`] loads a checkpoint and turns images into poses, with Monte-Carlo
//! dropout uncertainty when asked for more than one pass and, with [`Localizer::with_tta`],
//! test-time augmentation ([`crate::tta`]).
//!
//! The pose is the plain (dropout-off) pass, the weight-scaling rule that the mean of infinitely
//! many MC passes approaches; with TTA, the position is the mean of the plain passes of the view
//! and its copies (the rotation stays the view's own). A finite MC mean is noisier: on the full
//! ceiling demo's held-out walk the mean of 16 passes had a median error of 0.209 m, of 64
//! passes 0.162 m, the plain pass 0.166 m.
//!
//! With `N > 1` passes the network runs once per image up to the pooled features, which are
//! repeated `N` times, masked by `N` Bernoulli masks and sent through the head as one batch.
//! The MC spread is `sqrt(trace Σ_pos)` with the population covariance of the sample positions,
//! and `sigma_rot_deg` is the RMS angle between the samples and their mean rotation. Masks come
//! from a generator seeded per call, so the same image gives the same estimate every time.
//!
//! The position covariance `cov_pos_m2` adds three covariances, each weighed by the
//! checkpoint's [`SigmaWeights`] (fitted on the validation frames by [`crate::calibrate`]; 1
//! for models from before): the MC samples' covariance, the TTA views' covariance about their
//! mean (each shrunk to isotropic, [`SHRINKAGE`]), and for a model with a per-image scale
//! output ([`crate::net::HeadConfig::aleatoric`]) that error's own, isotropic covariance:
//! under the density `∝ exp(−‖e‖ / b)` in `d` dimensions, `E‖e‖² = d(d + 1)·b²`, averaged
//! over the views. So it holds what the model is
//! unsure of (the MC spread), how much the answer hangs on details of the image (the TTA
//! spread) and what the image leaves open (the scale). The sum is then multiplied by the
//! model's calibration scale ([`UncertaintyCalibration`]), so that it means what a Gaussian
//! covariance claims; `sigma_pos_m` is the square root of its trace.

use std::path::Path;

use burn::module::Module;
use burn::tensor::{Device, Tensor, TensorData};
use geom::{Pose, Pose3};
use image::DynamicImage;
use imgproc::view::{View, ViewSpec};
use nalgebra::{Matrix3, Quaternion, UnitQuaternion, Vector3};

use crate::checkpoint::{self, MODEL_BPK, ModelMeta};
use crate::head::{PoseCoding, Task};
use crate::net::PoseNet;
use crate::sigma::{SigmaParts, SigmaWeights, UncertaintyCalibration};
use crate::tta;
use crate::{LearnError, Result};

/// Images per forward pass when many are predicted at once: bounds memory, keeps batches
/// large enough for fast convolutions.
pub const CHUNK: usize = 32;

/// Seed of the dropout masks of MC inference unless [`Localizer::with_seed`] sets another.
pub const DEFAULT_MC_SEED: u64 = 0x1d00_710c;

/// A pose estimate with its uncertainty.
#[derive(Clone, Debug, PartialEq)]
pub struct Estimate {
    /// Camera-to-world pose (for a 3-DoF model, the level camera at the training height).
    pub pose: Pose,
    /// The 3-DoF pose, for 3-DoF models.
    pub pose3: Option<Pose3>,
    /// `sqrt(trace cov_pos_m2)`, metres.
    pub sigma_pos_m: f64,
    /// Position covariance, m², world axes (see the module docs): calibrated when the model
    /// is; for a 3-DoF model the z row and column are 0.
    pub cov_pos_m2: Matrix3<f64>,
    /// RMS angle of the MC samples to the mean rotation, degrees, times the square root of the
    /// model's rotation scale when it is calibrated; 0 without MC passes.
    pub sigma_rot_deg: f64,
    /// Stochastic passes used (0 = one deterministic pass).
    pub passes: usize,
}

/// A loaded model, ready to localise images.
#[derive(Debug)]
pub struct Localizer {
    net: PoseNet,
    meta: ModelMeta,
    spec: ViewSpec,
    device: Device,
    seed: u64,
    tta: bool,
}

impl Localizer {
    /// Loads the checkpoint folder `dir` (its `model.toml` and `model.bpk`) on the process's
    /// device ([`crate::device::select`]; the CPU by default). A missing, damaged or
    /// inconsistent file is an error naming it.
    pub fn load(dir: &Path) -> Result<Localizer> {
        Self::load_on(dir, crate::device::inference())
    }

    /// [`Localizer::load`] on a chosen device.
    pub fn load_on(dir: &Path, device: Device) -> Result<Localizer> {
        let meta = ModelMeta::read(dir)?;
        let bytes = checkpoint::read_checked(dir, MODEL_BPK, &meta.weights_hash)?;
        let net = checkpoint::load_weights(&meta.net, bytes, &device, &dir.join(MODEL_BPK))?;
        let spec = ViewSpec::resolve(&meta.view)
            .map_err(|e| LearnError::corrupt(dir.join(checkpoint::MODEL_TOML), e.to_string()))?;
        Ok(Localizer {
            net: net.valid().fold_batchnorm(),
            meta,
            spec,
            device,
            seed: DEFAULT_MC_SEED,
            tta: false,
        })
    }

    /// The same localizer with another seed for the MC dropout masks.
    pub fn with_seed(mut self, seed: u64) -> Localizer {
        self.seed = seed;
        self
    }

    /// The same localizer with test-time augmentation on or off (off by default): each image
    /// is also seen as `tta::TTA_VIEWS − 1` (4) shifted copies, at that many times the
    /// backbone's cost.
    pub fn with_tta(mut self, tta: bool) -> Localizer {
        self.tta = tta;
        self
    }

    /// Whether test-time augmentation is on.
    pub fn tta(&self) -> bool {
        self.tta
    }

    /// The (folded, inference-only) network.
    pub(crate) fn net(&self) -> &PoseNet {
        &self.net
    }

    /// The device the network runs on.
    pub(crate) fn device(&self) -> &Device {
        &self.device
    }

    /// The seed of the MC dropout masks.
    pub(crate) fn seed(&self) -> u64 {
        self.seed
    }

    /// Packs views into `[N, C, H, W]` values, checking each against the model's input shape.
    pub(crate) fn pack(&self, views: &[View]) -> Result<Vec<f32>> {
        pack_views(views, self.meta.input, &self.meta.view)
    }

    /// Global descriptors of views for image retrieval: the pretrained layers' map averaged
    /// over the image and L2-normalised, one row per view; `None` for a network without
    /// pretrained layers. ImageNet features find the same place from another viewpoint where
    /// thumbnails do not (ARCHITECTURE.md, "Real data"). Run `CHUNK` views at a time.
    pub fn descriptors(&self, views: &[View]) -> Result<Option<Vec<Vec<f32>>>> {
        let [c, h, w] = self.meta.input;
        let mut rows = Vec::with_capacity(views.len());
        for part in views.chunks(CHUNK) {
            let x = Tensor::<4>::from_data(
                TensorData::new(self.pack(part)?, [part.len(), c, h, w]),
                &self.device,
            );
            let Some(map) = self.net.frozen_maps(x) else {
                return Ok(None);
            };
            let [b, f, _, _] = map.dims();
            let pooled = map.mean_dim(3).mean_dim(2).reshape([b, f]);
            for mut row in rows_of(pooled)? {
                let norm = row.iter().map(|v| v * v).sum::<f32>().sqrt().max(1e-12);
                row.iter_mut().for_each(|v| *v /= norm);
                rows.push(row);
            }
        }
        Ok(Some(rows))
    }

    /// The checkpoint's description (task, view, metrics, ...).
    pub fn meta(&self) -> &ModelMeta {
        &self.meta
    }

    /// The view the network takes.
    pub fn view_spec(&self) -> &ViewSpec {
        &self.spec
    }

    /// The network's view of an image.
    pub fn view(&self, img: &DynamicImage) -> Result<View> {
        self.spec
            .apply(img, 0)
            .map_err(|e| LearnError::Input(e.to_string()))
    }

    /// The pose of one image; `mc_passes` > 1 adds MC-dropout uncertainty.
    pub fn predict(&self, img: &DynamicImage, mc_passes: usize) -> Result<Estimate> {
        self.predict_view(&self.view(img)?, mc_passes)
    }

    /// The pose of one view made with [`Localizer::view_spec`].
    pub fn predict_view(&self, view: &View, mc_passes: usize) -> Result<Estimate> {
        let mut out = self.predict_batch(std::slice::from_ref(view), mc_passes)?;
        out.pop()
            .ok_or_else(|| LearnError::Input("no estimate for the view".into()))
    }

    /// Poses of many views, run in batches of `CHUNK` images.
    pub fn predict_batch(&self, views: &[View], mc_passes: usize) -> Result<Vec<Estimate>> {
        let weights = self.meta.sigma_weights();
        let calibration = self.meta.uncertainty.as_ref();
        Ok(self
            .outputs(views, mc_passes)?
            .iter()
            .map(|o| o.estimate(&self.meta.coding, &weights, calibration))
            .collect())
    }

    /// Each view's pose, the covariances its `cov_pos_m2` is made of before the calibrated
    /// weights ([`SigmaParts`]: what each source of uncertainty says on its own) and the MC
    /// rotation spread (degrees, uncalibrated), with this localizer's TTA setting and
    /// `mc_passes` MC passes.
    pub fn sigma_parts(
        &self,
        views: &[View],
        mc_passes: usize,
    ) -> Result<Vec<(Pose, SigmaParts, f64)>> {
        Ok(self
            .outputs(views, mc_passes)?
            .iter()
            .map(|o| o.parts(&self.meta.coding))
            .collect())
    }

    /// The estimate this model gives a pose with its covariance parts and MC rotation spread
    /// (degrees, as [`Localizer::sigma_parts`] returns them) from `passes` MC passes: what
    /// [`Localizer::predict_batch`] would give, without running the network again.
    pub fn estimate_from_parts(
        &self,
        pose: Pose,
        parts: &SigmaParts,
        sigma_rot_deg: f64,
        passes: usize,
    ) -> Estimate {
        weighed(
            &self.meta.coding,
            &self.meta.sigma_weights(),
            self.meta.uncertainty.as_ref(),
            (pose, parts, sigma_rot_deg),
            passes,
        )
    }

    /// The network's outputs for `views`, [`CHUNK`] images at a time.
    fn outputs(&self, views: &[View], mc_passes: usize) -> Result<Vec<ImageOutputs>> {
        predict_outputs(
            &self.net,
            views,
            self.meta.input,
            &self.meta.view,
            Passes::new(self.tta, mc_passes, self.meta.dropout, self.seed),
            &self.device,
        )
    }
}

/// Packs views into `[N, C, H, W]` values, checking each against a model's `input` shape
/// (`view`: the model's view text, for the error).
pub(crate) fn pack_views(views: &[View], input: [usize; 3], view: &str) -> Result<Vec<f32>> {
    let [c, h, w] = input;
    let mut inputs = Vec::with_capacity(views.len() * c * h * w);
    for (i, v) in views.iter().enumerate() {
        if [v.channels as usize, v.height as usize, v.width as usize] != input {
            return Err(LearnError::Input(format!(
                "view {i} is {}x{}x{}, the model takes {c}x{h}x{w} (view '{view}')",
                v.channels, v.height, v.width
            )));
        }
        inputs.extend_from_slice(&v.data);
    }
    Ok(inputs)
}

/// How many rows each image gives: `views` plain passes (the image's view, then its TTA
/// copies) and `mc` Monte-Carlo passes of its own view with dropout `p` (none for `mc` < 2),
/// through the ensemble of masks drawn from `seed` ([`crate::net::mc::ensemble_masks`]).
#[derive(Clone, Copy, Debug)]
pub struct Passes {
    /// Views per image, the image's own first.
    pub views: usize,
    /// MC-dropout passes of the image's own view.
    pub mc: usize,
    /// Dropout probability of the MC passes.
    pub p: f64,
    /// Seed of the MC passes' masks.
    pub seed: u64,
}

impl Passes {
    /// One plain pass per image, nothing else.
    pub const PLAIN: Passes = Passes {
        views: 1,
        mc: 0,
        p: 0.0,
        seed: 0,
    };

    /// With or without TTA, `mc` MC passes (fewer than 2, or `p` = 0: none) at dropout `p`,
    /// masks drawn from `seed`.
    pub fn new(tta: bool, mc: usize, p: f64, seed: u64) -> Passes {
        Passes {
            views: if tta { tta::TTA_VIEWS } else { 1 },
            mc: if mc > 1 && p > 0.0 { mc } else { 0 },
            p,
            seed,
        }
    }
}

/// One image's network outputs.
#[derive(Clone, Debug, PartialEq)]
pub struct ImageOutputs {
    /// The plain pass of each view, the image's own first.
    pub views: Vec<Vec<f32>>,
    /// The MC-dropout passes of the image's own view.
    pub mc: Vec<Vec<f32>>,
}

impl ImageOutputs {
    /// The pose (see the module docs), its covariance parts and the MC rotation spread
    /// (degrees).
    pub fn parts(&self, coding: &PoseCoding) -> (Pose, SigmaParts, f64) {
        let poses: Vec<Pose> = self.views.iter().map(|r| coding.decode(r)).collect();
        let rotation = poses
            .first()
            .map_or(Pose::identity().rotation, |p| p.rotation);
        let (mean, _, _) = mean_pose(&poses);
        let (mc, sigma_rot_deg) = if self.mc.len() > 1 {
            let samples: Vec<Pose> = self.mc.iter().map(|r| coding.decode(r)).collect();
            let (_, _, rot) = mean_pose(&samples);
            (position_covariance(&samples), rot)
        } else {
            (Matrix3::zeros(), 0.0)
        };
        let dims = coding.task.pos_dims();
        let per_axis = aleatoric_variance(coding, &self.views) / dims as f64;
        let mut scale = Matrix3::zeros();
        for k in 0..dims {
            scale[(k, k)] = per_axis;
        }
        let parts = SigmaParts {
            mc: shrunk(&mc, dims),
            tta: shrunk(&position_covariance(&poses), dims),
            scale,
        };
        (Pose::new(rotation, mean.translation), parts, sigma_rot_deg)
    }

    /// The estimate these outputs give: its covariance parts weighed by `weights`, then
    /// scaled by `calibration` when there is one.
    pub fn estimate(
        &self,
        coding: &PoseCoding,
        weights: &SigmaWeights,
        calibration: Option<&UncertaintyCalibration>,
    ) -> Estimate {
        let (pose, parts, sigma_rot_deg) = self.parts(coding);
        let passes = if self.mc.len() > 1 { self.mc.len() } else { 0 };
        weighed(
            coding,
            weights,
            calibration,
            (pose, &parts, sigma_rot_deg),
            passes,
        )
    }
}

/// The estimate of a pose with its covariance parts and MC rotation spread (degrees): the
/// parts weighed by `weights`, then scaled by `calibration` when there is one.
pub(crate) fn weighed(
    coding: &PoseCoding,
    weights: &SigmaWeights,
    calibration: Option<&UncertaintyCalibration>,
    (pose, parts, sigma_rot_deg): (Pose, &SigmaParts, f64),
    passes: usize,
) -> Estimate {
    let cov = weights.covariance(parts, coding.task.pos_dims())
        * calibration.map_or(1.0, |c| c.position.scale);
    let rot_scale = calibration
        .and_then(|c| c.rotation.as_ref())
        .map_or(1.0, |c| c.scale);
    Estimate {
        pose,
        pose3: (coding.task == Task::Pose3).then(|| pose.to_pose3(coding.mount)),
        sigma_pos_m: cov.trace().max(0.0).sqrt(),
        cov_pos_m2: cov,
        sigma_rot_deg: sigma_rot_deg * rot_scale.sqrt(),
        passes,
    }
}

/// Share of the isotropic part in a sample covariance after shrinkage ([`shrunk`]): all of it.
/// Measured with `study uncertainty --quick` on held-out walks (2026-12-06): the sample
/// covariances as they are left 2 % of the forward walk's errors inside the calibrated 50 %
/// region and 85 % inside the 95 % one (expected calibration error 0.32); halfway to isotropic
/// 46 % / 98 % (0.074); isotropic 53 % / 95 % (0.046), and the fused track 51 % / 89 % against
/// 26 % / 92 % halfway.
pub const SHRINKAGE: f64 = 1.0;

/// `(1 − λ)·C + λ·(tr C / d)·I` on the position's `d` axes, λ = [`SHRINKAGE`]: a covariance of
/// 16 MC samples or 5 TTA views is sure of too much in its thinnest directions (a camera
/// height the samples agree on to the millimetre is not known to the millimetre).
fn shrunk(c: &Matrix3<f64>, dims: usize) -> Matrix3<f64> {
    let mut out = c * (1.0 - SHRINKAGE);
    let iso = c.trace() / dims as f64;
    for k in 0..dims {
        out[(k, k)] += SHRINKAGE * iso;
    }
    out
}

/// Population covariance of the poses' positions, m².
pub fn position_covariance(poses: &[Pose]) -> Matrix3<f64> {
    if poses.len() < 2 {
        return Matrix3::zeros();
    }
    let n = poses.len() as f64;
    let mean = poses
        .iter()
        .fold(Vector3::zeros(), |acc, p| acc + p.translation)
        / n;
    poses.iter().fold(Matrix3::zeros(), |acc, p| {
        let d = p.translation - mean;
        acc + d * d.transpose()
    }) / n
}

/// [`image_outputs`] of views (each image's own; with TTA in `passes` its copies are made
/// here, [`CHUNK`] images at a time so that memory stays that of the views), checked against
/// the model's `input` shape (`view`: its view text, for errors).
pub fn predict_outputs(
    net: &PoseNet,
    views: &[View],
    input: [usize; 3],
    view: &str,
    passes: Passes,
    device: &Device,
) -> Result<Vec<ImageOutputs>> {
    if passes.views <= 1 {
        let inputs = pack_views(views, input, view)?;
        return image_outputs(net, &inputs, input, passes, device);
    }
    let mut out = Vec::with_capacity(views.len());
    for chunk in views.chunks(CHUNK) {
        let copies = chunk
            .iter()
            .map(tta::views)
            .collect::<Result<Vec<_>>>()?
            .concat();
        let inputs = pack_views(&copies, input, view)?;
        out.extend(image_outputs(net, &inputs, input, passes, device)?);
    }
    Ok(out)
}

/// Outputs of `net` for packed inputs `[N · passes.views, C, H, W]`, one [`ImageOutputs`] per
/// image. The backbone runs once per view; the MC passes reuse the image's own view's pooled
/// features, repeated and masked by the ensemble of `passes.seed`, the same for every image
/// ([`crate::net::mc::ensemble_masks`]).
pub fn image_outputs(
    net: &PoseNet,
    inputs: &[f32],
    [c, h, w]: [usize; 3],
    passes: Passes,
    device: &Device,
) -> Result<Vec<ImageOutputs>> {
    let per_view = c * h * w;
    let k = passes.views.max(1);
    let images = inputs.len() / (per_view * k).max(1);
    let mut out = Vec::with_capacity(images);
    for start in (0..images).step_by(CHUNK) {
        let b = CHUNK.min(images - start);
        let data = inputs[start * k * per_view..(start + b) * k * per_view].to_vec();
        let x = Tensor::<4>::from_data(TensorData::new(data, [b * k, c, h, w]), device);
        let features = net.features(x);
        let plain = rows_of(net.head_plain(features.clone()))?;
        let mc = if passes.mc > 1 && passes.p > 0.0 {
            let [_, f] = features.dims();
            let own = features.reshape([b, k, f]).narrow(1, 0, 1).reshape([b, f]);
            rows_of(net.mc_head(own, passes.mc, passes.p, passes.seed))?
        } else {
            Vec::new()
        };
        for i in 0..b {
            out.push(ImageOutputs {
                views: plain[i * k..(i + 1) * k].to_vec(),
                mc: mc
                    .get(i * passes.mc..(i + 1) * passes.mc)
                    .map_or_else(Vec::new, <[_]>::to_vec),
            });
        }
    }
    Ok(out)
}

/// The rows of a network output `[B, O]`.
pub(crate) fn rows_of(y: Tensor<2>) -> Result<Vec<Vec<f32>>> {
    let [_, o] = y.dims();
    let values = y
        .into_data()
        .try_to_vec::<f32>()
        .map_err(|e| LearnError::Input(format!("cannot read the network's outputs: {e:?}")))?;
    Ok(values.chunks_exact(o.max(1)).map(<[f32]>::to_vec).collect())
}

/// Pooled features of packed inputs `[N, C, H, W]`, `N · F` values image-major, and `F`; run
/// in chunks of [`CHUNK`].
pub fn feature_rows(
    net: &PoseNet,
    inputs: &[f32],
    [c, h, w]: [usize; 3],
    device: &Device,
) -> Result<(Vec<f32>, usize)> {
    let per = c * h * w;
    let n = inputs.len() / per.max(1);
    let (mut values, mut width) = (Vec::new(), 0);
    for start in (0..n).step_by(CHUNK) {
        let b = CHUNK.min(n - start);
        let data = inputs[start * per..(start + b) * per].to_vec();
        let x = Tensor::<4>::from_data(TensorData::new(data, [b, c, h, w]), device);
        let features = net.features(x);
        width = features.dims()[1];
        values.extend(
            features
                .into_data()
                .try_to_vec::<f32>()
                .map_err(|e| LearnError::Input(format!("cannot read the features: {e:?}")))?,
        );
    }
    Ok((values, width))
}

/// Mean predicted position-error variance `d(d + 1)·b²` of output rows with a log-scale column
/// (see the module docs); 0 for rows without one.
fn aleatoric_variance(coding: &PoseCoding, rows: &[Vec<f32>]) -> f64 {
    let column = coding.task.outputs();
    let d = coding.task.pos_dims() as f64;
    let (lo, hi) = crate::loss::LOG_SCALE_RANGE;
    let var: f64 = rows
        .iter()
        .filter_map(|r| r.get(column))
        .map(|&s| d * (d + 1.0) * (2.0 * s.clamp(lo, hi) as f64).exp())
        .sum();
    var / rows.len().max(1) as f64
}

/// One [`Estimate`] per `1 + mc` consecutive output rows: a plain pass (the pose and its
/// predicted error scale) then `mc` MC-dropout passes (their spread), weighed as they are.
pub fn estimates(coding: &PoseCoding, rows: &[Vec<f32>], mc: usize) -> Vec<Estimate> {
    rows.chunks(1 + mc)
        .map(|group| {
            ImageOutputs {
                views: group[..1].to_vec(),
                mc: group[1..].to_vec(),
            }
            .estimate(coding, &SigmaWeights::UNIT, None)
        })
        .collect()
}

/// Mean pose of samples, `sqrt(trace Σ_pos)` and the RMS rotation angle to the mean (degrees).
pub fn mean_pose(poses: &[Pose]) -> (Pose, f64, f64) {
    let Some(first) = poses.first() else {
        return (Pose::identity(), 0.0, 0.0);
    };
    let n = poses.len() as f64;
    let mean_t = poses
        .iter()
        .fold(Vector3::zeros(), |acc, p| acc + p.translation)
        / n;
    let q0 = first.rotation.into_inner();
    let sum = poses
        .iter()
        .fold(Quaternion::new(0.0, 0.0, 0.0, 0.0), |acc, p| {
            let q = p.rotation.into_inner();
            if q.dot(&q0) < 0.0 { acc - q } else { acc + q }
        });
    let mut q = UnitQuaternion::from_quaternion(sum);
    if q.w < 0.0 {
        q = UnitQuaternion::from_quaternion(-q.into_inner());
    }
    let mean = Pose::new(q, mean_t);
    let var_pos = poses
        .iter()
        .map(|p| (p.translation - mean_t).norm_squared())
        .sum::<f64>()
        / n;
    let var_rot = poses
        .iter()
        .map(|p| geom::metrics::rotation_error_deg(&mean, p).powi(2))
        .sum::<f64>()
        / n;
    (mean, var_pos.sqrt(), var_rot.sqrt())
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn scale_outputs_add_their_variance() {
        let coding = PoseCoding {
            task: Task::Pose3,
            pos_mean: vec![0.0, 0.0],
            pos_std: vec![1.0, 1.0],
            mount: geom::Mount::Ceiling,
            z: 2.5,
        };
        // One pass, s = ln 0.5: E‖e‖² = d(d + 1)·b² = 6 · 0.25 in the plane.
        let row = vec![1.0, 2.0, 0.0, 1.0, 0.5f32.ln()];
        let est = &estimates(&coding, std::slice::from_ref(&row), 0)[0];
        assert!((est.sigma_pos_m - 1.5f64.sqrt()).abs() < 1e-6, "{est:?}");
        assert_eq!(est.sigma_rot_deg, 0.0);
        // The plain pass, then two MC passes 2 m apart: MC variance 1 m² on top of the plain
        // pass's scale; the pose is the plain pass's.
        let mut moved = row.clone();
        moved[0] = 3.0;
        let est = &estimates(&coding, &[row.clone(), row.clone(), moved], 2)[0];
        assert!((est.sigma_pos_m - 2.5f64.sqrt()).abs() < 1e-6, "{est:?}");
        assert_eq!(est.passes, 2);
        // Without the column, nothing is added but the millimetre floor on x and y.
        let est = &estimates(&coding, &[row[..4].to_vec()], 0)[0];
        assert!((est.sigma_pos_m - 2e-6f64.sqrt()).abs() < 1e-12, "{est:?}");
        assert_eq!(est.cov_pos_m2[(2, 2)], 0.0);
    }

    #[test]
    fn mean_pose_of_spread_samples() -> geom::Result<()> {
        let a = Pose::from_euler_ypr(0.1, 0.0, 0.0, [1.0, 0.0, 0.0])?;
        let b = Pose::from_euler_ypr(-0.1, 0.0, 0.0, [-1.0, 0.0, 0.0])?;
        // The same rotation as b, on the other hemisphere: must not cancel in the mean.
        let mut b2 = b;
        b2.rotation = UnitQuaternion::new_unchecked(-b.rotation.into_inner());
        let (mean, sp, sr) = mean_pose(&[a, b2]);
        assert!(mean.translation.norm() < 1e-12);
        assert!(geom::metrics::rotation_error_deg(&mean, &Pose::identity()) < 1e-9);
        assert!((sp - 1.0).abs() < 1e-12);
        assert!((sr - 0.1f64.to_degrees()).abs() < 1e-9);
        let (one, sp, sr) = mean_pose(&[a]);
        assert_eq!((one.translation, sp, sr), (a.translation, 0.0, 0.0));
        Ok(())
    }
}
