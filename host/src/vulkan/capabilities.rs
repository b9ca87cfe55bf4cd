//! What a device can do, probed once, reported to the user, and used to decide which kernel variant
//! runs and which features get enabled.

use ash::vk;
use std::ffi::CStr;
use std::fmt;

/// Capabilities of one physical device that matter to the GI kernels.
#[derive(Clone, Debug)]
pub struct Capabilities {
    /// Device name as the driver reports it (e.g. `llvmpipe (LLVM 15.0.6, 256 bits)`).
    pub name: String,
    /// Discrete, integrated, virtual or CPU.
    pub device_type: vk::PhysicalDeviceType,
    /// Vulkan API version the device supports.
    pub api_version: u32,
    /// Driver name and version string (e.g. `llvmpipe`, `Mesa 25.0.7`).
    pub driver: String,
    /// `VK_KHR_ray_query` with the `rayQuery` feature, and everything it depends on.
    pub ray_query: bool,
    /// `VK_KHR_acceleration_structure` with the `accelerationStructure` feature.
    pub acceleration_structure: bool,
    /// `bufferDeviceAddress` (needed to build acceleration structures).
    pub buffer_device_address: bool,
    /// Subgroup size of compute shaders (lavapipe: 8, NVIDIA: 32, AMD: 32 or 64).
    pub subgroup_size: u32,
    /// Subgroup operations compute shaders may use (`supportedOperations` when `supportedStages`
    /// has compute, empty otherwise).
    pub subgroup_operations: vk::SubgroupFeatureFlags,
    /// `shaderFloat16` arithmetic.
    pub shader_float16: bool,
    /// `shaderInt8` arithmetic.
    pub shader_int8: bool,
    /// `shaderInt16` arithmetic.
    pub shader_int16: bool,
    /// `shaderInt64` arithmetic.
    pub shader_int64: bool,
    /// `shaderBufferInt64Atomics`.
    pub int64_atomics: bool,
    /// `shaderBufferFloat32AtomicAdd` (`VK_EXT_shader_atomic_float`).
    pub float32_atomic_add: bool,
    /// `vulkanMemoryModel` (rust-gpu's Vulkan targets always use it).
    pub vulkan_memory_model: bool,
    /// `vulkanMemoryModelDeviceScope` (device-scope atomics and barriers).
    pub vulkan_memory_model_device_scope: bool,
    /// `scalarBlockLayout`.
    pub scalar_block_layout: bool,
    /// Timestamp queries work on the compute queue.
    pub compute_timestamps: bool,
    /// Nanoseconds per timestamp tick.
    pub timestamp_period_ns: f32,
    /// `maxStorageBufferRange` in bytes (lavapipe: 128 MiB).
    pub max_storage_buffer_range: u64,
    /// `maxComputeSharedMemorySize` in bytes.
    pub max_shared_memory: u32,
    /// `maxComputeWorkGroupCount`.
    pub max_workgroup_count: [u32; 3],
    /// `VK_KHR_push_descriptor` (how the host binds resources).
    pub push_descriptor: bool,
    /// `minAccelerationStructureScratchOffsetAlignment` (0 without acceleration structures).
    pub accel_scratch_alignment: u32,
    /// `maxComputeWorkGroupInvocations`.
    pub max_workgroup_invocations: u32,
    /// Largest device-local heap in bytes.
    pub device_local_bytes: u64,
    /// Largest memory heap of any kind in bytes: no allocation can be larger.
    pub largest_heap_bytes: u64,
    /// `maxBufferSize` (`VK_KHR_maintenance4`); `u64::MAX` where the device does not say.
    pub max_buffer_size: u64,
    /// `maxImageDimension2D`: the longest side of a 2D image.
    pub max_image_dimension_2d: u32,
    /// Fewest of `maxPerStageDescriptorSampledImages`, `maxPerStageDescriptorSamplers`,
    /// `maxDescriptorSetSampledImages` and `maxDescriptorSetSamplers`: the longest texture array.
    pub max_sampled_images: u32,
    /// `runtimeDescriptorArray`, `shaderSampledImageArrayNonUniformIndexing` and
    /// `descriptorBindingPartiallyBound`: the bindless texture array.
    pub bindless_textures: bool,
    /// `shaderStorageBufferArrayNonUniformIndexing`: the scene's split arrays, their chunk picked
    /// per invocation.
    pub storage_buffer_arrays: bool,
}

/// Device feature structs: what a probe found, what device creation enables (trimmed to what
/// the kernels use: [`DeviceRequirements`](super::DeviceRequirements)), or what an engine
/// enabled on its device ([`ExternalDevice`](super::ExternalDevice)). Their `p_next` fields are
/// ignored: [`FeatureChain::chain`] links them.
#[derive(Clone, Copy, Default)]
pub struct FeatureChain {
    /// Vulkan 1.0 features.
    pub core: vk::PhysicalDeviceFeatures,
    /// Vulkan 1.1 features.
    pub v11: vk::PhysicalDeviceVulkan11Features<'static>,
    /// Vulkan 1.2 features.
    pub v12: vk::PhysicalDeviceVulkan12Features<'static>,
    /// `VK_KHR_acceleration_structure` features.
    pub accel: vk::PhysicalDeviceAccelerationStructureFeaturesKHR<'static>,
    /// `VK_KHR_ray_query` features.
    pub ray_query: vk::PhysicalDeviceRayQueryFeaturesKHR<'static>,
    /// `VK_EXT_shader_atomic_float` features (probed, never required).
    pub atomic_float: vk::PhysicalDeviceShaderAtomicFloatFeaturesEXT<'static>,
}

/// Reads one feature's flag from a chain.
type FeatureField = fn(&FeatureChain) -> vk::Bool32;

/// Each feature the kernels may require, by its Vulkan name, and where it sits in the chain.
const REQUIRABLE: [(&str, FeatureField); 11] = [
    ("shaderInt16", |f| f.core.shader_int16),
    ("shaderInt64", |f| f.core.shader_int64),
    ("shaderInt8", |f| f.v12.shader_int8),
    ("vulkanMemoryModel", |f| f.v12.vulkan_memory_model),
    ("vulkanMemoryModelDeviceScope", |f| {
        f.v12.vulkan_memory_model_device_scope
    }),
    ("runtimeDescriptorArray", |f| f.v12.runtime_descriptor_array),
    ("shaderSampledImageArrayNonUniformIndexing", |f| {
        f.v12.shader_sampled_image_array_non_uniform_indexing
    }),
    ("descriptorBindingPartiallyBound", |f| {
        f.v12.descriptor_binding_partially_bound
    }),
    ("bufferDeviceAddress", |f| f.v12.buffer_device_address),
    ("accelerationStructure", |f| f.accel.acceleration_structure),
    ("rayQuery", |f| f.ray_query.ray_query),
];

impl FeatureChain {
    /// The first feature set here (required) that `enabled` lacks, by its Vulkan name.
    pub fn missing_in(&self, enabled: &FeatureChain) -> Option<&'static str> {
        REQUIRABLE
            .iter()
            .find(|(_, get)| get(self) == vk::TRUE && get(enabled) != vk::TRUE)
            .map(|(name, _)| *name)
    }

    /// The structs linked for `VkDeviceCreateInfo::pNext` (or a features query): core, 1.1 and
    /// 1.2, then the acceleration-structure and ray-query structs when `ray_query` (only with
    /// their extensions enabled).
    pub fn chain(&mut self, ray_query: bool) -> vk::PhysicalDeviceFeatures2<'_> {
        // A copy's links point into the original: cut them before linking anew.
        self.v11.p_next = std::ptr::null_mut();
        self.v12.p_next = std::ptr::null_mut();
        self.accel.p_next = std::ptr::null_mut();
        self.ray_query.p_next = std::ptr::null_mut();
        let mut f2 = vk::PhysicalDeviceFeatures2::default()
            .features(self.core)
            .push_next(&mut self.v11)
            .push_next(&mut self.v12);
        if ray_query {
            f2 = f2.push_next(&mut self.accel).push_next(&mut self.ray_query);
        }
        f2
    }
}

pub(crate) fn has_extension(extensions: &[vk::ExtensionProperties], name: &CStr) -> bool {
    extensions
        .iter()
        .any(|e| e.extension_name_as_c_str().is_ok_and(|n| n == name))
}

impl Capabilities {
    /// Probes `pd`. Unsafe because `pd` must belong to `instance`.
    pub(crate) unsafe fn probe(
        instance: &ash::Instance,
        pd: vk::PhysicalDevice,
    ) -> (Self, Vec<vk::ExtensionProperties>) {
        let extensions =
            unsafe { instance.enumerate_device_extension_properties(pd) }.unwrap_or_default();
        let has = |n: &CStr| has_extension(&extensions, n);
        let has_accel = has(ash::khr::acceleration_structure::NAME)
            && has(ash::khr::deferred_host_operations::NAME);
        let has_rq = has(ash::khr::ray_query::NAME);
        let has_atomic_float = has(ash::ext::shader_atomic_float::NAME);

        let mut chain = FeatureChain::default();
        {
            let mut f2 = vk::PhysicalDeviceFeatures2::default()
                .push_next(&mut chain.v11)
                .push_next(&mut chain.v12);
            if has_accel {
                f2 = f2.push_next(&mut chain.accel);
            }
            if has_rq {
                f2 = f2.push_next(&mut chain.ray_query);
            }
            if has_atomic_float {
                f2 = f2.push_next(&mut chain.atomic_float);
            }
            unsafe { instance.get_physical_device_features2(pd, &mut f2) };
            chain.core = f2.features;
        }

        let mut subgroup = vk::PhysicalDeviceSubgroupProperties::default();
        let mut driver = vk::PhysicalDeviceDriverProperties::default();
        let mut accel_props = vk::PhysicalDeviceAccelerationStructurePropertiesKHR::default();
        let has_maintenance4 = has(ash::khr::maintenance4::NAME);
        let mut maintenance4 = vk::PhysicalDeviceMaintenance4Properties::default();
        let props = {
            let mut p2 = vk::PhysicalDeviceProperties2::default()
                .push_next(&mut subgroup)
                .push_next(&mut driver);
            if has_accel {
                p2 = p2.push_next(&mut accel_props);
            }
            if has_maintenance4 {
                p2 = p2.push_next(&mut maintenance4);
            }
            unsafe { instance.get_physical_device_properties2(pd, &mut p2) };
            p2.properties
        };
        let memory = unsafe { instance.get_physical_device_memory_properties(pd) };
        let heaps = &memory.memory_heaps[..memory.memory_heap_count as usize];
        let device_local_bytes = heaps
            .iter()
            .filter(|h| h.flags.contains(vk::MemoryHeapFlags::DEVICE_LOCAL))
            .map(|h| h.size)
            .max()
            .unwrap_or(0);
        let largest_heap_bytes = heaps.iter().map(|h| h.size).max().unwrap_or(0);
        let queues = unsafe { instance.get_physical_device_queue_family_properties(pd) };
        let compute_timestamps = queues
            .iter()
            .any(|q| q.queue_flags.contains(vk::QueueFlags::COMPUTE) && q.timestamp_valid_bits > 0);

        let cstr = |s: Result<&CStr, _>| {
            s.map(|c: &CStr| c.to_string_lossy().into_owned())
                .unwrap_or_default()
        };
        let caps = Self {
            name: cstr(props.device_name_as_c_str()),
            device_type: props.device_type,
            api_version: props.api_version,
            driver: format!(
                "{} ({})",
                cstr(driver.driver_name_as_c_str()),
                cstr(driver.driver_info_as_c_str())
            ),
            acceleration_structure: has_accel && chain.accel.acceleration_structure == vk::TRUE,
            ray_query: has_accel
                && has_rq
                && chain.ray_query.ray_query == vk::TRUE
                && chain.accel.acceleration_structure == vk::TRUE
                && chain.v12.buffer_device_address == vk::TRUE,
            buffer_device_address: chain.v12.buffer_device_address == vk::TRUE,
            subgroup_size: subgroup.subgroup_size,
            subgroup_operations: if subgroup
                .supported_stages
                .contains(vk::ShaderStageFlags::COMPUTE)
            {
                subgroup.supported_operations
            } else {
                vk::SubgroupFeatureFlags::empty()
            },
            shader_float16: chain.v12.shader_float16 == vk::TRUE,
            shader_int8: chain.v12.shader_int8 == vk::TRUE,
            shader_int16: chain.core.shader_int16 == vk::TRUE,
            shader_int64: chain.core.shader_int64 == vk::TRUE,
            int64_atomics: chain.v12.shader_buffer_int64_atomics == vk::TRUE,
            float32_atomic_add: has_atomic_float
                && chain.atomic_float.shader_buffer_float32_atomic_add == vk::TRUE,
            vulkan_memory_model: chain.v12.vulkan_memory_model == vk::TRUE,
            vulkan_memory_model_device_scope: chain.v12.vulkan_memory_model_device_scope
                == vk::TRUE,
            scalar_block_layout: chain.v12.scalar_block_layout == vk::TRUE,
            compute_timestamps,
            timestamp_period_ns: props.limits.timestamp_period,
            max_storage_buffer_range: u64::from(props.limits.max_storage_buffer_range),
            max_shared_memory: props.limits.max_compute_shared_memory_size,
            max_workgroup_invocations: props.limits.max_compute_work_group_invocations,
            max_workgroup_count: props.limits.max_compute_work_group_count,
            push_descriptor: has(ash::khr::push_descriptor::NAME),
            accel_scratch_alignment: accel_props
                .min_acceleration_structure_scratch_offset_alignment,
            device_local_bytes,
            largest_heap_bytes,
            max_buffer_size: match has_maintenance4 {
                true => maintenance4.max_buffer_size,
                false => u64::MAX,
            },
            max_image_dimension_2d: props.limits.max_image_dimension2_d,
            max_sampled_images: props
                .limits
                .max_per_stage_descriptor_sampled_images
                .min(props.limits.max_per_stage_descriptor_samplers)
                .min(props.limits.max_descriptor_set_sampled_images)
                .min(props.limits.max_descriptor_set_samplers),
            bindless_textures: chain.v12.runtime_descriptor_array == vk::TRUE
                && chain.v12.shader_sampled_image_array_non_uniform_indexing == vk::TRUE
                && chain.v12.descriptor_binding_partially_bound == vk::TRUE,
            storage_buffer_arrays: chain.v12.shader_storage_buffer_array_non_uniform_indexing
                == vk::TRUE,
        };
        (caps, extensions)
    }

    /// The length of the scene's texture array (set 2): [`crate::vulkan::MAX_SCENE_TEXTURES`],
    /// or fewer where the device allows fewer (at least 1).
    pub fn scene_texture_slots(&self) -> u32 {
        self.max_sampled_images
            .clamp(1, crate::vulkan::MAX_SCENE_TEXTURES)
    }

    /// `cpu`, `discrete GPU`, ... for reports.
    pub fn device_type_name(&self) -> &'static str {
        match self.device_type {
            vk::PhysicalDeviceType::DISCRETE_GPU => "discrete GPU",
            vk::PhysicalDeviceType::INTEGRATED_GPU => "integrated GPU",
            vk::PhysicalDeviceType::VIRTUAL_GPU => "virtual GPU",
            vk::PhysicalDeviceType::CPU => "CPU",
            _ => "other",
        }
    }
}

#[cfg(test)]
impl Capabilities {
    /// A device that has everything (ray queries as asked), for unit tests.
    pub(crate) fn for_tests(ray_query: bool) -> Self {
        Self {
            name: "test device".into(),
            device_type: vk::PhysicalDeviceType::DISCRETE_GPU,
            api_version: vk::API_VERSION_1_3,
            driver: String::new(),
            ray_query,
            acceleration_structure: ray_query,
            buffer_device_address: true,
            subgroup_size: 32,
            subgroup_operations: vk::SubgroupFeatureFlags::BASIC
                | vk::SubgroupFeatureFlags::ARITHMETIC,
            shader_float16: true,
            shader_int8: true,
            shader_int16: true,
            shader_int64: true,
            int64_atomics: true,
            float32_atomic_add: true,
            vulkan_memory_model: true,
            vulkan_memory_model_device_scope: true,
            scalar_block_layout: true,
            compute_timestamps: true,
            timestamp_period_ns: 1.0,
            max_storage_buffer_range: 1 << 27,
            max_shared_memory: 1 << 15,
            max_workgroup_count: [65535; 3],
            push_descriptor: true,
            accel_scratch_alignment: 128,
            max_workgroup_invocations: 1024,
            device_local_bytes: 1 << 30,
            largest_heap_bytes: 1 << 30,
            max_buffer_size: 1 << 32,
            max_image_dimension_2d: 16384,
            max_sampled_images: 1 << 20,
            bindless_textures: true,
            storage_buffer_arrays: true,
        }
    }
}

impl fmt::Display for Capabilities {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        let yn = |b: bool| if b { "yes" } else { "no" };
        let mib = |b: u64| b as f64 / (1024.0 * 1024.0);
        writeln!(
            f,
            "device:              {} ({})",
            self.name,
            self.device_type_name()
        )?;
        writeln!(
            f,
            "driver:              {}, Vulkan {}.{}.{}",
            self.driver,
            vk::api_version_major(self.api_version),
            vk::api_version_minor(self.api_version),
            vk::api_version_patch(self.api_version)
        )?;
        writeln!(f, "ray queries:         {}", yn(self.ray_query))?;
        writeln!(
            f,
            "accel. structures:   {}",
            yn(self.acceleration_structure)
        )?;
        writeln!(
            f,
            "subgroups:           size {}, arithmetic in compute {}",
            self.subgroup_size,
            yn(self
                .subgroup_operations
                .contains(vk::SubgroupFeatureFlags::ARITHMETIC))
        )?;
        writeln!(
            f,
            "f16 / i8 / i16 / i64: {} / {} / {} / {}",
            yn(self.shader_float16),
            yn(self.shader_int8),
            yn(self.shader_int16),
            yn(self.shader_int64)
        )?;
        writeln!(
            f,
            "atomics:             int64 {}, float32 add {}",
            yn(self.int64_atomics),
            yn(self.float32_atomic_add)
        )?;
        writeln!(
            f,
            "memory model:        {} (device scope {})",
            yn(self.vulkan_memory_model),
            yn(self.vulkan_memory_model_device_scope)
        )?;
        writeln!(
            f,
            "timestamps:          {} ({} ns/tick)",
            yn(self.compute_timestamps),
            self.timestamp_period_ns
        )?;
        writeln!(
            f,
            "limits:              storage buffer {:.0} MiB, shared memory {} KiB, workgroup {} invocations",
            mib(self.max_storage_buffer_range),
            self.max_shared_memory / 1024,
            self.max_workgroup_invocations
        )?;
        write!(
            f,
            "device-local memory: {:.0} MiB",
            mib(self.device_local_bytes)
        )
    }
}
