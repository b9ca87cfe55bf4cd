//! Shading at secondary hits (GI-1.0's probe and cache rays): a ray's closest hit is shaded
//! ([`shade_cache_hit`]: a miss takes the environment, a front-facing emissive hit its emission,
//! both MIS-weighted against the primary hit's light sample), every hit appends a
//! [`CacheQuery`] for the light it reflects ([`surface_query`]),
//! and GenerateReservoirs samples one light for it through the light grid
//! ([`sample_query_light`]) into a shadow ray ([`shadow_ray`], [`shadow_ray_radiance`]).

use crate::elements::Elements;
use crate::light_grid::{
    DiffuseHit, LightGridEntry, LightGridParams, LightGridSample, light_grid_needed,
    sample_each_light, sample_light_grid,
};
use crate::lights::{LightSources, SceneLights, sky_radiance};
use crate::math::INV_PI;
use crate::packing::{pack_albedo10x3, pack_octahedral16, pack_snorm10x3};
use crate::path_tracer::{
    PathTracerParams, STRATEGY_BSDF_ONLY, STRATEGY_MIS, bsdf_mis_weight, environment_light_pdf,
    folded_cosine, hit_emission,
};
use crate::primary_surface::PrimarySurface;
use crate::random::Random;
use crate::ray::{HitRecord, Ray, offset_ray_origin};
use crate::ray_cone::{RayCone, RayFootprint};
use crate::scene_data::{
    GpuTriangle, GpuVertex, MaterialSample, NONE, SceneSurfaces, Surface, hit_surface,
};
use crate::screen_probes::PROBE_CELLS;
use crate::textures::TextureImages;
use crate::world_cache::{
    CacheFrameParams, CacheQuery, FLAG_EMITTERS_SAMPLED, FLAG_ENVIRONMENT_LIGHT, FLAG_PROBE_RAYS,
    NO_TILE, SHADOW_BYPASS, ShadowRay, finite_sample,
};
use glam::Vec3;

/// What the cosine ray found: radiance straight into the ray (a miss or an emissive hit), or a
/// query for the cache.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct CacheHit {
    /// Radiance the ray takes now.
    pub radiance: Vec3,
    /// The query (meaningful when `has_query`).
    pub query: CacheQuery,
    /// Whether the hit queries the cache.
    pub has_query: bool,
}

/// A ray a pass traced from a primary hit: the ray, its closest hit, and its index among the
/// frame's rays (the key that orders its query, `CacheQuery::ray_index`).
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct TracedRay {
    /// The cosine ray.
    pub ray: Ray,
    /// Its closest hit, or [`HitRecord::miss`].
    pub hit: HitRecord,
    /// Its index among the frame's rays (a pixel or a probe cell).
    pub index: u32,
}

/// Shades the cosine ray `traced` of `primary`: a miss
/// sees the sky; a hit on a side that emits takes its emission (× the multiplier) straight into
/// the ray, never into a cell ("adding emissive to cells enlarges the light and leaks"); both are
/// MIS-weighted against [`primary_direct_light`](crate::cache_view::primary_direct_light) as the path tracer weighs them. Every hit,
/// emitter or not, also becomes a query of a diffuse surface (normals facing the ray's origin):
/// an emitter reflects light too, and dropping it darkened every emissive surface's
/// surroundings (a closed furnace whose walls all emit got no reflected light at all).
pub fn shade_cache_hit<I: TextureImages + ?Sized>(
    view: &CacheFrameParams,
    primary: &PrimarySurface,
    traced: &TracedRay,
    surfaces: SceneSurfaces<'_, impl Elements<Item = GpuVertex>, impl Elements<Item = GpuTriangle>>,
    images: &I,
    lighting: SceneLights<'_>,
) -> CacheHit {
    let (ray, hit, ray_index) = (&traced.ray, &traced.hit, traced.index);
    let sources = lighting.sources;
    let (lights, environment) = (sources.lights, sources.environment);
    let mut out = CacheHit {
        radiance: Vec3::ZERO,
        query: CacheQuery::default(),
        has_query: false,
    };
    let direction = Vec3::from_array(ray.direction).normalize_or_zero();
    if direction == Vec3::ZERO || ray.t_max < 0.0 {
        return out;
    }
    let params = path_params(view);
    let strategy = if view.has(FLAG_PROBE_RAYS) {
        STRATEGY_BSDF_ONLY
    } else {
        STRATEGY_MIS
    };
    let bsdf_pdf =
        folded_cosine(primary.shading_normal, primary.geometric_normal, direction) * INV_PI;
    if !hit.is_hit() {
        let light_pdf = environment_light_pdf(&params, lights, sources.environment_cdf, direction);
        out.radiance = sky_radiance(view.environment_size, view.sky, environment, direction)
            * bsdf_mis_weight(strategy, bsdf_pdf, light_pdf);
        return out;
    }
    let (surface, material) = hit_surface(surfaces, images, ray, secondary_hit_footprint(), hit);
    // With emitter sampling the primary hit has taken a probe ray's emitter already.
    let ray_direction = Vec3::from_array(ray.direction);
    if !view.has(FLAG_PROBE_RAYS | FLAG_EMITTERS_SAMPLED)
        && let Some((emission, light_pdf)) = hit_emission(
            &params,
            lighting,
            surfaces.materials,
            hit,
            &surface,
            &material,
            ray_direction,
        )
    {
        // The emitter's light, MIS-weighted; what it reflects still comes from its cell below
        // (a cell never holds emission, so neither is counted twice).
        out.radiance = emission * bsdf_mis_weight(strategy, bsdf_pdf, light_pdf);
    }
    if let Some(query) = surface_query(ray, hit, &surface, &material, ray_index) {
        out.query = query;
        out.has_query = true;
    }
    out
}

/// The query of `ray`'s closest hit `hit` on `surface` with `material`: a diffuse surface at
/// the offset hit, its normals facing the ray's origin; `None` for a degenerate triangle or a
/// non-finite hit.
#[inline]
pub fn surface_query(
    ray: &Ray,
    hit: &HitRecord,
    surface: &Surface,
    material: &MaterialSample,
    ray_index: u32,
) -> Option<CacheQuery> {
    let direction = Vec3::from_array(ray.direction).normalize_or_zero();
    let mut ng = surface.geometric_normal;
    let mut ns = surface.shading_normal;
    if ng.dot(direction) > 0.0 {
        ng = -ng;
        ns = -ns;
    }
    if ng == Vec3::ZERO {
        return None;
    }
    if ns.dot(ng) <= 0.0 {
        ns = ng;
    }
    let distance = hit.t * Vec3::from_array(ray.direction).length();
    let query = CacheQuery {
        hit_position: keyed_hit_point(direction, surface).to_array(),
        ray_index,
        direction: pack_octahedral16(direction),
        hit_distance: distance,
        normal: pack_octahedral16(ns),
        geometric_normal: pack_snorm10x3(ng),
        albedo: pack_albedo10x3(material.base_color.truncate()),
        tile: NO_TILE,
        cell: 0,
        flags: 0,
    };
    if distance.is_finite() && query.position().is_finite() {
        Some(query)
    } else {
        None
    }
}

/// The point a hit on `surface` along unit `direction` is keyed and lit at: the hit offset off
/// the surface toward the ray's origin ([`offset_ray_origin`]). A query and a bounce ray that
/// reads the cache at the same hit both key this point: the hit itself rounds to either side of
/// a surface that lies on a cell's border (a floor at `y = 0`), and a bounce keyed there read an
/// empty cell beneath the floor, every frame, while the query filled the one above.
#[inline]
pub fn keyed_hit_point(direction: Vec3, surface: &Surface) -> Vec3 {
    let ng = surface.geometric_normal;
    let facing = if ng.dot(direction) > 0.0 { -ng } else { ng };
    offset_ray_origin(surface.position, facing, surface.size)
}

/// The path tracer's parameters that its light sampling and MIS read, from the view's: the
/// primary hit is lit exactly as the path tracer lights its first hit.
#[inline]
pub fn path_params(view: &CacheFrameParams) -> PathTracerParams {
    PathTracerParams {
        sky: view.sky,
        emissive_multiplier: view.emissive_multiplier,
        light_count: view.light_count,
        seed: view.seed,
        environment_size: view.environment_size,
        environment_light: if view.has(FLAG_ENVIRONMENT_LIGHT) && view.light_count > 0 {
            view.light_count - 1
        } else {
            NONE
        },
        light_candidates: view.light_candidates,
        strategy: STRATEGY_MIS,
        ..Default::default()
    }
}

/// The query's hit as light sampling shades it: diffuse, at its offset position.
#[inline]
pub fn diffuse_hit(query: &CacheQuery) -> DiffuseHit {
    DiffuseHit {
        position: query.position(),
        normal: query.shading_normal(),
        albedo: query.albedo(),
    }
}

/// The shadow ray of query `query_index` for a light sample: what an unoccluded ray adds to the
/// cell (and, when `bypass`, to the query's ray: [`SHADOW_BYPASS`]). A sample that cannot light
/// the hit (no candidate, zero or non-finite contribution) gives an untraceable ray that adds
/// zero: the cell still counts it, so that its mean is not taken over the lit samples alone.
#[inline]
pub fn shadow_ray(sample: &LightGridSample, query_index: u32, bypass: bool) -> ShadowRay {
    let ray = sample.contribution.sample.ray;
    let contribution = sample.radiance;
    let usable = sample.reservoir.ucw > 0.0
        && contribution.is_finite()
        && contribution.min_element() >= 0.0
        && contribution.max_element() > 0.0
        && ray.is_traceable();
    ShadowRay {
        origin: ray.origin,
        query: query_index,
        direction: ray.direction,
        t_max: if usable { ray.t_max } else { -1.0 },
        contribution: if usable {
            contribution.to_array()
        } else {
            [0.0; 3]
        },
        flags: if bypass { SHADOW_BYPASS } else { 0 },
    }
}

/// What a traced shadow ray adds: its contribution when it carries one and `occluded` is false,
/// else zero (still one sample of the cell).
#[inline]
pub fn shadow_ray_radiance(shadow: &ShadowRay, occluded: bool) -> Vec3 {
    if shadow.t_max < 0.0 || occluded {
        Vec3::ZERO
    } else {
        finite_sample(Vec3::from_array(shadow.contribution))
    }
}

/// Light sampling at a query's hit: through the light grid (RIS over its candidates), or over
/// every light where there are too few for a grid ([`light_grid_needed`]); one shadow ray
/// ([`shadow_ray`]).
#[inline]
pub fn sample_query_light(
    grid: &LightGridParams,
    entries: &[LightGridEntry],
    lighting: LightSources<'_>,
    query: &CacheQuery,
    rng: &mut Random,
) -> LightGridSample {
    if light_grid_needed(grid.light_count) {
        sample_light_grid(grid, entries, lighting, &diffuse_hit(query), rng)
    } else {
        sample_each_light(grid, lighting, &diffuse_hit(query), rng)
    }
}

/// The footprint a secondary hit's textures are filtered for: a probe traces one ray per
/// octahedral cell, each standing for that share of the hemisphere.
#[inline]
pub fn secondary_hit_footprint() -> RayFootprint {
    RayFootprint::cone(RayCone::hemisphere_share(0.0, PROBE_CELLS))
}
