//! Acceleration structures for the ray-query variant: one bottom level per triangle mesh, one top
//! level of instances, both built on the device.

use super::context::{Context, SharedDevice};
use super::memory::{Buffer, StagedWrites, memory_barrier};
use crate::error::{Error, Result, VkContext};
use ash::vk;
use gpu_allocator::MemoryLocation;
use std::sync::Arc;

/// A built acceleration structure and the buffer that holds it, freed when dropped.
pub struct AccelerationStructure {
    /// The handle kernels bind.
    pub handle: vk::AccelerationStructureKHR,
    address: vk::DeviceAddress,
    // Dropped after the structure it holds (fields drop after `drop`).
    _buffer: Buffer,
    shared: Arc<SharedDevice>,
}

/// One instance of a bottom-level structure in a top-level one.
pub struct Instance<'a> {
    /// The mesh.
    pub blas: &'a AccelerationStructure,
    /// Row-major 3x4 object-to-world transform.
    pub transform: [[f32; 4]; 3],
    /// Reported to kernels as the instance custom index (24 bits).
    pub custom_index: u32,
}

const BUILD_INPUT: vk::BufferUsageFlags = vk::BufferUsageFlags::from_raw(
    vk::BufferUsageFlags::ACCELERATION_STRUCTURE_BUILD_INPUT_READ_ONLY_KHR.as_raw()
        | vk::BufferUsageFlags::SHADER_DEVICE_ADDRESS.as_raw(),
);

fn accel_ext(ctx: &Context) -> Result<&ash::khr::acceleration_structure::Device> {
    ctx.shared
        .accel
        .as_ref()
        .ok_or_else(|| Error::MissingFeature {
            device: ctx.capabilities().name.clone(),
            feature: "VK_KHR_acceleration_structure (context not created for ray queries)".into(),
            needed_for: "acceleration structure builds".into(),
        })
}

impl AccelerationStructure {
    /// Bytes of device memory the structure takes.
    pub fn bytes(&self) -> u64 {
        self._buffer.size
    }

    /// Builds a bottom-level structure over `vertices` indexed by `indices` (three per triangle).
    /// Its triangles are opaque unless `alpha_tested`: then every hit on them is a candidate
    /// that the kernels' alpha test confirms or not (`kernels/src/trace.rs`).
    pub fn triangles(
        ctx: &Context,
        vertices: &[[f32; 3]],
        indices: &[u32],
        alpha_tested: bool,
    ) -> Result<Self> {
        if indices.is_empty() || !indices.len().is_multiple_of(3) {
            return Err(Error::InvalidArgument {
                name: "indices",
                why: format!("{} indices do not make whole triangles", indices.len()),
            });
        }
        if let Some(bad) = indices.iter().find(|&&i| i as usize >= vertices.len()) {
            return Err(Error::InvalidArgument {
                name: "indices",
                why: format!("index {bad} out of range of {} vertices", vertices.len()),
            });
        }
        let vb = Buffer::device_local(ctx, "blas vertices", vertices, BUILD_INPUT)?;
        let ib = Buffer::device_local(ctx, "blas indices", indices, BUILD_INPUT)?;
        let triangles = vk::AccelerationStructureGeometryTrianglesDataKHR::default()
            .vertex_format(vk::Format::R32G32B32_SFLOAT)
            .vertex_data(vk::DeviceOrHostAddressConstKHR {
                device_address: vb.device_address(ctx),
            })
            .vertex_stride(12)
            .max_vertex(vertices.len().saturating_sub(1) as u32)
            .index_type(vk::IndexType::UINT32)
            .index_data(vk::DeviceOrHostAddressConstKHR {
                device_address: ib.device_address(ctx),
            });
        let geometry = vk::AccelerationStructureGeometryKHR::default()
            .geometry_type(vk::GeometryTypeKHR::TRIANGLES)
            .geometry(vk::AccelerationStructureGeometryDataKHR { triangles })
            .flags(if alpha_tested {
                vk::GeometryFlagsKHR::empty()
            } else {
                vk::GeometryFlagsKHR::OPAQUE
            });
        // The inputs go when this returns: the build has finished by then.
        Self::build(
            ctx,
            vk::AccelerationStructureTypeKHR::BOTTOM_LEVEL,
            geometry,
            (indices.len() / 3) as u32,
        )
    }

    /// Creates the structure of `ty` for `primitive_count` primitives of `geometry`, unbuilt,
    /// and a scratch buffer for its builds (aligned for the device).
    fn create(
        ctx: &Context,
        ty: vk::AccelerationStructureTypeKHR,
        geometry: vk::AccelerationStructureGeometryKHR<'_>,
        primitive_count: u32,
    ) -> Result<(Self, Scratch)> {
        let ext = accel_ext(ctx)?;
        let geometries = [geometry];
        let info = build_info(ty, &geometries);
        let mut sizes = vk::AccelerationStructureBuildSizesInfoKHR::default();
        unsafe {
            ext.get_acceleration_structure_build_sizes(
                vk::AccelerationStructureBuildTypeKHR::DEVICE,
                &info,
                &[primitive_count],
                &mut sizes,
            )
        };
        let buffer = Buffer::new(
            ctx,
            "acceleration structure",
            sizes.acceleration_structure_size,
            vk::BufferUsageFlags::ACCELERATION_STRUCTURE_STORAGE_KHR
                | vk::BufferUsageFlags::SHADER_DEVICE_ADDRESS,
            MemoryLocation::GpuOnly,
        )?;
        let create = vk::AccelerationStructureCreateInfoKHR::default()
            .buffer(buffer.handle)
            .size(sizes.acceleration_structure_size)
            .ty(ty);
        let handle = unsafe { ext.create_acceleration_structure(&create, None) }
            .vk("vkCreateAccelerationStructureKHR")?;
        // From here on, dropping `created` frees the structure and its buffer.
        let mut created = Self {
            handle,
            address: 0,
            _buffer: buffer,
            shared: ctx.shared.clone(),
        };
        created.address = unsafe {
            ext.get_acceleration_structure_device_address(
                &vk::AccelerationStructureDeviceAddressInfoKHR::default()
                    .acceleration_structure(handle),
            )
        };
        let align = u64::from(ctx.capabilities().accel_scratch_alignment.max(1));
        let buffer = Buffer::new(
            ctx,
            "acceleration structure scratch",
            sizes.build_scratch_size + align,
            vk::BufferUsageFlags::SHADER_DEVICE_ADDRESS,
            MemoryLocation::GpuOnly,
        )?;
        let address = buffer.device_address(ctx).div_ceil(align) * align;
        Ok((created, Scratch { buffer, address }))
    }

    /// Records a full build of the structure over `geometry` with `scratch`.
    fn record_build(
        &self,
        ext: &ash::khr::acceleration_structure::Device,
        cmd: vk::CommandBuffer,
        ty: vk::AccelerationStructureTypeKHR,
        geometry: vk::AccelerationStructureGeometryKHR<'_>,
        primitive_count: u32,
        scratch: &Scratch,
    ) {
        let geometries = [geometry];
        let info = build_info(ty, &geometries)
            .dst_acceleration_structure(self.handle)
            .scratch_data(vk::DeviceOrHostAddressKHR {
                device_address: scratch.address,
            });
        let range =
            [vk::AccelerationStructureBuildRangeInfoKHR::default()
                .primitive_count(primitive_count)];
        unsafe { ext.cmd_build_acceleration_structures(cmd, &[info], &[&range]) };
    }

    fn build(
        ctx: &Context,
        ty: vk::AccelerationStructureTypeKHR,
        geometry: vk::AccelerationStructureGeometryKHR<'_>,
        primitive_count: u32,
    ) -> Result<Self> {
        let ext = accel_ext(ctx)?;
        let (built, scratch) = Self::create(ctx, ty, geometry, primitive_count)?;
        ctx.submit(|cmd| built.record_build(ext, cmd, ty, geometry, primitive_count, &scratch))?;
        Ok(built)
    }
}

/// A build's scratch memory: the buffer and its aligned device address.
struct Scratch {
    buffer: Buffer,
    address: vk::DeviceAddress,
}

fn build_info<'a>(
    ty: vk::AccelerationStructureTypeKHR,
    geometries: &'a [vk::AccelerationStructureGeometryKHR<'a>],
) -> vk::AccelerationStructureBuildGeometryInfoKHR<'a> {
    vk::AccelerationStructureBuildGeometryInfoKHR::default()
        .ty(ty)
        .flags(vk::BuildAccelerationStructureFlagsKHR::PREFER_FAST_TRACE)
        .mode(vk::BuildAccelerationStructureModeKHR::BUILD)
        .geometries(geometries)
}

/// Bytes of one `VkAccelerationStructureInstanceKHR`.
const INSTANCE_RECORD_BYTES: u64 = size_of::<vk::AccelerationStructureInstanceKHR>() as u64;

/// A top level over instances that keeps what a rebuild needs (the instance records, on the
/// host and in a device buffer, and the scratch memory), so that moved instances cost a rewrite
/// of their records and one build on the device ([`TopLevel::record_rebuild`]). The rebuild goes
/// into the same structure: its handle, and the descriptor sets that bind it, stay valid.
///
/// A full build rather than an update (`ALLOW_UPDATE`, mode `UPDATE`): an update keeps the tree
/// of the first build and only refits its boxes, which degrades as objects travel, and over
/// instances a build is cheap.
pub struct TopLevel {
    structure: AccelerationStructure,
    records: Vec<vk::AccelerationStructureInstanceKHR>,
    instances: Buffer,
    scratch: Scratch,
}

impl TopLevel {
    /// Builds a top level over `instances`.
    pub fn new(ctx: &Context, instances: &[Instance<'_>]) -> Result<Self> {
        if instances.is_empty() {
            return Err(Error::InvalidArgument {
                name: "instances",
                why: "a top-level structure needs at least one instance".into(),
            });
        }
        let records: Vec<vk::AccelerationStructureInstanceKHR> = instances
            .iter()
            .map(|i| vk::AccelerationStructureInstanceKHR {
                transform: transform_matrix(i.transform),
                instance_custom_index_and_mask: vk::Packed24_8::new(i.custom_index, 0xff),
                instance_shader_binding_table_record_offset_and_flags: vk::Packed24_8::new(
                    0,
                    vk::GeometryInstanceFlagsKHR::TRIANGLE_FACING_CULL_DISABLE.as_raw() as u8,
                ),
                acceleration_structure_reference: vk::AccelerationStructureReferenceKHR {
                    device_handle: i.blas.address,
                },
            })
            .collect();
        let instances =
            Buffer::device_local(ctx, "tlas instances", record_bytes(&records), BUILD_INPUT)?;
        let geometry = instance_geometry(ctx, &instances);
        let ty = vk::AccelerationStructureTypeKHR::TOP_LEVEL;
        let count = records.len() as u32;
        let (structure, scratch) = AccelerationStructure::create(ctx, ty, geometry, count)?;
        let top = Self {
            structure,
            records,
            instances,
            scratch,
        };
        ctx.submit(|cmd| top.record_rebuild(ctx, cmd))??;
        Ok(top)
    }

    /// The handle kernels bind.
    pub fn handle(&self) -> vk::AccelerationStructureKHR {
        self.structure.handle
    }

    /// Bytes of device memory: the structure, its instance records and its scratch memory.
    pub fn bytes(&self) -> u64 {
        self.structure.bytes() + self.instances.size + self.scratch.buffer.size
    }

    /// Gives instance `index` the row-major 3x4 object-to-world `transform`, on the host: queue
    /// its record with [`TopLevel::stage_record`], then [`TopLevel::record_rebuild`]. Errors when
    /// there is no such instance.
    pub fn set_transform(&mut self, index: usize, transform: [[f32; 4]; 3]) -> Result<()> {
        let count = self.records.len();
        let record = self.records.get_mut(index).ok_or(Error::InvalidArgument {
            name: "instance",
            why: format!("instance {index} of a top level of {count}"),
        })?;
        record.transform = transform_matrix(transform);
        Ok(())
    }

    /// Queues in `writes` the rewrite of instance `index`'s record on the device. Errors when
    /// there is no such instance.
    pub fn stage_record<'a>(&'a self, index: usize, writes: &mut StagedWrites<'a>) -> Result<()> {
        let record = self.records.get(index).ok_or(Error::InvalidArgument {
            name: "instance",
            why: format!("instance {index} of a top level of {}", self.records.len()),
        })?;
        let bytes = record_bytes(std::slice::from_ref(record));
        writes.write(&self.instances, index as u64 * INSTANCE_RECORD_BYTES, bytes)
    }

    /// Records a build over the instance records (written before in the same submission, or
    /// earlier), followed by a barrier that makes it visible to every later kernel's ray
    /// queries.
    pub fn record_rebuild(&self, ctx: &Context, cmd: vk::CommandBuffer) -> Result<()> {
        let ext = accel_ext(ctx)?;
        self.structure.record_build(
            ext,
            cmd,
            vk::AccelerationStructureTypeKHR::TOP_LEVEL,
            instance_geometry(ctx, &self.instances),
            self.records.len() as u32,
            &self.scratch,
        );
        memory_barrier(
            ctx,
            cmd,
            (
                vk::PipelineStageFlags::ACCELERATION_STRUCTURE_BUILD_KHR,
                vk::AccessFlags::ACCELERATION_STRUCTURE_WRITE_KHR,
            ),
            (
                vk::PipelineStageFlags::COMPUTE_SHADER
                    | vk::PipelineStageFlags::ACCELERATION_STRUCTURE_BUILD_KHR,
                vk::AccessFlags::ACCELERATION_STRUCTURE_READ_KHR
                    | vk::AccessFlags::ACCELERATION_STRUCTURE_WRITE_KHR,
            ),
        );
        Ok(())
    }
}

fn transform_matrix(rows: [[f32; 4]; 3]) -> vk::TransformMatrixKHR {
    let mut matrix = [0.0f32; 12];
    for (r, row) in rows.iter().enumerate() {
        matrix[r * 4..r * 4 + 4].copy_from_slice(row);
    }
    vk::TransformMatrixKHR { matrix }
}

fn record_bytes(records: &[vk::AccelerationStructureInstanceKHR]) -> &[u8] {
    // SAFETY: the instance struct is plain old data laid out as Vulkan expects.
    unsafe { std::slice::from_raw_parts(records.as_ptr().cast::<u8>(), size_of_val(records)) }
}

fn instance_geometry<'a>(
    ctx: &Context,
    instances: &Buffer,
) -> vk::AccelerationStructureGeometryKHR<'a> {
    let data = vk::AccelerationStructureGeometryInstancesDataKHR::default().data(
        vk::DeviceOrHostAddressConstKHR {
            device_address: instances.device_address(ctx),
        },
    );
    vk::AccelerationStructureGeometryKHR::default()
        .geometry_type(vk::GeometryTypeKHR::INSTANCES)
        .geometry(vk::AccelerationStructureGeometryDataKHR { instances: data })
        // Opacity is the bottom levels' (per mesh), not forced here.
        .flags(vk::GeometryFlagsKHR::empty())
}

impl Drop for AccelerationStructure {
    fn drop(&mut self) {
        // Made only where the extension is loaded.
        if let Some(ext) = &self.shared.accel {
            unsafe { ext.destroy_acceleration_structure(self.handle, None) };
        }
    }
}
