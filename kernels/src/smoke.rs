//! The smoke kernel: the smallest end-to-end proof that kernels run and agree with the CPU.

use gi_shared::hash::pcg;
use spirv_std::glam::UVec3;
use spirv_std::spirv;

/// `out[i] = pcg(i)`.
#[spirv(compute(threads(64)))]
pub fn smoke(
    #[spirv(global_invocation_id)] id: UVec3,
    #[spirv(storage_buffer, descriptor_set = 0, binding = 0)] out: &mut [u32],
) {
    let i = id.x as usize;
    if i < out.len() {
        out[i] = pcg(id.x);
    }
}
