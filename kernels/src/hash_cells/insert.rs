//! InsertRadianceCache: one invocation per query (dispatched from the query counter) finds or
//! inserts the query's tile, stamps it, lists it for the update on its first touch of the frame,
//! and writes the tile and cell into the query (`gi_shared::cache_view::insert_query`).
//!
//! Set 0: keys, last touch, values, lists, cache-view counters, queries.

use crate::atomics::DeviceWords;
use gi_shared::atomics::AtomicWords;
use gi_shared::cache_view::{CachePassParams, CacheQuery, QUERY_COUNT, insert_query};
use gi_shared::layout::HashCellValue;
use gi_shared::math::min_u32;
use spirv_std::glam::UVec3;
use spirv_std::spirv;

/// Inserts query `id.x`.
#[spirv(compute(threads(64)))]
#[allow(
    clippy::too_many_arguments,
    reason = "an entry point takes one argument per binding"
)]
pub fn insert_radiance_cache(
    #[spirv(global_invocation_id)] id: UVec3,
    #[spirv(push_constant)] params: &CachePassParams,
    #[spirv(storage_buffer, descriptor_set = 0, binding = 0)] keys: &mut [u32],
    #[spirv(storage_buffer, descriptor_set = 0, binding = 1)] last_touch: &mut [u32],
    #[spirv(storage_buffer, descriptor_set = 0, binding = 2)] values: &mut [HashCellValue],
    #[spirv(storage_buffer, descriptor_set = 0, binding = 3)] lists: &mut [u32],
    #[spirv(storage_buffer, descriptor_set = 0, binding = 4)] counters: &mut [u32],
    #[spirv(storage_buffer, descriptor_set = 0, binding = 5)] queries: &mut [CacheQuery],
) {
    let mut counters = DeviceWords(counters);
    let count = min_u32(counters.load(QUERY_COUNT), queries.len() as u32);
    if id.x >= count {
        return;
    }
    let i = id.x as usize;
    let mut query = queries[i];
    insert_query(
        &mut DeviceWords(keys),
        &mut DeviceWords(last_touch),
        values,
        &mut DeviceWords(lists),
        &mut counters,
        params,
        &mut query,
    );
    queries[i] = query;
}
