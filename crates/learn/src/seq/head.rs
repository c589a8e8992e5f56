//! The recurrent part of a sequence model (CNN+LSTM): per-frame CNN features in, an LSTM over
//! the frames of a window, a linear layer per frame out.
//!
//! Training sees windows (`[B, K, F]` features, [`crate::window`] says which frames form one);
//! a live stream steps one frame at a time with the state carried over ([`SeqStream`]), and a
//! scene cut calls [`SeqStream::reset`]. Stepping K frames gives the same outputs as the window
//! of those K frames (a test checks it), so what was trained is what runs live.

use burn::module::Module;
use burn::nn::{Linear, LinearConfig, Lstm, LstmConfig, LstmState};
use burn::tensor::{Device, Tensor};
use serde::{Deserialize, Serialize};

/// What a [`SeqHead`] is built from.
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
            lstm: LstmConfig::new(self.features, self.hidden, true)
                .with_batch_first(true)
                .init(device),
            out: LinearConfig::new(self.hidden, self.outputs).init(device),
        })
    }
}

/// LSTM over a window's features, then a linear layer per frame.
#[derive(Module, Debug)]
pub struct SeqHead {
    lstm: Lstm,
    out: Linear,
}

impl SeqHead {
    /// Outputs `[B, K, outputs]` of features `[B, K, F]`, starting from `state` (zeros when
    /// `None`); also the state after the last frame.
    pub fn forward(
        &self,
        features: Tensor<3>,
        state: Option<LstmState<2>>,
    ) -> (Tensor<3>, LstmState<2>) {
        let (hidden, state) = self.lstm.forward(features, state);
        (self.out.forward(hidden), state)
    }
}

/// A live stream through a [`SeqHead`]: one frame at a time, the LSTM state carried from frame
/// to frame until [`reset`](SeqStream::reset).
#[derive(Debug)]
pub struct SeqStream<'a> {
    head: &'a SeqHead,
    state: Option<LstmState<2>>,
}

impl<'a> SeqStream<'a> {
    /// A stream with no history.
    pub fn new(head: &'a SeqHead) -> SeqStream<'a> {
        SeqStream { head, state: None }
    }

    /// Outputs `[B, outputs]` for the next frame's features `[B, F]`.
    pub fn step(&mut self, features: Tensor<2>) -> Tensor<2> {
        let [b, f] = features.dims();
        let (y, state) = self
            .head
            .forward(features.reshape([b, 1, f]), self.state.take());
        self.state = Some(state);
        let [_, _, o] = y.dims();
        y.reshape([b, o])
    }

    /// Forgets the history: the next frame starts a new stretch of time (a scene cut).
    pub fn reset(&mut self) {
        self.state = None;
    }

    /// Whether the stream carries history.
    pub fn has_history(&self) -> bool {
        self.state.is_some()
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::{LearnError, Result};
    use burn::tensor::TensorData;

    fn values<const D: usize>(y: Tensor<D>) -> Result<Vec<f32>> {
        y.into_data()
            .try_to_vec::<f32>()
            .map_err(|e| LearnError::Input(format!("{e:?}")))
    }

    fn features(k: usize, f: usize, device: &Device) -> Tensor<3> {
        let v: Vec<f32> = (0..k * f)
            .map(|i| ((i * 37 % 101) as f32 / 50.0) - 1.0)
            .collect();
        Tensor::<3>::from_data(TensorData::new(v, [1, k, f]), device)
    }

    /// Stepping frame by frame gives the window's outputs; after a reset the stream starts
    /// over as a fresh one.
    #[test]
    fn stepping_equals_the_window_and_reset_starts_over() -> Result<()> {
        let device = Device::flex();
        let cfg = SeqHeadConfig {
            features: 16,
            hidden: 8,
            outputs: 7,
        };
        let head = cfg.init(&device, 5);
        let (k, f) = (6, cfg.features);
        let x = features(k, f, &device);
        let (window, _) = head.forward(x.clone(), None);
        let window = values(window)?;
        assert_eq!(window.len(), k * cfg.outputs);

        let mut stream = SeqStream::new(&head);
        assert!(!stream.has_history());
        let mut stepped = Vec::new();
        for t in 0..k {
            let frame = x.clone().slice([0..1, t..t + 1, 0..f]).reshape([1, f]);
            stepped.extend(values(stream.step(frame))?);
        }
        for (a, b) in window.iter().zip(&stepped) {
            assert!((a - b).abs() < 1e-5, "{a} vs {b}");
        }
        // the history matters: frame 2 alone differs from frame 2 after frames 0 and 1
        let third = x.clone().slice([0..1, 2..3, 0..f]).reshape([1, f]);
        let alone = values(SeqStream::new(&head).step(third.clone()))?;
        assert!(
            alone
                .iter()
                .zip(&stepped[2 * cfg.outputs..3 * cfg.outputs])
                .any(|(a, b)| (a - b).abs() > 1e-4)
        );
        // after a reset, the stream answers as a fresh one
        stream.reset();
        assert!(!stream.has_history());
        let again = values(stream.step(third))?;
        for (a, b) in alone.iter().zip(&again) {
            assert!((a - b).abs() < 1e-6);
        }
        Ok(())
    }
}
