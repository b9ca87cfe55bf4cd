//! The primary hit as the G-buffer gives it ([`PrimarySurface`], [`primary_surface`]): the
//! point, normals and albedo a pixel's rays start from, rebuilt from depth just off the surface,
//! and the emission the camera sees there ([`primary_emission`]). Screen probes, the denoiser,
//! the primary lighting and the cache view read it.

use crate::camera::{CameraParams, primary_ray};
use crate::ray::{Ray, offset_ray_origin};
use crate::scene_data::GpuMaterial;
use crate::world_cache::finite_sample;
use glam::{UVec2, UVec4, Vec3, Vec4};

/// The primary hit of a pixel, rebuilt from the G-buffer.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct PrimarySurface {
    /// Hit point offset off the surface toward the camera.
    pub position: Vec3,
    /// Unit geometric normal facing the camera.
    pub geometric_normal: Vec3,
    /// Unit shading normal on the geometric normal's side.
    pub shading_normal: Vec3,
    /// Whether the pixel sees a surface.
    pub valid: bool,
}

/// The primary hit of `pixel` from its G-buffer depth and normals: the point of the G-buffer's own
/// primary ray at that linear depth, offset by [`offset_ray_origin`] with the depth as the size
/// (32 ULPs of it cover the few ULPs the depth round trip loses).
#[inline]
pub fn primary_surface(
    camera: &CameraParams,
    pixel: UVec2,
    depth: f32,
    geometric_normal: Vec4,
    shading_normal: Vec4,
) -> PrimarySurface {
    let ray = primary_ray(camera, pixel, camera.jitter());
    let direction = Vec3::from_array(ray.direction);
    let along = direction.dot(camera.forward());
    let ng = geometric_normal.truncate().normalize_or_zero();
    let mut ns = shading_normal.truncate().normalize_or_zero();
    let valid = depth > 0.0 && geometric_normal.w > 0.0 && along > 0.0 && ng != Vec3::ZERO;
    if ns.dot(ng) <= 0.0 {
        ns = ng;
    }
    let p = point_on(&ray, along, if valid { depth } else { 0.0 });
    PrimarySurface {
        position: offset_ray_origin(p, ng, depth),
        geometric_normal: ng,
        shading_normal: ns,
        valid,
    }
}

/// The point at linear depth `depth` on `pixel`'s primary ray (the G-buffer's, with the frame's
/// jitter), not offset off its surface; the eye for a depth or a ray that is not in front.
#[inline]
pub fn primary_point(camera: &CameraParams, pixel: UVec2, depth: f32) -> Vec3 {
    let ray = primary_ray(camera, pixel, camera.jitter());
    let along = Vec3::from_array(ray.direction).dot(camera.forward());
    point_on(&ray, along, depth)
}

/// The point at linear depth `depth` on primary ray `ray`, whose direction has forward
/// component `along`; the ray's origin for a depth or a ray that is not in front.
#[inline]
fn point_on(ray: &Ray, along: f32, depth: f32) -> Vec3 {
    let t = if depth > 0.0 && along > 0.0 {
        depth / along
    } else {
        0.0
    };
    Vec3::from_array(ray.origin) + Vec3::from_array(ray.direction) * t
}

/// The primary hit's emission toward the camera: the G-buffer's `emissive` (× the multiplier)
/// when the camera sees the triangle's front face or the material is double-sided (`ids` as the
/// G-buffer stores them: instance, primitive, material, front face), as the path tracer counts it.
#[inline]
pub fn primary_emission(
    materials: &[GpuMaterial],
    ids: UVec4,
    emissive: Vec4,
    multiplier: f32,
) -> Vec3 {
    let double_sided =
        (ids.z as usize) < materials.len() && materials[ids.z as usize].double_sided != 0;
    if ids.w == 1 || double_sided {
        finite_sample(emissive.truncate() * multiplier)
    } else {
        Vec3::ZERO
    }
}

#[cfg(test)]
pub(crate) mod tests {
    use super::*;
    use crate::cache_view::cache_ray;
    use crate::random::Random;

    pub(crate) fn camera() -> CameraParams {
        CameraParams::new(Vec3::new(0.0, 0.0, 5.0), Vec3::NEG_Z, Vec3::Y, 0.8, 32, 24)
    }

    /// A wall at z = 0 facing the camera, seen by every pixel.
    pub(crate) fn wall(camera: &CameraParams, pixel: UVec2) -> PrimarySurface {
        let ray = primary_ray(camera, pixel, camera.jitter());
        let d = Vec3::from_array(ray.direction);
        let t = 5.0 / -d.z;
        let depth = t * d.dot(camera.forward());
        primary_surface(
            camera,
            pixel,
            depth,
            Vec4::new(0.0, 0.0, 1.0, 1.0),
            Vec4::new(0.0, 0.0, 1.0, 1.0),
        )
    }

    #[test]
    fn primary_surfaces_are_rebuilt_just_off_the_wall() {
        let c = camera();
        for (x, y) in [(0, 0), (16, 12), (31, 23)] {
            let s = wall(&c, UVec2::new(x, y));
            assert!(s.valid);
            assert!(s.position.z > 0.0 && s.position.z < 1e-4, "{}", s.position);
            assert_eq!(s.geometric_normal, Vec3::Z);
        }
        let sky = primary_surface(&c, UVec2::ZERO, 0.0, Vec4::ZERO, Vec4::ZERO);
        assert!(!sky.valid);
        // Cosine rays leave the wall's front side, with the cosine distribution's mean cosine 2/3.
        let s = wall(&c, UVec2::new(3, 4));
        let mut rng = Random::new(1, 0);
        let n = 20_000;
        let mut mean = 0.0f64;
        for _ in 0..n {
            let r = cache_ray(&s, rng.next_vec2());
            let d = Vec3::from_array(r.direction);
            assert!(d.z > 0.0 && r.is_traceable());
            mean += f64::from(d.z);
        }
        assert!((mean / f64::from(n) - 2.0 / 3.0).abs() < 0.01);
    }
}
