//! Traces a buffer of rays and writes their closest hits: the kernel that checks both tracing
//! variants against each other and against the CPU, and measures their speed.

use crate::trace;
use gi_shared::ray::{HitRecord, Ray};
use spirv_std::glam::UVec3;
use spirv_std::spirv;

/// `hits[i]` = closest hit of `rays[i]` in the scene.
#[cfg(feature = "ray-query")]
#[spirv(compute(threads(64)))]
pub fn trace_rays(
    #[spirv(global_invocation_id)] id: UVec3,
    #[spirv(descriptor_set = 0, binding = 0)] tlas: &trace::AccelerationStructure,
    #[spirv(storage_buffer, descriptor_set = 0, binding = 1)] rays: &[Ray],
    #[spirv(storage_buffer, descriptor_set = 0, binding = 2)] hits: &mut [HitRecord],
) {
    let i = id.x as usize;
    if i < rays.len() && i < hits.len() {
        hits[i] = trace::closest_hit(tlas, &rays[i]);
    }
}

/// `hits[i]` = closest hit of `rays[i]` in the scene.
#[cfg(not(feature = "ray-query"))]
#[spirv(compute(threads(64)))]
pub fn trace_rays(
    #[spirv(global_invocation_id)] id: UVec3,
    #[spirv(storage_buffer, descriptor_set = 0, binding = 0)] nodes: &[trace::BvhNode],
    #[spirv(storage_buffer, descriptor_set = 0, binding = 1)] triangles: &[trace::BvhTriangle],
    #[spirv(storage_buffer, descriptor_set = 0, binding = 2)] rays: &[Ray],
    #[spirv(storage_buffer, descriptor_set = 0, binding = 3)] hits: &mut [HitRecord],
) {
    let i = id.x as usize;
    if i < rays.len() && i < hits.len() {
        hits[i] = trace::closest_hit(nodes, triangles, &rays[i]);
    }
}
