//! One level of the GPU exclusive prefix sum (`gi_shared::scan`): [`scan_blocks`] scans blocks of
//! `SCAN_BLOCK` words and writes each block's sum, [`add_block_offsets`] adds the scanned block
//! sums back.
//!
//! Set 0: the data words (binding 0), the block sums (binding 1; the same buffer as the data at
//! levels above the first) and, for `scan_blocks`, the word receiving the total (binding 2).
//! Push constants: `ScanPush`.

use gi_shared::abi::WORKGROUP_SIZE;
use gi_shared::scan::{NO_WORD, SCAN_BLOCK, ScanPush};
use spirv_std::arch::{
    subgroup_exclusive_i_add, subgroup_i_add, workgroup_memory_barrier_with_group_sync,
};
use spirv_std::glam::UVec3;
use spirv_std::spirv;

/// Subgroups per workgroup at most (subgroups of one invocation).
const MAX_SUBGROUPS: usize = WORKGROUP_SIZE as usize;

/// Replaces each block of `SCAN_BLOCK` words by its exclusive prefix sums and writes the block's
/// sum to `sums[sums_offset + block]` and, when asked, to `total[total_index]`.
///
/// Invocations take the block's words in subgroup order (subgroup `s`, lane `l` takes word
/// `s * subgroup_size + l`), so subgroup scans add up whatever the subgroups' layout.
#[spirv(compute(threads(64)))]
#[allow(
    clippy::too_many_arguments,
    reason = "an entry point takes one argument per binding and built-in"
)]
pub fn scan_blocks(
    #[spirv(workgroup_id)] group: UVec3,
    #[spirv(subgroup_id)] subgroup: u32,
    #[spirv(subgroup_local_invocation_id)] lane: u32,
    #[spirv(subgroup_size)] subgroup_size: u32,
    #[spirv(num_subgroups)] subgroups: u32,
    #[spirv(push_constant)] push: &ScanPush,
    #[spirv(storage_buffer, descriptor_set = 0, binding = 0)] data: &mut [u32],
    #[spirv(storage_buffer, descriptor_set = 0, binding = 1)] sums: &mut [u32],
    #[spirv(storage_buffer, descriptor_set = 0, binding = 2)] total: &mut [u32],
    #[spirv(workgroup)] subgroup_sums: &mut [u32; MAX_SUBGROUPS],
) {
    let local = subgroup * subgroup_size + lane;
    let element = group.x * SCAN_BLOCK + local;
    let index = push.data_offset.wrapping_add(element) as usize;
    let inside = element < push.count && index < data.len();
    let value = if inside { data[index] } else { 0 };
    let before_in_subgroup = subgroup_exclusive_i_add(value);
    let subgroup_sum = subgroup_i_add(value);
    if lane == 0 && (subgroup as usize) < MAX_SUBGROUPS {
        subgroup_sums[subgroup as usize] = subgroup_sum;
    }
    workgroup_memory_barrier_with_group_sync();
    let mut before = 0u32;
    let mut block = 0u32;
    let mut s = 0;
    while s < subgroups as usize && s < MAX_SUBGROUPS {
        let t = subgroup_sums[s];
        if s < subgroup as usize {
            before = before.wrapping_add(t);
        }
        block = block.wrapping_add(t);
        s += 1;
    }
    if inside {
        data[index] = before.wrapping_add(before_in_subgroup);
    }
    if local == 0 {
        if push.sums_offset != NO_WORD {
            let i = push.sums_offset.wrapping_add(group.x) as usize;
            if i < sums.len() {
                sums[i] = block;
            }
        }
        if push.total_index != NO_WORD && (push.total_index as usize) < total.len() {
            total[push.total_index as usize] = block;
        }
    }
}

/// Adds `sums[sums_offset + block]` (the exclusive sum of the blocks before) to every word of
/// each block.
#[spirv(compute(threads(64)))]
pub fn add_block_offsets(
    #[spirv(global_invocation_id)] id: UVec3,
    #[spirv(workgroup_id)] group: UVec3,
    #[spirv(push_constant)] push: &ScanPush,
    #[spirv(storage_buffer, descriptor_set = 0, binding = 0)] data: &mut [u32],
    #[spirv(storage_buffer, descriptor_set = 0, binding = 1)] sums: &[u32],
) {
    let index = push.data_offset.wrapping_add(id.x) as usize;
    let s = push.sums_offset.wrapping_add(group.x) as usize;
    if id.x < push.count && index < data.len() && s < sums.len() {
        data[index] = data[index].wrapping_add(sums[s]);
    }
}
