//! PopulateRadianceCache: one invocation per shadow ray traces it and accumulates what it carries
//! into the query's cell: its contribution when the light sample is visible, else zero (one sample
//! either way, so the cell's mean is not taken over lit samples alone). With multi-bounce
//! (`gi_shared::multi_bounce`) the query's bounce ray adds `albedo ×` the previous frame's cell at
//! its hit to the same sample, and carries that hit over to the next frame as a query when its
//! cell is missing or stale. A bypassing ray also adds it to its own pixel's ray (light-leak
//! fix 2). An occluded sample's stored ReSTIR reservoir is invalidated (its `W` zeroed).
//!
//! Set 0: cache-view counters, shadow rays, queries, accumulators, pixels, lists (for the count of
//! dropped samples), this frame's ReSTIR reservoirs, the hash grid's keys and values, the
//! environment image, the hash grid's last touch, the carried queries, the hash grid's bounce
//! copy. Set 1: the scene's
//! geometry; set 2 as `traced_kernel!` binds it.

use crate::atomics::DeviceWords;
use crate::texture_images::Bindless;
use gi_shared::append_list::append;
use gi_shared::atomics::AtomicWords;
use gi_shared::hash_cells::layout::{HashCellValue, HashCellsRead};
use gi_shared::hash_cells::lists::{DROPPED_SAMPLES, count};
use gi_shared::math::min_u32;
use gi_shared::multi_bounce::{BounceHit, bounce_radiance, bounce_ray, carried_query};
use gi_shared::scene_data::{Surface, surface_material};
use gi_shared::secondary_hits::{secondary_hit_footprint, shadow_ray_radiance};
use gi_shared::world_cache::{
    BOUNCE_MISSES, CARRIED_NEXT, CachePassParams, CacheQuery, FLAG_MULTI_BOUNCE, PASS_BOUNCE,
    QUERY_CARRIED, RayRecord, SHADOW_BYPASS, SHADOW_RAY_COUNT, ShadowRay, accumulate_into_cell,
    pass_random,
};
use gi_shared::world_restir::PackedReservoir;
use spirv_std::glam::{UVec3, Vec2, Vec3};
use spirv_std::spirv;

traced_kernel! {
    /// Traces shadow ray `id.x` and accumulates its light.
    #[spirv(compute(threads(64)))]
    pub fn populate_radiance_cache(
        scene, texture_images;
        #[spirv(global_invocation_id)] id: UVec3,
        #[spirv(push_constant)] params: &CachePassParams,
        #[spirv(storage_buffer, descriptor_set = 0, binding = 0)] counters: &mut [u32],
        #[spirv(storage_buffer, descriptor_set = 0, binding = 1)] shadow_rays: &[ShadowRay],
        #[spirv(storage_buffer, descriptor_set = 0, binding = 2)] queries: &[CacheQuery],
        #[spirv(storage_buffer, descriptor_set = 0, binding = 3)] accumulators: &mut [u32],
        #[spirv(storage_buffer, descriptor_set = 0, binding = 4)] pixels: &mut [RayRecord],
        #[spirv(storage_buffer, descriptor_set = 0, binding = 5)] lists: &mut [u32],
        #[spirv(storage_buffer, descriptor_set = 0, binding = 6)] reservoirs: &mut [PackedReservoir],
        #[spirv(storage_buffer, descriptor_set = 0, binding = 7)] keys: &[u32],
        #[spirv(storage_buffer, descriptor_set = 0, binding = 8)] values: &[HashCellValue],
        #[spirv(storage_buffer, descriptor_set = 0, binding = 9)] environment: &[[f32; 4]],
        #[spirv(storage_buffer, descriptor_set = 0, binding = 10)] last_touch: &[u32],
        #[spirv(storage_buffer, descriptor_set = 0, binding = 11)] carried: &mut [CacheQuery],
        #[spirv(storage_buffer, descriptor_set = 0, binding = 12)] bounce_values: &[HashCellValue],
    ) {
        let mut counters = DeviceWords(counters);
        let n = min_u32(counters.load(SHADOW_RAY_COUNT), shadow_rays.len() as u32);
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
        let mut radiance = shadow_ray_radiance(&shadow, occluded);
        if params.view.has(FLAG_MULTI_BOUNCE) {
            let view = params.view;
            let mut rng = pass_random(view.seed, query.ray_index, PASS_BOUNCE, view.frame_index);
            let ray = bounce_ray(&query, rng.next_vec2());
            let hit = scene.closest_hit(&ray, texture_images);
            // Fetched once: the bounce keys its point, a carried query shades it.
            let surface = if hit.is_hit() {
                scene.surfaces.surface(hit.instance, hit.primitive, Vec2::from_array(hit.barycentrics))
            } else {
                Surface::default()
            };
            // Inserts and touches finished in an earlier dispatch: plain loads see them.
            let cells = HashCellsRead { keys, last_touch, values };
            let bounce = bounce_radiance(
                cells,
                bounce_values,
                params,
                environment,
                &query,
                &ray,
                BounceHit::of(&ray, &hit, &surface),
            );
            radiance += bounce.radiance;
            if bounce.missed_cell {
                counters.fetch_add(BOUNCE_MISSES, 1);
            }
            // Carried queries carry none of their own: at most one per ray, so the list never
            // overflows and no frame depends on which appends came first.
            if bounce.carry && hit.is_hit() && query.flags & QUERY_CARRIED == 0 {
                let material = surface_material(
                    scene.surfaces, &Bindless(texture_images), &ray,
                    secondary_hit_footprint(), &hit, &surface,
                );
                if let Some(next) = carried_query(&query, &ray, &hit, &surface, &material)
                    && let Some(slot) = append(&mut counters, CARRIED_NEXT, carried.len() as u32)
                {
                    carried[slot as usize] = next;
                }
            }
        }
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
