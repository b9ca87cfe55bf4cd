//! Kernels that exist for `tests/tests/frame_machinery.rs`: they drive the frame machinery (GPU
//! atomics, append lists, indirect dispatch, hash-cell inserts) under contention so the test can
//! compare the outcome with the CPU model in `gi_shared::machinery_tests`.
//!
//! Set 0 and push constants (`MachineryPush`) are listed per kernel.

use crate::atomics::{DeviceWords, WorkgroupWords};
use gi_shared::append_list::{append, clamped_count};
use gi_shared::atomics::AtomicWords;
use gi_shared::hash_cells::layout::HashGridParams;
use gi_shared::hash_cells::storage::insert_tile;
use gi_shared::light_grid::{clear_hit_bounds, report_hit_bounds};
use gi_shared::machinery_tests::{
    AtomicsRecord, BOUNDS_COUNT_WORD, COUNTER_INVOCATIONS, COUNTER_ITEMS, MachineryPush, WORD_CAS,
    WORD_MAX, WORD_MIN, WORD_STORE, WORD_SUM, WORD_SWAP, WORD_TICKET, WorkgroupRecord,
    appended_items, contention_descriptor, contention_value, encode_insert, item_value,
};
use spirv_std::arch::workgroup_memory_barrier_with_group_sync;
use spirv_std::glam::{UVec3, Vec3};
use spirv_std::spirv;

/// Workgroup-memory words of [`atomics_contention`]: counter, minimum, maximum.
const SHARED_WORDS: usize = 3;

/// Every invocation hits the same device words with each atomic operation (see the `WORD_*`
/// constants) and records what it got back in `records`; each workgroup also counts, minimises
/// and maximises through workgroup-memory atomics and writes `groups[workgroup]`.
#[spirv(compute(threads(64)))]
#[allow(
    clippy::too_many_arguments,
    reason = "an entry point takes one argument per binding and built-in"
)]
pub fn atomics_contention(
    #[spirv(global_invocation_id)] id: UVec3,
    #[spirv(local_invocation_index)] local: u32,
    #[spirv(workgroup_id)] group: UVec3,
    #[spirv(push_constant)] push: &MachineryPush,
    #[spirv(storage_buffer, descriptor_set = 0, binding = 0)] words: &mut [u32],
    #[spirv(storage_buffer, descriptor_set = 0, binding = 1)] records: &mut [AtomicsRecord],
    #[spirv(storage_buffer, descriptor_set = 0, binding = 2)] groups: &mut [WorkgroupRecord],
    #[spirv(workgroup)] shared: &mut [u32; SHARED_WORDS],
) {
    let i = id.x;
    let active = i < push.count && (i as usize) < records.len();
    let value = contention_value(i, push.seed);
    let mut shared = WorkgroupWords(shared);
    if local == 0 {
        shared.store(0, 0);
        shared.store(1, u32::MAX);
        shared.store(2, 0);
    }
    workgroup_memory_barrier_with_group_sync();
    let mut workgroup_ticket = 0;
    if active {
        workgroup_ticket = shared.fetch_add(0, 1);
        shared.fetch_min(1, value);
        shared.fetch_max(2, value);
    }
    workgroup_memory_barrier_with_group_sync();
    if local == 0 && (group.x as usize) < groups.len() {
        groups[group.x as usize] = WorkgroupRecord {
            count: shared.load(0),
            min: shared.load(1),
            max: shared.load(2),
            _pad: 0,
        };
    }
    let own = WORD_STORE + i as usize;
    if active && own < words.len() {
        let mut words = DeviceWords(words);
        words.fetch_add(WORD_SUM, i + 1);
        words.fetch_min(WORD_MIN, value);
        words.fetch_max(WORD_MAX, value);
        let cas_old = words.compare_exchange(WORD_CAS, 0, i + 1);
        let swap_old = words.swap(WORD_SWAP, i + 1);
        let ticket = words.fetch_add(WORD_TICKET, 1);
        words.store(own, value);
        let loaded = words.load(own);
        records[i as usize] = AtomicsRecord {
            cas_old,
            swap_old,
            ticket,
            loaded,
            workgroup_ticket,
            _pad: [0; 3],
        };
    }
}

/// Invocation `i < count` appends [`appended_items`]`(i, seed)` items ([`item_value`]) to the list
/// (`capacity` slots) whose counter is word [`COUNTER_ITEMS`] of `counters`.
#[spirv(compute(threads(64)))]
pub fn append_items(
    #[spirv(global_invocation_id)] id: UVec3,
    #[spirv(push_constant)] push: &MachineryPush,
    #[spirv(storage_buffer, descriptor_set = 0, binding = 0)] counters: &mut [u32],
    #[spirv(storage_buffer, descriptor_set = 0, binding = 1)] list: &mut [u32],
) {
    if id.x >= push.count {
        return;
    }
    let mut counters = DeviceWords(counters);
    let items = appended_items(id.x, push.seed);
    let mut k = 0;
    while k < items {
        if let Some(slot) = append(&mut counters, COUNTER_ITEMS, push.capacity)
            && (slot as usize) < list.len()
        {
            list[slot as usize] = item_value(id.x, k);
        }
        k += 1;
    }
}

/// Dispatched indirectly over the list [`append_items`] filled: every invocation counts itself in
/// word [`COUNTER_INVOCATIONS`]; invocation `i` below the clamped count adds 1 to
/// `touched[list[i]]`.
#[spirv(compute(threads(64)))]
pub fn touch_items(
    #[spirv(global_invocation_id)] id: UVec3,
    #[spirv(push_constant)] push: &MachineryPush,
    #[spirv(storage_buffer, descriptor_set = 0, binding = 0)] counters: &mut [u32],
    #[spirv(storage_buffer, descriptor_set = 0, binding = 1)] list: &[u32],
    #[spirv(storage_buffer, descriptor_set = 0, binding = 2)] touched: &mut [u32],
) {
    let mut counters = DeviceWords(counters);
    counters.fetch_add(COUNTER_INVOCATIONS, 1);
    let count = clamped_count(counters.load(COUNTER_ITEMS), push.capacity);
    if id.x < count && (id.x as usize) < list.len() {
        let item = list[id.x as usize] as usize;
        if item < touched.len() {
            DeviceWords(touched).fetch_add(item, 1);
        }
    }
}

/// Invocation `i < count` inserts [`contention_descriptor`]`(i, ..)` into the hash-cell `keys`
/// with `gi_shared::hash_cells::storage::insert_tile` and writes the encoded outcome
/// ([`encode_insert`]) to `outcomes[i]`. `capacity` is the number of distinct keys.
#[spirv(compute(threads(64)))]
pub fn insert_keys(
    #[spirv(global_invocation_id)] id: UVec3,
    #[spirv(push_constant)] push: &MachineryPush,
    #[spirv(storage_buffer, descriptor_set = 0, binding = 0)] params: &HashGridParams,
    #[spirv(storage_buffer, descriptor_set = 0, binding = 1)] keys: &mut [u32],
    #[spirv(storage_buffer, descriptor_set = 0, binding = 2)] outcomes: &mut [u32],
) {
    let i = id.x as usize;
    if id.x < push.count && i < outcomes.len() {
        let desc = contention_descriptor(id.x, push.capacity, push.seed, params.num_buckets_log2);
        let params = *params;
        outcomes[i] = encode_insert(insert_tile(&mut DeviceWords(keys), &desc, &params));
    }
}

/// Workgroup-memory words of [`point_bounds`]: the bounds, then the point count.
const BOUNDS_SHARED_WORDS: usize = BOUNDS_COUNT_WORD + 1;

/// The bounds of `points[..count]` (xyz of each) as `gi_shared::light_grid` hit bounds in
/// `bounds[..6]`, and the number of finite points in `bounds[BOUNDS_COUNT_WORD]`: each workgroup
/// reduces its points in workgroup memory, then merges its box into the device words with one
/// atomic per word. The host clears `bounds` first (`LIGHT_GRID_BOUNDS_CLEAR`, count 0).
#[spirv(compute(threads(64)))]
pub fn point_bounds(
    #[spirv(global_invocation_id)] id: UVec3,
    #[spirv(local_invocation_index)] local: u32,
    #[spirv(push_constant)] push: &MachineryPush,
    #[spirv(storage_buffer, descriptor_set = 0, binding = 0)] points: &[[f32; 4]],
    #[spirv(storage_buffer, descriptor_set = 0, binding = 1)] bounds: &mut [u32],
    #[spirv(workgroup)] shared: &mut [u32; BOUNDS_SHARED_WORDS],
) {
    let mut shared = WorkgroupWords(shared);
    if local == 0 {
        clear_hit_bounds(&mut shared, 0);
        shared.store(BOUNDS_COUNT_WORD, 0);
    }
    workgroup_memory_barrier_with_group_sync();
    let i = id.x as usize;
    if id.x < push.count && i < points.len() {
        let p = points[i];
        let p = Vec3::new(p[0], p[1], p[2]);
        if p.is_finite() {
            report_hit_bounds(&mut shared, 0, p);
            shared.fetch_add(BOUNDS_COUNT_WORD, 1);
        }
    }
    workgroup_memory_barrier_with_group_sync();
    if local == 0 && bounds.len() >= BOUNDS_SHARED_WORDS {
        let mut bounds = DeviceWords(bounds);
        let mut w = 0;
        while w < 3 {
            bounds.fetch_min(w, shared.load(w));
            bounds.fetch_max(3 + w, shared.load(3 + w));
            w += 1;
        }
        bounds.fetch_add(BOUNDS_COUNT_WORD, shared.load(BOUNDS_COUNT_WORD));
    }
}
