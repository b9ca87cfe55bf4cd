//! UpdateLightGrid (`gi_shared::light_grid`): [`update_light_grid`] turns this frame's hit bounds
//! into the grid's parameters and the indirect dispatch of [`build_light_grid`]: one workgroup
//! per cell, whose 64 lanes share the pass over the light clusters (`gi_shared::light_clusters`),
//! then each draws one entry.
//!
//! `update_light_grid`, set 0: hit bounds (`u32`), grid parameters (`LightGridParams`), indirect
//! arguments (`DispatchIndirect`). `build_light_grid`, set 0: grid parameters, entries
//! (`LightGridEntry`), lights (`GpuLight`), clusters (`LightCluster`). Push constants:
//! `CachePassParams`.

#![cfg(not(feature = "ray-query"))]

use gi_shared::hash::pcg_chain;
use gi_shared::indirect::{DispatchIndirect, dispatch_for_count};
use gi_shared::light_clusters::LightCluster;
use gi_shared::light_grid::{
    LIGHT_GRID_RESERVOIRS_PER_CELL, LanePick, LightGridEntry, LightGridParams,
    light_grid_entry_from_lanes, light_grid_lane, light_grid_max_cells, light_grid_params,
    read_hit_bounds,
};
use gi_shared::lights::GpuLight;
use gi_shared::world_cache::{ARGS_LIGHT_GRID, CachePassParams, PASS_LIGHT_GRID};
use spirv_std::arch::workgroup_memory_barrier_with_group_sync;
use spirv_std::glam::{UVec2, UVec3};
use spirv_std::spirv;

/// The grid over this frame's hits and the dispatch of its build; one invocation.
#[spirv(compute(threads(1)))]
pub fn update_light_grid(
    #[spirv(push_constant)] params: &CachePassParams,
    #[spirv(storage_buffer, descriptor_set = 0, binding = 0)] bounds: &mut [u32],
    #[spirv(storage_buffer, descriptor_set = 0, binding = 1)] grid: &mut [LightGridParams],
    #[spirv(storage_buffer, descriptor_set = 0, binding = 2)] args: &mut [DispatchIndirect],
) {
    let view = params.view;
    let (lo, hi) = read_hit_bounds(bounds, 0);
    let g = light_grid_params(
        lo,
        hi,
        view.light_count,
        UVec2::from_array(view.environment_size),
        view.environment_irradiance,
        view.emissive_multiplier,
    );
    if !grid.is_empty() {
        grid[0] = g;
    }
    let a = ARGS_LIGHT_GRID as usize;
    if a < args.len() {
        args[a] = dispatch_for_count(
            g.entry_count(),
            light_grid_max_cells(view.light_count) * LIGHT_GRID_RESERVOIRS_PER_CELL,
            view.max_groups,
        );
    }
}

/// Cell `group.x` of the grid: lane `local` streams over its share of the light clusters, then
/// draws entry `local`.
#[spirv(compute(threads(64)))]
#[allow(
    clippy::too_many_arguments,
    reason = "an entry point takes one argument per binding"
)]
pub fn build_light_grid(
    #[spirv(workgroup_id)] group: UVec3,
    #[spirv(local_invocation_index)] local: u32,
    #[spirv(push_constant)] params: &CachePassParams,
    #[spirv(storage_buffer, descriptor_set = 0, binding = 0)] grid: &[LightGridParams],
    #[spirv(storage_buffer, descriptor_set = 0, binding = 1)] entries: &mut [LightGridEntry],
    #[spirv(storage_buffer, descriptor_set = 0, binding = 2)] lights: &[GpuLight],
    #[spirv(storage_buffer, descriptor_set = 0, binding = 3)] clusters: &[LightCluster],
    #[spirv(workgroup)] lanes: &mut [LanePick; LIGHT_GRID_RESERVOIRS_PER_CELL as usize],
) {
    // The whole workgroup is in or out of the grid together: no lane leaves before the barrier.
    if grid.is_empty() {
        return;
    }
    let g = grid[0];
    let cell = group.x;
    let i = cell * LIGHT_GRID_RESERVOIRS_PER_CELL + local;
    if cell >= g.cell_count() {
        return;
    }
    let seed = pcg_chain([params.view.seed, params.view.frame_index, PASS_LIGHT_GRID]);
    lanes[local as usize] = light_grid_lane(&g, lights, clusters, cell, local, seed);
    workgroup_memory_barrier_with_group_sync();
    if (i as usize) < entries.len() {
        entries[i as usize] =
            light_grid_entry_from_lanes(&g, lights, clusters, cell, local, lanes, seed);
    }
}
