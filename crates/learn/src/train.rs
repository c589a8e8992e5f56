//! Training: [`train`] runs epochs over a native dataset, validates after each one, checkpoints
//! (see [`crate::checkpoint`]) and stops early when validation stops improving.
//!
//! Determinism: weights are initialised from `seed`; the order of the training frames and the
//! dropout masks of epoch `e` come from a ChaCha generator seeded with `seed` on stream `e`, and
//! the learning rate is a function of the step number. A resumed run therefore continues exactly
//! where the checkpointed one would have gone, with no generator state to save.

use std::path::{Path, PathBuf};
use std::time::Instant;

use burn::module::Module;
use burn::optim::decay::WeightDecayConfig;
use burn::optim::{AdamConfig, AdamWConfig, GradientsParams, ModuleOptimizer};
use burn::tensor::{Device, Tensor, TensorData};
use imgproc::view::ViewSpec;
use rand::SeedableRng;
use rand::seq::SliceRandom;
use rand_chacha::ChaCha8Rng;

use crate::calibrate::ValidationPasses;
use crate::checkpoint::{
    self, DatasetRef, EpochMetrics, FORMAT, MODEL_BPK, MODEL_TOML, ModelMeta, STATE_DIR, StateFiles,
};
use crate::config::{OptimizerKind, TrainConfig, validation_score};
use crate::dataset::{self, Samples, TrainData};
use crate::head::{PoseCoding, Task};
use crate::infer;
use crate::loader;
use crate::loss::pose_loss;
use crate::net::{HeadConfig, NetConfig, PoseNet};
use crate::planes::{self, PlaneTargets, plane_loss};
use crate::progress::Progress;
use crate::{LearnError, Result};

/// What [`train`] loaded before its first epoch.
#[derive(Clone, Debug, PartialEq)]
pub struct Loaded {
    /// Training frames.
    pub train: usize,
    /// Validation frames.
    pub val: usize,
    /// Input shape `[C, H, W]`.
    pub input: [usize; 3],
    /// Seconds spent reading and viewing images.
    pub seconds: f64,
}

/// Progress of [`train`], for progress bars and logs.
pub type TrainEvent = Progress<Loaded, EpochMetrics>;

/// The outcome of [`train`].
#[derive(Clone, Debug, PartialEq)]
pub struct TrainSummary {
    /// Checkpoint folder.
    pub out: PathBuf,
    /// Epochs finished (over all resumed runs).
    pub epochs: usize,
    /// Epoch of the weights in `model.bpk`.
    pub best_epoch: usize,
    /// Median validation position error of `model.bpk`, metres.
    pub val_median_pos_m: f64,
    /// Median validation rotation error of `model.bpk`, degrees.
    pub val_median_rot_deg: f64,
    /// True when early stopping ended the run.
    pub stopped_early: bool,
    /// Training frames.
    pub train_frames: usize,
    /// Validation frames.
    pub val_frames: usize,
    /// Per-epoch metrics (over all resumed runs).
    pub history: Vec<EpochMetrics>,
    /// The validation frames through the calibrated model, when this run calibrated it
    /// (`None` when the model was calibrated before, or had too few validation frames).
    pub validation: Option<ValidationPasses>,
}

impl TrainSummary {
    fn of(meta: &ModelMeta, out: &Path, validation: Option<ValidationPasses>) -> TrainSummary {
        TrainSummary {
            out: out.to_path_buf(),
            epochs: meta.epoch,
            best_epoch: meta.best_epoch,
            val_median_pos_m: meta.val_median_pos_m,
            val_median_rot_deg: meta.val_median_rot_deg,
            stopped_early: meta.stopped_early,
            train_frames: meta.dataset.train_frames,
            val_frames: meta.dataset.val_frames,
            history: meta.history.clone(),
            validation,
        }
    }
}

/// The optimizer a config asks for. Epsilon is PyTorch's 1e-8 (burn's default is 1e-5), so
/// that runs compare with the PyTorch peer.
fn optimizer(cfg: &TrainConfig) -> ModuleOptimizer {
    match cfg.optimizer {
        OptimizerKind::AdamW => AdamWConfig::new()
            .with_epsilon(1e-8)
            .with_weight_decay(cfg.weight_decay as f32)
            .init(),
        OptimizerKind::Amsgrad => AdamConfig::new()
            .with_epsilon(1e-8)
            .with_amsgrad(true)
            .with_weight_decay(
                (cfg.weight_decay > 0.0).then(|| WeightDecayConfig::new(cfg.weight_decay as f32)),
            )
            .init(),
    }
}

/// Median and mean errors of a network on samples: `(median pos m, median rot deg, mean pos m)`.
pub fn evaluate(
    net: &PoseNet,
    coding: &PoseCoding,
    samples: &Samples,
    device: &Device,
) -> Result<(f64, f64, f64)> {
    let input = [samples.channels, samples.height, samples.width];
    let outputs = infer::image_outputs(net, &samples.inputs, input, infer::Passes::PLAIN, device)?;
    let poses: Vec<_> = outputs.iter().map(|o| o.parts(coding).0).collect();
    let pos: Vec<f64> = poses
        .iter()
        .zip(&samples.poses)
        .map(|(e, gt)| geom::metrics::position_error(gt, e))
        .collect();
    let rot: Vec<f64> = poses
        .iter()
        .zip(&samples.poses)
        .map(|(e, gt)| geom::metrics::rotation_error_deg(gt, e))
        .collect();
    let stats = |v: &[f64]| {
        geom::metrics::Stats::of(v)
            .map_err(|e| LearnError::Diverged(format!("validation errors are not finite ({e})")))
    };
    let (p, r) = (stats(&pos)?, stats(&rot)?);
    Ok((p.median, r.median, p.mean))
}

/// What a fresh run or a checkpoint starts from.
struct Start {
    meta: ModelMeta,
    net: PoseNet,
    optim: ModuleOptimizer,
    /// Epochs since the best one (for early stopping), from the history.
    stale: usize,
}

/// A new run: fresh network, empty history.
fn fresh(cfg: &TrainConfig, data: &TrainData, spec: &ViewSpec, device: &Device) -> Result<Start> {
    let task = cfg.task.unwrap_or(Task::for_dof(data.info.dof));
    let coding = PoseCoding::fit(task, data.info.mount, &data.train.poses)?;
    let net_cfg = NetConfig {
        arch: cfg.arch,
        channels: data.train.channels,
        outputs: task.outputs(),
        learned_weighting: cfg.learned_weighting,
        head: HeadConfig {
            hidden: cfg.hidden,
            aleatoric: cfg.aleatoric,
        },
        split: cfg.split,
        planes: cfg.planes,
    };
    let mut net = net_cfg.init(device, cfg.seed)?;
    if let Some(weights) = crate::pretrained::weights_for(cfg.arch) {
        net = net.load_pretrained(&crate::pretrained::locate(&weights)?, device)?;
    }
    let meta = ModelMeta {
        format: FORMAT,
        net: net_cfg,
        coding,
        view: spec.to_string(),
        input: [data.train.channels, data.train.height, data.train.width],
        dropout: cfg.dropout,
        dataset: DatasetRef {
            name: data.info.name.clone(),
            hash: data.hash.clone(),
            path: cfg.data.clone(),
            train_frames: data.train.len(),
            val_frames: data.val.len(),
        },
        config: cfg.clone(),
        epoch: 0,
        best_epoch: 0,
        val_median_pos_m: f64::INFINITY,
        val_median_rot_deg: f64::INFINITY,
        stopped_early: false,
        weights_hash: String::new(),
        state: StateFiles::default(),
        history: Vec::new(),
        sigma_weights: None,
        uncertainty: None,
    };
    Ok(Start {
        meta,
        net,
        optim: optimizer(cfg),
        stale: 0,
    })
}

/// Continues from the checkpoint in `cfg.out`, after checking that it was made with the same
/// data, view and settings.
fn resume(cfg: &TrainConfig, data: &TrainData, spec: &ViewSpec, device: &Device) -> Result<Start> {
    let dir = &cfg.out;
    let toml = dir.join(MODEL_TOML);
    let meta = ModelMeta::read(dir)?;
    let mismatch = |msg: String| {
        Err(LearnError::Mismatch {
            path: toml.clone(),
            msg,
        })
    };
    if meta.dataset.hash != data.hash {
        return mismatch(format!(
            "trained on dataset '{}' ({}), not on the content of {} ({})",
            meta.dataset.name,
            meta.dataset.hash,
            cfg.data.display(),
            data.hash
        ));
    }
    if meta.view != spec.to_string() {
        return mismatch(format!("view '{}', not '{spec}'", meta.view));
    }
    let (old, new) = (meta.config.resume_key(), cfg.resume_key());
    let task_differs = cfg.task.is_some() && cfg.task != Some(meta.coding.task);
    if task_differs || old != new {
        return mismatch(format!(
            "trained with different settings; checkpoint: {}; now: {}",
            settings_text(&old, meta.coding.task),
            settings_text(&new, cfg.task.unwrap_or(meta.coding.task))
        ));
    }
    let (net, optim) =
        checkpoint::read_state(dir, &meta.state, meta.net.init(device, 0)?, optimizer(cfg))?;
    let stale = meta.epoch.saturating_sub(meta.best_epoch);
    let mut meta = meta;
    meta.config.epochs = cfg.epochs;
    meta.config.patience = cfg.patience;
    meta.config.data = cfg.data.clone();
    Ok(Start {
        meta,
        net,
        optim,
        stale,
    })
}

/// The settings a resume compares, in one line for the error message.
fn settings_text(c: &TrainConfig, task: Task) -> String {
    format!(
        "task {task}, arch {}, batch {}, lr {}, {:?}, {:?}, weight decay {}, beta {}, learned weighting {}, dropout {}, hidden {}, aleatoric {}, split {}, augment {}, seed {}, max steps {:?}, shape bias {}, planes {}",
        c.arch,
        c.batch_size,
        c.lr,
        c.schedule,
        c.optimizer,
        c.weight_decay,
        c.beta,
        c.learned_weighting,
        c.dropout,
        c.hidden,
        c.aleatoric,
        c.split,
        c.augment,
        c.seed,
        c.max_steps_per_epoch,
        c.shape_bias,
        c.planes
    )
}

/// Trains a pose network on the native dataset `cfg.data` and checkpoints it into `cfg.out`
/// after every epoch. With `cfg.resume` and a checkpoint in `cfg.out`, training continues from
/// its last epoch (an error when the checkpoint was made from other data or settings); with
/// `cfg.force` a checkpoint there is replaced, and with neither refused. `progress` sees every
/// step and epoch.
pub fn train(cfg: &TrainConfig, progress: &mut dyn FnMut(&TrainEvent)) -> Result<TrainSummary> {
    cfg.validate()?;
    checkpoint::refuse_overwrite(&cfg.out, MODEL_TOML, cfg.resume || cfg.force)?;
    let t0 = Instant::now();
    let default_view = match (&cfg.view, cfg.task) {
        (Some(_), _) => "",
        (None, _) if cfg.arch.pretrained() => PRETRAINED_VIEW,
        (None, Some(task)) => task.default_view(),
        (None, None) => Task::for_dof(dataset::dof(&cfg.data)?).default_view(),
    };
    let spec = ViewSpec::resolve(cfg.view.as_deref().unwrap_or(default_view))
        .map_err(|e| LearnError::Config(e.to_string()))?;
    checkpoint::check_bounds(&spec, cfg.hidden).map_err(LearnError::Config)?;
    let mut data = dataset::load(&cfg.data, &spec, cfg.seed, cfg.blocks)?;
    let planes = if cfg.planes {
        let (train_planes, val_planes, files_hash) = plane_targets(cfg, &data)?;
        data.hash = format!("{}-planes{files_hash:016x}", data.hash);
        Some((train_planes, val_planes))
    } else {
        None
    };
    progress(&TrainEvent::Loaded(Loaded {
        train: data.train.len(),
        val: data.val.len(),
        input: [data.train.channels, data.train.height, data.train.width],
        seconds: t0.elapsed().as_secs_f64(),
    }));
    if data.train.len() < 2 {
        return Err(LearnError::Input(format!(
            "{}: {} training frame(s); BatchNorm needs at least 2",
            cfg.data.display(),
            data.train.len()
        )));
    }
    let device = crate::device::training();
    let resuming = cfg.resume && cfg.out.join(MODEL_TOML).is_file();
    let Start {
        mut meta,
        mut net,
        mut optim,
        mut stale,
    } = if resuming {
        let start = resume(cfg, &data, &spec, &device)?;
        progress(&TrainEvent::Resumed {
            epoch: start.meta.epoch,
        });
        start
    } else {
        fresh(cfg, &data, &spec, &device)?
    };
    if meta.stopped_early {
        return Ok(TrainSummary::of(&meta, &cfg.out, None));
    }
    // A frozen backbone's maps are computed once; training and validation read them instead
    // of the views (the views stay for the calibration at the end).
    let cached = frozen_maps(&net, &data)?;
    if cached.is_some() {
        data.train.inputs = Vec::new();
    }
    let (train_set, val_set) = match &cached {
        Some((train, val)) => (train, val),
        None => (&data.train, &data.val),
    };
    let coding = meta.coding.clone();
    let targets: Vec<Vec<f32>> = data.train.poses.iter().map(|p| coding.target(p)).collect();
    let batch_size = cfg.batch_size.min(data.train.len());
    let mut steps = data.train.len() / batch_size;
    if let Some(cap) = cfg.max_steps_per_epoch {
        steps = steps.min(cap);
    }
    let total_steps = steps * cfg.epochs;
    let [c, h, w] = [train_set.channels, train_set.height, train_set.width];
    let outputs = targets[0].len();
    let plain = crate::device::inference();
    while meta.epoch < cfg.epochs {
        let epoch = meta.epoch + 1;
        let t_epoch = Instant::now();
        let mut rng = ChaCha8Rng::seed_from_u64(cfg.seed);
        rng.set_stream(epoch as u64);
        let mut order: Vec<usize> = (0..data.train.len()).collect();
        order.shuffle(&mut rng);
        let (mut loss_sum, mut pos_sum, mut lr) = (0.0, 0.0, cfg.lr);
        let augment = (cfg.augment || cfg.shape_bias).then(|| loader::Augment {
            rng: loader::jitter_rng(cfg.seed, epoch),
            jitter: cfg.augment,
            style: cfg.shape_bias,
            reframe: false,
        });
        std::thread::scope(|scope| -> Result<()> {
            let source = loader::Source {
                samples: train_set,
                targets: &targets,
                planes: planes.as_ref().map(|p| &p.0),
            };
            let batches = loader::spawn(scope, source, order, batch_size, steps, augment);
            for (step, b) in batches.iter().enumerate() {
                let x =
                    Tensor::<4>::from_data(TensorData::new(b.inputs, [b.rows, c, h, w]), &device);
                let y =
                    Tensor::<2>::from_data(TensorData::new(b.targets, [b.rows, outputs]), &device);
                let (out, plane_out) = net.forward_dropout_planes(x, cfg.dropout, &mut rng);
                let parts = pose_loss(&coding, out, y, cfg.beta, net.log_vars());
                let total = match (plane_out, &b.planes) {
                    (Some(p), Some(t)) => {
                        parts.total.clone()
                            + plane_loss(&p, t, &device)
                                .total
                                .mul_scalar(PLANE_LOSS_WEIGHT)
                    }
                    _ => parts.total.clone(),
                };
                let grads = GradientsParams::from_grads(total.backward(), &net);
                let loss: f64 = total.into_scalar::<f32>() as f64;
                if !loss.is_finite() {
                    return Err(LearnError::Diverged(format!(
                        "loss {loss} at epoch {epoch}, step {}; try a lower learning rate",
                        step + 1
                    )));
                }
                let global = (epoch - 1) * steps + step;
                lr = cfg.schedule.lr(cfg.lr, global, total_steps, steps);
                net = optim.step(lr, net.clone(), grads);
                loss_sum += loss;
                pos_sum += parts.pos.into_scalar::<f32>() as f64;
                progress(&TrainEvent::Step {
                    epoch,
                    step: step + 1,
                    steps,
                    loss,
                });
            }
            Ok(())
        })?;
        let valid = net.valid();
        let (med_pos, med_rot, mean_pos) = evaluate(&valid, &coding, val_set, &plain)?;
        let val_plane_accuracy = match &planes {
            Some((_, val_targets)) => Some(plane_accuracy(&valid, &data.val, val_targets, &plain)?),
            None => None,
        };
        let metrics = EpochMetrics {
            epoch,
            train_loss: loss_sum / steps as f64,
            train_pos_m: pos_sum / steps as f64,
            lr,
            val_median_pos_m: med_pos,
            val_median_rot_deg: med_rot,
            val_mean_pos_m: mean_pos,
            seconds: t_epoch.elapsed().as_secs_f64(),
            val_plane_accuracy,
        };
        let improved = meta.best_epoch == 0
            || validation_score(med_pos, med_rot)
                < validation_score(meta.val_median_pos_m, meta.val_median_rot_deg);
        stale = if improved { 0 } else { stale + 1 };
        meta.epoch = epoch;
        meta.history.push(metrics.clone());
        if improved {
            meta.best_epoch = epoch;
            meta.val_median_pos_m = med_pos;
            meta.val_median_rot_deg = med_rot;
        }
        meta.stopped_early = cfg.patience.is_some_and(|p| stale >= p) && epoch < cfg.epochs;
        save_epoch(&cfg.out, &mut meta, &net, &optim, improved.then_some(valid))?;
        progress(&TrainEvent::Epoch(metrics));
        if meta.stopped_early {
            progress(&TrainEvent::EarlyStop {
                epoch,
                best_epoch: meta.best_epoch,
            });
            break;
        }
    }
    let mut validation = None;
    if meta.uncertainty.is_none() && meta.best_epoch > 0 {
        if let Some(fitted) = crate::calibrate::calibrate(&cfg.out, &data.val)? {
            meta.sigma_weights = Some(fitted.weights);
            meta.uncertainty = Some(fitted.calibration);
            validation = Some(fitted.passes);
        }
        meta.write(&cfg.out)?;
    }
    Ok(TrainSummary::of(&meta, &cfg.out, validation))
}

/// The view a pretrained backbone gets by default: 320x240 RGB with ImageNet's statistics
/// (the half-size 640x480 frame; measured in ARCHITECTURE.md, "Real data").
pub const PRETRAINED_VIEW: &str = "rgb320";

/// The frozen layers' maps of the training and validation views (`None` without frozen
/// layers), from the folded network, a chunk at a time.
fn frozen_maps(net: &PoseNet, data: &TrainData) -> Result<Option<(Samples, Samples)>> {
    let plain = crate::device::inference();
    let frozen = net.valid().fold_batchnorm();
    let maps = |samples: &Samples| -> Result<Option<Samples>> {
        let mut inputs = Vec::new();
        let mut dims = [0; 3];
        for start in (0..samples.len()).step_by(infer::CHUNK) {
            let end = (start + infer::CHUNK).min(samples.len());
            let Some(map) = frozen.frozen_maps(samples.batch(start..end, &plain)) else {
                return Ok(None);
            };
            let [_, c, h, w] = map.dims();
            dims = [c, h, w];
            inputs.extend(
                map.into_data()
                    .try_to_vec::<f32>()
                    .map_err(|e| LearnError::Input(format!("{e:?}")))?,
            );
        }
        Ok(Some(Samples {
            channels: dims[0],
            height: dims[1],
            width: dims[2],
            inputs,
            poses: samples.poses.clone(),
            names: samples.names.clone(),
        }))
    };
    Ok(match (maps(&data.train)?, maps(&data.val)?) {
        (Some(train), Some(val)) => Some((train, val)),
        _ => None,
    })
}

/// Weight of the plane loss beside the pose loss (whose position part is in metres).
pub const PLANE_LOSS_WEIGHT: f64 = 1.0;

/// The plane targets of the training and validation frames on the plane branch's grid, and a
/// hash of the files read.
fn plane_targets(cfg: &TrainConfig, data: &TrainData) -> Result<(PlaneTargets, PlaneTargets, u64)> {
    let input = [data.train.channels, data.train.height, data.train.width];
    let grid = crate::net::plane_grid(cfg.arch, input)?;
    let (train, h1) = planes::load(&cfg.data, &data.info.camera, &data.train, grid)?;
    let (val, h2) = planes::load(&cfg.data, &data.info.camera, &data.val, grid)?;
    if train.coverage() == 0.0 {
        return Err(LearnError::Input(format!(
            "{}: no training frame shows a plane that could be fitted; the plane task has nothing to learn",
            cfg.data.display()
        )));
    }
    Ok((train, val, h1 ^ h2.rotate_left(1)))
}

/// Share of `samples`' cells whose plane class the network's plane branch gets right.
fn plane_accuracy(
    net: &PoseNet,
    samples: &Samples,
    targets: &PlaneTargets,
    device: &Device,
) -> Result<f64> {
    let [gh, gw] = targets.grid;
    let cells = gh * gw;
    let (mut right, mut all) = (0.0, 0usize);
    for start in (0..samples.len()).step_by(infer::CHUNK) {
        let end = (start + infer::CHUNK).min(samples.len());
        let Some(out) = net.plane_outputs(samples.batch(start..end, device)) else {
            return Ok(0.0);
        };
        let logits = out
            .classes
            .into_data()
            .try_to_vec::<f32>()
            .map_err(|e| LearnError::Input(format!("{e:?}")))?;
        let classes: Vec<u8> = targets.frames[start..end]
            .iter()
            .flat_map(|f| f.classes.iter().copied())
            .collect();
        right += planes::class_accuracy(&classes, &logits, cells) * classes.len() as f64;
        all += classes.len();
    }
    Ok(right / all.max(1) as f64)
}

/// Writes the checkpoint of a finished epoch: state files, `model.bpk` when `best` is given,
/// then `model.toml`, then removes the previous state files.
fn save_epoch(
    dir: &Path,
    meta: &mut ModelMeta,
    net: &PoseNet,
    optim: &ModuleOptimizer,
    best: Option<PoseNet>,
) -> Result<()> {
    meta.state = checkpoint::write_state(dir, STATE_DIR, meta.epoch, net.clone(), optim)?;
    if let Some(best) = best {
        let bytes = checkpoint::weights_bytes(best, &dir.join(MODEL_BPK))?;
        meta.weights_hash = checkpoint::write_file(dir, MODEL_BPK, &bytes)?;
        // New weights: the uncertainty is calibrated again once training ends.
        meta.sigma_weights = None;
        meta.uncertainty = None;
    }
    meta.write(dir)?;
    checkpoint::prune_state(dir, &meta.state);
    Ok(())
}
