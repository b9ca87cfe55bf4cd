//! `gi cache-view`: the world-space hash-grid radiance cache seen on its own, before screen probes
//! exist. Each G-buffer pixel casts one cosine-distributed ray per frame ([`cache_ray`]); its
//! secondary hit queries and feeds the cache, the primary hit samples its direct light
//! ([`primary_direct_light`]), and the image converges to emission + albedo × (direct +
//! cache-lit indirect) ([`composite`], [`accumulate_sample`]). The cache's own passes are those
//! of the GI frame ([`crate::world_cache`]).

use crate::elements::Elements;
use crate::lights::LightSources;
use crate::math::INV_PI;
use crate::path_tracer::{
    DirectLightSample, ShadingFrame, sample_direct_light, sample_folded_cosine,
};
use crate::primary_surface::PrimarySurface;
use crate::random::Random;
use crate::ray::Ray;
use crate::scene_data::{GpuTriangle, GpuVertex, SceneSurfaces};
use crate::secondary_hits::path_params;
use crate::textures::TextureImages;
use crate::world_cache::{CacheFrameParams, RayRecord, finite_sample};
use glam::{Vec2, Vec3};

/// Workgroup of the per-pixel cache-view kernels: `CACHE_VIEW_TILE × CACHE_VIEW_TILE` pixels.
pub const CACHE_VIEW_TILE: u32 = 8;

/// The cosine ray of a primary surface: a direction of the folded cosine lobe (the path tracer's
/// BSDF, [`sample_folded_cosine`]), `u` uniform in `[0, 1)²`. Untraceable (it misses) when the
/// direction degenerates.
#[inline]
pub fn cache_ray(surface: &PrimarySurface, u: Vec2) -> Ray {
    let d = sample_folded_cosine(surface.shading_normal, surface.geometric_normal, u);
    Ray {
        origin: surface.position.to_array(),
        t_min: 0.0,
        direction: d.to_array(),
        t_max: if d == Vec3::ZERO { -1.0 } else { f32::INFINITY },
    }
}

/// The primary hit's next-event estimate of every light (the path tracer's
/// [`sample_direct_light`]): emissive triangles and the environment MIS-weighted against the
/// cosine ray, punctual lights in full. Its shadow ray is traced by TraceCacheRays.
pub fn primary_direct_light<I: TextureImages + ?Sized>(
    view: &CacheFrameParams,
    surface: &PrimarySurface,
    albedo: Vec3,
    surfaces: SceneSurfaces<'_, impl Elements<Item = GpuVertex>, impl Elements<Item = GpuTriangle>>,
    images: &I,
    lighting: LightSources<'_>,
    rng: &mut Random,
) -> DirectLightSample {
    if !surface.valid {
        return DirectLightSample {
            ray: Ray {
                origin: surface.position.to_array(),
                t_min: 0.0,
                direction: [0.0; 3],
                t_max: -1.0,
            },
            radiance: Vec3::ZERO,
        };
    }
    let frame = ShadingFrame {
        origin: surface.position,
        ns: surface.shading_normal,
        ng: surface.geometric_normal,
        brdf: albedo * INV_PI,
    };
    sample_direct_light(&frame, &path_params(view), surfaces, images, lighting, rng)
}

/// This frame's estimate of a pixel: the primary hit's emission and light sample, plus albedo ×
/// the cosine ray's radiance (a cosine-distributed ray estimates irradiance / π, which the diffuse
/// BRDF turns into albedo × radiance). Non-finite terms count as black.
#[inline]
pub fn composite(pixel: &RayRecord, albedo: Vec3) -> Vec3 {
    if pixel.surface == 0 {
        return finite_sample(Vec3::from_array(pixel.ray_radiance));
    }
    finite_sample(Vec3::from_array(pixel.base))
        + albedo * finite_sample(Vec3::from_array(pixel.ray_radiance))
}

/// Adds `sample` (made finite) to a running sum `(rgb, count)`.
#[inline]
pub fn accumulate_sample(sum: [f32; 4], sample: Vec3) -> [f32; 4] {
    let s = finite_sample(sample);
    [sum[0] + s.x, sum[1] + s.y, sum[2] + s.z, sum[3] + 1.0]
}

/// The mean of a running sum `(rgb, count)`; black when empty.
#[inline]
pub fn running_mean(sum: [f32; 4]) -> Vec3 {
    if sum[3] > 0.0 {
        Vec3::new(sum[0], sum[1], sum[2]) / sum[3]
    } else {
        Vec3::ZERO
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::lights::GpuLight;
    use crate::lights::SceneLights;
    use crate::primary_surface::tests::{camera, wall};
    use crate::ray::HitRecord;
    use crate::secondary_hits::{TracedRay, shade_cache_hit};
    use crate::world_cache::{
        CacheQuery, FLAG_ENVIRONMENT_LIGHT, NO_TILE, QUERY_BYPASS, QUERY_FED_BACK,
        needs_cache_radiance,
    };
    use glam::UVec2;

    #[test]
    fn primary_direct_light_is_unbiased_for_punctual_lights() {
        let c = camera();
        let s = wall(&c, UVec2::new(16, 12));
        // A point light 2 m in front of the wall and a directional light grazing the wall from
        // behind (no contribution).
        let mut lights = [
            GpuLight::point(s.position + Vec3::new(0.0, 0.0, 2.0), Vec3::splat(8.0)),
            GpuLight::directional(Vec3::Z, Vec3::splat(3.0)),
        ];
        for (l, p) in lights.iter_mut().zip([0.6f32, 0.4]) {
            l.select_pmf = p;
            l.alias = 0;
            l.alias_threshold = 1.0;
        }
        // Alias table for (0.6, 0.4) over 2 columns (p·2 = 1.2, 0.8).
        lights[1].alias_threshold = 0.8;
        let view = CacheFrameParams {
            light_count: 2,
            light_candidates: 4,
            ..Default::default()
        };
        let albedo = Vec3::splat(0.5);
        let exact = 0.5 * INV_PI * 8.0 / 4.0;
        let mut rng = Random::new(3, 0);
        let n = 40_000;
        let mut sum = 0.0f64;
        for _ in 0..n {
            let p = primary_direct_light(
                &view,
                &s,
                albedo,
                SceneSurfaces::EMPTY,
                &[][..],
                LightSources {
                    lights: &lights,
                    ..LightSources::EMPTY
                },
                &mut rng,
            );
            if p.radiance.x > 0.0 {
                assert!(Vec3::from_array(p.ray.direction).z > 0.99);
            }
            sum += f64::from(p.radiance.x);
        }
        let mean = sum / f64::from(n);
        assert!(
            (mean - f64::from(exact)).abs() < 0.01 * f64::from(exact),
            "{mean} vs {exact}"
        );
    }

    /// Each light path counted once: under a uniform sampled environment (a 1 × 1 image), light
    /// sampling plus the MIS-weighted cosine ray that misses give albedo × sky.
    #[test]
    fn sky_is_split_between_light_sampling_and_the_cosine_ray() {
        let c = camera();
        let s = wall(&c, UVec2::new(5, 7));
        let mut env = GpuLight::ENVIRONMENT;
        env.select_pmf = 1.0;
        env.alias_threshold = 1.0;
        let lights = [env];
        let environment = [[2.0f32, 2.0, 2.0, 0.0]];
        let cdf = [0.0f32, 1.0, 0.0, 1.0];
        let view = CacheFrameParams {
            light_count: 1,
            light_candidates: 1,
            environment_size: [1, 1],
            flags: FLAG_ENVIRONMENT_LIGHT,
            ..Default::default()
        };
        let lighting = SceneLights {
            sources: LightSources {
                lights: &lights,
                environment: &environment,
                environment_cdf: &cdf,
            },
            light_table: &[],
        };
        let albedo = Vec3::splat(0.5);
        let mut rng = Random::new(9, 0);
        let n = 100_000;
        let (mut nee, mut bsdf) = (0.0f64, 0.0f64);
        for _ in 0..n {
            let d = primary_direct_light(
                &view,
                &s,
                albedo,
                SceneSurfaces::EMPTY,
                &[][..],
                lighting.sources,
                &mut rng,
            );
            nee += f64::from(d.radiance.x);
            let ray = cache_ray(&s, rng.next_vec2());
            let traced = TracedRay {
                ray,
                hit: HitRecord::miss(),
                index: 0,
            };
            let hit = shade_cache_hit(&view, &s, &traced, SceneSurfaces::EMPTY, &[][..], lighting);
            bsdf += f64::from(albedo.x * hit.radiance.x);
        }
        let (nee, bsdf) = (nee / f64::from(n), bsdf / f64::from(n));
        // Both strategies carry a real share, and together they make albedo × sky.
        assert!(nee > 0.1 && bsdf > 0.1, "{nee} {bsdf}");
        assert!((nee + bsdf - 1.0).abs() < 0.01, "{nee} + {bsdf}");
    }

    #[test]
    fn composite_and_accumulation_stay_finite() {
        let px = RayRecord {
            ray_radiance: [1.0, 2.0, f32::NAN],
            surface: 1,
            base: [0.5, 0.0, 0.0],
            emissive: 0,
        };
        // A non-finite channel blackens its whole term.
        let c = composite(&px, Vec3::splat(0.5));
        assert_eq!(c, Vec3::new(0.5, 0.0, 0.0));
        let ok = RayRecord {
            ray_radiance: [1.0, 2.0, 0.0],
            ..px
        };
        assert_eq!(composite(&ok, Vec3::splat(0.5)), Vec3::new(1.0, 1.0, 0.0));
        let mut sum = [0.0; 4];
        sum = accumulate_sample(sum, composite(&ok, Vec3::splat(0.5)));
        sum = accumulate_sample(sum, Vec3::new(f32::INFINITY, 1.0, 1.0));
        assert_eq!(sum, [1.0, 1.0, 0.0, 2.0]);
        assert_eq!(running_mean(sum), Vec3::new(0.5, 0.5, 0.0));
        assert_eq!(running_mean([0.0; 4]), Vec3::ZERO);
        let q = CacheQuery {
            tile: 3,
            ..Default::default()
        };
        assert!(needs_cache_radiance(&q));
        assert!(!needs_cache_radiance(&CacheQuery {
            flags: QUERY_BYPASS,
            ..q
        }));
        assert!(!needs_cache_radiance(&CacheQuery {
            flags: QUERY_FED_BACK,
            ..q
        }));
        assert!(!needs_cache_radiance(&CacheQuery { tile: NO_TILE, ..q }));
    }
}
