//! `gi cache-view`: the world-space hash-grid radiance cache seen on its own, before screen probes
//! exist. Each G-buffer pixel casts one cosine-distributed ray per frame; its secondary hit queries
//! and feeds the cache, and the image converges to emission + albedo × (direct + cache-lit
//! indirect).
//!
//! This module holds the layouts every cache pass shares ([`CacheQuery`], [`ShadowRay`],
//! [`CacheViewPixel`], [`FeedbackTexel`], the push constants [`CachePassParams`] and the counter
//! words) and the per-item functions the kernels run, so that the CPU runs (and tests) them too.
//!
//! # Frame
//!
//! In the talk's order, with its pass names (`host/src/gi/` records them):
//!
//! 1. **PurgeRadianceCache**: [`begin_cache_frame`]; evict old tiles of the previous live list.
//! 2. **GBuffer**.
//! 3. **TraceCacheRays** (the stand-in for PopulateScreenProbes): [`primary_surface`] from the
//!    G-buffer, [`cache_ray`], then [`shade_cache_hit`]: a miss takes the environment, a
//!    front-facing emissive hit its emission (never put in a cell), both MIS-weighted, and every
//!    hit appends a [`CacheQuery`] for the light it reflects. The same pass samples the primary
//!    hit's direct light ([`primary_direct_light`]) and traces its shadow ray.
//! 4. **InsertRadianceCache**: each query's tile is found or inserted, touched, and its cell written
//!    into the query.
//! 5. **UpdateLightGrid**.
//! 6. **GenerateReservoirs**: [`feedback_lookup`] (temporal radiance feedback) or
//!    [`sample_query_light`] (RIS through the light grid, one [`ShadowRay`]); with ReSTIR, the
//!    hit also joins this frame's reservoir grid ([`insert_reservoir`]).
//! 7. World-space ReSTIR (optional): **ClearReservoirs** (before GenerateReservoirs),
//!    **CompactReservoirs** ([`reservoir_entry`] after a prefix scan of the slot counts, then
//!    [`ordered_reservoir_entry`], so that each cell's list has one order whatever the GPU's) and
//!    **ResampleReservoirs** ([`resample_reservoir`]: temporal reuse from the previous frame's
//!    grid, which replaces each shadow ray's light sample).
//! 8. **PopulateRadianceCache**: shadow rays; every sample is accumulated into the cell, an
//!    occluded one (or one that nothing could light) as zero ([`shadow_ray_radiance`]), so the
//!    cell's mean is not taken over the lit samples alone.
//! 9. **UpdateRadianceCache**: temporal blend and mips.
//! 10. **ResolveRadianceCache**: [`needs_cache_radiance`] queries add the cell's filtered radiance.
//! 11. **CacheViewComposite**: [`composite`] and [`accumulate_sample`].
//!
//! # Each light path counted once
//!
//! The primary hit is lit as the path tracer lights its first hit: [`primary_direct_light`]
//! (the path tracer's `sample_direct_light`: RIS over power-proportional candidates of the whole
//! light buffer, one shadow ray) samples every light; the cosine ray that misses or hits a
//! front-facing emitter adds the sky or emission × its power-heuristic weight against that light
//! sample's density ([`shade_cache_hit`]), so emissive triangles and a sampled environment are
//! shared between the two strategies with weights summing to one. Punctual lights, which no ray
//! can hit, come from the light sample alone (weight 1). An emitter hit also queries the cache,
//! for the light the emitter reflects (cells hold reflected light only). At the secondary hit,
//! RIS samples every light of the light buffer through the light grid and the hit's own emission
//! is never added. `gi` turns a constant `--sky` into a
//! uniform environment image (`Environment::constant` on the host), so both hits sample it; a
//! constant [`CacheViewParams::sky`] alone is not in the light buffer: the cosine ray alone finds
//! it at the primary hit, and secondary hits only through feedback.
//!
//! With temporal feedback, a secondary hit that reprojects into the previous frame's image takes
//! that image's radiance instead of a light sample: the image holds direct + indirect light, so
//! this adds further bounces ("(limited) infinite multi-bounce for free"). Every other hit, on
//! screen or not, gets them through the cache itself: with multi-bounce (`crate::multi_bounce`)
//! its sample adds `albedo ×` the previous frame's cell where its bounce ray lands.
//!
//! # Known bias
//!
//! * Without multi-bounce, further bounces exist only through feedback: an off-screen secondary
//!   hit gets direct light alone (a closed furnace of albedo 0.5 reads 1.75 of its exact 2.0;
//!   with multi-bounce it converges within 2%: `tests/tests/gi_furnace.rs`).
//! * A pixel that sees an emitter is no feedback source ([`feedback_texel`]): a hit that is not an
//!   emitter but reprojects onto one lies beside it and would take its emission (this brightened
//!   the Cornell box by 7%).
//! * The cache filters over its cells (and their mips while they hold under 16 samples).

use bytemuck::{Pod, Zeroable};
use glam::{UVec2, UVec4, Vec2, Vec3, Vec4};

use crate::atomics::AtomicWords;
use crate::camera::{CameraParams, primary_ray};
use crate::elements::Elements;
use crate::hash::pcg_chain;
use crate::hash_cells::accumulate::accumulate_sample as accumulate_cell_sample;
use crate::hash_cells::full_buckets::{is_admitted, is_new_tile, note_new_key, settle_tile};
use crate::hash_cells::lists::{
    FAILED_INSERTS, UPDATE_TILES, begin_frame, count, live_list, push_tile,
};
use crate::hash_cells::read::filtered_radiance;
use crate::hash_cells::storage::{TileInsert, insert_tile};
use crate::hash_cells::touch::{clear_tile_values, touch_tile};
use crate::hash_cells::{CellDescriptor, TILE_CELL_RATIO, cell_descriptor};
use crate::layout::HashCellValue;
use crate::layout::HashGridParams;
use crate::light_grid::{
    DiffuseHit, LightGridEntry, LightGridParams, LightGridSample, light_contribution,
    sample_light_grid, sample_params_uv,
};
use crate::lights::{GpuLight, sky_radiance};
use crate::math::{INV_PI, min_u32};
use crate::packing::{pack_snorm10x3, unpack_snorm10x3};
use crate::path_tracer::{
    DirectLightSample, PathTracerParams, STRATEGY_BSDF_ONLY, STRATEGY_MIS, ShadingFrame,
    bsdf_mis_weight, emits_toward, emitter_light_pdf, environment_light_pdf, folded_cosine,
    sample_direct_light, sample_folded_cosine,
};
use crate::radiance_feedback::{accepts, reproject};
use crate::random::Random;
use crate::ray::{HitRecord, Ray, offset_ray_origin};
use crate::ray_cone::{RayCone, RayFootprint};
use crate::scene_data::{
    GpuInstance, GpuMaterial, GpuMesh, GpuTexture, GpuTriangle, GpuVertex, MaterialSample, NONE,
    Surface, hit_surface,
};
use crate::screen_probes::PROBE_CELLS;
use crate::textures::TextureImages;
use crate::world_restir::{
    PackedReservoir, RESERVOIR_GRID_BUCKETS, RESERVOIR_GRID_NONE, RESERVOIR_GRID_SLOTS_PER_BUCKET,
    ReservoirCell, ReservoirHit, TemporalResampling, find_reservoir_cell, insert_reservoir_cell,
    jitter_in_tangent_plane, reservoir_cell, temporal_neighbour, temporal_neighbour_count,
};

/// Workgroup of the per-pixel cache-view kernels: `CACHE_VIEW_TILE × CACHE_VIEW_TILE` pixels.
pub const CACHE_VIEW_TILE: u32 = 8;

/// [`CacheQuery::tile`] of a query without a tile (not inserted yet, or its bucket was full).
pub const NO_TILE: u32 = u32::MAX;

/// [`CacheQuery::flags`]: temporal feedback lit the query; it gets no shadow ray and no cache
/// radiance.
pub const QUERY_FED_BACK: u32 = 1;
/// [`CacheQuery::flags`]: the hit is closer to the ray's origin than its cell's size, so its ray
/// uses its own unfiltered light sample, not the cell's filtered radiance (light-leak fix 2).
pub const QUERY_BYPASS: u32 = 2;

/// [`CacheQuery::flags`]: a query carried over from the previous frame by multi-bounce
/// (`crate::multi_bounce`): it refreshes the cell a bounce ray read, and has no ray of its own
/// (its `ray_index` has [`CARRIED_QUERY_BIT`] set, past every ray record).
pub const QUERY_CARRIED: u32 = 4;
/// [`CacheQuery::flags`], within InsertRadianceCache only: the query's bucket was full
/// ([`admit_query`] clears it).
pub const QUERY_REFUSED: u32 = 8;
/// Set in a carried query's `ray_index` (its parent's, so that its random streams stay keyed by
/// a ray, not by a list slot): no ray record is that large.
pub const CARRIED_QUERY_BIT: u32 = 1 << 31;

/// [`ShadowRay::flags`]: the query's ray takes the shadow ray's result itself (see
/// [`QUERY_BYPASS`]).
pub const SHADOW_BYPASS: u32 = 1;

/// [`CacheViewParams::flags`]: temporal radiance feedback on.
pub const FLAG_FEEDBACK: u32 = 1;
/// [`CacheViewParams::flags`]: the previous frame's image exists (feedback needs it).
pub const FLAG_HISTORY: u32 = 2;
/// [`CacheViewParams::flags`]: the descriptor's short-ray flag on (light-leak fix 1). Off, every
/// query is keyed as a long ray.
pub const FLAG_SHORT_RAY: u32 = 4;
/// [`CacheViewParams::flags`]: short queries bypass the cell's filtered radiance (light-leak
/// fix 2).
pub const FLAG_BYPASS: u32 = 8;
/// [`CacheViewParams::flags`]: world-space ReSTIR temporal reuse on.
pub const FLAG_RESTIR: u32 = 16;
/// [`CacheViewParams::flags`]: the previous frame's reservoir grid exists (ReSTIR was on then).
pub const FLAG_RESTIR_HISTORY: u32 = 32;
/// [`CacheViewParams::flags`]: the light buffer's last light is the environment (the path
/// tracer's `environment_light`), which MIS weighs misses against.
pub const FLAG_ENVIRONMENT_LIGHT: u32 = 64;
/// [`CacheViewParams::flags`]: the rays are screen-probe rays: their origin samples no emitter
/// and no environment (the GI frame's primary hit samples punctual lights alone), so a miss and
/// an emissive hit count in full rather than MIS-weighted.
pub const FLAG_PROBE_RAYS: u32 = 128;
/// [`CacheViewParams::flags`]: multi-bounce through the world cache (`crate::multi_bounce`):
/// every query that takes a light sample also traces a bounce ray and adds the cell it hits.
pub const FLAG_MULTI_BOUNCE: u32 = 256;
/// [`CacheViewParams::flags`], with [`FLAG_PROBE_RAYS`]: the GI frame's primary hit samples the
/// emissive triangles (`FLAG_EMITTER_SAMPLING`), so a probe ray's emissive hit adds nothing (a
/// miss still brings the sky in full).
pub const FLAG_EMITTERS_SAMPLED: u32 = 512;

/// Counter words of the cache view's counter buffer (the hash grid keeps its own counters in its
/// list buffer, `hash_cells::lists`): queries appended this frame.
pub const QUERY_COUNT: usize = 0;
/// Shadow rays appended this frame.
pub const SHADOW_RAY_COUNT: usize = 1;
/// Queries lit by temporal feedback this frame.
pub const FEEDBACK_COUNT: usize = 2;
/// Tiles inserted this frame (new keys; each also joins the live list).
pub const INSERTED_TILES: usize = 3;
/// Queries flagged [`QUERY_BYPASS`] this frame.
pub const BYPASS_COUNT: usize = 4;
/// Bounce rays that hit a surface whose cell the cache did not have, or had without a sample:
/// they added nothing (`crate::multi_bounce`; every shadow ray traces one bounce ray).
pub const BOUNCE_MISSES: usize = 5;
/// Queries carried to the next frame (appended by PopulateRadianceCache; the one counter that
/// outlives its frame, read by [`begin_cache_frame`]).
pub const CARRIED_NEXT: usize = 6;
/// Queries carried into this frame: the first this many of the query list.
pub const CARRIED_QUERIES: usize = 7;
/// Words of the cache view's counter buffer (8 used).
pub const CACHE_COUNTER_WORDS: usize = 8;

/// Indirect dispatches of a frame, as indices into the arguments buffer: the previous live list.
pub const ARGS_PURGE: u32 = 0;
/// Indirect arguments: one invocation per query.
pub const ARGS_QUERIES: u32 = 1;
/// Indirect arguments: one invocation per light-grid entry (written by the grid-params kernel).
pub const ARGS_LIGHT_GRID: u32 = 2;
/// Indirect arguments: one invocation per shadow ray.
pub const ARGS_SHADOW_RAYS: u32 = 3;
/// Indirect arguments: one invocation per tile to update.
pub const ARGS_UPDATE: u32 = 4;
/// Number of indirect argument slots.
pub const ARGS_COUNT: u32 = 5;

const _: () = assert!(CARRIED_QUERIES < CACHE_COUNTER_WORDS);
const _: () = assert!(ARGS_UPDATE < ARGS_COUNT);

/// Start of frame `frame` (one invocation): zeroes the cache view's counters and the hash grid's
/// (all but the previous live list, which the purge reads: [`begin_frame`]). The queries the
/// previous frame carried over (at most `carried_capacity`) become the first of this frame's
/// query list: [`CARRIED_QUERIES`] and [`QUERY_COUNT`] start at their count, and
/// [`carry_query`] copies them there.
#[inline]
pub fn begin_cache_frame<L: AtomicWords + ?Sized, C: AtomicWords + ?Sized>(
    lists: &mut L,
    counters: &mut C,
    frame: u32,
    carried_capacity: u32,
) {
    begin_frame(lists, frame);
    let carried = if CARRIED_NEXT < counters.word_count() {
        crate::math::min_u32(counters.load(CARRIED_NEXT), carried_capacity)
    } else {
        0
    };
    let mut i = 0;
    while i < CACHE_COUNTER_WORDS && i < counters.word_count() {
        counters.store(i, 0);
        i += 1;
    }
    if CARRIED_QUERIES < counters.word_count() {
        counters.store(CARRIED_QUERIES, carried);
        counters.store(QUERY_COUNT, carried);
    }
}

/// The carried query `index` of the previous frame (from `carried`, the list PopulateRadianceCache
/// appended to) as query `index` of this frame, when [`begin_cache_frame`] counted it.
#[inline]
pub fn carry_query<C: AtomicWords + ?Sized>(
    counters: &C,
    carried: &[CacheQuery],
    queries: &mut [CacheQuery],
    index: u32,
) {
    let i = index as usize;
    if index < counters.load(CARRIED_QUERIES) && i < carried.len() && i < queries.len() {
        queries[i] = carried[i];
    }
}

/// The view's settings as the kernels see them (80 bytes).
///
/// | offset | field                    |
/// |--------|--------------------------|
/// | 0      | `sky`                    |
/// | 12     | `frame_index`            |
/// | 16     | `emissive_multiplier`    |
/// | 20     | `light_count`            |
/// | 24     | `seed`                   |
/// | 28     | `flags`                  |
/// | 32     | `environment_size`       |
/// | 40     | `environment_irradiance` |
/// | 44     | `light_candidates`       |
/// | 48     | `image_size`             |
/// | 56     | `max_groups`             |
/// | 60     | `reservoir_cell_const`   |
/// | 64     | `previous_eye`           |
/// | 76     | `reservoir_buckets`      |
#[repr(C)]
#[derive(Clone, Copy, Debug, Default, PartialEq, Pod, Zeroable)]
pub struct CacheViewParams {
    /// Constant sky radiance for misses without an environment image.
    pub sky: [f32; 3],
    /// Frame counter: random streams differ per frame.
    pub frame_index: u32,
    /// Factor on every surface's emission.
    pub emissive_multiplier: f32,
    /// Lights in the light buffer.
    pub light_count: u32,
    /// Seed of every random stream.
    pub seed: u32,
    /// [`FLAG_FEEDBACK`], [`FLAG_HISTORY`], [`FLAG_SHORT_RAY`], [`FLAG_BYPASS`], [`FLAG_RESTIR`],
    /// [`FLAG_RESTIR_HISTORY`], [`FLAG_ENVIRONMENT_LIGHT`], [`FLAG_PROBE_RAYS`],
    /// [`FLAG_MULTI_BOUNCE`].
    pub flags: u32,
    /// Width and height of the environment image (zero for none: misses see `sky`).
    pub environment_size: [u32; 2],
    /// The light grid's weight of the environment light (see
    /// [`LightGridParams::environment_irradiance`]).
    pub environment_irradiance: f32,
    /// RIS candidates of the primary hit's next-event estimate, 1 to
    /// [`crate::lights::MAX_LIGHT_CANDIDATES`].
    pub light_candidates: u32,
    /// Image width and height.
    pub image_size: [u32; 2],
    /// `maxComputeWorkGroupCount[0]`: kernels that write indirect arguments clamp to it.
    pub max_groups: u32,
    /// The reservoir grid's cell size per unit of distance
    /// (`world_restir::reservoir_cell_const`).
    pub reservoir_cell_const: f32,
    /// The previous frame's eye: the previous reservoir grid's levels were taken from it.
    pub previous_eye: [f32; 3],
    /// Buckets of the reservoir grid ([`reservoir_grid_buckets`]).
    pub reservoir_buckets: u32,
}

impl CacheViewParams {
    /// Whether every bit of `flag` is set.
    #[inline]
    pub fn has(&self, flag: u32) -> bool {
        self.flags & flag == flag
    }
}

/// The push constants of every cache pass (128 bytes, the most every device offers).
#[repr(C)]
#[derive(Clone, Copy, Debug, Default, PartialEq, Pod, Zeroable)]
pub struct CachePassParams {
    /// The hash grid's parameters (eye, LOD constants, sizes, frame).
    pub grid: HashGridParams,
    /// The view's.
    pub view: CacheViewParams,
}

/// One secondary hit that queries the cache (80 bytes), appended by TraceCacheRays.
///
/// | offset | field              |
/// |--------|--------------------|
/// | 0      | `hit_position`     |
/// | 12     | `ray_index`        |
/// | 16     | `direction`        |
/// | 28     | `hit_distance`     |
/// | 32     | `normal`           |
/// | 44     | `geometric_normal` |
/// | 48     | `albedo`           |
/// | 60     | `tile`             |
/// | 64     | `cell`             |
/// | 68     | `flags`            |
/// | 72     | `_pad`             |
#[repr(C)]
#[derive(Clone, Copy, Debug, Default, PartialEq, Pod, Zeroable)]
pub struct CacheQuery {
    /// The hit point, already offset off the surface toward the ray's origin (shadow rays start
    /// here; the descriptor keys it).
    pub hit_position: [f32; 3],
    /// The pixel whose ray hit: `y · width + x`.
    pub ray_index: u32,
    /// Unit direction of the ray.
    pub direction: [f32; 3],
    /// Distance from the ray's origin to the hit.
    pub hit_distance: f32,
    /// Unit shading normal, facing the ray's origin.
    pub normal: [f32; 3],
    /// Unit geometric normal facing the ray's origin, as `pack_snorm10x3`.
    pub geometric_normal: u32,
    /// Diffuse albedo (the secondary material is forced diffuse).
    pub albedo: [f32; 3],
    /// The tile (slot) of the hit's cell, written by InsertRadianceCache; [`NO_TILE`] before or
    /// when the bucket was full.
    pub tile: u32,
    /// The mip-0 cell inside the tile, `x + 8 · y`.
    pub cell: u32,
    /// [`QUERY_FED_BACK`], [`QUERY_BYPASS`].
    pub flags: u32,
    /// Explicit padding.
    pub _pad: [u32; 2],
}

impl CacheQuery {
    /// Hit position.
    #[inline]
    pub fn position(&self) -> Vec3 {
        Vec3::from_array(self.hit_position)
    }

    /// Ray direction.
    #[inline]
    pub fn ray_direction(&self) -> Vec3 {
        Vec3::from_array(self.direction)
    }

    /// The mip-0 cell as `[x, y]`.
    #[inline]
    pub fn cell_xy(&self) -> [u32; 2] {
        [self.cell & 7, (self.cell >> 3) & 7]
    }

    /// Whether every bit of `flag` is set.
    #[inline]
    pub fn has(&self, flag: u32) -> bool {
        self.flags & flag == flag
    }
}

/// One shadow ray of PopulateRadianceCache (48 bytes), appended by GenerateReservoirs.
///
/// | offset | field          |
/// |--------|----------------|
/// | 0      | `origin`       |
/// | 12     | `query`        |
/// | 16     | `direction`    |
/// | 28     | `t_max`        |
/// | 32     | `contribution` |
/// | 44     | `flags`        |
#[repr(C)]
#[derive(Clone, Copy, Debug, Default, PartialEq, Pod, Zeroable)]
pub struct ShadowRay {
    /// Origin (the query's offset hit point).
    pub origin: [f32; 3],
    /// Index of the query in the query list.
    pub query: u32,
    /// Direction toward the light sample (not normalised for triangle lights: `t_max` = 1).
    pub direction: [f32; 3],
    /// End of the ray, in units of `direction`.
    pub t_max: f32,
    /// Outgoing radiance toward the query's ray origin if the ray is unoccluded (finite, ≥ 0).
    pub contribution: [f32; 3],
    /// [`SHADOW_BYPASS`].
    pub flags: u32,
}

impl ShadowRay {
    /// The ray to trace.
    #[inline]
    pub fn ray(&self) -> Ray {
        Ray {
            origin: self.origin,
            t_min: 0.0,
            direction: self.direction,
            t_max: self.t_max,
        }
    }
}

/// One pixel's cosine ray and the primary hit's own terms (32 bytes), written by TraceCacheRays,
/// completed by the cache passes and read by the composite.
#[repr(C)]
#[derive(Clone, Copy, Debug, Default, PartialEq, Pod, Zeroable)]
pub struct CacheViewPixel {
    /// Radiance arriving along the cosine ray (sky, emission, feedback, light sample or cache).
    pub ray_radiance: [f32; 3],
    /// 1 when the pixel sees a surface.
    pub surface: u32,
    /// The primary hit's emission toward the camera plus its light sample.
    pub base: [f32; 3],
    /// 1 when the primary hit emits toward the camera: the pixel is then no feedback source (a
    /// hit that is not an emitter and reprojects there lies on another surface, next to the
    /// emitter, and would take its emission).
    pub emissive: u32,
}

/// One pixel of the previous frame's image as temporal feedback reads it (32 bytes), written by the
/// composite after feedback has read it.
#[repr(C)]
#[derive(Clone, Copy, Debug, Default, PartialEq, Pod, Zeroable)]
pub struct FeedbackTexel {
    /// The pixel's radiance toward the camera, resolved from its irradiance before the denoiser
    /// (the denoised image lags).
    pub radiance: [f32; 3],
    /// Linear depth; 0 for sky.
    pub depth: f32,
    /// Unit geometric normal facing the camera.
    pub normal: [f32; 3],
    /// 1 when the pixel saw a surface.
    pub valid: u32,
}

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
    let t = if valid { depth / along } else { 0.0 };
    let p = Vec3::from_array(ray.origin) + direction * t;
    PrimarySurface {
        position: offset_ray_origin(p, ng, depth),
        geometric_normal: ng,
        shading_normal: ns,
        valid,
    }
}

/// [`pass_random`]'s stream of TraceCacheRays.
pub const PASS_TRACE: u32 = 0;
/// [`pass_random`]'s stream of GenerateReservoirs.
pub const PASS_GENERATE: u32 = 1;
/// [`pass_random`]'s stream of the light grid's build.
pub const PASS_LIGHT_GRID: u32 = 2;
/// [`pass_random`]'s stream of ResampleReservoirs.
pub const PASS_RESTIR: u32 = 3;
/// [`pass_random`]'s stream of the bounce rays of PopulateRadianceCache.
pub const PASS_BOUNCE: u32 = 4;

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

/// The random stream of `pixel` in frame `frame` for pass `pass` (streams of different passes are
/// independent).
#[inline]
pub fn pass_random(seed: u32, pixel_or_item: u32, pass: u32, frame: u32) -> Random {
    Random::new(pcg_chain([pixel_or_item, pass, seed]), frame)
}

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

/// Shades the cosine ray `ray` of `primary`, pixel `ray_index`, with closest hit `hit`: a miss
/// sees the sky; a hit on a side that emits takes its emission (× the multiplier) straight into
/// the ray, never into a cell ("adding emissive to cells enlarges the light and leaks"); both are
/// MIS-weighted against [`primary_direct_light`] as the path tracer weighs them. Every hit,
/// emitter or not, also becomes a query of a diffuse surface (normals facing the ray's origin):
/// an emitter reflects light too, and dropping it darkened every emissive surface's
/// surroundings (a closed furnace whose walls all emit got no reflected light at all).
#[allow(
    clippy::too_many_arguments,
    reason = "rust-gpu cannot keep storage-buffer slices in a struct: one argument per buffer"
)]
pub fn shade_cache_hit<I: TextureImages + ?Sized>(
    view: &CacheViewParams,
    ray: &Ray,
    primary: &PrimarySurface,
    hit: &HitRecord,
    ray_index: u32,
    instances: &[GpuInstance],
    meshes: &[GpuMesh],
    vertices: impl Elements<Item = GpuVertex>,
    triangles: impl Elements<Item = GpuTriangle>,
    materials: &[GpuMaterial],
    textures: &[GpuTexture],
    images: &I,
    lights: &[GpuLight],
    light_table: &[u32],
    environment: &[[f32; 4]],
    environment_cdf: &[f32],
) -> CacheHit {
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
        let light_pdf = environment_light_pdf(&params, lights, environment_cdf, direction);
        out.radiance = sky_radiance(view.environment_size, view.sky, environment, direction)
            * bsdf_mis_weight(strategy, bsdf_pdf, light_pdf);
        return out;
    }
    let (surface, material) = hit_surface(
        instances,
        meshes,
        vertices,
        triangles,
        materials,
        textures,
        images,
        ray,
        secondary_hit_footprint(),
        hit,
    );
    let emission = material.emissive * view.emissive_multiplier;
    // With emitter sampling the primary hit has taken a probe ray's emitter already.
    if emission.max_element() > 0.0
        && !view.has(FLAG_PROBE_RAYS | FLAG_EMITTERS_SAMPLED)
        && emits_toward(
            materials,
            surface.material,
            surface.geometric_normal,
            -direction,
        )
    {
        let light_pdf = emitter_light_pdf(
            &params,
            lights,
            light_table,
            hit,
            surface.area,
            surface.geometric_normal.dot(direction),
            Vec3::from_array(ray.direction).length(),
        );
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
        hit_position: offset_ray_origin(surface.position, ng, surface.size).to_array(),
        ray_index,
        direction: direction.to_array(),
        hit_distance: distance,
        normal: ns.to_array(),
        geometric_normal: pack_snorm10x3(ng),
        albedo: material.base_color.truncate().to_array(),
        tile: NO_TILE,
        cell: 0,
        flags: 0,
        _pad: [0; 2],
    };
    if distance.is_finite() && query.position().is_finite() {
        Some(query)
    } else {
        None
    }
}

/// The path tracer's parameters that its light sampling and MIS read, from the view's: the
/// primary hit is lit exactly as the path tracer lights its first hit.
#[inline]
pub fn path_params(view: &CacheViewParams) -> PathTracerParams {
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

/// The primary hit's next-event estimate of every light (the path tracer's
/// [`sample_direct_light`]): emissive triangles and the environment MIS-weighted against the
/// cosine ray, punctual lights in full. Its shadow ray is traced by TraceCacheRays.
#[allow(
    clippy::too_many_arguments,
    reason = "rust-gpu cannot keep storage-buffer slices in a struct: one argument per buffer"
)]
pub fn primary_direct_light<I: TextureImages + ?Sized>(
    view: &CacheViewParams,
    surface: &PrimarySurface,
    albedo: Vec3,
    instances: &[GpuInstance],
    meshes: &[GpuMesh],
    vertices: impl Elements<Item = GpuVertex>,
    triangles: impl Elements<Item = GpuTriangle>,
    materials: &[GpuMaterial],
    textures: &[GpuTexture],
    images: &I,
    lights: &[GpuLight],
    environment: &[[f32; 4]],
    environment_cdf: &[f32],
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
    sample_direct_light(
        &frame,
        &path_params(view),
        instances,
        meshes,
        vertices,
        triangles,
        materials,
        textures,
        images,
        lights,
        environment,
        environment_cdf,
        rng,
    )
}

/// What temporal radiance feedback found for a query.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct FeedbackLookup {
    /// The previous image's radiance at the reprojected hit.
    pub radiance: Vec3,
    /// Whether the hit reprojected and passed the depth and normal tests.
    pub accepted: bool,
}

/// Temporal radiance feedback (`crate::radiance_feedback`): the query's hit reprojected into the
/// previous frame's image; when that pixel passes the depth and normal tests, its radiance is the
/// hit's outgoing radiance (diffuse: the same toward every direction). `history` holds the
/// previous frame's [`FeedbackTexel`]s, row by row.
pub fn feedback_lookup(
    camera: &CameraParams,
    query: &CacheQuery,
    history: &[FeedbackTexel],
) -> FeedbackLookup {
    let mut out = FeedbackLookup {
        radiance: Vec3::ZERO,
        accepted: false,
    };
    let Some(at) = reproject(camera, query.position()) else {
        return out;
    };
    let i = (at.pixel.y * camera.image_size[0] + at.pixel.x) as usize;
    if i >= history.len() {
        return out;
    }
    let texel = history[i];
    let normal = unpack_snorm10x3(query.geometric_normal);
    if texel.valid == 0
        || texel.depth <= 0.0
        || !accepts(&at, normal, texel.depth, Vec3::from_array(texel.normal))
    {
        return out;
    }
    let radiance = Vec3::from_array(texel.radiance);
    if radiance.is_finite() && radiance.min_element() >= 0.0 {
        out.radiance = radiance;
        out.accepted = true;
    }
    out
}

/// InsertRadianceCache for one query, its first step ([`crate::hash_cells::full_buckets`]): its
/// descriptor (from the eye, the hit, the direction and the keyed hit distance,
/// [`keyed_hit_distance`]) finds or inserts its tile; a new tile joins the live list with zeroed
/// values (and counts in [`INSERTED_TILES`]); the first touch of the frame lists the tile for the
/// update; a full bucket leaves [`NO_TILE`] and [`QUERY_REFUSED`] for [`admit_query`]. New keys
/// are noted in `marks`. The query's [`QUERY_BYPASS`] flag is set here too (it needs the cell
/// size).
#[allow(
    clippy::too_many_arguments,
    reason = "rust-gpu cannot keep storage-buffer slices in a struct: one argument per buffer"
)]
#[inline]
pub fn insert_query<K, T, L, C, M>(
    keys: &mut K,
    last_touch: &mut T,
    values: &mut [HashCellValue],
    lists: &mut L,
    counters: &mut C,
    marks: &mut M,
    params: &CachePassParams,
    query: &mut CacheQuery,
) where
    K: AtomicWords + ?Sized,
    T: AtomicWords + ?Sized,
    L: AtomicWords + ?Sized,
    C: AtomicWords + ?Sized,
    M: AtomicWords + ?Sized,
{
    query.tile = NO_TILE;
    let desc = query_cell(params, query);
    if desc.is_none() {
        return;
    }
    if is_bypass(&params.view, query.hit_distance, desc.cell_size()) {
        query.flags |= QUERY_BYPASS;
        counters.fetch_add(BYPASS_COUNT, 1);
    }
    place_query(
        keys, last_touch, values, lists, counters, marks, params, query, &desc,
    );
}

/// The cell a query's hit falls into, as InsertRadianceCache keys it.
#[inline]
fn query_cell(params: &CachePassParams, query: &CacheQuery) -> CellDescriptor {
    hit_descriptor(
        params,
        query.position(),
        query.ray_direction(),
        query.hit_distance,
    )
}

/// Finds or inserts the tile of `desc` for `query` (see [`insert_query`]). A tile inserted into a
/// slot a full bucket took back this frame is on the frame's lists already: it is neither listed
/// nor counted again.
#[allow(
    clippy::too_many_arguments,
    reason = "rust-gpu cannot keep storage-buffer slices in a struct: one argument per buffer"
)]
#[inline]
fn place_query<K, T, L, C, M>(
    keys: &mut K,
    last_touch: &mut T,
    values: &mut [HashCellValue],
    lists: &mut L,
    counters: &mut C,
    marks: &mut M,
    params: &CachePassParams,
    query: &mut CacheQuery,
    desc: &CellDescriptor,
) where
    K: AtomicWords + ?Sized,
    T: AtomicWords + ?Sized,
    L: AtomicWords + ?Sized,
    C: AtomicWords + ?Sized,
    M: AtomicWords + ?Sized,
{
    let grid = &params.grid;
    let tile_count = grid.tile_count();
    let tile = match insert_tile(keys, desc, grid) {
        TileInsert::Found(tile) => tile,
        TileInsert::Inserted(tile) => {
            if !is_new_tile(marks, tile) {
                push_tile(lists, live_list(grid.frame_index), tile_count, tile);
                counters.fetch_add(INSERTED_TILES, 1);
            }
            note_new_key(marks, desc, Some(tile), grid);
            clear_tile_values(values, tile);
            tile
        }
        TileInsert::Full => {
            note_new_key(marks, desc, None, grid);
            query.flags |= QUERY_REFUSED;
            return;
        }
    };
    if touch_tile(last_touch, tile, grid.frame_index) {
        push_tile(lists, UPDATE_TILES, tile_count, tile);
    }
    query.tile = tile;
    query.cell = desc.cell[0] + TILE_CELL_RATIO * desc.cell[1];
}

/// InsertRadianceCache's second step for one query: a tile a full bucket takes back leaves the
/// query without a tile (a failed insert). The slot stays listed, and counted in
/// [`INSERTED_TILES`], until the next purge drops it.
#[inline]
pub fn settle_query<K, L, M>(
    keys: &mut K,
    lists: &mut L,
    marks: &M,
    params: &CachePassParams,
    query: &mut CacheQuery,
) where
    K: AtomicWords + ?Sized,
    L: AtomicWords + ?Sized,
    M: AtomicWords + ?Sized,
{
    if query.tile == NO_TILE {
        return;
    }
    if settle_tile(keys, marks, query.tile, &params.grid) {
        count(lists, FAILED_INSERTS);
        query.tile = NO_TILE;
    }
}

/// InsertRadianceCache's third step for one query: a refused query whose key is its bucket's
/// smallest new one inserts it again; every other refused query counts a failed insert.
#[allow(
    clippy::too_many_arguments,
    reason = "rust-gpu cannot keep storage-buffer slices in a struct: one argument per buffer"
)]
#[inline]
pub fn admit_query<K, T, L, C, M>(
    keys: &mut K,
    last_touch: &mut T,
    values: &mut [HashCellValue],
    lists: &mut L,
    counters: &mut C,
    marks: &mut M,
    params: &CachePassParams,
    query: &mut CacheQuery,
) where
    K: AtomicWords + ?Sized,
    T: AtomicWords + ?Sized,
    L: AtomicWords + ?Sized,
    C: AtomicWords + ?Sized,
    M: AtomicWords + ?Sized,
{
    if query.flags & QUERY_REFUSED == 0 {
        return;
    }
    let desc = query_cell(params, query);
    if is_admitted(marks, &desc, &params.grid) {
        place_query(
            keys, last_touch, values, lists, counters, marks, params, query, &desc,
        );
    }
    // Refused again only where the bucket was full of older keys.
    query.flags &= !QUERY_REFUSED;
    if query.tile == NO_TILE {
        count(lists, FAILED_INSERTS);
    }
}

/// Adds a radiance sample to the query's cell (nothing without a tile); false when the sample was
/// not finite and was dropped (the caller counts it).
#[inline]
pub fn accumulate_into_cell<A: AtomicWords + ?Sized>(
    accumulators: &mut A,
    query: &CacheQuery,
    radiance: Vec3,
) -> bool {
    if query.tile == NO_TILE {
        return true;
    }
    accumulate_cell_sample(accumulators, query.tile, query.cell_xy(), radiance)
}

/// The cache's filtered radiance for a query that [`needs_cache_radiance`] (adaptive mip read);
/// black when its tile holds no sample.
#[inline]
pub fn cache_radiance(values: &[HashCellValue], query: &CacheQuery, min_samples: f32) -> Vec3 {
    if !needs_cache_radiance(query) {
        return Vec3::ZERO;
    }
    match filtered_radiance(values, query.tile, query.cell_xy(), min_samples) {
        Some(v) => finite_sample(v),
        None => Vec3::ZERO,
    }
}

/// The query's hit as light sampling shades it: diffuse, at its offset position.
#[inline]
pub fn diffuse_hit(query: &CacheQuery) -> DiffuseHit {
    DiffuseHit {
        position: query.position(),
        normal: Vec3::from_array(query.normal),
        albedo: Vec3::from_array(query.albedo),
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

/// Light sampling at a query's hit through the light grid (RIS over its candidates, one shadow
/// ray: [`shadow_ray`]).
#[allow(
    clippy::too_many_arguments,
    reason = "rust-gpu cannot keep storage-buffer slices in a struct: one argument per buffer"
)]
#[inline]
pub fn sample_query_light(
    grid: &LightGridParams,
    entries: &[LightGridEntry],
    lights: &[GpuLight],
    environment: &[[f32; 4]],
    environment_cdf: &[f32],
    query: &CacheQuery,
    rng: &mut Random,
) -> LightGridSample {
    sample_light_grid(
        grid,
        entries,
        lights,
        environment,
        environment_cdf,
        &diffuse_hit(query),
        rng,
    )
}

/// Buckets of the reservoir grid of a frame of `pixels` pixels: one slot per pixel
/// (`pixels / 16` buckets of [`RESERVOIR_GRID_SLOTS_PER_BUCKET`]), a power of two between 64 and
/// the reference's [`RESERVOIR_GRID_BUCKETS`].
#[inline]
pub fn reservoir_grid_buckets(pixels: u32) -> u32 {
    let wanted = pixels.div_ceil(RESERVOIR_GRID_SLOTS_PER_BUCKET);
    let mut b = 64;
    while b < wanted && b < RESERVOIR_GRID_BUCKETS {
        b *= 2;
    }
    b
}

/// The reservoir-grid cell of a query's hit seen from `eye`: its position jittered in the
/// tangent plane by up to √2 cells ([`jitter_in_tangent_plane`]), so neighbouring cells share
/// reservoirs.
#[inline]
pub fn reservoir_grid_cell(
    view: &CacheViewParams,
    eye: Vec3,
    query: &CacheQuery,
    rng: &mut Random,
) -> ReservoirCell {
    let p = query.position();
    let n = Vec3::from_array(query.normal);
    let cell = reservoir_cell(p, eye, view.reservoir_cell_const, view.reservoir_buckets);
    let jittered = jitter_in_tangent_plane(p, n, cell.size, rng.next_vec2());
    reservoir_cell(
        jittered,
        eye,
        view.reservoir_cell_const,
        view.reservoir_buckets,
    )
}

/// GenerateReservoirs with ReSTIR: inserts the query's hit into this frame's reservoir grid
/// (`keys`, one checksum per slot) and claims its place in the slot's list (`counts`, one word per
/// slot): `[slot, index]`, slot [`RESERVOIR_GRID_NONE`] when the bucket is full.
#[inline]
pub fn insert_reservoir<K: AtomicWords + ?Sized, C: AtomicWords + ?Sized>(
    keys: &mut K,
    counts: &mut C,
    view: &CacheViewParams,
    eye: Vec3,
    query: &CacheQuery,
    rng: &mut Random,
) -> [u32; 2] {
    let cell = reservoir_grid_cell(view, eye, query, rng);
    let slot = insert_reservoir_cell(keys, 0, &cell);
    if slot == RESERVOIR_GRID_NONE || slot as usize >= counts.word_count() {
        return [RESERVOIR_GRID_NONE, 0];
    }
    [slot, counts.fetch_add(slot as usize, 1)]
}

/// CompactReservoirs: the entry of the compacted list a shadow ray's reservoir goes to, from its
/// `[slot, index]` and the scanned slot counts `offsets`; `None` without a slot.
#[inline]
pub fn reservoir_entry(offsets: &[u32], place: [u32; 2]) -> Option<u32> {
    let [slot, index] = place;
    if slot == RESERVOIR_GRID_NONE || slot as usize >= offsets.len() {
        return None;
    }
    Some(offsets[slot as usize] + index)
}

/// OrderReservoirs: the entry of the ordered list that shadow ray `ray`'s reservoir goes to, in
/// its slot's run sorted by the queries' `ray_index` (unique within a frame: a ray's query, or the
/// one query carried over from it, with [`CARRIED_QUERY_BIT`]), so that the run's order, which the
/// next frame's ResampleReservoirs strides through, does not depend on the order in which
/// GenerateReservoirs's atomics ran. `unordered` is CompactReservoirs's scatter. Reads every member
/// of the run: one reservoir cell's hits (tens to hundreds; cells span a fixed angle in pixels, so
/// the run does not grow with the resolution).
#[inline]
pub fn ordered_reservoir_entry(
    offsets: &[u32],
    unordered: &[u32],
    queries: &[CacheQuery],
    shadow_rays: &[ShadowRay],
    place: [u32; 2],
    ray: u32,
) -> Option<u32> {
    let slot = place[0] as usize;
    if place[0] == RESERVOIR_GRID_NONE || slot + 1 >= offsets.len() {
        return None;
    }
    let (first, end) = (
        offsets[slot],
        min_u32(offsets[slot + 1], unordered.len() as u32),
    );
    let own = reservoir_order_key(queries, shadow_rays, ray);
    let mut rank = 0;
    let mut e = first;
    while e < end {
        let other = reservoir_order_key(queries, shadow_rays, unordered[e as usize]);
        if other[0] < own[0] || (other[0] == own[0] && other[1] < own[1]) {
            rank += 1;
        }
        e += 1;
    }
    Some(first + rank)
}

/// What [`ordered_reservoir_entry`] sorts shadow ray `ray` by: its query's `ray_index`, then the
/// shadow ray's own index (never reached: `ray_index` is unique); past the lists, last.
#[inline]
fn reservoir_order_key(queries: &[CacheQuery], shadow_rays: &[ShadowRay], ray: u32) -> [u32; 2] {
    if (ray as usize) < shadow_rays.len() {
        let q = shadow_rays[ray as usize].query as usize;
        if q < queries.len() {
            return [queries[q].ray_index, ray];
        }
    }
    [u32::MAX, u32::MAX]
}

/// ResampleReservoirs for one query: its reservoir this frame (`current`, the light grid's) merged
/// with at most four reservoirs of the previous frame's cell (looked up from the previous eye,
/// normals checked, `M` capped at 20: [`TemporalResampling`]). The previous grid: slot checksums
/// `keys`, exclusive prefix sums of its slot counts `offsets` (`slots + 1` words, the last the
/// total), the compacted list `entries` of previous shadow-ray indices, slot after slot, and per
/// previous shadow ray its reservoir and hit. Returns the combined sample.
#[allow(
    clippy::too_many_arguments,
    reason = "rust-gpu cannot keep storage-buffer slices in a struct: one argument per buffer"
)]
pub fn resample_reservoir(
    grid: &LightGridParams,
    lights: &[GpuLight],
    environment: &[[f32; 4]],
    environment_cdf: &[f32],
    view: &CacheViewParams,
    query: &CacheQuery,
    current: &PackedReservoir,
    keys: &[u32],
    offsets: &[u32],
    entries: &[u32],
    reservoirs: &[PackedReservoir],
    hits: &[ReservoirHit],
    rng: &mut Random,
) -> LightGridSample {
    let hit = diffuse_hit(query);
    let mut sample = LightGridSample::NONE;
    sample.reservoir = current.reservoir();
    sample.params = current.params;
    sample.contribution = light_contribution(
        grid,
        lights,
        environment,
        environment_cdf,
        &hit,
        current.light,
        sample_params_uv(current.params),
    );
    let mut resampling = TemporalResampling::begin(&sample, rng.next_f32());
    if view.has(FLAG_RESTIR_HISTORY) {
        let cell = reservoir_grid_cell(view, Vec3::from_array(view.previous_eye), query, rng);
        let slot = find_reservoir_cell(keys, 0, &cell);
        if slot != RESERVOIR_GRID_NONE && (slot as usize) + 1 < offsets.len() {
            let first = offsets[slot as usize];
            let count = offsets[slot as usize + 1].wrapping_sub(first);
            let u = rng.next_f32();
            let n = temporal_neighbour_count(count);
            let mut k = 0;
            while k < n {
                let e = (first + temporal_neighbour(count, k, u)) as usize;
                if e < entries.len() {
                    let r = entries[e] as usize;
                    if r < reservoirs.len() && r < hits.len() {
                        let neighbour = reservoirs[r];
                        let normal = hits[r].normal();
                        resampling.merge_neighbour(
                            grid,
                            lights,
                            environment,
                            environment_cdf,
                            &hit,
                            &neighbour,
                            normal,
                            rng.next_f32(),
                        );
                    }
                }
                k += 1;
            }
        }
    }
    resampling.finish()
}

/// Light-leak fix 2: whether a hit `hit_distance` from its ray's origin bypasses its cell's
/// filtered radiance, being closer than `cell_size` (the hit's cell size).
#[inline]
pub fn is_bypass(view: &CacheViewParams, hit_distance: f32, cell_size: f32) -> bool {
    view.has(FLAG_BYPASS) && hit_distance < cell_size
}

/// The hit distance the descriptor keys a hit by: its own, or (short-ray flag off) the largest
/// finite distance, so that no hit counts as short.
#[inline]
pub fn keyed_hit_distance(view: &CacheViewParams, hit_distance: f32) -> f32 {
    if view.has(FLAG_SHORT_RAY) {
        hit_distance
    } else {
        f32::MAX
    }
}

/// The cell of a hit at `position` reached along unit `direction` after `hit_distance`, as this
/// frame keys it (its eye, its short-ray flag): a query's and a bounce ray's alike.
#[inline]
pub fn hit_descriptor(
    params: &CachePassParams,
    position: Vec3,
    direction: Vec3,
    hit_distance: f32,
) -> CellDescriptor {
    cell_descriptor(
        params.grid.eye(),
        position,
        direction,
        keyed_hit_distance(&params.view, hit_distance),
        &params.grid,
    )
}

/// The footprint a secondary hit's textures are filtered for: a probe traces one ray per
/// octahedral cell, each standing for that share of the hemisphere.
#[inline]
pub fn secondary_hit_footprint() -> RayFootprint {
    RayFootprint::cone(RayCone::hemisphere_share(0.0, PROBE_CELLS))
}

/// Whether ResolveRadianceCache adds the cell's filtered radiance to the query's ray: it has a
/// tile and was neither fed back nor bypassed.
#[inline]
pub fn needs_cache_radiance(query: &CacheQuery) -> bool {
    query.tile != NO_TILE && query.flags & (QUERY_FED_BACK | QUERY_BYPASS) == 0
}

/// A sample as it may enter a sum: finite and non-negative, else black.
#[inline]
pub fn finite_sample(v: Vec3) -> Vec3 {
    if v.is_finite() && v.min_element() >= 0.0 {
        v
    } else {
        Vec3::ZERO
    }
}

/// This frame's estimate of a pixel: the primary hit's emission and light sample, plus albedo ×
/// the cosine ray's radiance (a cosine-distributed ray estimates irradiance / π, which the diffuse
/// BRDF turns into albedo × radiance). Non-finite terms count as black.
#[inline]
pub fn composite(pixel: &CacheViewPixel, albedo: Vec3) -> Vec3 {
    if pixel.surface == 0 {
        return finite_sample(Vec3::from_array(pixel.ray_radiance));
    }
    finite_sample(Vec3::from_array(pixel.base))
        + albedo * finite_sample(Vec3::from_array(pixel.ray_radiance))
}

/// The [`FeedbackTexel`] a pixel leaves for the next frame: the running mean `sum` of its
/// image, its G-buffer depth and geometric normal; no source where it saw no surface or an
/// emitter.
#[inline]
pub fn feedback_texel(
    pixel: &CacheViewPixel,
    sum: [f32; 4],
    depth: f32,
    normal: Vec3,
) -> FeedbackTexel {
    FeedbackTexel {
        radiance: running_mean(sum).to_array(),
        depth,
        normal: normal.to_array(),
        valid: if pixel.surface != 0 && pixel.emissive == 0 && depth > 0.0 {
            1
        } else {
            0
        },
    }
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
    use core::mem::{offset_of, size_of};

    #[test]
    fn layouts() {
        assert_eq!(size_of::<CacheViewParams>(), 80);
        assert_eq!(offset_of!(CacheViewParams, flags), 28);
        assert_eq!(offset_of!(CacheViewParams, environment_size), 32);
        assert_eq!(offset_of!(CacheViewParams, environment_irradiance), 40);
        assert_eq!(offset_of!(CacheViewParams, image_size), 48);
        assert_eq!(offset_of!(CacheViewParams, reservoir_cell_const), 60);
        assert_eq!(offset_of!(CacheViewParams, previous_eye), 64);
        assert_eq!(offset_of!(CacheViewParams, reservoir_buckets), 76);
        assert_eq!(size_of::<CachePassParams>(), 128);
        assert!(size_of::<CachePassParams>() <= crate::layout::MAX_PUSH_CONSTANT_BYTES);
        assert_eq!(offset_of!(CachePassParams, view), 48);
        assert_eq!(size_of::<CacheQuery>(), 80);
        assert_eq!(offset_of!(CacheQuery, ray_index), 12);
        assert_eq!(offset_of!(CacheQuery, hit_distance), 28);
        assert_eq!(offset_of!(CacheQuery, geometric_normal), 44);
        assert_eq!(offset_of!(CacheQuery, albedo), 48);
        assert_eq!(offset_of!(CacheQuery, tile), 60);
        assert_eq!(offset_of!(CacheQuery, cell), 64);
        assert_eq!(offset_of!(CacheQuery, flags), 68);
        assert_eq!(size_of::<ShadowRay>(), 48);
        assert_eq!(offset_of!(ShadowRay, query), 12);
        assert_eq!(offset_of!(ShadowRay, t_max), 28);
        assert_eq!(offset_of!(ShadowRay, flags), 44);
        assert_eq!(size_of::<CacheViewPixel>(), 32);
        assert_eq!(size_of::<FeedbackTexel>(), 32);
    }

    #[test]
    fn counters_reset_except_the_previous_live_list() {
        use crate::hash_cells::lists::{COUNTER_WORDS, previous_live_list};
        for frame in [0u32, 1, 2, 77, u32::MAX] {
            let mut lists = [7u32; COUNTER_WORDS as usize];
            let mut counters = [7u32; CACHE_COUNTER_WORDS];
            begin_cache_frame(&mut lists[..], &mut counters[..], frame, 5);
            let kept = previous_live_list(frame) as usize;
            for (i, &v) in lists.iter().enumerate() {
                assert_eq!(v, if i == kept { 7 } else { 0 }, "frame {frame} word {i}");
            }
            // The 7 carried queries, cut to the capacity of 5, open the query list.
            let mut expected = [0; CACHE_COUNTER_WORDS];
            expected[CARRIED_QUERIES] = 5;
            expected[QUERY_COUNT] = 5;
            assert_eq!(counters, expected);
            // Without carried queries every counter starts at zero.
            begin_cache_frame(&mut lists[..], &mut counters[..], frame, 5);
            assert_eq!(counters, [0; CACHE_COUNTER_WORDS]);
        }
    }

    #[test]
    fn carried_queries_are_copied_once_counted() {
        let mut counters = [0u32; CACHE_COUNTER_WORDS];
        counters[CARRIED_NEXT] = 2;
        let mut lists = [0u32; crate::hash_cells::lists::COUNTER_WORDS as usize];
        begin_cache_frame(&mut lists[..], &mut counters[..], 3, 8);
        let carried: Vec<CacheQuery> = (0..4)
            .map(|i| CacheQuery {
                ray_index: CARRIED_QUERY_BIT | i,
                flags: QUERY_CARRIED,
                ..Default::default()
            })
            .collect();
        let mut queries = vec![CacheQuery::default(); 4];
        for i in 0..6 {
            carry_query(&counters[..], &carried, &mut queries, i);
        }
        assert_eq!(&queries[..2], &carried[..2]);
        assert_eq!(queries[2], CacheQuery::default());
        assert_eq!(counters[QUERY_COUNT], 2);
    }

    fn camera() -> CameraParams {
        CameraParams::new(Vec3::new(0.0, 0.0, 5.0), Vec3::NEG_Z, Vec3::Y, 0.8, 32, 24)
    }

    /// A wall at z = 0 facing the camera, seen by every pixel.
    fn wall(camera: &CameraParams, pixel: UVec2) -> PrimarySurface {
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
        let view = CacheViewParams {
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
                &[],
                &[],
                &[],
                &[],
                &[],
                &[],
                &[][..],
                &lights,
                &[],
                &[],
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
        let view = CacheViewParams {
            light_count: 1,
            light_candidates: 1,
            environment_size: [1, 1],
            flags: FLAG_ENVIRONMENT_LIGHT,
            ..Default::default()
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
                &[],
                &[],
                &[],
                &[],
                &[],
                &[],
                &[][..],
                &lights,
                &environment,
                &cdf,
                &mut rng,
            );
            nee += f64::from(d.radiance.x);
            let ray = cache_ray(&s, rng.next_vec2());
            let hit = shade_cache_hit(
                &view,
                &ray,
                &s,
                &HitRecord::miss(),
                0,
                &[],
                &[],
                &[],
                &[],
                &[],
                &[],
                &[][..],
                &lights,
                &[],
                &environment,
                &cdf,
            );
            bsdf += f64::from(albedo.x * hit.radiance.x);
        }
        let (nee, bsdf) = (nee / f64::from(n), bsdf / f64::from(n));
        // Both strategies carry a real share, and together they make albedo × sky.
        assert!(nee > 0.1 && bsdf > 0.1, "{nee} {bsdf}");
        assert!((nee + bsdf - 1.0).abs() < 0.01, "{nee} + {bsdf}");
    }

    fn query_at(p: Vec3, n: Vec3) -> CacheQuery {
        CacheQuery {
            hit_position: p.to_array(),
            geometric_normal: pack_snorm10x3(n),
            normal: n.to_array(),
            direction: (-n).to_array(),
            hit_distance: 1.0,
            tile: NO_TILE,
            ..Default::default()
        }
    }

    #[test]
    fn feedback_accepts_the_same_surface_and_rejects_others() {
        let c = camera();
        let [w, h] = c.image_size;
        let history: Vec<FeedbackTexel> = (0..w * h)
            .map(|i| FeedbackTexel {
                radiance: [i as f32, 1.0, 2.0],
                depth: 5.0,
                normal: [0.0, 0.0, 1.0],
                valid: 1,
            })
            .collect();
        let p = Vec3::new(0.1, -0.2, 0.0);
        let hit = feedback_lookup(&c, &query_at(p, Vec3::Z), &history);
        assert!(hit.accepted);
        let uv = crate::camera::project(&c.view_proj, p);
        let expected = (uv.y * h as f32) as u32 * w + (uv.x * w as f32) as u32;
        assert_eq!(hit.radiance, Vec3::new(expected as f32, 1.0, 2.0));
        // A point 6 % nearer the camera, the back of the wall, a point off screen: rejected.
        assert!(!feedback_lookup(&c, &query_at(p + Vec3::Z * 0.3, Vec3::Z), &history).accepted);
        assert!(!feedback_lookup(&c, &query_at(p, Vec3::NEG_Z), &history).accepted);
        assert!(
            !feedback_lookup(&c, &query_at(Vec3::new(50.0, 0.0, 0.0), Vec3::Z), &history).accepted
        );
        // 4 % nearer passes.
        assert!(feedback_lookup(&c, &query_at(p + Vec3::Z * 0.2, Vec3::Z), &history).accepted);
        // No history.
        assert!(!feedback_lookup(&c, &query_at(p, Vec3::Z), &[]).accepted);
    }

    /// A hash grid on the CPU and InsertRadianceCache's three steps over a frame's queries, each
    /// step over every query before the next (as the three dispatches run).
    struct CpuCache {
        keys: Vec<u32>,
        touch: Vec<u32>,
        values: Vec<HashCellValue>,
        lists: Vec<u32>,
        counters: [u32; CACHE_COUNTER_WORDS],
        marks: Vec<u32>,
    }

    impl CpuCache {
        fn new(grid: &HashGridParams, touch: u32, value: HashCellValue) -> Self {
            use crate::hash_cells::full_buckets::marks_words;
            use crate::hash_cells::lists::list_buffer_words;
            let tiles = grid.tile_count() as usize;
            Self {
                keys: vec![0; tiles],
                touch: vec![touch; tiles],
                values: vec![value; tiles * crate::hash_cells::CELLS_PER_TILE as usize],
                lists: vec![0; list_buffer_words(tiles as u32)],
                counters: [0; CACHE_COUNTER_WORDS],
                marks: vec![0; marks_words(grid.num_buckets_log2, grid.tiles_per_bucket_log2)],
            }
        }

        /// A new frame's counters and lists (the hash grid kept).
        fn next_frame(&mut self) {
            self.counters = [0; CACHE_COUNTER_WORDS];
            self.lists.fill(0);
        }

        fn insert(&mut self, params: &CachePassParams, queries: &mut [CacheQuery]) {
            use crate::hash_cells::full_buckets::MARKS_CLEAR;
            self.marks.fill(MARKS_CLEAR);
            for q in queries.iter_mut() {
                insert_query(
                    &mut self.keys[..],
                    &mut self.touch[..],
                    &mut self.values,
                    &mut self.lists[..],
                    &mut self.counters[..],
                    &mut self.marks[..],
                    params,
                    q,
                );
            }
            for q in queries.iter_mut() {
                settle_query(
                    &mut self.keys[..],
                    &mut self.lists[..],
                    &self.marks[..],
                    params,
                    q,
                );
            }
            for q in queries.iter_mut() {
                admit_query(
                    &mut self.keys[..],
                    &mut self.touch[..],
                    &mut self.values,
                    &mut self.lists[..],
                    &mut self.counters[..],
                    &mut self.marks[..],
                    params,
                    q,
                );
            }
        }
    }

    /// Inserts on the CPU: a query finds its tile the second time, short hits bypass, a one-tile
    /// cache refuses a second key and counts it.
    #[test]
    fn insert_query_finds_touches_and_counts() {
        use crate::hash_cells::lists::list_len;
        let mut params = CachePassParams {
            grid: HashGridParams::new(Vec3::ZERO, 0.01, 5),
            view: CacheViewParams {
                flags: FLAG_SHORT_RAY | FLAG_BYPASS,
                ..Default::default()
            },
        };
        params.grid.num_buckets_log2 = 0;
        params.grid.tiles_per_bucket_log2 = 0;
        assert_eq!(params.grid.tile_count(), 1);
        let mut cache = CpuCache::new(&params.grid, 4, HashCellValue::new(Vec3::ONE, 1.0));
        let mut q = query_at(Vec3::new(1.0, 2.0, 3.0), Vec3::Z);
        q.hit_distance = 1e-3;
        let mut a = [q];
        cache.insert(&params, &mut a);
        assert_eq!(a[0].tile, 0);
        assert!(a[0].has(QUERY_BYPASS));
        let mut b = [q];
        cache.insert(&params, &mut b);
        assert_eq!((b[0].tile, b[0].cell), (a[0].tile, a[0].cell));
        // Another place, in a later insert pass: the single slot is taken by an older key.
        let mut c = [query_at(Vec3::new(-40.0, 2.0, 3.0), Vec3::Z)];
        cache.insert(&params, &mut c);
        assert_eq!(c[0].tile, NO_TILE);
        assert!(!c[0].has(QUERY_BYPASS) && !c[0].has(QUERY_REFUSED));
        assert_eq!(cache.counters[INSERTED_TILES], 1);
        assert_eq!(cache.counters[BYPASS_COUNT], 2);
        assert_eq!(cache.lists[FAILED_INSERTS as usize], 1);
        assert_eq!(list_len(&cache.lists[..], UPDATE_TILES, 1), 1);
        assert_eq!(list_len(&cache.lists[..], live_list(5), 1), 1);
        assert_eq!(cache.touch[0], 5);
        assert!(cache.values.iter().all(|v| *v == HashCellValue::ZERO));
        // Without the bypass flag nothing bypasses.
        params.view.flags = FLAG_SHORT_RAY;
        let mut d = [q];
        cache.insert(&params, &mut d);
        assert!(!d[0].has(QUERY_BYPASS));
    }

    /// A bucket of two slots, one held by an older key, asked for three new keys (two queries
    /// each) in every order: it ends holding the old key and the smallest new one, every query of
    /// the others without a tile, and the counts the same. With room for every new key, all get
    /// in.
    #[test]
    fn a_full_bucket_settles_the_same_whatever_the_insert_order() {
        use crate::hash_cells::lists::list_len;
        use itertools::Itertools;
        let mut params = CachePassParams {
            grid: HashGridParams::new(Vec3::ZERO, 0.01, 9),
            view: CacheViewParams::default(),
        };
        params.grid.num_buckets_log2 = 0;
        params.grid.tiles_per_bucket_log2 = 1;
        let queries: Vec<CacheQuery> = [-40.0f32, 10.0, 25.0, 60.0]
            .iter()
            .map(|&x| query_at(Vec3::new(x, 2.0, 3.0), Vec3::Z))
            .collect();
        let sums: Vec<u32> = queries
            .iter()
            .map(|q| query_cell(&params, q).checksum)
            .collect();
        let smallest_new = *sums[1..].iter().min().unwrap();
        // The six new queries, two per new key, in every order.
        let new_queries = [1, 2, 3, 1, 2, 3];
        let mut outcomes = Vec::new();
        for order in (0..new_queries.len()).permutations(new_queries.len()) {
            let mut cache = CpuCache::new(&params.grid, 0, HashCellValue::ZERO);
            // Frame 8: the old key.
            params.grid.frame_index = 8;
            cache.insert(&params, &mut [queries[0]]);
            // Frame 9: the new keys, in this order.
            params.grid.frame_index = 9;
            cache.next_frame();
            let mut frame: Vec<CacheQuery> =
                order.iter().map(|&i| queries[new_queries[i]]).collect();
            cache.insert(&params, &mut frame);
            let mut held = cache.keys.clone();
            held.sort_unstable();
            let mut expected = vec![sums[0], smallest_new];
            expected.sort_unstable();
            assert_eq!(held, expected, "order {order:?}");
            for (q, &i) in frame.iter().zip(order.iter()) {
                let key = sums[new_queries[i]];
                assert_eq!(q.tile != NO_TILE, key == smallest_new, "order {order:?}");
                assert!(!q.has(QUERY_REFUSED));
            }
            outcomes.push((
                cache.counters[INSERTED_TILES],
                cache.lists[FAILED_INSERTS as usize],
                list_len(&cache.lists[..], UPDATE_TILES, cache.keys.len() as u32),
            ));
        }
        assert!(outcomes.windows(2).all(|w| w[0] == w[1]), "{outcomes:?}");
        assert_eq!(outcomes[0].0, 1);
        assert_eq!(outcomes[0].1, 4);

        // Room for the three new keys: nothing is taken back.
        params.grid.tiles_per_bucket_log2 = 2;
        let mut cache = CpuCache::new(&params.grid, 0, HashCellValue::ZERO);
        let mut frame: Vec<CacheQuery> = queries[1..].to_vec();
        cache.insert(&params, &mut frame);
        assert!(frame.iter().all(|q| q.tile != NO_TILE));
        assert_eq!(cache.counters[INSERTED_TILES], 3);
    }

    #[test]
    fn reservoir_runs_are_ordered_the_same_whatever_the_scatter_order() {
        use itertools::Itertools;
        // Five shadow rays in two slots (three in slot 0, two in slot 1), one with no slot; the
        // queries' ray indices are unrelated to the shadow rays' and the queries' order.
        let ray_indices = [40u32, 7, CARRIED_QUERY_BIT | 7, 12, 3, 99];
        let queries: Vec<CacheQuery> = ray_indices
            .iter()
            .map(|&r| CacheQuery {
                ray_index: r,
                ..CacheQuery::default()
            })
            .collect();
        let query_of = [2u32, 0, 4, 1, 3, 5];
        let shadow_rays: Vec<ShadowRay> = query_of
            .iter()
            .map(|&q| ShadowRay {
                query: q,
                ..ShadowRay::default()
            })
            .collect();
        let slot_of = [0u32, 1, 0, 0, 1, RESERVOIR_GRID_NONE];
        let offsets = [0u32, 3, 5];
        let mut lists = Vec::new();
        for order in (0..shadow_rays.len()).permutations(shadow_rays.len()) {
            // GenerateReservoirs's atomics hand out places in this order.
            let mut counts = [0u32; 2];
            let mut places = [[0u32; 2]; 6];
            for &r in &order {
                let slot = slot_of[r];
                places[r] = [slot, 0];
                if slot != RESERVOIR_GRID_NONE {
                    places[r][1] = counts[slot as usize];
                    counts[slot as usize] += 1;
                }
            }
            let mut unordered = [u32::MAX; 5];
            for (r, &place) in places.iter().enumerate() {
                if let Some(e) = reservoir_entry(&offsets, place) {
                    unordered[e as usize] = r as u32;
                }
            }
            let mut ordered = [u32::MAX; 5];
            for (r, &place) in places.iter().enumerate() {
                let e = ordered_reservoir_entry(
                    &offsets,
                    &unordered,
                    &queries,
                    &shadow_rays,
                    place,
                    r as u32,
                );
                assert_eq!(e.is_none(), slot_of[r] == RESERVOIR_GRID_NONE);
                if let Some(e) = e {
                    assert_eq!(ordered[e as usize], u32::MAX, "{order:?}: entry {e} twice");
                    ordered[e as usize] = r as u32;
                }
            }
            lists.push(ordered);
        }
        assert!(lists.windows(2).all(|w| w[0] == w[1]));
        // Slot 0 holds rays 0, 2, 3 (ray indices 7 | CARRIED, 3, 7), slot 1 rays 1, 4 (40, 12).
        assert_eq!(lists[0], [2, 3, 0, 4, 1]);
    }

    #[test]
    fn composite_and_accumulation_stay_finite() {
        let px = CacheViewPixel {
            ray_radiance: [1.0, 2.0, f32::NAN],
            surface: 1,
            base: [0.5, 0.0, 0.0],
            emissive: 0,
        };
        // A non-finite channel blackens its whole term.
        let c = composite(&px, Vec3::splat(0.5));
        assert_eq!(c, Vec3::new(0.5, 0.0, 0.0));
        let ok = CacheViewPixel {
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
