//! OpenCV's `saturate_cast<uchar>(float)`: round half to even (`cvRound` under the default
//! rounding mode), then clamp to 0..=255.
//!
//! Why by hand: `f32::round_ties_even` becomes a library call on baseline x86-64 (no SSE4.1),
//! which would dominate the per-pixel loops; adding and subtracting 2^23 rounds with the FPU's
//! own ties-to-even mode in two vectorisable instructions.

/// 2^23: from here on `f32` has no fraction bits.
const MAGIC: f32 = 8_388_608.0;

/// Rounds `x` to the nearest integer, ties to even, for `0 <= x < 2^23` (what pixel arithmetic
/// produces). Negative inputs give a value `<= 0`, which [`sat_u8`] clamps to 0 as OpenCV does.
#[inline(always)]
pub(crate) fn rne(x: f32) -> f32 {
    (x + MAGIC) - MAGIC
}

/// Clamps to `0..=255` and converts (Rust's float-to-int `as` saturates; NaN gives 0).
#[inline(always)]
pub(crate) fn sat_u8(x: f32) -> u8 {
    x as u8
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn ties_go_to_even_and_values_saturate() {
        assert_eq!(rne(0.5), 0.0);
        assert_eq!(rne(1.5), 2.0);
        assert_eq!(rne(2.5), 2.0);
        assert_eq!(rne(2.500_001), 3.0);
        assert_eq!(rne(254.49), 254.0);
        assert_eq!(sat_u8(rne(300.2)), 255);
        assert_eq!(sat_u8(rne(-3.0)), 0);
    }
}
