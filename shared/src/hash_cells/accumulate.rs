//! Per-frame accumulation of radiance samples into mip-0 cells: each cell owns
//! [`ACCUMULATOR_WORDS`] words of the flat accumulator buffer, `r`, `g`, `b` as 64-bit fixed point
//! ([`crate::fixed_point`]) and a sample count, added with atomics in any order to the same bits.
//!
//! Non-finite samples (a NaN or infinite channel) are dropped whole, not counted, so they cannot
//! poison a cell; [`accumulate_sample`] reports them for a statistics counter. Finite negative
//! channels count as 0 and channels above [`crate::fixed_point::MAX_SAMPLE`] are clamped to it.

use glam::Vec3;

use super::TILE_CELL_RATIO;
use super::layout::{ACCUMULATOR_WORDS, HashCellAccumulator, TILE_ACCUMULATOR_WORDS, TREND_WORD};
use crate::atomics::AtomicWords;
use crate::fixed_point;
use crate::math::min_u32;

/// First accumulator word of mip-0 cell `cell` (`[x, y]`, each clamped to 0..8) of tile `tile`.
#[inline]
pub fn accumulator_word(tile: u32, cell: [u32; 2]) -> usize {
    let last = TILE_CELL_RATIO - 1;
    let x = min_u32(cell[0], last);
    let y = min_u32(cell[1], last);
    tile as usize * TILE_ACCUMULATOR_WORDS + (x + y * TILE_CELL_RATIO) as usize * ACCUMULATOR_WORDS
}

/// The luminance-trend word of tile `tile` ([`super::adaptive_blend`]), after its cells' words.
#[inline]
pub fn trend_word(tile: u32) -> usize {
    tile as usize * TILE_ACCUMULATOR_WORDS + TREND_WORD
}

/// Adds one radiance sample to mip-0 cell `cell` of tile `tile`; false (and nothing written) when
/// the sample is not finite.
#[inline]
pub fn accumulate_sample<W: AtomicWords + ?Sized>(
    accumulators: &mut W,
    tile: u32,
    cell: [u32; 2],
    radiance: Vec3,
) -> bool {
    if !radiance.is_finite() {
        return false;
    }
    let base = accumulator_word(tile, cell);
    fixed_point::atomic_add(accumulators, base, radiance.x);
    fixed_point::atomic_add(accumulators, base + 2, radiance.y);
    fixed_point::atomic_add(accumulators, base + 4, radiance.z);
    accumulators.fetch_add(base + HashCellAccumulator::COUNT_WORD, 1);
    true
}

/// The sample count of the accumulator whose first word is `base`: one load, so passes skip the
/// sums of cells that got no sample.
#[inline]
pub fn accumulator_count<W: AtomicWords + ?Sized>(accumulators: &W, base: usize) -> u32 {
    accumulators.load(base + HashCellAccumulator::COUNT_WORD)
}

/// The accumulator whose first word is `base` (see [`accumulator_word`]), loaded by value.
#[inline]
pub fn load_accumulator<W: AtomicWords + ?Sized>(
    accumulators: &W,
    base: usize,
) -> HashCellAccumulator {
    HashCellAccumulator {
        r: fixed_point::load(accumulators, base),
        g: fixed_point::load(accumulators, base + 2),
        b: fixed_point::load(accumulators, base + 4),
        count: accumulator_count(accumulators, base),
    }
}

/// Zeroes the accumulator whose first word is `base`, for the next frame.
#[inline]
pub fn clear_accumulator<W: AtomicWords + ?Sized>(accumulators: &mut W, base: usize) {
    let mut i = 0;
    while i < ACCUMULATOR_WORDS {
        accumulators.store(base + i, 0);
        i += 1;
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn samples_add_up_and_bad_ones_are_dropped() {
        let mut acc = vec![0u32; 2 * TILE_ACCUMULATOR_WORDS];
        let a: &mut [u32] = &mut acc;
        assert_eq!(accumulator_word(1, [2, 3]), 64 * 7 + 1 + (2 + 24) * 7);
        assert_eq!(trend_word(1), 2 * 64 * 7 + 1);
        assert_eq!(accumulator_word(0, [9, 9]), 63 * 7);
        assert!(accumulate_sample(a, 1, [2, 3], Vec3::new(1.0, 2.0, 3.0)));
        assert!(accumulate_sample(a, 1, [2, 3], Vec3::new(0.5, -1.0, 1e12)));
        for bad in [f32::NAN, f32::INFINITY, f32::NEG_INFINITY] {
            assert!(!accumulate_sample(a, 1, [2, 3], Vec3::new(1.0, bad, 1.0)));
        }
        let base = accumulator_word(1, [2, 3]);
        let loaded = load_accumulator(a, base);
        assert_eq!(loaded.count, 2);
        assert_eq!(
            loaded.radiance_sum(),
            Vec3::new(1.5, 2.0, 3.0 + fixed_point::MAX_SAMPLE)
        );
        // Only this cell's seven words changed.
        let nonzero: Vec<usize> = (0..acc.len()).filter(|&i| acc[i] != 0).collect();
        assert!(nonzero.iter().all(|&i| (base..base + 7).contains(&i)));
        clear_accumulator(&mut acc[..], base);
        assert!(acc.iter().all(|&w| w == 0));
    }
}
