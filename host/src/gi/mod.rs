//! The GI-1.0 frame on the host, in layers that use only the layers below them:
//! [`settings`] (every knob, with its cost and quality effect) and [`pass_inputs`] (what every
//! pass takes besides its resources: push-constant size, pixel workgroups, view options, the
//! scene's lighting); [`resources`] (persistent GPU resources sized from the settings and the
//! resolution, and the [`Occupancy`] read back from their counters); one module per pass group,
//! named like its kernels: [`hash_cells`] (the world-space radiance cache), [`lighting`] (light
//! grid and light sampling at secondary hits), [`screen_probes`], [`primary_lighting`] and
//! [`gi_denoiser`]; [`world_cache`] (the cache passes strung together); and the frames that use
//! them: [`renderer`] (the GI frame) and [`cache_view`] (`gi cache-view`, the cache on its own:
//! the frame loop) with its [`debug_views`].

pub mod cache_view;
pub mod camera_path;
pub mod debug_views;
pub mod gbuffer_import;
pub mod gi_denoiser;
pub mod hash_cells;
pub mod lighting;
pub mod pass_inputs;
pub mod presets;
pub mod primary_lighting;
pub mod probe_debug_views;
pub mod renderer;
pub mod resources;
pub mod screen_probes;
pub mod settings;
pub mod world_cache;

pub use cache_view::{CacheState, CacheView};
pub use pass_inputs::ViewOptions;
pub use presets::Preset;
pub use resources::Occupancy;
pub use settings::{GiSettings, SpawnRate};
