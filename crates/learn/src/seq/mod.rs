//! Sequence models (CNN+LSTM): a trained single-frame network's pooled features per frame, an
//! LSTM over the frames, a pose per frame.
//!
//! # Two stages
//! The CNN is the single-frame model of the same checkpoint folder, frozen; only the LSTM and
//! its output layer are trained ([`train_sequence`]), on windows of `K` consecutive frames of
//! one recording ([`crate::window`]) whose features are computed once. End-to-end training
//! would run the CNN forward and backward over `K` frames per window, `K` times the cost of
//! the single-frame model per sample; frozen features make the sequence model a few minutes on
//! top of it on a laptop CPU, and let the study compare the two on exactly the same CNN. So
//! that the LSTM does not learn to trust features that are cleaner on training frames than on
//! new ones, training windows see the features of jittered views too
//! (`loader::jitter_view`) and dropout masks on every frame's features (the same masks
//! give Monte-Carlo uncertainty at inference).
//!
//! # Files (beside the single-frame model's)
//! ```text
//! MODEL/
//!   seq.toml                    SeqMeta: head, config, the base weights' hash, metrics
//!   seq.bpk                     LSTM + output layer of the best epoch
//!   seq-state/weights-NNNN.bpk  state after the last finished epoch (resume)
//!   seq-state/optimizer-NNNN.bpk
//! ```
//! `seq.toml` records the hash of the `model.bpk` it was trained on: a retrained CNN makes the
//! sequence model refuse to load rather than run on features it never saw.
//!
//! # Inference
//! [`SeqLocalizer`] runs whole recordings at once ([`SeqLocalizer::predict_run`]) or live, one
//! frame at a time with the LSTM state carried over ([`SeqTracker::step`]); a scene cut or a new
//! recording calls [`SeqTracker::reset`].

mod head;
mod infer;
mod meta;
mod stream;
mod train;

pub use head::{SeqHead, SeqHeadConfig};
pub use infer::{SeqLocalizer, SeqTracker};
pub use meta::{
    MAX_LSTM_UNITS, SEQ_BPK, SEQ_FORMAT, SEQ_STATE_DIR, SEQ_TOML, SeqConfig, SeqEpoch, SeqMeta,
};
pub use stream::SeqStream;
pub use train::{MAX_STEP_RATIO, SeqEvent, SeqFeatures, SeqSummary, train_sequence};
