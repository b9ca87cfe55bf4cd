//! `gi cache-view`'s own passes (`gi_shared::cache_view`): TraceCacheRays, one cosine ray per
//! G-buffer pixel (the stand-in for the screen probes' PopulateScreenProbes) with the primary
//! hit's next-event estimate, and CacheViewComposite, the running mean of each frame's estimate.
//!
//! TraceCacheRays, set 0: camera (`CameraParams`), G-buffer depth, geometric normal, shading
//! normal, albedo, emissive, ids (images), pixels (`RayRecord`), queries (`CacheQuery`),
//! cache-view counters (`u32`), light-grid bounds (`u32`). Set 1: the scene's geometry. Set 2: the
//! scene's shading data and lights. CacheViewComposite, set 0: camera, G-buffer depth, geometric
//! normal and albedo, pixels, accumulation (`[f32; 4]`: sum and count), feedback history
//! (`FeedbackTexel`). Push constants: `CachePassParams`. Workgroups of 8 × 8 pixels.

use crate::atomics::DeviceWords;
use crate::gbuffer::{DepthImage, HalfImage, IdImage, UnormImage};
use crate::texture_images::Bindless;
use gi_shared::append_list::append;
use gi_shared::cache_view::{cache_ray, primary_direct_light};
use gi_shared::camera::{CameraParams, primary_ray};
use gi_shared::gbuffer::in_image;
use gi_shared::light_grid::report_hit_bounds;
use gi_shared::lights::{GpuLight, LightSources, SceneLights};
use gi_shared::primary_surface::{primary_emission, primary_surface};
use gi_shared::secondary_hits::{TracedRay, shade_cache_hit};
use gi_shared::world_cache::{
    CachePassParams, CacheQuery, PASS_TRACE, QUERY_COUNT, RayRecord, pass_random,
};
use spirv_std::glam::{UVec2, UVec3, UVec4, Vec3, Vec4};
use spirv_std::spirv;

traced_kernel! {
    /// TraceCacheRays: the cosine ray of pixel `id` and its primary hit's next-event estimate.
    #[spirv(compute(threads(8, 8)))]
    pub fn trace_cache_rays(
        scene, texture_images;
        #[spirv(global_invocation_id)] id: UVec3,
        #[spirv(push_constant)] params: &CachePassParams,
        #[spirv(storage_buffer, descriptor_set = 0, binding = 0)] camera: &CameraParams,
        #[spirv(descriptor_set = 0, binding = 1)] depth: &DepthImage,
        #[spirv(descriptor_set = 0, binding = 2)] geometric_normal: &HalfImage,
        #[spirv(descriptor_set = 0, binding = 3)] shading_normal: &HalfImage,
        #[spirv(descriptor_set = 0, binding = 4)] albedo: &UnormImage,
        #[spirv(descriptor_set = 0, binding = 5)] emissive: &HalfImage,
        #[spirv(descriptor_set = 0, binding = 6)] ids: &IdImage,
        #[spirv(storage_buffer, descriptor_set = 0, binding = 7)] pixels: &mut [RayRecord],
        #[spirv(storage_buffer, descriptor_set = 0, binding = 8)] queries: &mut [CacheQuery],
        #[spirv(storage_buffer, descriptor_set = 0, binding = 9)] counters: &mut [u32],
        #[spirv(storage_buffer, descriptor_set = 0, binding = 10)] bounds: &mut [u32],
        #[spirv(storage_buffer, descriptor_set = 2, binding = 7)] lights: &[GpuLight],
        #[spirv(storage_buffer, descriptor_set = 2, binding = 8)] light_table: &[u32],
        #[spirv(storage_buffer, descriptor_set = 2, binding = 9)] environment: &[[f32; 4]],
        #[spirv(storage_buffer, descriptor_set = 2, binding = 10)] environment_cdf: &[f32],
    ) {
        let lighting = SceneLights {
            sources: LightSources { lights, environment, environment_cdf },
            light_table,
        };
        let pixel = UVec2::new(id.x, id.y);
        if !in_image(camera, pixel) {
            return;
        }
        let view = params.view;
        let index = pixel.y * camera.image_size[0] + pixel.x;
        if index as usize >= pixels.len() {
            return;
        }
        let d: f32 = depth.read(pixel);
        let gn: Vec4 = geometric_normal.read(pixel);
        let sn: Vec4 = shading_normal.read(pixel);
        let surface = primary_surface(camera, pixel, d, gn, sn);
        let mut out = RayRecord::default();
        if !surface.valid {
            let ray = primary_ray(camera, pixel, camera.jitter());
            let direction = Vec3::from_array(ray.direction).normalize_or_zero();
            out.ray_radiance = gi_shared::lights::sky_radiance(view.environment_size, view.sky, environment, direction).to_array();
            pixels[index as usize] = out;
            return;
        }
        let a: Vec4 = albedo.read(pixel);
        let e: Vec4 = emissive.read(pixel);
        let ids_texel: UVec4 = ids.read(pixel);
        let mut rng = pass_random(view.seed, index, PASS_TRACE, view.frame_index);
        let ray = cache_ray(&surface, rng.next_vec2());
        let hit = scene.closest_hit(&ray, texture_images);
        let shaded = shade_cache_hit(
            &view, &surface, &TracedRay { ray, hit, index }, scene.surfaces, &Bindless(texture_images), lighting,
        );
        let emission = primary_emission(scene.surfaces.materials, ids_texel, e, view.emissive_multiplier);
        out.emissive = if emission.max_element() > 0.0 { 1 } else { 0 };
        let mut base = emission;
        let direct = primary_direct_light(
            &view, &surface, a.truncate(), scene.surfaces, &Bindless(texture_images), lighting.sources,
            &mut rng,
        );
        if direct.radiance.max_element() > 0.0 && !scene.any_hit(&direct.ray, texture_images) {
            base += direct.radiance;
        }
        out.ray_radiance = shaded.radiance.to_array();
        out.surface = 1;
        out.base = base.to_array();
        pixels[index as usize] = out;
        if shaded.has_query {
            report_hit_bounds(&mut DeviceWords(bounds), 0, shaded.query.position());
            let capacity = queries.len() as u32;
            if let Some(slot) = append(&mut DeviceWords(counters), QUERY_COUNT, capacity) {
                queries[slot as usize] = shaded.query;
            }
        }
    }
}

/// Adds this frame's estimate of pixel `id` to the running mean and records it for the next
/// frame's temporal feedback.
#[cfg(not(feature = "ray-query"))]
#[spirv(compute(threads(8, 8)))]
#[allow(
    clippy::too_many_arguments,
    reason = "an entry point takes one argument per binding"
)]
pub fn composite(
    #[spirv(global_invocation_id)] id: UVec3,
    #[spirv(storage_buffer, descriptor_set = 0, binding = 0)] camera: &CameraParams,
    #[spirv(descriptor_set = 0, binding = 1)] depth: &DepthImage,
    #[spirv(descriptor_set = 0, binding = 2)] geometric_normal: &HalfImage,
    #[spirv(descriptor_set = 0, binding = 3)] albedo: &UnormImage,
    #[spirv(storage_buffer, descriptor_set = 0, binding = 4)] pixels: &[RayRecord],
    #[spirv(storage_buffer, descriptor_set = 0, binding = 5)] accumulation: &mut [[f32; 4]],
    #[spirv(storage_buffer, descriptor_set = 0, binding = 6)]
    history: &mut [gi_shared::radiance_feedback::FeedbackTexel],
) {
    use gi_shared::cache_view::{accumulate_sample, composite};
    use gi_shared::radiance_feedback::feedback_texel;
    let pixel = UVec2::new(id.x, id.y);
    if !in_image(camera, pixel) {
        return;
    }
    let i = (pixel.y * camera.image_size[0] + pixel.x) as usize;
    if i >= pixels.len() || i >= accumulation.len() {
        return;
    }
    let a: Vec4 = albedo.read(pixel);
    let record = pixels[i];
    let sum = accumulate_sample(accumulation[i], composite(&record, a.truncate()));
    accumulation[i] = sum;
    // Without temporal feedback the history is a one-texel placeholder nobody reads.
    if i < history.len() {
        let d: f32 = depth.read(pixel);
        let gn: Vec4 = geometric_normal.read(pixel);
        history[i] = feedback_texel(&record, sum, d, gn.truncate());
    }
}
