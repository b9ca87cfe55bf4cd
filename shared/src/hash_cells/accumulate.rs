//! Per-frame accumulation of radiance samples into mip-0 cells: each cell owns
//! [`ACCUMULATOR_WORDS`] words of the flat accumulator buffer, `r`, `g`, `b` as 64-bit fixed point
//! ([`crate::fixed_point`]) and the samples' weight in [`SAMPLE_WEIGHT_ONE`]ths, added with
//! atomics in any order to the same bits.
//!
//! A sample weighs the inverse of how much more often than uniformly its ray was drawn
//! ([`sample_weight`]): guided probe rays favour bright directions, and a cell that straddles
//! light and shadow would otherwise average mostly its lit part and hand that to the rays that
//! land in its dark part, whose guided estimates weigh the most.
//!
//! Non-finite samples (a NaN or infinite channel) are dropped whole, not counted, so they cannot
//! poison a cell; [`accumulate_sample`] reports them for a statistics counter. Finite negative
//! channels count as 0 and channels above [`crate::fixed_point::MAX_SAMPLE`] are clamped to it.

use glam::Vec3;

use super::TILE_CELL_RATIO;
use super::layout::{
    ACCUMULATOR_WORDS, HashCellAccumulator, MAX_SAMPLE_WEIGHT, SAMPLE_WEIGHT_ONE,
    TILE_ACCUMULATOR_WORDS, TREND_WORD,
};
use crate::atomics::AtomicWords;
use crate::fixed_point;
use crate::math::{clamp, min_u32};

/// The count-word weight of a sample whose ray was drawn `density` times as often as uniform
/// sampling would draw it (1: uniform; a guided probe ray: 64 × its cell's probability): the
/// inverse, rounded to sixteenths, within 1/16 and [`MAX_SAMPLE_WEIGHT`]; a density that is not a
/// positive finite number weighs one sample.
#[inline]
pub fn sample_weight(density: f32) -> u32 {
    if !(density > 0.0 && density.is_finite()) {
        return SAMPLE_WEIGHT_ONE;
    }
    let w = SAMPLE_WEIGHT_ONE as f32 / density + 0.5;
    clamp(w, 1.0, MAX_SAMPLE_WEIGHT as f32) as u32
}

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

/// Adds one radiance sample of weight `weight` ([`sample_weight`]; [`SAMPLE_WEIGHT_ONE`] for an
/// unweighted sample) to mip-0 cell `cell` of tile `tile`; false (and nothing written) when the
/// sample is not finite.
#[inline]
pub fn accumulate_sample<W: AtomicWords + ?Sized>(
    accumulators: &mut W,
    tile: u32,
    cell: [u32; 2],
    radiance: Vec3,
    weight: u32,
) -> bool {
    if !radiance.is_finite() {
        return false;
    }
    let base = accumulator_word(tile, cell);
    let weighted = if weight == SAMPLE_WEIGHT_ONE {
        radiance
    } else {
        radiance * (weight as f32 * (1.0 / SAMPLE_WEIGHT_ONE as f32))
    };
    fixed_point::atomic_add(accumulators, base, weighted.x);
    fixed_point::atomic_add(accumulators, base + 2, weighted.y);
    fixed_point::atomic_add(accumulators, base + 4, weighted.z);
    accumulators.fetch_add(base + HashCellAccumulator::COUNT_WORD, weight);
    true
}

/// The samples' weight (in [`SAMPLE_WEIGHT_ONE`]ths) of the accumulator whose first word is `base`: one load, so passes skip the
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
    fn sample_weights_invert_the_density_within_their_bounds() {
        assert_eq!(sample_weight(1.0), SAMPLE_WEIGHT_ONE);
        assert_eq!(sample_weight(0.25), 4 * SAMPLE_WEIGHT_ONE);
        assert_eq!(sample_weight(4.0), SAMPLE_WEIGHT_ONE / 4);
        // Rounded to sixteenths, at least one sixteenth, at most MAX_SAMPLE_WEIGHT.
        assert_eq!(sample_weight(3.0), 5);
        assert_eq!(sample_weight(1e6), 1);
        assert_eq!(sample_weight(1e-6), MAX_SAMPLE_WEIGHT);
        assert_eq!(sample_weight(f32::MIN_POSITIVE / 4.0), MAX_SAMPLE_WEIGHT);
        for bad in [0.0, -1.0, f32::NAN, f32::INFINITY, f32::NEG_INFINITY] {
            assert_eq!(sample_weight(bad), SAMPLE_WEIGHT_ONE, "{bad}");
        }
    }

    /// Weighted samples give the weighted mean, whatever order they arrive in.
    #[test]
    fn weighted_samples_average_by_their_weights() {
        let base = accumulator_word(0, [1, 1]);
        let samples = [
            (Vec3::splat(8.0), 4),
            (Vec3::splat(1.0), 64),
            (Vec3::ZERO, 16),
        ];
        let mut orders = [[0, 1, 2], [2, 1, 0], [1, 2, 0]].map(|order| {
            let mut acc = vec![0u32; TILE_ACCUMULATOR_WORDS];
            for i in order {
                let (r, w) = samples[i];
                assert!(accumulate_sample(&mut acc[..], 0, [1, 1], r, w));
            }
            load_accumulator(&acc[..], base)
        });
        let first = orders[0];
        assert!(orders.iter_mut().all(|a| *a == first));
        assert_eq!(first.samples(), 84.0 / 16.0);
        let expected = (8.0 * 4.0 + 64.0) / 84.0;
        assert!((first.mean() - Vec3::splat(expected)).abs().max_element() < 1e-6);
    }

    #[test]
    fn samples_add_up_and_bad_ones_are_dropped() {
        let mut acc = vec![0u32; 2 * TILE_ACCUMULATOR_WORDS];
        let a: &mut [u32] = &mut acc;
        assert_eq!(accumulator_word(1, [2, 3]), 64 * 7 + 1 + (2 + 24) * 7);
        assert_eq!(trend_word(1), 2 * 64 * 7 + 1);
        assert_eq!(accumulator_word(0, [9, 9]), 63 * 7);
        assert!(accumulate_sample(
            a,
            1,
            [2, 3],
            Vec3::new(1.0, 2.0, 3.0),
            SAMPLE_WEIGHT_ONE
        ));
        assert!(accumulate_sample(
            a,
            1,
            [2, 3],
            Vec3::new(0.5, -1.0, 1e12),
            SAMPLE_WEIGHT_ONE
        ));
        for bad in [f32::NAN, f32::INFINITY, f32::NEG_INFINITY] {
            assert!(!accumulate_sample(
                a,
                1,
                [2, 3],
                Vec3::new(1.0, bad, 1.0),
                SAMPLE_WEIGHT_ONE
            ));
        }
        let base = accumulator_word(1, [2, 3]);
        let loaded = load_accumulator(a, base);
        assert_eq!(loaded.samples(), 2.0);
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
