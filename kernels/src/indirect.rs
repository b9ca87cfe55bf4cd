//! Turns a counter word into the arguments of an indirect dispatch (`gi_shared::indirect`).
//!
//! Set 0: the counters (binding 0), the dispatch arguments (binding 1). Push constants:
//! `IndirectPush`.

use gi_shared::indirect::{DispatchIndirect, IndirectPush, dispatch_for_count};
use spirv_std::spirv;

/// `args[args_index] = dispatch_for_count(counters[counter_index], capacity, max_groups)`; one
/// invocation.
#[spirv(compute(threads(1)))]
pub fn dispatch_from_counter(
    #[spirv(push_constant)] push: &IndirectPush,
    #[spirv(storage_buffer, descriptor_set = 0, binding = 0)] counters: &[u32],
    #[spirv(storage_buffer, descriptor_set = 0, binding = 1)] args: &mut [DispatchIndirect],
) {
    let c = push.counter_index as usize;
    let a = push.args_index as usize;
    if c < counters.len() && a < args.len() {
        args[a] = dispatch_for_count(counters[c], push.capacity, push.max_groups);
    }
}
