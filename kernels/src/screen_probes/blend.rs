//! BlendScreenProbes (`gi_shared::screen_probes::blend`): one workgroup of 8 × 8 lanes per
//! spawned probe bins its 64 ray results into its cells (through workgroup memory), blends them
//! with the history hemisphere (hysteresis adaptive to the probe's change), backs up cells left
//! empty and
//! writes the probe tile's cells, record and mask texel.
//!
//! Set 0: frame (`GiFrameParams`), camera, G-buffer depth and geometric normal, spawns (packed
//! seeds), probe rays, ray records (`RayRecord`, the rays' radiance), probe
//! history, current records (written), current mask (mip 0 written), current atlas (written).
//! `[spawn_grid.x, spawn_grid.y, 1]` workgroups of 8 × 8; spawn index =
//! `workgroup.y × spawn_grid.x + workgroup.x`.

use crate::gbuffer::{DepthImage, HalfImage};
use gi_shared::camera::CameraParams;
use gi_shared::gbuffer::in_image;
use gi_shared::packing::unpack_seed;
use gi_shared::screen_probes::LANES;
use gi_shared::screen_probes::blend::{
    blend_cell, cell_estimate, gather_rays, ray_source, spawned_record,
};
use gi_shared::screen_probes::hemisphere::{UNMAPPED, link_mapped};
use gi_shared::screen_probes::hysteresis::{cell_change, other_cells};
use gi_shared::screen_probes::radiance_backup::{backed_up_cell, probe_backup};
use gi_shared::screen_probes::spawn::spawned_seed;
use gi_shared::screen_probes::{
    EMPTY, GiFrameParams, PROBE_CELLS, ProbeRay, ProbeRecord, StoredCell,
};
use gi_shared::world_cache::RayRecord;
use spirv_std::arch::workgroup_memory_barrier_with_group_sync;
use spirv_std::glam::{UVec3, Vec4};
use spirv_std::spirv;

/// Blends spawned probe `workgroup`; lane `local` is ray `local` in phase 1 and cell `local`
/// after.
#[spirv(compute(threads(8, 8)))]
#[allow(
    clippy::too_many_arguments,
    reason = "an entry point takes one argument per binding"
)]
pub fn blend_screen_probes(
    #[spirv(workgroup_id)] group: UVec3,
    #[spirv(local_invocation_index)] local: u32,
    #[spirv(storage_buffer, descriptor_set = 0, binding = 0)] frame: &GiFrameParams,
    #[spirv(storage_buffer, descriptor_set = 0, binding = 1)] camera: &CameraParams,
    #[spirv(descriptor_set = 0, binding = 2)] depth: &DepthImage,
    #[spirv(descriptor_set = 0, binding = 3)] geometric_normal: &HalfImage,
    #[spirv(storage_buffer, descriptor_set = 0, binding = 4)] spawns: &[u32],
    #[spirv(storage_buffer, descriptor_set = 0, binding = 5)] probe_rays: &[ProbeRay],
    #[spirv(storage_buffer, descriptor_set = 0, binding = 6)] ray_records: &[RayRecord],
    #[spirv(storage_buffer, descriptor_set = 0, binding = 7)] probe_history: &[StoredCell],
    #[spirv(storage_buffer, descriptor_set = 0, binding = 8)] records: &mut [ProbeRecord],
    #[spirv(storage_buffer, descriptor_set = 0, binding = 9)] mask: &mut [u32],
    #[spirv(storage_buffer, descriptor_set = 0, binding = 10)] atlas: &mut [StoredCell],
    #[spirv(workgroup)] mapped: &mut [u32; LANES],
    #[spirv(workgroup)] heads: &mut [u32; LANES],
    #[spirv(workgroup)] next: &mut [u32; LANES],
    #[spirv(workgroup)] cells: &mut [[f32; 4]; LANES],
    #[spirv(workgroup)] blended: &mut [[f32; 4]; LANES],
    #[spirv(workgroup)] changes: &mut [[f32; 2]; LANES],
    #[spirv(workgroup)] probabilities: &mut [f32; LANES],
    #[spirv(workgroup)] backup: &mut [[f32; 4]; 1],
) {
    let spawn = group.y * frame.spawn_grid[0] + group.x;
    // Uniform over the workgroup: the whole group leaves before any barrier.
    if spawned_seed(spawns, spawn).is_none() {
        return;
    }
    let lane = local % PROBE_CELLS;
    let l = lane as usize;
    let seed = spawns[spawn as usize];
    let pixel = unpack_seed(seed);
    let record = if in_image(camera, pixel) {
        let d: f32 = depth.read(pixel);
        let gn: Vec4 = geometric_normal.read(pixel);
        spawned_record(camera, seed, d, gn)
    } else {
        ProbeRecord::NONE
    };
    // Uniform too: a seed that sees no surface traced nothing and leaves its tile as it is.
    if !record.is_valid() {
        return;
    }
    let tile = frame.probe_tile_of(pixel);
    let ray_index = (spawn * PROBE_CELLS + lane) as usize;

    // Phase 1, lane = ray.
    let (target, cell, probability) =
        if ray_index < probe_rays.len() && ray_index < ray_records.len() {
            let ray = probe_rays[ray_index];
            let (target, cell) = ray_source(ray, ray_records[ray_index]);
            (target, cell, ray.cell_probability)
        } else {
            (UNMAPPED, EMPTY, 0.0)
        };
    mapped[l] = target;
    cells[l] = cell;
    probabilities[l] = probability;
    workgroup_memory_barrier_with_group_sync();
    // One lane links each cell's rays, so that every lane walks only its own.
    if lane == 0 {
        link_mapped(mapped, heads, next);
    }
    workgroup_memory_barrier_with_group_sync();

    // Phase 2, lane = cell: the rays' mean and its change from the history.
    let history = if ray_index < probe_history.len() {
        probe_history[ray_index].unpack()
    } else {
        EMPTY
    };
    let (mean, rays, probability) = gather_rays(heads, next, cells, probabilities, lane);
    changes[l] = cell_change(mean, history);
    let new = cell_estimate(probabilities[0] > 0.0, mean, rays, probability, history);
    workgroup_memory_barrier_with_group_sync();

    // Phase 3, lane = cell: the mean against the history.
    blended[l] = blend_cell(frame, new, history, other_cells(changes, lane));
    workgroup_memory_barrier_with_group_sync();

    // Phase 4: one lane takes the probe's backup, then the probe tile's cell, record and mask
    // texel.
    if lane == 0 {
        backup[0] = probe_backup(frame, blended);
    }
    workgroup_memory_barrier_with_group_sync();
    let out = backed_up_cell(frame, blended[l], backup[0]);
    let i = (tile * PROBE_CELLS + lane) as usize;
    if i < atlas.len() {
        atlas[i] = StoredCell::pack_running(out, frame.frame_index);
    }
    if lane == 0 {
        let t = tile as usize;
        if t < records.len() {
            records[t] = record;
        }
        // Mip 0 comes first in the mask buffer.
        if t < mask.len() {
            mask[t] = record.seed;
        }
    }
}
