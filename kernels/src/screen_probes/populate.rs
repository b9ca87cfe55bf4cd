//! PopulateScreenProbes: one ray per cell of every probe spawned this frame, in the direction
//! SampleScreenProbes chose. A miss takes the sky and a front-facing emitter its emission, both
//! in full (`FLAG_PROBE_RAYS`: the primary hit samples neither); any other hit appends a
//! `CacheQuery`, which the cache passes (InsertRadianceCache ... ResolveRadianceCache) complete
//! into the ray's record.
//!
//! Set 0: frame (`GiFrameParams`), camera, G-buffer depth and geometric normal, spawns, probe
//! rays, ray records (`RayRecord`), queries, cache counters, light-grid
//! bounds. Set 1: the scene's geometry. Set 2: its shading data and lights. Push constants:
//! `CachePassParams`. One workgroup of 64 invocations per spawn slot, `[spawn_grid.x,
//! spawn_grid.y]` groups.

use crate::gbuffer::{DepthImage, HalfImage};
use crate::texture_images::Bindless;
use gi_shared::append_list::append;
use gi_shared::camera::CameraParams;
use gi_shared::light_grid::report_hit_bounds;
use gi_shared::lights::{GpuLight, LightSources, SceneLights};
use gi_shared::packing::unpack_seed;
use gi_shared::primary_surface::primary_surface;
use gi_shared::ray::Ray;
use gi_shared::screen_probes::spawn::spawned_seed;
use gi_shared::screen_probes::{GiFrameParams, MISS_DISTANCE, PROBE_CELLS, ProbeRay};
use gi_shared::secondary_hits::{TracedRay, shade_cache_hit};
use gi_shared::world_cache::{CachePassParams, CacheQuery, QUERY_COUNT, RayRecord};
use spirv_std::glam::{UVec3, Vec3, Vec4};
use spirv_std::spirv;

traced_kernel! {
    /// Traces ray `lane` of spawn slot `group`.
    #[spirv(compute(threads(64)))]
    pub fn populate_screen_probes(
        scene, texture_images;
        #[spirv(workgroup_id)] group: UVec3,
        #[spirv(local_invocation_index)] lane: u32,
        #[spirv(push_constant)] params: &CachePassParams,
        #[spirv(storage_buffer, descriptor_set = 0, binding = 0)] frame: &GiFrameParams,
        #[spirv(storage_buffer, descriptor_set = 0, binding = 1)] camera: &CameraParams,
        #[spirv(descriptor_set = 0, binding = 2)] depth: &DepthImage,
        #[spirv(descriptor_set = 0, binding = 3)] geometric_normal: &HalfImage,
        #[spirv(storage_buffer, descriptor_set = 0, binding = 4)] spawns: &[u32],
        #[spirv(storage_buffer, descriptor_set = 0, binding = 5)] probe_rays: &mut [ProbeRay],
        #[spirv(storage_buffer, descriptor_set = 0, binding = 6)] ray_records: &mut [RayRecord],
        #[spirv(storage_buffer, descriptor_set = 0, binding = 7)] queries: &mut [CacheQuery],
        #[spirv(storage_buffer, descriptor_set = 0, binding = 8)] counters: &mut [u32],
        #[spirv(storage_buffer, descriptor_set = 0, binding = 9)] bounds: &mut [u32],
        #[spirv(storage_buffer, descriptor_set = 2, binding = 7)] lights: &[GpuLight],
        #[spirv(storage_buffer, descriptor_set = 2, binding = 8)] light_table: &[u32],
        #[spirv(storage_buffer, descriptor_set = 2, binding = 9)] environment: &[[f32; 4]],
        #[spirv(storage_buffer, descriptor_set = 2, binding = 10)] environment_cdf: &[f32],
    ) {
        let lighting = SceneLights {
            sources: LightSources { lights, environment, environment_cdf },
            light_table,
        };
        let spawn = group.y * frame.spawn_grid[0] + group.x;
        if spawned_seed(spawns, spawn).is_none() {
            return;
        }
        let index = spawn * PROBE_CELLS + lane;
        let i = index as usize;
        if i >= probe_rays.len() || i >= ray_records.len() {
            return;
        }
        let seed = unpack_seed(spawns[spawn as usize]);
        let d: f32 = depth.read(seed);
        let gn: Vec4 = geometric_normal.read(seed);
        let surface = primary_surface(camera, seed, d, gn, gn);
        let mut record = probe_rays[i];
        let direction = Vec3::from_array(record.direction);
        let mut out = RayRecord::default();
        record.hit_distance = MISS_DISTANCE;
        if surface.valid && direction != Vec3::ZERO {
            let ray = Ray {
                origin: surface.position.to_array(),
                t_min: 0.0,
                direction: record.direction,
                t_max: f32::INFINITY,
            };
            let hit = scene.closest_hit(&ray, texture_images);
            let shaded = shade_cache_hit(
                &params.view, &surface, &TracedRay { ray, hit, index }, scene.surfaces, &Bindless(texture_images), lighting,
            );
            if hit.is_hit() {
                record.hit_distance = hit.t * direction.length();
            }
            out.ray_radiance = shaded.radiance.to_array();
            out.surface = 1;
            if shaded.has_query {
                report_hit_bounds(&mut crate::atomics::DeviceWords(bounds), 0, shaded.query.position());
                let capacity = queries.len() as u32;
                if let Some(slot) = append(&mut crate::atomics::DeviceWords(counters), QUERY_COUNT, capacity) {
                    // A guided ray's sample weighs as if the ray had been drawn uniformly.
                    queries[slot as usize] = shaded
                        .query
                        .with_density(PROBE_CELLS as f32 * record.cell_probability);
                }
            }
        }
        probe_rays[i] = record;
        ray_records[i] = out;
    }
}
