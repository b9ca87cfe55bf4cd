//! Traces a buffer of rays and writes their closest hits: the kernel that checks both tracing
//! variants against each other and against the CPU, and measures their speed.
//!
//! Set 0: the rays (`Ray`), the hits (`HitRecord`).

use gi_shared::ray::{HitRecord, Ray};
use spirv_std::glam::UVec3;
use spirv_std::spirv;

traced_kernel! {
    /// `hits[i]` = closest hit of `rays[i]` in the scene.
    #[spirv(compute(threads(64)))]
    pub fn trace_rays(
        scene, texture_images;
        #[spirv(global_invocation_id)] id: UVec3,
        #[spirv(storage_buffer, descriptor_set = 0, binding = 0)] rays: &[Ray],
        #[spirv(storage_buffer, descriptor_set = 0, binding = 1)] hits: &mut [HitRecord],
    ) {
        let i = id.x as usize;
        if i < rays.len() && i < hits.len() {
            hits[i] = scene.closest_hit(&rays[i], texture_images);
        }
    }
}
