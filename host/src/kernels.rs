//! The two compiled kernel modules and the choice between them.

use crate::error::{Error, Result};
use crate::vulkan::Capabilities;
use std::fmt;

/// How the user wants rays traced.
#[derive(Clone, Copy, Debug, Default, PartialEq, Eq, clap::ValueEnum)]
pub enum TraceMode {
    /// Ray queries where the device has them, software BVH traversal otherwise.
    #[default]
    Auto,
    /// `VK_KHR_ray_query`; an error on devices without it.
    RayQuery,
    /// Software BVH traversal, on any device.
    Software,
}

/// One of the two builds of `kernels/`.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum KernelVariant {
    /// Traces with `VK_KHR_ray_query` against device-built acceleration structures.
    RayQuery,
    /// Walks the shared crate's BVH in software.
    Software,
}

const SOFTWARE_SPV: &[u8] = include_bytes!(env!("GI_KERNELS_SOFTWARE_SPV"));
const RAY_QUERY_SPV: &[u8] = include_bytes!(env!("GI_KERNELS_RAY_QUERY_SPV"));

impl KernelVariant {
    /// Both variants, software first.
    pub const ALL: [Self; 2] = [Self::Software, Self::RayQuery];

    /// Applies `mode` to a device: `Auto` prefers ray queries; a forced mode the device cannot run
    /// is an error naming the missing feature.
    pub fn resolve(mode: TraceMode, caps: &Capabilities) -> Result<Self> {
        match mode {
            TraceMode::Software => Ok(Self::Software),
            TraceMode::Auto if caps.ray_query => Ok(Self::RayQuery),
            TraceMode::Auto => Ok(Self::Software),
            TraceMode::RayQuery if caps.ray_query => Ok(Self::RayQuery),
            TraceMode::RayQuery => Err(Error::MissingFeature {
                device: caps.name.clone(),
                feature:
                    "VK_KHR_ray_query (with VK_KHR_acceleration_structure and bufferDeviceAddress)"
                        .into(),
                needed_for: "--trace ray-query".into(),
            }),
        }
    }

    /// The SPIR-V module of this variant, as words.
    pub fn spirv_words(self) -> Vec<u32> {
        let bytes = match self {
            Self::RayQuery => RAY_QUERY_SPV,
            Self::Software => SOFTWARE_SPV,
        };
        // The build script wrote the module itself; a malformed one is a build bug.
        ash::util::read_spv(&mut std::io::Cursor::new(bytes)).unwrap_or_default()
    }

    /// The names of the module's entry points.
    pub fn entry_points(self) -> Vec<String> {
        entry_points(&self.spirv_words())
    }
}

impl fmt::Display for KernelVariant {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        f.write_str(match self {
            Self::RayQuery => "ray query",
            Self::Software => "software BVH traversal",
        })
    }
}

/// Entry point names declared by `OpEntryPoint` instructions of a SPIR-V module.
pub fn entry_points(words: &[u32]) -> Vec<String> {
    const OP_ENTRY_POINT: u32 = 15;
    let mut names = vec![];
    let mut i = 5; // past the header
    while i < words.len() {
        let count = (words[i] >> 16) as usize;
        if count == 0 || i + count > words.len() {
            break;
        }
        if words[i] & 0xffff == OP_ENTRY_POINT && count > 3 {
            let bytes: Vec<u8> = words[i + 3..i + count]
                .iter()
                .flat_map(|w| w.to_le_bytes())
                .take_while(|&b| b != 0)
                .collect();
            names.push(String::from_utf8_lossy(&bytes).into_owned());
        }
        i += count;
    }
    names
}

#[cfg(test)]
mod tests {
    use super::*;
    use ash::vk;

    fn caps(ray_query: bool) -> Capabilities {
        Capabilities {
            name: "test device".into(),
            device_type: vk::PhysicalDeviceType::DISCRETE_GPU,
            api_version: vk::API_VERSION_1_3,
            driver: String::new(),
            ray_query,
            acceleration_structure: ray_query,
            buffer_device_address: true,
            subgroup_size: 32,
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
        }
    }

    #[test]
    fn auto_prefers_ray_queries_and_falls_back_to_software() {
        assert_eq!(
            KernelVariant::resolve(TraceMode::Auto, &caps(true)).unwrap(),
            KernelVariant::RayQuery
        );
        assert_eq!(
            KernelVariant::resolve(TraceMode::Auto, &caps(false)).unwrap(),
            KernelVariant::Software
        );
        assert_eq!(
            KernelVariant::resolve(TraceMode::Software, &caps(true)).unwrap(),
            KernelVariant::Software
        );
    }

    #[test]
    fn forced_ray_queries_without_them_name_the_missing_feature() {
        let err = KernelVariant::resolve(TraceMode::RayQuery, &caps(false)).unwrap_err();
        let text = err.to_string();
        assert!(text.contains("VK_KHR_ray_query"), "{text}");
        assert!(text.contains("test device"), "{text}");
    }

    #[test]
    fn entry_points_are_read_from_the_modules() {
        assert!(
            KernelVariant::Software
                .entry_points()
                .contains(&"smoke::smoke".to_string())
        );
        assert!(entry_points(&[]).is_empty());
        // A truncated module yields what was complete, without panicking.
        let words = KernelVariant::RayQuery.spirv_words();
        let _ = entry_points(&words[..words.len() / 2]);
    }
}
