//! Counts the non-finite `f32` words of a buffer (`gi_shared::finite_check`): a grid-stride loop
//! over the words, a workgroup-memory reduction, and one device atomic per workgroup that found
//! any.
//!
//! Set 0: the words to check (binding 0), the counts (binding 1). Push constants:
//! `FiniteCheckPush`.

use crate::atomics::{DeviceWords, WorkgroupWords};
use gi_shared::atomics::AtomicWords;
use gi_shared::finite_check::{FINITE_CHECK_GROUP, FiniteCheckPush, counts_as_non_finite};
use gi_shared::math::min_u32;
use spirv_std::arch::workgroup_memory_barrier_with_group_sync;
use spirv_std::glam::UVec3;
use spirv_std::spirv;

/// Adds the number of non-finite floats among the first `push.word_count` words of `words` to
/// `counts[push.slot]`.
#[spirv(compute(threads(64)))]
pub fn count_non_finite(
    #[spirv(global_invocation_id)] id: UVec3,
    #[spirv(num_workgroups)] groups: UVec3,
    #[spirv(local_invocation_index)] local: u32,
    #[spirv(push_constant)] push: &FiniteCheckPush,
    #[spirv(storage_buffer, descriptor_set = 0, binding = 0)] words: &[u32],
    #[spirv(storage_buffer, descriptor_set = 0, binding = 1)] counts: &mut [u32],
    #[spirv(workgroup)] shared: &mut [u32; 1],
) {
    let mut shared = WorkgroupWords(shared);
    if local == 0 {
        shared.store(0, 0);
    }
    workgroup_memory_barrier_with_group_sync();
    let n = min_u32(push.word_count, words.len() as u32);
    let stride = groups.x * FINITE_CHECK_GROUP;
    let mut found = 0;
    let mut i = id.x;
    while i < n {
        if counts_as_non_finite(push, i, words[i as usize]) {
            found += 1;
        }
        i += stride;
    }
    if found > 0 {
        shared.fetch_add(0, found);
    }
    workgroup_memory_barrier_with_group_sync();
    if local == 0 {
        let total = shared.load(0);
        if total > 0 && (push.slot as usize) < counts.len() {
            DeviceWords(counts).fetch_add(push.slot as usize, total);
        }
    }
}
