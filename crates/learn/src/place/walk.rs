//! Places over a walk: a discrete Bayes filter (the forward pass of a hidden Markov model) over
//! the place classes, so that a frame the network cannot place on its own (a close-up of a
//! corridor's end window, a door seen side-on) takes its place from the frames before it.
//!
//! - **Motion model** ([`PlaceTransitions`]): how often consecutive training frames changed
//!   place, and into which place, counted once at training time and stored in `place.toml`.
//!   Over `Δt` seconds a walker stays with probability `stay^(Δt / frame_s)`; otherwise it
//!   moves as the training walks did (a turn about in the same corridor is common, a jump to
//!   another building is not), with one pseudo-count spread over every place so that nothing
//!   is impossible.
//! - **Observation**: the frame's posterior over places, the three heads' product
//!   ([`super::place_posterior`]).
//!
//! The filter is causal (each answer uses the frames up to it and none after), so a live
//! stream gets the same answers as a recorded one. It must be reset where time does not run on:
//! a new sequence, a scene cut, a gap.
//!
//! Hand-written: a 26-state forward pass is a few lines of arithmetic, and no HMM crate keeps
//! an online, resettable, time-aware belief.

use serde::{Deserialize, Serialize};

/// Place changes between consecutive training frames: the filter's motion model.
#[derive(Clone, Debug, PartialEq, Serialize, Deserialize)]
pub struct PlaceTransitions {
    /// Seconds between two consecutive frames of the training walks.
    pub frame_s: f64,
    /// Pairs of consecutive training frames counted.
    pub pairs: u64,
    /// Of them, pairs whose place stayed the same.
    pub stays: u64,
    /// `changes[i][j]`: pairs that went from place `i` to place `j` (`i ≠ j`).
    pub changes: Vec<Vec<u64>>,
}

impl PlaceTransitions {
    /// Counts `places` (class index of each frame, in time order within each sequence; a
    /// `None` breaks the chain, as between two sequences or over a missing frame) taken every
    /// `frame_s` seconds, over `classes` places.
    pub fn count(
        chains: impl IntoIterator<Item = Option<usize>>,
        classes: usize,
        frame_s: f64,
    ) -> PlaceTransitions {
        let mut out = PlaceTransitions {
            frame_s,
            pairs: 0,
            stays: 0,
            changes: vec![vec![0; classes]; classes],
        };
        let mut last: Option<usize> = None;
        for place in chains {
            if let (Some(a), Some(b)) = (last, place)
                && a < classes
                && b < classes
            {
                out.pairs += 1;
                if a == b {
                    out.stays += 1;
                } else {
                    out.changes[a][b] += 1;
                }
            }
            last = place;
        }
        out
    }

    /// Probability of keeping the place from one frame to the next (`frame_s` later), with
    /// one pseudo-count each way so that neither staying nor moving is certain.
    pub fn stay(&self) -> f64 {
        (self.stays as f64 + 1.0) / (self.pairs as f64 + 2.0)
    }

    /// Where a walker who leaves place `i` goes: row `i` of the change counts plus one
    /// pseudo-count spread evenly over the other places, normalised.
    fn moves(&self) -> Vec<Vec<f64>> {
        let n = self.changes.len();
        let spread = 1.0 / (n.max(2) - 1) as f64;
        (0..n)
            .map(|i| {
                let mut row: Vec<f64> = (0..n)
                    .map(|j| {
                        if i == j {
                            0.0
                        } else {
                            self.changes[i].get(j).copied().unwrap_or(0) as f64 + spread
                        }
                    })
                    .collect();
                let total: f64 = row.iter().sum();
                if total > 0.0 {
                    row.iter_mut().for_each(|v| *v /= total);
                }
                row
            })
            .collect()
    }
}

/// The belief over places along one walk; see the module docs.
#[derive(Clone, Debug)]
pub struct PlaceFilter {
    stay: f64,
    frame_s: f64,
    moves: Vec<Vec<f64>>,
    belief: Option<Vec<f64>>,
    last_t: Option<f64>,
}

impl PlaceFilter {
    /// A filter with the motion model `transitions`, at the start of a walk.
    pub fn new(transitions: &PlaceTransitions) -> PlaceFilter {
        PlaceFilter {
            stay: transitions.stay(),
            frame_s: transitions.frame_s,
            moves: transitions.moves(),
            belief: None,
            last_t: None,
        }
    }

    /// Forgets the walk: the next frame is placed on its own.
    pub fn reset(&mut self) {
        self.belief = None;
        self.last_t = None;
    }

    /// Takes in one frame's `posterior` over places, seen at time `t` seconds (`None`: one
    /// training frame interval after the last), and returns the belief over places given every
    /// frame since the last reset. A posterior of another length than the model's places (or
    /// not a distribution) resets the walk and comes back as it is.
    pub fn step(&mut self, posterior: &[f32], t: Option<f64>) -> Vec<f32> {
        if posterior.len() != self.moves.len() {
            self.reset();
            return posterior.to_vec();
        }
        let dt = match (t, self.last_t) {
            (Some(now), Some(before)) if now >= before => now - before,
            _ => self.frame_s,
        };
        self.last_t = Some(t.unwrap_or_else(|| self.last_t.map_or(0.0, |b| b + self.frame_s)));
        let seen = || posterior.iter().map(|&p| f64::from(p.max(0.0)));
        let mut belief: Vec<f64> = match &self.belief {
            Some(before) => self
                .predict(before, dt)
                .into_iter()
                .zip(seen())
                .map(|(p, o)| p * o)
                .collect(),
            None => seen().collect(),
        };
        if !is_mass(&belief) {
            // The frame contradicts everything before it: the walk starts over from it.
            belief = seen().collect();
        }
        if !is_mass(&belief) {
            self.reset();
            return posterior.to_vec();
        }
        let total: f64 = belief.iter().sum();
        belief.iter_mut().for_each(|b| *b /= total);
        let out = belief.iter().map(|&b| b as f32).collect();
        self.belief = Some(belief);
        out
    }

    /// The belief `dt` seconds on, before the next frame is seen.
    fn predict(&self, belief: &[f64], dt: f64) -> Vec<f64> {
        let stay = self.stay.powf(dt / self.frame_s.max(1e-9)).clamp(0.0, 1.0);
        let mut prior: Vec<f64> = belief.iter().map(|b| stay * b).collect();
        for (from, row) in belief.iter().zip(&self.moves) {
            let leaving = (1.0 - stay) * from;
            for (p, m) in prior.iter_mut().zip(row) {
                *p += leaving * m;
            }
        }
        prior
    }
}

/// Whether `v` has a positive, finite total to normalise by.
fn is_mass(v: &[f64]) -> bool {
    let total: f64 = v.iter().sum();
    total > 0.0 && total.is_finite()
}
