//! The GI frame's persistent GPU resources, sized from the settings (the hash grid) and the
//! resolution (one query, shadow ray and pixel record per pixel), each named so the memory table
//! lists it.
//!
//! Ping-pong: the hash grid's live-tile lists alternate on the frame parity inside the list
//! buffer (`gi_shared::hash_cells::lists`); world-space ReSTIR's reservoir grids are a
//! [`PingPong`] pair ([`RestirResources`]). The feedback history needs no second copy: the
//! composite writes it after GenerateReservoirs has read the previous frame's.

use super::settings::GiSettings;
use crate::error::Result;
use crate::frame::{FloatWords, indirect_args};
use crate::vulkan::{Buffer, Context, PingPong};
use ash::vk;
use gi_shared::camera::CameraParams;
use gi_shared::hash_cells::CELLS_PER_TILE;
use gi_shared::hash_cells::full_buckets::marks_words;
use gi_shared::hash_cells::layout::{HashCellValue, TILE_ACCUMULATOR_WORDS};
use gi_shared::hash_cells::lists::{
    DROPPED_SAMPLES, EVICTED_TILES, FAILED_INSERTS, UPDATE_TILES, list_buffer_words, live_list,
};
use gi_shared::hash_cells::touch::initial_last_touch;
use gi_shared::layout::MAX_STORAGE_BUFFER_BYTES;
use gi_shared::light_grid::{
    LIGHT_GRID_BOUNDS_WORDS, LIGHT_GRID_RESERVOIRS_PER_CELL, LightGridEntry, LightGridParams,
    light_grid_max_cells, light_grid_needed,
};
use gi_shared::multi_bounce::carried_capacity;
use gi_shared::radiance_feedback::FeedbackTexel;
use gi_shared::world_cache::{
    ARGS_COUNT, BOUNCE_MISSES, BYPASS_COUNT, CACHE_COUNTER_WORDS, CARRIED_QUERIES, CacheQuery,
    FEEDBACK_COUNT, INSERTED_TILES, QUERY_COUNT, RayRecord, SHADOW_RAY_COUNT, ShadowRay,
};
use gi_shared::world_restir::reservoir_grid_buckets;
use gi_shared::world_restir::{PackedReservoir, RESERVOIR_GRID_SLOTS_PER_BUCKET, ReservoirHit};

/// Entries of the light grid for `light_count` lights: the largest grid's for that many lights
/// (`light_grid_max_cells`), or one placeholder where there is no grid.
fn light_grid_entries(light_count: u32) -> usize {
    if light_grid_needed(light_count) {
        (light_grid_max_cells(light_count) * LIGHT_GRID_RESERVOIRS_PER_CELL) as usize
    } else {
        1
    }
}

/// Every buffer of a cache-view frame.
pub struct CacheResources {
    /// The camera of the frame (host-written parameters).
    pub camera: Buffer,
    /// Hash grid: one checksum per tile slot (0 = empty).
    pub keys: Buffer,
    /// Hash grid: the frame each tile was last touched.
    pub last_touch: Buffer,
    /// Hash grid: 85 [`HashCellValue`]s per tile.
    pub values: Buffer,
    /// Hash grid: multi-bounce's bounce copy of `values`, the history bounce rays read
    /// (`gi_shared::hash_cells::update::update_bounce_copy`); one value without multi-bounce.
    pub bounce_values: Buffer,
    /// Hash grid: [`TILE_ACCUMULATOR_WORDS`] words per tile (7 per mip-0 cell and the tile's
    /// luminance trend).
    pub accumulators: Buffer,
    /// Hash grid: counters and the live (×2, ping-pong) and update tile lists.
    pub lists: Buffer,
    /// The cache view's counters (`gi_shared::world_cache::QUERY_COUNT` ...).
    pub counters: Buffer,
    /// One [`CacheQuery`] per ray at most.
    pub queries: Buffer,
    /// One [`ShadowRay`] per ray at most.
    pub shadow_rays: Buffer,
    /// One [`RayRecord`] per ray: the cache passes complete its `ray_radiance` (the cache
    /// view traces one ray per pixel, the GI frame one per probe cell it spawns).
    pub ray_records: Buffer,
    /// One [`FeedbackTexel`] per pixel: the previous frame's image for temporal feedback; a
    /// one-texel placeholder without it (`GiSettings::temporal_feedback`), which the composite
    /// then leaves alone.
    pub history: Buffer,
    /// The light grid's hit bounds ([`LIGHT_GRID_BOUNDS_WORDS`] words).
    pub bounds: Buffer,
    /// The light grid's [`LightGridParams`].
    pub light_grid: Buffer,
    /// The light grid's entries, for the largest grid of the scene's lights
    /// (`gi_shared::light_grid::light_grid_max_cells`); one placeholder where they need no grid
    /// (`gi_shared::light_grid::light_grid_needed`).
    pub light_grid_entries: Buffer,
    /// Indirect dispatch arguments (`ARGS_COUNT` of them).
    pub args: Buffer,
    /// Queries multi-bounce carries to the next frame (`gi_shared::multi_bounce`):
    /// `carried_capacity(rays)` of them, one placeholder without multi-bounce.
    pub carried: Buffer,
    /// Hash grid: InsertRadianceCache's marks, a word per tile and two per bucket
    /// (`gi_shared::hash_cells::full_buckets`), refilled every frame.
    pub insert_marks: Buffer,
    tile_count: u32,
    pixel_count: u32,
    ray_capacity: u32,
    carried_capacity: u32,
    /// Whether temporal feedback reads the history (else it is a placeholder).
    feedback: bool,
}

/// Texels of the feedback history for `pixels` pixels: one each with temporal feedback, else
/// one placeholder.
fn feedback_texels(feedback: bool, pixels: usize) -> usize {
    if feedback { pixels } else { 1 }
}

/// Queries the carried list holds for `rays` rays: none without multi-bounce, whose carried
/// queries are the only ones (the list and its room in the query and shadow-ray lists are then
/// not allocated).
fn carried_queries(multi_bounce: bool, rays: usize) -> usize {
    if multi_bounce {
        carried_capacity(rays as u32) as usize
    } else {
        0
    }
}

/// Queries per frame at most for `rays` rays, with or without `multi_bounce`: one per ray and the
/// carried ones. The query and shadow-ray lists, and world-space ReSTIR's per-shadow-ray buffers,
/// hold this many (a shadow ray past ReSTIR's buffers would leave the grid in the order of the
/// atomics).
pub fn query_capacity(multi_bounce: bool, rays: u32) -> u32 {
    let rays = rays.max(1) as usize;
    (rays + carried_queries(multi_bounce, rays)) as u32
}

impl CacheResources {
    /// Allocates the resources of a `width × height` frame that traces at most `rays` rays into
    /// the cache per frame, with `settings` (validated first: a bad setting is an error naming
    /// it), the hash grid empty for a first frame `first_frame`.
    pub fn new(
        ctx: &Context,
        settings: &GiSettings,
        width: u32,
        height: u32,
        rays: u32,
        first_frame: u32,
        light_count: u32,
    ) -> Result<Self> {
        settings.validate(width, height)?;
        let tiles = settings.tile_count() as usize;
        let pixels = width as usize * height as usize;
        let rays = (rays as usize).max(1);
        let carried = carried_queries(settings.multi_bounce, rays);
        let queries = query_capacity(settings.multi_bounce, rays as u32) as usize;
        let cells = tiles * CELLS_PER_TILE as usize;
        let accumulator_words = tiles * TILE_ACCUMULATOR_WORDS;
        debug_assert!(accumulator_words * 4 <= MAX_STORAGE_BUFFER_BYTES);
        let entries = light_grid_entries(light_count);
        Ok(Self {
            camera: Buffer::parameters(ctx, "camera", &[CameraParams::default()])?,
            keys: Buffer::device_zeroed::<u32>(ctx, "hash grid keys", tiles)?,
            last_touch: Buffer::device_local(
                ctx,
                "hash grid last touch",
                &vec![initial_last_touch(first_frame); tiles],
                vk::BufferUsageFlags::empty(),
            )?,
            values: Buffer::device_zeroed::<HashCellValue>(ctx, "hash grid values", cells)?,
            bounce_values: Buffer::device_zeroed::<HashCellValue>(
                ctx,
                "hash grid bounce values",
                if settings.multi_bounce { cells } else { 1 },
            )?,
            accumulators: Buffer::device_zeroed::<u32>(
                ctx,
                "hash grid accumulators",
                accumulator_words,
            )?,
            lists: Buffer::device_zeroed::<u32>(
                ctx,
                "hash grid lists",
                list_buffer_words(tiles as u32),
            )?,
            counters: Buffer::device_zeroed::<u32>(ctx, "cache counters", CACHE_COUNTER_WORDS)?,
            queries: Buffer::device_zeroed::<CacheQuery>(ctx, "cache queries", queries)?,
            shadow_rays: Buffer::device_zeroed::<ShadowRay>(ctx, "shadow rays", queries)?,
            ray_records: Buffer::device_zeroed::<RayRecord>(ctx, "ray records", rays)?,
            history: Buffer::device_zeroed::<FeedbackTexel>(
                ctx,
                "feedback history",
                feedback_texels(settings.temporal_feedback, pixels),
            )?,
            bounds: Buffer::device_zeroed::<u32>(
                ctx,
                "light grid bounds",
                LIGHT_GRID_BOUNDS_WORDS,
            )?,
            light_grid: Buffer::device_zeroed::<LightGridParams>(ctx, "light grid", 1)?,
            light_grid_entries: Buffer::device_zeroed::<LightGridEntry>(
                ctx,
                "light grid entries",
                entries,
            )?,
            args: indirect_args(ctx, "indirect arguments", ARGS_COUNT as usize)?,
            carried: Buffer::device_zeroed::<CacheQuery>(ctx, "carried queries", carried.max(1))?,
            insert_marks: Buffer::device_zeroed::<u32>(
                ctx,
                "hash grid insert marks",
                marks_words(settings.buckets_log2, settings.tiles_per_bucket_log2),
            )?,
            tile_count: tiles as u32,
            pixel_count: pixels as u32,
            ray_capacity: rays as u32,
            carried_capacity: carried as u32,
            feedback: settings.temporal_feedback,
        })
    }

    /// Makes the light grid's entries fit a scene of `light_count` lights (the largest grid, or
    /// one placeholder where it needs none): after a change of scene.
    pub fn fit_light_grid(&mut self, ctx: &Context, light_count: u32) -> Result<()> {
        let entries = light_grid_entries(light_count);
        if self.light_grid_entries.size != (entries * size_of::<LightGridEntry>()) as u64 {
            self.light_grid_entries =
                Buffer::device_zeroed::<LightGridEntry>(ctx, "light grid entries", entries)?;
        }
        Ok(())
    }

    /// Reallocates what depends on the frame's size (queries, shadow rays, ray records and
    /// carried queries for `rays` rays; feedback history for `width × height`
    /// pixels, zeroed; the counters, zeroed, so that no query is carried into the new lists) and
    /// keeps the hash grid and the light grid: the world cache survives a resize. On an error
    /// nothing changed.
    pub fn resize(&mut self, ctx: &Context, width: u32, height: u32, rays: u32) -> Result<()> {
        let pixels = width as usize * height as usize;
        let rays = (rays as usize).max(1);
        let multi_bounce = self.carried_capacity > 0;
        let carried = carried_queries(multi_bounce, rays);
        let capacity = query_capacity(multi_bounce, rays as u32) as usize;
        // Each new buffer takes the name of the field it replaces.
        let counters =
            Buffer::device_zeroed::<u32>(ctx, self.counters.name(), CACHE_COUNTER_WORDS)?;
        let queries = Buffer::device_zeroed::<CacheQuery>(ctx, self.queries.name(), capacity)?;
        let shadow_rays =
            Buffer::device_zeroed::<ShadowRay>(ctx, self.shadow_rays.name(), capacity)?;
        let ray_records = Buffer::device_zeroed::<RayRecord>(ctx, self.ray_records.name(), rays)?;
        let history = Buffer::device_zeroed::<FeedbackTexel>(
            ctx,
            self.history.name(),
            feedback_texels(self.feedback, pixels),
        )?;
        let carried_queries =
            Buffer::device_zeroed::<CacheQuery>(ctx, self.carried.name(), carried.max(1))?;
        self.counters = counters;
        self.queries = queries;
        self.shadow_rays = shadow_rays;
        self.ray_records = ray_records;
        self.history = history;
        self.carried = carried_queries;
        self.pixel_count = pixels as u32;
        self.ray_capacity = rays as u32;
        self.carried_capacity = carried as u32;
        Ok(())
    }

    /// Tiles of the hash grid.
    pub fn tile_count(&self) -> u32 {
        self.tile_count
    }

    /// Pixels of the frame: the feedback history's size with temporal feedback.
    pub fn pixel_count(&self) -> u32 {
        self.pixel_count
    }

    /// Rays per frame at most: the capacity of the ray-record buffer.
    pub fn ray_capacity(&self) -> u32 {
        self.ray_capacity
    }

    /// Queries per frame at most (one per ray and the carried ones): the capacity of the query
    /// and shadow-ray buffers.
    pub fn query_capacity(&self) -> u32 {
        self.ray_capacity + self.carried_capacity
    }

    /// Queries multi-bounce can carry to the next frame (0 without multi-bounce: its buffer is a
    /// one-element placeholder).
    pub fn carried_capacity(&self) -> u32 {
        self.carried_capacity
    }

    /// Every buffer.
    pub fn buffers(&self) -> [&Buffer; 18] {
        [
            &self.camera,
            &self.keys,
            &self.last_touch,
            &self.values,
            &self.bounce_values,
            &self.accumulators,
            &self.lists,
            &self.counters,
            &self.queries,
            &self.shadow_rays,
            &self.ray_records,
            &self.history,
            &self.bounds,
            &self.light_grid,
            &self.light_grid_entries,
            &self.args,
            &self.carried,
            &self.insert_marks,
        ]
    }

    /// The occupancy after frame `frame`, read back from the counters.
    pub fn occupancy(&self, ctx: &Context, frame: u32) -> Result<Occupancy> {
        let counters: Vec<u32> = self.counters.read_back(ctx)?;
        let lists: Vec<u32> = self.lists.read_back(ctx)?;
        let tiles = self.tile_count();
        let queries = self.query_capacity();
        let word = |list: u32| lists.get(list as usize).copied().unwrap_or(0);
        Ok(Occupancy {
            frame,
            live_tiles: word(live_list(frame)).min(tiles),
            inserted: counters[INSERTED_TILES],
            failed_inserts: word(FAILED_INSERTS),
            evicted: word(EVICTED_TILES),
            updated: word(UPDATE_TILES).min(tiles),
            queries: counters[QUERY_COUNT].min(queries),
            carried: counters[CARRIED_QUERIES],
            fed_back: counters[FEEDBACK_COUNT],
            shadow_rays: counters[SHADOW_RAY_COUNT].min(queries),
            bypassed: counters[BYPASS_COUNT],
            bounce_misses: counters[BOUNCE_MISSES],
            dropped: word(DROPPED_SAMPLES),
        })
    }

    /// Total bytes of the buffers.
    pub fn bytes(&self) -> u64 {
        self.buffers().iter().map(|b| b.size).sum()
    }

    /// The buffers that hold floats, with which of their words are floats (each record's
    /// [`FloatLayout`](gi_shared::layout::FloatLayout)): what a NaN check reads. Keys, lists,
    /// counters, marks, the host's parameters and the cell values (packed
    /// [`gi_shared::packing::pack_wide16`]s, which cannot hold a NaN) are left out.
    pub fn float_buffers(&self) -> Result<Vec<(&Buffer, FloatWords)>> {
        Ok(vec![
            (&self.queries, FloatWords::of::<CacheQuery>()?),
            (&self.shadow_rays, FloatWords::of::<ShadowRay>()?),
            (&self.ray_records, FloatWords::of::<RayRecord>()?),
            (&self.history, FloatWords::of::<FeedbackTexel>()?),
            (&self.light_grid, FloatWords::of::<LightGridParams>()?),
            (
                &self.light_grid_entries,
                FloatWords::of::<LightGridEntry>()?,
            ),
        ])
    }
}

/// The cache's occupancy and the frame's work, read back after a frame.
#[derive(Clone, Copy, Debug, Default, PartialEq, Eq)]
pub struct Occupancy {
    /// The frame's index.
    pub frame: u32,
    /// Tiles in this frame's live list (kept from the previous frame + inserted).
    pub live_tiles: u32,
    /// Tiles inserted this frame.
    pub inserted: u32,
    /// Inserts refused because the bucket was full (those rays got no cache light).
    pub failed_inserts: u32,
    /// Tiles evicted this frame.
    pub evicted: u32,
    /// Tiles updated this frame.
    pub updated: u32,
    /// Queries (secondary hits, and the queries carried over).
    pub queries: u32,
    /// Queries multi-bounce carried over from the previous frame (among `queries`).
    pub carried: u32,
    /// Queries lit by temporal feedback.
    pub fed_back: u32,
    /// Shadow rays traced.
    pub shadow_rays: u32,
    /// Queries that bypassed their cell (light-leak fix 2).
    pub bypassed: u32,
    /// Bounce rays (one per shadow ray with [`GiSettings::multi_bounce`]) whose hit had no cell
    /// with a sample: they added nothing.
    pub bounce_misses: u32,
    /// Samples dropped as not finite.
    pub dropped: u32,
}

/// One frame's world-space ReSTIR reservoir grid.
pub struct ReservoirGrid {
    /// One checksum per slot (0 = empty).
    pub keys: Buffer,
    /// Per slot the count of its reservoirs, scanned in place into exclusive offsets by
    /// CompactReservoirs; one more word holds the total.
    pub offsets: Buffer,
    /// The shadow-ray indices, slot after slot.
    pub entries: Buffer,
    /// Per shadow ray its reservoir (`PackedReservoir`).
    pub reservoirs: Buffer,
    /// Per shadow ray its hit (`ReservoirHit`).
    pub hits: Buffer,
}

impl ReservoirGrid {
    /// A grid of `slots` slots for `rays` shadow rays, its buffers named with `which`.
    fn new(ctx: &Context, which: &str, slots: usize, rays: usize) -> Result<Self> {
        Ok(Self {
            keys: Buffer::device_zeroed::<u32>(
                ctx,
                &format!("reservoir grid keys ({which})"),
                slots,
            )?,
            offsets: Buffer::device_zeroed::<u32>(
                ctx,
                &format!("reservoir grid offsets ({which})"),
                slots + 1,
            )?,
            entries: Buffer::device_zeroed::<u32>(
                ctx,
                &format!("reservoir grid entries ({which})"),
                rays,
            )?,
            reservoirs: Buffer::device_zeroed::<PackedReservoir>(
                ctx,
                &format!("reservoirs ({which})"),
                rays,
            )?,
            hits: Buffer::device_zeroed::<ReservoirHit>(
                ctx,
                &format!("reservoir hits ({which})"),
                rays,
            )?,
        })
    }
}

/// World-space ReSTIR's resources: this frame's and the previous frame's reservoir grids, and
/// each shadow ray's place in this frame's. Sized for the frame when ReSTIR is on
/// ([`reservoir_grid_buckets`] buckets of 16 slots, one entry per ray); one-element
/// placeholders (that the kernels bind but never use) when it is off.
pub struct RestirResources {
    /// This frame's grid and the previous frame's.
    pub grids: PingPong<ReservoirGrid>,
    /// Per shadow ray `[slot, index in the slot]` (`[u32; 2]`).
    pub places: Buffer,
    /// Each shadow ray's sort key (`[u32; 2]`, `gi_shared::world_restir::reservoir_order_key`),
    /// slot after slot in the order of the atomics that placed them (CompactReservoirs's scatter,
    /// before it orders each slot's run into the grid's entries).
    pub unordered: Buffer,
    /// Slots of a grid.
    pub slots: u32,
    /// Buckets of a grid.
    pub buckets: u32,
}

impl RestirResources {
    /// The resources of a frame of at most `rays` rays ([`query_capacity`] shadow rays) with
    /// `settings`, real when ReSTIR is on.
    pub fn new(ctx: &Context, settings: &GiSettings, rays: u32) -> Result<Self> {
        let on = settings.restir;
        let rays = query_capacity(settings.multi_bounce, rays);
        let buckets = if on { reservoir_grid_buckets(rays) } else { 1 };
        let slots = if on {
            buckets * RESERVOIR_GRID_SLOTS_PER_BUCKET
        } else {
            1
        };
        let rays = if on { rays as usize } else { 1 };
        Ok(Self {
            grids: PingPong::new(
                ReservoirGrid::new(ctx, "a", slots as usize, rays)?,
                ReservoirGrid::new(ctx, "b", slots as usize, rays)?,
            ),
            places: Buffer::device_zeroed::<[u32; 2]>(ctx, "reservoir places", rays)?,
            unordered: Buffer::device_zeroed::<[u32; 2]>(ctx, "reservoir scatter", rays)?,
            slots,
            buckets,
        })
    }

    /// Both grids' reservoirs and hits, with their float words (as
    /// [`CacheResources::float_buffers`]).
    pub fn float_buffers(&self) -> Result<Vec<(&Buffer, FloatWords)>> {
        let (reservoir, hit) = (
            FloatWords::of::<PackedReservoir>()?,
            FloatWords::of::<ReservoirHit>()?,
        );
        let (a, b) = self.grids.pair();
        Ok(vec![
            (&a.reservoirs, reservoir),
            (&a.hits, hit),
            (&b.reservoirs, reservoir),
            (&b.hits, hit),
        ])
    }
}
