//! Colour helpers: luminance.

use glam::Vec3;

/// Rec. 709 luminance of linear RGB.
#[inline]
pub fn luminance(rgb: Vec3) -> f32 {
    rgb.dot(Vec3::new(0.2126, 0.7152, 0.0722))
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
}
