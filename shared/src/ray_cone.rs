//! Ray footprints: what a ray's texture reads are filtered over. Ray cones (Akenine-Möller et
//! al., "Texture Level of Detail Strategies for Real-Time Ray Tracing", Ray Tracing Gems, ch. 20,
//! 2019) for probe and cache rays; ray differentials for primary rays.
//!
//! A probe or cache ray stands for a cone of directions, the share of the hemisphere it samples.
//! Where it hits, the cone's width, divided by the cosine of the incidence, is the footprint on
//! the surface; scaled by the triangle's ratio of texture area to world area it is the footprint
//! in texture coordinates, whose base-2 logarithm is the footprint's level
//! ([`RayCone::footprint_lod`]), read as a disc ([`UvFootprint::isotropic`]). Distant and grazing
//! surfaces then read coarse mip levels instead of aliasing a few texels into probe and cache
//! noise.
//!
//! A primary ray knows more: its pixel's ray differentials (Igehy, "Tracing Ray Differentials",
//! 1999), how its direction changes from one pixel to the next along x and y
//! ([`RayFootprint::pixel`]). Carried to the hit's plane and through the triangle's UV gradients
//! they give the pixel's footprint in texture coordinates as two axes
//! ([`RayFootprint::on_surface`]), which the anisotropic read
//! ([`crate::textures::sample_footprint`]) filters over. At a grazing angle the footprint is long
//! and narrow: a cone's single width would blur the texture across it (a tiled floor's grout lines
//! would vanish), the differentials keep what the path tracer's pixel keeps.
//!
//! The path tracer, the ground truth, reads level 0 ([`RayFootprint::POINT`]): its samples
//! integrate the pixel and the hemisphere themselves, so any prefiltering would be a bias. Its
//! pixel-centre mode, which compares lighting with the GI frame's, reads the camera hit as the
//! G-buffer does ([`RayFootprint::pixel`]): one point per pixel would alias.

use glam::{Vec2, Vec3};
use num_traits::Float;

use crate::camera::CameraParams;
use crate::textures::UvFootprint;

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

/// What a ray's texture reads are filtered over: a cone, or a primary ray's pixel differentials.
#[derive(Clone, Copy, Debug, Default, PartialEq)]
pub struct RayFootprint {
    /// The cone, used when both differentials are zero.
    pub cone: RayCone,
    /// Change of the ray's direction (as the ray carries it, unnormalised) from one pixel to the
    /// next along the image's x; zero for a cone.
    pub direction_dx: Vec3,
    /// The same along the image's y.
    pub direction_dy: Vec3,
}

impl RayFootprint {
    /// A ray that stands for itself alone: every hit reads level 0.
    pub const POINT: Self = Self::cone(RayCone::POINT);

    /// The isotropic footprint of `cone`.
    #[inline]
    pub const fn cone(cone: RayCone) -> Self {
        Self {
            cone,
            direction_dx: Vec3::ZERO,
            direction_dy: Vec3::ZERO,
        }
    }

    /// The differentials of `camera`'s primary rays ([`crate::camera::primary_ray`]): one pixel's
    /// step across the image plane one unit ahead of the eye, scaled by the camera's
    /// [`CameraParams::texture_footprint`].
    #[inline]
    pub fn pixel(camera: &CameraParams) -> Self {
        let size = camera.image_size_f32().max(Vec2::ONE);
        let scale = camera.texture_footprint;
        let scale = if scale > 0.0 { scale } else { 0.0 };
        let step = 2.0 * camera.tan_half_fov_y * scale;
        Self {
            cone: RayCone::POINT,
            direction_dx: camera.right() * (step * camera.aspect / size.x),
            direction_dy: camera.up() * (-step / size.y),
        }
    }

    /// The footprint in texture coordinates where a ray of (unnormalised) `direction` hit, at
    /// parameter `t`, a triangle with unit geometric normal `normal`, world area `area`, texture
    /// area `uv_area` and texture-coordinate gradients `uv_gradients` (the fields of these names
    /// of [`Surface`](crate::scene_data::Surface)). Never NaN for finite inputs; a point without
    /// UVs.
    pub fn on_surface(
        &self,
        direction: Vec3,
        t: f32,
        normal: Vec3,
        area: f32,
        uv_area: f32,
        uv_gradients: [Vec3; 2],
    ) -> UvFootprint {
        if self.direction_dx == Vec3::ZERO && self.direction_dy == Vec3::ZERO {
            let length = direction.length();
            let lod =
                self.cone
                    .footprint_lod(t * length, direction / length, normal, area, uv_area);
            return UvFootprint::isotropic(Float::exp2(lod));
        }
        // Igehy's transfer to the hit's plane: the point moves by t·(dD − D·(dD·n)/(D·n)). Grazing
        // incidence is clamped as for cones: a long footprint, not an infinite one.
        let n = normal;
        let least = MIN_COSINE * direction.length();
        let dn = direction.dot(n);
        let dn = if Float::abs(dn) >= least {
            dn
        } else if dn < 0.0 {
            -least
        } else {
            least
        };
        UvFootprint {
            x: uv_step(self.direction_dx, direction, n, dn, t, uv_gradients),
            y: uv_step(self.direction_dy, direction, n, dn, t, uv_gradients),
        }
    }
}

/// The UV change of the hit point when the ray's direction changes by `dd` (see
/// [`RayFootprint::on_surface`]).
#[inline]
fn uv_step(dd: Vec3, direction: Vec3, n: Vec3, dn: f32, t: f32, gradients: [Vec3; 2]) -> Vec2 {
    let step = (dd - direction * (dd.dot(n) / dn)) * t;
    Vec2::new(gradients[0].dot(step), gradients[1].dot(step))
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn footprints_grow_with_distance_and_grazing() {
        let cone = RayCone {
            width: 0.0,
            spread: 0.02,
        };
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

    #[test]
    fn pixel_differentials_stretch_the_footprint_along_a_grazing_view() {
        // The plane y = -1 with u = x, v = z, seen from the origin 10 units away at a slope of
        // 1:10; one pixel turns the direction by 0.01 either way.
        let gradients = [Vec3::X, Vec3::Z];
        let footprint = RayFootprint {
            cone: RayCone::POINT,
            direction_dx: Vec3::new(0.01, 0.0, 0.0),
            direction_dy: Vec3::new(0.0, -0.01, 0.0),
        };
        let uv = footprint.on_surface(
            Vec3::new(0.0, -0.1, -1.0),
            10.0,
            Vec3::Y,
            0.0,
            0.0,
            gradients,
        );
        // Across the view: 10 × 0.01; along it ten times longer, as 1 / sin of the slope says.
        assert!((uv.x - Vec2::new(0.1, 0.0)).length() < 1e-6, "{uv:?}");
        assert!((uv.y - Vec2::new(0.0, 1.0)).length() < 1e-5, "{uv:?}");
        // Edge-on and without UVs: finite, and a point.
        let edge = footprint.on_surface(
            Vec3::new(0.0, 0.0, -1.0),
            10.0,
            Vec3::Y,
            0.0,
            0.0,
            gradients,
        );
        assert!(edge.x.is_finite() && edge.y.is_finite());
        let bare = [Vec3::ZERO; 2];
        let none = footprint.on_surface(Vec3::new(0.0, -0.1, -1.0), 10.0, Vec3::Y, 0.0, 0.0, bare);
        assert_eq!(none, UvFootprint::POINT);
        // A cone reads isotropically: its width, at the incidence, in UV units.
        let cone = RayFootprint::cone(RayCone {
            width: 0.0,
            spread: 0.01,
        });
        // A triangle of world and texture area 1.
        let iso = cone.on_surface(
            Vec3::new(0.0, -1.0, 0.0),
            10.0,
            Vec3::Y,
            1.0,
            1.0,
            gradients,
        );
        assert!((iso.x.x - 0.1).abs() < 1e-6 && iso.y == Vec2::new(0.0, iso.x.x));
    }
}
