//! Colour helpers of the probe pipeline: luminance and the shadow-preserving temporal hysteresis.

use glam::Vec3;

use crate::math::{clamp, max, min};

/// Rec. 709 luminance of linear RGB.
#[inline]
pub fn luminance(rgb: Vec3) -> f32 {
    rgb.dot(Vec3::new(0.2126, 0.7152, 0.0722))
}

/// Largest history weight the hysteresis allows before squaring.
pub const HYSTERESIS_MAX_BLEND: f32 = 0.95;

/// History weight of `BlendScreenProbes` for new luminance `a` and history luminance `b`:
/// `clamp(max(a − b − min(a, b), 0) / max(max(a, b), 1e-4), 0, 0.95)²`; the result is
/// `lerp(new, history, weight)`.
///
/// Only brightening beyond twice the history is damped (fireflies); darkening — a shadow arriving —
/// gets weight 0 and passes at once. NaN inputs give 0 (take the new value).
#[inline]
pub fn temporal_hysteresis_weight(a: f32, b: f32) -> f32 {
    let excess = max(a - b - min(a, b), 0.0);
    let w = clamp(excess / max(max(a, b), 1e-4), 0.0, HYSTERESIS_MAX_BLEND);
    w * w
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn luminance_weights() {
        assert!((luminance(Vec3::ONE) - 1.0).abs() < 1e-6);
        assert_eq!(luminance(Vec3::Y), 0.7152);
        assert_eq!(luminance(Vec3::ZERO), 0.0);
    }

    #[test]
    fn hysteresis_preserves_shadows_and_damps_fireflies() {
        // Darkening and mild brightening pass through.
        assert_eq!(temporal_hysteresis_weight(0.1, 1.0), 0.0);
        assert_eq!(temporal_hysteresis_weight(0.0, 5.0), 0.0);
        assert_eq!(temporal_hysteresis_weight(1.5, 1.0), 0.0);
        assert_eq!(temporal_hysteresis_weight(2.0, 1.0), 0.0);
        // 4× brighter: ((4 − 1 − 1) / 4)² = 0.25.
        assert!((temporal_hysteresis_weight(4.0, 1.0) - 0.25).abs() < 1e-6);
        // A firefly out of black saturates at 0.95².
        assert!((temporal_hysteresis_weight(100.0, 0.0) - 0.9025).abs() < 1e-6);
        assert!((temporal_hysteresis_weight(1e30, 1.0) - 0.9025).abs() < 1e-6);
        assert_eq!(temporal_hysteresis_weight(0.0, 0.0), 0.0);
        assert_eq!(temporal_hysteresis_weight(f32::NAN, 1.0), 0.0);
        assert_eq!(temporal_hysteresis_weight(1.0, f32::NAN), 0.0);
        // Monotone in the new luminance.
        let mut last = 0.0;
        for i in 0..1000 {
            let w = temporal_hysteresis_weight(i as f32 * 0.01, 1.0);
            assert!(w >= last);
            last = w;
        }
    }
}
