//! Random streams of the generator.
//!
//! Every aspect of the building (layout, decoration, poster content, furniture, debris) draws from
//! its own stream, seeded from a hash of the world seed, the aspect's name and (for the aspects a
//! variant changes) the variant. So a variant that moves the furniture cannot shift a single wall:
//! the layout stream never sees the variant. The hash is SplitMix64-style mixing written out here,
//! not `std`'s hasher, whose output Rust does not promise to keep across releases.

use rand::{Rng, SeedableRng};
use rand_chacha::ChaCha8Rng;

/// The generator's random number source.
pub(crate) type Stream = ChaCha8Rng;

/// Mixes one 64-bit word into a hash state (SplitMix64 finaliser).
fn mix(state: u64, word: u64) -> u64 {
    let mut z = state
        ^ word
            .wrapping_add(0x9E37_79B9_7F4A_7C15)
            .wrapping_add(state << 6);
    z = (z ^ (z >> 30)).wrapping_mul(0xBF58_476D_1CE4_E5B9);
    z = (z ^ (z >> 27)).wrapping_mul(0x94D0_49BB_1331_11EB);
    z ^ (z >> 31)
}

/// A stable hash of a list of words.
pub(crate) fn hash(words: &[u64]) -> u64 {
    words
        .iter()
        .fold(0x5EED_1D00_C0FF_EE00, |state, &w| mix(state, w))
}

/// A stable hash of a short text (names of aspects), for use as a word in [`hash`].
pub(crate) fn text(s: &str) -> u64 {
    s.bytes().fold(0xCBF2_9CE4_8422_2325, |h, b| {
        (h ^ u64::from(b)).wrapping_mul(0x0000_0100_0000_01B3)
    })
}

/// A stream seeded from a hash of `words`.
pub(crate) fn stream(words: &[u64]) -> Stream {
    Stream::seed_from_u64(hash(words))
}

/// Uniform `f32` in `[lo, hi)`; `lo` when the range is empty (never panics).
pub(crate) fn range(rng: &mut Stream, lo: f32, hi: f32) -> f32 {
    if hi > lo {
        lo + (hi - lo) * rng.random::<f32>()
    } else {
        lo
    }
}

/// Uniform integer in `[lo, hi]`; `lo` when the range is empty (never panics).
pub(crate) fn range_i(rng: &mut Stream, lo: i32, hi: i32) -> i32 {
    if hi > lo {
        rng.random_range(lo..=hi)
    } else {
        lo
    }
}

/// True with probability `p` (clamped to 0–1).
pub(crate) fn chance(rng: &mut Stream, p: f32) -> bool {
    rng.random::<f32>() < p.clamp(0.0, 1.0)
}

/// One element of a non-empty slice, or `None` for an empty one.
pub(crate) fn pick<'a, T>(rng: &mut Stream, items: &'a [T]) -> Option<&'a T> {
    if items.is_empty() {
        None
    } else {
        items.get(rng.random_range(0..items.len()))
    }
}

/// A fresh 64-bit seed for a material's pattern.
pub(crate) fn seed(rng: &mut Stream) -> u64 {
    rng.random::<u64>()
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn hash_is_stable_and_order_sensitive() {
        assert_eq!(hash(&[1, 2, 3]), hash(&[1, 2, 3]));
        assert_ne!(hash(&[1, 2, 3]), hash(&[3, 2, 1]));
        assert_ne!(text("layout"), text("decor"));
    }

    #[test]
    fn empty_ranges_do_not_panic() {
        let mut rng = stream(&[7]);
        assert_eq!(range(&mut rng, 2.0, 1.0), 2.0);
        assert_eq!(range_i(&mut rng, 5, 4), 5);
        assert!(pick::<u8>(&mut rng, &[]).is_none());
    }
}
