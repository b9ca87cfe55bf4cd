//! FilterBlurMask (`gi_shared::gi_denoiser::blur_mask`): the dilated, cost-budgeted blur radius
//! of each pixel.
//!
//! Set 0: 0 frame (`GiFrameParams`), 1 blur mask (`f32`, ReprojectGI's), 2 blur radius (`f32`,
//! written), 3 GI counters (`u32`, `BLUR_TAPS`). Workgroups of 8 × 8 pixels (the budget is per
//! workgroup), dispatched `[ceil(W / 8), ceil(H / 8), 1]`.

use crate::atomics::{DeviceWords, WorkgroupWords};
use gi_shared::gi_denoiser::blur_mask::{
    add_blur_cost, begin_blur_cost, count_blur_taps, finish_blur_radius,
};
use gi_shared::screen_probes::GiFrameParams;
use spirv_std::arch::workgroup_memory_barrier_with_group_sync;
use spirv_std::glam::{UVec2, UVec3};
use spirv_std::spirv;

/// The blur radius of pixel `id`. Every lane reaches both barriers (pixels outside the image
/// add no cost and write nothing).
#[spirv(compute(threads(8, 8)))]
#[allow(
    clippy::too_many_arguments,
    reason = "an entry point takes one argument per binding and built-in"
)]
pub fn filter_blur_mask(
    #[spirv(global_invocation_id)] id: UVec3,
    #[spirv(local_invocation_index)] lane: u32,
    #[spirv(storage_buffer, descriptor_set = 0, binding = 0)] frame: &GiFrameParams,
    #[spirv(storage_buffer, descriptor_set = 0, binding = 1)] mask: &[f32],
    #[spirv(storage_buffer, descriptor_set = 0, binding = 2)] radius: &mut [f32],
    #[spirv(storage_buffer, descriptor_set = 0, binding = 3)] counters: &mut [u32],
    #[spirv(workgroup)] shared: &mut [u32; 1],
) {
    let pixel = UVec2::new(id.x, id.y);
    let mut shared = WorkgroupWords(shared);
    begin_blur_cost(&mut shared, lane);
    workgroup_memory_barrier_with_group_sync();
    let r = add_blur_cost(frame, mask, pixel, &mut shared);
    workgroup_memory_barrier_with_group_sync();
    let out = finish_blur_radius(r, &shared);
    if pixel.x < frame.image_size[0] && pixel.y < frame.image_size[1] {
        let i = (pixel.y * frame.image_size[0] + pixel.x) as usize;
        if i < radius.len() {
            radius[i] = out;
        }
    }
    count_blur_taps(&shared, &mut DeviceWords(counters), lane);
}
