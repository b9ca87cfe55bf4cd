//! GenerateReservoirs: one invocation per query (dispatched from the query counter). A hit that
//! reprojects into the previous frame's image takes its radiance, for its ray and its cell
//! (temporal radiance feedback); any other samples one light through the light grid (RIS over
//! its candidates) and appends one shadow ray for PopulateRadianceCache (with zero contribution
//! when nothing can light it: the cell still counts the sample). With ReSTIR, the hit also joins
//! this frame's reservoir grid, with its reservoir and normal.
//!
//! Set 0: camera (`CameraParams`), queries, cache-view counters, pixels, feedback history
//! (`FeedbackTexel`), accumulators, grid parameters (`LightGridParams`), grid entries
//! (`LightGridEntry`), shadow rays (`ShadowRay`), lists (dropped-sample count), lights
//! (`GpuLight`), the environment's texels and distribution, then this frame's reservoir grid:
//! slot keys, slot counts, each shadow ray's place (`[u32; 2]`), reservoir (`PackedReservoir`)
//! and hit (`ReservoirHit`). Push constants: `CachePassParams`.

#![cfg(not(feature = "ray-query"))]

use crate::atomics::DeviceWords;
use gi_shared::append_list::append;
use gi_shared::atomics::AtomicWords;
use gi_shared::camera::CameraParams;
use gi_shared::hash_cells::lists::{DROPPED_SAMPLES, count};
use gi_shared::light_grid::{LightGridEntry, LightGridParams};
use gi_shared::lights::{GpuLight, LightSources};
use gi_shared::math::min_u32;
use gi_shared::radiance_feedback::{FeedbackTexel, feedback_lookup};
use gi_shared::secondary_hits::{sample_query_light, shadow_ray};
use gi_shared::world_cache::{
    CachePassParams, CacheQuery, FEEDBACK_COUNT, FLAG_FEEDBACK, FLAG_HISTORY, FLAG_RESTIR,
    PASS_GENERATE, QUERY_BYPASS, QUERY_COUNT, QUERY_FED_BACK, RayRecord, SHADOW_RAY_COUNT,
    ShadowRay, accumulate_into_cell, pass_random,
};
use gi_shared::world_restir::insert_reservoir;
use gi_shared::world_restir::{PackedReservoir, ReservoirHit};
use spirv_std::glam::{UVec3, Vec3};
use spirv_std::spirv;

/// Lights query `id.x` by feedback or appends its shadow ray.
#[spirv(compute(threads(64)))]
#[allow(
    clippy::too_many_arguments,
    reason = "an entry point takes one argument per binding"
)]
pub fn generate_reservoirs(
    #[spirv(global_invocation_id)] id: UVec3,
    #[spirv(push_constant)] params: &CachePassParams,
    #[spirv(storage_buffer, descriptor_set = 0, binding = 0)] camera: &CameraParams,
    #[spirv(storage_buffer, descriptor_set = 0, binding = 1)] queries: &mut [CacheQuery],
    #[spirv(storage_buffer, descriptor_set = 0, binding = 2)] counters: &mut [u32],
    #[spirv(storage_buffer, descriptor_set = 0, binding = 3)] pixels: &mut [RayRecord],
    #[spirv(storage_buffer, descriptor_set = 0, binding = 4)] history: &[FeedbackTexel],
    #[spirv(storage_buffer, descriptor_set = 0, binding = 5)] accumulators: &mut [u32],
    #[spirv(storage_buffer, descriptor_set = 0, binding = 6)] grid: &[LightGridParams],
    #[spirv(storage_buffer, descriptor_set = 0, binding = 7)] entries: &[LightGridEntry],
    #[spirv(storage_buffer, descriptor_set = 0, binding = 8)] shadow_rays: &mut [ShadowRay],
    #[spirv(storage_buffer, descriptor_set = 0, binding = 9)] lists: &mut [u32],
    #[spirv(storage_buffer, descriptor_set = 0, binding = 10)] lights: &[GpuLight],
    #[spirv(storage_buffer, descriptor_set = 0, binding = 11)] environment: &[[f32; 4]],
    #[spirv(storage_buffer, descriptor_set = 0, binding = 12)] environment_cdf: &[f32],
    #[spirv(storage_buffer, descriptor_set = 0, binding = 13)] reservoir_keys: &mut [u32],
    #[spirv(storage_buffer, descriptor_set = 0, binding = 14)] reservoir_counts: &mut [u32],
    #[spirv(storage_buffer, descriptor_set = 0, binding = 15)] places: &mut [[u32; 2]],
    #[spirv(storage_buffer, descriptor_set = 0, binding = 16)] reservoirs: &mut [PackedReservoir],
    #[spirv(storage_buffer, descriptor_set = 0, binding = 17)] hits: &mut [ReservoirHit],
) {
    let view = params.view;
    let mut counters = DeviceWords(counters);
    let n = min_u32(counters.load(QUERY_COUNT), queries.len() as u32);
    if id.x >= n || grid.is_empty() {
        return;
    }
    let i = id.x as usize;
    let mut query = queries[i];
    let r = query.ray_index as usize;
    if view.has(FLAG_FEEDBACK | FLAG_HISTORY) && r < pixels.len() {
        let feedback = feedback_lookup(camera, &query, history);
        if feedback.accepted {
            let mut pixel = pixels[r];
            pixel.ray_radiance =
                (Vec3::from_array(pixel.ray_radiance) + feedback.radiance).to_array();
            pixels[r] = pixel;
            if !accumulate_into_cell(&mut DeviceWords(accumulators), &query, feedback.radiance) {
                count(&mut DeviceWords(lists), DROPPED_SAMPLES);
            }
            query.flags |= QUERY_FED_BACK;
            queries[i] = query;
            counters.fetch_add(FEEDBACK_COUNT, 1);
            return;
        }
    }
    let mut rng = pass_random(view.seed, query.ray_index, PASS_GENERATE, view.frame_index);
    let lighting = LightSources {
        lights,
        environment,
        environment_cdf,
    };
    let sample = sample_query_light(&grid[0], entries, lighting, &query, &mut rng);
    let capacity = shadow_rays.len() as u32;
    let Some(slot) = append(&mut counters, SHADOW_RAY_COUNT, capacity) else {
        return;
    };
    let s = slot as usize;
    shadow_rays[s] = shadow_ray(&sample, id.x, query.flags & QUERY_BYPASS != 0);
    if view.has(FLAG_RESTIR) && s < places.len() && s < reservoirs.len() && s < hits.len() {
        places[s] = insert_reservoir(
            &mut DeviceWords(reservoir_keys),
            &mut DeviceWords(reservoir_counts),
            &view,
            params.grid.eye(),
            &query,
            &mut rng,
        );
        reservoirs[s] = PackedReservoir::pack(&sample.reservoir, sample.params);
        hits[s] = ReservoirHit::new(query.position(), query.shading_normal());
    }
}
