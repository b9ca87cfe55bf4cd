//! Ray cones: the texture level of detail of a ray's hit (Akenine-Möller et al., "Texture Level
//! of Detail Strategies for Real-Time Ray Tracing", Ray Tracing Gems, ch. 20, 2019).
//!
//! A ray stands for a cone of directions: the pixel it samples for a primary ray, the share of
//! the hemisphere it samples for a probe or cache ray. Where it hits, the cone's width, divided
//! by the cosine of the incidence, is the footprint on the surface; scaled by the triangle's ratio
//! of texture area to world area it is the footprint in texture coordinates, whose base-2
//! logarithm is the footprint's level ([`RayCone::footprint_lod`]); each texture adds its own
//! size ([`crate::textures::texture_lod`]). Distant and grazing surfaces then read coarse mip
//! levels instead of aliasing a few texels into probe and cache noise.
//!
//! The path tracer, the ground truth, reads level 0 ([`RayCone::POINT`]): its samples integrate
//! the pixel and the hemisphere themselves, so any prefiltering would be a bias.

use glam::Vec3;
use num_traits::Float;

/// Incidence cosines below this count as this: a grazing hit reads a coarse level, not an
/// infinite one.
const MIN_COSINE: f32 = 1e-3;

/// A cone around a ray: its width where the ray starts and how fast it widens.
#[derive(Clone, Copy, Debug, Default, PartialEq)]
pub struct RayCone {
    /// Width at the ray's origin, world units.
    pub width: f32,
    /// Full apex angle, radians (width gained per unit of distance).
    pub spread: f32,
}

impl RayCone {
    /// A ray that stands for itself alone: every hit reads level 0.
    pub const POINT: Self = Self {
        width: 0.0,
        spread: 0.0,
    };

    /// The cone of a primary ray through one pixel of an image `height` pixels high with a
    /// vertical field of view of `2·atan(tan_half_fov_y)`: the angle one pixel subtends at the
    /// image's centre.
    pub fn pixel(tan_half_fov_y: f32, height: u32) -> Self {
        let h = if height == 0 { 1.0 } else { height as f32 };
        Self {
            width: 0.0,
            spread: Float::atan(2.0 * tan_half_fov_y / h),
        }
    }

    /// The cone of one of `rays` rays that together sample a hemisphere uniformly, starting where
    /// the cone of a primary ray `width` wide hit: each covers `2π / rays` steradians, a cone of
    /// apex angle `2·sqrt(2 / rays)` (small-angle approximation).
    pub fn hemisphere_share(width: f32, rays: u32) -> Self {
        let n = if rays == 0 { 1.0 } else { rays as f32 };
        Self {
            width,
            spread: 2.0 * Float::sqrt(2.0 / n),
        }
    }

    /// Width at `distance` along the ray (world units).
    #[inline]
    pub fn width_at(&self, distance: f32) -> f32 {
        self.width + self.spread * distance
    }

    /// The footprint's level of detail at a hit `distance` away along unit direction `direction`
    /// on a surface with normal `normal`, whose triangle has world area `area` and texture area
    /// `uv_area`: `log2(width / |cos| · sqrt(uv_area / area))`. `-∞` (level 0 after clamping)
    /// for a point cone or untextured triangle; never NaN.
    pub fn footprint_lod(
        &self,
        distance: f32,
        direction: Vec3,
        normal: Vec3,
        area: f32,
        uv_area: f32,
    ) -> f32 {
        let width = self.width_at(distance);
        let cosine = Float::abs(direction.dot(normal));
        let cosine = if cosine > MIN_COSINE {
            cosine
        } else {
            MIN_COSINE
        };
        let lod = Float::log2(width / cosine) + 0.5 * Float::log2(uv_area / area);
        if lod.is_nan() { f32::NEG_INFINITY } else { lod }
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn footprints_grow_with_distance_and_grazing() {
        let cone = RayCone::pixel(1.0, 100);
        assert!((cone.spread - (0.02f32).atan()).abs() < 1e-7);
        let n = Vec3::Z;
        let d = -Vec3::Z;
        // A triangle whose texture area equals its world area: the level is log2 of the width.
        let near = cone.footprint_lod(10.0, d, n, 0.5, 0.5);
        assert!((near - (10.0 * cone.spread).log2()).abs() < 1e-5);
        let far = cone.footprint_lod(40.0, d, n, 0.5, 0.5);
        assert!(
            (far - near - 2.0).abs() < 1e-4,
            "4× as far: 2 levels coarser"
        );
        // At 60° incidence the footprint doubles: one level.
        let slanted = Vec3::new(3f32.sqrt() * 0.5, 0.0, -0.5);
        let grazing = cone.footprint_lod(10.0, slanted, n, 0.5, 0.5);
        assert!((grazing - near - 1.0).abs() < 1e-4);
        // Texture 4× denser (UV area 16× the world area): 2 levels coarser.
        let dense = cone.footprint_lod(10.0, d, n, 0.5, 8.0);
        assert!((dense - near - 2.0).abs() < 1e-4);
        // Edge-on stays finite.
        assert!(cone.footprint_lod(10.0, Vec3::X, n, 0.5, 0.5).is_finite());
    }

    #[test]
    fn degenerate_inputs_read_level_zero() {
        let d = -Vec3::Z;
        let n = Vec3::Z;
        assert_eq!(
            RayCone::POINT.footprint_lod(5.0, d, n, 1.0, 1.0),
            f32::NEG_INFINITY
        );
        let cone = RayCone::hemisphere_share(0.01, 64);
        assert!((cone.spread - 2.0 * (2.0f32 / 64.0).sqrt()).abs() < 1e-7);
        // No UVs (UV area 0), degenerate triangle (area 0), NaN: never NaN.
        for (area, uv_area) in [(1.0, 0.0), (0.0, 0.0), (0.0, 1.0), (f32::NAN, 1.0)] {
            let lod = cone.footprint_lod(1.0, d, n, area, uv_area);
            assert!(!lod.is_nan(), "{area} {uv_area}");
        }
    }
}
