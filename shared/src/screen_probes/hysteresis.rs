//! Temporal hysteresis of BlendScreenProbes, adaptive to change: where a cell has both a new
//! value and a history value, the result is `lerp(new, history, w)` with
//! `w = 1 − 1 / frames`, `frames = 1 + (HYSTERESIS_FRAMES − 1) × (1 − change)²`, where `change`
//! is the mean over the probe's *other* cells that hold both values ([`other_cells`]) of their
//! relative luminance change `|n − h| / max(n, h)` ([`cell_change`]).
//!
//! * A probe whose lighting holds keeps an exponential average over about
//!   [`HYSTERESIS_FRAMES`] frames: a firefly (one ray that found a small light) is spread over
//!   them, and moves its neighbours' change by at most 1/63.
//! * A change that moves the probe's lighting (a light switched off, a shadow arriving over the
//!   probe) brings `w` to 0 at once: the new value passes.
//! * `w` never looks at the cell's own new value, so the average keeps the cell's mean. The
//!   reference's weight grew with how far the new luminance exceeded twice the history's: it
//!   damped only brightening, and lost 3.8 % of the Cornell box's mean (`gi render --no
//!   filter,feedback,temporal,spatial`, 128 frames averaged, with and without hysteresis).
//!
//! The history is the probe's own: the cells of the probe its tile held, mapped to the new seed
//! (`ray_guiding::blend_history`; the 3 × 3 neighbourhood's mean only where those are empty).
//! Until issue 22's round 5 it was the neighbourhood's mean, so the average over frames was also
//! a spatial blur that moved the converged mean by −6 to +4 points; what remains is measured in
//! the bias budget's "no hysteresis" column (README, "Bias budget").

use glam::Vec3;

use super::{LANES, cell_is_filled, cell_radiance};
use crate::color::luminance;
use crate::math::{abs, max, saturate};

/// Frames a cell's history averages at most, when its probe's lighting holds.
pub const HYSTERESIS_FRAMES: f32 = 8.0;

/// What a cell contributes to its probe's change measure: `[relative luminance change, 1]` when
/// both cells are filled (`|n − h| / max(n, h)`, 0 when both are dark, 1 for NaN), else
/// `[0, 0]`.
#[inline]
pub fn cell_change(new: [f32; 4], history: [f32; 4]) -> [f32; 2] {
    if !cell_is_filled(new) || !cell_is_filled(history) {
        return [0.0; 2];
    }
    let n = luminance(cell_radiance(new));
    let h = luminance(cell_radiance(history));
    let r = abs(n - h) / max(n, h);
    let change = if n == h {
        0.0
    } else if r < 1.0 {
        max(r, 0.0)
    } else {
        1.0
    };
    [change, 1.0]
}

/// The sums of `changes` over every cell but `cell` (in cell order): `[change, cells]`.
#[inline]
pub fn other_cells(changes: &[[f32; 2]; LANES], cell: u32) -> [f32; 2] {
    let mut sum = [0.0; 2];
    let mut k = 0;
    while k < LANES {
        if k as u32 != cell {
            sum[0] += changes[k][0];
            sum[1] += changes[k][1];
        }
        k += 1;
    }
    sum
}

/// The history weight `w` for the other cells' sums `[change, cells]` (0: take the new value).
/// No other cell: the full [`HYSTERESIS_FRAMES`] average; NaN: 0.
#[inline]
pub fn hysteresis_weight(others: [f32; 2]) -> f32 {
    let mean = others[0] / others[1];
    let change = if others[1] <= 0.0 {
        0.0
    } else if mean >= 0.0 {
        saturate(mean)
    } else {
        1.0
    };
    let hold = 1.0 - change;
    let frames = 1.0 + (HYSTERESIS_FRAMES - 1.0) * hold * hold;
    let w = 1.0 - 1.0 / frames;
    if w.is_finite() { w } else { 0.0 }
}

/// `lerp(new, history, weight)`.
#[inline]
pub fn apply_hysteresis(new: Vec3, history: Vec3, weight: f32) -> Vec3 {
    new + (history - new) * weight
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::screen_probes::{EMPTY, make_cell};

    #[test]
    fn still_lighting_averages_and_a_change_passes() {
        // Nothing moved: the full average, w = 7/8; no other cell: the same.
        assert!((hysteresis_weight([0.0, 63.0]) - 0.875).abs() < 1e-6);
        assert!((hysteresis_weight([0.0, 0.0]) - 0.875).abs() < 1e-6);
        // Every other cell went dark (a light off) or lit up: the new value as is.
        assert_eq!(hysteresis_weight([63.0, 63.0]), 0.0);
        // Half the cells changed fully: 1 + 7/4 frames.
        assert!((hysteresis_weight([31.5, 63.0]) - (1.0 - 1.0 / 2.75)).abs() < 1e-6);
        assert_eq!(hysteresis_weight([f32::NAN, 1.0]), 0.0);
        let b = Vec3::new(0.2, 0.5, 0.1);
        assert!((apply_hysteresis(b * 9.0, b, 0.875) - b * 2.0).length() < 1e-6);
    }

    #[test]
    fn a_cell_is_left_out_of_its_own_change() {
        let cell = |v: f32| make_cell(Vec3::splat(v), 1.0);
        assert_eq!(cell_change(cell(1.0), cell(1.0)), [0.0, 1.0]);
        assert_eq!(cell_change(cell(0.0), cell(0.0)), [0.0, 1.0]);
        assert_eq!(cell_change(cell(100.0), cell(1.0)), [0.99, 1.0]);
        assert_eq!(cell_change(cell(0.0), cell(2.0)), [1.0, 1.0]);
        assert_eq!(cell_change(cell(1.0), EMPTY), [0.0, 0.0]);
        assert_eq!(
            cell_change(make_cell(Vec3::NAN, 1.0), cell(1.0)),
            [1.0, 1.0]
        );
        let mut changes = [[0.0, 1.0]; LANES];
        changes[3] = [0.99, 1.0];
        // Cell 3's firefly moves every other cell's sums by 0.99 / 63, not its own.
        assert_eq!(other_cells(&changes, 3), [0.0, 63.0]);
        assert_eq!(other_cells(&changes, 4), [0.99, 63.0]);
    }

    /// One cell sees a small light in 1 frame out of 10 (a firefly of 10), its 63 neighbours a
    /// steady 1: over 20 000 frames its average stays the light's mean within 2 %, while no
    /// value reaches 6 (runs of fireflies stack up; one alone gives 1.25 over a dark history).
    #[test]
    fn the_average_keeps_the_mean_of_a_firefly() {
        let mut rng = crate::random::Random::new(3, 0);
        let mut history = 0.0f32;
        let (mut sum, mut peak) = (0.0f64, 0.0f32);
        let frames = 20_000;
        for f in 0..frames {
            let new = if rng.next_f32() < 0.1 { 10.0 } else { 0.0 };
            let w = if f == 0 {
                0.0
            } else {
                hysteresis_weight([0.0, 63.0])
            };
            history = apply_hysteresis(Vec3::splat(new), Vec3::splat(history), w).x;
            if f >= 100 {
                sum += f64::from(history);
                peak = peak.max(history);
            }
        }
        let mean = sum / f64::from(frames - 100);
        assert!((mean - 1.0).abs() < 0.02, "{mean}");
        assert!(peak < 6.0, "{peak}");
    }
}
