//! Tracing, with the implementation chosen at build time: `VK_KHR_ray_query` against the
//! device-built acceleration structure (feature `ray-query`), or the shared crate's BVH walked in
//! software. Both return the same [`HitRecord`].
//!
//! A kernel that traces takes the scene's geometry as the first bindings of set 0: the top-level
//! acceleration structure (binding 0) with ray queries; the BVH nodes (binding 0) and triangles
//! (binding 1) in software. Its own bindings follow.

use gi_shared::ray::{HitRecord, Ray};

/// The BVH buffers as the kernels bind them: rows of 16 bytes, one vector load each.
#[cfg(not(feature = "ray-query"))]
pub use gi_shared::bvh::{BvhNodeRows as BvhNode, BvhTriangleRows as BvhTriangle};
#[cfg(feature = "ray-query")]
pub use spirv_std::ray_tracing::AccelerationStructure;

/// The closest hit of `ray`, or [`HitRecord::miss`].
#[cfg(feature = "ray-query")]
pub fn closest_hit(tlas: &AccelerationStructure, ray: &Ray) -> HitRecord {
    use spirv_std::glam::Vec3;
    use spirv_std::ray_tracing::{CommittedIntersection, RayFlags, RayQuery};
    // Ray queries leave such rays undefined; the software traversal misses them, and so must this.
    if !ray.is_traceable() {
        return HitRecord::miss();
    }
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
        match query.get_committed_intersection_type() {
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
        }
    }
}

/// The closest hit of `ray`, or [`HitRecord::miss`].
#[cfg(not(feature = "ray-query"))]
pub fn closest_hit(nodes: &[BvhNode], triangles: &[BvhTriangle], ray: &Ray) -> HitRecord {
    gi_shared::bvh::closest_hit(nodes, triangles, ray)
}

/// Whether `ray` hits anything between `t_min` and `t_max` (shadow rays).
#[cfg(feature = "ray-query")]
pub fn any_hit(tlas: &AccelerationStructure, ray: &Ray) -> bool {
    use spirv_std::glam::Vec3;
    use spirv_std::ray_tracing::{CommittedIntersection, RayFlags, RayQuery};
    if !ray.is_traceable() {
        return false;
    }
    spirv_std::ray_query!(let mut query);
    unsafe {
        query.initialize(
            tlas,
            RayFlags::OPAQUE | RayFlags::TERMINATE_ON_FIRST_HIT,
            0xff,
            Vec3::from(ray.origin),
            ray.t_min,
            Vec3::from(ray.direction),
            ray.t_max,
        );
        while query.proceed() {}
        !matches!(
            query.get_committed_intersection_type(),
            CommittedIntersection::None
        )
    }
}

/// Whether `ray` hits anything between `t_min` and `t_max` (shadow rays).
#[cfg(not(feature = "ray-query"))]
pub fn any_hit(nodes: &[BvhNode], triangles: &[BvhTriangle], ray: &Ray) -> bool {
    gi_shared::bvh::any_hit(nodes, triangles, ray)
}
