//! Acceleration structures for the ray-query variant: one bottom level per triangle mesh, one top
//! level of instances, both built on the device.

use super::context::{Context, SharedDevice};
use super::memory::Buffer;
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

    /// Builds a top-level structure over `instances`.
    pub fn instances(ctx: &Context, instances: &[Instance<'_>]) -> Result<Self> {
        if instances.is_empty() {
            return Err(Error::InvalidArgument {
                name: "instances",
                why: "a top-level structure needs at least one instance".into(),
            });
        }
        let raw: Vec<vk::AccelerationStructureInstanceKHR> = instances
            .iter()
            .map(|i| {
                let mut matrix = [0.0f32; 12];
                for (r, row) in i.transform.iter().enumerate() {
                    matrix[r * 4..r * 4 + 4].copy_from_slice(row);
                }
                vk::AccelerationStructureInstanceKHR {
                    transform: vk::TransformMatrixKHR { matrix },
                    instance_custom_index_and_mask: vk::Packed24_8::new(i.custom_index, 0xff),
                    instance_shader_binding_table_record_offset_and_flags: vk::Packed24_8::new(
                        0,
                        vk::GeometryInstanceFlagsKHR::TRIANGLE_FACING_CULL_DISABLE.as_raw() as u8,
                    ),
                    acceleration_structure_reference: vk::AccelerationStructureReferenceKHR {
                        device_handle: i.blas.address,
                    },
                }
            })
            .collect();
        // SAFETY: the instance struct is plain old data laid out as Vulkan expects.
        let bytes = unsafe {
            std::slice::from_raw_parts(
                raw.as_ptr().cast::<u8>(),
                std::mem::size_of_val(raw.as_slice()),
            )
        };
        let ib = Buffer::device_local(ctx, "tlas instances", bytes, BUILD_INPUT)?;
        let data = vk::AccelerationStructureGeometryInstancesDataKHR::default().data(
            vk::DeviceOrHostAddressConstKHR {
                device_address: ib.device_address(ctx),
            },
        );
        let geometry = vk::AccelerationStructureGeometryKHR::default()
            .geometry_type(vk::GeometryTypeKHR::INSTANCES)
            .geometry(vk::AccelerationStructureGeometryDataKHR { instances: data })
            // Opacity is the bottom levels' (per mesh), not forced here.
            .flags(vk::GeometryFlagsKHR::empty());
        Self::build(
            ctx,
            vk::AccelerationStructureTypeKHR::TOP_LEVEL,
            geometry,
            raw.len() as u32,
        )
    }

    fn build(
        ctx: &Context,
        ty: vk::AccelerationStructureTypeKHR,
        geometry: vk::AccelerationStructureGeometryKHR<'_>,
        primitive_count: u32,
    ) -> Result<Self> {
        let ext = accel_ext(ctx)?;
        let geometries = [geometry];
        let mut info = vk::AccelerationStructureBuildGeometryInfoKHR::default()
            .ty(ty)
            .flags(vk::BuildAccelerationStructureFlagsKHR::PREFER_FAST_TRACE)
            .mode(vk::BuildAccelerationStructureModeKHR::BUILD)
            .geometries(&geometries);
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
        // From here on, dropping `built` frees the structure and its buffer.
        let mut built = Self {
            handle,
            address: 0,
            _buffer: buffer,
            shared: ctx.shared.clone(),
        };
        let align = u64::from(ctx.capabilities().accel_scratch_alignment.max(1));
        let scratch = Buffer::new(
            ctx,
            "acceleration structure scratch",
            sizes.build_scratch_size + align,
            vk::BufferUsageFlags::SHADER_DEVICE_ADDRESS,
            MemoryLocation::GpuOnly,
        );
        let scratch = scratch?;
        let scratch_address = scratch.device_address(ctx).div_ceil(align) * align;
        info = info
            .dst_acceleration_structure(handle)
            .scratch_data(vk::DeviceOrHostAddressKHR {
                device_address: scratch_address,
            });
        let range =
            [vk::AccelerationStructureBuildRangeInfoKHR::default()
                .primitive_count(primitive_count)];
        ctx.submit(|cmd| unsafe {
            ext.cmd_build_acceleration_structures(cmd, &[info], &[&range]);
        })?;
        drop(scratch);
        built.address = unsafe {
            ext.get_acceleration_structure_device_address(
                &vk::AccelerationStructureDeviceAddressInfoKHR::default()
                    .acceleration_structure(handle),
            )
        };
        Ok(built)
    }
}

impl Drop for AccelerationStructure {
    fn drop(&mut self) {
        // Made only where the extension is loaded.
        if let Some(ext) = &self.shared.accel {
            unsafe { ext.destroy_acceleration_structure(self.handle, None) };
        }
    }
}
