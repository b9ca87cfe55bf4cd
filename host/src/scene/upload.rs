//! The scene's geometry on the device, in the form the context's kernel variant traces: bottom-
//! level acceleration structures per mesh and a top-level one of instances for ray queries, or the
//! flattened BVH's node and triangle buffers for the software traversal.

use super::Scene;
use super::bvh::{Bvh, TriangleId};
use crate::error::Result;
use crate::kernels::KernelVariant;
use crate::vulkan::{AccelerationStructure, BindingKind, Buffer, Context, Instance, Resource};
use ash::vk;

/// Geometry bound as the first bindings of set 0 of every kernel that traces (see
/// `kernels/src/trace.rs`).
pub enum SceneGeometry {
    /// Ray queries: one bottom level per mesh, one top level over the instances.
    RayQuery {
        /// Bottom levels, indexed like `Scene::meshes`.
        blases: Vec<AccelerationStructure>,
        /// Top level; instance custom index = instance index.
        tlas: AccelerationStructure,
    },
    /// Software traversal of the flattened BVH.
    Software {
        /// `gi_shared::bvh::BvhNode`s.
        nodes: Buffer,
        /// `gi_shared::bvh::BvhTriangle`s.
        triangles: Buffer,
    },
}

/// Flattens every instance's triangles to world space for the software BVH, flagging those of
/// mirroring instances so that both tracing variants agree on the front face.
pub fn build_bvh(scene: &Scene) -> Result<Bvh> {
    let (tris, ids): (Vec<[[f32; 3]; 3]>, Vec<TriangleId>) = scene
        .world_triangles()
        .map(|t| {
            (
                t.vertices.map(|v| v.to_array()),
                TriangleId {
                    instance: t.instance,
                    primitive: t.primitive,
                    mirrored: scene
                        .instances
                        .get(t.instance as usize)
                        .is_some_and(|i| i.is_mirrored()),
                },
            )
        })
        .unzip();
    Bvh::build(&tris, &ids)
}

impl SceneGeometry {
    /// Uploads `scene` for the context's variant. The software variant uses `bvh` when given
    /// (built from this scene by [`build_bvh`]) and builds it otherwise.
    pub fn new(ctx: &Context, scene: &Scene, bvh: Option<&Bvh>) -> Result<Self> {
        match ctx.variant() {
            KernelVariant::RayQuery => {
                let mut blases = Vec::with_capacity(scene.meshes.len());
                for mesh in &scene.meshes {
                    let vertices: Vec<[f32; 3]> =
                        mesh.positions.iter().map(|p| p.to_array()).collect();
                    let indices: Vec<u32> = mesh.triangles.iter().flatten().copied().collect();
                    match AccelerationStructure::triangles(ctx, &vertices, &indices) {
                        Ok(b) => blases.push(b),
                        Err(e) => {
                            blases.into_iter().for_each(|b| b.destroy(ctx));
                            return Err(e);
                        }
                    }
                }
                let instances: Vec<Instance<'_>> = scene
                    .instances
                    .iter()
                    .enumerate()
                    .map(|(i, inst)| Instance {
                        blas: &blases[inst.mesh as usize],
                        transform: inst.transform_3x4(),
                        custom_index: i as u32,
                    })
                    .collect();
                let tlas = AccelerationStructure::instances(ctx, &instances);
                drop(instances);
                match tlas {
                    Ok(tlas) => Ok(Self::RayQuery { blases, tlas }),
                    Err(e) => {
                        blases.into_iter().for_each(|b| b.destroy(ctx));
                        Err(e)
                    }
                }
            }
            KernelVariant::Software => {
                let built;
                let bvh = match bvh {
                    Some(b) => b,
                    None => {
                        built = build_bvh(scene)?;
                        &built
                    }
                };
                let usage = vk::BufferUsageFlags::empty();
                let nodes = Buffer::device_local(ctx, "bvh nodes", &bvh.nodes, usage)?;
                match Buffer::device_local(ctx, "bvh triangles", &bvh.triangles, usage) {
                    Ok(triangles) => Ok(Self::Software { nodes, triangles }),
                    Err(e) => {
                        nodes.destroy(ctx);
                        Err(e)
                    }
                }
            }
        }
    }

    /// The binding kinds the geometry occupies, from binding 0.
    pub fn binding_kinds(&self) -> Vec<BindingKind> {
        match self {
            Self::RayQuery { .. } => vec![BindingKind::AccelerationStructure],
            Self::Software { .. } => vec![BindingKind::StorageBuffer; 2],
        }
    }

    /// The resources for [`SceneGeometry::binding_kinds`].
    pub fn resources(&self) -> Vec<Resource<'_>> {
        match self {
            Self::RayQuery { tlas, .. } => vec![Resource::AccelerationStructure(tlas.handle)],
            Self::Software { nodes, triangles } => {
                vec![Resource::Buffer(nodes), Resource::Buffer(triangles)]
            }
        }
    }

    /// Frees the device copies.
    pub fn destroy(self, ctx: &Context) {
        match self {
            Self::RayQuery { blases, tlas } => {
                tlas.destroy(ctx);
                blases.into_iter().for_each(|b| b.destroy(ctx));
            }
            Self::Software { nodes, triangles } => {
                nodes.destroy(ctx);
                triangles.destroy(ctx);
            }
        }
    }
}
