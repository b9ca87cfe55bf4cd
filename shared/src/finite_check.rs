//! Counting the non-finite `f32` words of a GPU buffer (kernel `kernels/src/finite_check.rs`,
//! host `gi_host::frame::FiniteCheck`), so that a test can check every float buffer of a frame on
//! the GPU without reading it back.
//!
//! A buffer is seen as records of [`FiniteCheckPush::record_words`] 32-bit words (at most
//! [`MAX_RECORD_WORDS`]); word `i` of a record is an `f32` when bit `i` of
//! [`FiniteCheckPush::float_mask`] is set, and the other words (indices, flags, packed normals,
//! the `u32::MAX` of an empty slot) are skipped. A float is non-finite when its exponent bits are
//! all ones (NaN or ±∞): a test on the bits, which no floating-point rewrite can fold away.

use bytemuck::{Pod, Zeroable};

use crate::math::{max_u32, min_u32};

/// Invocations per workgroup of the kernel.
pub const FINITE_CHECK_GROUP: u32 = 64;
/// Most words a record may have: one bit of [`FiniteCheckPush::float_mask`] each.
pub const MAX_RECORD_WORDS: u32 = 32;
/// The exponent bits of an `f32`.
const EXPONENT_BITS: u32 = 0x7f80_0000;

/// The kernel's push constants (16 bytes): one dispatch checks one buffer.
#[repr(C)]
#[derive(Clone, Copy, Debug, Default, PartialEq, Eq, Pod, Zeroable)]
pub struct FiniteCheckPush {
    /// Words of the buffer to check (the kernel also stops at the binding's length).
    pub word_count: u32,
    /// Words per record, 1 to [`MAX_RECORD_WORDS`] (0 counts as 1).
    pub record_words: u32,
    /// Bit `i` set: word `i` of every record is an `f32`.
    pub float_mask: u32,
    /// Word of the count buffer the dispatch adds its count to.
    pub slot: u32,
}

/// Whether the `f32` with bits `bits` is NaN or ±∞.
#[inline]
pub fn is_non_finite_bits(bits: u32) -> bool {
    bits & EXPONENT_BITS == EXPONENT_BITS
}

/// Whether word `index` of the buffer `push` describes is an `f32`.
#[inline]
pub fn is_float_word(push: &FiniteCheckPush, index: u32) -> bool {
    let record = min_u32(max_u32(push.record_words, 1), MAX_RECORD_WORDS);
    (push.float_mask >> (index % record)) & 1 != 0
}

/// Whether word `index`, holding `bits`, is a non-finite `f32`.
#[inline]
pub fn counts_as_non_finite(push: &FiniteCheckPush, index: u32, bits: u32) -> bool {
    is_float_word(push, index) && is_non_finite_bits(bits)
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn bits_and_masks() {
        for x in [f32::NAN, f32::INFINITY, f32::NEG_INFINITY, -f32::NAN] {
            assert!(is_non_finite_bits(x.to_bits()), "{x}");
        }
        for x in [
            0.0f32,
            -0.0,
            1.0,
            f32::MAX,
            f32::MIN,
            f32::MIN_POSITIVE,
            1e-45,
        ] {
            assert!(!is_non_finite_bits(x.to_bits()), "{x}");
        }
        // Words 0 and 2 of 3-word records are floats: u32::MAX in word 1 is not counted.
        let push = FiniteCheckPush {
            word_count: 6,
            record_words: 3,
            float_mask: 0b101,
            slot: 0,
        };
        let words = [
            f32::NAN.to_bits(),
            u32::MAX,
            1.0f32.to_bits(),
            0,
            u32::MAX,
            f32::INFINITY.to_bits(),
        ];
        let counted: Vec<bool> = (0..6)
            .map(|i| counts_as_non_finite(&push, i, words[i as usize]))
            .collect();
        assert_eq!(counted, [true, false, false, false, false, true]);
        // Degenerate record sizes are clamped, not divided by.
        let zero = FiniteCheckPush {
            record_words: 0,
            float_mask: 1,
            ..push
        };
        assert!((0..4).all(|i| is_float_word(&zero, i)));
        let wide = FiniteCheckPush {
            record_words: 99,
            float_mask: 1 << 31,
            ..push
        };
        assert!(is_float_word(&wide, 31) && is_float_word(&wide, 63) && !is_float_word(&wide, 32));
    }
}
