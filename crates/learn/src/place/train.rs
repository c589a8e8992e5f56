//! Training a place classifier (see the [module docs](super)).
//!
//! The split decides what the validation accuracy means. `session` (the default) keeps the
//! dataset's split by sequence: no validation frame has a near-twin among the training frames,
//! as a new visit to the building would not. `random` pools the training and validation
//! frames and draws a fifth of them at random, so neighbours of almost every validation frame,
//! a few centimetres away, are in training: the figure it gives is what a leaky evaluation
//! reports, kept to show the difference (`study place-split`).
//!
//! Determinism and resuming follow [`crate::train`].

use std::collections::HashMap;
use std::path::{Path, PathBuf};
use std::time::Instant;

use burn::module::Module;
use burn::optim::{AdamWConfig, GradientsParams, ModuleOptimizer};
use burn::tensor::activation::log_softmax;
use burn::tensor::{Device, Tensor, TensorData};
use data::native::{Label, NativeDataset};
use imgproc::view::ViewSpec;
use rand::SeedableRng;
use rand::seq::SliceRandom;
use rand_chacha::ChaCha8Rng;

use super::classes::PlaceClasses;
use super::infer::classify;
use super::meta::{
    PLACE_BPK, PLACE_FORMAT, PLACE_STATE_DIR, PLACE_TOML, PlaceConfig, PlaceEpoch, PlaceMeta,
    PlaceSplit,
};
use super::net::{PlaceNet, PlaceNetConfig};
use super::walk::PlaceTransitions;
use crate::checkpoint::{self, DatasetRef, StateFiles};
use crate::config::Schedule;
use crate::dataset::{self, DEFAULT_VAL_FRACTION, Samples};
use crate::loader;
use crate::net::mc;
use crate::progress::Progress;
use crate::{LearnError, Result};

/// What [`train_place`] loaded before its first epoch.
#[derive(Clone, Debug, PartialEq)]
pub struct PlaceLoaded {
    /// Training frames.
    pub train: usize,
    /// Validation frames.
    pub val: usize,
    /// Classes per level.
    pub classes: [usize; 3],
    /// Seconds spent reading and viewing images.
    pub seconds: f64,
}

/// Progress of [`train_place`].
pub type PlaceEvent = Progress<PlaceLoaded, PlaceEpoch>;

/// The outcome of [`train_place`].
#[derive(Clone, Debug, PartialEq)]
pub struct PlaceSummary {
    /// Checkpoint folder.
    pub out: PathBuf,
    /// Epochs finished.
    pub epochs: usize,
    /// Epoch of the weights in `place.bpk`.
    pub best_epoch: usize,
    /// Validation accuracy of `place.bpk` per level.
    pub val_accuracy: [f64; 3],
    /// Training frames.
    pub train_frames: usize,
    /// Validation frames.
    pub val_frames: usize,
    /// Per-epoch metrics.
    pub history: Vec<PlaceEpoch>,
}

impl PlaceSummary {
    fn of(meta: &PlaceMeta, out: &Path) -> PlaceSummary {
        PlaceSummary {
            out: out.to_path_buf(),
            epochs: meta.epoch,
            best_epoch: meta.best_epoch,
            val_accuracy: meta.val_accuracy,
            train_frames: meta.dataset.train_frames,
            val_frames: meta.dataset.val_frames,
            history: meta.history.clone(),
        }
    }
}

/// The labels of `samples` (by their `seq/frame` names) as class indices. Every sample must
/// have a label whose classes are in `classes`.
pub(super) fn sample_targets(
    samples: &Samples,
    labels: &HashMap<u64, Label>,
    classes: &PlaceClasses,
    labels_path: &Path,
) -> Result<Vec<[usize; 3]>> {
    samples
        .names
        .iter()
        .enumerate()
        .map(|(i, name)| {
            let label = samples
                .frame_key(i)
                .and_then(|(_, frame)| labels.get(&frame))
                .ok_or_else(|| {
                    LearnError::Input(format!(
                        "{}: no label for frame {name}",
                        labels_path.display()
                    ))
                })?;
            classes.indices(label).ok_or_else(|| {
                LearnError::Input(format!(
                    "{}: frame {name} has a class the model does not know",
                    labels_path.display()
                ))
            })
        })
        .collect()
}

/// The dataset's labels by frame number, their classes, and the dataset's scene cuts (frame
/// numbers, sorted).
pub(super) fn dataset_labels(root: &Path) -> Result<(HashMap<u64, Label>, PlaceClasses, Vec<u64>)> {
    let ds = NativeDataset::open(root)?;
    let mut cuts = ds.cuts.unwrap_or_default();
    cuts.sort_unstable();
    let labels = ds.labels.ok_or_else(|| {
        LearnError::Input(format!(
            "{}: missing; a place classifier learns from the frames' place labels",
            root.join(data::native::LABELS_CSV).display()
        ))
    })?;
    let classes = PlaceClasses::of(&labels);
    Ok((
        labels.into_iter().map(|l| (l.frame, l)).collect(),
        classes,
        cuts,
    ))
}

/// Accuracy per level of `predicted` class indices against `targets`.
pub fn accuracy(predicted: &[[usize; 3]], targets: &[[usize; 3]]) -> [f64; 3] {
    let mut right = [0usize; 3];
    for (p, t) in predicted.iter().zip(targets) {
        for level in 0..3 {
            right[level] += usize::from(p[level] == t[level]);
        }
    }
    right.map(|r| r as f64 / targets.len().max(1) as f64)
}

/// One-hot rows `[rows, n]` of the class column `level` of packed targets (3 per row).
fn one_hot(targets: &[f32], level: usize, n: usize, device: &Device) -> Tensor<2> {
    let rows = targets.len() / 3;
    let mut v = vec![0.0f32; rows * n];
    for r in 0..rows {
        v[r * n + targets[r * 3 + level] as usize] = 1.0;
    }
    Tensor::from_data(TensorData::new(v, [rows, n]), device)
}

struct Start {
    meta: PlaceMeta,
    net: PlaceNet,
    optim: ModuleOptimizer,
    stale: usize,
}

fn optimizer(cfg: &PlaceConfig) -> ModuleOptimizer {
    AdamWConfig::new()
        .with_epsilon(1e-8)
        .with_weight_decay(cfg.weight_decay as f32)
        .init()
}

/// Trains a place classifier on the labelled native dataset `cfg.data` into `cfg.out`,
/// checkpointing every epoch; with `cfg.resume` it continues from the checkpoint there.
pub fn train_place(
    cfg: &PlaceConfig,
    progress: &mut dyn FnMut(&PlaceEvent),
) -> Result<PlaceSummary> {
    cfg.validate()?;
    crate::checkpoint::refuse_overwrite(&cfg.out, PLACE_TOML, cfg.resume || cfg.force)?;
    let t0 = Instant::now();
    let spec = ViewSpec::resolve(cfg.view.as_deref().unwrap_or("place240"))
        .map_err(|e| LearnError::Config(e.to_string()))?;
    crate::checkpoint::check_bounds(&spec, 0).map_err(LearnError::Config)?;
    let (labels, classes, cuts) = dataset_labels(&cfg.data)?;
    let data = dataset::load(&cfg.data, &spec, cfg.seed, None)?;
    let (train, val) = match cfg.split {
        PlaceSplit::Session => (data.train.clone(), data.val.clone()),
        PlaceSplit::Random => {
            let n = data.train.len() + data.val.len();
            let mut order: Vec<usize> = (0..n).collect();
            order.shuffle(&mut ChaCha8Rng::seed_from_u64(cfg.seed));
            let n_val = ((n as f64 * DEFAULT_VAL_FRACTION).round() as usize).clamp(1, n - 1);
            let (val, train) = order.split_at(n_val);
            (
                data.train.select(&data.val, train),
                data.train.select(&data.val, val),
            )
        }
    };
    let labels_path = cfg.data.join(data::native::LABELS_CSV);
    let train_targets = sample_targets(&train, &labels, &classes, &labels_path)?;
    let val_targets = sample_targets(&val, &labels, &classes, &labels_path)?;
    progress(&PlaceEvent::Loaded(PlaceLoaded {
        train: train.len(),
        val: val.len(),
        classes: classes.sizes(),
        seconds: t0.elapsed().as_secs_f64(),
    }));
    if train.len() < 2 {
        return Err(LearnError::Input(format!(
            "{}: {} training frame(s); BatchNorm needs at least 2",
            cfg.data.display(),
            train.len()
        )));
    }
    let device = crate::device::training();
    let plain = crate::device::inference();
    let input = [train.channels, train.height, train.width];
    let net_cfg = PlaceNetConfig {
        arch: cfg.arch,
        channels: train.channels,
        classes: classes.sizes(),
        grid: cfg.grid,
    };
    let transitions = walk_transitions(
        &train,
        &train_targets,
        &cuts,
        classes.sizes()[2],
        data.info.frame_rate,
    );
    let Start {
        mut meta,
        mut net,
        mut optim,
        mut stale,
    } = if cfg.resume && PlaceMeta::exists(&cfg.out) {
        let start = resume(cfg, &data.hash, &net_cfg, &device)?;
        progress(&PlaceEvent::Resumed {
            epoch: start.meta.epoch,
        });
        start
    } else {
        let meta = PlaceMeta {
            format: PLACE_FORMAT,
            net: net_cfg.clone(),
            classes: classes.clone(),
            view: spec.to_string(),
            input,
            dropout: cfg.dropout,
            dataset: DatasetRef {
                name: data.info.name.clone(),
                hash: data.hash.clone(),
                path: cfg.data.clone(),
                train_frames: train.len(),
                val_frames: val.len(),
            },
            config: cfg.clone(),
            epoch: 0,
            best_epoch: 0,
            val_accuracy: [0.0; 3],
            weights_hash: String::new(),
            state: StateFiles::default(),
            history: Vec::new(),
            transitions: transitions.clone(),
        };
        Start {
            meta,
            net: net_cfg.init(&device, cfg.seed)?,
            optim: optimizer(cfg),
            stale: 0,
        }
    };
    let targets: Vec<Vec<f32>> = train_targets
        .iter()
        .map(|t| t.iter().map(|&c| c as f32).collect())
        .collect();
    let batch = cfg.batch_size.min(train.len());
    let steps = train.len() / batch;
    let total_steps = steps * cfg.epochs;
    let schedule = Schedule::Cosine {
        final_fraction: 0.01,
    };
    let sizes = classes.sizes();
    let tree = classes.tree();
    let [c, h, w] = input;
    while meta.epoch < cfg.epochs && !cfg.patience.is_some_and(|p| meta.epoch > 0 && stale >= p) {
        let epoch = meta.epoch + 1;
        let t_epoch = Instant::now();
        let mut rng = ChaCha8Rng::seed_from_u64(cfg.seed);
        rng.set_stream(epoch as u64);
        let mut order: Vec<usize> = (0..train.len()).collect();
        order.shuffle(&mut rng);
        let augment = (cfg.augment || cfg.shape_bias || cfg.reframe).then(|| loader::Augment {
            rng: loader::jitter_rng(cfg.seed, epoch),
            jitter: cfg.augment,
            style: cfg.shape_bias,
            reframe: cfg.reframe,
        });
        let mut loss_sum = 0.0;
        std::thread::scope(|scope| -> Result<()> {
            let source = loader::Source {
                samples: &train,
                targets: &targets,
                planes: None,
            };
            let batches = loader::spawn(scope, source, order, batch, steps, augment);
            for (step, b) in batches.iter().enumerate() {
                let x =
                    Tensor::<4>::from_data(TensorData::new(b.inputs, [b.rows, c, h, w]), &device);
                let features = net.features(x);
                let [rows, f] = features.dims();
                let features = if cfg.dropout > 0.0 {
                    let mask = mc::dropout_mask(rows, f, cfg.dropout, &mut rng);
                    features * Tensor::<2>::from_data(TensorData::new(mask, [rows, f]), &device)
                } else {
                    features
                };
                let logits = net.logits(features);
                let mut loss: Option<Tensor<1>> = None;
                for (level, logit) in logits.into_iter().enumerate() {
                    let target = one_hot(&b.targets, level, sizes[level], &device);
                    let ce = (log_softmax(logit, 1) * target).sum_dim(1).mean().neg();
                    loss = Some(match loss {
                        Some(l) => l + ce,
                        None => ce,
                    });
                }
                let Some(loss) = loss else {
                    return Err(LearnError::Config("no levels to train".into()));
                };
                let grads = GradientsParams::from_grads(loss.backward(), &net);
                let value = loss.into_scalar::<f32>() as f64;
                if !value.is_finite() {
                    return Err(LearnError::Diverged(format!(
                        "loss {value} at epoch {epoch}, step {}; try a lower learning rate",
                        step + 1
                    )));
                }
                let lr = schedule.lr(cfg.lr, (epoch - 1) * steps + step, total_steps, steps);
                net = optim.step(lr, net.clone(), grads);
                loss_sum += value;
                progress(&PlaceEvent::Step {
                    epoch,
                    step: step + 1,
                    steps,
                    loss: value,
                });
            }
            Ok(())
        })?;
        let valid = net.valid();
        let predicted = classify(&valid, &val.inputs, input, tree.as_deref(), &plain)?;
        let best: Vec<[usize; 3]> = predicted.iter().map(|p| p.map(|(k, _)| k)).collect();
        let val_accuracy = accuracy(&best, &val_targets);
        let metrics = PlaceEpoch {
            epoch,
            train_loss: loss_sum / steps.max(1) as f64,
            val_accuracy,
            seconds: t_epoch.elapsed().as_secs_f64(),
        };
        let mean = |a: &[f64; 3]| a.iter().sum::<f64>() / 3.0;
        let improved = meta.best_epoch == 0 || mean(&val_accuracy) > mean(&meta.val_accuracy);
        stale = if improved { 0 } else { stale + 1 };
        meta.epoch = epoch;
        meta.history.push(metrics.clone());
        if improved {
            meta.best_epoch = epoch;
            meta.val_accuracy = val_accuracy;
        }
        meta.state =
            checkpoint::write_state(&cfg.out, PLACE_STATE_DIR, epoch, net.clone(), &optim)?;
        if improved {
            let bytes = checkpoint::weights_bytes(valid, &cfg.out.join(PLACE_BPK))?;
            meta.weights_hash = checkpoint::write_file(&cfg.out, PLACE_BPK, &bytes)?;
        }
        meta.write(&cfg.out)?;
        checkpoint::prune_state(&cfg.out, &meta.state);
        progress(&PlaceEvent::Epoch(metrics));
        if cfg.patience.is_some_and(|p| stale >= p) && epoch < cfg.epochs {
            progress(&PlaceEvent::EarlyStop {
                epoch,
                best_epoch: meta.best_epoch,
            });
        }
    }
    if meta.transitions.is_none() && transitions.is_some() {
        // A model trained before place filtering, resumed: it gains the motion model of its
        // own training walks.
        meta.transitions = transitions;
        meta.write(&cfg.out)?;
    }
    Ok(PlaceSummary::of(&meta, &cfg.out))
}

/// The place changes between consecutive frames of the training walks (`targets`' place
/// class, frames in order of sequence and number; a missing frame or a scene cut, `cuts`
/// sorted, breaks the chain, as it resets the filter), taken `frame_rate` times a second.
/// `None` without a frame rate.
fn walk_transitions(
    samples: &Samples,
    targets: &[[usize; 3]],
    cuts: &[u64],
    places: usize,
    frame_rate: f64,
) -> Option<PlaceTransitions> {
    if !(frame_rate > 0.0 && frame_rate.is_finite()) {
        return None;
    }
    let mut frames: Vec<(&str, u64, usize)> = (0..samples.len())
        .filter_map(|i| {
            let (seq, frame) = samples.frame_key(i)?;
            Some((seq, frame, targets.get(i)?[2]))
        })
        .collect();
    frames.sort_unstable();
    let chain = frames
        .iter()
        .enumerate()
        .flat_map(|(i, &(seq, frame, place))| {
            let follows = i > 0 && {
                let (s, f, _) = frames[i - 1];
                s == seq && f + 1 == frame && cuts.binary_search(&frame).is_err()
            };
            // A break, then the frame, where it does not follow the one before.
            (!follows).then_some(None).into_iter().chain([Some(place)])
        });
    Some(PlaceTransitions::count(chain, places, 1.0 / frame_rate))
}

/// Continues from the checkpoint in `cfg.out` after checking data and settings.
fn resume(
    cfg: &PlaceConfig,
    data_hash: &str,
    net_cfg: &PlaceNetConfig,
    device: &Device,
) -> Result<Start> {
    let dir = &cfg.out;
    let meta = PlaceMeta::read(dir)?;
    let mismatch = |msg: String| {
        Err(LearnError::Mismatch {
            path: dir.join(PLACE_TOML),
            msg,
        })
    };
    if meta.dataset.hash != data_hash {
        return mismatch(format!(
            "trained on dataset '{}' ({}), not on the content of {} ({data_hash})",
            meta.dataset.name,
            meta.dataset.hash,
            cfg.data.display()
        ));
    }
    if meta.config.resume_key() != cfg.resume_key() || &meta.net != net_cfg {
        return mismatch(format!(
            "trained with different settings; checkpoint: {:?}; now: {:?}",
            meta.config.resume_key(),
            cfg.resume_key()
        ));
    }
    let (net, optim) =
        checkpoint::read_state(dir, &meta.state, net_cfg.init(device, 0)?, optimizer(cfg))?;
    let stale = meta.epoch.saturating_sub(meta.best_epoch);
    let mut meta = meta;
    meta.config.epochs = cfg.epochs;
    meta.config.patience = cfg.patience;
    meta.config.data = cfg.data.clone();
    meta.config.out = cfg.out.clone();
    Ok(Start {
        meta,
        net,
        optim,
        stale,
    })
}
