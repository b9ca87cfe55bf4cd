//! The reference path tracer: one path per pixel per dispatch, added to an accumulation buffer
//! (`[f32; 4]` per pixel, row by row: radiance sum and sample count). The host runs N dispatches
//! with sample indices 0..N and divides. The path itself is `gi_shared::path_tracer`; this loop
//! only traces.
//!
//! Set 0 after the scene's geometry (1 binding with ray queries, 2 in software): the camera
//! (`CameraParams`), the shading data (instances, meshes, vertices, triangles, materials, texture
//! table, texels), the lights (`GpuLight`), the triangle→light table (`u32`), the environment
//! image (`[f32; 4]` texels) and its distribution (`f32`), the accumulation buffer. Push constants:
//! `PathTracerParams`. Workgroups of 8 × 8 pixels.

use crate::trace;
use gi_shared::camera::CameraParams;
use gi_shared::gbuffer::in_image;
use gi_shared::lights::GpuLight;
use gi_shared::path_tracer::{MAX_BOUNCES, PathTracerParams, begin_path, finite_radiance, shade};
use gi_shared::scene_data::{
    GpuInstance, GpuMaterial, GpuMesh, GpuTexture, GpuTriangle, GpuVertex,
};
use spirv_std::glam::{UVec2, UVec3};
use spirv_std::spirv;

/// Adds `radiance` and one sample to pixel `pixel` of `accumulation`.
macro_rules! accumulate {
    ($accumulation:expr, $camera:expr, $pixel:expr, $radiance:expr) => {{
        let i = $pixel.y as usize * $camera.image_size[0] as usize + $pixel.x as usize;
        if i < $accumulation.len() {
            let r = finite_radiance($radiance);
            let old = $accumulation[i];
            $accumulation[i] = [old[0] + r.x, old[1] + r.y, old[2] + r.z, old[3] + 1.0];
        }
    }};
}

/// Adds one path of pixel `id` to the accumulation buffer.
#[cfg(feature = "ray-query")]
#[spirv(compute(threads(8, 8)))]
#[allow(
    clippy::too_many_arguments,
    reason = "an entry point takes one argument per binding"
)]
pub fn path_tracer(
    #[spirv(global_invocation_id)] id: UVec3,
    #[spirv(push_constant)] params: &PathTracerParams,
    #[spirv(descriptor_set = 0, binding = 0)] tlas: &trace::AccelerationStructure,
    #[spirv(storage_buffer, descriptor_set = 0, binding = 1)] camera: &CameraParams,
    #[spirv(storage_buffer, descriptor_set = 0, binding = 2)] instances: &[GpuInstance],
    #[spirv(storage_buffer, descriptor_set = 0, binding = 3)] meshes: &[GpuMesh],
    #[spirv(storage_buffer, descriptor_set = 0, binding = 4)] vertices: &[GpuVertex],
    #[spirv(storage_buffer, descriptor_set = 0, binding = 5)] triangles: &[GpuTriangle],
    #[spirv(storage_buffer, descriptor_set = 0, binding = 6)] materials: &[GpuMaterial],
    #[spirv(storage_buffer, descriptor_set = 0, binding = 7)] textures: &[GpuTexture],
    #[spirv(storage_buffer, descriptor_set = 0, binding = 8)] texels: &[u32],
    #[spirv(storage_buffer, descriptor_set = 0, binding = 9)] lights: &[GpuLight],
    #[spirv(storage_buffer, descriptor_set = 0, binding = 10)] light_table: &[u32],
    #[spirv(storage_buffer, descriptor_set = 0, binding = 11)] environment: &[[f32; 4]],
    #[spirv(storage_buffer, descriptor_set = 0, binding = 12)] environment_cdf: &[f32],
    #[spirv(storage_buffer, descriptor_set = 0, binding = 13)] accumulation: &mut [[f32; 4]],
) {
    let pixel = UVec2::new(id.x, id.y);
    if !in_image(camera, pixel) {
        return;
    }
    let mut path = begin_path(camera, params, pixel);
    let mut steps = 0;
    while path.active && steps <= MAX_BOUNCES {
        let hit = trace::closest_hit(tlas, &path.ray);
        shade(
            &mut path,
            &hit,
            params,
            instances,
            meshes,
            vertices,
            triangles,
            materials,
            textures,
            texels,
            lights,
            light_table,
            environment,
            environment_cdf,
        );
        if path.shadow_pending && !trace::any_hit(tlas, &path.shadow_ray) {
            path.radiance += path.shadow_radiance;
        }
        steps += 1;
    }
    accumulate!(accumulation, camera, pixel, path.radiance);
}

/// Adds one path of pixel `id` to the accumulation buffer.
#[cfg(not(feature = "ray-query"))]
#[spirv(compute(threads(8, 8)))]
#[allow(
    clippy::too_many_arguments,
    reason = "an entry point takes one argument per binding"
)]
pub fn path_tracer(
    #[spirv(global_invocation_id)] id: UVec3,
    #[spirv(push_constant)] params: &PathTracerParams,
    #[spirv(storage_buffer, descriptor_set = 0, binding = 0)] nodes: &[trace::BvhNode],
    #[spirv(storage_buffer, descriptor_set = 0, binding = 1)]
    bvh_triangles: &[trace::BvhTriangle],
    #[spirv(storage_buffer, descriptor_set = 0, binding = 2)] camera: &CameraParams,
    #[spirv(storage_buffer, descriptor_set = 0, binding = 3)] instances: &[GpuInstance],
    #[spirv(storage_buffer, descriptor_set = 0, binding = 4)] meshes: &[GpuMesh],
    #[spirv(storage_buffer, descriptor_set = 0, binding = 5)] vertices: &[GpuVertex],
    #[spirv(storage_buffer, descriptor_set = 0, binding = 6)] triangles: &[GpuTriangle],
    #[spirv(storage_buffer, descriptor_set = 0, binding = 7)] materials: &[GpuMaterial],
    #[spirv(storage_buffer, descriptor_set = 0, binding = 8)] textures: &[GpuTexture],
    #[spirv(storage_buffer, descriptor_set = 0, binding = 9)] texels: &[u32],
    #[spirv(storage_buffer, descriptor_set = 0, binding = 10)] lights: &[GpuLight],
    #[spirv(storage_buffer, descriptor_set = 0, binding = 11)] light_table: &[u32],
    #[spirv(storage_buffer, descriptor_set = 0, binding = 12)] environment: &[[f32; 4]],
    #[spirv(storage_buffer, descriptor_set = 0, binding = 13)] environment_cdf: &[f32],
    #[spirv(storage_buffer, descriptor_set = 0, binding = 14)] accumulation: &mut [[f32; 4]],
) {
    let pixel = UVec2::new(id.x, id.y);
    if !in_image(camera, pixel) {
        return;
    }
    let mut path = begin_path(camera, params, pixel);
    let mut steps = 0;
    while path.active && steps <= MAX_BOUNCES {
        let hit = trace::closest_hit(nodes, bvh_triangles, &path.ray);
        shade(
            &mut path,
            &hit,
            params,
            instances,
            meshes,
            vertices,
            triangles,
            materials,
            textures,
            texels,
            lights,
            light_table,
            environment,
            environment_cdf,
        );
        if path.shadow_pending && !trace::any_hit(nodes, bvh_triangles, &path.shadow_ray) {
            path.radiance += path.shadow_radiance;
        }
        steps += 1;
    }
    accumulate!(accumulation, camera, pixel, path.radiance);
}
