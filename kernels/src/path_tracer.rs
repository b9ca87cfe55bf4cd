//! The reference path tracer: one path per pixel per dispatch, added to an accumulation buffer
//! (`[f32; 4]` per pixel, row by row: radiance sum and sample count). The host runs N dispatches
//! with sample indices 0..N and divides. The path itself is `gi_shared::path_tracer`; this loop
//! only traces.
//!
//! Set 0: the camera (`CameraParams`), the accumulation buffer. Set 1: the scene's geometry. Set
//! 2: the scene's shading data (instances, meshes, vertices, triangles, materials, texture table,
//! texels), lights (`GpuLight`), triangle→light table (`u32`), environment image (`[f32; 4]`
//! texels) and its distribution (`f32`). Push constants: `PathTracerParams`. Workgroups of 8 × 8
//! pixels.

use crate::texture_images::Bindless;
use gi_shared::camera::CameraParams;
use gi_shared::gbuffer::in_image;
use gi_shared::lights::{GpuLight, LightSources, SceneLights};
use gi_shared::path_tracer::{MAX_BOUNCES, PathTracerParams, begin_path, finite_radiance, shade};
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

traced_kernel! {
    /// Adds one path of pixel `id` to the accumulation buffer.
    #[spirv(compute(threads(8, 8)))]
    pub fn path_tracer(
        scene, texture_images;
        #[spirv(global_invocation_id)] id: UVec3,
        #[spirv(push_constant)] params: &PathTracerParams,
        #[spirv(storage_buffer, descriptor_set = 0, binding = 0)] camera: &CameraParams,
        #[spirv(storage_buffer, descriptor_set = 0, binding = 1)] accumulation: &mut [[f32; 4]],
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
        let mut path = begin_path(camera, params, pixel);
        let mut steps = 0;
        while path.active && steps <= MAX_BOUNCES {
            let hit = scene.closest_hit(&path.ray, texture_images);
            shade(
                &mut path,
                &hit,
                camera,
                params,
                scene.surfaces,
                &Bindless(texture_images),
                lighting,
            );
            if path.shadow_pending && !scene.any_hit(&path.shadow_ray, texture_images) {
                path.radiance += path.shadow_radiance;
            }
            steps += 1;
        }
        accumulate!(accumulation, camera, pixel, path.radiance);
    }
}
