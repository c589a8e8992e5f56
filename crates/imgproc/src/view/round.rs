//! OpenCV's `saturate_cast<uchar>(float)`: round half to even (`cvRound` under the default
//! rounding mode), then clamp to 0..=255.
//!
//! Why by hand: `f32::round_ties_even` becomes a library call on baseline x86-64 (no SSE4.1),
//! and Rust's saturating `as u8` turns into scalar min/max per value; both would dominate the
//! per-pixel loops. Adding 2^23 makes the FPU round to an integer with its own ties-to-even mode,
//! and that integer is then the low bits of the float's representation, so rounding and clamping
//! are three vectorisable integer/float instructions.

/// 2^23: from here on `f32` has no fraction bits.
const MAGIC: f32 = 8_388_608.0;
/// Bit pattern of [`MAGIC`].
const MAGIC_BITS: i32 = 0x4B00_0000;

/// `x` rounded to the nearest integer (ties to even) and clamped to 0..=255, for
/// `-2^22 < x < 2^23` (pixel arithmetic stays far inside this range).
#[inline(always)]
pub(crate) fn round_u8(x: f32) -> u8 {
    ((x + MAGIC).to_bits() as i32 - MAGIC_BITS).clamp(0, 255) as u8
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn ties_go_to_even_and_values_saturate() {
        let cases = [
            (0.5, 0),
            (1.5, 2),
            (2.5, 2),
            (2.500_001, 3),
            (254.49, 254),
            (254.5, 254),
            (255.5, 255),
            (300.2, 255),
            (-0.4, 0),
            (-3.0, 0),
            (-1000.0, 0),
            (1e6, 255),
        ];
        for (x, want) in cases {
            assert_eq!(round_u8(x), want, "{x}");
        }
        for v in 0..=255u8 {
            assert_eq!(round_u8(v as f32), v);
        }
    }
}
