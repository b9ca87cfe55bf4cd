//! The Vulkan layer: context, memory, pipelines, acceleration structures, timing, and the
//! current/previous pairs of per-frame resources.

mod accel;
mod bindings;
mod capabilities;
mod context;
mod image;
mod memory;
mod ping_pong;
mod pipeline;
pub mod reflect;
mod sampled_image;
mod split_buffer;
mod texture_image;
mod timing;
mod validation;

pub use accel::{AccelerationStructure, Instance, TopLevel};
pub use bindings::{BindingField, Bindings, DeclaredBinding, Sampled};
pub use capabilities::{Capabilities, FeatureChain};
pub use context::{
    Context, ContextOptions, DEVICE_ENV, DeviceRequirements, ExternalDevice, LOADER_ENV,
    SUBMIT_TIMEOUT, select_device,
};
pub use image::Image;
pub(crate) use memory::memory_barrier;
pub use memory::{
    Buffer, BufferInfo, DeviceMemoryUse, MemoryLocation, StagedWrites, transfer_barrier,
};
pub use ping_pong::PingPong;
pub use pipeline::{
    BindingKind, DescriptorSet, Kernel, KernelModule, MAX_PUSH_BINDINGS, MAX_SCENE_TEXTURES,
    Resource, SHADING_BINDINGS, SceneSet, SceneSets, TEXTURES_BINDING, TRIANGLES_BINDING,
    VERTICES_BINDING, compute_barrier,
};
pub(crate) use pipeline::{Groups, SetZero};
pub use sampled_image::SampledImage;
pub use split_buffer::{SplitBuffer, split_layout};
pub use texture_image::{STAGING_BYTES, Samplers, TextureImage, TextureLevels, upload_textures};
pub use timing::{FrameTimings, GpuTimer, PassTiming, submit_timed};
