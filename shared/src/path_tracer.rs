//! The reference path tracer's per-path function, shared by the kernels and the CPU.
//!
//! rust-gpu cannot keep storage-buffer slices (nor an acceleration structure) in a struct, so the
//! path is not generic over a tracer object: it is a state machine. The caller owns the loop and
//! the tracing (ray queries, the software BVH on the GPU, or the host's BVH on the CPU):
//!
//! ```text
//! let mut path = begin_path(camera, params, pixel);
//! while path.active {
//!     let hit = closest_hit(&path.ray);
//!     shade(&mut path, &hit, params, <scene buffers>, lights, environment);
//!     if path.shadow_pending && !any_hit(&path.shadow_ray) {
//!         path.radiance += path.shadow_radiance;
//!     }
//! }
//! ```
//!
//! The loop ends: every step either ends the path or adds a bounce, and [`shade`] ends it at
//! [`PathTracerParams::max_bounces`] (clamped to [`MAX_BOUNCES`]).
//!
//! # Model
//!
//! Lambertian diffuse (albedo = base colour × texture) and emission; metallic and roughness are
//! ignored. Both sides of every surface are shaded (the normals are flipped toward the incoming
//! ray). Surfaces emit from their front (counter-clockwise) face, and from both faces when the
//! material is double-sided: a one-sided ceiling light must not light the ceiling behind it.
//! Next-event estimation picks one light uniformly (see [`crate::lights`]): an emissive triangle
//! is combined with BSDF sampling by multiple importance sampling (power heuristic); punctual
//! lights are sampled by NEE only (no ray can hit them). The sky is a constant radiance or an
//! equirectangular environment image ([`sky_radiance`]), seen by rays that escape and found by
//! BSDF sampling only (no importance sampling of the environment yet). Russian
//! roulette starts after [`ROULETTE_START`] bounces.
//!
//! `max_bounces` counts reflections: 0 shows only what the camera sees emit, 1 adds direct
//! lighting, and so on.

use bytemuck::{Pod, Zeroable};
use glam::{UVec2, Vec2, Vec3};

use crate::camera::{CameraParams, primary_ray};
use crate::hash::pcg_chain;
use crate::lights::{
    GpuLight, LIGHT_TRIANGLE, power_heuristic, punctual_incidence, russian_roulette_survival,
    sample_triangle_light, select_light, triangle_light_pdf,
};
use crate::math::{INV_PI, abs, acos, atan2, clamp, max, min_u32, to_u32_clamped};
use crate::random::Random;
use crate::ray::{HitRecord, Ray};
use crate::sampling::{sample_cosine_hemisphere, tangent_to_world};
use crate::scene_data::{
    GpuInstance, GpuMaterial, GpuMesh, GpuTexture, GpuTriangle, GpuVertex, fetch_surface,
    hit_surface, sample_material,
};

/// The largest bounce count a path may take, whatever the parameters ask.
pub const MAX_BOUNCES: u32 = 64;
/// Russian roulette applies from this many bounces on.
pub const ROULETTE_START: u32 = 3;
/// Workgroup size of the kernel, both directions.
pub const PATH_TRACER_TILE: u32 = 8;

/// The kernel's push constants (48 bytes).
///
/// | offset | field                 |
/// |--------|-----------------------|
/// | 0      | `sky`                 |
/// | 12     | `sample_index`        |
/// | 16     | `max_bounces`         |
/// | 20     | `emissive_multiplier` |
/// | 24     | `light_count`         |
/// | 28     | `seed`                |
/// | 32     | `environment_size`    |
/// | 40     | `_pad`                |
#[repr(C)]
#[derive(Clone, Copy, Debug, Default, PartialEq, Pod, Zeroable)]
pub struct PathTracerParams {
    /// Radiance of the sky, W/(sr·m²) (black for none).
    pub sky: [f32; 3],
    /// Index of this sample: the random streams of a pixel differ per sample.
    pub sample_index: u32,
    /// Reflections per path (see the [module](self)).
    pub max_bounces: u32,
    /// Factor on the emission of every surface.
    pub emissive_multiplier: f32,
    /// Number of lights in the light buffer (0 for none; the buffer then holds a placeholder).
    pub light_count: u32,
    /// Seed of every random stream.
    pub seed: u32,
    /// Width and height of the equirectangular environment image; zero for none (the sky is then
    /// the constant `sky`).
    pub environment_size: [u32; 2],
    /// Explicit padding.
    pub _pad: [u32; 2],
}

/// Radiance arriving from the sky along the unit `direction` (pointing away from the scene): the
/// environment image's texel when there is one, else the constant `params.sky`.
///
/// The environment is equirectangular in glTF's frame (+Y up): row 0 is straight up, the middle
/// column looks along -Z, u grows toward +X; `environment` holds its texels row by row (RGB, the
/// fourth channel unused). Nearest texel; a too-short buffer reads as black.
pub fn sky_radiance(params: &PathTracerParams, environment: &[[f32; 4]], direction: Vec3) -> Vec3 {
    let [w, h] = params.environment_size;
    if w == 0 || h == 0 {
        return Vec3::from_array(params.sky);
    }
    let u = 0.5 + atan2(direction.x, -direction.z) * (0.5 * INV_PI);
    let v = acos(clamp(direction.y, -1.0, 1.0)) * INV_PI;
    let x = min_u32(to_u32_clamped(u * w as f32), w - 1);
    let y = min_u32(to_u32_clamped(v * h as f32), h - 1);
    let i = y as usize * w as usize + x as usize;
    if i < environment.len() {
        let t = environment[i];
        Vec3::new(t[0], t[1], t[2])
    } else {
        Vec3::ZERO
    }
}

/// One path in flight (see the [module](self) for the loop that drives it).
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct PathState {
    /// The ray to trace next.
    pub ray: Ray,
    /// Product of BSDF × cosine / pdf (and roulette weights) so far.
    pub throughput: Vec3,
    /// Radiance gathered so far.
    pub radiance: Vec3,
    /// The path's random stream.
    pub rng: Random,
    /// Reflections so far: 0 while the camera ray is in flight.
    pub bounce: u32,
    /// Solid-angle density of the BSDF sample that made `ray`; 0 for the camera ray (emission it
    /// sees is counted in full).
    pub bsdf_pdf: f32,
    /// Whether the path goes on.
    pub active: bool,
    /// A shadow ray to trace after [`shade`], when `shadow_pending`.
    pub shadow_ray: Ray,
    /// What to add to `radiance` when `shadow_ray` hits nothing.
    pub shadow_radiance: Vec3,
    /// Whether [`shade`] left a shadow ray.
    pub shadow_pending: bool,
}

/// The random stream of `pixel`'s sample `params.sample_index`.
#[inline]
pub fn path_random(params: &PathTracerParams, pixel: UVec2) -> Random {
    Random::new(
        pcg_chain([pixel.x, pixel.y, params.seed]),
        params.sample_index,
    )
}

/// A new path through a uniformly jittered point of `pixel`.
pub fn begin_path(camera: &CameraParams, params: &PathTracerParams, pixel: UVec2) -> PathState {
    let mut rng = path_random(params, pixel);
    let jitter = rng.next_vec2() - Vec2::splat(0.5);
    let ray = primary_ray(camera, pixel, jitter);
    PathState {
        ray,
        throughput: Vec3::ONE,
        radiance: Vec3::ZERO,
        rng,
        bounce: 0,
        bsdf_pdf: 0.0,
        active: true,
        shadow_ray: ray,
        shadow_radiance: Vec3::ZERO,
        shadow_pending: false,
    }
}

/// A sample's radiance for accumulation: non-finite or negative samples count as black (as the
/// reference discards them) so that one bad path cannot spoil a pixel for ever.
#[inline]
pub fn finite_radiance(radiance: Vec3) -> Vec3 {
    if radiance.is_finite() && radiance.min_element() >= 0.0 {
        radiance
    } else {
        Vec3::ZERO
    }
}

/// Whether a surface of material `material` with front-face normal `front_normal` emits toward
/// `outgoing`: from its front face, or from both for a double-sided material.
#[inline]
pub fn emits_toward(
    materials: &[GpuMaterial],
    material: u32,
    front_normal: Vec3,
    outgoing: Vec3,
) -> bool {
    let double_sided =
        (material as usize) < materials.len() && materials[material as usize].double_sided != 0;
    double_sided || front_normal.dot(outgoing) > 0.0
}

/// Offset of a ray origin off a surface at `p`, scaled to the position's magnitude.
#[inline]
fn ray_epsilon(p: Vec3) -> f32 {
    1e-4 * max(1.0, p.abs().max_element())
}

/// Shades the hit `hit` of `path.ray`: adds emission (MIS-weighted) or sky, prepares a shadow ray
/// for next-event estimation, and samples the next ray, or ends the path.
#[allow(
    clippy::too_many_arguments,
    reason = "rust-gpu cannot keep storage-buffer slices in a struct: one argument per buffer"
)]
pub fn shade(
    path: &mut PathState,
    hit: &HitRecord,
    params: &PathTracerParams,
    instances: &[GpuInstance],
    meshes: &[GpuMesh],
    vertices: &[GpuVertex],
    triangles: &[GpuTriangle],
    materials: &[GpuMaterial],
    textures: &[GpuTexture],
    texels: &[u32],
    lights: &[GpuLight],
    environment: &[[f32; 4]],
) {
    path.shadow_pending = false;
    if !hit.is_hit() {
        let direction = Vec3::from_array(path.ray.direction).normalize_or_zero();
        path.radiance += path.throughput * sky_radiance(params, environment, direction);
        path.active = false;
        return;
    }
    let light_count = if (params.light_count as usize) < lights.len() {
        params.light_count
    } else {
        lights.len() as u32
    };
    let (surface, material) = hit_surface(
        instances, meshes, vertices, triangles, materials, textures, texels, hit,
    );
    let ray_direction = Vec3::from_array(path.ray.direction);
    let direction = ray_direction.normalize_or_zero();
    let position = Vec3::from_array(path.ray.origin) + ray_direction * hit.t;
    let mut ng = surface.geometric_normal;
    let mut ns = surface.shading_normal;
    if ng.dot(direction) > 0.0 {
        ng = -ng;
        ns = -ns;
    }
    if ng == Vec3::ZERO || direction == Vec3::ZERO {
        path.active = false;
        return;
    }
    if ns.dot(ng) <= 0.0 {
        // An interpolated normal pointing under the surface would send light through it.
        ns = ng;
    }

    let emission = material.emissive * params.emissive_multiplier;
    if emission.max_element() > 0.0
        && emits_toward(
            materials,
            surface.material,
            surface.geometric_normal,
            -direction,
        )
    {
        let weight = if path.bsdf_pdf > 0.0 && light_count > 0 {
            let distance = hit.t * ray_direction.length();
            let light_pdf =
                triangle_light_pdf(surface.area, distance * distance, ng.dot(direction))
                    / light_count as f32;
            power_heuristic(path.bsdf_pdf, light_pdf)
        } else {
            1.0
        };
        path.radiance += path.throughput * emission * weight;
    }

    if path.bounce >= params.max_bounces || path.bounce >= MAX_BOUNCES {
        path.active = false;
        return;
    }
    let albedo = material.base_color.truncate();
    let brdf = albedo * INV_PI;
    let origin = position + ng * ray_epsilon(position);

    // Next-event estimation: one light, chosen uniformly.
    if light_count > 0 {
        let index = select_light(light_count, path.rng.next_f32()) as usize;
        let light = if index < lights.len() {
            lights[index]
        } else {
            GpuLight::ZERO
        };
        let select_pdf = 1.0 / light_count as f32;
        let u = path.rng.next_vec2();
        if light.kind == LIGHT_TRIANGLE {
            let s = sample_triangle_light(&light, origin, u);
            let cos_surface = ns.dot(s.direction);
            let light_pdf = s.pdf * select_pdf;
            if light_pdf > 0.0 && cos_surface > 0.0 && ng.dot(s.direction) > 0.0 {
                let light_surface = fetch_surface(
                    instances,
                    meshes,
                    vertices,
                    triangles,
                    light.instance,
                    light.primitive,
                    s.barycentrics,
                );
                let emits = emits_toward(
                    materials,
                    light_surface.material,
                    light_surface.geometric_normal,
                    -s.direction,
                );
                let radiance = sample_material(
                    materials,
                    textures,
                    texels,
                    light_surface.material,
                    light_surface.uv,
                )
                .emissive
                    * params.emissive_multiplier;
                let weight = power_heuristic(light_pdf, cos_surface * INV_PI);
                path.shadow_radiance =
                    path.throughput * brdf * radiance * (cos_surface * weight / light_pdf);
                path.shadow_ray = Ray {
                    origin: origin.to_array(),
                    t_min: 0.0,
                    direction: s.direction.to_array(),
                    t_max: s.distance * (1.0 - 1e-3),
                };
                path.shadow_pending = emits && path.shadow_radiance.max_element() > 0.0;
            }
        } else {
            let incidence = punctual_incidence(&light, origin);
            let cos_surface = ns.dot(incidence.direction);
            if cos_surface > 0.0 && ng.dot(incidence.direction) > 0.0 {
                path.shadow_radiance =
                    path.throughput * brdf * incidence.irradiance * (cos_surface / select_pdf);
                path.shadow_ray = Ray {
                    origin: origin.to_array(),
                    t_min: 0.0,
                    direction: incidence.direction.to_array(),
                    t_max: incidence.distance,
                };
                path.shadow_pending = path.shadow_radiance.max_element() > 0.0;
            }
        }
    }

    // BSDF sampling: cosine-weighted, so throughput × f × cos / pdf = throughput × albedo.
    let local = sample_cosine_hemisphere(path.rng.next_vec2());
    let next = tangent_to_world(local, ns).normalize_or_zero();
    let cos_next = ns.dot(next);
    if cos_next <= 0.0 || ng.dot(next) <= 0.0 {
        path.active = false;
        return;
    }
    path.throughput *= albedo;
    path.bounce += 1;
    if path.bounce >= ROULETTE_START {
        let survival = russian_roulette_survival(path.throughput);
        if path.rng.next_f32() >= survival {
            path.active = false;
            return;
        }
        path.throughput /= survival;
    }
    path.bsdf_pdf = abs(cos_next) * INV_PI;
    path.ray = Ray {
        origin: origin.to_array(),
        t_min: 0.0,
        direction: next.to_array(),
        t_max: f32::INFINITY,
    };
}

#[cfg(test)]
mod tests {
    use super::*;
    use core::mem::{offset_of, size_of};

    #[test]
    fn layout() {
        assert_eq!(size_of::<PathTracerParams>(), 48);
        assert_eq!(offset_of!(PathTracerParams, sky), 0);
        assert_eq!(offset_of!(PathTracerParams, sample_index), 12);
        assert_eq!(offset_of!(PathTracerParams, max_bounces), 16);
        assert_eq!(offset_of!(PathTracerParams, emissive_multiplier), 20);
        assert_eq!(offset_of!(PathTracerParams, light_count), 24);
        assert_eq!(offset_of!(PathTracerParams, seed), 28);
        assert_eq!(offset_of!(PathTracerParams, environment_size), 32);
        assert_eq!(offset_of!(PathTracerParams, _pad), 40);
    }

    #[test]
    fn environment_lookup() {
        // 4 × 2 texels, each its own index.
        let env: [[f32; 4]; 8] = core::array::from_fn(|i| [i as f32, 0.0, 0.0, 0.0]);
        let params = PathTracerParams {
            sky: [9.0; 3],
            environment_size: [4, 2],
            ..Default::default()
        };
        let at = |d: Vec3| sky_radiance(&params, &env, d.normalize()).x;
        // Up is row 0, down row 1; -Z is the middle (u = 0.5), +X at u = 0.75, -X at u = 0.25.
        assert_eq!(at(Vec3::new(0.0, 0.5, -1.0)), 2.0);
        assert_eq!(at(Vec3::new(1.0, 0.5, 0.0)), 3.0);
        assert_eq!(at(Vec3::new(-1.0, 0.5, -0.01)), 1.0);
        assert_eq!(at(Vec3::new(0.0, -0.5, -1.0)), 6.0);
        // Straight up is row 0, whichever column.
        assert!(at(Vec3::Y) < 4.0);
        // +Z wraps to either edge column, never outside.
        let back = at(Vec3::new(0.0, 0.5, 1.0));
        assert!(back == 0.0 || back == 3.0);
        // Without an image the constant sky; with a short buffer black.
        let none = PathTracerParams {
            environment_size: [0, 0],
            ..params
        };
        assert_eq!(sky_radiance(&none, &env, Vec3::Y), Vec3::splat(9.0));
        assert_eq!(sky_radiance(&params, &env[..3], Vec3::NEG_Y), Vec3::ZERO);
    }

    #[test]
    fn bad_samples_are_black() {
        assert_eq!(finite_radiance(Vec3::ONE), Vec3::ONE);
        assert_eq!(finite_radiance(Vec3::new(f32::NAN, 0.0, 0.0)), Vec3::ZERO);
        assert_eq!(
            finite_radiance(Vec3::new(f32::INFINITY, 0.0, 0.0)),
            Vec3::ZERO
        );
        assert_eq!(finite_radiance(Vec3::new(-1.0, 0.0, 0.0)), Vec3::ZERO);
    }

    #[test]
    fn surfaces_emit_from_the_front_unless_double_sided() {
        let one = GpuMaterial::default();
        let two = GpuMaterial {
            double_sided: 1,
            ..one
        };
        let materials = [one, two];
        assert!(emits_toward(
            &materials,
            0,
            Vec3::Z,
            Vec3::new(0.0, 0.5, 1.0)
        ));
        assert!(!emits_toward(&materials, 0, Vec3::Z, Vec3::NEG_Z));
        assert!(emits_toward(&materials, 1, Vec3::Z, Vec3::NEG_Z));
        // An unknown material reads as the default, single-sided one.
        assert!(!emits_toward(&materials, 7, Vec3::Z, Vec3::NEG_Z));
    }

    /// A sky-only scene: every camera ray misses and sees the sky, whatever the bounce count.
    #[test]
    fn escaping_rays_see_the_sky() {
        let camera = CameraParams::new(Vec3::ZERO, Vec3::NEG_Z, Vec3::Y, 1.0, 4, 4);
        let params = PathTracerParams {
            sky: [0.5, 1.0, 2.0],
            max_bounces: 4,
            emissive_multiplier: 1.0,
            ..Default::default()
        };
        let mut path = begin_path(&camera, &params, UVec2::new(1, 2));
        shade(
            &mut path,
            &HitRecord::miss(),
            &params,
            &[],
            &[],
            &[],
            &[],
            &[],
            &[],
            &[],
            &[],
            &[],
        );
        assert!(!path.active && !path.shadow_pending);
        assert_eq!(path.radiance, Vec3::new(0.5, 1.0, 2.0));
        // The same pixel and sample give the same stream; another sample another.
        let again = begin_path(&camera, &params, UVec2::new(1, 2));
        assert_eq!(
            again.ray,
            begin_path(&camera, &params, UVec2::new(1, 2)).ray
        );
        let other = PathTracerParams {
            sample_index: 1,
            ..params
        };
        assert_ne!(again.ray, begin_path(&camera, &other, UVec2::new(1, 2)).ray);
    }
}
