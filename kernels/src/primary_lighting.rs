//! The primary hit's own lighting and the final composite (`gi_shared::primary_lighting`, whose
//! module doc gives the split of light paths): DirectLight (traces shadow rays, both variants)
//! and ResolveGI (software variant only).
//!
//! DirectLight, set 0: 0 frame (`GiFrameParams`), 1 camera (`CameraParams`), 2 depth, 3
//! geometric normal, 4 shading normal, 5 emissive, 6 ids (images), 7 primary lighting
//! (`PrimaryLighting`, written), 8 interpolated irradiance (`[f32; 4]`, the sampled direct light
//! added: `gi_shared::primary_lighting::samples_light`). Set 1: the scene's geometry. Set 2:
//! instances, meshes, vertices, triangles, materials, textures, texels, lights, light table,
//! environment, environment CDF (as TraceCacheRays).
//!
//! ResolveGI, set 0: 0 camera, 1 depth, 2 geometric normal, 3 albedo, 4 primary lighting, 5
//! denoised irradiance (`[f32; 4]`), 6 colour (`[f32; 4]`, written), 7 feedback history
//! (`FeedbackTexel`, written), 8 interpolated irradiance before the denoiser (`[f32; 4]`).
//!
//! Both: workgroups of 8 × 8 pixels, dispatched `[ceil(W / 8), ceil(H / 8), 1]`; per-pixel
//! buffers indexed `y × W + x`.

use crate::gbuffer::{DepthImage, HalfImage, IdImage};
use crate::texture_images::Bindless;
use gi_shared::camera::{CameraParams, primary_ray};
use gi_shared::gbuffer::in_image;
use gi_shared::lights::GpuLight;
use gi_shared::primary_lighting::{
    PrimaryLighting, add_sampled_light, samples_light, sky_lighting, surface_lighting,
};
use gi_shared::primary_surface::{primary_emission, primary_surface};
use gi_shared::ray::Ray;
use gi_shared::screen_probes::{GiFrameParams, PASS_DIRECT};
use gi_shared::world_cache::pass_random;
use spirv_std::glam::{UVec2, UVec3, UVec4, Vec3, Vec4};
use spirv_std::spirv;

traced_kernel! {
    /// DirectLight: the emission (or sky) and the punctual lights' direct irradiance of pixel
    /// `id`; the direct irradiance it samples is added to its interpolated GI irradiance.
    #[spirv(compute(threads(8, 8)))]
    pub fn direct_light(
        scene, texture_images;
        #[spirv(global_invocation_id)] id: UVec3,
        #[spirv(storage_buffer, descriptor_set = 0, binding = 0)] frame: &GiFrameParams,
        #[spirv(storage_buffer, descriptor_set = 0, binding = 1)] camera: &CameraParams,
        #[spirv(descriptor_set = 0, binding = 2)] depth: &DepthImage,
        #[spirv(descriptor_set = 0, binding = 3)] geometric_normal: &HalfImage,
        #[spirv(descriptor_set = 0, binding = 4)] shading_normal: &HalfImage,
        #[spirv(descriptor_set = 0, binding = 5)] emissive: &HalfImage,
        #[spirv(descriptor_set = 0, binding = 6)] ids: &IdImage,
        #[spirv(storage_buffer, descriptor_set = 0, binding = 7)] lighting: &mut [PrimaryLighting],
        #[spirv(storage_buffer, descriptor_set = 0, binding = 8)] irradiance: &mut [[f32; 4]],
        #[spirv(storage_buffer, descriptor_set = 2, binding = 7)] lights: &[GpuLight],
        #[spirv(storage_buffer, descriptor_set = 2, binding = 8)] _light_table: &[u32],
        #[spirv(storage_buffer, descriptor_set = 2, binding = 9)] environment: &[[f32; 4]],
        #[spirv(storage_buffer, descriptor_set = 2, binding = 10)] _environment_cdf: &[f32],
    ) {
        let pixel = UVec2::new(id.x, id.y);
        if !in_image(camera, pixel) {
            return;
        }
        let index = pixel.y * camera.image_size[0] + pixel.x;
        if index as usize >= lighting.len() {
            return;
        }
        let d: f32 = depth.read(pixel);
        let gn: Vec4 = geometric_normal.read(pixel);
        let sn: Vec4 = shading_normal.read(pixel);
        let surface = primary_surface(camera, pixel, d, gn, sn);
        if !surface.valid {
            let ray = primary_ray(camera, pixel, camera.jitter());
            let direction = Vec3::from_array(ray.direction).normalize_or_zero();
            lighting[index as usize] = sky_lighting(frame, environment, direction);
            return;
        }
        let e: Vec4 = emissive.read(pixel);
        let ids_texel: UVec4 = ids.read(pixel);
        let emission = primary_emission(scene.surfaces.materials, ids_texel, e, frame.emissive_multiplier);
        let mut rng = pass_random(frame.seed, index, PASS_DIRECT, frame.frame_index);
        let tracer = scene.tracer();
        let lit = surface_lighting(
            frame,
            &surface,
            emission,
            lights,
            &mut rng,
            &Bindless(texture_images),
            move |ray: &Ray, images: &Bindless<'_>| tracer.any_hit(ray, images),
        );
        lighting[index as usize] = lit.record;
        if samples_light(frame) && (index as usize) < irradiance.len() {
            irradiance[index as usize] = add_sampled_light(irradiance[index as usize], lit.sampled);
        }
    }
}

/// ResolveGI: the final colour of pixel `id` (emission + albedo / π × (denoised GI irradiance +
/// direct light)) and its feedback texel for the next frame (the same colour from the irradiance
/// before the denoiser: `gi_shared::primary_lighting::resolve_feedback`).
#[cfg(not(feature = "ray-query"))]
#[spirv(compute(threads(8, 8)))]
#[allow(
    clippy::too_many_arguments,
    reason = "an entry point takes one argument per binding"
)]
pub fn resolve_gi(
    #[spirv(global_invocation_id)] id: UVec3,
    #[spirv(storage_buffer, descriptor_set = 0, binding = 0)] camera: &CameraParams,
    #[spirv(descriptor_set = 0, binding = 1)] depth: &DepthImage,
    #[spirv(descriptor_set = 0, binding = 2)] geometric_normal: &HalfImage,
    #[spirv(descriptor_set = 0, binding = 3)] albedo: &crate::gbuffer::UnormImage,
    #[spirv(storage_buffer, descriptor_set = 0, binding = 4)] lighting: &[PrimaryLighting],
    #[spirv(storage_buffer, descriptor_set = 0, binding = 5)] irradiance: &[[f32; 4]],
    #[spirv(storage_buffer, descriptor_set = 0, binding = 6)] color: &mut [[f32; 4]],
    #[spirv(storage_buffer, descriptor_set = 0, binding = 7)]
    history: &mut [gi_shared::radiance_feedback::FeedbackTexel],
    #[spirv(storage_buffer, descriptor_set = 0, binding = 8)] undenoised: &[[f32; 4]],
) {
    use gi_shared::primary_lighting::{resolve_color, resolve_feedback};
    let pixel = UVec2::new(id.x, id.y);
    if !in_image(camera, pixel) {
        return;
    }
    let i = (pixel.y * camera.image_size[0] + pixel.x) as usize;
    if i >= lighting.len() || i >= irradiance.len() || i >= color.len() {
        return;
    }
    let record = lighting[i];
    let a: Vec4 = albedo.read(pixel);
    let c = resolve_color(&record, a.truncate(), irradiance[i]);
    color[i] = [c.x, c.y, c.z, 1.0];
    // Without temporal feedback the history is a one-texel placeholder nobody reads.
    if i < history.len() && i < undenoised.len() {
        let d: f32 = depth.read(pixel);
        let gn: Vec4 = geometric_normal.read(pixel);
        let fed_back = resolve_color(&record, a.truncate(), undenoised[i]);
        history[i] = resolve_feedback(&record, fed_back, d, gn.truncate().normalize_or_zero());
    }
}
