//! Runs `gi_shared::difftest::evaluate` on the GPU so tests can compare it with the CPU.

use gi_shared::difftest::{DiffCase, DiffOutput, DiffPush, evaluate};
use spirv_std::glam::UVec3;
use spirv_std::spirv;

/// `out[i] = evaluate(push.function, cases[i])`.
#[spirv(compute(threads(64)))]
pub fn difftest(
    #[spirv(global_invocation_id)] id: UVec3,
    #[spirv(push_constant)] push: &DiffPush,
    #[spirv(storage_buffer, descriptor_set = 0, binding = 0)] cases: &[DiffCase],
    #[spirv(storage_buffer, descriptor_set = 0, binding = 1)] out: &mut [DiffOutput],
) {
    let i = id.x as usize;
    if id.x < push.count && i < cases.len() && i < out.len() {
        out[i] = DiffOutput {
            words: evaluate(push.function, cases[i].input),
        };
    }
}
