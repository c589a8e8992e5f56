//! Training the LSTM of a sequence model on the frozen features of the folder's single-frame
//! network (see the [module docs](super) for why two stages).
//!
//! Each step takes `batch_size` windows of `window` consecutive frames of one recording,
//! every frame's features drawn from the clean view or one of `jittered_copies` jittered ones
//! and masked by dropout, and minimises the pose loss summed over every frame of the window.
//! After each epoch the validation recordings run whole with the state carried over, as a live
//! stream would; the best epoch by median position error is kept.
//!
//! Determinism and resuming follow [`crate::train`]: the window order, copy choice and masks of
//! epoch `e` come from a ChaCha generator seeded with `seed` on stream `e`, the jittered copies
//! from `seed` alone, so a resumed run continues exactly as an unbroken one.

use std::path::{Path, PathBuf};
use std::time::Instant;

use burn::module::Module;
use burn::optim::{AdamWConfig, GradientsParams, ModuleOptimizer};
use burn::tensor::{Device, Tensor, TensorData};
use geom::Pose;
use rand::seq::SliceRandom;
use rand::{Rng, SeedableRng};
use rand_chacha::ChaCha8Rng;

use super::head::{SeqHead, SeqHeadConfig};
use super::infer::{frames_of, run_outputs};
use super::meta::{SEQ_BPK, SEQ_FORMAT, SEQ_STATE_DIR, SEQ_TOML, SeqConfig, SeqEpoch, SeqMeta};
use crate::checkpoint::{self, DatasetRef, StateFiles};
use crate::config::validation_score;
use crate::dataset::{self, Samples};
use crate::head::PoseCoding;
use crate::infer::{self, Localizer};
use crate::loader;
use crate::loss::pose_loss;
use crate::net::{PoseNet, mc};
use crate::progress::Progress;
use crate::window;
use crate::{LearnError, Result};

/// What [`train_sequence`] computed before its first epoch.
#[derive(Clone, Debug, PartialEq)]
pub struct SeqFeatures {
    /// Training frames.
    pub train: usize,
    /// Validation frames.
    pub val: usize,
    /// Training windows.
    pub windows: usize,
    /// Feature copies per training frame (clean + jittered).
    pub copies: usize,
    /// Seconds spent reading, viewing and running the CNN.
    pub seconds: f64,
}

/// Progress of [`train_sequence`].
pub type SeqEvent = Progress<SeqFeatures, SeqEpoch>;

/// The outcome of [`train_sequence`].
#[derive(Clone, Debug, PartialEq)]
pub struct SeqSummary {
    /// Checkpoint folder.
    pub dir: PathBuf,
    /// Epochs finished.
    pub epochs: usize,
    /// Epoch of the weights in `seq.bpk`.
    pub best_epoch: usize,
    /// Median validation position error of `seq.bpk`, metres.
    pub val_median_pos_m: f64,
    /// Median validation rotation error of `seq.bpk`, degrees.
    pub val_median_rot_deg: f64,
    /// Training windows per epoch.
    pub windows: usize,
    /// Per-epoch metrics.
    pub history: Vec<SeqEpoch>,
}

impl SeqSummary {
    fn of(meta: &SeqMeta, dir: &Path, windows: usize) -> SeqSummary {
        SeqSummary {
            dir: dir.to_path_buf(),
            epochs: meta.epoch,
            best_epoch: meta.best_epoch,
            val_median_pos_m: meta.val_median_pos_m,
            val_median_rot_deg: meta.val_median_rot_deg,
            windows,
            history: meta.history.clone(),
        }
    }
}

/// `(sequence, frame number)` of each sample, from its `seq/frame` name.
fn frame_keys(samples: &Samples, data: &Path) -> Result<Vec<(String, u64)>> {
    (0..samples.len())
        .map(|i| {
            samples
                .frame_key(i)
                .map(|(seq, number)| (seq.to_string(), number))
                .ok_or_else(|| {
                    LearnError::Input(format!(
                        "{}: frame '{}' has no frame number; a sequence model needs \
                         recordings of numbered frames",
                        data.display(),
                        samples.names[i]
                    ))
                })
        })
        .collect()
}

/// The dataset's camera must be the one the single-frame model decodes poses for: its task
/// (6-DoF or 3-DoF) and mount.
fn check_camera(data: &dataset::TrainData, coding: &PoseCoding, path: &Path) -> Result<()> {
    let task = crate::head::Task::for_dof(data.info.dof);
    if task != coding.task || data.info.mount != coding.mount {
        return Err(LearnError::Mismatch {
            path: path.to_path_buf(),
            msg: format!(
                "a {:?} camera with {} degrees of freedom, but the single-frame model localizes a \
                 {:?} camera ({:?})",
                data.info.mount, data.info.dof, coding.mount, coding.task
            ),
        });
    }
    Ok(())
}

/// Median distance the camera moves between consecutive frames of the `runs` of `poses`,
/// metres; `None` when no run has two frames.
fn step_length(poses: &[Pose], runs: &[std::ops::Range<usize>]) -> Option<f64> {
    let mut steps: Vec<f64> = runs
        .iter()
        .flat_map(|run| {
            poses[run.clone()]
                .windows(2)
                .map(|p| (p[1].translation - p[0].translation).norm())
        })
        .collect();
    if steps.is_empty() {
        return None;
    }
    steps.sort_by(f64::total_cmp);
    Some(steps[steps.len() / 2])
}

/// How much longer one set's median step between frames may be than the other's.
pub const MAX_STEP_RATIO: f64 = 3.0;

/// Refuses training recordings whose frames lie much further apart (or much closer) than the
/// validation recordings': an LSTM learns the motion between frames, so one trained on walks at
/// 1 Hz misreads a camera at 10 Hz (on the quick demo's 10 Hz test walk the first LSTM trained
/// on the 1 Hz training walks gave 0.84 m, on 10 Hz walks 0.61 m).
fn check_motion(train: Option<f64>, val: Option<f64>, path: &Path) -> Result<()> {
    let (Some(train), Some(val)) = (train, val) else {
        return Ok(());
    };
    let (lo, hi) = (train.min(val), train.max(val));
    if hi < 1e-3 || hi <= MAX_STEP_RATIO * lo {
        return Ok(());
    }
    Err(LearnError::Input(format!(
        "{}: the training recordings move {train:.3} m between frames (median), the validation \
         recordings {val:.3} m; a sequence model learns the motion between frames, so it must \
         train on recordings at the frame rate it runs at (at most {MAX_STEP_RATIO}x apart): \
         record or render the training walks at the camera's rate, or train the sequence part \
         on such a dataset (`train --seq-data`)",
        path.display()
    )))
}

/// Stream offset of the jittered copies' generators (epochs use streams `1..=epochs`).
const JITTER_STREAM: u64 = 1 << 40;

/// The frozen features of the training views: the clean ones, then `copies` jittered versions.
fn training_features(
    base: &Localizer,
    samples: &Samples,
    copies: usize,
    seed: u64,
) -> Result<(Vec<Vec<f32>>, usize)> {
    let input = [samples.channels, samples.height, samples.width];
    let (clean, width) = infer::feature_rows(base.net(), &samples.inputs, input, base.device())?;
    let mut out = vec![clean];
    for copy in 0..copies {
        let mut rng = ChaCha8Rng::seed_from_u64(seed);
        rng.set_stream(JITTER_STREAM + copy as u64);
        let mut inputs = samples.inputs.clone();
        for view in inputs.chunks_exact_mut(samples.view_len()) {
            loader::jitter_view(
                view,
                samples.channels,
                samples.height,
                samples.width,
                &mut rng,
            );
        }
        out.push(infer::feature_rows(base.net(), &inputs, input, base.device())?.0);
    }
    Ok((out, width))
}

/// Validation of a head: the recordings run whole from a fresh state, no dropout.
struct Validation<'a> {
    net: &'a PoseNet,
    features: Vec<f32>,
    width: usize,
    runs: Vec<std::ops::Range<usize>>,
    poses: &'a [Pose],
    coding: &'a PoseCoding,
}

impl Validation<'_> {
    /// `(median position m, median rotation °, jitter m)`.
    fn measure(&self, head: &SeqHead, device: &Device) -> Result<(f64, f64, f64)> {
        let (mut pos, mut rot) = (Vec::new(), Vec::new());
        let (mut steps, mut pairs) = (0.0, 0usize);
        let mut rng = ChaCha8Rng::seed_from_u64(0);
        for run in &self.runs {
            let f = &self.features[run.start * self.width..run.end * self.width];
            let rows = run_outputs(head, self.net, f, self.width, 0, 0.0, &mut rng, device)?;
            let est = infer::estimates(self.coding, &rows, 0);
            let errors: Vec<f64> = est
                .iter()
                .zip(&self.poses[run.clone()])
                .map(|(e, gt)| geom::metrics::position_error(gt, &e.pose))
                .collect();
            steps += geom::metrics::jitter(&errors) * errors.len().saturating_sub(1) as f64;
            pairs += errors.len().saturating_sub(1);
            rot.extend(
                est.iter()
                    .zip(&self.poses[run.clone()])
                    .map(|(e, gt)| geom::metrics::rotation_error_deg(gt, &e.pose)),
            );
            pos.extend(errors);
        }
        let stats = |v: &[f64]| {
            geom::metrics::Stats::of(v).map_err(|e| {
                LearnError::Diverged(format!("validation errors are not finite ({e})"))
            })
        };
        Ok((
            stats(&pos)?.median,
            stats(&rot)?.median,
            steps / pairs.max(1) as f64,
        ))
    }
}

/// What a fresh run or a checkpoint starts from.
struct Start {
    meta: SeqMeta,
    head: SeqHead,
    optim: ModuleOptimizer,
    stale: usize,
}

fn optimizer(cfg: &SeqConfig) -> ModuleOptimizer {
    AdamWConfig::new()
        .with_epsilon(1e-8)
        .with_weight_decay(cfg.weight_decay as f32)
        .init()
}

fn fresh(
    cfg: &SeqConfig,
    base: &Localizer,
    dataset: DatasetRef,
    head_cfg: SeqHeadConfig,
    dropout: f64,
    device: &Device,
) -> Start {
    let meta = SeqMeta {
        format: SEQ_FORMAT,
        base_weights_hash: base.meta().weights_hash.clone(),
        dataset: Some(dataset),
        head: head_cfg,
        dropout,
        config: cfg.clone(),
        epoch: 0,
        best_epoch: 0,
        val_median_pos_m: f64::INFINITY,
        val_median_rot_deg: f64::INFINITY,
        weights_hash: String::new(),
        state: StateFiles::default(),
        history: Vec::new(),
    };
    Start {
        meta,
        head: head_cfg.init(device, cfg.seed),
        optim: optimizer(cfg),
        stale: 0,
    }
}

fn resume(
    cfg: &SeqConfig,
    base: &Localizer,
    dataset: &DatasetRef,
    head_cfg: SeqHeadConfig,
    device: &Device,
) -> Result<Start> {
    let dir = &cfg.model;
    let meta = SeqMeta::read(dir)?;
    let mismatch = |msg: String| {
        Err(LearnError::Mismatch {
            path: dir.join(SEQ_TOML),
            msg,
        })
    };
    if meta.base_weights_hash != base.meta().weights_hash {
        return mismatch(format!(
            "trained on single-frame weights {}, but model.bpk is now {}",
            meta.base_weights_hash,
            base.meta().weights_hash
        ));
    }
    if let Some(trained) = meta.dataset.as_ref().filter(|d| d.hash != dataset.hash) {
        return mismatch(format!(
            "trained on dataset '{}' ({}), not on the content of {} ({}); train it again \
             without resuming",
            trained.name,
            trained.hash,
            dataset.path.display(),
            dataset.hash
        ));
    }
    if meta.config.resume_key() != cfg.resume_key() || meta.head != head_cfg {
        return mismatch(format!(
            "trained with different settings; checkpoint: {:?}; now: {:?}",
            meta.config.resume_key(),
            cfg.resume_key()
        ));
    }
    let (head, optim) =
        checkpoint::read_state(dir, &meta.state, head_cfg.init(device, 0), optimizer(cfg))?;
    let stale = meta.epoch.saturating_sub(meta.best_epoch);
    let mut meta = meta;
    meta.config.epochs = cfg.epochs;
    meta.config.patience = cfg.patience;
    meta.config.data = cfg.data.clone();
    meta.config.model = cfg.model.clone();
    Ok(Start {
        meta,
        head,
        optim,
        stale,
    })
}

/// Trains the sequence part of the model in `cfg.model` on `cfg.data` (a dataset of the
/// single-frame model's camera, read through its view; its training and validation recordings
/// must move alike between frames) and checkpoints it beside the model after every epoch. With
/// `cfg.resume` it continues from the last epoch there, on the same data.
pub fn train_sequence(cfg: &SeqConfig, progress: &mut dyn FnMut(&SeqEvent)) -> Result<SeqSummary> {
    cfg.validate()?;
    checkpoint::refuse_overwrite(&cfg.model, SEQ_TOML, cfg.resume || cfg.force)?;
    let t0 = Instant::now();
    let base = Localizer::load(&cfg.model)?;
    let base_meta = base.meta().clone();
    let data = dataset::load(
        &cfg.data,
        base.view_spec(),
        base_meta.config.seed,
        base_meta.config.blocks,
    )?;
    check_camera(&data, &base_meta.coding, &cfg.data)?;
    let cuts_path = cfg.data.join(data::native::CUTS_CSV);
    let cuts = if cuts_path.is_file() {
        data::cuts::read(&cuts_path)?
    } else {
        Vec::new()
    };
    let train_keys = frame_keys(&data.train, &cfg.data)?;
    let val_keys = frame_keys(&data.val, &cfg.data)?;
    let windows = window::window_starts(&train_keys, &cuts, cfg.window, cfg.stride);
    if windows.is_empty() {
        return Err(LearnError::Input(format!(
            "{}: no run of {} consecutive training frames (without a gap or cut) to make a window of",
            cfg.data.display(),
            cfg.window
        )));
    }
    let val_runs = window::runs(&val_keys, &cuts);
    check_motion(
        step_length(&data.train.poses, &window::runs(&train_keys, &cuts)),
        step_length(&data.val.poses, &val_runs),
        &cfg.data,
    )?;
    let dataset = DatasetRef {
        name: data.info.name.clone(),
        hash: data.hash.clone(),
        path: cfg.data.clone(),
        train_frames: data.train.len(),
        val_frames: data.val.len(),
    };
    let (copies, width) = training_features(&base, &data.train, cfg.jittered_copies, cfg.seed)?;
    let input = [data.val.channels, data.val.height, data.val.width];
    let (val_features, _) =
        infer::feature_rows(base.net(), &data.val.inputs, input, base.device())?;
    progress(&SeqEvent::Loaded(SeqFeatures {
        train: data.train.len(),
        val: data.val.len(),
        windows: windows.len(),
        copies: copies.len(),
        seconds: t0.elapsed().as_secs_f64(),
    }));
    let coding = base_meta.coding.clone();
    let validation = Validation {
        net: base.net(),
        features: val_features,
        width,
        runs: val_runs,
        poses: &data.val.poses,
        coding: &coding,
    };
    let head_cfg = SeqHeadConfig {
        features: width,
        hidden: cfg.hidden,
        outputs: base_meta.net.head.outputs(base_meta.net.outputs),
    };
    let beta = cfg.beta.unwrap_or(base_meta.config.beta);
    let dropout = cfg.dropout.unwrap_or(base_meta.dropout);
    let device = crate::device::training();
    let plain = crate::device::inference();
    let resuming = cfg.resume && SeqMeta::exists(&cfg.model);
    let Start {
        mut meta,
        mut head,
        mut optim,
        mut stale,
    } = if resuming {
        let start = resume(cfg, &base, &dataset, head_cfg, &device)?;
        progress(&SeqEvent::Resumed {
            epoch: start.meta.epoch,
        });
        start
    } else {
        fresh(cfg, &base, dataset, head_cfg, dropout, &device)
    };
    let targets: Vec<Vec<f32>> = data.train.poses.iter().map(|p| coding.target(p)).collect();
    let (k, t_width, o) = (cfg.window, targets[0].len(), head_cfg.outputs);
    let batch = cfg.batch_size.min(windows.len());
    let steps = windows.len() / batch;
    let total_steps = steps * cfg.epochs;
    while meta.epoch < cfg.epochs && !stop_early(cfg, stale, meta.epoch) {
        let epoch = meta.epoch + 1;
        let t_epoch = Instant::now();
        let mut rng = ChaCha8Rng::seed_from_u64(cfg.seed);
        rng.set_stream(epoch as u64);
        let mut order = windows.clone();
        order.shuffle(&mut rng);
        let mut loss_sum = 0.0;
        for step in 0..steps {
            let mut x = Vec::with_capacity(batch * k * width);
            let mut y = Vec::with_capacity(batch * k * t_width);
            for &start in &order[step * batch..(step + 1) * batch] {
                for i in start..start + k {
                    let copy = &copies[rng.random_range(0..copies.len())];
                    x.extend_from_slice(&copy[i * width..(i + 1) * width]);
                    y.extend_from_slice(&targets[i]);
                }
            }
            if dropout > 0.0 {
                let mask = mc::dropout_mask(batch * k, width, dropout, &mut rng);
                x.iter_mut().zip(&mask).for_each(|(v, m)| *v *= m);
            }
            let (frames, frame_width) = frames_of(base.net(), &x, width, &plain)?;
            let x =
                Tensor::<3>::from_data(TensorData::new(frames, [batch, k, frame_width]), &device);
            let y = Tensor::<2>::from_data(TensorData::new(y, [batch * k, t_width]), &device);
            let (out, _) = head.forward(x, None);
            let parts = pose_loss(&coding, out.reshape([batch * k, o]), y, beta, None);
            let grads = GradientsParams::from_grads(parts.total.backward(), &head);
            let loss = parts.total.into_scalar::<f32>() as f64;
            if !loss.is_finite() {
                return Err(LearnError::Diverged(format!(
                    "sequence loss {loss} at epoch {epoch}, step {}; try a lower learning rate",
                    step + 1
                )));
            }
            let lr = cfg
                .schedule
                .lr(cfg.lr, (epoch - 1) * steps + step, total_steps, steps);
            head = optim.step(lr, head.clone(), grads);
            loss_sum += loss;
            progress(&SeqEvent::Step {
                epoch,
                step: step + 1,
                steps,
                loss,
            });
        }
        let valid = head.valid();
        let (med_pos, med_rot, jitter) = validation.measure(&valid, &plain)?;
        let metrics = SeqEpoch {
            epoch,
            train_loss: loss_sum / steps.max(1) as f64,
            val_median_pos_m: med_pos,
            val_median_rot_deg: med_rot,
            val_jitter_m: jitter,
            seconds: t_epoch.elapsed().as_secs_f64(),
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
        save_epoch(
            &cfg.model,
            &mut meta,
            &head,
            &optim,
            improved.then_some(valid),
        )?;
        progress(&SeqEvent::Epoch(metrics));
        if stop_early(cfg, stale, epoch) && epoch < cfg.epochs {
            progress(&SeqEvent::EarlyStop {
                epoch,
                best_epoch: meta.best_epoch,
            });
        }
    }
    Ok(SeqSummary::of(&meta, &cfg.model, windows.len()))
}

/// Whether `stale` epochs without improvement end the run.
fn stop_early(cfg: &SeqConfig, stale: usize, epoch: usize) -> bool {
    epoch > 0 && cfg.patience.is_some_and(|p| stale >= p)
}

/// Writes the checkpoint of a finished epoch: state files, `seq.bpk` when `best` is given,
/// then `seq.toml`, then removes the previous state files.
fn save_epoch(
    dir: &Path,
    meta: &mut SeqMeta,
    head: &SeqHead,
    optim: &ModuleOptimizer,
    best: Option<SeqHead>,
) -> Result<()> {
    meta.state = checkpoint::write_state(dir, SEQ_STATE_DIR, meta.epoch, head.clone(), optim)?;
    if let Some(best) = best {
        let bytes = checkpoint::weights_bytes(best, &dir.join(SEQ_BPK))?;
        meta.weights_hash = checkpoint::write_file(dir, SEQ_BPK, &bytes)?;
    }
    meta.write(dir)?;
    checkpoint::prune_state(dir, &meta.state);
    Ok(())
}

#[cfg(test)]
mod tests {
    use super::*;

    /// Poses along the x axis, `step` metres apart.
    fn walk(n: usize, step: f64) -> Vec<Pose> {
        (0..n)
            .map(|i| Pose::from_euler_ypr(0.0, 0.0, 0.0, [i as f64 * step, 0.0, 1.5]).unwrap())
            .collect()
    }

    #[test]
    fn recordings_at_another_rate_than_the_validation_ones_are_refused() {
        // two runs of a walk at 1.2 m a frame (1 Hz), broken between them
        let slow = step_length(&walk(10, 1.2), &[0..4, 4..10]);
        let fast = step_length(&walk(10, 0.12), std::slice::from_ref(&(0..10)));
        assert_eq!(slow.map(|s| (s * 1e6).round()), Some(1.2e6));
        let err = check_motion(slow, fast, Path::new("walks")).unwrap_err();
        let msg = err.to_string();
        assert!(
            msg.contains("walks") && msg.contains("1.200 m") && msg.contains("0.120 m"),
            "{msg}"
        );
        assert!(check_motion(fast, slow, Path::new("walks")).is_err());
        // the same rate, a little faster or slower, a camera standing still, one-frame runs
        assert!(check_motion(fast, fast.map(|s| 2.5 * s), Path::new("walks")).is_ok());
        assert!(check_motion(Some(0.0), Some(1e-4), Path::new("walks")).is_ok());
        assert_eq!(step_length(&walk(3, 1.0), &[0..1, 1..2, 2..3]), None);
        assert!(check_motion(None, fast, Path::new("walks")).is_ok());
    }
}
