//! ProjectScreenProbes (`gi_shared::screen_probes::sh_projection`): one workgroup of 8 × 8 lanes
//! per probe tile projects the probe's 64 cells onto order-2 SH: each lane writes its cell's 9
//! terms into workgroup memory, then lanes 0..9 each sum one coefficient over the cells in order.
//!
//! Set 0: frame (`GiFrameParams`), current records, cells (the filtered cells, or the atlas when
//! the filter is off), SH (written: `probe × 9 + i`, `[r, g, b, 0]`).
//! `[probe_grid.x, probe_grid.y, 1]` workgroups of 8 × 8.

use gi_shared::screen_probes::hemisphere::record_frame;
use gi_shared::screen_probes::sh_projection::{
    SH_TERMS, cell_sh_terms, sh_term_index, sum_sh_coefficient,
};
use gi_shared::screen_probes::{EMPTY, GiFrameParams, PROBE_CELLS, ProbeRecord, StoredCell};
use gi_shared::sh::SH_COEFFICIENT_COUNT;
use spirv_std::arch::workgroup_memory_barrier_with_group_sync;
use spirv_std::glam::UVec3;
use spirv_std::spirv;

/// Projects probe tile `workgroup`; lane `local` is cell `local`, then coefficient `local`.
#[spirv(compute(threads(8, 8)))]
pub fn project_screen_probes(
    #[spirv(workgroup_id)] group: UVec3,
    #[spirv(local_invocation_index)] local: u32,
    #[spirv(storage_buffer, descriptor_set = 0, binding = 0)] frame: &GiFrameParams,
    #[spirv(storage_buffer, descriptor_set = 0, binding = 1)] records: &[ProbeRecord],
    #[spirv(storage_buffer, descriptor_set = 0, binding = 2)] cells: &[StoredCell],
    #[spirv(storage_buffer, descriptor_set = 0, binding = 3)] sh: &mut [[f32; 4]],
    #[spirv(workgroup)] terms: &mut [[f32; 4]; SH_TERMS],
) {
    // Uniform over the workgroup: the whole group leaves before the barrier.
    if group.x >= frame.probe_grid[0] || group.y >= frame.probe_grid[1] {
        return;
    }
    let tile = group.y * frame.probe_grid[0] + group.x;
    let lane = local % PROBE_CELLS;
    let out = (tile * SH_COEFFICIENT_COUNT as u32 + lane) as usize;
    let record = if (tile as usize) < records.len() {
        records[tile as usize]
    } else {
        ProbeRecord::NONE
    };
    if !record.is_valid() {
        if (lane as usize) < SH_COEFFICIENT_COUNT && out < sh.len() {
            sh[out] = [0.0; 4];
        }
        return;
    }
    let i = (tile * PROBE_CELLS + lane) as usize;
    let cell = if i < cells.len() {
        cells[i].unpack()
    } else {
        EMPTY
    };
    let t = cell_sh_terms(&record_frame(&record), lane, cell);
    let mut k = 0;
    while k < SH_COEFFICIENT_COUNT {
        terms[sh_term_index(k as u32, lane)] = t[k];
        k += 1;
    }
    workgroup_memory_barrier_with_group_sync();
    if (lane as usize) < SH_COEFFICIENT_COUNT && out < sh.len() {
        sh[out] = sum_sh_coefficient(terms, lane);
    }
}
