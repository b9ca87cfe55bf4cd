//! The cache's blend adapts to how much a tile's lighting changed (the luminance-change-adaptive
//! blend one of GI-1.0's authors has shared, pooled per tile): while the light holds, a cell keeps
//! its history of up to `sample_cap` samples; when a light goes off, on or moves, the tile's cells
//! drop their history within a few frames, and the light the multi-bounce loop kept circulating
//! fades with them.
//!
//! Each frame the update pass pools, over the tile's mip-0 cells that have both a history and new
//! samples, the luminance change of the new samples' mean from the history's mean, each cell
//! weighted by its new samples ([`frame_change`]): the signed change and the absolute change, both
//! relative to the pooled luminance, so in `[-1, 1]` and `[0, 1]`. A [`TileTrend`] keeps their
//! running means (rate [`TREND_RATE`]). Their ratio `|trend| / spread` is near 1 when the cells
//! change the same way frame after frame (a light went off: every cell darkens), and small when
//! they only scatter (noise: the signs cancel, whatever the noise level). From
//! [`CHANGE_START`] to [`CHANGE_FULL`] the blend's cap falls smoothly from `sample_cap` to 1
//! ([`blend_cap`]).
//!
//! # Bias
//!
//! The decision reads the frame's own samples, so it correlates with them: a tile of one noisy
//! cell would drop its history after a dark sample more often than after a bright one and darken
//! (a simulated tile of one cell with heavy-tailed samples lost 25–75 %; of 32 cells, under
//! 0.6 %). The tile's pooled samples gate the adaptation: none at [`MIN_POOLED_SAMPLES`], all of
//! it from [`FULL_POOLED_SAMPLES`]. The gate is low because tiles of low-resolution frames pool
//! few samples (a gate of 8 to 32 never adapted at 64 × 64); what it costs in the converged image
//! is measured: up to 1.5 points of the mean over the repository's scenes and the Bitterli
//! interiors (the living room, darker; 0.6 when first measured), with lower relMSE in every one
//! (README, "Bias budget"). A faster [`TREND_RATE`] follows a change sooner and darkens more;
//! taking the previous frame's trend removes the bias and lags more (README, "Round 17").
//!
//! A cell's stored count stays `min(count + k, sample_cap)` (less what a fading history,
//! [`super::update`], takes): the adaptive read steps to a coarser mip for cells with few recent
//! samples, not for cells whose history a change cut short.
//!
//! Memory: one word per tile, after its cells' accumulators ([`crate::hash_cells::layout::TREND_WORD`]).

use glam::{Vec2, Vec3};

use crate::color::luminance;
use crate::math::{abs, clamp, max, min, saturate};
use crate::packing::{pack_half2, unpack_half2};

/// Share of a frame's change that enters the tile's running trend: a noise-free change gets the
/// full response at once; after frames of noise, a light switched off gets it from its fifth
/// frame (`a_tile_that_darkens_frame_after_frame_drops_its_history`).
pub const TREND_RATE: f32 = 0.25;
/// `|trend| / spread` below which the cap stays `sample_cap`: noise whose signs balance stays
/// below it (`noise_without_a_trend_keeps_the_cap`).
pub const CHANGE_START: f32 = 0.4;
/// `|trend| / spread` from which the blend keeps no history (cap 1).
pub const CHANGE_FULL: f32 = 0.8;
/// Pooled new samples of a tile below which its blend does not adapt (see the bias section).
pub const MIN_POOLED_SAMPLES: f32 = 1.0;
/// Pooled new samples from which its blend adapts fully.
pub const FULL_POOLED_SAMPLES: f32 = 4.0;

/// A tile's running luminance change: `trend` the mean signed relative change per frame, `spread`
/// the mean absolute one. Both 0 for a new tile.
#[derive(Clone, Copy, Debug, Default, PartialEq)]
pub struct TileTrend {
    /// Running mean of the pooled signed change, in `[-1, 1]`.
    pub trend: f32,
    /// Running mean of the pooled absolute change, in `[0, 1]`.
    pub spread: f32,
}

impl TileTrend {
    /// The trend of a tile word ([`Self::pack`]); a non-finite half reads as 0.
    #[inline]
    pub fn unpack(word: u32) -> Self {
        let v = unpack_half2(word);
        let finite = |x: f32| if x.is_finite() { x } else { 0.0 };
        Self {
            trend: clamp(finite(v.x), -1.0, 1.0),
            spread: saturate(finite(v.y)),
        }
    }

    /// Two halves in one word: `trend` low, `spread` high.
    #[inline]
    pub fn pack(self) -> u32 {
        pack_half2(Vec2::new(self.trend, self.spread))
    }

    /// `|trend| / spread`, in `[0, 1]` (0 for a tile without change).
    #[inline]
    pub fn coherence(self) -> f32 {
        if self.spread > 0.0 {
            saturate(abs(self.trend) / self.spread)
        } else {
            0.0
        }
    }

    /// The trend after a frame whose pooled change is `change` ([`PooledChange`]); a frame that
    /// pooled no cell resets it (the tile is new, or no cell of it has both a history and samples).
    #[inline]
    pub fn update(self, change: PooledChange) -> Self {
        if change.luminance <= 0.0 || !change.luminance.is_finite() {
            return Self::default();
        }
        let signed = clamp(change.signed / change.luminance, -1.0, 1.0);
        let absolute = saturate(change.absolute / change.luminance);
        if !(signed.is_finite() && absolute.is_finite()) {
            return Self::default();
        }
        Self {
            trend: self.trend + (signed - self.trend) * TREND_RATE,
            spread: self.spread + (absolute - self.spread) * TREND_RATE,
        }
    }
}

/// One frame's luminance change pooled over a tile's cells ([`frame_change`] per cell, summed).
#[derive(Clone, Copy, Debug, Default, PartialEq)]
pub struct PooledChange {
    /// `Σ k (new − history)`.
    pub signed: f32,
    /// `Σ k |new − history|`.
    pub absolute: f32,
    /// `Σ k (new + history)`.
    pub luminance: f32,
    /// `Σ k`, the new samples pooled.
    pub samples: f32,
}

/// Adds one cell's change to `pooled`: `new_mean` the mean of its `k` new samples, `history_mean`
/// its history's mean (cells without history or without samples add nothing).
#[inline]
pub fn frame_change(
    pooled: PooledChange,
    new_mean: Vec3,
    k: f32,
    history_mean: Vec3,
    history_count: f32,
) -> PooledChange {
    if k.is_nan() || k <= 0.0 || history_count.is_nan() || history_count <= 0.0 {
        return pooled;
    }
    let (a, m) = (
        max(luminance(new_mean), 0.0),
        max(luminance(history_mean), 0.0),
    );
    PooledChange {
        signed: pooled.signed + k * (a - m),
        absolute: pooled.absolute + k * abs(a - m),
        luminance: pooled.luminance + k * (a + m),
        samples: pooled.samples + k,
    }
}

/// The cap the frame's blend weights use: `cap` while the tile's change is noise, falling smoothly
/// to 1 as its [coherence](TileTrend::coherence) goes from [`CHANGE_START`] to [`CHANGE_FULL`],
/// scaled by how many samples were pooled ([`MIN_POOLED_SAMPLES`] to [`FULL_POOLED_SAMPLES`]).
#[inline]
pub fn blend_cap(cap: f32, trend: TileTrend, pooled_samples: f32) -> f32 {
    let x = saturate((trend.coherence() - CHANGE_START) / (CHANGE_FULL - CHANGE_START));
    let response = x * x * (3.0 - 2.0 * x);
    let trust = saturate(
        (pooled_samples - MIN_POOLED_SAMPLES) / (FULL_POOLED_SAMPLES - MIN_POOLED_SAMPLES),
    );
    let cap = max(cap, 1.0);
    min(cap, cap - (cap - 1.0) * response * trust)
}

#[cfg(test)]
mod tests {
    use super::*;

    fn pooled(cells: &[(f32, f32)], k: f32) -> PooledChange {
        cells.iter().fold(PooledChange::default(), |p, &(a, m)| {
            frame_change(p, Vec3::splat(a), k, Vec3::splat(m), 16.0)
        })
    }

    #[test]
    fn a_tile_that_darkens_frame_after_frame_drops_its_history() {
        // Without noise the change is coherent from its first frame.
        let t = TileTrend::default().update(pooled(&[(0.5, 1.0); 16], 2.0));
        assert_eq!(blend_cap(16.0, t, 32.0), 1.0, "{t:?}");
        // After noise (cells ±40 %, signs balanced), a light off (every cell at half its history)
        // takes a few frames to stand out of it.
        let mut t = TileTrend::default();
        for frame in 0..20 {
            let s = if frame % 2 == 0 { 0.4 } else { -0.4 };
            let cells: Vec<(f32, f32)> = (0..16)
                .map(|i| (1.0 + if i % 2 == 0 { s } else { -s }, 1.0))
                .collect();
            t = t.update(pooled(&cells, 2.0));
        }
        let mut caps = vec![];
        for _ in 0..6 {
            t = t.update(pooled(&[(0.5, 1.0); 16], 2.0));
            caps.push(blend_cap(16.0, t, 32.0));
        }
        assert_eq!(caps[0], 16.0, "{caps:?}");
        assert!(caps[1] < 16.0 && caps[2] < caps[1], "{caps:?}");
        assert!(caps[4..].iter().all(|&c| c == 1.0), "{caps:?}");
        assert!(t.trend < -0.25, "{t:?}");
    }

    #[test]
    fn noise_without_a_trend_keeps_the_cap() {
        // Cells scatter ±40 % around their history with the signs balanced every frame.
        let mut t = TileTrend::default();
        for frame in 0..50 {
            let s = if frame % 2 == 0 { 1.0 } else { -1.0 };
            let cells: Vec<(f32, f32)> = (0..16)
                .map(|i| (1.0 + s * if i % 2 == 0 { 0.4 } else { -0.4 }, 1.0))
                .collect();
            t = t.update(pooled(&cells, 2.0));
            assert_eq!(blend_cap(16.0, t, 32.0), 16.0, "{t:?}");
        }
        assert!(t.spread > 0.15 && t.coherence() < 1e-3, "{t:?}");
    }

    #[test]
    fn sparse_tiles_do_not_adapt_and_dense_ones_fully() {
        let coherent = TileTrend {
            trend: -0.3,
            spread: 0.3,
        };
        assert_eq!(blend_cap(16.0, coherent, MIN_POOLED_SAMPLES), 16.0);
        assert_eq!(blend_cap(16.0, coherent, 1.0), 16.0);
        assert_eq!(blend_cap(16.0, coherent, FULL_POOLED_SAMPLES), 1.0);
        let half = blend_cap(
            16.0,
            coherent,
            0.5 * (MIN_POOLED_SAMPLES + FULL_POOLED_SAMPLES),
        );
        assert!((half - 8.5).abs() < 1e-5, "{half}");
        // Caps below 1 read as 1, as the fixed blend does.
        assert_eq!(blend_cap(0.0, coherent, 64.0), 1.0);
    }

    #[test]
    fn a_new_or_unpooled_tile_resets_and_bad_words_read_as_no_change() {
        let t = TileTrend {
            trend: 0.5,
            spread: 0.6,
        };
        assert_eq!(t.update(PooledChange::default()), TileTrend::default());
        // Cells without history or without samples pool nothing.
        let p = frame_change(PooledChange::default(), Vec3::ONE, 3.0, Vec3::ONE, 0.0);
        let p = frame_change(p, Vec3::ONE, 0.0, Vec3::ONE, 5.0);
        assert_eq!(p, PooledChange::default());
        // Extremes: a huge or infinite luminance pools to a non-finite sum and resets.
        let p = frame_change(
            PooledChange::default(),
            Vec3::splat(f32::MAX),
            4.0,
            Vec3::ONE,
            1.0,
        );
        assert_eq!(t.update(p), TileTrend::default());
        // Black history and black samples: no luminance, no trend.
        let p = frame_change(PooledChange::default(), Vec3::ZERO, 4.0, Vec3::ZERO, 1.0);
        assert_eq!(t.update(p), TileTrend::default());
        // A light switched on in a black tile: the largest change, +1.
        let p = frame_change(PooledChange::default(), Vec3::ONE, 4.0, Vec3::ZERO, 1.0);
        assert_eq!(TileTrend::default().update(p).trend, TREND_RATE);
        // Packing round-trips within half precision; NaN and ∞ halves read as 0.
        let word = t.pack();
        let back = TileTrend::unpack(word);
        assert!((back.trend - 0.5).abs() < 1e-3 && (back.spread - 0.6).abs() < 1e-3);
        assert_eq!(TileTrend::unpack(0x7e00_7e00), TileTrend::default());
        assert_eq!(TileTrend::unpack(0x7c00_fc00), TileTrend::default());
        assert_eq!(TileTrend::unpack(0), TileTrend::default());
        // NaN colours pool as black (luminance clamped at 0 drops NaN).
        let p = frame_change(PooledChange::default(), Vec3::NAN, 1.0, Vec3::ONE, 1.0);
        assert!(t.update(p).trend.is_finite());
    }
}
