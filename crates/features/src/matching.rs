//! Brute-force matching of binary descriptors by Hamming distance, with Lowe's ratio test and
//! one match per train feature (the closest query wins). A query feature is compared with every
//! train feature: for the few thousand features of a handful of keyframes this is a few
//! million 256-bit comparisons, which costs less than building any index. Where the CPU has
//! AVX-512's 64-bit population count, eight train descriptors are compared with a query at once
//! (the train set laid out word by word, eight descriptors to a block); elsewhere four `popcnt`
//! per comparison. Both find the same matches.

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
    #[cfg(target_arch = "x86_64")]
    let wide = wide::available().then(|| wide::Blocks::new(train));
    for (qi, q) in query.iter().enumerate() {
        #[cfg(target_arch = "x86_64")]
        let (ti, best, second) = match &wide {
            // SAFETY: `wide` exists only where the CPU has what `wide::nearest_two` needs.
            Some(blocks) => unsafe { wide::nearest_two(q, blocks) },
            None => nearest_two(q, train),
        };
        #[cfg(not(target_arch = "x86_64"))]
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
/// (`u32::MAX` when there is one train descriptor). Ties go to the lower index.
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
    let mut near = NearestTwo::default();
    for (i, t) in train.iter().enumerate() {
        near.offer(i, distance(q, t));
    }
    near.answer()
}

/// The nearest and second nearest of distances offered in increasing index order.
#[derive(Clone, Copy)]
struct NearestTwo {
    index: usize,
    best: u32,
    second: u32,
}

impl Default for NearestTwo {
    fn default() -> Self {
        NearestTwo {
            index: 0,
            best: u32::MAX,
            second: u32::MAX,
        }
    }
}

impl NearestTwo {
    #[inline(always)]
    fn offer(&mut self, index: usize, d: u32) {
        if d < self.best {
            self.second = self.best;
            self.best = d;
            self.index = index;
        } else if d < self.second {
            self.second = d;
        }
    }

    fn answer(self) -> (usize, u32, u32) {
        (self.index, self.best, self.second)
    }
}

/// Matching eight train descriptors at a time with AVX-512 (`vpopcntq`).
#[cfg(target_arch = "x86_64")]
mod wide {
    use super::{Descriptor, NearestTwo, distance};
    use std::arch::x86_64::*;

    /// Descriptors per block: one 512-bit register of 64-bit words.
    const LANES: usize = 8;

    /// The train set word by word: block `b`'s word `j` of its eight descriptors at
    /// `words[(b * 4 + j) * 8..][..8]`; the descriptors past the last whole block in `tail`.
    pub(super) struct Blocks<'a> {
        words: Vec<u64>,
        tail: &'a [Descriptor],
    }

    impl<'a> Blocks<'a> {
        pub(super) fn new(train: &'a [Descriptor]) -> Self {
            let whole = train.len() / LANES * LANES;
            let mut words = vec![0u64; whole * 4];
            for (b, block) in train[..whole].chunks_exact(LANES).enumerate() {
                for j in 0..4 {
                    for (l, d) in block.iter().enumerate() {
                        words[(b * 4 + j) * LANES + l] = d[j];
                    }
                }
            }
            Blocks {
                words,
                tail: &train[whole..],
            }
        }
    }

    /// Whether this CPU runs [`nearest_two`].
    pub(super) fn available() -> bool {
        std::arch::is_x86_feature_detected!("avx512f")
            && std::arch::is_x86_feature_detected!("avx512vpopcntdq")
    }

    /// What [`super::nearest_two_portable`] answers, from [`Blocks`].
    ///
    /// # Safety
    /// The CPU must have AVX-512F and AVX-512 VPOPCNTDQ ([`available`]).
    #[target_feature(enable = "avx512f,avx512vpopcntdq,popcnt")]
    pub(super) unsafe fn nearest_two(q: &Descriptor, train: &Blocks) -> (usize, u32, u32) {
        let qw = q.map(|w| _mm512_set1_epi64(w as i64));
        let mut best = _mm512_set1_epi64(-1);
        let mut second = best;
        let mut index = _mm512_setzero_si512();
        let mut current = _mm512_set_epi64(7, 6, 5, 4, 3, 2, 1, 0);
        let step = _mm512_set1_epi64(LANES as i64);
        for block in train.words.chunks_exact(4 * LANES) {
            let mut d = _mm512_setzero_si512();
            for (j, q) in qw.iter().enumerate() {
                // SAFETY: `block` holds 4 * 8 words; word j's eight start at j * 8.
                let t = unsafe { _mm512_loadu_si512(block.as_ptr().add(j * LANES).cast()) };
                d = _mm512_add_epi64(d, _mm512_popcnt_epi64(_mm512_xor_si512(*q, t)));
            }
            let nearer = _mm512_cmplt_epu64_mask(d, best);
            second = _mm512_min_epu64(second, _mm512_max_epu64(best, d));
            best = _mm512_min_epu64(best, d);
            index = _mm512_mask_blend_epi64(nearer, index, current);
            current = _mm512_add_epi64(current, step);
        }
        let (mut bests, mut seconds, mut indices) = ([0u64; LANES], [0u64; LANES], [0u64; LANES]);
        // SAFETY: each array holds the eight 64-bit lanes stored.
        unsafe {
            _mm512_storeu_si512(bests.as_mut_ptr().cast(), best);
            _mm512_storeu_si512(seconds.as_mut_ptr().cast(), second);
            _mm512_storeu_si512(indices.as_mut_ptr().cast(), index);
        }
        merge_lanes(
            q,
            train,
            Lanes {
                bests,
                seconds,
                indices,
            },
        )
    }

    /// Each lane's nearest and second nearest distance and the nearest one's index, over the
    /// whole blocks.
    pub(super) struct Lanes {
        pub bests: [u64; LANES],
        pub seconds: [u64; LANES],
        pub indices: [u64; LANES],
    }

    /// The nearest two over all lanes and the tail, as if offered one by one in index order.
    pub(super) fn merge_lanes(q: &Descriptor, train: &Blocks, lanes: Lanes) -> (usize, u32, u32) {
        let Lanes {
            bests,
            seconds,
            indices,
        } = lanes;
        // Lanes in order of their best (ties by index).
        let mut order: Vec<usize> = (0..LANES).filter(|&l| bests[l] != u64::MAX).collect();
        order.sort_by_key(|&l| (bests[l], indices[l]));
        let mut near = NearestTwo::default();
        for (rank, &l) in order.iter().enumerate() {
            near.offer(indices[l] as usize, bests[l] as u32);
            if rank == 0 && seconds[l] != u64::MAX {
                near.offer(indices[l] as usize, seconds[l] as u32);
            }
        }
        let whole = train.words.len() / 4;
        for (i, t) in train.tail.iter().enumerate() {
            near.offer(whole + i, distance(q, t));
        }
        near.answer()
    }
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

    /// Descriptors of few set bits, so that distances tie often.
    fn sparse_descriptors(n: usize, seed: u64) -> Vec<Descriptor> {
        let mut state = seed;
        let mut next = move || {
            state = state
                .wrapping_mul(6_364_136_223_846_793_005)
                .wrapping_add(1_442_695_040_888_963_407);
            state >> 33
        };
        (0..n)
            .map(|_| {
                let mut d = [0u64; 4];
                for _ in 0..6 {
                    let bit = next() % 256;
                    d[(bit / 64) as usize] |= 1 << (bit % 64);
                }
                d
            })
            .collect()
    }

    /// The lane layout and the merge of the lanes, run in plain code (what the AVX-512 loop
    /// computes, lane by lane), find what one at a time finds; and so does the AVX-512 loop
    /// itself where the CPU has it.
    #[cfg(target_arch = "x86_64")]
    #[test]
    fn eight_at_a_time_finds_what_one_at_a_time_finds() {
        let queries = sparse_descriptors(200, 1);
        for n in [1, 7, 8, 9, 23, 64, 301] {
            let train = sparse_descriptors(n, n as u64 + 2);
            let blocks = wide::Blocks::new(&train);
            for q in &queries {
                let one_at_a_time = nearest_two_portable(q, &train);
                let mut lanes = wide::Lanes {
                    bests: [u64::MAX; 8],
                    seconds: [u64::MAX; 8],
                    indices: [0; 8],
                };
                for (b, block) in train.chunks_exact(8).enumerate() {
                    for (l, t) in block.iter().enumerate() {
                        let d = u64::from(distance(q, t));
                        lanes.seconds[l] = lanes.seconds[l].min(lanes.bests[l].max(d));
                        if d < lanes.bests[l] {
                            lanes.bests[l] = d;
                            lanes.indices[l] = (b * 8 + l) as u64;
                        }
                    }
                }
                let merged = wide::merge_lanes(q, &blocks, lanes);
                assert_eq!(merged, one_at_a_time, "{n} train descriptors, lanes merged");
                if wide::available() {
                    // SAFETY: checked just above.
                    let simd = unsafe { wide::nearest_two(q, &blocks) };
                    assert_eq!(simd, one_at_a_time, "{n} train descriptors, AVX-512");
                }
            }
        }
    }
}
