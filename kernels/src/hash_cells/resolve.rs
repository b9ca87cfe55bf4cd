//! ResolveRadianceCache: one invocation per query (dispatched from the query counter) adds the
//! adaptive-mip filtered radiance of its cell to its ray, unless temporal feedback lit it or it
//! bypasses the cell (`gi_shared::world_cache::cache_radiance`).
//!
//! Set 0: cache-view counters, queries, values, pixels.

use gi_shared::hash_cells::layout::HashCellValue;
use gi_shared::math::min_u32;
use gi_shared::world_cache::{CachePassParams, CacheQuery, QUERY_COUNT, RayRecord, cache_radiance};
use spirv_std::glam::{UVec3, Vec3};
use spirv_std::spirv;

/// Resolves query `id.x`.
#[spirv(compute(threads(64)))]
pub fn resolve_radiance_cache(
    #[spirv(global_invocation_id)] id: UVec3,
    #[spirv(push_constant)] params: &CachePassParams,
    #[spirv(storage_buffer, descriptor_set = 0, binding = 0)] counters: &[u32],
    #[spirv(storage_buffer, descriptor_set = 0, binding = 1)] queries: &[CacheQuery],
    #[spirv(storage_buffer, descriptor_set = 0, binding = 2)] values: &[HashCellValue],
    #[spirv(storage_buffer, descriptor_set = 0, binding = 3)] pixels: &mut [RayRecord],
) {
    let count = min_u32(counters[QUERY_COUNT], queries.len() as u32);
    if id.x >= count {
        return;
    }
    let query = queries[id.x as usize];
    let radiance = cache_radiance(values, &query, params.grid.read_min_samples());
    let r = query.ray_index as usize;
    if radiance.max_element() > 0.0 && r < pixels.len() {
        let mut pixel = pixels[r];
        pixel.ray_radiance = (Vec3::from_array(pixel.ray_radiance) + radiance).to_array();
        pixels[r] = pixel;
    }
}
