//! Per-frame sums that never saturate: non-negative `f32` samples in 64-bit fixed point, kept as two
//! `u32` words `(lo, hi)` and added with two 32-bit atomic adds plus a carry.
//!
//! A sample is scaled by `2^FRACTION_BITS` (exact: a power of two) and rounded to the nearest
//! integer, which is split exactly into `hi = floor(s / 2^32)` and `lo = s − hi · 2^32` (both exact
//! in `f32`). Integer addition is associative, so the sum is exact and does not depend on the order
//! of the adds: the GPU and the CPU end with bit-identical words for the same set of samples.
//!
//! Limits (value units, e.g. radiance or metres):
//! - resolution: [`RESOLUTION`] = 2^-20 ≈ 9.5 · 10⁻⁷ (each sample is rounded to a multiple of it,
//!   so a sample of 10⁻³ is off by at most 0.05 %);
//! - one sample: clamped to [`MAX_SAMPLE`] = 2^31 ≈ 2.1 · 10⁹ (covers 10⁴ radiance, 10⁷ m scene
//!   extents and the 10⁹ m "miss" distance); negative values and NaN count as 0;
//! - a sum: at most [`MAX_TOTAL`] = 2^44 ≈ 1.76 · 10¹³ before the 64-bit integer wraps, e.g.
//!   1.7 · 10⁹ samples of 10⁴, 1.7 · 10⁶ samples of 10⁷ or 8192 samples at the clamp.

use crate::atomics::AtomicWords;
use crate::math::{floor, to_u32_clamped};

/// Fraction bits of the fixed-point format.
pub const FRACTION_BITS: u32 = 20;
/// `2^FRACTION_BITS`: one value unit in fixed-point steps.
pub const SCALE: f32 = (1u32 << FRACTION_BITS) as f32;
/// Smallest step: `2^-FRACTION_BITS`.
pub const RESOLUTION: f32 = 1.0 / SCALE;
/// `log2` of the per-sample clamp.
pub const MAX_SAMPLE_LOG2: u32 = 31;
/// Largest value one sample adds (`2^31`); larger samples and `+∞` are clamped to it.
pub const MAX_SAMPLE: f32 = (1u64 << MAX_SAMPLE_LOG2) as f32;
/// Largest exact sum: `2^(64 − FRACTION_BITS)` value units, beyond which the 64-bit integer wraps.
pub const MAX_TOTAL: f32 = (1u64 << (64 - FRACTION_BITS)) as f32;

// A clamped sample must leave room for many more in the 64-bit sum.
const _: () = assert!(MAX_SAMPLE_LOG2 + FRACTION_BITS <= 52);

/// `2^32` as an `f32`.
const TWO_POW_32: f32 = 4_294_967_296.0;

/// The fixed-point words `[lo, hi]` of one sample: `round(clamp(x, 0, MAX_SAMPLE) · 2^20)` (ties
/// up). NaN and negative values give 0.
#[inline]
pub fn encode(x: f32) -> [u32; 2] {
    // NaN fails `x > 0`.
    let x = if x > 0.0 { x } else { 0.0 };
    let x = if x < MAX_SAMPLE { x } else { MAX_SAMPLE };
    let s = x * SCALE;
    // s < 2^51: hi fits easily, and hi · 2^32 ≤ s makes the remainder exact and in [0, 2^32).
    let hi = floor(s * (1.0 / TWO_POW_32));
    let rem = s - hi * TWO_POW_32;
    let whole = floor(rem);
    // The fraction is exact; it is non-zero only when rem < 2^23, so `+ 1` never reaches 2^32.
    let round_up = if rem - whole >= 0.5 { 1 } else { 0 };
    [to_u32_clamped(whole) + round_up, to_u32_clamped(hi)]
}

/// The value of fixed-point words `[lo, hi]` (rounded to `f32`, within about 1 ulp).
#[inline]
pub fn decode(words: [u32; 2]) -> f32 {
    (words[1] as f32 * TWO_POW_32 + words[0] as f32) * RESOLUTION
}

/// `a + b` on fixed-point words, wrapping at 2^64 like the atomic version.
#[inline]
pub fn add_words(a: [u32; 2], b: [u32; 2]) -> [u32; 2] {
    let lo = a[0].wrapping_add(b[0]);
    let carry = if lo < a[0] { 1 } else { 0 };
    [lo, a[1].wrapping_add(b[1]).wrapping_add(carry)]
}

/// Atomically adds sample `x` (see [`encode`]) to the sum in words `lo_index` (low word) and
/// `lo_index + 1` (high word). Concurrent adds commute; a reader must wait until every add is done
/// (the next pass), since the two words are updated one after the other.
#[inline]
pub fn atomic_add<W: AtomicWords + ?Sized>(words: &mut W, lo_index: usize, x: f32) {
    let [lo, hi] = encode(x);
    let old = words.fetch_add(lo_index, lo);
    // The low word wrapped iff the new value is below the old one.
    let carry = if old.wrapping_add(lo) < old { 1 } else { 0 };
    let high = hi + carry;
    // Most samples are below 2^12 and have nothing to carry: skip the second atomic.
    if high != 0 {
        words.fetch_add(lo_index + 1, high);
    }
}

/// The sum in words `lo_index` and `lo_index + 1`.
#[inline]
pub fn load<W: AtomicWords + ?Sized>(words: &W, lo_index: usize) -> [u32; 2] {
    [words.load(lo_index), words.load(lo_index + 1)]
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::hash_cells::shared_words::SharedWords;
    use crate::random::Random;
    use core::sync::atomic::AtomicU32;

    fn as_u64(w: [u32; 2]) -> u64 {
        u64::from(w[0]) | (u64::from(w[1]) << 32)
    }

    #[test]
    fn constants() {
        assert_eq!(SCALE, 1_048_576.0);
        assert_eq!(MAX_SAMPLE, 2_147_483_648.0);
        assert_eq!(MAX_TOTAL, 17_592_186_044_416.0);
        const { assert!(MAX_TOTAL > 1e13) };
    }

    #[test]
    fn encode_is_exact_rounding() {
        assert_eq!(encode(1.0), [1 << 20, 0]);
        assert_eq!(encode(0.0), [0, 0]);
        assert_eq!(encode(-5.0), [0, 0]);
        assert_eq!(encode(f32::NAN), [0, 0]);
        assert_eq!(encode(f32::NEG_INFINITY), [0, 0]);
        assert_eq!(encode(f32::INFINITY), [0, 1 << 19]);
        assert_eq!(encode(1e30), encode(MAX_SAMPLE));
        assert_eq!(as_u64(encode(MAX_SAMPLE)), 1 << 51);
        // 10⁷ m: an integer, exact.
        assert_eq!(as_u64(encode(1e7)), 10_000_000 << 20);
        assert_eq!(decode(encode(1e7)), 1e7);
        // Half a step rounds up, less rounds down.
        assert_eq!(encode(RESOLUTION * 0.5), [1, 0]);
        assert_eq!(encode(RESOLUTION * 0.499), [0, 0]);
        // Random values: the integer is the correctly rounded f64 product.
        let mut rng = Random::new(7, 0);
        for _ in 0..100_000 {
            let x = 10f32.powf(rng.next_f32() * 16.0 - 7.0);
            let exact = f64::from(x) * f64::from(SCALE);
            let q = as_u64(encode(x));
            assert!((q as f64 - exact).abs() <= 0.5, "{x}");
            let back = decode(encode(x));
            assert!(
                (back - x).abs() <= RESOLUTION * 0.5 + x * 2.0 * f32::EPSILON,
                "{x}"
            );
        }
    }

    #[test]
    fn tiny_values_keep_their_resolution() {
        let x = 1e-3f32;
        let mut sum = [0u32; 2];
        for _ in 0..1000 {
            sum = add_words(sum, encode(x));
        }
        // Every sample is off by at most half a step: 0.05 % of 10⁻³.
        assert!((decode(sum) - 1.0).abs() <= 1000.0 * RESOLUTION * 0.5);
        assert!((decode(encode(x)) - x).abs() / x < 5e-4);
    }

    #[test]
    fn sums_of_2_pow_20_samples_of_1e4_are_exact() {
        let mut words = [0u32; 2];
        let n = 1u32 << 20;
        for _ in 0..n {
            atomic_add(&mut words[..], 0, 1e4);
        }
        let expected = 1e4f64 * f64::from(n);
        assert_eq!(as_u64(words) as f64, expected * f64::from(SCALE));
        assert!((f64::from(decode(words)) - expected).abs() <= expected * 1.2e-7);
    }

    #[test]
    fn distances_of_1e7_sum_without_wrapping() {
        let mut words = [0u32; 2];
        for _ in 0..1_000_000 {
            atomic_add(&mut words[..], 0, 1e7);
        }
        assert_eq!(as_u64(words), 1_000_000u64 * (10_000_000 << 20));
        assert!((decode(words) - 1e13).abs() <= 1e13 * 1.2e-7);
    }

    #[test]
    fn carries_across_many_adds() {
        // Values whose low word alone wraps every few adds.
        let mut words = [0u32; 2];
        let mut expected = 0u64;
        let mut rng = Random::new(9, 0);
        for _ in 0..200_000 {
            let x = rng.next_f32() * 5000.0;
            expected += as_u64(encode(x));
            atomic_add(&mut words[..], 0, x);
            assert_eq!(as_u64(words), expected);
        }
        assert!(expected > 1 << 40);
    }

    #[test]
    fn order_independent_and_thread_safe() {
        let mut rng = Random::new(11, 0);
        let samples: Vec<f32> = (0..20_000)
            .map(|_| 10f32.powf(rng.next_f32() * 10.0 - 4.0))
            .collect();
        let mut forward = [0u32; 2];
        for &x in &samples {
            atomic_add(&mut forward[..], 0, x);
        }
        // A shuffled order (Fisher–Yates) gives the same words.
        let mut shuffled = samples.clone();
        for i in (1..shuffled.len()).rev() {
            let j = (rng.next_u32() as usize) % (i + 1);
            shuffled.swap(i, j);
        }
        let mut backward = [0u32; 2];
        for &x in &shuffled {
            atomic_add(&mut backward[..], 0, x);
        }
        assert_eq!(forward, backward);
        // And so do four threads adding concurrently.
        let words: Vec<AtomicU32> = (0..2).map(|_| AtomicU32::new(0)).collect();
        std::thread::scope(|s| {
            for chunk in shuffled.chunks(5000) {
                let mut view = SharedWords(&words);
                s.spawn(move || {
                    for &x in chunk {
                        atomic_add(&mut view, 0, x);
                    }
                });
            }
        });
        let shared = [words[0].load(SEQ), words[1].load(SEQ)];
        assert_eq!(shared, forward);
        let exact: f64 = samples
            .iter()
            .map(|&x| as_u64(encode(x)) as f64 / f64::from(SCALE))
            .sum();
        assert!((f64::from(decode(forward)) - exact).abs() <= exact * 2.4e-7);
    }

    const SEQ: core::sync::atomic::Ordering = core::sync::atomic::Ordering::SeqCst;
}
