//! Sequence-model inference: whole recordings at once, or live frame by frame.
//!
//! The pose is the plain stream's, as the single-frame model's is its plain pass: the LSTM over
//! the unmasked features. Monte-Carlo dropout adds `N` more streams side by side (the LSTM's
//! batch), each frame's features masked by its own Bernoulli mask per stream, each stream
//! carrying its own state; their spread and the plain stream's predicted error scale make the
//! frame's sigma ([`crate::infer::estimates`]). The mean of the `N` masked streams was the pose
//! before: every masked stream drifts from the features the LSTM trusts, and their mean was
//! measurably worse than the plain stream.

use std::ops::Range;
use std::path::Path;

use burn::tensor::{Device, Tensor, TensorData};
use imgproc::view::View;
use rand::SeedableRng;
use rand_chacha::ChaCha8Rng;

use super::head::SeqHead;
use super::meta::{SEQ_BPK, SEQ_TOML, SeqMeta};
use super::stream::SeqStream;
use crate::checkpoint;
use crate::infer::{self, Estimate, Localizer};
use crate::net::{PoseNet, mc};
use crate::{LearnError, Result};

/// A loaded sequence model: the single-frame model of the folder and the LSTM on its features.
#[derive(Debug)]
pub struct SeqLocalizer {
    base: Localizer,
    head: SeqHead,
    /// The head's weights for live steps, copied once.
    stream: SeqStream,
    meta: SeqMeta,
}

impl SeqLocalizer {
    /// Loads the checkpoint folder `dir` (`model.toml`, `model.bpk`, `seq.toml`, `seq.bpk`) on
    /// the CPU. A sequence part trained on other single-frame weights is refused by name.
    pub fn load(dir: &Path) -> Result<SeqLocalizer> {
        let base = Localizer::load(dir)?;
        let meta = SeqMeta::read(dir)?;
        let mismatch = |msg: String| LearnError::Mismatch {
            path: dir.join(SEQ_TOML),
            msg,
        };
        if meta.base_weights_hash != base.meta().weights_hash {
            return Err(mismatch(format!(
                "trained on single-frame weights {}, but model.bpk is {} (retrained since?); \
                 train the sequence part again with `train --window`",
                meta.base_weights_hash,
                base.meta().weights_hash
            )));
        }
        let net = &base.meta().net;
        let features = net.arch.features() * if net.split { 2 } else { 1 };
        let outputs = net.head.outputs(net.outputs);
        if (meta.head.features, meta.head.outputs) != (features, outputs) {
            return Err(mismatch(format!(
                "head takes {} features to {} outputs; the network gives {features} and needs {outputs}",
                meta.head.features, meta.head.outputs
            )));
        }
        let bytes = checkpoint::read_checked(dir, SEQ_BPK, &meta.weights_hash)?;
        let head =
            checkpoint::load_into(meta.head.init(base.device(), 0), bytes, &dir.join(SEQ_BPK))?;
        let stream = head.stream()?;
        Ok(SeqLocalizer {
            base,
            head,
            stream,
            meta,
        })
    }

    /// The single-frame model whose features the LSTM reads (its view, its own estimates).
    pub fn base(&self) -> &Localizer {
        &self.base
    }

    /// The sequence part's description.
    pub fn meta(&self) -> &SeqMeta {
        &self.meta
    }

    /// The MC-dropout streams of `mc_passes` beside the plain one: none for fewer than two or
    /// a model without dropout.
    fn mc_streams(&self, mc_passes: usize) -> usize {
        if mc_passes > 1 && self.meta.dropout > 0.0 {
            mc_passes
        } else {
            0
        }
    }

    /// Poses of the views of one unbroken recording (no cut, no gap), in order, the state
    /// carried from frame to frame from a fresh start: the same as [`SeqTracker::step`] on each
    /// view after a reset, but the CNN runs in batches. `mc_passes` > 1 adds MC-dropout
    /// uncertainty.
    pub fn predict_run(&self, views: &[View], mc_passes: usize) -> Result<Vec<Estimate>> {
        if views.is_empty() {
            return Ok(Vec::new());
        }
        let inputs = self.base.pack(views)?;
        let (features, width) = infer::feature_rows(
            self.base.net(),
            &inputs,
            self.base.meta().input,
            self.device(),
        )?;
        let mut rng = ChaCha8Rng::seed_from_u64(self.base.seed());
        let mc = self.mc_streams(mc_passes);
        let rows = run_outputs(
            &self.head,
            self.base.net(),
            &features,
            width,
            mc,
            self.meta.dropout,
            &mut rng,
            self.device(),
        )?;
        Ok(infer::estimates(&self.base.meta().coding, &rows, mc))
    }

    /// Poses of `views` made of several recordings: each range of `runs` (in order, covering
    /// the views) starts from a fresh state ([`crate::window::runs`] finds them).
    pub fn predict_runs(
        &self,
        views: &[View],
        runs: &[Range<usize>],
        mc_passes: usize,
    ) -> Result<Vec<Estimate>> {
        let mut out = Vec::with_capacity(views.len());
        for run in runs {
            let part = views.get(run.clone()).ok_or_else(|| {
                LearnError::Input(format!("run {run:?} outside the {} views", views.len()))
            })?;
            out.extend(self.predict_run(part, mc_passes)?);
        }
        Ok(out)
    }

    /// A live stream: one frame at a time, the LSTM state carried over until
    /// [`SeqTracker::reset`].
    pub fn tracker(&self, mc_passes: usize) -> SeqTracker<'_> {
        SeqTracker {
            loc: self,
            stream: self.stream.clone(),
            mc: self.mc_streams(mc_passes),
            p: self.meta.dropout,
            rng: ChaCha8Rng::seed_from_u64(self.base.seed()),
        }
    }

    /// The same localizer with another seed for the MC dropout masks.
    pub fn with_seed(mut self, seed: u64) -> SeqLocalizer {
        self.base = self.base.with_seed(seed);
        self
    }

    fn device(&self) -> &Device {
        self.base.device()
    }
}

/// A live stream through a [`SeqLocalizer`] (see [`SeqLocalizer::tracker`]).
#[derive(Debug)]
pub struct SeqTracker<'a> {
    loc: &'a SeqLocalizer,
    stream: SeqStream,
    /// MC-dropout streams beside the plain one.
    mc: usize,
    p: f64,
    rng: ChaCha8Rng,
}

impl SeqTracker<'_> {
    /// The pose of the next frame of the stream.
    pub fn step(&mut self, view: &View) -> Result<Estimate> {
        let base = &self.loc.base;
        let inputs = base.pack(std::slice::from_ref(view))?;
        let device = self.loc.device();
        let (features, f) = infer::feature_rows(base.net(), &inputs, base.meta().input, device)?;
        let n = 1 + self.mc;
        let mut x = Vec::with_capacity(n * f);
        for _ in 0..n {
            x.extend_from_slice(&features);
        }
        if self.mc > 0 {
            let mask = mc::dropout_mask(self.mc, f, self.p, &mut self.rng);
            x[f..].iter_mut().zip(&mask).for_each(|(v, m)| *v *= m);
        }
        let (frames, _) = frames_of(base.net(), &x, f, device)?;
        let out = self.stream.step(&frames, n)?;
        let rows: Vec<Vec<f32>> = out
            .chunks_exact(self.stream.outputs())
            .map(<[f32]>::to_vec)
            .collect();
        infer::estimates(&base.meta().coding, &rows, self.mc)
            .pop()
            .ok_or_else(|| LearnError::Input("no estimate for the frame".into()))
    }

    /// Forgets the history (a scene cut, a new recording): the next frame starts afresh, with
    /// the masks of a fresh tracker.
    pub fn reset(&mut self) {
        self.stream.reset();
        self.rng = ChaCha8Rng::seed_from_u64(self.loc.base.seed());
    }

    /// Whether the stream carries history.
    pub fn has_history(&self) -> bool {
        self.stream.has_history()
    }
}

/// Each row of `features` (`n · width` values) followed by the single-frame head's plain
/// outputs for it: the frames the LSTM reads ([`SeqHead::forward`]), and their width.
pub(super) fn frames_of(
    net: &PoseNet,
    features: &[f32],
    width: usize,
    device: &Device,
) -> Result<(Vec<f32>, usize)> {
    let n = features.len() / width.max(1);
    let mut frames = Vec::new();
    let mut frame_width = width;
    for start in (0..n).step_by(infer::CHUNK) {
        let b = infer::CHUNK.min(n - start);
        let part = &features[start * width..(start + b) * width];
        let x = Tensor::<2>::from_data(TensorData::new(part.to_vec(), [b, width]), device);
        let single = infer::rows_of(net.head_plain(x))?;
        for (row, out) in part.chunks_exact(width).zip(&single) {
            frames.extend_from_slice(row);
            frames.extend_from_slice(out);
            frame_width = width + out.len();
        }
    }
    Ok((frames, frame_width))
}

/// Outputs of the head over one run of `T` frames' features (`T · width` values): the plain
/// stream and `mc` streams whose every frame's features are masked with probability `p`
/// (the single-frame outputs each stream reads are the head's on its masked features); rows
/// frame-major (`T · (1 + mc)` rows, frame `t`'s plain row then its MC rows), as
/// [`infer::estimates`] takes them.
#[allow(clippy::too_many_arguments)]
pub(super) fn run_outputs(
    head: &SeqHead,
    net: &PoseNet,
    features: &[f32],
    width: usize,
    mc: usize,
    p: f64,
    rng: &mut ChaCha8Rng,
    device: &Device,
) -> Result<Vec<Vec<f32>>> {
    let t = features.len() / width.max(1);
    if t == 0 {
        return Ok(Vec::new());
    }
    let streams = 1 + mc;
    let mut x = Vec::with_capacity(streams * features.len());
    for _ in 0..streams {
        x.extend_from_slice(features);
    }
    if mc > 0 {
        // frame-major draws, as a tracker draws them frame after frame
        let mask = mc::dropout_mask(t * mc, width, p, rng);
        for frame in 0..t {
            for pass in 0..mc {
                let m = &mask[(frame * mc + pass) * width..][..width];
                let row = &mut x[((1 + pass) * t + frame) * width..][..width];
                row.iter_mut().zip(m).for_each(|(v, m)| *v *= m);
            }
        }
    }
    let (frames, frame_width) = frames_of(net, &x, width, device)?;
    let x = Tensor::<3>::from_data(TensorData::new(frames, [streams, t, frame_width]), device);
    let (out, _) = head.forward(x, None);
    let [_, _, o] = out.dims();
    // [streams, T, O] -> [T, streams, O]
    let out = out.swap_dims(0, 1).reshape([t * streams, o]);
    infer::rows_of(out)
}
