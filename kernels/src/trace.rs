//! Tracing, with the implementation chosen at build time: `VK_KHR_ray_query` against the
//! device-built acceleration structure (feature `ray-query`), or the shared crate's BVH walked in
//! software. Both return the same [`HitRecord`].
//!
//! A kernel that traces is written once, with [`traced_kernel!`](crate::traced_kernel): the macro
//! emits its entry point for the variant being built, binding the scene's geometry as set 1 (the
//! top-level acceleration structure at binding 0 with ray queries; the two-level BVH's nodes at
//! binding 0 in software)
//! and the shading data that tracing reads, set 2 bindings 0 to 6 (instances, meshes, vertices,
//! triangles: the software traversal reads its triangles there; materials, texture table and
//! texture images: the alpha test of meshes flagged `MESH_ALPHA_TESTED` reads them), and handing
//! the body a [`Scene`] that traces and holds the six buffers, and the texture images beside it.
//!
//! The arrays that scale with the triangle count (vertices, triangles, BVH nodes) are bound split
//! ([`Chunks`], a descriptor array of storage buffers: `gi_shared::elements`), so that a mesh
//! larger than one storage binding traces; the body reads them as [`Chunked`].
//!
//! The texture images stay out of [`Scene`] and [`Tracer`], and out of closures: a composite
//! holding the bindless array fails SPIR-V validation (VUID-StandaloneSpirv-None-04667) unless
//! every function that sees it is inlined. Every trace takes them as an argument instead, the
//! way shading reads them (`texture_images::Bindless`, a bare reference).

use crate::texture_images::Bindless;
pub use crate::texture_images::SceneTextures;
use gi_shared::elements::{ChunkIndex, Elements};
use gi_shared::layout::SCENE_BUFFER_CHUNKS;
use gi_shared::ray::{HitRecord, Ray};
pub use gi_shared::scene_data::{
    GpuInstance, GpuMaterial, GpuMesh, GpuTriangle, GpuVertex, SceneSurfaces,
};
pub use gi_shared::textures::GpuTexture;
use spirv_std::{RuntimeArray, TypedBuffer};

/// One of the scene's split arrays as the kernels bind it: one storage buffer per chunk, all
/// [`SCENE_BUFFER_CHUNKS`] written (`gi_shared::elements`).
pub type Chunks<T> = RuntimeArray<TypedBuffer<[T]>>;

/// A split array, read through the shared [`Elements`]: its chunks, with the index and the length
/// found once, when a traced kernel starts.
pub struct Chunked<'a, T> {
    chunks: &'a Chunks<T>,
    index: ChunkIndex,
    len: usize,
}

impl<T> Clone for Chunked<'_, T> {
    #[inline(always)]
    fn clone(&self) -> Self {
        *self
    }
}

impl<T> Copy for Chunked<'_, T> {}

impl<'a, T> Chunked<'a, T> {
    /// The array bound as `chunks`.
    #[inline(always)]
    pub fn new(chunks: &'a Chunks<T>) -> Self {
        // SAFETY (here and in `get`): the host writes all `SCENE_BUFFER_CHUNKS` descriptors, the
        // slots past the last chunk with a buffer too short for one element.
        let first = unsafe { chunks.index(0) }.len();
        let mut len = first;
        let mut k = 1;
        while k < SCENE_BUFFER_CHUNKS {
            len += unsafe { chunks.index(k) }.len();
            k += 1;
        }
        Self {
            chunks,
            index: ChunkIndex::new(first as u32),
            len,
        }
    }
}

impl<T: Copy> Elements for Chunked<'_, T> {
    type Item = T;

    #[inline(always)]
    fn len(&self) -> usize {
        self.len
    }

    #[inline(always)]
    fn get(&self, i: usize) -> T {
        let (chunk, j) = self.index.locate(i as u32);
        // SAFETY: callers read below `len`, so `j` is within chunk `chunk` (every chunk but the
        // last is full). Unchecked: lavapipe gives `OpArrayLength` on a non-uniformly indexed
        // binding one invocation's length for all, which made bounds checks fail.
        unsafe { *self.chunks.index(chunk as usize).get_unchecked(j as usize) }
    }
}

/// The BVH nodes as the kernels bind them: rows of 16 bytes, one vector load each.
#[cfg(not(feature = "ray-query"))]
pub use gi_shared::bvh::BvhNodeRows as BvhNode;
#[cfg(feature = "ray-query")]
pub use spirv_std::ray_tracing::AccelerationStructure;

/// Defines a kernel that traces, once for both variants. It takes the entry point's attributes,
/// the names the body calls the [`Scene`] and the texture images ([`SceneTextures`]) by, then the
/// kernel's own parameters (set 0, and set 2 from binding 7 on) and its body:
///
/// ```ignore
/// traced_kernel! {
///     /// Docs.
///     #[spirv(compute(threads(64)))]
///     pub fn name(scene, images; #[spirv(global_invocation_id)] id: UVec3, ...) {
///         let hit = scene.closest_hit(&ray, images);
///         let mesh = scene.surfaces.meshes[0];
///     }
/// }
/// ```
///
/// The variant being built gets one entry point of that name with the scene's bindings (set 1,
/// and set 2 bindings 0 to 6) added in front of the kernel's parameters.
#[macro_export]
macro_rules! traced_kernel {
    (
        $(#[$attr:meta])*
        pub fn $name:ident(
            $scene:ident, $images:ident;
            $($(#[$param_attr:meta])* $param:ident: $ty:ty),* $(,)?
        ) $body:block
    ) => {
        #[cfg(feature = "ray-query")]
        $(#[$attr])*
        #[allow(
            clippy::too_many_arguments,
            reason = "an entry point takes one argument per binding"
        )]
        pub fn $name(
            #[spirv(descriptor_set = 1, binding = 0)]
            tlas: &[$crate::trace::AccelerationStructure; 1],
            #[spirv(storage_buffer, descriptor_set = 2, binding = 0)]
            instances: &[$crate::trace::GpuInstance],
            #[spirv(storage_buffer, descriptor_set = 2, binding = 1)]
            meshes: &[$crate::trace::GpuMesh],
            #[spirv(storage_buffer, descriptor_set = 2, binding = 2)]
            vertices: &$crate::trace::Chunks<$crate::trace::GpuVertex>,
            #[spirv(storage_buffer, descriptor_set = 2, binding = 3)]
            triangles: &$crate::trace::Chunks<$crate::trace::GpuTriangle>,
            #[spirv(storage_buffer, descriptor_set = 2, binding = 4)]
            materials: &[$crate::trace::GpuMaterial],
            #[spirv(storage_buffer, descriptor_set = 2, binding = 5)]
            textures: &[$crate::trace::GpuTexture],
            #[spirv(descriptor_set = 2, binding = 6)]
            $images: &$crate::trace::SceneTextures,
            $($(#[$param_attr])* $param: $ty),*
        ) {
            let $scene = $crate::trace::Scene {
                tlas,
                surfaces: $crate::trace::scene_surfaces(
                    instances, meshes, vertices, triangles, materials, textures,
                ),
            };
            $body
        }

        #[cfg(not(feature = "ray-query"))]
        $(#[$attr])*
        #[allow(
            clippy::too_many_arguments,
            reason = "an entry point takes one argument per binding"
        )]
        pub fn $name(
            #[spirv(storage_buffer, descriptor_set = 1, binding = 0)]
            bvh_nodes: &$crate::trace::Chunks<$crate::trace::BvhNode>,
            #[spirv(storage_buffer, descriptor_set = 2, binding = 0)]
            instances: &[$crate::trace::GpuInstance],
            #[spirv(storage_buffer, descriptor_set = 2, binding = 1)]
            meshes: &[$crate::trace::GpuMesh],
            #[spirv(storage_buffer, descriptor_set = 2, binding = 2)]
            vertices: &$crate::trace::Chunks<$crate::trace::GpuVertex>,
            #[spirv(storage_buffer, descriptor_set = 2, binding = 3)]
            triangles: &$crate::trace::Chunks<$crate::trace::GpuTriangle>,
            #[spirv(storage_buffer, descriptor_set = 2, binding = 4)]
            materials: &[$crate::trace::GpuMaterial],
            #[spirv(storage_buffer, descriptor_set = 2, binding = 5)]
            textures: &[$crate::trace::GpuTexture],
            #[spirv(descriptor_set = 2, binding = 6)]
            $images: &$crate::trace::SceneTextures,
            $($(#[$param_attr])* $param: $ty),*
        ) {
            let $scene = $crate::trace::Scene {
                nodes: $crate::trace::Chunked::new(bvh_nodes),
                surfaces: $crate::trace::scene_surfaces(
                    instances, meshes, vertices, triangles, materials, textures,
                ),
            };
            $body
        }
    };
}

/// Set 2 bindings 0 to 5 as [`SceneSurfaces`], the split arrays read through [`Chunked`].
#[inline(always)]
pub fn scene_surfaces<'a>(
    instances: &'a [GpuInstance],
    meshes: &'a [GpuMesh],
    vertices: &'a Chunks<GpuVertex>,
    triangles: &'a Chunks<GpuTriangle>,
    materials: &'a [GpuMaterial],
    textures: &'a [GpuTexture],
) -> SceneSurfaces<'a, Chunked<'a, GpuVertex>, Chunked<'a, GpuTriangle>> {
    SceneSurfaces {
        instances,
        meshes,
        vertices: Chunked::new(vertices),
        triangles: Chunked::new(triangles),
        materials,
        textures,
    }
}

/// The scene's geometry and materials as a tracing kernel sees it (built by [`traced_kernel!`]).
#[cfg(feature = "ray-query")]
#[derive(Clone, Copy)]
pub struct Scene<'a> {
    /// The top-level acceleration structure, bound as an array of one: a reference to the
    /// structure itself, kept in this composite, could not be loaded through (SPIR-V's logical
    /// addressing loads only from a variable or an access chain; indexing the array makes one).
    pub tlas: &'a [AccelerationStructure; 1],
    /// Set 2 bindings 0 to 5: the instances, meshes, vertices, triangles (in the software
    /// walk, each mesh's in its leaf order), materials and texture table.
    pub surfaces: SceneSurfaces<'a, Chunked<'a, GpuVertex>, Chunked<'a, GpuTriangle>>,
}

/// The scene's geometry and materials as a tracing kernel sees it (built by
/// [`traced_kernel!`](crate::traced_kernel)).
#[cfg(not(feature = "ray-query"))]
#[derive(Clone, Copy)]
pub struct Scene<'a> {
    /// The two-level BVH's nodes.
    pub nodes: Chunked<'a, BvhNode>,
    /// Set 2 bindings 0 to 5: the instances, meshes, vertices, triangles (in the software
    /// walk, each mesh's in its leaf order), materials and texture table.
    pub surfaces: SceneSurfaces<'a, Chunked<'a, GpuVertex>, Chunked<'a, GpuTriangle>>,
}

/// What traces, without the rest of the [`Scene`]: small enough for a closure to capture. With
/// ray queries it must be: a `Scene` captured whole would carry the acceleration structure's
/// handle inside a composite value, which SPIR-V's logical addressing cannot load through.
#[cfg(feature = "ray-query")]
#[derive(Clone, Copy)]
pub struct Tracer<'a> {
    tlas: &'a [AccelerationStructure; 1],
    surfaces: SceneSurfaces<'a, Chunked<'a, GpuVertex>, Chunked<'a, GpuTriangle>>,
}

/// What traces, without the rest of the [`Scene`]: small enough for a closure to capture.
#[cfg(not(feature = "ray-query"))]
#[derive(Clone, Copy)]
pub struct Tracer<'a> {
    bvh: gi_shared::bvh::BvhScene<
        'a,
        Chunked<'a, BvhNode>,
        Chunked<'a, GpuVertex>,
        Chunked<'a, GpuTriangle>,
    >,
}

#[cfg(feature = "ray-query")]
impl<'a> Scene<'a> {
    /// What traces, for a closure to capture.
    #[inline(always)]
    pub fn tracer(&self) -> Tracer<'a> {
        Tracer {
            tlas: self.tlas,
            surfaces: self.surfaces,
        }
    }
}

#[cfg(not(feature = "ray-query"))]
impl<'a> Scene<'a> {
    /// What traces, for a closure to capture.
    #[inline(always)]
    pub fn tracer(&self) -> Tracer<'a> {
        Tracer {
            bvh: gi_shared::bvh::BvhScene {
                nodes: self.nodes,
                surfaces: self.surfaces,
            },
        }
    }
}

// By reference: a copy of the whole `Scene` would carry the acceleration structure's handle
// inside a composite value, which SPIR-V's logical addressing cannot load through.
impl Scene<'_> {
    /// The closest hit of `ray`, or [`HitRecord::miss`]; `images` are the scene's textures, for
    /// the alpha test.
    #[inline(always)]
    pub fn closest_hit(&self, ray: &Ray, images: &SceneTextures) -> HitRecord {
        self.tracer().closest_hit(ray, &Bindless(images))
    }

    /// Whether `ray` hits anything between `t_min` and `t_max` (shadow rays); `images` as for
    /// [`Self::closest_hit`].
    #[inline(always)]
    pub fn any_hit(&self, ray: &Ray, images: &SceneTextures) -> bool {
        self.tracer().any_hit(ray, &Bindless(images))
    }
}

#[cfg(not(feature = "ray-query"))]
impl Tracer<'_> {
    /// The closest hit of `ray`, or [`HitRecord::miss`]; `images` are the scene's textures, for
    /// the alpha test.
    #[inline(always)]
    pub fn closest_hit(self, ray: &Ray, images: &Bindless<'_>) -> HitRecord {
        gi_shared::bvh::closest_hit(self.bvh, images, ray)
    }

    /// Whether `ray` hits anything between `t_min` and `t_max` (shadow rays); `images` as for
    /// [`Self::closest_hit`].
    #[inline(always)]
    pub fn any_hit(self, ray: &Ray, images: &Bindless<'_>) -> bool {
        gi_shared::bvh::any_hit(self.bvh, images, ray)
    }
}

#[cfg(feature = "ray-query")]
impl Tracer<'_> {
    /// The closest hit of `ray`, or [`HitRecord::miss`]; `images` are the scene's textures, for
    /// the alpha test.
    #[inline(always)]
    pub fn closest_hit(self, ray: &Ray, images: &Bindless<'_>) -> HitRecord {
        closest_hit(&self.tlas[0], self.surfaces, images, ray)
    }

    /// Whether `ray` hits anything between `t_min` and `t_max` (shadow rays); `images` as for
    /// [`Self::closest_hit`].
    #[inline(always)]
    pub fn any_hit(self, ray: &Ray, images: &Bindless<'_>) -> bool {
        any_hit(&self.tlas[0], self.surfaces, images, ray)
    }
}

/// Runs `query` (initialised) to its end, confirming each candidate, all of them triangles of
/// the non-opaque bottom levels (meshes flagged `MESH_ALPHA_TESTED`), where the alpha test finds
/// the surface. Opaque triangles are committed without a candidate.
#[cfg(feature = "ray-query")]
#[inline(always)]
fn run_alpha_tested(
    query: &spirv_std::ray_tracing::RayQuery,
    surfaces: SceneSurfaces<'_, Chunked<'_, GpuVertex>, Chunked<'_, GpuTriangle>>,
    images: &Bindless<'_>,
) {
    use spirv_std::ray_tracing::CandidateIntersection;
    unsafe {
        while query.proceed() {
            if matches!(
                query.get_candidate_intersection_type(),
                CandidateIntersection::Triangle
            ) && gi_shared::scene_data::alpha_visible(
                surfaces,
                images,
                query.get_candidate_intersection_instance_custom_index(),
                query.get_candidate_intersection_primitive_index(),
                query.get_candidate_intersection_barycentrics(),
            ) {
                query.confirm_intersection();
            }
        }
    }
}

/// The closest hit of `ray`, or [`HitRecord::miss`].
#[cfg(feature = "ray-query")]
fn closest_hit(
    tlas: &AccelerationStructure,
    surfaces: SceneSurfaces<'_, Chunked<'_, GpuVertex>, Chunked<'_, GpuTriangle>>,
    images: &Bindless<'_>,
    ray: &Ray,
) -> HitRecord {
    use spirv_std::glam::Vec3;
    use spirv_std::ray_tracing::{CommittedIntersection, RayFlags, RayQuery};
    // Ray queries leave such rays undefined; the software traversal misses them, and so must this.
    if !ray.is_traceable() {
        return HitRecord::miss();
    }
    spirv_std::ray_query!(let mut query);
    unsafe {
        // No ray flag forces opacity: only the alpha-tested meshes' bottom levels are non-opaque.
        query.initialize(
            tlas,
            RayFlags::NONE,
            0xff,
            Vec3::from(ray.origin),
            ray.t_min,
            Vec3::from(ray.direction),
            ray.t_max,
        );
        run_alpha_tested(query, surfaces, images);
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

/// Whether `ray` hits anything between `t_min` and `t_max` (shadow rays).
#[cfg(feature = "ray-query")]
fn any_hit(
    tlas: &AccelerationStructure,
    surfaces: SceneSurfaces<'_, Chunked<'_, GpuVertex>, Chunked<'_, GpuTriangle>>,
    images: &Bindless<'_>,
    ray: &Ray,
) -> bool {
    use spirv_std::glam::Vec3;
    use spirv_std::ray_tracing::{CommittedIntersection, RayFlags, RayQuery};
    if !ray.is_traceable() {
        return false;
    }
    spirv_std::ray_query!(let mut query);
    unsafe {
        query.initialize(
            tlas,
            RayFlags::TERMINATE_ON_FIRST_HIT,
            0xff,
            Vec3::from(ray.origin),
            ray.t_min,
            Vec3::from(ray.direction),
            ray.t_max,
        );
        run_alpha_tested(query, surfaces, images);
        !matches!(
            query.get_committed_intersection_type(),
            CommittedIntersection::None
        )
    }
}
