//! World-space ReSTIR's passes after GenerateReservoirs (which inserts each shadow ray's hit into
//! this frame's reservoir grid): CompactReservoirs lists the shadow rays slot after slot (after a
//! prefix scan of the slot counts, in the order of GenerateReservoirs's atomics), then orders each
//! slot's run by ray (`order_reservoirs`), and ResampleReservoirs merges each shadow ray's reservoir with
//! the previous frame's neighbours and rewrites its light sample
//! (`gi_shared::world_restir::resample_reservoir`). ClearReservoirs is a buffer fill on the host.
//!
//! `compact_reservoirs`, set 0: cache counters, places (`[u32; 2]` per shadow ray), scanned slot
//! counts (`u32`), queries, shadow rays, and the scatter: each shadow ray's sort key (`[u32; 2]`),
//! in the order of the atomics. `order_reservoirs`, set 0: cache counters, places, scanned slot
//! counts, the scatter, ordered entries (`u32`, shadow-ray indices).
//! `resample_reservoirs`, set 0: cache-view counters, queries,
//! shadow rays, this frame's reservoirs (`PackedReservoir`), the previous frame's keys, scanned
//! counts, entries, reservoirs and hits (`ReservoirHit`), grid parameters (`LightGridParams`),
//! lights, the environment's texels and distribution. Push constants: `CachePassParams`.

#![cfg(not(feature = "ray-query"))]

use gi_shared::light_grid::LightGridParams;
use gi_shared::lights::{GpuLight, LightSources};
use gi_shared::math::min_u32;
use gi_shared::secondary_hits::shadow_ray;
use gi_shared::world_cache::{
    CachePassParams, CacheQuery, PASS_RESTIR, QUERY_BYPASS, SHADOW_RAY_COUNT, ShadowRay,
    pass_random,
};
use gi_shared::world_restir::{
    PackedReservoir, PreviousReservoirGrid, ReservoirHit, ordered_reservoir_entry,
    resample_reservoir, reservoir_entry, reservoir_order_key,
};
use spirv_std::glam::UVec3;
use spirv_std::spirv;

/// Lists shadow ray `id.x`'s key in its slot's run of the compacted list.
#[spirv(compute(threads(64)))]
pub fn compact_reservoirs(
    #[spirv(global_invocation_id)] id: UVec3,
    #[spirv(storage_buffer, descriptor_set = 0, binding = 0)] counters: &[u32],
    #[spirv(storage_buffer, descriptor_set = 0, binding = 1)] places: &[[u32; 2]],
    #[spirv(storage_buffer, descriptor_set = 0, binding = 2)] offsets: &[u32],
    #[spirv(storage_buffer, descriptor_set = 0, binding = 3)] queries: &[CacheQuery],
    #[spirv(storage_buffer, descriptor_set = 0, binding = 4)] shadow_rays: &[ShadowRay],
    #[spirv(storage_buffer, descriptor_set = 0, binding = 5)] unordered: &mut [[u32; 2]],
) {
    let n = min_u32(counters[SHADOW_RAY_COUNT], places.len() as u32);
    if id.x >= n {
        return;
    }
    if let Some(e) = reservoir_entry(offsets, places[id.x as usize])
        && (e as usize) < unordered.len()
    {
        unordered[e as usize] = reservoir_order_key(queries, shadow_rays, id.x);
    }
}

/// Moves shadow ray `id.x` to its place in its slot's run ordered by ray.
#[spirv(compute(threads(64)))]
pub fn order_reservoirs(
    #[spirv(global_invocation_id)] id: UVec3,
    #[spirv(storage_buffer, descriptor_set = 0, binding = 0)] counters: &[u32],
    #[spirv(storage_buffer, descriptor_set = 0, binding = 1)] places: &[[u32; 2]],
    #[spirv(storage_buffer, descriptor_set = 0, binding = 2)] offsets: &[u32],
    #[spirv(storage_buffer, descriptor_set = 0, binding = 3)] unordered: &[[u32; 2]],
    #[spirv(storage_buffer, descriptor_set = 0, binding = 4)] entries: &mut [u32],
) {
    let n = min_u32(counters[SHADOW_RAY_COUNT], places.len() as u32);
    if id.x >= n {
        return;
    }
    if let Some(e) = ordered_reservoir_entry(offsets, unordered, places[id.x as usize])
        && (e as usize) < entries.len()
    {
        entries[e as usize] = id.x;
    }
}

/// Resamples shadow ray `id.x`'s reservoir with the previous frame's and rewrites its sample.
#[spirv(compute(threads(64)))]
#[allow(
    clippy::too_many_arguments,
    reason = "an entry point takes one argument per binding"
)]
pub fn resample_reservoirs(
    #[spirv(global_invocation_id)] id: UVec3,
    #[spirv(push_constant)] params: &CachePassParams,
    #[spirv(storage_buffer, descriptor_set = 0, binding = 0)] counters: &[u32],
    #[spirv(storage_buffer, descriptor_set = 0, binding = 1)] queries: &[CacheQuery],
    #[spirv(storage_buffer, descriptor_set = 0, binding = 2)] shadow_rays: &mut [ShadowRay],
    #[spirv(storage_buffer, descriptor_set = 0, binding = 3)] reservoirs: &mut [PackedReservoir],
    #[spirv(storage_buffer, descriptor_set = 0, binding = 4)] previous_keys: &[u32],
    #[spirv(storage_buffer, descriptor_set = 0, binding = 5)] previous_offsets: &[u32],
    #[spirv(storage_buffer, descriptor_set = 0, binding = 6)] previous_entries: &[u32],
    #[spirv(storage_buffer, descriptor_set = 0, binding = 7)]
    previous_reservoirs: &[PackedReservoir],
    #[spirv(storage_buffer, descriptor_set = 0, binding = 8)] previous_hits: &[ReservoirHit],
    #[spirv(storage_buffer, descriptor_set = 0, binding = 9)] grid: &[LightGridParams],
    #[spirv(storage_buffer, descriptor_set = 0, binding = 10)] lights: &[GpuLight],
    #[spirv(storage_buffer, descriptor_set = 0, binding = 11)] environment: &[[f32; 4]],
    #[spirv(storage_buffer, descriptor_set = 0, binding = 12)] environment_cdf: &[f32],
) {
    let n = min_u32(counters[SHADOW_RAY_COUNT], shadow_rays.len() as u32);
    let i = id.x as usize;
    if id.x >= n || i >= reservoirs.len() || grid.is_empty() {
        return;
    }
    let old = shadow_rays[i];
    if old.query as usize >= queries.len() {
        return;
    }
    let query = queries[old.query as usize];
    let view = params.view;
    let current = reservoirs[i];
    let mut rng = pass_random(view.seed, query.ray_index, PASS_RESTIR, view.frame_index);
    let lighting = LightSources {
        lights,
        environment,
        environment_cdf,
    };
    let sample = resample_reservoir(
        &grid[0],
        lighting,
        &view,
        &query,
        &current,
        PreviousReservoirGrid {
            keys: previous_keys,
            offsets: previous_offsets,
            entries: previous_entries,
            reservoirs: previous_reservoirs,
            hits: previous_hits,
        },
        &mut rng,
    );
    reservoirs[i] = PackedReservoir::pack(&sample.reservoir, sample.params);
    shadow_rays[i] = shadow_ray(&sample, old.query, query.flags & QUERY_BYPASS != 0);
}
