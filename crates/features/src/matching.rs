//! Brute-force matching of binary descriptors by Hamming distance, with Lowe's ratio test and
//! one match per train feature (the closest query wins). A query feature is compared with every
//! train feature: for the few thousand features of a handful of keyframes this is a few
//! million 256-bit comparisons, four `popcnt` each, which costs less than building any index.

use crate::Descriptor;
use crate::describe::distance;

/// When two features count as the same point.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct MatchConfig {
    /// Largest Hamming distance of a match (of 256 bits).
    pub max_distance: u32,
    /// The best distance must be below this fraction of the second best (Lowe's ratio test).
    pub ratio: f32,
}

impl Default for MatchConfig {
    /// Distance ≤ 64, ratio 0.8 (SIFT + PnP's, as `sift_pnp.py` runs it).
    fn default() -> Self {
        MatchConfig {
            max_distance: 64,
            ratio: 0.8,
        }
    }
}

/// A query feature matched to a train feature.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub struct Match {
    /// Index of the query feature.
    pub query: usize,
    /// Index of the train feature.
    pub train: usize,
    /// Hamming distance.
    pub distance: u32,
}

/// The matches of `query` features among `train` features (see the module docs), ordered by
/// query index.
pub fn match_descriptors(
    query: &[Descriptor],
    train: &[Descriptor],
    cfg: &MatchConfig,
) -> Vec<Match> {
    if train.is_empty() {
        return Vec::new();
    }
    let mut best_for_train: Vec<Option<Match>> = vec![None; train.len()];
    for (qi, q) in query.iter().enumerate() {
        let (ti, best, second) = nearest_two(q, train);
        let ratio_ok = second == u32::MAX || (best as f32) < cfg.ratio * second as f32;
        if best <= cfg.max_distance && ratio_ok {
            let m = Match {
                query: qi,
                train: ti,
                distance: best,
            };
            let slot = &mut best_for_train[ti];
            if slot.is_none_or(|old| old.distance > best) {
                *slot = Some(m);
            }
        }
    }
    let mut out: Vec<Match> = best_for_train.into_iter().flatten().collect();
    out.sort_by_key(|m| m.query);
    out
}

/// Index and distance of the nearest train descriptor, and the second nearest distance
/// (`u32::MAX` when there is one train descriptor).
fn nearest_two(q: &Descriptor, train: &[Descriptor]) -> (usize, u32, u32) {
    #[cfg(target_arch = "x86_64")]
    {
        if std::arch::is_x86_feature_detected!("popcnt") {
            // SAFETY: the CPU has `popcnt`, the only feature the function is compiled for.
            return unsafe { nearest_two_popcnt(q, train) };
        }
    }
    nearest_two_portable(q, train)
}

/// [`nearest_two_portable`] compiled with the `popcnt` instruction (without it a word's count
/// is a dozen shifts and adds).
#[cfg(target_arch = "x86_64")]
#[target_feature(enable = "popcnt")]
fn nearest_two_popcnt(q: &Descriptor, train: &[Descriptor]) -> (usize, u32, u32) {
    nearest_two_portable(q, train)
}

#[inline(always)]
fn nearest_two_portable(q: &Descriptor, train: &[Descriptor]) -> (usize, u32, u32) {
    let (mut bi, mut best, mut second) = (0usize, u32::MAX, u32::MAX);
    for (i, t) in train.iter().enumerate() {
        let d = distance(q, t);
        if d < best {
            second = best;
            best = d;
            bi = i;
        } else if d < second {
            second = d;
        }
    }
    (bi, best, second)
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn near_twins_match_and_ambiguous_or_far_ones_do_not() {
        let a = [0u64, 0, 0, 0];
        let b = [u64::MAX, u64::MAX, 0, 0];
        let c = [0u64, u64::MAX, u64::MAX, 0];
        let train = vec![a, b, c];
        // a with 3 bits flipped: distance 3 to a, ≥ 125 to the others.
        let q0 = [0b111u64, 0, 0, 0];
        // Far from all.
        let q1 = [0u64, 0, 0, u64::MAX];
        let got = match_descriptors(&[q0, q1], &train, &MatchConfig::default());
        assert_eq!(
            got,
            vec![Match {
                query: 0,
                train: 0,
                distance: 3
            }]
        );
        // Two equally near train features fail the ratio test.
        let twins = vec![[1u64, 0, 0, 0], [2u64, 0, 0, 0]];
        assert!(match_descriptors(&[a], &twins, &MatchConfig::default()).is_empty());
        // One train feature takes one query: the nearer.
        let got = match_descriptors(&[[1u64, 0, 0, 0], a], &[a], &MatchConfig::default());
        assert_eq!(got.len(), 1);
        assert_eq!(got[0].query, 1);
        assert_eq!(nearest_two(&q0, &train), nearest_two_portable(&q0, &train));
    }
}
