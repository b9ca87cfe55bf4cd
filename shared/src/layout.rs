//! The frame-wide capacities that the GPU buffers must respect (the device limits every Vulkan
//! device guarantees), and the rules every GPU record follows: `#[repr(C)]` + `Pod`; only
//! `u32`/`i32`/`f32` and arrays of them (no `bool`, no `Vec3`, whose 12-byte layout breaks std430
//! without scalar block layout); explicit padding; every struct's size and field offsets asserted
//! by a test beside it, with the words that hold floats ([`FloatLayout`]).
//!
//! The hash grid's own layouts (its capacities, cell records and pass parameters) are in
//! [`crate::hash_cells::layout`].

/// Which 32-bit words of a GPU record hold `f32`s (the others hold indices, flags, packed normals
/// or halves): what the host's NaN check reads (`gi_host::frame::FloatWords::of`). Each record
/// lists them once, beside its definition; a test there derives them from `offset_of!` of its
/// float fields (`float_field_words` in the tests).
pub trait FloatLayout: bytemuck::Pod {
    /// The float words' indices, ascending.
    const FLOAT_WORDS: &'static [u32];
}

/// The word indices of float fields given as `(byte offset, floats)`: what a record's
/// [`FloatLayout::FLOAT_WORDS`] must equal.
#[cfg(test)]
pub(crate) fn float_field_words(fields: &[(usize, usize)]) -> std::vec::Vec<u32> {
    let mut words: std::vec::Vec<u32> = fields
        .iter()
        .flat_map(|&(offset, n)| (0..n).map(move |k| (offset / 4 + k) as u32))
        .collect();
    words.sort_unstable();
    words
}

/// Largest storage buffer binding we rely on: lavapipe's (and wgpu's default)
/// `maxStorageBufferRange` of 128 MiB.
pub const MAX_STORAGE_BUFFER_BYTES: usize = 128 << 20;
/// Most buffers (chunks) one of the scene's arrays that scale with its triangle count (vertices,
/// triangles, BVH nodes) is split into, each one storage binding (`crate::elements`): the length
/// of the descriptor array that binds it. 8 × [`MAX_STORAGE_BUFFER_BYTES`] = 1 GiB per array on
/// every device, e.g. 32 M vertices.
pub const SCENE_BUFFER_CHUNKS: usize = 8;
/// Push-constant bytes every Vulkan device guarantees (`maxPushConstantsSize` minimum).
pub const MAX_PUSH_CONSTANT_BYTES: usize = 128;

/// Largest frame width the buffers are sized for (seed packing allows up to 65534).
pub const MAX_FRAME_WIDTH: u32 = 3840;
/// Largest frame height the buffers are sized for.
pub const MAX_FRAME_HEIGHT: u32 = 2160;
/// Screen-probe resolution: 8 × 8 cells per probe, one probe tile of 8 × 8 pixels.
pub const PROBE_SIZE: u32 = 8;
/// Spawn tile of the quarter-spp sampling mode: one new probe per 16 × 16 pixels.
pub const PROBE_SPAWN_TILE_SIZE: u32 = 16;

/// Probes spawned per frame at most: `⌈W/16⌉ · ⌈H/16⌉`.
pub const fn max_probe_spawn_count(width: u32, height: u32) -> u32 {
    width.div_ceil(PROBE_SPAWN_TILE_SIZE) * height.div_ceil(PROBE_SPAWN_TILE_SIZE)
}

/// Probe rays per frame at most: one per cell of every spawned probe.
pub const fn max_ray_count(width: u32, height: u32) -> u32 {
    max_probe_spawn_count(width, height) * PROBE_SIZE * PROBE_SIZE
}

/// Rays per frame at [`MAX_FRAME_WIDTH`] × [`MAX_FRAME_HEIGHT`] (2 073 600).
pub const MAX_RAY_COUNT: u32 = max_ray_count(MAX_FRAME_WIDTH, MAX_FRAME_HEIGHT);

// Seed pixels keep 16 bits per coordinate.
const _: () = assert!(
    MAX_FRAME_WIDTH <= crate::packing::SEED_MAX_COORD
        && MAX_FRAME_HEIGHT <= crate::packing::SEED_MAX_COORD
);

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn capacities() {
        assert_eq!(max_probe_spawn_count(1920, 1080), 120 * 68);
        assert_eq!(max_ray_count(1920, 1080), 120 * 68 * 64);
        assert_eq!(MAX_RAY_COUNT, 2_073_600);
    }
}
