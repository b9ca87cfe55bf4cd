//! The update pass, per tile touched this frame: blend each mip-0 cell's history with the frame's
//! accumulated samples, clear the accumulators, then rebuild mips 1–3 as sums of their four
//! children. One invocation per tile runs [`super::passes::update_pass`]: [`tile_blend_cap`], the
//! bounce copy, then [`blend_tile`]. Its parts are per cell, so a workgroup of 64 per tile could
//! run [`update_mip0_cell`] each, then (with a barrier between levels) [`update_mip_cell`] for
//! mips 1, 2 and 3 on the first 16, 4 and 1 invocations (a test checks it gives the same bits).
//!
//! Blend: with history mean `m` over `c0` samples and `k` new samples of mean `a`, the new count
//! is `c = min(c0 + k, cap)` (the sample cap, 16 by default) and the mean is the running mean that
//! keeps the newest `c` samples' worth of weight: `(m · (c − k') + a · k') / c` with
//! `k' = min(k, cap)`. Below the cap this is the exact mean of all samples; at the cap the history
//! keeps weight `cap − k'`. For `k = 1` it equals
//! the reference's `lerp(m, a, 1/c)`; for `k > 1` the reference gives the `k` samples the weight
//! of one, this gives them `k`. A cell without samples (`k = 0`) is left unchanged, where the
//! reference decrements its count (so stale cells of a touched tile drifted to coarser mips).
//!
//! The weights may use a lower cap than the count ([`blend_cell`]'s `blend_cap`): the tile's
//! [adaptive blend](super::adaptive_blend) lowers it while the tile's lighting changes.
//!
//! # History that fades with time
//!
//! A cap counts samples, however old: a cell that one probe ray in ten reaches keeps sixteen
//! samples spanning 160 frames. Multi-bounce compounds that age, since each bounce reads cells
//! as old as their samples: the light of a room lit mostly by bounces (the Bitterli staircase,
//! 44% of it direct) rose for over 700 frames. With `history_frames` `H > 0`, each update of a
//! tile first weighs every mip-0 cell's history `1 − 1/H` ([`history_keep`]), sample or not
//! ([`decayed`]), so a
//! history spans about `H` updates at most and a further bounce arrives within about `H` frames.
//! The mean is kept, the count falls: a cell without recent samples reads its parent mip
//! ([`super::read`]).

use super::accumulate::{
    accumulator_count, accumulator_word, clear_accumulator, load_accumulator, trend_word,
};
use super::adaptive_blend::{PooledChange, TileTrend, blend_cap, frame_change};
use super::layout::{HashCellAccumulator, HashCellValue};
use super::{BOUNCE_HISTORY_FRAMES, MIP0_CELLS_PER_TILE, NUM_MIPS, TILE_CELL_RATIO, cell_index};
use crate::atomics::AtomicWords;
use crate::math::{clamp, max, max_u32, min, min_u32};
use glam::Vec4;

/// `(rgb · n, n)` stored as a running mean's value in frame `frame`, rounded once per update
/// with [`crate::packing::running_mean_dither`] so that it keeps following a slow change (rounded
/// to nearest, a GI furnace of albedo 0.8 read 0.65 points darker).
#[inline]
pub fn stored_value(value: Vec4, frame: u32) -> HashCellValue {
    let dither = crate::packing::running_mean_dither(value, frame);
    HashCellValue::new_dithered(value.truncate(), value.w, dither)
}

/// A mip-0 cell's new value `(rgb · n, n)` from its old value and the frame's accumulator (see
/// the module documentation for the weights). The count grows to `cap`; the weights cap the
/// history at `blend_cap` (at most `cap`, at least 1) instead where that is lower.
#[inline]
pub fn blend_cell(old: Vec4, acc: HashCellAccumulator, cap: u32, blend_cap: f32) -> Vec4 {
    if acc.count == 0 {
        return old;
    }
    let cap_count = max_u32(cap, 1);
    let cap = cap_count as f32;
    let k = acc.samples();
    let k_kept = min(k, cap);
    // Mip-0 counts lie in 0..=cap; the clamp also turns a NaN count into 0.
    let c0 = clamp(old.w, 0.0, cap);
    let c = min(c0 + k_kept, cap);
    // The clamp also reads a NaN cap as 1 (no history).
    let weights = min(c0 + k_kept, clamp(blend_cap, 1.0, cap));
    let history_weight = max(weights - k_kept, 0.0);
    let total = history_weight + k_kept;
    // Unit scales are written out: divisions need not be exact on the GPU, `x / x` included.
    let history_scale = if c0 <= 0.0 {
        0.0
    } else if history_weight == c0 {
        1.0
    } else {
        history_weight / c0
    };
    let new_scale = if k_kept == k { 1.0 } else { k_kept / k };
    let sum = old.truncate() * history_scale + acc.radiance_sum() * new_scale;
    // The mean of `total` weights, stored with the count `c`.
    let sum = if total == c { sum } else { sum * (c / total) };
    sum.extend(c)
}

/// The weight an update gives a cell's history: `1 − 1/history_frames`, or 1 (no fading) for 0.
#[inline]
pub fn history_keep(history_frames: u32) -> f32 {
    if history_frames == 0 {
        1.0
    } else {
        1.0 - 1.0 / history_frames as f32
    }
}

/// `value` (`(rgb · n, n)`) with its history weighed `keep` ([`history_keep`]; unchanged for an
/// empty cell): the mean is kept, the count falls.
#[inline]
pub fn decayed(value: Vec4, keep: f32) -> Vec4 {
    if keep >= 1.0 || value.w <= 0.0 {
        return value;
    }
    value * keep
}

/// Blends mip-0 cell `cell` (`x + 8 · y`, in 0..64) of tile `tile`, its history [`decayed`] by
/// `keep` ([`history_keep`], computed once per tile), with its accumulator ([`blend_cell`],
/// weights capped at `blend_cap`) and clears the accumulator; stored for frame `frame`
/// ([`stored_value`]).
#[inline]
#[allow(
    clippy::too_many_arguments,
    reason = "the cell, its tile's blend and the frame, as the update pass holds them"
)]
pub fn update_mip0_cell<W: AtomicWords + ?Sized>(
    values: &mut [HashCellValue],
    accumulators: &mut W,
    tile: u32,
    cell: u32,
    cap: u32,
    blend_cap: f32,
    keep: f32,
    frame: u32,
) {
    let cell = min_u32(cell, MIP0_CELLS_PER_TILE - 1);
    let xy = [cell % TILE_CELL_RATIO, cell / TILE_CELL_RATIO];
    let index = cell_index(tile, 0, xy[0], xy[1]) as usize;
    let base = accumulator_word(tile, xy);
    let old = decayed(values[index].sum_and_count(), keep);
    if accumulator_count(accumulators, base) != 0 {
        let acc = load_accumulator(accumulators, base);
        values[index] = stored_value(blend_cell(old, acc, cap, blend_cap), frame);
        clear_accumulator(accumulators, base);
    } else if keep < 1.0 && old.w > 0.0 {
        values[index] = stored_value(old, frame);
    }
}

/// Cells of mip `mip` (64, 16, 4, 1; mip clamped to 3).
#[inline]
pub fn mip_cell_count(mip: u32) -> u32 {
    let side = TILE_CELL_RATIO >> min_u32(mip, NUM_MIPS - 1);
    side * side
}

/// Cell `(x, y)` of mip `mip ≥ 1` as the sum of its four children in mip `mip − 1`, added in a
/// fixed order (so every invocation layout gives the same bits) and stored once, rounded to
/// nearest. Mip 0 reads the cell itself.
#[inline]
pub fn mip_cell(values: &[HashCellValue], tile: u32, mip: u32, x: u32, y: u32) -> HashCellValue {
    if mip == 0 {
        return values[cell_index(tile, 0, x, y) as usize];
    }
    let child = min_u32(mip, NUM_MIPS - 1) - 1;
    let (cx, cy) = (2 * x, 2 * y);
    let sum = values[cell_index(tile, child, cx, cy) as usize].sum_and_count()
        + values[cell_index(tile, child, cx + 1, cy) as usize].sum_and_count()
        + values[cell_index(tile, child, cx, cy + 1) as usize].sum_and_count()
        + values[cell_index(tile, child, cx + 1, cy + 1) as usize].sum_and_count();
    HashCellValue::new(sum.truncate(), sum.w)
}

/// Writes cell `cell` (`x + side · y`) of mip `mip` (1..=3) of tile `tile` from its children
/// ([`mip_cell`]); the finer mip must be complete.
#[inline]
pub fn update_mip_cell(values: &mut [HashCellValue], tile: u32, mip: u32, cell: u32) {
    let side = TILE_CELL_RATIO >> min_u32(mip, NUM_MIPS - 1);
    let (x, y) = (cell % side, cell / side);
    let value = mip_cell(values, tile, mip, x, y);
    values[cell_index(tile, mip, x, y) as usize] = value;
}

/// The cap of tile `tile`'s blend weights this frame ([`super::adaptive_blend`]): with
/// `adaptive`, from its luminance trend updated with the frame's change pooled over its mip-0
/// cells (and stored back); without, `cap`. Reads the accumulators before [`update_mip0_cell`]
/// clears them.
#[inline]
pub fn tile_blend_cap<W: AtomicWords + ?Sized>(
    values: &[HashCellValue],
    accumulators: &mut W,
    tile: u32,
    cap: u32,
    adaptive: bool,
) -> f32 {
    let cap = max_u32(cap, 1) as f32;
    if !adaptive {
        return cap;
    }
    let mut pooled = PooledChange::default();
    let mut cell = 0;
    while cell < MIP0_CELLS_PER_TILE {
        let xy = [cell % TILE_CELL_RATIO, cell / TILE_CELL_RATIO];
        let base = accumulator_word(tile, xy);
        if accumulator_count(accumulators, base) != 0 {
            let acc = load_accumulator(accumulators, base);
            let old = values[cell_index(tile, 0, xy[0], xy[1]) as usize];
            pooled = frame_change(pooled, acc.mean(), acc.samples(), old.mean(), old.count());
        }
        cell += 1;
    }
    let word = trend_word(tile);
    let trend = TileTrend::unpack(accumulators.load(word)).update(pooled);
    accumulators.store(word, trend.pack());
    blend_cap(cap, trend, pooled.samples)
}

/// Tile `tile`'s 64 mip-0 blends with weights capped at `blend_cap` (clearing the accumulators),
/// then mips 1, 2, 3; stored for frame `frame` ([`stored_value`]).
#[inline]
pub fn blend_tile<W: AtomicWords + ?Sized>(
    values: &mut [HashCellValue],
    accumulators: &mut W,
    tile: u32,
    cap: u32,
    blend_cap: f32,
    history_frames: u32,
    frame: u32,
) {
    let keep = history_keep(history_frames);
    let mut cell = 0;
    while cell < MIP0_CELLS_PER_TILE {
        update_mip0_cell(
            values,
            accumulators,
            tile,
            cell,
            cap,
            blend_cap,
            keep,
            frame,
        );
        cell += 1;
    }
    update_mips(values, tile);
}

/// Mips 1, 2, 3 of tile `tile` from its mip-0 cells.
#[inline]
fn update_mips(values: &mut [HashCellValue], tile: u32) {
    let mut mip = 1;
    while mip < NUM_MIPS {
        let mut cell = 0;
        while cell < mip_cell_count(mip) {
            update_mip_cell(values, tile, mip, cell);
            cell += 1;
        }
        mip += 1;
    }
}

/// Multi-bounce's bounce copy of tile `tile` (`bounce`, laid out as `values`): each mip-0 cell
/// blended with the frame's accumulator like the cell itself (weights capped at `blend_cap`), but
/// its history fading over [`BOUNCE_HISTORY_FRAMES`] updates, then its mips. Runs before
/// [`blend_tile`] changes `values` or clears the accumulators: a cell that had no history in
/// `values` (a tile just inserted, a cell never sampled) starts its copy over, so no copy outlives
/// its tile. Stored for frame `frame` ([`stored_value`]).
#[inline]
pub fn update_bounce_copy<W: AtomicWords + ?Sized>(
    bounce: &mut [HashCellValue],
    values: &[HashCellValue],
    accumulators: &W,
    tile: u32,
    cap: u32,
    blend_cap: f32,
    frame: u32,
) {
    let keep = history_keep(BOUNCE_HISTORY_FRAMES);
    let mut cell = 0;
    while cell < MIP0_CELLS_PER_TILE {
        let xy = [cell % TILE_CELL_RATIO, cell / TILE_CELL_RATIO];
        let index = cell_index(tile, 0, xy[0], xy[1]) as usize;
        let old = if values[index].count() > 0.0 {
            decayed(bounce[index].sum_and_count(), keep)
        } else {
            Vec4::ZERO
        };
        let base = accumulator_word(tile, xy);
        let new = if accumulator_count(accumulators, base) != 0 {
            blend_cell(old, load_accumulator(accumulators, base), cap, blend_cap)
        } else {
            old
        };
        bounce[index] = stored_value(new, frame);
        cell += 1;
    }
    update_mips(bounce, tile);
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::fixed_point;
    use crate::hash_cells::CELLS_PER_TILE;
    use crate::hash_cells::MAX_SAMPLE_COUNT;
    use crate::hash_cells::accumulate::accumulate_sample;
    use crate::hash_cells::layout::SAMPLE_WEIGHT_ONE as ONE;
    use crate::hash_cells::layout::TILE_ACCUMULATOR_WORDS;
    use glam::Vec3;

    fn acc(sum: Vec3, count: u32) -> HashCellAccumulator {
        HashCellAccumulator {
            r: fixed_point::encode(sum.x),
            g: fixed_point::encode(sum.y),
            b: fixed_point::encode(sum.z),
            count: count * ONE,
        }
    }

    /// [`blend_cell`] on stored values, rounded to nearest.
    fn blend(
        old: HashCellValue,
        acc: HashCellAccumulator,
        cap: u32,
        blend_cap: f32,
    ) -> HashCellValue {
        let v = blend_cell(old.sum_and_count(), acc, cap, blend_cap);
        HashCellValue::new(v.truncate(), v.w)
    }

    /// The blend with the fixed cap.
    fn fixed(old: HashCellValue, acc: HashCellAccumulator, cap: u32) -> HashCellValue {
        blend(old, acc, cap, cap as f32)
    }

    std::thread_local! {
        static FRAME: core::cell::Cell<u32> = const { core::cell::Cell::new(0) };
    }

    /// The next frame index of this test's updates (each test runs on its own thread), so that
    /// the dithers change from update to update as the renderer's do.
    fn next_frame() -> u32 {
        FRAME.with(|f| {
            f.set(f.get() + 1);
            f.get()
        })
    }

    /// The update of one tile without a bounce copy: its blend cap, then [`blend_tile`].
    fn update_tile<W: AtomicWords + ?Sized>(
        values: &mut [HashCellValue],
        accumulators: &mut W,
        tile: u32,
        cap: u32,
        adaptive: bool,
        history_frames: u32,
    ) {
        let blend_cap = tile_blend_cap(values, accumulators, tile, cap, adaptive);
        blend_tile(
            values,
            accumulators,
            tile,
            cap,
            blend_cap,
            history_frames,
            next_frame(),
        );
    }

    /// Equal within the stored values' dithered rounding: up to a unit (2^-9) of the sum and one
    /// of the count.
    fn close(a: Vec3, b: Vec3) -> bool {
        let e = 4.0 * crate::packing::WIDE16_MAX_RELATIVE_ERROR;
        (a - b).abs().max_element() <= e * b.abs().max_element().max(1.0)
    }

    #[test]
    fn blend_weights() {
        let m = Vec3::new(1.0, 2.0, 4.0);
        let a = Vec3::new(3.0, 0.0, 0.5);
        // k = 0: unchanged (the reference would drop the count to 4).
        let old = HashCellValue::new(m * 5.0, 5.0);
        assert_eq!(fixed(old, acc(Vec3::ZERO, 0), MAX_SAMPLE_COUNT), old);
        // Empty history: the new samples' mean, count k.
        let v = fixed(HashCellValue::ZERO, acc(a * 3.0, 3), MAX_SAMPLE_COUNT);
        assert_eq!(v.count(), 3.0);
        assert!(close(v.mean(), a));
        // k = 1 below the cap: lerp(m, a, 1/c), as the reference.
        let v = fixed(old, acc(a, 1), MAX_SAMPLE_COUNT);
        assert_eq!(v.count(), 6.0);
        assert!(close(v.mean(), m + (a - m) / 6.0));
        // k = 1 at the cap: lerp(m, a, 1/16).
        let full = HashCellValue::new(m * 16.0, 16.0);
        let v = fixed(full, acc(a, 1), MAX_SAMPLE_COUNT);
        assert_eq!(v.count(), 16.0);
        assert!(close(v.mean(), m + (a - m) / 16.0));
        // k = 4 below the cap: the exact mean of 5 + 4 samples.
        let v = fixed(old, acc(a * 4.0, 4), MAX_SAMPLE_COUNT);
        assert_eq!(v.count(), 9.0);
        assert!(close(v.mean(), (m * 5.0 + a * 4.0) / 9.0));
        // k = 4 crossing the cap from 14: history keeps weight 12.
        let v = fixed(
            HashCellValue::new(m * 14.0, 14.0),
            acc(a * 4.0, 4),
            MAX_SAMPLE_COUNT,
        );
        assert_eq!(v.count(), 16.0);
        assert!(close(v.mean(), (m * 12.0 + a * 4.0) / 16.0));
        // k > 16: the history is replaced by the new mean.
        let v = fixed(full, acc(a * 40.0, 40), MAX_SAMPLE_COUNT);
        assert_eq!(v.count(), 16.0);
        assert!(close(v.mean(), a));
        // A corrupt count is treated as empty history.
        let nan = HashCellValue::new(m, f32::NAN);
        assert!(close(fixed(nan, acc(a, 1), MAX_SAMPLE_COUNT).mean(), a));
        // Another cap: 4 keeps a quarter of the weight per new sample; 0 reads as 1.
        let v = fixed(HashCellValue::new(m * 4.0, 4.0), acc(a, 1), 4);
        assert_eq!(v.count(), 4.0);
        assert!(close(v.mean(), m + (a - m) / 4.0));
        let v = fixed(old, acc(a * 2.0, 2), 0);
        assert_eq!(v.count(), 1.0);
        assert!(close(v.mean(), a));
    }

    #[test]
    fn a_lower_blend_cap_weighs_the_history_less_and_keeps_the_count() {
        let m = Vec3::new(1.0, 2.0, 4.0);
        let a = Vec3::new(3.0, 0.0, 0.5);
        let full = HashCellValue::new(m * 16.0, 16.0);
        // Cap 1: the new samples only, count still 16 (the read keeps its mip).
        let v = blend(full, acc(a, 1), MAX_SAMPLE_COUNT, 1.0);
        assert_eq!(v.count(), 16.0);
        assert!(close(v.mean(), a));
        // Cap 4: lerp(m, a, 1/4).
        let v = blend(full, acc(a, 1), MAX_SAMPLE_COUNT, 4.0);
        assert_eq!(v.count(), 16.0);
        assert!(close(v.mean(), m + (a - m) / 4.0));
        // More new samples than the blend cap: their mean.
        let v = blend(full, acc(a * 3.0, 3), MAX_SAMPLE_COUNT, 2.0);
        assert!(close(v.mean(), a));
        // A young cell below the blend cap: the exact mean, as with the fixed cap.
        let young = HashCellValue::new(m * 2.0, 2.0);
        assert_eq!(
            blend(young, acc(a, 1), MAX_SAMPLE_COUNT, 8.0),
            fixed(young, acc(a, 1), MAX_SAMPLE_COUNT)
        );
        // A blend cap above the cap, infinite or NaN is clamped into [1, cap].
        assert_eq!(
            blend(full, acc(a, 1), MAX_SAMPLE_COUNT, f32::INFINITY),
            fixed(full, acc(a, 1), MAX_SAMPLE_COUNT)
        );
        assert!(close(
            blend(full, acc(a, 1), MAX_SAMPLE_COUNT, f32::NAN).mean(),
            a
        ));
    }

    /// Every mip-0 cell of tile 0 gets `per_cell` samples of `radiance(frame, cell)`; then the
    /// tile updates. Returns the tile's mean radiance over its mip-0 cells.
    fn run_tile(
        values: &mut [HashCellValue],
        accs: &mut [u32],
        frame: u32,
        adaptive: bool,
        radiance: impl Fn(u32, u32) -> f32,
    ) -> f32 {
        for cell in 0..64 {
            let xy = [cell % 8, cell / 8];
            accumulate_sample(accs, 0, xy, Vec3::splat(radiance(frame, cell)), ONE);
        }
        update_tile(values, accs, 0, MAX_SAMPLE_COUNT, adaptive, 0);
        (0..64)
            .map(|c| values[cell_index(0, 0, c % 8, c / 8) as usize].mean().x)
            .sum::<f32>()
            / 64.0
    }

    #[test]
    fn a_fading_history_keeps_its_mean_and_lets_a_sparse_cell_follow_its_light() {
        // Cell 0 of a tile updated every frame holds 16 samples of 1; its light steps to 3 and
        // it gets one sample every 8th frame (its neighbour, cell 1, keeps the tile touched).
        for (frames, after_32) in [(0, 0.0), (6, 2.9)] {
            let mut values = vec![HashCellValue::ZERO; CELLS_PER_TILE as usize];
            let mut accs = vec![0u32; TILE_ACCUMULATOR_WORDS];
            values[0] = HashCellValue::new(Vec3::splat(16.0), 16.0);
            for frame in 0..33 {
                if frame % 8 == 0 {
                    accumulate_sample(&mut accs[..], 0, [0, 0], Vec3::splat(3.0), ONE);
                }
                accumulate_sample(&mut accs[..], 0, [1, 0], Vec3::ONE, ONE);
                update_tile(
                    &mut values,
                    &mut accs[..],
                    0,
                    MAX_SAMPLE_COUNT,
                    false,
                    frames,
                );
                if frame == 1 && frames != 0 {
                    // Without a sample, the history fades: the mean stays, the count falls.
                    let after_0 = 16.0 * 5.0 / 6.0 + 1.0;
                    let (n, m) = (values[0].count(), values[0].mean().x);
                    // Within the packed value's rounding, twice (the blend and the fade).
                    let e = 2.0 * crate::packing::WIDE16_MAX_RELATIVE_ERROR;
                    let (want_n, want_m) = (after_0 * 5.0 / 6.0, (after_0 + 2.0) / after_0);
                    assert!((n - want_n).abs() <= e * want_n, "{n}");
                    assert!((m - want_m).abs() <= 2.0 * e * want_m, "{m}");
                }
            }
            // Five samples of 3. The whole history keeps 15/16 of the old light per sample; a
            // 6-frame history keeps little of it.
            let mean = values[0].mean().x;
            if frames == 0 {
                let want = 3.0 - 2.0 * (15.0f32 / 16.0).powi(5);
                // Rounded once per update that touched the cell.
                let e = 6.0 * crate::packing::WIDE16_MAX_RELATIVE_ERROR;
                assert!((mean - want).abs() <= e * want, "{mean}");
            } else {
                assert!(mean > after_32, "{frames}: {mean}");
            }
        }
    }

    #[test]
    fn a_tile_whose_light_went_off_forgets_it_within_a_few_frames() {
        for adaptive in [false, true] {
            let mut values = vec![HashCellValue::ZERO; CELLS_PER_TILE as usize];
            let mut accs = vec![0u32; TILE_ACCUMULATOR_WORDS];
            // 32 frames of light 1 ± 0.5 (the signs balanced over the tile), then darkness.
            let lit = |f: u32, c: u32| 1.0 + if (f + c).is_multiple_of(2) { 0.5 } else { -0.5 };
            for frame in 0..32 {
                let mean = run_tile(&mut values, &mut accs, frame, adaptive, lit);
                if frame >= 16 {
                    // Noise alone keeps the whole history: the tile's mean stays 1.
                    assert!((mean - 1.0).abs() < 0.05, "{adaptive} {frame}: {mean}");
                }
            }
            let mut mean = 1.0;
            for frame in 32..38 {
                mean = run_tile(&mut values, &mut accs, frame, adaptive, |_, _| 0.0);
            }
            if adaptive {
                assert!(mean < 0.02, "adaptive: {mean} left after 6 frames");
            } else {
                // The fixed cap keeps (15/16)^6 of it.
                assert!(
                    (mean - (15.0f32 / 16.0).powi(6)).abs() < 0.02,
                    "fixed: {mean}"
                );
            }
        }
    }

    #[test]
    fn mips_are_sums_of_children_and_accumulators_are_cleared() {
        let tiles = 2;
        let mut values = vec![HashCellValue::ZERO; tiles * CELLS_PER_TILE as usize];
        let mut accs = vec![0u32; tiles * TILE_ACCUMULATOR_WORDS];
        // Tile 1: cell (x, y) gets x + 1 samples of radiance (y + 1).
        for y in 0..8 {
            for x in 0..8 {
                for _ in 0..=x {
                    accumulate_sample(&mut accs[..], 1, [x, y], Vec3::splat((y + 1) as f32), ONE);
                }
            }
        }
        // An untouched cell of tile 1 keeps its old value.
        let untouched = cell_index(1, 0, 0, 0) as usize;
        accs[accumulator_word(1, [0, 0])..][..7].fill(0);
        values[untouched] = HashCellValue::new(Vec3::splat(3.0), 3.0);
        update_tile(&mut values, &mut accs[..], 1, MAX_SAMPLE_COUNT, true, 0);
        assert!(accs.iter().all(|&w| w == 0));
        assert!(
            values[..CELLS_PER_TILE as usize]
                .iter()
                .all(|v| *v == HashCellValue::ZERO)
        );
        assert_eq!(values[untouched], HashCellValue::new(Vec3::splat(3.0), 3.0));
        let c = |mip, x, y| values[cell_index(1, mip, x, y) as usize];
        assert_eq!(c(0, 3, 2).count(), 4.0);
        assert_eq!(c(0, 3, 2).mean(), Vec3::splat(3.0));
        for mip in 1..NUM_MIPS {
            let side = 8 >> mip;
            for y in 0..side {
                for x in 0..side {
                    let sum = c(mip - 1, 2 * x, 2 * y).sum_and_count()
                        + c(mip - 1, 2 * x + 1, 2 * y).sum_and_count()
                        + c(mip - 1, 2 * x, 2 * y + 1).sum_and_count()
                        + c(mip - 1, 2 * x + 1, 2 * y + 1).sum_and_count();
                    let expected = HashCellValue::new(sum.truncate(), sum.w);
                    assert_eq!(c(mip, x, y), expected);
                    assert_eq!(mip_cell(&values, 1, mip, x, y), expected);
                }
            }
        }
        // Root: counts 3 (old cell) + Σ_{y, x ≠ (0,0)} min(x + 1, 16).
        let counts: f32 = 3.0 + (0..8).map(|x| (x + 1) as f32).sum::<f32>() * 8.0 - 1.0;
        assert_eq!(c(3, 0, 0).count(), counts);
        assert_eq!(mip_cell_count(0), 64);
        assert_eq!(mip_cell_count(3), 1);
        assert_eq!(mip_cell_count(9), 1);

        // 64 invocations per tile give the same bits.
        let mut other = vec![HashCellValue::ZERO; tiles * CELLS_PER_TILE as usize];
        other[untouched] = HashCellValue::new(Vec3::splat(3.0), 3.0);
        for y in 0..8 {
            for x in 0..8 {
                for _ in 0..=x {
                    accumulate_sample(&mut accs[..], 1, [x, y], Vec3::splat((y + 1) as f32), ONE);
                }
            }
        }
        accs[accumulator_word(1, [0, 0])..][..7].fill(0);
        for cell in (0..64).rev() {
            update_mip0_cell(
                &mut other,
                &mut accs[..],
                1,
                cell,
                MAX_SAMPLE_COUNT,
                16.0,
                1.0,
                0,
            );
        }
        for mip in 1..NUM_MIPS {
            for cell in 0..mip_cell_count(mip) {
                update_mip_cell(&mut other, 1, mip, cell);
            }
        }
        assert_eq!(other, values);
    }

    /// One update of tile 0 through the pass: the bounce copy first, then the cells.
    fn update_both(
        values: &mut [HashCellValue],
        bounce: &mut [HashCellValue],
        accs: &mut [u32],
        history_frames: u32,
    ) {
        let blend_cap = tile_blend_cap(values, accs, 0, MAX_SAMPLE_COUNT, false);
        let frame = next_frame();
        update_bounce_copy(bounce, values, accs, 0, MAX_SAMPLE_COUNT, blend_cap, frame);
        blend_tile(
            values,
            accs,
            0,
            MAX_SAMPLE_COUNT,
            blend_cap,
            history_frames,
            frame,
        );
    }

    #[test]
    fn the_bounce_copy_follows_a_change_sooner_and_agrees_once_it_holds() {
        let cells = CELLS_PER_TILE as usize;
        let (mut values, mut bounce) = (
            vec![HashCellValue::ZERO; cells],
            vec![HashCellValue::ZERO; cells],
        );
        let mut accs = vec![0u32; TILE_ACCUMULATOR_WORDS];
        let frame = |values: &mut [HashCellValue],
                     bounce: &mut [HashCellValue],
                     accs: &mut [u32],
                     light: f32| {
            for cell in 0..64 {
                accumulate_sample(accs, 0, [cell % 8, cell / 8], Vec3::splat(light), ONE);
            }
            update_both(values, bounce, accs, 12);
        };
        // A steady light: both hold it, the copy with a shorter history.
        for _ in 0..40 {
            frame(&mut values, &mut bounce, &mut accs, 1.0);
        }
        for i in [0, 63, 64, 84] {
            assert!(
                close(values[i].mean(), Vec3::ONE) && close(bounce[i].mean(), Vec3::ONE),
                "{i}"
            );
            assert!(bounce[i].count() < values[i].count(), "{i}");
        }
        // The light doubles: after 6 frames the copy is within 10 % of it (it keeps 2/3 per
        // update), the cells (11/12) still more than half short; both converge to it.
        for _ in 0..6 {
            frame(&mut values, &mut bounce, &mut accs, 2.0);
        }
        let (slow, fast) = (values[84].mean().x, bounce[84].mean().x);
        assert!(fast > 1.9 && slow < 1.5, "{slow} {fast}");
        for _ in 0..200 {
            frame(&mut values, &mut bounce, &mut accs, 2.0);
        }
        assert!(
            close(values[84].mean(), Vec3::splat(2.0))
                && close(bounce[84].mean(), Vec3::splat(2.0)),
            "{} {}",
            values[84].mean(),
            bounce[84].mean()
        );
        // The accumulators are cleared once, after both read them.
        assert!(accs.iter().take(64 * 7).all(|&w| w == 0));
    }

    #[test]
    fn a_new_tile_starts_its_bounce_copy_over() {
        let cells = CELLS_PER_TILE as usize;
        let mut values = vec![HashCellValue::ZERO; cells];
        let mut accs = vec![0u32; TILE_ACCUMULATOR_WORDS];
        // The slot's copy still holds an evicted tile's light; the new tile's cells are cleared.
        let mut bounce = vec![HashCellValue::new(Vec3::splat(90.0), 3.0); cells];
        accumulate_sample(&mut accs[..], 0, [2, 5], Vec3::splat(0.5), ONE);
        update_both(&mut values, &mut bounce, &mut accs, 12);
        // The sampled cell's copy is its sample; the others hold nothing; the mips sum them.
        let sampled = cell_index(0, 0, 2, 5) as usize;
        assert_eq!(bounce[sampled], HashCellValue::new(Vec3::splat(0.5), 1.0));
        for i in (0..64).filter(|&i| i != sampled) {
            assert_eq!(bounce[i], HashCellValue::ZERO, "{i}");
        }
        assert_eq!(bounce[84], bounce[sampled]);
        // A copy that is too short for the cells is left alone by the pass (multi-bounce off).
        let mut lists = vec![0u32; crate::hash_cells::lists::list_buffer_words(1)];
        crate::hash_cells::lists::push_tile(
            &mut lists[..],
            crate::hash_cells::lists::UPDATE_TILES,
            1,
            0,
        );
        accumulate_sample(&mut accs[..], 0, [2, 5], Vec3::splat(0.5), ONE);
        let mut short = [HashCellValue::new(Vec3::ONE, 1.0)];
        let mut params = crate::hash_cells::layout::HashGridParams::new(Vec3::ZERO, 0.01, 1);
        params.num_buckets_log2 = 0;
        params.tiles_per_bucket_log2 = 0;
        crate::hash_cells::passes::update_pass(
            &mut values,
            &mut short,
            &mut accs[..],
            &lists[..],
            &params,
            0,
        );
        assert_eq!(short, [HashCellValue::new(Vec3::ONE, 1.0)]);
        // The cells blend as ever (a history that never fades: two samples).
        assert_eq!(values[sampled].count(), 2.0);
    }
}
