//! FilterScreenProbes (`gi_shared::screen_probes::probe_filter`): the 7 × 7 separable probe
//! filter, one dispatch along x, then one along y. One workgroup of 8 × 8 lanes per probe tile,
//! lane = cell; a tile without a probe (or the filter switched off) is copied.
//!
//! Set 0: frame (`GiFrameParams`), current records, current mask (mip 0 read), input cells,
//! output cells. Push constant: `u32` axis (0 = horizontal, 1 = vertical).
//! `[probe_grid.x, probe_grid.y, 1]` workgroups of 8 × 8.

use gi_shared::screen_probes::probe_filter::filter_cell;
use gi_shared::screen_probes::{GiFrameParams, PROBE_CELLS, ProbeRecord, StoredCell};
use spirv_std::glam::UVec3;
use spirv_std::spirv;

/// Filters cell `local` of probe tile `workgroup` along `axis`.
#[spirv(compute(threads(8, 8)))]
#[allow(
    clippy::too_many_arguments,
    reason = "an entry point takes one argument per binding"
)]
pub fn filter_screen_probes(
    #[spirv(workgroup_id)] group: UVec3,
    #[spirv(local_invocation_index)] local: u32,
    #[spirv(push_constant)] axis: &u32,
    #[spirv(storage_buffer, descriptor_set = 0, binding = 0)] frame: &GiFrameParams,
    #[spirv(storage_buffer, descriptor_set = 0, binding = 1)] records: &[ProbeRecord],
    #[spirv(storage_buffer, descriptor_set = 0, binding = 2)] mask: &[u32],
    #[spirv(storage_buffer, descriptor_set = 0, binding = 3)] input: &[StoredCell],
    #[spirv(storage_buffer, descriptor_set = 0, binding = 4)] output: &mut [StoredCell],
) {
    if group.x >= frame.probe_grid[0] || group.y >= frame.probe_grid[1] {
        return;
    }
    let tile = group.y * frame.probe_grid[0] + group.x;
    let cell = local % PROBE_CELLS;
    let i = (tile * PROBE_CELLS + cell) as usize;
    if i < output.len() {
        output[i] = StoredCell::pack(filter_cell(frame, records, mask, input, tile, *axis, cell));
    }
}
