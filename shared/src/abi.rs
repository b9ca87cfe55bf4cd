//! What the host and the kernel build must agree on about the kernel modules themselves.

/// Threads per workgroup of every one-dimensional kernel (`#[spirv(compute(threads(64)))]`).
/// 64 is a multiple of every subgroup size we meet (lavapipe 8, NVIDIA 32, AMD 32/64).
pub const WORKGROUP_SIZE: u32 = 64;

/// SPIR-V capabilities every kernel module declares beyond `Shader` and `VulkanMemoryModel`.
/// The kernel build declares them; the host enables the matching device feature and refuses a
/// device without it, naming the feature.
///
/// - `VulkanMemoryModelDeviceScope`: device-scope atomics (`kernels/src/atomics.rs`).
/// - `GroupNonUniform`, `GroupNonUniformArithmetic`: subgroup ids and subgroup scans in compute
///   kernels (the prefix scan).
/// - `ShaderNonUniform`, `RuntimeDescriptorArray`, `SampledImageArrayNonUniformIndexing`: the
///   scene's bindless texture array, indexed per invocation (`kernels/src/texture_images.rs`).
/// - `StorageBufferArrayNonUniformIndexing`: the scene's split arrays (vertices, triangles, BVH
///   nodes), their chunk picked per invocation (`crate::elements`, `kernels/src/trace.rs`).
pub const KERNEL_CAPABILITIES: &[&str] = &[
    "VulkanMemoryModelDeviceScope",
    "GroupNonUniform",
    "GroupNonUniformArithmetic",
    "ShaderNonUniform",
    "RuntimeDescriptorArray",
    "SampledImageArrayNonUniformIndexing",
    "StorageBufferArrayNonUniformIndexing",
];
