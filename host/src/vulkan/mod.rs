//! The Vulkan layer: context, memory, pipelines, acceleration structures and timing.

mod accel;
mod capabilities;
mod context;
mod image;
mod memory;
mod pipeline;
mod timing;
mod validation;

pub use accel::{AccelerationStructure, Instance};
pub use capabilities::Capabilities;
pub use context::{Context, ContextOptions, DEVICE_ENV, LOADER_ENV, SUBMIT_TIMEOUT, select_device};
pub use image::Image;
pub use memory::{Buffer, BufferInfo, MemoryLocation, transfer_barrier};
pub use pipeline::{BindingKind, Kernel, KernelModule, Resource, compute_barrier};
pub use timing::{GpuTimer, submit_timed};
