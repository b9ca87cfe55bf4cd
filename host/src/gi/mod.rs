//! The GI-1.0 frame on the host: [`settings`] (every knob, with its cost and quality effect),
//! [`resources`] (persistent GPU resources sized from the settings and the resolution), and one
//! module per pass group, named like its kernels: [`hash_cells`] (the world-space radiance
//! cache), [`lighting`] (light grid and light sampling at secondary hits) and [`cache_view`]
//! (`gi cache-view`, the cache on its own: the frame loop) with its [`debug_views`].

pub mod cache_view;
pub mod camera_path;
pub mod debug_views;
pub mod gbuffer_import;
pub mod gi_denoiser;
pub mod hash_cells;
pub mod lighting;
pub mod presets;
pub mod primary_lighting;
pub mod probe_debug_views;
pub mod renderer;
pub mod resources;
pub mod screen_probes;
pub mod settings;
pub mod world_cache;

pub use cache_view::{CacheState, CacheView, Occupancy, ViewOptions};
pub use presets::Preset;
pub use settings::{GiSettings, SpawnRate};
