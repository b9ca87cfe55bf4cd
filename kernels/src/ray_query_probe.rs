//! Traces a buffer of rays with `VK_KHR_ray_query` and writes the closest hits: the proof that
//! device-built acceleration structures and ray queries work on a device.

use gi_shared::ray::{HitRecord, Ray};
use spirv_std::glam::{UVec3, Vec3};
use spirv_std::ray_tracing::{AccelerationStructure, CommittedIntersection, RayFlags, RayQuery};
use spirv_std::spirv;

/// `hits[i]` = closest hit of `rays[i]` in `tlas`.
#[spirv(compute(threads(64)))]
pub fn ray_query_probe(
    #[spirv(global_invocation_id)] id: UVec3,
    #[spirv(descriptor_set = 0, binding = 0)] tlas: &AccelerationStructure,
    #[spirv(storage_buffer, descriptor_set = 0, binding = 1)] rays: &[Ray],
    #[spirv(storage_buffer, descriptor_set = 0, binding = 2)] hits: &mut [HitRecord],
) {
    let i = id.x as usize;
    if i >= rays.len() || i >= hits.len() {
        return;
    }
    let ray = rays[i];
    spirv_std::ray_query!(let mut query);
    unsafe {
        query.initialize(
            tlas,
            RayFlags::OPAQUE,
            0xff,
            Vec3::from(ray.origin),
            ray.t_min,
            Vec3::from(ray.direction),
            ray.t_max,
        );
        while query.proceed() {}
        hits[i] = match query.get_committed_intersection_type() {
            CommittedIntersection::Triangle => {
                let b = query.get_committed_intersection_barycentrics();
                HitRecord {
                    t: query.get_committed_intersection_t(),
                    instance: query.get_committed_intersection_instance_custom_index(),
                    primitive: query.get_committed_intersection_primitive_index(),
                    front_face: query.get_committed_intersection_front_face() as u32,
                    barycentrics: [b.x, b.y],
                    _pad: [0; 2],
                }
            }
            _ => HitRecord::miss(),
        };
    }
}
