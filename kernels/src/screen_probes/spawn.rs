//! SpawnScreenProbes (`gi_shared::screen_probes::spawn`): one invocation per spawn tile writes
//! the tile's jittered seed to its own slot of the spawn list (none for the sky), and opens the
//! slot's override word when its probe tile already holds a reprojected probe.
//!
//! Set 0: frame (`GiFrameParams`), camera, G-buffer depth and geometric normal, this frame's
//! probe records, spawns, overrides, GI counters. `ceil(spawn_capacity / 64)` workgroups of 64.

use crate::atomics::DeviceWords;
use crate::gbuffer::{DepthImage, HalfImage};
use gi_shared::camera::CameraParams;
use gi_shared::screen_probes::spawn::{SpawnSeed, spawn_probe, spawn_seed_of};
use gi_shared::screen_probes::{GiFrameParams, ProbeRecord};
use spirv_std::glam::UVec3;
use spirv_std::spirv;

/// Spawns the probe of spawn tile `id.x`.
#[spirv(compute(threads(64)))]
#[allow(
    clippy::too_many_arguments,
    reason = "an entry point takes one argument per binding"
)]
pub fn spawn_screen_probes(
    #[spirv(global_invocation_id)] id: UVec3,
    #[spirv(storage_buffer, descriptor_set = 0, binding = 0)] frame: &GiFrameParams,
    #[spirv(storage_buffer, descriptor_set = 0, binding = 1)] camera: &CameraParams,
    #[spirv(descriptor_set = 0, binding = 2)] depth: &DepthImage,
    #[spirv(descriptor_set = 0, binding = 3)] geometric_normal: &HalfImage,
    #[spirv(storage_buffer, descriptor_set = 0, binding = 4)] records: &[ProbeRecord],
    #[spirv(storage_buffer, descriptor_set = 0, binding = 5)] spawns: &mut [u32],
    #[spirv(storage_buffer, descriptor_set = 0, binding = 6)] overrides: &mut [u32],
    #[spirv(storage_buffer, descriptor_set = 0, binding = 7)] counters: &mut [u32],
) {
    let seed = spawn_seed_of(frame, id.x)
        .filter(|seed| seed.x < camera.image_size[0] && seed.y < camera.image_size[1]);
    let seed = match seed {
        Some(pixel) => SpawnSeed {
            pixel,
            depth: depth.read(pixel),
            geometric_normal: geometric_normal.read(pixel),
        },
        None => SpawnSeed::NONE,
    };
    spawn_probe(
        frame,
        id.x,
        seed,
        records,
        spawns,
        overrides,
        &mut DeviceWords(counters),
    );
}
