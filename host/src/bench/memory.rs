//! What a GI frame allocates for a preset at a resolution, without rendering (`gi memory`): the
//! renderer is created, its resources counted from the context's live buffers and images, and
//! dropped. The world cache's buffers (`hash grid …`) scale with its tiles, everything else with
//! the pixels (and the probe rays, which follow the pixels at a preset's spawn rate).
//!
//! Failure modes: a resolution whose buffers exceed the device's limits fails with the error
//! that names the buffer; the scene's own buffers (geometry, lights) are not counted, but its
//! light count is (at most `EXACT_DIRECT_LIGHTS` lights need no light grid).

use crate::error::Result;
use crate::frame::MemoryTable;
use crate::gi::renderer::GiRenderer;
use crate::gi::{Preset, ViewOptions};
use crate::scene::lights::LightSet;
use crate::vulkan::Context;

/// Prefix of the world cache's resources in the memory table.
pub const WORLD_CACHE_PREFIX: &str = "hash grid";

/// The memory of one preset at one resolution.
#[derive(Clone, Debug, PartialEq)]
pub struct MemoryPoint {
    /// The preset.
    pub preset: Preset,
    /// Width in pixels.
    pub width: u32,
    /// Height in pixels.
    pub height: u32,
    /// Tiles of the world cache.
    pub cache_tiles: u32,
    /// Every resource of the GI frame, in bytes.
    pub total_bytes: u64,
    /// The world cache's resources (named [`WORLD_CACHE_PREFIX`]…), in bytes.
    pub cache_bytes: u64,
}

impl MemoryPoint {
    /// What is not the world cache, per pixel.
    pub fn bytes_per_pixel(&self) -> f64 {
        (self.total_bytes - self.cache_bytes) as f64
            / (f64::from(self.width) * f64::from(self.height))
    }
}

/// Creates the renderer of `preset` at `width × height` for `lights` and counts what it holds.
pub fn measure_memory(
    ctx: &Context,
    lights: &LightSet,
    preset: Preset,
    width: u32,
    height: u32,
) -> Result<MemoryPoint> {
    let before = MemoryTable::of(ctx);
    let settings = preset.settings(width, height);
    let gi = GiRenderer::new(ctx, lights, width, height, settings, ViewOptions::default())?;
    let after = MemoryTable::of(ctx);
    drop(gi);
    let total_bytes = after.total_bytes().saturating_sub(before.total_bytes());
    let cache = |t: &MemoryTable| -> u64 {
        t.rows
            .iter()
            .filter(|r| r.name.starts_with(WORLD_CACHE_PREFIX))
            .map(|r| r.bytes)
            .sum()
    };
    Ok(MemoryPoint {
        preset,
        width,
        height,
        cache_tiles: settings.tile_count(),
        total_bytes,
        cache_bytes: cache(&after).saturating_sub(cache(&before)),
    })
}
