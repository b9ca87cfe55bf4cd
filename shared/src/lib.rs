//! The contract between the CPU and the GPU of the GI-1.0 port: buffer layouts, constants and the
//! math both sides run.
//!
//! Everything here also compiles for `spirv-unknown-vulkan1.2` with rust-gpu: `no_std` without the
//! `std` feature, no allocation, no recursion, no 64-bit integers in GPU paths, and every
//! float→int conversion explicit (see [`math`]).
#![cfg_attr(not(any(feature = "std", test)), no_std)]

pub mod abi;
pub mod append_list;
pub mod atomics;
pub mod bvh;
pub mod cache_view;
pub mod camera;
pub mod color;
pub mod difftest;
pub mod elements;
pub mod environment;
pub mod finite_check;
pub mod fixed_point;
pub mod gbuffer;
pub mod gbuffer_import;
pub mod gi_denoiser;
pub mod hash;
pub mod hash_cells;
pub mod indirect;
pub mod layout;
pub mod light_clusters;
pub mod light_grid;
pub mod lights;
pub mod machinery_tests;
pub mod math;
pub mod multi_bounce;
pub mod octahedral;
pub mod packing;
pub mod path_tracer;
pub mod primary_lighting;
pub mod primary_surface;
pub mod radiance_feedback;
pub mod random;
pub mod ray;
pub mod ray_cone;
pub mod reservoir;
pub mod sampling;
pub mod scan;
pub mod scene_data;
pub mod screen_probes;
pub mod screen_space_gi;
pub mod secondary_hits;
pub mod sh;
pub mod textures;
pub mod world_cache;
pub mod world_restir;
