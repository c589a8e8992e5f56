//! Windows of consecutive frames for sequence models (CNN+LSTM): which runs of `len` frames a
//! model may see as one stretch of time.
//!
//! A window lies within one recording: every frame of the same sequence, frame numbers
//! consecutive (a gap means frames are missing and time jumped), and no scene cut inside it. A
//! cut at the window's first frame is allowed: the window then starts with the new scene, as a
//! model whose state was reset at the cut sees it.

use std::ops::Range;

/// The unbroken runs of `frames` (index ranges): a new run starts where the sequence changes,
/// a frame number is skipped, or a cut (a frame number in `cuts`, any order) starts a new
/// scene. `frames` holds `(sequence, frame number)` in dataset order. A sequence model's state
/// lives within one run.
pub fn runs<S: PartialEq>(frames: &[(S, u64)], cuts: &[u64]) -> Vec<Range<usize>> {
    let mut cuts = cuts.to_vec();
    cuts.sort_unstable();
    let breaks_before = |i: usize| -> bool {
        let (seq, number) = &frames[i];
        let (prev_seq, prev_number) = &frames[i - 1];
        seq != prev_seq
            || prev_number.checked_add(1) != Some(*number)
            || cuts.binary_search(number).is_ok()
    };
    let mut runs = Vec::new();
    let mut run_start = 0;
    for i in 1..=frames.len() {
        if i == frames.len() || breaks_before(i) {
            runs.push(run_start..i);
            run_start = i;
        }
    }
    runs
}

/// Start positions (indices into `frames`) of the windows of `len` frames, every `stride`
/// frames along each unbroken run ([`runs`]).
pub fn window_starts<S: PartialEq>(
    frames: &[(S, u64)],
    cuts: &[u64],
    len: usize,
    stride: usize,
) -> Vec<usize> {
    if len == 0 || stride == 0 || frames.len() < len {
        return Vec::new();
    }
    runs(frames, cuts)
        .into_iter()
        .filter(|run| run.len() >= len)
        .flat_map(|run| (run.start..=run.end - len).step_by(stride))
        .collect()
}

#[cfg(test)]
mod tests {
    use super::*;
    use rand::{Rng, SeedableRng};
    use rand_chacha::ChaCha8Rng;

    /// Brute force: is `frames[s..s + len]` one unbroken stretch?
    fn valid(frames: &[(u8, u64)], cuts: &[u64], s: usize, len: usize) -> bool {
        (s + 1..s + len).all(|i| {
            frames[i].0 == frames[i - 1].0
                && frames[i].1 == frames[i - 1].1 + 1
                && !cuts.contains(&frames[i].1)
        })
    }

    #[test]
    fn windows_never_cross_sequences_gaps_or_cuts_and_miss_none() {
        let mut rng = ChaCha8Rng::seed_from_u64(11);
        for _ in 0..200 {
            // random recordings: sequences of random length, occasional gaps, random cuts
            let mut frames = Vec::new();
            let mut number = 0u64;
            for seq in 0..rng.random_range(1..5u8) {
                for _ in 0..rng.random_range(0..40) {
                    number += if rng.random_bool(0.05) { 3 } else { 1 };
                    frames.push((seq, number));
                }
            }
            let cuts: Vec<u64> = (0..rng.random_range(0..4))
                .map(|_| rng.random_range(0..number + 2))
                .collect();
            let len = rng.random_range(1..12);
            let starts = window_starts(&frames, &cuts, len, 1);
            let expected: Vec<usize> = (0..frames.len().saturating_sub(len - 1))
                .filter(|&s| valid(&frames, &cuts, s, len))
                .collect();
            assert_eq!(
                starts, expected,
                "len {len} cuts {cuts:?} frames {frames:?}"
            );
        }
    }

    #[test]
    fn stride_and_edge_cases() {
        let frames: Vec<(&str, u64)> = (0..10).map(|i| ("a", i)).collect();
        assert_eq!(window_starts(&frames, &[], 4, 3), vec![0, 3, 6]);
        // a cut at 5: windows up to frame 4, then from 5 on
        assert_eq!(window_starts(&frames, &[5], 4, 1), vec![0, 1, 5, 6]);
        assert_eq!(runs(&frames, &[5, 99]), vec![0..5, 5..10]);
        assert!(runs::<&str>(&[], &[]).is_empty());
        assert!(window_starts(&frames, &[], 11, 1).is_empty());
        assert!(window_starts(&frames, &[], 0, 1).is_empty());
        assert!(window_starts(&frames, &[], 2, 0).is_empty());
    }
}
