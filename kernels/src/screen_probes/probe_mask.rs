//! FilterProbeMask (`gi_shared::screen_probes::probe_mask`): one dispatch per mip `k ≥ 1` of the
//! probe mask, one invocation per texel of mip `k`: the first valid seed of its 2 × 2 children in
//! mip `k − 1`.
//!
//! Set 0: frame (`GiFrameParams`), mask (the whole chain, mips one after another). Push
//! constant: `u32` mip `k`. `[ceil(w_k / 8), ceil(h_k / 8), 1]` workgroups of 8 × 8, where
//! `w_k × h_k = mask_mip_size(probe_grid, k)`.

use gi_shared::screen_probes::GiFrameParams;
use gi_shared::screen_probes::probe_mask::{filter_mask_texel, mask_texel_index};
use spirv_std::glam::{UVec2, UVec3};
use spirv_std::spirv;

/// Writes texel `id.xy` of mip `mip`.
#[spirv(compute(threads(8, 8)))]
pub fn filter_probe_mask(
    #[spirv(global_invocation_id)] id: UVec3,
    #[spirv(push_constant)] mip: &u32,
    #[spirv(storage_buffer, descriptor_set = 0, binding = 0)] frame: &GiFrameParams,
    #[spirv(storage_buffer, descriptor_set = 0, binding = 1)] mask: &mut [u32],
) {
    let mip = *mip;
    let texel = UVec2::new(id.x, id.y);
    if mip == 0 {
        return;
    }
    if let Some(i) = mask_texel_index(frame.probe_grid, mip, texel)
        && i < mask.len()
    {
        mask[i] = filter_mask_texel(mask, frame.probe_grid, mip, texel);
    }
}
