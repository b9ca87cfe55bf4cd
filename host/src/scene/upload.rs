//! The scene on the device. Its geometry ([`SceneGeometry`]) in the form the context's kernel
//! variant traces: bottom-level acceleration structures per mesh and a top-level one of instances
//! for ray queries, or the two-level BVH's node buffer for the software traversal; bound as set 1
//! of every kernel that traces. The whole scene ([`GpuScene`]) adds the shading data and lights,
//! bound as set 2 (see `vulkan::pipeline`), which every kernel that traces needs too: the
//! software traversal reads the triangles and vertices there.

use super::Scene;
use super::bvh::{Bvh, build_tlas, instance_bounds};
use super::gpu_data::{GpuShadingData, ShadingData, gpu_instance};
use super::lights::{GpuLights, LightSet};
use super::memory_report::SceneMemory;
use crate::error::{Error, Result};
use crate::kernels::KernelVariant;
use crate::vulkan::{
    AccelerationStructure, Buffer, Context, DescriptorSet, Instance, Resource, SceneSet, SceneSets,
    SplitBuffer, StagedWrites, TopLevel,
};
use gi_shared::gbuffer::PreviousTransform;
use gi_shared::scene_data::GpuInstance;
use glam::Mat4;

/// The scene's geometry on the device and its descriptor set (set 1 of every kernel that traces,
/// see `kernels/src/trace.rs`).
pub struct SceneGeometry {
    /// What the kernels trace.
    pub data: GeometryData,
    set: DescriptorSet,
}

/// The geometry in the context's variant.
pub enum GeometryData {
    /// Ray queries: one bottom level per mesh, one top level over the instances.
    RayQuery {
        /// Bottom levels, indexed like `Scene::meshes`.
        blases: Vec<AccelerationStructure>,
        /// Top level; instance custom index = instance index. Boxed: it is the enum's large
        /// variant.
        tlas: Box<TopLevel>,
    },
    /// Software traversal of the two-level BVH.
    Software {
        /// `gi_shared::bvh::BvhNode`s ([`Bvh::nodes`]), split.
        nodes: SplitBuffer,
    },
}

impl SceneGeometry {
    /// Uploads `scene` for the context's variant, with its descriptor set. The software variant
    /// uses `bvh` when given (built from this scene by [`Bvh::new`]) and builds it otherwise.
    pub fn new(ctx: &Context, scene: &Scene, bvh: Option<&Bvh>) -> Result<Self> {
        Self::with_binding_limit(ctx, scene, bvh, u64::MAX)
    }

    /// [`Self::new`], the software variant's nodes split into bindings of at most
    /// `max_binding_bytes` (and the device's `maxStorageBufferRange`): what the tests of the
    /// splitting use.
    pub fn with_binding_limit(
        ctx: &Context,
        scene: &Scene,
        bvh: Option<&Bvh>,
        max_binding_bytes: u64,
    ) -> Result<Self> {
        let data = GeometryData::new(ctx, scene, bvh, max_binding_bytes)?;
        let set = DescriptorSet::new(ctx, SceneSet::Geometry, &data.resources())?;
        Ok(Self { data, set })
    }
}

impl GeometryData {
    fn new(
        ctx: &Context,
        scene: &Scene,
        bvh: Option<&Bvh>,
        max_binding_bytes: u64,
    ) -> Result<Self> {
        match ctx.variant() {
            KernelVariant::RayQuery => {
                let blases = scene
                    .meshes
                    .iter()
                    .map(|mesh| {
                        let vertices: Vec<[f32; 3]> =
                            mesh.positions.iter().map(|p| p.to_array()).collect();
                        let indices: Vec<u32> = mesh.triangles.iter().flatten().copied().collect();
                        let alpha_tested = mesh.alpha_tested(&scene.materials);
                        AccelerationStructure::triangles(ctx, &vertices, &indices, alpha_tested)
                    })
                    .collect::<Result<Vec<_>>>()?;
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
                let tlas = Box::new(TopLevel::new(ctx, &instances)?);
                drop(instances);
                Ok(Self::RayQuery { blases, tlas })
            }
            KernelVariant::Software => {
                let built;
                let bvh = match bvh {
                    Some(b) => b,
                    None => {
                        built = Bvh::new(scene)?;
                        &built
                    }
                };
                let limit = max_binding_bytes.min(ctx.capabilities().max_storage_buffer_range);
                Ok(Self::Software {
                    nodes: SplitBuffer::device_local(ctx, "bvh nodes", &bvh.nodes, limit)?,
                })
            }
        }
    }

    /// The resources of set 1, in the order of [`SceneSet::binding_kinds`].
    /// Bytes of device memory: the acceleration structures, or the BVH's buffers.
    pub fn bytes(&self) -> u64 {
        match self {
            Self::RayQuery { blases, tlas } => {
                blases.iter().map(|b| b.bytes()).sum::<u64>() + tlas.bytes()
            }
            Self::Software { nodes } => nodes.bytes(),
        }
    }

    fn resources(&self) -> Vec<Resource<'_>> {
        match self {
            Self::RayQuery { tlas, .. } => vec![Resource::AccelerationStructure(tlas.handle())],
            Self::Software { nodes } => vec![Resource::Split(nodes)],
        }
    }
}

/// A scene on the device: its geometry (set 1), shading data and lights, the descriptor set
/// that binds the last two (set 2), and the instances' previous transforms (what the G-buffer's
/// motion vectors of moving objects need, bound in the G-buffer kernel's set 0).
///
/// [`GpuScene::set_pose`] moves its instances in place; textures, vertices, triangles and
/// bottom levels are written once, at the upload.
pub struct GpuScene {
    /// The geometry, with set 1.
    pub geometry: SceneGeometry,
    /// The shading data.
    pub shading: GpuShadingData,
    /// The lights.
    pub lights: GpuLights,
    set: DescriptorSet,
    previous_transforms: Buffer,
    object_motion: bool,
    /// Each instance's mesh and object-to-world transform, as the device has them.
    posed: Vec<(u32, Mat4)>,
    last_pose: PoseUpdate,
}

/// What one [`GpuScene::set_pose`] wrote: O(instances) at most, nothing that depends on the
/// scene's triangle or texel count.
#[derive(Clone, Copy, Debug, Default, PartialEq, Eq)]
pub struct PoseUpdate {
    /// Instances whose transform differs from the pose before (their records were rewritten).
    pub moved_instances: u32,
    /// Lights rewritten: the run from the first to the last light whose record changed.
    pub lights: u32,
    /// Light clusters rewritten (`gi_shared::light_clusters`), the same way.
    pub light_clusters: u32,
    /// Whether the top level was built again (software: on the CPU, its nodes uploaded; ray
    /// queries: on the device): whenever an instance moved.
    pub top_level_rebuilt: bool,
    /// Bytes copied to device-local buffers: instance records, top-level nodes or instance
    /// records of the acceleration structure, lights, light clusters.
    pub uploaded_bytes: u64,
    /// Bytes written to the host-visible previous transforms.
    pub parameter_bytes: u64,
}

/// The previous-transform buffer's contents for instances now at `current` that were at
/// `previous` in the last frame: one [`PreviousTransform`] per instance when any moved, else one
/// [`PreviousTransform::STATIC`] (no object motion).
pub fn previous_transforms(current: &[Mat4], previous: &[Mat4]) -> Vec<PreviousTransform> {
    let moved = |(c, p): (&Mat4, &Mat4)| c != p;
    if !current.iter().zip(previous).any(moved) {
        return vec![PreviousTransform::STATIC];
    }
    current
        .iter()
        .zip(previous)
        .map(|(c, p)| {
            if c == p {
                PreviousTransform::STATIC
            } else {
                let rows = p.transpose().to_cols_array_2d();
                PreviousTransform::moved_from([rows[0], rows[1], rows[2]])
            }
        })
        .collect()
}

impl GpuScene {
    /// Binds the uploaded parts of `scene` as one scene.
    pub fn new(
        ctx: &Context,
        scene: &Scene,
        geometry: SceneGeometry,
        shading: GpuShadingData,
        lights: GpuLights,
    ) -> Result<Self> {
        let mut resources = shading.resources();
        resources.extend(lights.resources());
        let set = DescriptorSet::new(ctx, SceneSet::Shading, &resources)?;
        drop(resources);
        let previous_transforms =
            Buffer::parameters(ctx, "previous transforms", &[PreviousTransform::STATIC])?;
        Ok(Self {
            geometry,
            shading,
            lights,
            set,
            previous_transforms,
            object_motion: false,
            posed: scene
                .instances
                .iter()
                .map(|i| (i.mesh, i.transform))
                .collect(),
            last_pose: PoseUpdate::default(),
        })
    }

    /// Moves the scene on the device to `scene`'s current pose (after [`Scene::set_time`]), lit
    /// by `lights` (made from the posed scene), with `previous` the instances' object-to-world
    /// transforms in the frame before (the last pose's `Scene::pose_at`): the G-buffer then gives
    /// moving objects their motion vectors.
    ///
    /// Writes in place only what the pose changed ([`GpuScene::last_pose`] says what): the
    /// records of the instances whose transform differs from the device's, the top level (in
    /// the software variant built on the CPU over the instances' bounds, its nodes written over
    /// the first of the node buffer; with ray queries its instance records rewritten and the
    /// structure rebuilt on the device), the lights that changed, and the previous transforms.
    /// Every buffer keeps its handle, so the descriptor sets stay valid. Every submission waits
    /// for its completion, so no command still reads what this writes.
    ///
    /// Errors when `previous` or `scene` do not have the uploaded scene's instance count, when
    /// an instance shows another mesh, or when `lights` were made from another scene or sky:
    /// such changes need a new upload.
    pub fn set_pose(
        &mut self,
        ctx: &Context,
        scene: &Scene,
        lights: &LightSet,
        previous: &[Mat4],
    ) -> Result<()> {
        let count = |what: &'static str, n: usize| Error::InvalidArgument {
            name: what,
            why: format!(
                "{n} for a scene of {} instances on the device ({}); set_pose moves \
                 instances, a scene of others needs a new upload",
                self.posed.len(),
                scene.source.display()
            ),
        };
        if previous.len() != self.posed.len() {
            return Err(count("previous transforms", previous.len()));
        }
        if scene.instances.len() != self.posed.len() {
            return Err(count("scene instances", scene.instances.len()));
        }
        let mut moved = Vec::new();
        for (i, (inst, &(mesh, transform))) in scene.instances.iter().zip(&self.posed).enumerate() {
            if inst.mesh != mesh {
                return Err(Error::InvalidArgument {
                    name: "scene instances",
                    why: format!(
                        "{}: instance {i} ({:?}) shows mesh {} where the device has mesh {mesh}; \
                         set_pose moves instances, changing them needs a new upload",
                        scene.source.display(),
                        inst.name,
                        inst.mesh
                    ),
                });
            }
            if inst.transform != transform {
                moved.push(i);
            }
        }
        let mut writes = StagedWrites::new();
        let [lights_written, clusters_written] = self.lights.stage_pose(lights, &mut writes)?;
        if let Some(buffer) = self.shading.instances() {
            for &i in &moved {
                let offset = (i * size_of::<GpuInstance>()) as u64;
                writes.write(buffer, offset, &[gpu_instance(&scene.instances[i])])?;
            }
        }
        let rebuild = match &mut self.geometry.data {
            _ if moved.is_empty() => None,
            GeometryData::Software { nodes } => {
                // The top level is the first `tlas_node_count` nodes, whatever the pose.
                let (top, _) = build_tlas(&instance_bounds(scene));
                nodes.stage(&mut writes, 0, &top)?;
                None
            }
            GeometryData::RayQuery { tlas, .. } => {
                for &i in &moved {
                    tlas.set_transform(i, scene.instances[i].transform_3x4())?;
                }
                let tlas: &TopLevel = tlas;
                for &i in &moved {
                    tlas.stage_record(i, &mut writes)?;
                }
                Some(tlas)
            }
        };
        let uploaded_bytes = writes.bytes();
        if uploaded_bytes > 0 || rebuild.is_some() {
            writes.submit(ctx, |cmd| match rebuild {
                Some(tlas) => tlas.record_rebuild(ctx, cmd),
                None => Ok(()),
            })??;
        }
        for &i in &moved {
            self.posed[i].1 = scene.instances[i].transform;
        }
        let current: Vec<Mat4> = scene.instances.iter().map(|i| i.transform).collect();
        let transforms = previous_transforms(&current, previous);
        let motion = transforms.iter().any(|t| t.moved != 0);
        let mut parameter_bytes = 0;
        if motion || self.object_motion {
            let capacity = self.previous_transforms.size as usize / size_of::<PreviousTransform>();
            if transforms.len() > capacity {
                self.previous_transforms =
                    Buffer::parameters(ctx, "previous transforms", &transforms)?;
            } else if motion {
                self.previous_transforms
                    .write(bytemuck::cast_slice(&transforms))?;
            } else {
                // Motion stopped: every entry of the larger buffer must say so.
                let still = vec![PreviousTransform::STATIC; capacity];
                self.previous_transforms
                    .write(bytemuck::cast_slice(&still))?;
            }
            parameter_bytes = self.previous_transforms.size;
        }
        self.object_motion = motion;
        self.last_pose = PoseUpdate {
            moved_instances: moved.len() as u32,
            lights: lights_written,
            light_clusters: clusters_written,
            top_level_rebuilt: !moved.is_empty(),
            uploaded_bytes,
            parameter_bytes,
        };
        Ok(())
    }

    /// What the last [`GpuScene::set_pose`] wrote (all zero before the first).
    pub fn last_pose(&self) -> PoseUpdate {
        self.last_pose
    }

    /// Whether an instance moved between the previous pose and this one ([`GpuScene::set_pose`]).
    pub fn has_object_motion(&self) -> bool {
        self.object_motion
    }

    /// The instances' previous transforms (`gi_shared::gbuffer::PreviousTransform`s), for the
    /// G-buffer kernel's set 0.
    pub fn previous_transforms(&self) -> &Buffer {
        &self.previous_transforms
    }

    /// Uploads `scene` lit by its emitters and `environment` (importance-sampled where
    /// `sample_environment`), its BVH built here: the lights and the scene on the device.
    pub fn upload_lit(
        ctx: &Context,
        scene: &Scene,
        environment: Option<super::lights::Environment>,
        sample_environment: bool,
    ) -> Result<(LightSet, Self)> {
        let shading = ShadingData::new(scene)?;
        let lights = LightSet::new(scene, environment, sample_environment);
        let gpu = Self::upload(ctx, scene, None, &shading, &lights)?;
        Ok((lights, gpu))
    }

    /// Uploads `scene` with its shading data and lights (`bvh` as for [`SceneGeometry::new`]).
    pub fn upload(
        ctx: &Context,
        scene: &Scene,
        bvh: Option<&Bvh>,
        shading: &ShadingData,
        lights: &LightSet,
    ) -> Result<Self> {
        Self::upload_with_binding_limit(ctx, scene, bvh, shading, lights, u64::MAX)
    }

    /// [`Self::upload`], with the arrays that scale with the triangle count (vertices,
    /// triangles, the software variant's BVH nodes) split into storage bindings of at most
    /// `max_binding_bytes` (and the device's `maxStorageBufferRange`, which alone decides in
    /// [`Self::upload`]): the tests force tiny bindings with it. Errors, naming the array and
    /// its size, when `gi_shared::layout::SCENE_BUFFER_CHUNKS` bindings cannot hold one.
    pub fn upload_with_binding_limit(
        ctx: &Context,
        scene: &Scene,
        bvh: Option<&Bvh>,
        shading: &ShadingData,
        lights: &LightSet,
        max_binding_bytes: u64,
    ) -> Result<Self> {
        let geometry = SceneGeometry::with_binding_limit(ctx, scene, bvh, max_binding_bytes)?;
        let shading = GpuShadingData::with_binding_limit(ctx, shading, max_binding_bytes)?;
        let lights = GpuLights::new(ctx, lights)?;
        Self::new(ctx, scene, geometry, shading, lights)
    }

    /// The sets every kernel that traces is dispatched with.
    pub fn sets(&self) -> SceneSets<'_> {
        SceneSets {
            geometry: &self.geometry.set,
            shading: &self.set,
        }
    }

    /// The scene's device memory by part.
    pub fn memory(&self) -> SceneMemory {
        SceneMemory {
            geometry: self.shading.geometry_bytes(),
            bvh: self.geometry.data.bytes(),
            textures: self.shading.texture_bytes(),
            lights: self.lights.bytes(),
        }
    }
}
