//! The recurrent part of a sequence model (CNN+LSTM): per-frame CNN features and the
//! single-frame head's outputs in, an LSTM over the frames of a window, a correction to the
//! single-frame outputs per frame out.
//!
//! # Why a correction
//! The LSTM reads each frame's features beside what the single-frame head makes of them, and
//! its output layer adds to those outputs, starting at zero: an untrained sequence model is the
//! single-frame model, and training only has to learn what the history adds (smoothing, the
//! motion since the last frames). An LSTM that had to learn the whole feature-to-pose map
//! again from its own windows, as the first version did, lost to its own backbone: on the
//! quick demo's held-out walk 0.61 m / 4.2° against 0.52 m / 2.6°, even trained on walks at
//! the test walk's frame rate (`indoorloc study sequence --quick`).
//!
//! Training sees windows (`[B, K, F]` features, [`crate::window`] says which frames form one);
//! a live stream steps one frame at a time with the state carried over ([`SeqStream`], the same
//! weights outside burn), and a scene cut calls [`SeqStream::reset`]. Stepping K frames gives the
//! same outputs as the window of those K frames (a test checks it), so what was trained is what
//! runs live.

use burn::module::{Initializer, Module};
use burn::nn::{Linear, LinearConfig, Lstm, LstmConfig, LstmState};
use burn::tensor::{Device, Tensor};
use serde::{Deserialize, Serialize};

use super::stream::{GateWeights, LinearWeights, SeqStream};
use crate::{LearnError, Result};

/// What a [`SeqHead`] is built from. The LSTM reads `features + outputs` values per frame.
#[derive(Clone, Copy, Debug, PartialEq, Eq, Serialize, Deserialize)]
pub struct SeqHeadConfig {
    /// Width of the per-frame features (the backbone's pooled features).
    pub features: usize,
    /// LSTM units (the CNN+LSTM indoor APR work uses 256 or 512).
    pub hidden: usize,
    /// Outputs per frame (the pose coding's, e.g. 7 for 6-DoF).
    pub outputs: usize,
}

impl SeqHeadConfig {
    /// A head with freshly initialised weights on `device`; the same `seed` gives the same
    /// weights.
    pub fn init(&self, device: &Device, seed: u64) -> SeqHead {
        crate::net::seeded_init(device, seed, || SeqHead {
            lstm: LstmConfig::new(self.features + self.outputs, self.hidden, true)
                .with_batch_first(true)
                .init(device),
            out: LinearConfig::new(self.hidden, self.outputs)
                .with_initializer(Initializer::Zeros)
                .init(device),
        })
    }
}

/// LSTM over a window's frames (features and single-frame outputs), then a linear layer per
/// frame whose output corrects the single-frame outputs.
#[derive(Module, Debug)]
pub struct SeqHead {
    lstm: Lstm,
    out: Linear,
}

impl SeqHead {
    /// Outputs `[B, K, O]` of frames `[B, K, F + O]` (each frame's features, then the
    /// single-frame head's `O` outputs for them), starting from `state` (zeros when `None`):
    /// the single-frame outputs plus the LSTM's correction. Also the state after the last frame.
    pub fn forward(
        &self,
        frames: Tensor<3>,
        state: Option<LstmState<2>>,
    ) -> (Tensor<3>, LstmState<2>) {
        let [_, _, width] = frames.dims();
        let [_, outputs] = self.out.weight.dims();
        let single = frames.clone().narrow(2, width - outputs, outputs);
        let (hidden, state) = self.lstm.forward(frames, state);
        (single + self.out.forward(hidden), state)
    }

    /// A live stream through this head ([`SeqStream`]), its weights copied out.
    pub fn stream(&self) -> Result<SeqStream> {
        let gates = [
            Some(&self.lstm.input_gate),
            self.lstm.forget_gate.as_ref(),
            Some(&self.lstm.output_gate),
            Some(&self.lstm.cell_gate),
        ];
        let mut parts = Vec::with_capacity(4);
        for gate in gates {
            let gate = gate.ok_or_else(|| {
                LearnError::Config("the LSTM has no forget gate (coupled gates)".into())
            })?;
            parts.push(GateWeights {
                input: linear_weights(&gate.input_transform)?,
                hidden: linear_weights(&gate.hidden_transform)?,
            });
        }
        SeqStream::new(&parts, linear_weights(&self.out)?)
    }
}

/// Weights `[in, out]` (row-major, as burn stores them) and bias of a linear layer.
fn linear_weights(layer: &Linear) -> Result<LinearWeights> {
    let [rows, cols] = layer.weight.dims();
    let read = |t: Tensor<2>| {
        t.into_data()
            .try_to_vec::<f32>()
            .map_err(|e| LearnError::Input(format!("cannot read the LSTM weights: {e:?}")))
    };
    let bias = match &layer.bias {
        Some(b) => read(b.val().reshape([1, cols]))?,
        None => vec![0.0; cols],
    };
    Ok(LinearWeights {
        rows,
        cols,
        weight: read(layer.weight.val())?,
        bias,
    })
}

#[cfg(test)]
mod tests {
    use super::*;
    use burn::tensor::TensorData;

    fn values<const D: usize>(y: Tensor<D>) -> Result<Vec<f32>> {
        y.into_data()
            .try_to_vec::<f32>()
            .map_err(|e| LearnError::Input(format!("{e:?}")))
    }

    fn features(b: usize, k: usize, f: usize, device: &Device) -> Tensor<3> {
        let v: Vec<f32> = (0..b * k * f)
            .map(|i| ((i * 37 % 101) as f32 / 50.0) - 1.0)
            .collect();
        Tensor::<3>::from_data(TensorData::new(v, [b, k, f]), device)
    }

    /// Stepping frame by frame (outside burn) gives the window's outputs, stream by stream;
    /// after a reset the stream starts over as a fresh one.
    #[test]
    fn stepping_equals_the_window_and_reset_starts_over() -> Result<()> {
        let device = Device::flex();
        let cfg = SeqHeadConfig {
            features: 16,
            hidden: 8,
            outputs: 7,
        };
        let mut head = cfg.init(&device, 5);
        // a trained correction: the fresh one is zero, and adds nothing to the single frame
        let (b, k, o) = (2, 6, cfg.outputs);
        let f = cfg.features + o;
        let x = features(b, k, f, &device);
        let single = values(x.clone().narrow(2, cfg.features, o))?;
        assert_eq!(values(head.forward(x.clone(), None).0)?, single);
        head.out = crate::net::seeded_init(&device, 6, || {
            LinearConfig::new(cfg.hidden, o).init(&device)
        });
        let window = values(head.forward(x.clone(), None).0)?;
        assert_eq!(window.len(), b * k * o);
        let frame = |t: usize| -> Result<Vec<f32>> {
            values(x.clone().slice([0..b, t..t + 1, 0..f]).reshape([b, f]))
        };

        let mut stream = head.stream()?;
        assert!(!stream.has_history());
        let mut stepped = Vec::new();
        for t in 0..k {
            stepped.push(stream.step(&frame(t)?, b)?);
        }
        for (t, out) in stepped.iter().enumerate() {
            for row in 0..b {
                let want = &window[(row * k + t) * o..][..o];
                for (a, w) in out[row * o..(row + 1) * o].iter().zip(want) {
                    assert!((a - w).abs() < 1e-5, "frame {t} row {row}: {a} vs {w}");
                }
            }
        }
        // the history matters: frame 2 alone differs from frame 2 after frames 0 and 1
        let alone = head.stream()?.step(&frame(2)?, b)?;
        assert!(
            alone
                .iter()
                .zip(&stepped[2])
                .any(|(a, s)| (a - s).abs() > 1e-4)
        );
        // after a reset, the stream answers as a fresh one
        stream.reset();
        assert!(!stream.has_history());
        assert_eq!(stream.step(&frame(2)?, b)?, alone);
        assert!(stream.step(&frame(3)?, b + 1).is_err());
        Ok(())
    }
}
