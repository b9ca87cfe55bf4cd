//! PatchScreenProbes (`gi_shared::screen_probes::patch`): with `FLAG_PATCHING`, one invocation
//! per empty tile moves a random override spawn's seed into the tile (first surface pixel from
//! the tile's jittered one), by compare-exchange so that no slot is patched twice.
//!
//! Set 0: frame (`GiFrameParams`), camera, G-buffer depth and geometric normal, empty tiles,
//! overrides, spawns, GI counters. `ceil(probe_count / 64)` workgroups of 64.

use crate::atomics::DeviceWords;
use crate::gbuffer::{DepthImage, HalfImage};
use gi_shared::camera::CameraParams;
use gi_shared::screen_probes::GiFrameParams;
use gi_shared::screen_probes::patch::{patch_count, patch_seed, patch_tile};
use gi_shared::screen_probes::spawn::sees_surface;
use spirv_std::glam::{UVec2, UVec3, Vec4};
use spirv_std::spirv;

/// Patches entry `id.x` of the empty-tile list.
#[spirv(compute(threads(64)))]
#[allow(
    clippy::too_many_arguments,
    reason = "an entry point takes one argument per binding"
)]
pub fn patch_screen_probes(
    #[spirv(global_invocation_id)] id: UVec3,
    #[spirv(storage_buffer, descriptor_set = 0, binding = 0)] frame: &GiFrameParams,
    #[spirv(storage_buffer, descriptor_set = 0, binding = 1)] camera: &CameraParams,
    #[spirv(descriptor_set = 0, binding = 2)] depth: &DepthImage,
    #[spirv(descriptor_set = 0, binding = 3)] geometric_normal: &HalfImage,
    #[spirv(storage_buffer, descriptor_set = 0, binding = 4)] empty_tiles: &[u32],
    #[spirv(storage_buffer, descriptor_set = 0, binding = 5)] overrides: &[u32],
    #[spirv(storage_buffer, descriptor_set = 0, binding = 6)] spawns: &mut [u32],
    #[spirv(storage_buffer, descriptor_set = 0, binding = 7)] counters: &mut [u32],
) {
    let mut counters = DeviceWords(counters);
    let count = patch_count(frame, &counters, empty_tiles.len() as u32);
    if id.x >= count {
        return;
    }
    let tile = empty_tiles[id.x as usize];
    let surface = |pixel: UVec2| {
        if pixel.x >= camera.image_size[0] || pixel.y >= camera.image_size[1] {
            return false;
        }
        let d: f32 = depth.read(pixel);
        let gn: Vec4 = geometric_normal.read(pixel);
        sees_surface(d, gn)
    };
    if let Some(seed) = patch_seed(frame, tile, surface) {
        patch_tile(
            frame,
            tile,
            seed,
            overrides,
            &mut DeviceWords(spawns),
            &mut counters,
        );
    }
}
