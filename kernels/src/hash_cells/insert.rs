//! InsertRadianceCache: one invocation per query (dispatched from the query counter) finds or
//! inserts the query's tile, stamps it, lists it for the update on its first touch of the frame,
//! and writes the tile and cell into the query (`gi_shared::world_cache::insert_query`). Two more
//! dispatches over the queries settle the buckets that could not take every new key, the same
//! way whatever order the inserts ran in (`gi_shared::hash_cells::full_buckets`):
//! [`settle_full_buckets`] and [`admit_to_full_buckets`].
//!
//! Set 0 of all three: keys, last touch, values, lists, cache-view counters, queries, the insert
//! marks.

use crate::atomics::DeviceWords;
use gi_shared::atomics::AtomicWords;
use gi_shared::hash_cells::layout::{HashCellValue, HashCellsInsert};
use gi_shared::math::min_u32;
use gi_shared::world_cache::{
    CachePassParams, CacheQuery, QUERY_COUNT, admit_query, insert_query, settle_query,
};
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
    #[spirv(storage_buffer, descriptor_set = 0, binding = 6)] marks: &mut [u32],
) {
    let cells = device_cells(keys, last_touch, values, lists, counters, marks);
    place::<false>(id, params, cells, queries);
}

/// Takes back query `id.x`'s tile where a full bucket does not keep it.
#[spirv(compute(threads(64)))]
#[allow(
    clippy::too_many_arguments,
    reason = "an entry point takes one argument per binding"
)]
pub fn settle_full_buckets(
    #[spirv(global_invocation_id)] id: UVec3,
    #[spirv(push_constant)] params: &CachePassParams,
    #[spirv(storage_buffer, descriptor_set = 0, binding = 0)] keys: &mut [u32],
    #[spirv(storage_buffer, descriptor_set = 0, binding = 1)] _last_touch: &mut [u32],
    #[spirv(storage_buffer, descriptor_set = 0, binding = 2)] _values: &mut [HashCellValue],
    #[spirv(storage_buffer, descriptor_set = 0, binding = 3)] lists: &mut [u32],
    #[spirv(storage_buffer, descriptor_set = 0, binding = 4)] counters: &mut [u32],
    #[spirv(storage_buffer, descriptor_set = 0, binding = 5)] queries: &mut [CacheQuery],
    #[spirv(storage_buffer, descriptor_set = 0, binding = 6)] marks: &mut [u32],
) {
    let counters = DeviceWords(counters);
    let Some(i) = query_index(&counters, queries, id.x) else {
        return;
    };
    let mut query = queries[i];
    settle_query(
        &mut DeviceWords(keys),
        &mut DeviceWords(lists),
        &DeviceWords(marks),
        params,
        &mut query,
    );
    queries[i] = query;
}

/// Inserts query `id.x` again where its full bucket admits its key.
#[spirv(compute(threads(64)))]
#[allow(
    clippy::too_many_arguments,
    reason = "an entry point takes one argument per binding"
)]
pub fn admit_to_full_buckets(
    #[spirv(global_invocation_id)] id: UVec3,
    #[spirv(push_constant)] params: &CachePassParams,
    #[spirv(storage_buffer, descriptor_set = 0, binding = 0)] keys: &mut [u32],
    #[spirv(storage_buffer, descriptor_set = 0, binding = 1)] last_touch: &mut [u32],
    #[spirv(storage_buffer, descriptor_set = 0, binding = 2)] values: &mut [HashCellValue],
    #[spirv(storage_buffer, descriptor_set = 0, binding = 3)] lists: &mut [u32],
    #[spirv(storage_buffer, descriptor_set = 0, binding = 4)] counters: &mut [u32],
    #[spirv(storage_buffer, descriptor_set = 0, binding = 5)] queries: &mut [CacheQuery],
    #[spirv(storage_buffer, descriptor_set = 0, binding = 6)] marks: &mut [u32],
) {
    let cells = device_cells(keys, last_touch, values, lists, counters, marks);
    place::<true>(id, params, cells, queries);
}

/// The insert's buffers under device-scope atomics, held by value (`HashCellsInsert`).
type DeviceCells<'a> = HashCellsInsert<
    'a,
    DeviceWords<'a>,
    DeviceWords<'a>,
    DeviceWords<'a>,
    DeviceWords<'a>,
    DeviceWords<'a>,
>;

/// The insert's bindings as [`DeviceCells`].
fn device_cells<'a>(
    keys: &'a mut [u32],
    last_touch: &'a mut [u32],
    values: &'a mut [HashCellValue],
    lists: &'a mut [u32],
    counters: &'a mut [u32],
    marks: &'a mut [u32],
) -> DeviceCells<'a> {
    HashCellsInsert {
        keys: DeviceWords(keys),
        last_touch: DeviceWords(last_touch),
        values,
        lists: DeviceWords(lists),
        counters: DeviceWords(counters),
        marks: DeviceWords(marks),
    }
}

/// Inserts query `id.x` (`insert_query`), or with `ADMIT` inserts it again where its full bucket
/// admits its key (`admit_query`): the two steps take the same buffers.
fn place<const ADMIT: bool>(
    id: UVec3,
    params: &CachePassParams,
    cells: DeviceCells<'_>,
    queries: &mut [CacheQuery],
) {
    let Some(i) = query_index(&cells.counters, queries, id.x) else {
        return;
    };
    let mut query = queries[i];
    // Both steps are generic: a function pointer would not compile for the GPU.
    if ADMIT {
        admit_query(cells, params, &mut query);
    } else {
        insert_query(cells, params, &mut query);
    }
    queries[i] = query;
}

/// Invocation `x`'s query, if the frame has that many.
fn query_index(counters: &DeviceWords, queries: &[CacheQuery], x: u32) -> Option<usize> {
    let count = min_u32(counters.load(QUERY_COUNT), queries.len() as u32);
    if x < count { Some(x as usize) } else { None }
}
