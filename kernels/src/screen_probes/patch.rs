//! PatchScreenProbes (`gi_shared::screen_probes::patch`): with `FLAG_PATCHING`, one invocation
//! per empty tile claims its candidate spawn slots ([`claim_override_slots`], the lowest tile
//! wins each), then, in a second dispatch, moves the first slot it won into the tile (first
//! surface pixel from the tile's jittered one).
//!
//! Set 0 of both: frame (`GiFrameParams`), camera, G-buffer depth and geometric normal, empty
//! tiles, override words, spawns, GI counters. `ceil(probe_count / 64)` workgroups of 64.

use crate::atomics::DeviceWords;
use crate::gbuffer::{DepthImage, HalfImage};
use gi_shared::camera::CameraParams;
use gi_shared::screen_probes::GiFrameParams;
use gi_shared::screen_probes::patch::{
    claim_override_slots as claim, patch_count, patch_seed, patch_tile,
};
use gi_shared::screen_probes::spawn::sees_surface;
use spirv_std::glam::{UVec2, UVec3, Vec4};
use spirv_std::spirv;

/// Claims the candidate slots of entry `id.x` of the empty-tile list.
#[spirv(compute(threads(64)))]
#[allow(
    clippy::too_many_arguments,
    reason = "an entry point takes one argument per binding"
)]
pub fn claim_override_slots(
    #[spirv(global_invocation_id)] id: UVec3,
    #[spirv(storage_buffer, descriptor_set = 0, binding = 0)] frame: &GiFrameParams,
    #[spirv(storage_buffer, descriptor_set = 0, binding = 1)] camera: &CameraParams,
    #[spirv(descriptor_set = 0, binding = 2)] depth: &DepthImage,
    #[spirv(descriptor_set = 0, binding = 3)] geometric_normal: &HalfImage,
    #[spirv(storage_buffer, descriptor_set = 0, binding = 4)] empty_tiles: &[u32],
    #[spirv(storage_buffer, descriptor_set = 0, binding = 5)] overrides: &mut [u32],
    // The same set 0 as PatchScreenProbes, so that one descriptor list serves both.
    #[spirv(storage_buffer, descriptor_set = 0, binding = 6)] _spawns: &mut [u32],
    #[spirv(storage_buffer, descriptor_set = 0, binding = 7)] counters: &mut [u32],
) {
    let counters = DeviceWords(counters);
    if let Some((tile, _)) = empty_tile(
        frame,
        camera,
        depth,
        geometric_normal,
        empty_tiles,
        &counters,
        id.x,
    ) {
        claim(frame, tile, &mut DeviceWords(overrides), &counters);
    }
}

/// Patches entry `id.x` of the empty-tile list with the first slot it claimed.
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
    #[spirv(storage_buffer, descriptor_set = 0, binding = 5)] overrides: &mut [u32],
    #[spirv(storage_buffer, descriptor_set = 0, binding = 6)] spawns: &mut [u32],
    #[spirv(storage_buffer, descriptor_set = 0, binding = 7)] counters: &mut [u32],
) {
    let mut counters = DeviceWords(counters);
    if let Some((tile, seed)) = empty_tile(
        frame,
        camera,
        depth,
        geometric_normal,
        empty_tiles,
        &counters,
        id.x,
    ) {
        patch_tile(frame, tile, seed, overrides, spawns, &mut counters);
    }
}

/// Entry `index` of the empty-tile list and the seed patching would put there ([`patch_seed`]):
/// `None` past the list, without patching, or for a tile that is all sky.
#[inline]
fn empty_tile(
    frame: &GiFrameParams,
    camera: &CameraParams,
    depth: &DepthImage,
    geometric_normal: &HalfImage,
    empty_tiles: &[u32],
    counters: &DeviceWords<'_>,
    index: u32,
) -> Option<(u32, UVec2)> {
    if index >= patch_count(frame, counters, empty_tiles.len() as u32) {
        return None;
    }
    let tile = empty_tiles[index as usize];
    let sees = |pixel: UVec2| {
        if pixel.x >= camera.image_size[0] || pixel.y >= camera.image_size[1] {
            return false;
        }
        let d: f32 = depth.read(pixel);
        let gn: Vec4 = geometric_normal.read(pixel);
        sees_surface(d, gn)
    };
    patch_seed(frame, tile, sees).map(|seed| (tile, seed))
}
