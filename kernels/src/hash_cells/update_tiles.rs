//! UpdateRadianceCache: one invocation per tile touched this frame (dispatched from the update
//! list's counter) blends the frame's accumulators into the tile's mip-0 cells (sample cap 16),
//! rebuilds its 4 × 4, 2 × 2 and 1 × 1 mips and clears the accumulators
//! (`gi_shared::hash_cells::passes::update_pass`); with multi-bounce, the tile's bounce copy too.
//!
//! Set 0: values, accumulators, lists, bounce copy (one value where multi-bounce is off).

use crate::atomics::DeviceWords;
use gi_shared::hash_cells::layout::HashCellValue;
use gi_shared::hash_cells::passes::update_pass;
use gi_shared::world_cache::CachePassParams;
use spirv_std::glam::UVec3;
use spirv_std::spirv;

/// Updates entry `id.x` of the update list.
#[spirv(compute(threads(64)))]
pub fn update_radiance_cache(
    #[spirv(global_invocation_id)] id: UVec3,
    #[spirv(push_constant)] params: &CachePassParams,
    #[spirv(storage_buffer, descriptor_set = 0, binding = 0)] values: &mut [HashCellValue],
    #[spirv(storage_buffer, descriptor_set = 0, binding = 1)] accumulators: &mut [u32],
    #[spirv(storage_buffer, descriptor_set = 0, binding = 2)] lists: &mut [u32],
    #[spirv(storage_buffer, descriptor_set = 0, binding = 3)] bounce_values: &mut [HashCellValue],
) {
    update_pass(
        values,
        bounce_values,
        &mut DeviceWords(accumulators),
        &DeviceWords(lists),
        &params.grid,
        id.x,
    );
}
