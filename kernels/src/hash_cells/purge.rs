//! PurgeRadianceCache: [`begin_frame`] resets the frame's counters (one invocation), then
//! [`carry_queries`] opens the query list with the queries multi-bounce carried over, and
//! [`purge_tiles`] walks the previous frame's live list (one invocation per entry, dispatched from
//! its counter): tiles untouched for `TILE_DECAY_FRAMES` frames are evicted, the others carried
//! into this frame's list.
//!
//! `begin_frame`, set 0: lists, cache-view counters, light-grid bounds, carried queries.
//! `carry_queries`, set 0: cache-view counters, carried queries, queries. `purge_tiles`, set 0:
//! keys, last touch, lists.

use crate::atomics::DeviceWords;
use gi_shared::hash_cells::passes::purge_pass;
use gi_shared::light_grid::clear_hit_bounds;
use gi_shared::world_cache::{CachePassParams, CacheQuery, begin_cache_frame, carry_query};
use spirv_std::glam::UVec3;
use spirv_std::spirv;

/// Zeroes the frame's counters (all but the previous live list) and empties the light grid's hit
/// bounds; one invocation.
#[spirv(compute(threads(1)))]
pub fn begin_frame(
    #[spirv(push_constant)] params: &CachePassParams,
    #[spirv(storage_buffer, descriptor_set = 0, binding = 0)] lists: &mut [u32],
    #[spirv(storage_buffer, descriptor_set = 0, binding = 1)] counters: &mut [u32],
    #[spirv(storage_buffer, descriptor_set = 0, binding = 2)] bounds: &mut [u32],
    #[spirv(storage_buffer, descriptor_set = 0, binding = 3)] carried: &[CacheQuery],
) {
    begin_cache_frame(
        lists,
        counters,
        params.grid.frame_index,
        carried.len() as u32,
    );
    clear_hit_bounds(bounds, 0);
}

/// Copies carried query `id.x` to the head of the query list.
#[spirv(compute(threads(64)))]
pub fn carry_queries(
    #[spirv(global_invocation_id)] id: UVec3,
    #[spirv(storage_buffer, descriptor_set = 0, binding = 0)] counters: &[u32],
    #[spirv(storage_buffer, descriptor_set = 0, binding = 1)] carried: &[CacheQuery],
    #[spirv(storage_buffer, descriptor_set = 0, binding = 2)] queries: &mut [CacheQuery],
) {
    carry_query(counters, carried, queries, id.x);
}

/// Evicts or keeps entry `id.x` of the previous frame's live list.
#[spirv(compute(threads(64)))]
pub fn purge_tiles(
    #[spirv(global_invocation_id)] id: UVec3,
    #[spirv(push_constant)] params: &CachePassParams,
    #[spirv(storage_buffer, descriptor_set = 0, binding = 0)] keys: &mut [u32],
    #[spirv(storage_buffer, descriptor_set = 0, binding = 1)] last_touch: &mut [u32],
    #[spirv(storage_buffer, descriptor_set = 0, binding = 2)] lists: &mut [u32],
) {
    purge_pass(
        &mut DeviceWords(keys),
        &DeviceWords(last_touch),
        &mut DeviceWords(lists),
        &params.grid,
        id.x,
    );
}
