//! Shadow-preserving biased temporal hysteresis of BlendScreenProbes: where a cell has both a new
//! value and a history value, the history weight grows with how far the new luminance exceeds
//! twice the history's, `clamp(max(A − B − min(A, B), 0) / max(max(A, B), 1e-4), 0, 0.95)²` with
//! `A` = luminance(new), `B` = luminance(history). Darkening (a shadow arriving) passes at once;
//! only brightening beyond twice the history (fireflies) is damped. The weight itself is
//! [`crate::color::temporal_hysteresis_weight`].

use glam::Vec3;

use crate::color::{luminance, temporal_hysteresis_weight};

/// The history weight for radiance `new` against radiance `history` (0 = take `new`).
#[inline]
pub fn hysteresis_factor(new: Vec3, history: Vec3) -> f32 {
    temporal_hysteresis_weight(luminance(new), luminance(history))
}

/// The blended radiance: `lerp(new, history, hysteresis_factor(new, history))`.
#[inline]
pub fn apply_hysteresis(new: Vec3, history: Vec3) -> Vec3 {
    let blend = hysteresis_factor(new, history);
    new + (history - new) * blend
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn darkening_passes_and_fireflies_are_damped() {
        let b = Vec3::new(0.2, 0.5, 0.1);
        // Darkening or equal: blend 0, the new value as is.
        for s in [0.0, 0.3, 0.99, 1.0] {
            assert_eq!(hysteresis_factor(b * s, b), 0.0);
            assert_eq!(apply_hysteresis(b * s, b), b * s);
        }
        // Brightening up to twice the history passes; exactly 0 at A = 2B.
        assert_eq!(hysteresis_factor(b * 1.5, b), 0.0);
        assert_eq!(hysteresis_factor(b * 2.0, b), 0.0);
        assert!(hysteresis_factor(b * 2.1, b) > 0.0);
        // A firefly at 100 × the history: ((100 − 2) / 100 clamped to 0.95)² = 0.95².
        let f = hysteresis_factor(b * 100.0, b);
        assert!((f - 0.9025).abs() < 1e-6, "{f}");
        let r = apply_hysteresis(b * 100.0, b);
        let expected = b * 100.0 + (b - b * 100.0) * 0.9025;
        assert!((r - expected).length() < 1e-4, "{r} vs {expected}");
        assert!(r.x < b.x * 11.0);
        // 4 × the history: ((4 − 2) / 4)² = 0.25.
        assert!((hysteresis_factor(b * 4.0, b) - 0.25).abs() < 1e-6);
        // No light at all: blend 0.
        assert_eq!(hysteresis_factor(Vec3::ZERO, Vec3::ZERO), 0.0);
    }
}
