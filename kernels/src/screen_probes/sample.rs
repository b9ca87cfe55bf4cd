//! SampleScreenProbes (`gi_shared::screen_probes::ray_guiding`): one workgroup of 8 × 8 lanes per
//! spawned probe gathers the probe's history hemisphere from the current probes of the 3 × 3
//! tiles around its seed (map, link each cell's sources, then gather, through workgroup memory,
//! neighbour after neighbour), builds the ray-guiding CDF over its 64 cells from their mean and draws one ray per
//! lane; the history it writes is the own tile's probe's cells, the mean where those are empty.
//!
//! Set 0: frame (`GiFrameParams`), camera, G-buffer depth and geometric normal, spawns (packed
//! seeds), current records, current atlas, probe history (written), probe rays
//! (written). `[spawn_grid.x, spawn_grid.y, 1]` workgroups of 8 × 8; spawn index =
//! `workgroup.y × spawn_grid.x + workgroup.x`.

use crate::gbuffer::{DepthImage, HalfImage};
use gi_shared::camera::CameraParams;
use gi_shared::gbuffer::in_image;
use gi_shared::packing::unpack_seed;
use gi_shared::screen_probes::blend::spawned_record;
use gi_shared::screen_probes::hemisphere::{gather_linked, link_mapped, record_frame};
use gi_shared::screen_probes::ray_guiding::{
    HISTORY_NEIGHBOURS, HistorySum, OWN_NEIGHBOUR, blend_history, guiding_active, guiding_cdf,
    guiding_raw_weight, history_neighbour, map_history_source, sample_ray, untraced_ray,
};
use gi_shared::screen_probes::spawn::spawned_seed;
use gi_shared::screen_probes::{
    EMPTY, GiFrameParams, LANES, PROBE_CELLS, ProbeRay, ProbeRecord, StoredCell,
};
use spirv_std::arch::workgroup_memory_barrier_with_group_sync;
use spirv_std::glam::{UVec3, Vec4};
use spirv_std::spirv;

/// Samples the rays of spawned probe `workgroup`; lane `local` is source cell, target cell and
/// ray `local`.
#[spirv(compute(threads(8, 8)))]
#[allow(
    clippy::too_many_arguments,
    reason = "an entry point takes one argument per binding"
)]
pub fn sample_screen_probes(
    #[spirv(workgroup_id)] group: UVec3,
    #[spirv(local_invocation_index)] local: u32,
    #[spirv(storage_buffer, descriptor_set = 0, binding = 0)] frame: &GiFrameParams,
    #[spirv(storage_buffer, descriptor_set = 0, binding = 1)] camera: &CameraParams,
    #[spirv(descriptor_set = 0, binding = 2)] depth: &DepthImage,
    #[spirv(descriptor_set = 0, binding = 3)] geometric_normal: &HalfImage,
    #[spirv(storage_buffer, descriptor_set = 0, binding = 4)] spawns: &[u32],
    #[spirv(storage_buffer, descriptor_set = 0, binding = 5)] records: &[ProbeRecord],
    #[spirv(storage_buffer, descriptor_set = 0, binding = 6)] atlas: &[StoredCell],
    #[spirv(storage_buffer, descriptor_set = 0, binding = 7)] probe_history: &mut [StoredCell],
    #[spirv(storage_buffer, descriptor_set = 0, binding = 8)] probe_rays: &mut [ProbeRay],
    #[spirv(workgroup)] mapped: &mut [u32; LANES],
    #[spirv(workgroup)] moved: &mut [[f32; 4]; LANES],
    #[spirv(workgroup)] heads: &mut [u32; LANES],
    #[spirv(workgroup)] next: &mut [u32; LANES],
    #[spirv(workgroup)] raw: &mut [f32; LANES],
    #[spirv(workgroup)] cdf: &mut [f32; LANES],
) {
    let spawn = group.y * frame.spawn_grid[0] + group.x;
    // Uniform over the workgroup: the whole group leaves before any barrier.
    if spawned_seed(spawns, spawn).is_none() {
        return;
    }
    let lane = local % PROBE_CELLS;
    let l = lane as usize;
    let out = (spawn * PROBE_CELLS + lane) as usize;
    let seed = spawns[spawn as usize];
    let pixel = unpack_seed(seed);
    let record = if in_image(camera, pixel) {
        let d: f32 = depth.read(pixel);
        let gn: Vec4 = geometric_normal.read(pixel);
        spawned_record(camera, seed, d, gn)
    } else {
        ProbeRecord::NONE
    };
    // Uniform too (every lane reads the same seed): a seed that sees no surface traces nothing.
    if !record.is_valid() {
        if out < probe_history.len() {
            probe_history[out] = StoredCell::EMPTY;
        }
        if out < probe_rays.len() {
            probe_rays[out] = untraced_ray(lane);
        }
        return;
    }
    let probe = record_frame(&record);

    // Phase 1: the history hemisphere, one neighbour at a time.
    let mut history = HistorySum::ZERO;
    let mut own = EMPTY;
    let mut k = 0;
    while k < HISTORY_NEIGHBOURS {
        let neighbour = history_neighbour(frame, records, pixel, &probe, k);
        let (target, cell) = map_history_source(frame, atlas, neighbour, &probe, lane);
        mapped[l] = target;
        moved[l] = cell;
        workgroup_memory_barrier_with_group_sync();
        // One lane links each cell's sources, so that every lane walks only its own.
        if lane == 0 {
            link_mapped(mapped, heads, next);
        }
        workgroup_memory_barrier_with_group_sync();
        let gathered = gather_linked(heads, next, moved, lane);
        if k == OWN_NEIGHBOUR {
            own = gathered;
        }
        history.add(gathered);
        workgroup_memory_barrier_with_group_sync();
        k += 1;
    }
    let history = history.cell();
    if out < probe_history.len() {
        probe_history[out] = StoredCell::pack(blend_history(own, history));
    }

    // Phases 2 and 3: raw weights, then the CDF.
    raw[l] = guiding_raw_weight(history, lane);
    workgroup_memory_barrier_with_group_sync();
    cdf[l] = guiding_cdf(raw, lane);
    workgroup_memory_barrier_with_group_sync();

    // Phase 4: the ray.
    let guided = guiding_active(frame, cdf);
    let ray = sample_ray(frame, &probe, spawn, lane, cdf, guided);
    if out < probe_rays.len() {
        probe_rays[out] = ray;
    }
}
