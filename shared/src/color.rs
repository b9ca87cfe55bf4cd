//! Colour helpers: luminance and the sRGB transfer function.

use glam::Vec3;
use num_traits::Float;

use crate::math::clamp;

/// Rec. 709 luminance of linear RGB.
#[inline]
pub fn luminance(rgb: Vec3) -> f32 {
    rgb.dot(Vec3::new(0.2126, 0.7152, 0.0722))
}

/// The sRGB transfer function's inverse (IEC 61966-2-1) for `c` in `[0, 1]`.
#[inline]
pub fn srgb_to_linear(c: f32) -> f32 {
    if c <= 0.04045 {
        c * (1.0 / 12.92)
    } else {
        Float::powf((c + 0.055) * (1.0 / 1.055), 2.4)
    }
}

/// The sRGB transfer function (IEC 61966-2-1) for linear `c` in `[0, 1]` (clamped).
#[inline]
pub fn linear_to_srgb(c: f32) -> f32 {
    let c = clamp(c, 0.0, 1.0);
    if c <= 0.003_130_8 {
        c * 12.92
    } else {
        1.055 * Float::powf(c, 1.0 / 2.4) - 0.055
    }
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
    fn srgb_round_trips() {
        for i in 0..=255 {
            let c = i as f32 / 255.0;
            assert!((linear_to_srgb(srgb_to_linear(c)) - c).abs() < 1e-5);
        }
    }
}
