//! GPU kernels of the GI-1.0 port. Each entry point is thin: it reads its inputs, calls `gi-shared`,
//! and writes its outputs, so the same math runs (and is tested) on the CPU.
//!
//! Built twice by `host/build.rs`: without features, every kernel (tracing by software BVH
//! traversal); with the `ray-query` feature, only the kernels that trace (with
//! `VK_KHR_ray_query`), each defined once by [`traced_kernel!`]. A kernel that does not trace is
//! compiled once: its module carries `#[cfg(not(feature = "ray-query"))]`, and the host takes it
//! from the first module in both variants.
//!
//! Descriptor sets (the host side is `host/src/vulkan/pipeline.rs`): set 0 holds the kernel's own
//! resources, from binding 0; a kernel that traces also has the scene's geometry as set 1 and the
//! shading data's instances, meshes, vertices, triangles, materials, texture table and texture
//! images as set 2 bindings 0 to 6 (all bound by [`traced_kernel!`], which hands them to the body
//! in its `Scene` and, for the images, beside it: tracing reads them all for the alpha test), and
//! may read the rest of set 2 (lights, environment) itself. The numbers are the same in both
//! variants.
#![cfg_attr(target_arch = "spirv", no_std)]
#![cfg_attr(
    all(target_arch = "spirv", feature = "ray-query"),
    feature(asm_experimental_arch)
)]

#[macro_use]
pub mod trace;

// Both variants: the tracing cache passes append and accumulate with device atomics too.
#[cfg_attr(
    feature = "ray-query",
    allow(dead_code, reason = "workgroup atomics serve non-tracing kernels only")
)]
mod atomics;
mod cache_view;
#[cfg(not(feature = "ray-query"))]
mod difftest;
#[cfg(not(feature = "ray-query"))]
mod finite_check;
#[macro_use]
mod gbuffer;
#[cfg(not(feature = "ray-query"))]
mod gbuffer_import;
#[cfg(not(feature = "ray-query"))]
pub mod gi_denoiser;
mod hash_cells;
#[cfg(not(feature = "ray-query"))]
mod indirect;
#[cfg(not(feature = "ray-query"))]
mod lighting;
#[cfg(not(feature = "ray-query"))]
mod machinery_tests;
mod path_tracer;
pub mod primary_lighting;
#[cfg(not(feature = "ray-query"))]
mod scan;
pub mod screen_probes;
#[cfg(not(feature = "ray-query"))]
mod smoke;
mod texture_images;
mod trace_rays;

#[cfg(not(feature = "ray-query"))]
pub use cache_view::composite;
pub use cache_view::trace_cache_rays;
#[cfg(not(feature = "ray-query"))]
pub use difftest::difftest;
#[cfg(not(feature = "ray-query"))]
pub use finite_check::count_non_finite;
pub use gbuffer::gbuffer;
#[cfg(not(feature = "ray-query"))]
pub use gbuffer_import::import_gbuffer;
pub use hash_cells::populate::populate_radiance_cache;
#[cfg(not(feature = "ray-query"))]
pub use hash_cells::{
    insert::{admit_to_full_buckets, insert_radiance_cache, settle_full_buckets},
    purge::{begin_frame, carry_queries, purge_tiles},
    resolve::resolve_radiance_cache,
    update_tiles::update_radiance_cache,
};
#[cfg(not(feature = "ray-query"))]
pub use indirect::dispatch_from_counter;
#[cfg(not(feature = "ray-query"))]
pub use lighting::{
    light_grid::{build_light_grid, update_light_grid},
    reservoirs::generate_reservoirs,
    restir::{compact_reservoirs, order_reservoirs, resample_reservoirs},
};
#[cfg(not(feature = "ray-query"))]
pub use machinery_tests::{
    append_items, atomics_contention, insert_keys, point_bounds, touch_items,
};
pub use path_tracer::path_tracer;
#[cfg(not(feature = "ray-query"))]
pub use scan::{add_block_offsets, scan_blocks};
#[cfg(not(feature = "ray-query"))]
pub use smoke::smoke;
pub use trace_rays::trace_rays;
