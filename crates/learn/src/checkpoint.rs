//! Checkpoints: a folder per model.
//!
//! ```text
//! MODEL/
//!   model.toml                  ModelMeta: network, view, pose coding, dataset, config, metrics
//!   model.bpk                   weights of the best epoch (what `Localizer` loads)
//!   state/weights-NNNN.bpk      weights after the last finished epoch NNNN (for resuming)
//!   state/optimizer-NNNN.bpk    optimizer state after epoch NNNN
//! ```
//!
//! Every file is written atomically (temporary file beside it, then rename). `model.toml` is
//! written last and names the state files by epoch and the content hash of each weights file, so
//! a run killed at any moment leaves either the previous checkpoint or the new one, and a file
//! that does not belong to its `model.toml` (a torn copy, a manual edit) is refused by name
//! instead of being loaded.

use std::path::{Path, PathBuf};

use burn::module::Module;
use burn::optim::ModuleOptimizer;
use burn::store::ModuleRecord;
use burn::tensor::Bytes;
use geom::uncertainty::Calibration;
use serde::{Deserialize, Serialize};

use crate::config::TrainConfig;
use crate::hash::Fnv64;
use crate::head::PoseCoding;
use crate::net::{NetConfig, PoseNet};
use crate::sigma::{SigmaWeights, UncertaintyCalibration};
use crate::{LearnError, Result};

/// File name of the checkpoint description.
pub const MODEL_TOML: &str = "model.toml";
/// File name of the best weights.
pub const MODEL_BPK: &str = "model.bpk";
/// Folder of the resume state.
pub const STATE_DIR: &str = "state";
/// The largest view side a network takes, pixels (ResNets take 224 or 256): a hand-edited
/// `model.toml` or a `--view` of 32768x32768 asked for gigabytes before any weight was read.
pub const MAX_INPUT_SIDE: u32 = 2048;
/// The widest hidden layer of a head: `hidden = 1000000000` in a `model.toml` allocated
/// gigabytes before its weights were compared with `model.bpk`.
pub const MAX_HIDDEN: usize = 16384;

/// Refuses a view with a resize or crop side past [`MAX_INPUT_SIDE`] and a hidden layer past
/// [`MAX_HIDDEN`], before anything is allocated for them.
pub(crate) fn check_bounds(
    spec: &imgproc::view::ViewSpec,
    hidden: usize,
) -> std::result::Result<(), String> {
    use imgproc::view::Op;
    for op in &spec.ops {
        if let Op::Resize { width, height }
        | Op::CenterCrop { width, height }
        | Op::RandomCrop { width, height } = op
            && (*width > MAX_INPUT_SIDE || *height > MAX_INPUT_SIDE)
        {
            return Err(format!(
                "view '{spec}': {width}x{height} is larger than the {MAX_INPUT_SIDE}x{MAX_INPUT_SIDE} a network takes"
            ));
        }
    }
    if hidden > MAX_HIDDEN {
        return Err(format!(
            "hidden layer of {hidden} units is wider than {MAX_HIDDEN}"
        ));
    }
    Ok(())
}

/// Version of the checkpoint layout written by this crate.
pub const FORMAT: u32 = 2;

/// The dataset a model was trained on.
#[derive(Clone, Debug, PartialEq, Serialize, Deserialize)]
pub struct DatasetRef {
    /// `name` of its `dataset.toml`.
    pub name: String,
    /// Content hash of the metadata and images used (see `dataset::TrainData::hash`).
    pub hash: String,
    /// Where it was read from.
    pub path: PathBuf,
    /// Training frames.
    pub train_frames: usize,
    /// Validation frames.
    pub val_frames: usize,
}

/// The resume state of the last finished epoch (empty before the first).
#[derive(Clone, Debug, Default, PartialEq, Serialize, Deserialize)]
pub struct StateFiles {
    /// Weights file, relative to the checkpoint folder.
    pub weights: String,
    /// Content hash of the weights file.
    pub weights_hash: String,
    /// Optimizer state file, relative to the checkpoint folder.
    pub optimizer: String,
    /// Content hash of the optimizer file.
    pub optimizer_hash: String,
}

/// The content of `model.toml`.
#[derive(Clone, Debug, PartialEq, Serialize, Deserialize)]
pub struct ModelMeta {
    /// Layout version ([`FORMAT`]).
    pub format: u32,
    /// Network to rebuild before loading the weights.
    pub net: NetConfig,
    /// Meaning of the outputs.
    pub coding: PoseCoding,
    /// The input view, as view-spec text (`imgproc::view::ViewSpec`).
    pub view: String,
    /// Input shape `[channels, height, width]`.
    pub input: [usize; 3],
    /// Dropout probability on the pooled features (training and MC inference).
    pub dropout: f64,
    /// The dataset.
    pub dataset: DatasetRef,
    /// The training configuration (resuming checks the new one against it).
    pub config: TrainConfig,
    /// Epochs finished.
    pub epoch: usize,
    /// Epoch whose weights are in `model.bpk` (1-based).
    pub best_epoch: usize,
    /// Median validation position error of `model.bpk`, metres.
    pub val_median_pos_m: f64,
    /// Median validation rotation error of `model.bpk`, degrees.
    pub val_median_rot_deg: f64,
    /// True when early stopping ended training.
    pub stopped_early: bool,
    /// Content hash of `model.bpk`.
    pub weights_hash: String,
    /// Resume state.
    pub state: StateFiles,
    /// Metrics of every finished epoch.
    pub history: Vec<EpochMetrics>,
    /// Weights of the parts of `sigma_pos_m`, fitted on the validation frames after training
    /// ([`crate::calibrate`]); `None` until then, and for models from before (all 1 then).
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub sigma_weights: Option<SigmaWeights>,
    /// What the weighed covariance means as a probability, fitted on the validation frames
    /// with the weights ([`crate::calibrate`]); `None` until then, and for models from before.
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub uncertainty: Option<UncertaintyCalibration>,
}

/// Metrics of one finished epoch.
#[derive(Clone, Debug, PartialEq, Serialize, Deserialize)]
pub struct EpochMetrics {
    /// Epoch number, from 1.
    pub epoch: usize,
    /// Mean training loss.
    pub train_loss: f64,
    /// Mean training position error (metres, with dropout).
    pub train_pos_m: f64,
    /// Learning rate at the epoch's last step.
    pub lr: f64,
    /// Median validation position error, metres.
    pub val_median_pos_m: f64,
    /// Median validation rotation error, degrees.
    pub val_median_rot_deg: f64,
    /// Mean validation position error, metres.
    pub val_mean_pos_m: f64,
    /// Wall time of the epoch (training and validation), seconds.
    pub seconds: f64,
    /// Share of validation cells whose dominant-plane class the plane branch gets right (a
    /// network with a plane branch only).
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub val_plane_accuracy: Option<f64>,
}

impl ModelMeta {
    /// The weights of the parts of `sigma_pos_m` (all 1 before calibration).
    pub fn sigma_weights(&self) -> SigmaWeights {
        self.sigma_weights.unwrap_or(SigmaWeights::UNIT)
    }

    /// Reads and checks `dir/model.toml`.
    pub fn read(dir: &Path) -> Result<ModelMeta> {
        let path = dir.join(MODEL_TOML);
        if !path.is_file() {
            return Err(LearnError::corrupt(
                &path,
                "missing: not a checkpoint folder (no model.toml)",
            ));
        }
        let text = data::io::read_text(&path)?;
        let meta: ModelMeta =
            toml::from_str(&text).map_err(|e| LearnError::corrupt(&path, e.to_string()))?;
        meta.check()
            .map_err(|msg| LearnError::corrupt(&path, msg))?;
        Ok(meta)
    }

    /// Consistency of the fields (a damaged or hand-edited file must not reach the network).
    fn check(&self) -> std::result::Result<(), String> {
        if self.format != FORMAT {
            return Err(format!(
                "layout version {} (this build reads {FORMAT})",
                self.format
            ));
        }
        self.coding.validate()?;
        if self.net.outputs != self.coding.task.outputs() {
            return Err(format!(
                "{} outputs for task {}",
                self.net.outputs, self.coding.task
            ));
        }
        let spec = imgproc::view::ViewSpec::resolve(&self.view).map_err(|e| e.to_string())?;
        if spec.channels() as usize != self.net.channels || self.input[0] != self.net.channels {
            return Err(format!(
                "view '{}' gives {} channels, the network takes {}",
                self.view,
                spec.channels(),
                self.net.channels
            ));
        }
        if self.input.contains(&0) {
            return Err("input shape has a zero".into());
        }
        check_bounds(&spec, self.net.head.hidden)?;
        if self.input[1] > MAX_INPUT_SIDE as usize || self.input[2] > MAX_INPUT_SIDE as usize {
            return Err(format!(
                "input {}x{} is larger than {MAX_INPUT_SIDE}x{MAX_INPUT_SIDE}",
                self.input[2], self.input[1]
            ));
        }
        if !(0.0..1.0).contains(&self.dropout) {
            return Err(format!("dropout {} outside [0, 1)", self.dropout));
        }
        self.sigma_weights
            .as_ref()
            .map_or(Ok(()), SigmaWeights::check)?;
        if let Some(u) = &self.uncertainty {
            u.position.check()?;
            u.rotation.as_ref().map_or(Ok(()), Calibration::check)?;
            u.fused.as_ref().map_or(Ok(()), Calibration::check)?;
        }
        Ok(())
    }

    /// Writes `dir/model.toml` atomically.
    pub fn write(&self, dir: &Path) -> Result<()> {
        let path = dir.join(MODEL_TOML);
        let text = toml::to_string(self).map_err(|e| LearnError::corrupt(&path, e.to_string()))?;
        data::io::write_text_atomic(&path, &text)?;
        Ok(())
    }
}

/// The burnpack bytes of a module's weights (`path`: where they will go, for the error).
pub(crate) fn weights_bytes<M: Module>(module: M, path: &Path) -> Result<Vec<u8>> {
    let bytes = module
        .into_record()
        .into_bytes()
        .map_err(|e| LearnError::corrupt(path, format!("cannot serialise weights: {e}")))?;
    Ok(bytes.to_vec())
}

/// Writes `bytes` atomically to `dir/name` and returns their hash.
pub(crate) fn write_file(dir: &Path, name: &str, bytes: &[u8]) -> Result<String> {
    data::io::write_atomic(&dir.join(name), |w| w.write_all(bytes))?;
    Ok(Fnv64::hex_of(bytes))
}

/// Reads `dir/name`, checking its hash against the one `model.toml` recorded.
pub(crate) fn read_checked(dir: &Path, name: &str, hash: &str) -> Result<Vec<u8>> {
    let path = dir.join(name);
    let bytes = std::fs::read(&path).map_err(|e| LearnError::io(&path, e))?;
    let actual = Fnv64::hex_of(&bytes);
    if actual != hash {
        return Err(LearnError::corrupt(
            &path,
            format!(
                "content hash {actual} differs from {hash} recorded in {MODEL_TOML} \
                 (damaged, or written by an interrupted run)"
            ),
        ));
    }
    Ok(bytes)
}

/// Loads weights into a network built from `config` on `device`.
pub(crate) fn load_weights(
    config: &NetConfig,
    bytes: Vec<u8>,
    device: &burn::tensor::Device,
    path: &Path,
) -> Result<PoseNet> {
    load_into(config.init(device, 0)?, bytes, path)
}

/// `module` with the weights in `bytes` (read from `path`, named in errors).
pub(crate) fn load_into<M: Module>(module: M, bytes: Vec<u8>, path: &Path) -> Result<M> {
    let record = ModuleRecord::from_bytes(Bytes::from_bytes_vec(bytes))
        .map_err(|e| LearnError::corrupt(path, e.to_string()))?;
    module
        .try_load_record(record)
        .map_err(|e| LearnError::corrupt(path, e.to_string()))
}

/// Writes the resume state of epoch `epoch` into `dir/folder` (`weights-NNNN.bpk`,
/// `optimizer-NNNN.bpk`, atomically) and returns their names and hashes.
pub(crate) fn write_state<M: Module>(
    dir: &Path,
    folder: &str,
    epoch: usize,
    module: M,
    optim: &ModuleOptimizer,
) -> Result<StateFiles> {
    let weights_name = format!("{folder}/weights-{epoch:04}.bpk");
    let optimizer_name = format!("{folder}/optimizer-{epoch:04}.bpk");
    let weights = weights_bytes(module, &dir.join(&weights_name))?;
    let opt = optim
        .into_bytes()
        .map_err(|e| LearnError::corrupt(dir.join(&optimizer_name), e.to_string()))?;
    Ok(StateFiles {
        weights_hash: write_file(dir, &weights_name, &weights)?,
        weights: weights_name,
        optimizer_hash: write_file(dir, &optimizer_name, &opt)?,
        optimizer: optimizer_name,
    })
}

/// The module and optimizer of the resume state `state` in `dir`, loaded into `module` (built
/// as the checkpoint's) and `optim` (of the same kind); each file checked against its hash.
pub(crate) fn read_state<M: Module>(
    dir: &Path,
    state: &StateFiles,
    module: M,
    optim: ModuleOptimizer,
) -> Result<(M, ModuleOptimizer)> {
    let weights = read_checked(dir, &state.weights, &state.weights_hash)?;
    let module = load_into(module, weights, &dir.join(&state.weights))?;
    let bytes = read_checked(dir, &state.optimizer, &state.optimizer_hash)?;
    let optim = optim
        .from_bytes(Bytes::from_bytes_vec(bytes))
        .map_err(|e| LearnError::corrupt(dir.join(&state.optimizer), e.to_string()))?;
    Ok((module, optim))
}

/// Removes state files that `keep` does not name from the folder they are in (older epochs,
/// leftovers of a killed run). Failing to remove one is harmless, so errors are ignored.
pub(crate) fn prune_state(dir: &Path, keep: &StateFiles) {
    let Some(folder) = Path::new(&keep.weights).parent() else {
        return;
    };
    let Ok(entries) = std::fs::read_dir(dir.join(folder)) else {
        return;
    };
    for entry in entries.flatten() {
        let name = folder.join(entry.file_name());
        if name != Path::new(&keep.weights) && name != Path::new(&keep.optimizer) {
            let _ = std::fs::remove_file(entry.path());
        }
    }
}

/// Refuses to train into `dir` when it already holds the checkpoint described by `file`
/// (`model.toml`, `seq.toml`, `place.toml`), unless `allowed` (the run resumes it or was told to
/// replace it): the epochs it holds are otherwise lost to a repeated command.
pub(crate) fn refuse_overwrite(dir: &Path, file: &str, allowed: bool) -> Result<()> {
    let path = dir.join(file);
    if allowed || !path.is_file() {
        return Ok(());
    }
    Err(LearnError::Input(format!(
        "{} holds a trained model ({file}): --resume continues it, --force replaces it",
        dir.display()
    )))
}
