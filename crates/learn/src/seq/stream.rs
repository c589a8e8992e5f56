//! The live step of a sequence model outside burn: one frame's features in, its outputs out,
//! the LSTM state carried until [`SeqStream::reset`].
//!
//! Written by hand because burn's `Lstm` runs each of its four gates as separate small
//! operations (two matrix products, bias, activation), and at one frame the per-operation
//! overhead of the backend dominates: a step with 16 Monte-Carlo streams cost about 4 ms, three
//! times the CNN that makes the features. Here the four gates' weights are stacked into one
//! `[4H, F + H]` matrix, so a step is one matrix product (nalgebra's GEMM, or a GEMV for one
//! stream, each stream a contiguous column) and a pass of element-wise gate arithmetic. The weights are the trained `SeqHead`'s, copied; a test checks
//! that stepping gives burn's outputs for the same window.

use nalgebra::DMatrix;

use crate::{LearnError, Result};

/// Weights `[rows, cols]` (row-major, as burn's `Linear` stores them: `y = x·W + b`) and bias
/// of a linear layer.
#[derive(Clone, Debug)]
pub(super) struct LinearWeights {
    pub rows: usize,
    pub cols: usize,
    pub weight: Vec<f32>,
    pub bias: Vec<f32>,
}

/// The input and hidden transforms of one LSTM gate.
#[derive(Clone, Debug)]
pub(super) struct GateWeights {
    pub input: LinearWeights,
    pub hidden: LinearWeights,
}

/// A live stream through a sequence head: `rows` independent streams side by side (one, or one
/// per Monte-Carlo pass), each with its own state. A frame is its features then the
/// single-frame outputs, which the output adds to ([`super::SeqHead::forward`]).
#[derive(Clone, Debug)]
pub struct SeqStream {
    features: usize,
    hidden: usize,
    outputs: usize,
    /// Stacked gate weights `[4H, F + H]`, gates in the order input, forget, output, cell.
    gates: DMatrix<f32>,
    /// Summed input and hidden biases of the gates, `4H`.
    gate_bias: Vec<f32>,
    /// Output layer `[O, H]` and its bias.
    out: DMatrix<f32>,
    out_bias: Vec<f32>,
    /// `(h, c)`, each `[H, rows]` (a column per stream), when the stream has history.
    state: Option<(DMatrix<f32>, DMatrix<f32>)>,
}

impl SeqStream {
    /// A stream with no history, from the four gates (input, forget, output, cell) and the
    /// output layer.
    pub(super) fn new(gates: &[GateWeights], out: LinearWeights) -> Result<SeqStream> {
        let bad = |m: String| Err(LearnError::Config(format!("LSTM weights: {m}")));
        let Some(first) = gates.first() else {
            return bad("no gates".into());
        };
        let (f, h) = (first.input.rows, first.input.cols);
        if gates.len() != 4 {
            return bad(format!("{} gates, not 4", gates.len()));
        }
        let mut stacked = DMatrix::<f32>::zeros(4 * h, f + h);
        let mut gate_bias = vec![0.0; 4 * h];
        for (g, gate) in gates.iter().enumerate() {
            let (i, hh) = (&gate.input, &gate.hidden);
            if (i.rows, i.cols, hh.rows, hh.cols) != (f, h, h, h) {
                return bad(format!("gate {g} is not {f}->{h} and {h}->{h}"));
            }
            for r in 0..f {
                for c in 0..h {
                    stacked[(g * h + c, r)] = i.weight[r * h + c];
                }
            }
            for r in 0..h {
                for c in 0..h {
                    stacked[(g * h + c, f + r)] = hh.weight[r * h + c];
                }
            }
            for c in 0..h {
                gate_bias[g * h + c] = i.bias[c] + hh.bias[c];
            }
        }
        if out.rows != h {
            return bad(format!("output layer takes {}, not {h}", out.rows));
        }
        if out.cols >= f {
            return bad(format!(
                "{} outputs, but frames of {f} values hold features and as many single-frame outputs",
                out.cols
            ));
        }
        Ok(SeqStream {
            features: f,
            hidden: h,
            outputs: out.cols,
            gates: stacked,
            gate_bias,
            out: DMatrix::from_row_slice(out.rows, out.cols, &out.weight).transpose(),
            out_bias: out.bias,
            state: None,
        })
    }

    /// Outputs (`rows · outputs` values, row-major) of the next frame (`rows · width` values,
    /// row-major: each stream's features then its single-frame outputs), one row per stream.
    pub fn step(&mut self, features: &[f32], rows: usize) -> Result<Vec<f32>> {
        let (f, h) = (self.features, self.hidden);
        if features.len() != rows * f || rows == 0 {
            return Err(LearnError::Input(format!(
                "{} feature values for {rows} stream(s) of {f}",
                features.len()
            )));
        }
        let (mut hs, mut cs) = match self.state.take() {
            Some((hs, cs)) if hs.ncols() == rows => (hs, cs),
            _ => (DMatrix::zeros(h, rows), DMatrix::zeros(h, rows)),
        };
        // column-major: each stream's features then its previous hidden state, contiguous
        let mut columns = Vec::with_capacity((f + h) * rows);
        for r in 0..rows {
            columns.extend_from_slice(&features[r * f..(r + 1) * f]);
            columns.extend(hs.column(r).iter());
        }
        let z = &self.gates * DMatrix::from_vec(f + h, rows, columns);
        let sigmoid = |x: f32| 1.0 / (1.0 + (-x).exp());
        for r in 0..rows {
            let z = z.column(r);
            for c in 0..h {
                let at = |g: usize| z[g * h + c] + self.gate_bias[g * h + c];
                let (i, fg, o, g) = (sigmoid(at(0)), sigmoid(at(1)), sigmoid(at(2)), at(3).tanh());
                let cell = fg * cs[(c, r)] + i * g;
                cs[(c, r)] = cell;
                hs[(c, r)] = o * cell.tanh();
            }
        }
        let y = &self.out * &hs;
        self.state = Some((hs, cs));
        let mut out = Vec::with_capacity(rows * self.outputs);
        let single_at = f - self.outputs;
        for r in 0..rows {
            let single = &features[r * f + single_at..(r + 1) * f];
            out.extend((0..self.outputs).map(|c| single[c] + y[(c, r)] + self.out_bias[c]));
        }
        Ok(out)
    }

    /// Forgets the history: the next frame starts a new stretch of time (a scene cut).
    pub fn reset(&mut self) {
        self.state = None;
    }

    /// Whether the stream carries history.
    pub fn has_history(&self) -> bool {
        self.state.is_some()
    }

    /// Outputs per row.
    pub fn outputs(&self) -> usize {
        self.outputs
    }
}
