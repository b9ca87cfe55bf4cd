//! The world-space radiance cache's records and flags: what every cache pass reads and writes
//! ([`CacheQuery`], [`ShadowRay`], the ray records [`RayRecord`], the push constants
//! [`CachePassParams`] and the counter words), the random streams of its passes
//! ([`pass_random`]), and the per-query steps of InsertRadianceCache and ResolveRadianceCache,
//! so that the CPU runs (and tests) them too. The host strings the passes together in
//! `host/src/gi/world_cache.rs`.
//!
//! # Frame
//!
//! In the talk's order, with its pass names (`host/src/gi/` records them):
//!
//! 1. **PurgeRadianceCache**: [`begin_cache_frame`]; evict old tiles of the previous live list.
//! 2. **GBuffer**.
//! 3. **TraceCacheRays** (the stand-in for PopulateScreenProbes): [`primary_surface`](crate::primary_surface::primary_surface) from the
//!    G-buffer, [`cache_ray`](crate::cache_view::cache_ray), then [`shade_cache_hit`](crate::secondary_hits::shade_cache_hit): a miss takes the environment, a
//!    front-facing emissive hit its emission (never put in a cell), both MIS-weighted, and every
//!    hit appends a [`CacheQuery`] for the light it reflects. The same pass samples the primary
//!    hit's direct light ([`primary_direct_light`](crate::cache_view::primary_direct_light)) and traces its shadow ray.
//! 4. **InsertRadianceCache**: each query's tile is found or inserted, touched, and its cell written
//!    into the query.
//! 5. **UpdateLightGrid**.
//! 6. **GenerateReservoirs**: [`feedback_lookup`](crate::radiance_feedback::feedback_lookup) (temporal radiance feedback) or
//!    [`sample_query_light`](crate::secondary_hits::sample_query_light) (RIS through the light grid, one [`ShadowRay`]); with ReSTIR, the
//!    hit also joins this frame's reservoir grid ([`insert_reservoir`](crate::world_restir::insert_reservoir)).
//! 7. World-space ReSTIR (optional): **ClearReservoirs** (before GenerateReservoirs),
//!    **CompactReservoirs** ([`reservoir_entry`](crate::world_restir::reservoir_entry) after a prefix scan of the slot counts, then
//!    [`ordered_reservoir_entry`](crate::world_restir::ordered_reservoir_entry), so that each cell's list has one order whatever the GPU's) and
//!    **ResampleReservoirs** ([`resample_reservoir`](crate::world_restir::resample_reservoir): temporal reuse from the previous frame's
//!    grid, which replaces each shadow ray's light sample).
//! 8. **PopulateRadianceCache**: shadow rays; every sample is accumulated into the cell, an
//!    occluded one (or one that nothing could light) as zero ([`shadow_ray_radiance`](crate::secondary_hits::shadow_ray_radiance)), so the
//!    cell's mean is not taken over the lit samples alone.
//! 9. **UpdateRadianceCache**: temporal blend and mips.
//! 10. **ResolveRadianceCache**: [`needs_cache_radiance`] queries add the cell's filtered radiance.
//! 11. **CacheViewComposite**: [`composite`](crate::cache_view::composite) and [`accumulate_sample`](crate::cache_view::accumulate_sample).
//!
//! # Each light path counted once
//!
//! The primary hit is lit as the path tracer lights its first hit: [`primary_direct_light`](crate::cache_view::primary_direct_light)
//! (the path tracer's `sample_direct_light`: RIS over power-proportional candidates of the whole
//! light buffer, one shadow ray) samples every light; the cosine ray that misses or hits a
//! front-facing emitter adds the sky or emission × its power-heuristic weight against that light
//! sample's density ([`shade_cache_hit`](crate::secondary_hits::shade_cache_hit)), so emissive triangles and a sampled environment are
//! shared between the two strategies with weights summing to one. Punctual lights, which no ray
//! can hit, come from the light sample alone (weight 1). An emitter hit also queries the cache,
//! for the light the emitter reflects (cells hold reflected light only). At the secondary hit,
//! RIS samples every light of the light buffer through the light grid and the hit's own emission
//! is never added. `gi` turns a constant `--sky` into a
//! uniform environment image (`Environment::constant` on the host), so both hits sample it; a
//! constant [`CacheFrameParams::sky`] alone is not in the light buffer: the cosine ray alone finds
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
//! * A pixel that sees an emitter is no feedback source ([`feedback_texel`](crate::radiance_feedback::feedback_texel)): a hit that is not an
//!   emitter but reprojects onto one lies beside it and would take its emission (this brightened
//!   the Cornell box by 7%).
//! * The cache filters over its cells (and their mips while they hold under 16 samples).

use crate::atomics::AtomicWords;
use crate::hash::pcg_chain;
use crate::hash_cells::accumulate::accumulate_sample as accumulate_cell_sample;
use crate::hash_cells::full_buckets::{is_admitted, is_new_tile, note_new_key, settle_tile};
use crate::hash_cells::layout::{HashCellValue, HashCellsInsert, HashGridParams};
use crate::hash_cells::lists::{
    FAILED_INSERTS, UPDATE_TILES, begin_frame, count, live_list, push_tile,
};
use crate::hash_cells::read::filtered_radiance;
use crate::hash_cells::storage::{TileInsert, insert_tile};
use crate::hash_cells::touch::{clear_tile_values, touch_tile};
use crate::hash_cells::{CellDescriptor, TILE_CELL_RATIO, cell_descriptor};
use crate::packing::{unpack_albedo10x3, unpack_octahedral16};
use crate::random::Random;
use crate::ray::Ray;
use bytemuck::{Pod, Zeroable};
use glam::Vec3;

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

/// [`CacheQuery::flags`]: the lowest bit of the query's sample weight
/// ([`CacheQuery::sample_weight`]); the bits below are flags.
pub const QUERY_WEIGHT_SHIFT: u32 = 16;
const _: () =
    assert!(crate::hash_cells::layout::MAX_SAMPLE_WEIGHT < 1 << (32 - QUERY_WEIGHT_SHIFT));

/// Set in a carried query's `ray_index` (its parent's, so that its random streams stay keyed by
/// a ray, not by a list slot): no ray record is that large.
pub const CARRIED_QUERY_BIT: u32 = 1 << 31;

/// [`ShadowRay::flags`]: the query's ray takes the shadow ray's result itself (see
/// [`QUERY_BYPASS`]).
pub const SHADOW_BYPASS: u32 = 1;

/// [`CacheFrameParams::flags`]: temporal radiance feedback on.
pub const FLAG_FEEDBACK: u32 = 1;

/// [`CacheFrameParams::flags`]: the previous frame's image exists (feedback needs it).
pub const FLAG_HISTORY: u32 = 2;

/// [`CacheFrameParams::flags`]: the descriptor's short-ray flag on (light-leak fix 1). Off, every
/// query is keyed as a long ray.
pub const FLAG_SHORT_RAY: u32 = 4;

/// [`CacheFrameParams::flags`]: short queries bypass the cell's filtered radiance (light-leak
/// fix 2).
pub const FLAG_BYPASS: u32 = 8;

/// [`CacheFrameParams::flags`]: world-space ReSTIR temporal reuse on.
pub const FLAG_RESTIR: u32 = 16;

/// [`CacheFrameParams::flags`]: the previous frame's reservoir grid exists (ReSTIR was on then).
pub const FLAG_RESTIR_HISTORY: u32 = 32;

/// [`CacheFrameParams::flags`]: the light buffer's last light is the environment (the path
/// tracer's `environment_light`), which MIS weighs misses against.
pub const FLAG_ENVIRONMENT_LIGHT: u32 = 64;

/// [`CacheFrameParams::flags`]: the rays are screen-probe rays: their origin samples no emitter
/// and no environment (the GI frame's primary hit samples punctual lights alone), so a miss and
/// an emissive hit count in full rather than MIS-weighted.
pub const FLAG_PROBE_RAYS: u32 = 128;

/// [`CacheFrameParams::flags`]: multi-bounce through the world cache (`crate::multi_bounce`):
/// every query that takes a light sample also traces a bounce ray and adds the cell it hits.
pub const FLAG_MULTI_BOUNCE: u32 = 256;

/// [`CacheFrameParams::flags`], with [`FLAG_PROBE_RAYS`]: the GI frame's primary hit samples the
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

/// The frame's settings of the world-cache passes (the GI frame's and the cache view's), as the
/// kernels see them (80 bytes).
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
pub struct CacheFrameParams {
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
    /// [`crate::light_grid::LightGridParams::environment_irradiance`]).
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
    /// Buckets of the reservoir grid ([`reservoir_grid_buckets`](crate::world_restir::reservoir_grid_buckets)).
    pub reservoir_buckets: u32,
}

impl CacheFrameParams {
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
    pub view: CacheFrameParams,
}

/// One secondary hit that queries the cache (48 bytes), appended by TraceCacheRays. Directions
/// and normals travel packed (`crate::packing`: 16:16 octahedral, 10:10:10 snorm), the albedo as
/// gamma-2 10:10:10: a query is written once per ray and read by every cache pass, and the
/// query lists are the largest per-ray buffers (two per ray with multi-bounce).
///
/// | offset | field              |
/// |--------|--------------------|
/// | 0      | `hit_position`     |
/// | 12     | `ray_index`        |
/// | 16     | `direction`        |
/// | 20     | `hit_distance`     |
/// | 24     | `normal`           |
/// | 28     | `geometric_normal` |
/// | 32     | `albedo`           |
/// | 36     | `tile`             |
/// | 40     | `cell`             |
/// | 44     | `flags`            |
#[repr(C)]
#[derive(Clone, Copy, Debug, Default, PartialEq, Pod, Zeroable)]
pub struct CacheQuery {
    /// The hit point, already offset off the surface toward the ray's origin (shadow rays start
    /// here; the descriptor keys it).
    pub hit_position: [f32; 3],
    /// The pixel whose ray hit: `y · width + x`.
    pub ray_index: u32,
    /// Unit direction of the ray, as `pack_octahedral16` ([`Self::ray_direction`]).
    pub direction: u32,
    /// Distance from the ray's origin to the hit.
    pub hit_distance: f32,
    /// Unit shading normal facing the ray's origin, as `pack_octahedral16`
    /// ([`Self::shading_normal`]).
    pub normal: u32,
    /// Unit geometric normal facing the ray's origin, as `pack_snorm10x3`.
    pub geometric_normal: u32,
    /// Diffuse albedo (the secondary material is forced diffuse), as `pack_albedo10x3`
    /// ([`Self::albedo`]).
    pub albedo: u32,
    /// The tile (slot) of the hit's cell, written by InsertRadianceCache; [`NO_TILE`] before or
    /// when the bucket was full.
    pub tile: u32,
    /// The mip-0 cell inside the tile, `x + 8 · y`.
    pub cell: u32,
    /// [`QUERY_FED_BACK`], [`QUERY_BYPASS`], [`QUERY_CARRIED`], [`QUERY_REFUSED`], and from
    /// [`QUERY_WEIGHT_SHIFT`] up the sample's weight ([`Self::sample_weight`]).
    pub flags: u32,
}

impl crate::layout::FloatLayout for CacheQuery {
    const FLOAT_WORDS: &'static [u32] = &[0, 1, 2, 5];
}

impl CacheQuery {
    /// The weight its sample takes in its cell, in
    /// [`SAMPLE_WEIGHT_ONE`](crate::hash_cells::layout::SAMPLE_WEIGHT_ONE)ths: one sample
    /// unless [`Self::with_density`] set another.
    #[inline]
    pub fn sample_weight(&self) -> u32 {
        match self.flags >> QUERY_WEIGHT_SHIFT {
            0 => crate::hash_cells::layout::SAMPLE_WEIGHT_ONE,
            w => w,
        }
    }

    /// The query of a ray drawn `density` times as often as uniform sampling would draw it (a
    /// guided probe ray: 64 × its cell's probability): its sample weighs the inverse
    /// ([`crate::hash_cells::accumulate::sample_weight`]).
    #[inline]
    pub fn with_density(mut self, density: f32) -> Self {
        let w = crate::hash_cells::accumulate::sample_weight(density);
        self.flags = (self.flags & ((1 << QUERY_WEIGHT_SHIFT) - 1)) | (w << QUERY_WEIGHT_SHIFT);
        self
    }

    /// Hit position.
    #[inline]
    pub fn position(&self) -> Vec3 {
        Vec3::from_array(self.hit_position)
    }

    /// Ray direction (unit).
    #[inline]
    pub fn ray_direction(&self) -> Vec3 {
        unpack_octahedral16(self.direction)
    }

    /// Shading normal (unit).
    #[inline]
    pub fn shading_normal(&self) -> Vec3 {
        unpack_octahedral16(self.normal)
    }

    /// Diffuse albedo.
    #[inline]
    pub fn albedo(&self) -> Vec3 {
        unpack_albedo10x3(self.albedo)
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

impl crate::layout::FloatLayout for ShadowRay {
    const FLOAT_WORDS: &'static [u32] = &[0, 1, 2, 4, 5, 6, 7, 8, 9, 10];
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
pub struct RayRecord {
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

impl crate::layout::FloatLayout for RayRecord {
    const FLOAT_WORDS: &'static [u32] = &[0, 1, 2, 4, 5, 6];
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

/// The random stream of `pixel` in frame `frame` for pass `pass` (streams of different passes are
/// independent).
#[inline]
pub fn pass_random(seed: u32, pixel_or_item: u32, pass: u32, frame: u32) -> Random {
    Random::new(pcg_chain([pixel_or_item, pass, seed]), frame)
}

/// InsertRadianceCache for one query, its first step ([`crate::hash_cells::full_buckets`]): its
/// descriptor (from the eye, the hit, the direction and the keyed hit distance,
/// [`keyed_hit_distance`]) finds or inserts its tile; a new tile joins the live list with zeroed
/// values (and counts in [`INSERTED_TILES`]); the first touch of the frame lists the tile for the
/// update; a full bucket leaves [`NO_TILE`] and [`QUERY_REFUSED`] for [`admit_query`]. New keys
/// are noted in `marks`. The query's [`QUERY_BYPASS`] flag is set here too (it needs the cell
/// size).
#[inline]
pub fn insert_query<K, T, L, C, M>(
    mut cells: HashCellsInsert<'_, K, T, L, C, M>,
    params: &CachePassParams,
    query: &mut CacheQuery,
) where
    K: AtomicWords,
    T: AtomicWords,
    L: AtomicWords,
    C: AtomicWords,
    M: AtomicWords,
{
    query.tile = NO_TILE;
    let desc = query_cell(params, query);
    if desc.is_none() {
        return;
    }
    if is_bypass(&params.view, query.hit_distance, desc.cell_size()) {
        query.flags |= QUERY_BYPASS;
        cells.counters.fetch_add(BYPASS_COUNT, 1);
    }
    place_query(&mut cells, params, query, &desc);
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
#[inline]
fn place_query<K, T, L, C, M>(
    cells: &mut HashCellsInsert<'_, K, T, L, C, M>,
    params: &CachePassParams,
    query: &mut CacheQuery,
    desc: &CellDescriptor,
) where
    K: AtomicWords,
    T: AtomicWords,
    L: AtomicWords,
    C: AtomicWords,
    M: AtomicWords,
{
    let HashCellsInsert {
        keys,
        last_touch,
        values,
        lists,
        counters,
        marks,
    } = cells;
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
#[inline]
pub fn admit_query<K, T, L, C, M>(
    mut cells: HashCellsInsert<'_, K, T, L, C, M>,
    params: &CachePassParams,
    query: &mut CacheQuery,
) where
    K: AtomicWords,
    T: AtomicWords,
    L: AtomicWords,
    C: AtomicWords,
    M: AtomicWords,
{
    if query.flags & QUERY_REFUSED == 0 {
        return;
    }
    let desc = query_cell(params, query);
    if is_admitted(&cells.marks, &desc, &params.grid) {
        place_query(&mut cells, params, query, &desc);
    }
    // Refused again only where the bucket was full of older keys.
    query.flags &= !QUERY_REFUSED;
    if query.tile == NO_TILE {
        count(&mut cells.lists, FAILED_INSERTS);
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
    accumulate_cell_sample(
        accumulators,
        query.tile,
        query.cell_xy(),
        radiance,
        query.sample_weight(),
    )
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

/// Light-leak fix 2: whether a hit `hit_distance` from its ray's origin bypasses its cell's
/// filtered radiance, being closer than `cell_size` (the hit's cell size).
#[inline]
pub fn is_bypass(view: &CacheFrameParams, hit_distance: f32, cell_size: f32) -> bool {
    view.has(FLAG_BYPASS) && hit_distance < cell_size
}

/// The hit distance the descriptor keys a hit by: its own, or (short-ray flag off) the largest
/// finite distance, so that no hit counts as short.
#[inline]
pub fn keyed_hit_distance(view: &CacheFrameParams, hit_distance: f32) -> f32 {
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

#[cfg(test)]
pub(crate) mod tests {
    use super::*;

    /// A buffer of words the CPU model inserts into.
    type Words<'a> = &'a mut [u32];
    use crate::packing::pack_snorm10x3;
    use core::mem::{offset_of, size_of};

    /// A query's sample weight rides above its flags: setting it keeps the flags, and a query
    /// without one weighs one sample.
    #[test]
    fn a_query_carries_its_sample_weight_above_its_flags() {
        use crate::hash_cells::layout::{MAX_SAMPLE_WEIGHT, SAMPLE_WEIGHT_ONE};
        let q = CacheQuery {
            flags: QUERY_BYPASS | QUERY_CARRIED,
            ..CacheQuery::default()
        };
        assert_eq!(q.sample_weight(), SAMPLE_WEIGHT_ONE);
        let w = q.with_density(0.5);
        assert_eq!(w.sample_weight(), 2 * SAMPLE_WEIGHT_ONE);
        assert!(w.has(QUERY_BYPASS) && w.has(QUERY_CARRIED) && !w.has(QUERY_FED_BACK));
        assert_eq!(w.with_density(1e-9).sample_weight(), MAX_SAMPLE_WEIGHT);
        assert_eq!(w.with_density(f32::NAN).sample_weight(), SAMPLE_WEIGHT_ONE);
    }

    #[test]
    fn layouts() {
        use crate::layout::{FloatLayout, float_field_words};
        assert_eq!(
            RayRecord::FLOAT_WORDS,
            float_field_words(&[
                (offset_of!(RayRecord, ray_radiance), 3),
                (offset_of!(RayRecord, base), 3)
            ])
        );
        assert_eq!(
            ShadowRay::FLOAT_WORDS,
            float_field_words(&[
                (offset_of!(ShadowRay, origin), 3),
                (offset_of!(ShadowRay, direction), 3),
                (offset_of!(ShadowRay, t_max), 1),
                (offset_of!(ShadowRay, contribution), 3)
            ])
        );
        assert_eq!(
            CacheQuery::FLOAT_WORDS,
            float_field_words(&[
                (offset_of!(CacheQuery, hit_position), 3),
                (offset_of!(CacheQuery, hit_distance), 1)
            ])
        );
        assert_eq!(size_of::<CacheFrameParams>(), 80);
        assert_eq!(offset_of!(CacheFrameParams, flags), 28);
        assert_eq!(offset_of!(CacheFrameParams, environment_size), 32);
        assert_eq!(offset_of!(CacheFrameParams, environment_irradiance), 40);
        assert_eq!(offset_of!(CacheFrameParams, image_size), 48);
        assert_eq!(offset_of!(CacheFrameParams, reservoir_cell_const), 60);
        assert_eq!(offset_of!(CacheFrameParams, previous_eye), 64);
        assert_eq!(offset_of!(CacheFrameParams, reservoir_buckets), 76);
        assert_eq!(size_of::<CachePassParams>(), 128);
        assert!(size_of::<CachePassParams>() <= crate::layout::MAX_PUSH_CONSTANT_BYTES);
        assert_eq!(offset_of!(CachePassParams, view), 48);
        assert_eq!(size_of::<CacheQuery>(), 48);
        assert_eq!(offset_of!(CacheQuery, ray_index), 12);
        assert_eq!(offset_of!(CacheQuery, direction), 16);
        assert_eq!(offset_of!(CacheQuery, hit_distance), 20);
        assert_eq!(offset_of!(CacheQuery, normal), 24);
        assert_eq!(offset_of!(CacheQuery, geometric_normal), 28);
        assert_eq!(offset_of!(CacheQuery, albedo), 32);
        assert_eq!(offset_of!(CacheQuery, tile), 36);
        assert_eq!(offset_of!(CacheQuery, cell), 40);
        assert_eq!(offset_of!(CacheQuery, flags), 44);
        assert_eq!(size_of::<ShadowRay>(), 48);
        assert_eq!(offset_of!(ShadowRay, query), 12);
        assert_eq!(offset_of!(ShadowRay, t_max), 28);
        assert_eq!(offset_of!(ShadowRay, flags), 44);
        assert_eq!(size_of::<RayRecord>(), 32);
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

    pub(crate) fn query_at(p: Vec3, n: Vec3) -> CacheQuery {
        CacheQuery {
            hit_position: p.to_array(),
            geometric_normal: pack_snorm10x3(n),
            normal: crate::packing::pack_octahedral16(n),
            direction: crate::packing::pack_octahedral16(-n),
            hit_distance: 1.0,
            tile: NO_TILE,
            ..Default::default()
        }
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

        /// The buffers an insert writes.
        fn cells(
            &mut self,
        ) -> HashCellsInsert<'_, Words<'_>, Words<'_>, Words<'_>, Words<'_>, Words<'_>> {
            HashCellsInsert {
                keys: &mut self.keys[..],
                last_touch: &mut self.touch[..],
                values: &mut self.values,
                lists: &mut self.lists[..],
                counters: &mut self.counters[..],
                marks: &mut self.marks[..],
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
                insert_query(self.cells(), params, q);
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
                admit_query(self.cells(), params, q);
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
            view: CacheFrameParams {
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
            view: CacheFrameParams::default(),
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
}
