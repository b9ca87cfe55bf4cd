//! The Vulkan host of the GI-1.0 port.
//!
//! [`vulkan::Context`] opens a device and picks the kernel variant: ray queries where the device
//! has them, software BVH traversal where it does not. Kernels come from `kernels/`, compiled to
//! SPIR-V by rust-gpu at build time, and share every buffer layout with this crate through
//! `gi-shared`.

pub mod bench;
pub mod error;
pub mod frame;
pub mod fuzzing;
pub mod gbuffer;
pub mod gi;
pub mod image_io;
pub mod kernels;
pub mod metrics;
pub mod path_tracer;
pub mod scene;
pub mod smoke;
pub mod soak;
pub mod trace_rays;
pub mod vulkan;

pub use error::{Error, Result};
pub use kernels::{KernelVariant, TraceMode};
