//! PopulateRadianceCache: one invocation per shadow ray traces it and accumulates what it carries
//! into the query's cell: its contribution when the light sample is visible, else zero (one sample
//! either way, so the cell's mean is not taken over lit samples alone). A bypassing ray also adds
//! it to its own pixel's ray (light-leak fix 2). An occluded sample's stored ReSTIR reservoir is
//! invalidated (its `W` zeroed).
//!
//! Set 0: cache-view counters, shadow rays, queries, accumulators, pixels, lists (for the count of
//! dropped samples), this frame's ReSTIR reservoirs. Set 1: the scene's geometry; set 2 as
//! `traced_kernel!` binds it.

use crate::atomics::DeviceWords;
use gi_shared::cache_view::{
    CacheQuery, CacheViewPixel, SHADOW_BYPASS, SHADOW_RAY_COUNT, ShadowRay, accumulate_into_cell,
    shadow_ray_radiance,
};
use gi_shared::hash_cells::lists::{DROPPED_SAMPLES, count};
use gi_shared::math::min_u32;
use gi_shared::world_restir::PackedReservoir;
use spirv_std::glam::{UVec3, Vec3};
use spirv_std::spirv;

traced_kernel! {
    /// Traces shadow ray `id.x` and accumulates its light.
    #[spirv(compute(threads(64)))]
    pub fn populate_radiance_cache(
        scene, texture_images;
        #[spirv(global_invocation_id)] id: UVec3,
        #[spirv(storage_buffer, descriptor_set = 0, binding = 0)] counters: &[u32],
        #[spirv(storage_buffer, descriptor_set = 0, binding = 1)] shadow_rays: &[ShadowRay],
        #[spirv(storage_buffer, descriptor_set = 0, binding = 2)] queries: &[CacheQuery],
        #[spirv(storage_buffer, descriptor_set = 0, binding = 3)] accumulators: &mut [u32],
        #[spirv(storage_buffer, descriptor_set = 0, binding = 4)] pixels: &mut [CacheViewPixel],
        #[spirv(storage_buffer, descriptor_set = 0, binding = 5)] lists: &mut [u32],
        #[spirv(storage_buffer, descriptor_set = 0, binding = 6)] reservoirs: &mut [PackedReservoir],
    ) {
        let n = min_u32(counters[SHADOW_RAY_COUNT], shadow_rays.len() as u32);
        if id.x >= n {
            return;
        }
        let i = id.x as usize;
        let shadow = shadow_rays[i];
        if shadow.query as usize >= queries.len() {
            return;
        }
        let occluded = shadow.t_max >= 0.0 && scene.any_hit(&shadow.ray(), texture_images);
        if occluded && i < reservoirs.len() {
            // "Invalidate the stored reservoir": its sample is not seen from here.
            let mut r = reservoirs[i];
            r.ucw = 0.0;
            reservoirs[i] = r;
        }
        let query = queries[shadow.query as usize];
        let radiance = shadow_ray_radiance(&shadow, occluded);
        if !accumulate_into_cell(&mut DeviceWords(accumulators), &query, radiance) {
            count(&mut DeviceWords(lists), DROPPED_SAMPLES);
            return;
        }
        let r = query.ray_index as usize;
        if shadow.flags & SHADOW_BYPASS != 0 && r < pixels.len() && radiance.max_element() > 0.0 {
            let mut pixel = pixels[r];
            pixel.ray_radiance = (Vec3::from_array(pixel.ray_radiance) + radiance).to_array();
            pixels[r] = pixel;
        }
    }
}
