//! Progress of a training run, shared by [`crate::train`], [`crate::seq::train_sequence`] and
//! [`crate::place::train_place`] so that one progress display serves all three.

/// An event of a training run: `L` says what was loaded before the first epoch, `E` holds a
/// finished epoch's metrics.
#[derive(Clone, Debug, PartialEq)]
pub enum Progress<L, E> {
    /// The data is in memory.
    Loaded(L),
    /// Training continues from a checkpoint.
    Resumed {
        /// Epochs already finished.
        epoch: usize,
    },
    /// One optimisation step finished.
    Step {
        /// Epoch (from 1).
        epoch: usize,
        /// Step within the epoch (from 1).
        step: usize,
        /// Steps in the epoch.
        steps: usize,
        /// Loss of the batch.
        loss: f64,
    },
    /// An epoch finished and was checkpointed.
    Epoch(E),
    /// Validation did not improve for `patience` epochs.
    EarlyStop {
        /// Last epoch run.
        epoch: usize,
        /// Epoch of the kept weights.
        best_epoch: usize,
    },
}
