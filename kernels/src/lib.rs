//! GPU kernels of the GI-1.0 port. Each entry point is thin: it reads its inputs, calls `gi-shared`,
//! and writes its outputs, so the same math runs (and is tested) on the CPU.
//!
//! Built twice by `host/build.rs`: with the `ray-query` feature (tracing with `VK_KHR_ray_query`)
//! and without it (software BVH traversal).
#![cfg_attr(target_arch = "spirv", no_std)]
#![cfg_attr(
    all(target_arch = "spirv", feature = "ray-query"),
    feature(asm_experimental_arch)
)]

mod difftest;
mod gbuffer;
mod path_tracer;
mod smoke;
pub mod trace;
mod trace_rays;

pub use difftest::difftest;
pub use gbuffer::gbuffer;
pub use path_tracer::path_tracer;
pub use smoke::smoke;
pub use trace_rays::trace_rays;
