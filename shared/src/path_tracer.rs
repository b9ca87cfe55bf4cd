//! The reference path tracer's per-path function, shared by the kernels and the CPU.
//!
//! The path is not generic over a tracer object (a ray query's acceleration structure cannot be
//! held in a struct the path would carry): it is a state machine. The caller owns the loop and
//! the tracing (ray queries, the software BVH on the GPU, or the host's BVH on the CPU):
//!
//! ```text
//! let mut path = begin_path(camera, params, pixel);
//! while path.active {
//!     let hit = closest_hit(&path.ray);
//!     shade(&mut path, &hit, camera, params, surfaces, images, lights);
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
//!
//! Next-event estimation resamples [`PathTracerParams::light_candidates`] lights drawn in
//! proportion to power ([`crate::lights`]) with the unshadowed contribution as target (resampled
//! importance sampling, Talbot et al. 2005; [`crate::reservoir`]); one candidate means plain
//! power-proportional selection. Emissive triangles and the environment image are combined with
//! BSDF sampling by multiple importance sampling (power heuristic) with the candidate's source
//! density (selection probability × sample density), which both sides evaluate alike, so the
//! weights sum to one; punctual lights are sampled by NEE only (no ray can hit them). A
//! constant [`PathTracerParams::sky`] is found by BSDF sampling only (`gi` turns `--sky` into a
//! uniform environment image, which NEE samples). Russian roulette starts after
//! [`ROULETTE_START`] bounces.
//!
//! # Shading normals
//!
//! Interpolated normals change the shading, not the energy balance. The BSDF is the cosine lobe
//! around the shading normal `ns` *folded* about the geometric surface: the part of the lobe
//! below the geometric plane is mirrored above it (the reflection that Keller et al., "The Iray
//! Light Transport Simulation and Rendering System", 2017, apply to directions that end up below
//! the surface). Its cosine-weighted value is `albedo/π · (⟨ns·ω⟩ + ⟨ns·R(ω)⟩)` for `ω` above the
//! geometric surface, `R` the mirror about it: it integrates to `albedo` exactly, is sampled
//! exactly (a cosine sample, mirrored when below), and NEE evaluates the same function. A white
//! furnace therefore stays exact whatever the normals (`tests/tests/path_tracer.rs`); killing
//! directions below the surface lost 9% there.
//!
//! # Self-intersection
//!
//! Hit points come from the barycentrics, relative to a vertex
//! ([`Surface::position`](crate::scene_data::Surface::position)); rays leave them by
//! [`offset_ray_origin`], a few ULPs along the geometric normal, and shadow rays to an emissive
//! triangle end at the sampled point offset the same way toward the shading point.
//! Neither depends on the scene's scale.
//!
//! `max_bounces` counts reflections: 0 shows only what the camera sees emit, 1 adds direct
//! lighting, and so on.

use bytemuck::{Pod, Zeroable};
use glam::{UVec2, Vec2, Vec3};

use crate::camera::{CameraParams, primary_ray};
use crate::color::luminance;
use crate::elements::Elements;
use crate::environment::environment_pdf;
use crate::hash::pcg_chain;
use crate::lights::{
    self, GpuLight, LIGHT_ENVIRONMENT, LIGHT_TRIANGLE, LightSources, MAX_LIGHT_CANDIDATES,
    SceneLights, light_of_triangle, power_heuristic, russian_roulette_survival, sample_light,
    select_light, triangle_light_pdf,
};
use crate::math::{INV_PI, max, min_u32};
use crate::random::Random;
use crate::ray::{HitRecord, Ray, offset_ray_origin};
use crate::ray_cone::RayFootprint;
use crate::reservoir::Reservoir;
use crate::sampling::{sample_cosine_hemisphere, tangent_to_world};
use crate::scene_data::{
    GpuMaterial, GpuTriangle, GpuVertex, MaterialSample, SceneSurfaces, Surface, hit_surface,
};
use crate::textures::{TextureImages, UvFootprint};

/// The largest bounce count a path may take, whatever the parameters ask.
pub const MAX_BOUNCES: u32 = 64;
/// Russian roulette applies from this many bounces on.
pub const ROULETTE_START: u32 = 3;
/// Workgroup size of the kernel, both directions.
pub const PATH_TRACER_TILE: u32 = 8;

/// [`PathTracerParams::strategy`]: light sampling and BSDF sampling combined by MIS.
pub const STRATEGY_MIS: u32 = 0;
/// Light sampling alone finds the lights it can sample (BSDF-sampled rays that hit them count
/// nothing): for tests and comparisons.
pub const STRATEGY_LIGHTS_ONLY: u32 = 1;
/// BSDF sampling alone (no next-event estimation): for tests and comparisons. Punctual lights
/// are then invisible.
pub const STRATEGY_BSDF_ONLY: u32 = 2;

/// The kernel's push constants (64 bytes).
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
/// | 40     | `environment_light`   |
/// | 44     | `light_candidates`    |
/// | 48     | `strategy`            |
/// | 52     | `primary`             |
/// | 56     | `_pad`                |
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
    /// Index of the environment's [`LIGHT_ENVIRONMENT`] light, or [`crate::scene_data::NONE`]
    /// when the environment is not importance-sampled.
    pub environment_light: u32,
    /// Lights resampled per next-event estimate, 1 to [`MAX_LIGHT_CANDIDATES`].
    pub light_candidates: u32,
    /// [`STRATEGY_MIS`], [`STRATEGY_LIGHTS_ONLY`] or [`STRATEGY_BSDF_ONLY`].
    pub strategy: u32,
    /// [`PRIMARY_JITTERED`] (antialiased) or [`PRIMARY_PIXEL_CENTRE`].
    pub primary: u32,
    /// Explicit padding.
    pub _pad: [u32; 2],
}

/// [`PathTracerParams::primary`]: each path starts through a uniformly jittered point of its
/// pixel (an antialiased image).
pub const PRIMARY_JITTERED: u32 = 0;
/// [`PathTracerParams::primary`]: every path starts through the pixel's centre, the one primary
/// sample the GI frame's G-buffer takes, and reads the primary hit's textures filtered over the
/// pixel as the G-buffer does, so that a comparison measures lighting, not edges or aliasing.
pub const PRIMARY_PIXEL_CENTRE: u32 = 1;

/// Radiance arriving from the sky along the unit `direction` (pointing away from the scene): the
/// environment image's texel when there is one ([`crate::environment`] gives the mapping), else
/// the constant `params.sky`. `environment` holds its texels row by row (RGB, the fourth
/// channel unused); a too-short buffer reads as black.
pub fn sky_radiance(params: &PathTracerParams, environment: &[[f32; 4]], direction: Vec3) -> Vec3 {
    lights::sky_radiance(params.environment_size, params.sky, environment, direction)
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

/// A new path through a uniformly jittered point of `pixel`, or its centre
/// ([`PRIMARY_PIXEL_CENTRE`]; the jitter is drawn all the same, so the rest of the path takes
/// the same random numbers either way).
pub fn begin_path(camera: &CameraParams, params: &PathTracerParams, pixel: UVec2) -> PathState {
    let mut rng = path_random(params, pixel);
    let mut jitter = rng.next_vec2() - Vec2::splat(0.5);
    if params.primary == PRIMARY_PIXEL_CENTRE {
        jitter = Vec2::ZERO;
    }
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

/// What the texture reads at `path`'s next hit filter over: a pixel-centre camera ray's pixel
/// ([`RayFootprint::pixel`], the G-buffer's read), else a point (level 0). One point per pixel
/// aliases textures, and GI's comparisons counted that as its error (textured.gltf at 128 × 72:
/// relMSE 0.049 against a level-0 reference, 5.8e-5 against this one); jittered samples
/// integrate the pixel themselves, and later bounces the hemisphere.
#[inline]
pub fn hit_footprint(
    camera: &CameraParams,
    params: &PathTracerParams,
    path: &PathState,
) -> RayFootprint {
    if path.bounce == 0 && params.primary == PRIMARY_PIXEL_CENTRE {
        RayFootprint::pixel(camera)
    } else {
        RayFootprint::POINT
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

/// The folded cosine of the [module](self)'s BSDF: `⟨ns·ω⟩ + ⟨ns·R(ω)⟩` for the unit `omega`
/// above the geometric surface of unit normal `ng` (`R` the mirror about it), 0 below. The
/// BSDF's cosine-weighted value is `albedo/π` times this, and its sampling density `1/π` times it.
#[inline]
pub fn folded_cosine(ns: Vec3, ng: Vec3, omega: Vec3) -> f32 {
    let d = ng.dot(omega);
    if d.is_nan() || d <= 0.0 {
        return 0.0;
    }
    let mirrored = omega - ng * (2.0 * d);
    max(ns.dot(omega), 0.0) + max(ns.dot(mirrored), 0.0)
}

/// A direction drawn from the folded cosine lobe (`u` uniform in `[0, 1)²`): a cosine sample
/// around `ns`, mirrored about the geometric surface when it falls below it. Zero when it lies in
/// the surface.
#[inline]
pub fn sample_folded_cosine(ns: Vec3, ng: Vec3, u: Vec2) -> Vec3 {
    let omega = tangent_to_world(sample_cosine_hemisphere(u), ns).normalize_or_zero();
    let d = ng.dot(omega);
    if d < 0.0 {
        (omega - ng * (2.0 * d)).normalize_or_zero()
    } else if d > 0.0 {
        omega
    } else {
        Vec3::ZERO
    }
}

/// One light sample offered to next-event estimation's resampling.
#[derive(Clone, Copy)]
struct LightCandidate {
    /// BSDF × folded cosine × MIS weight (× nothing else): multiply by the radiance or
    /// irradiance to get the contribution.
    weight: Vec3,
    /// Radiance (or irradiance, for punctual lights) before emissive textures.
    radiance: Vec3,
    /// Source density: selection probability × the sample's density.
    pdf: f32,
    /// The shadow ray.
    ray: Ray,
    /// Index of the light.
    light: u32,
    /// Where on a triangle light (its barycentrics), for the emissive texture.
    barycentrics: Vec2,
}

impl LightCandidate {
    const NONE: Self = Self {
        weight: Vec3::ZERO,
        radiance: Vec3::ZERO,
        pdf: 0.0,
        ray: Ray {
            origin: [0.0; 3],
            t_min: 0.0,
            direction: [0.0; 3],
            t_max: 0.0,
        },
        light: 0,
        barycentrics: Vec2::ZERO,
    };
}

/// A diffuse shading point as next-event estimation needs it.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct ShadingFrame {
    /// Where shadow rays start (already offset off the surface).
    pub origin: Vec3,
    /// Unit shading normal on the geometric normal's side.
    pub ns: Vec3,
    /// Unit geometric normal facing the incoming ray.
    pub ng: Vec3,
    /// The Lambertian BRDF, albedo / π.
    pub brdf: Vec3,
}

/// Samples light `index` from `frame` (`u` uniform in `[0, 1)²`).
#[inline]
fn light_candidate(
    frame: &ShadingFrame,
    lights: &[GpuLight],
    index: u32,
    params: &PathTracerParams,
    environment: &[[f32; 4]],
    environment_cdf: &[f32],
    u: Vec2,
) -> LightCandidate {
    let light = if (index as usize) < lights.len() {
        lights[index as usize]
    } else {
        GpuLight::ZERO
    };
    let mut c = LightCandidate::NONE;
    c.light = index;
    let [w, h] = params.environment_size;
    let s = sample_light(
        &light,
        frame.origin,
        UVec2::new(w, h),
        environment,
        environment_cdf,
        u,
    );
    let cosine = folded_cosine(frame.ns, frame.ng, s.direction);
    let pdf = s.pdf * light.select_pmf;
    if pdf > 0.0 && cosine > 0.0 {
        if light.kind == LIGHT_TRIANGLE || light.kind == LIGHT_ENVIRONMENT {
            let mis = if params.strategy == STRATEGY_LIGHTS_ONLY {
                1.0
            } else {
                power_heuristic(pdf, cosine * INV_PI)
            };
            c.weight = frame.brdf * (cosine * mis);
        } else {
            // Punctual lights: no ray can hit them, so no MIS.
            c.weight = frame.brdf * cosine;
        }
        c.radiance = if light.kind == LIGHT_TRIANGLE {
            s.radiance * params.emissive_multiplier
        } else {
            s.radiance
        };
        c.pdf = pdf;
        c.barycentrics = s.barycentrics;
        c.ray = s.ray;
    }
    c
}

/// The MIS weight of a BSDF-sampled ray (density `bsdf_pdf`, 0 for a camera ray) that found a
/// light next-event estimation would have drawn with density `light_pdf` (0: it cannot).
#[inline]
pub fn bsdf_mis_weight(strategy: u32, bsdf_pdf: f32, light_pdf: f32) -> f32 {
    if bsdf_pdf > 0.0 && light_pdf > 0.0 {
        if strategy == STRATEGY_BSDF_ONLY {
            1.0
        } else if strategy == STRATEGY_LIGHTS_ONLY {
            0.0
        } else {
            power_heuristic(bsdf_pdf, light_pdf)
        }
    } else {
        1.0
    }
}

/// The density with which next-event estimation draws the unit `direction` toward the sky
/// (selection probability × the environment's solid-angle density); 0 when the environment is
/// not a light. BSDF-sampled rays that miss weigh their sky by MIS against it.
#[inline]
pub fn environment_light_pdf(
    params: &PathTracerParams,
    lights: &[GpuLight],
    environment_cdf: &[f32],
    direction: Vec3,
) -> f32 {
    let [w, h] = params.environment_size;
    let env = params.environment_light;
    if env < min_u32(params.light_count, lights.len() as u32) && w > 0 && h > 0 {
        lights[env as usize].select_pmf
            * environment_pdf(UVec2::new(w, h), environment_cdf, direction)
    } else {
        0.0
    }
}

/// The density with which next-event estimation draws the point `hit` of an emissive triangle of
/// area `area` (selection probability × solid-angle density); `cos_light` the cosine between the
/// ray and the triangle's normal, `direction_length` the length of the ray's direction (`hit.t`
/// is in its units). 0 when the triangle is not a light.
#[inline]
pub fn emitter_light_pdf(
    params: &PathTracerParams,
    lights: &[GpuLight],
    light_table: &[u32],
    hit: &HitRecord,
    area: f32,
    cos_light: f32,
    direction_length: f32,
) -> f32 {
    let light = light_of_triangle(light_table, hit.instance, hit.primitive);
    if light < min_u32(params.light_count, lights.len() as u32) {
        let distance = hit.t * direction_length;
        lights[light as usize].select_pmf * triangle_light_pdf(area, distance * distance, cos_light)
    } else {
        0.0
    }
}

/// What the surface a BSDF-sampled ray (direction `ray_direction`, not normalised: `hit.t` is
/// in its units) hit emits back along it, × the multiplier, and the density with which
/// next-event estimation would have drawn that point ([`emitter_light_pdf`], 0: not a light),
/// for the caller's MIS weight; `None` where the surface does not emit toward the ray.
#[inline]
pub fn hit_emission(
    params: &PathTracerParams,
    lighting: SceneLights<'_>,
    materials: &[GpuMaterial],
    hit: &HitRecord,
    surface: &Surface,
    material: &MaterialSample,
    ray_direction: Vec3,
) -> Option<(Vec3, f32)> {
    let emission = material.emissive * params.emissive_multiplier;
    let direction = ray_direction.normalize_or_zero();
    if emission.max_element() > 0.0
        && emits_toward(
            materials,
            surface.material,
            surface.geometric_normal,
            -direction,
        )
    {
        let light_pdf = emitter_light_pdf(
            params,
            lighting.sources.lights,
            lighting.light_table,
            hit,
            surface.area,
            surface.geometric_normal.dot(direction),
            ray_direction.length(),
        );
        Some((emission, light_pdf))
    } else {
        None
    }
}

/// Shades the hit `hit` of `path.ray`: adds emission (MIS-weighted) or sky, prepares a shadow ray
/// for next-event estimation, and samples the next ray, or ends the path.
///
/// `lighting` holds the lights next-event estimation samples and the triangle→light table
/// ([`light_of_triangle`]) that weighs a hit emitter against them.
pub fn shade<I: TextureImages + ?Sized>(
    path: &mut PathState,
    hit: &HitRecord,
    camera: &CameraParams,
    params: &PathTracerParams,
    surfaces: SceneSurfaces<'_, impl Elements<Item = GpuVertex>, impl Elements<Item = GpuTriangle>>,
    images: &I,
    lighting: SceneLights<'_>,
) {
    let sources = lighting.sources;
    let (lights, environment) = (sources.lights, sources.environment);
    let environment_cdf = sources.environment_cdf;
    path.shadow_pending = false;
    let light_count = min_u32(params.light_count, lights.len() as u32);
    let bsdf_pdf = path.bsdf_pdf;
    // BSDF sampling's MIS weight against light sampling, which would have drawn this sample
    // with density `light_pdf` (0: it cannot).
    let bsdf_weight = |light_pdf: f32| bsdf_mis_weight(params.strategy, bsdf_pdf, light_pdf);
    let ray_direction = Vec3::from_array(path.ray.direction);
    let direction = ray_direction.normalize_or_zero();
    if !hit.is_hit() {
        let light_pdf = environment_light_pdf(params, lights, environment_cdf, direction);
        path.radiance +=
            path.throughput * sky_radiance(params, environment, direction) * bsdf_weight(light_pdf);
        path.active = false;
        return;
    }
    let (surface, material) = hit_surface(
        surfaces,
        images,
        &path.ray,
        hit_footprint(camera, params, path),
        hit,
    );
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

    if let Some((emission, light_pdf)) = hit_emission(
        params,
        lighting,
        surfaces.materials,
        hit,
        &surface,
        &material,
        ray_direction,
    ) {
        path.radiance += path.throughput * emission * bsdf_weight(light_pdf);
    }

    if path.bounce >= params.max_bounces || path.bounce >= MAX_BOUNCES {
        path.active = false;
        return;
    }
    let albedo = material.base_color.truncate();
    let frame = ShadingFrame {
        origin: offset_ray_origin(surface.position, ng, surface.size),
        ns,
        ng,
        brdf: albedo * INV_PI,
    };

    if light_count > 0 && params.strategy != STRATEGY_BSDF_ONLY {
        let s = sample_direct_light(&frame, params, surfaces, images, sources, &mut path.rng);
        path.shadow_radiance = path.throughput * s.radiance;
        path.shadow_ray = s.ray;
        path.shadow_pending = path.shadow_radiance.max_element() > 0.0;
    }

    // BSDF sampling of the folded lobe: throughput × f × cos / pdf = throughput × albedo.
    let next = sample_folded_cosine(ns, ng, path.rng.next_vec2());
    let cosine = folded_cosine(ns, ng, next);
    if cosine.is_nan() || cosine <= 0.0 {
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
    path.bsdf_pdf = cosine * INV_PI;
    path.ray = Ray {
        origin: frame.origin.to_array(),
        t_min: 0.0,
        direction: next.to_array(),
        t_max: f32::INFINITY,
    };
}

/// One next-event estimate: a shadow ray and the outgoing radiance it adds when unoccluded.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct DirectLightSample {
    /// The shadow ray (meaningless when `radiance` is zero).
    pub ray: Ray,
    /// BRDF × folded cosine × MIS weight × light / source density: what an unoccluded `ray`
    /// adds to the outgoing radiance.
    pub radiance: Vec3,
}

/// Next-event estimation at `frame` over the first `params.light_count` lights: RIS over
/// `params.light_candidates` power-proportional candidates, emissive triangles and the
/// environment MIS-weighted against the folded cosine lobe (the weight that BSDF-sampled rays
/// complete with [`environment_light_pdf`] and [`emitter_light_pdf`]), punctual lights in full.
pub fn sample_direct_light<I: TextureImages + ?Sized>(
    frame: &ShadingFrame,
    params: &PathTracerParams,
    surfaces: SceneSurfaces<'_, impl Elements<Item = GpuVertex>, impl Elements<Item = GpuTriangle>>,
    images: &I,
    lighting: LightSources<'_>,
    rng: &mut Random,
) -> DirectLightSample {
    let LightSources {
        lights,
        environment,
        environment_cdf,
    } = lighting;
    let mut out = DirectLightSample {
        ray: LightCandidate::NONE.ray,
        radiance: Vec3::ZERO,
    };
    let light_count = min_u32(params.light_count, lights.len() as u32);
    if light_count == 0 {
        return out;
    }
    let candidates = if params.light_candidates == 0 {
        1
    } else {
        min_u32(params.light_candidates, MAX_LIGHT_CANDIDATES)
    };
    let mut reservoir = Reservoir::EMPTY;
    let mut chosen = LightCandidate::NONE;
    let mut target = 0.0;
    let mut i = 0;
    while i < candidates {
        let index = select_light(lights, light_count, rng.next_vec2());
        let c = light_candidate(
            frame,
            lights,
            index,
            params,
            environment,
            environment_cdf,
            rng.next_vec2(),
        );
        let p_hat = luminance(c.weight * c.radiance);
        let w = if c.pdf > 0.0 { p_hat / c.pdf } else { 0.0 };
        if reservoir.update(index, w, rng.next_f32()) {
            chosen = c;
            target = p_hat;
        }
        i += 1;
    }
    reservoir.finalize(target);
    if reservoir.ucw <= 0.0 {
        return out;
    }
    // The target used the light's radiance without its emissive texture: the contribution uses
    // the texture (the target only steers the choice; RIS stays unbiased).
    let mut radiance = chosen.radiance;
    let light = lights[chosen.light as usize];
    if light.kind == LIGHT_TRIANGLE {
        let s = surfaces.surface(light.instance, light.primitive, chosen.barycentrics);
        radiance = surfaces
            .material(images, s.material, s.uv, UvFootprint::POINT)
            .emissive
            * params.emissive_multiplier;
    }
    out.radiance = chosen.weight * radiance * reservoir.ucw;
    out.ray = chosen.ray;
    out
}

#[cfg(test)]
mod tests {
    use super::*;
    use core::mem::{offset_of, size_of};

    #[test]
    fn layout() {
        assert_eq!(size_of::<PathTracerParams>(), 64);
        assert_eq!(offset_of!(PathTracerParams, sky), 0);
        assert_eq!(offset_of!(PathTracerParams, sample_index), 12);
        assert_eq!(offset_of!(PathTracerParams, max_bounces), 16);
        assert_eq!(offset_of!(PathTracerParams, emissive_multiplier), 20);
        assert_eq!(offset_of!(PathTracerParams, light_count), 24);
        assert_eq!(offset_of!(PathTracerParams, seed), 28);
        assert_eq!(offset_of!(PathTracerParams, environment_size), 32);
        assert_eq!(offset_of!(PathTracerParams, environment_light), 40);
        assert_eq!(offset_of!(PathTracerParams, light_candidates), 44);
        assert_eq!(offset_of!(PathTracerParams, strategy), 48);
        assert_eq!(offset_of!(PathTracerParams, primary), 52);
        assert_eq!(offset_of!(PathTracerParams, _pad), 56);
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

    /// The folded lobe integrates to one over the upper geometric hemisphere for any shading
    /// normal, and its sampling follows its density.
    #[test]
    fn the_folded_lobe_keeps_its_energy() {
        let ng = Vec3::Z;
        let mut rng = Random::new(9, 0);
        for tilt in [0.0f32, 0.5, 0.96, 1.3] {
            let ns = Vec3::new(crate::math::sin(tilt), 0.0, crate::math::cos(tilt));
            // ∫ folded/π dω by uniform hemisphere sampling.
            let n = 200_000;
            let mut sum = 0.0f64;
            let mut mean_z_sampled = 0.0f64;
            let mut mean_z_weighted = 0.0f64;
            for _ in 0..n {
                let d = crate::sampling::sample_uniform_sphere(rng.next_vec2());
                let d = Vec3::new(d.x, d.y, d.z.abs());
                let f = f64::from(folded_cosine(ns, ng, d) * INV_PI) * 2.0 * core::f64::consts::PI;
                sum += f;
                mean_z_weighted += f * f64::from(d.z);
                let s = sample_folded_cosine(ns, ng, rng.next_vec2());
                assert!(s.z > 0.0 && (s.length() - 1.0).abs() < 1e-5);
                mean_z_sampled += f64::from(s.z);
            }
            let integral = sum / n as f64;
            assert!((integral - 1.0).abs() < 0.01, "tilt {tilt}: {integral}");
            // The sampled directions have the moments of the density.
            let (a, b) = (mean_z_sampled / n as f64, mean_z_weighted / n as f64);
            assert!((a - b).abs() < 0.01, "tilt {tilt}: {a} vs {b}");
        }
        assert_eq!(folded_cosine(Vec3::Z, Vec3::Z, Vec3::NEG_Z), 0.0);
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
            &camera,
            &params,
            SceneSurfaces::EMPTY,
            &[][..],
            SceneLights::EMPTY,
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
        // Pixel-centre primaries: every sample through the centre, the same stream after it.
        let centre = PathTracerParams {
            primary: PRIMARY_PIXEL_CENTRE,
            ..params
        };
        let a = begin_path(&camera, &centre, UVec2::new(1, 2));
        let b = begin_path(
            &camera,
            &PathTracerParams {
                sample_index: 5,
                ..centre
            },
            UVec2::new(1, 2),
        );
        assert_eq!(a.ray, b.ray);
        assert_eq!(a.ray, primary_ray(&camera, UVec2::new(1, 2), Vec2::ZERO));
        let mut jittered = begin_path(&camera, &params, UVec2::new(1, 2)).rng;
        let mut centred = a.rng;
        assert_eq!(jittered.next_vec2(), centred.next_vec2());
        // A pixel-centre camera ray filters its hit's textures over the pixel as the G-buffer
        // does; a jittered one, and every later bounce, reads level 0.
        assert_eq!(
            hit_footprint(&camera, &centre, &a),
            RayFootprint::pixel(&camera)
        );
        assert_ne!(hit_footprint(&camera, &centre, &a), RayFootprint::POINT);
        assert_eq!(hit_footprint(&camera, &params, &again), RayFootprint::POINT);
        let bounced = PathState { bounce: 1, ..a };
        assert_eq!(
            hit_footprint(&camera, &centre, &bounced),
            RayFootprint::POINT
        );
    }
}
