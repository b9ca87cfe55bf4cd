//! ReprojectScreenProbes (`gi_shared::screen_probes::reproject`): one workgroup of 8 × 8 lanes per
//! probe tile picks, among its pixels, the best one to carry last frame's probe (workgroup
//! minimum of the reuse key), re-bins the old probe's cells into the new seed's hemisphere
//! (map, link, then gather, through workgroup memory), fills empty cells with the radiance
//! backup (taken once per probe) and
//! writes the tile's record, mask texel and cells; a tile without a probe that no spawn fills
//! joins the empty-tile list.
//!
//! Set 0: frame (`GiFrameParams`), camera, G-buffer depth and geometric normal, previous records,
//! previous mask, previous atlas, current records, current mask, current atlas, empty tiles, GI
//! counters, G-buffer motion. `[probe_grid.x, probe_grid.y, 1]` workgroups of 8 × 8.

use crate::atomics::{DeviceWords, WorkgroupWords};
use crate::gbuffer::{DepthImage, FloatImage, HalfImage};
use gi_shared::atomics::AtomicWords;
use gi_shared::camera::CameraParams;
use gi_shared::gbuffer::ReprojectionTexel;
use gi_shared::screen_probes::hemisphere::{gather_linked, link_mapped};
use gi_shared::screen_probes::radiance_backup::{backed_up_cell, probe_backup};
use gi_shared::screen_probes::reproject::{
    NO_WINNER, PreviousProbes, Reprojection, finish_tile, lane_pixel, map_source_cell,
    reprojection, reuse_candidate, source_cell, spawn_fills, winner_lane,
};
use gi_shared::screen_probes::spawn::probe_tile_spawn_seed;
use gi_shared::screen_probes::{GiFrameParams, LANES, PROBE_CELLS, ProbeRecord, StoredCell};
use spirv_std::arch::workgroup_memory_barrier_with_group_sync;
use spirv_std::glam::{UVec2, UVec3, Vec4};
use spirv_std::spirv;

/// The G-buffer's linear depth and geometric normal at `pixel`; the sky outside the image.
fn texel(
    camera: &CameraParams,
    depth: &DepthImage,
    geometric_normal: &HalfImage,
    pixel: UVec2,
) -> (f32, Vec4) {
    if pixel.x < camera.image_size[0] && pixel.y < camera.image_size[1] {
        let d: f32 = depth.read(pixel);
        let gn: Vec4 = geometric_normal.read(pixel);
        (d, gn)
    } else {
        (0.0, Vec4::ZERO)
    }
}

/// The G-buffer's motion at `pixel`; none outside the image.
fn motion_texel(camera: &CameraParams, motion: &FloatImage, pixel: UVec2) -> Vec4 {
    if pixel.x < camera.image_size[0] && pixel.y < camera.image_size[1] {
        motion.read(pixel)
    } else {
        Vec4::ZERO
    }
}

/// Reprojects probe tile `group.xy`; lane `local` is pixel, source cell and target cell `local`.
#[spirv(compute(threads(8, 8)))]
#[allow(
    clippy::too_many_arguments,
    reason = "an entry point takes one argument per binding"
)]
pub fn reproject_screen_probes(
    #[spirv(workgroup_id)] group: UVec3,
    #[spirv(local_invocation_index)] local: u32,
    #[spirv(storage_buffer, descriptor_set = 0, binding = 0)] frame: &GiFrameParams,
    #[spirv(storage_buffer, descriptor_set = 0, binding = 1)] camera: &CameraParams,
    #[spirv(descriptor_set = 0, binding = 2)] depth: &DepthImage,
    #[spirv(descriptor_set = 0, binding = 3)] geometric_normal: &HalfImage,
    #[spirv(storage_buffer, descriptor_set = 0, binding = 4)] previous_records: &[ProbeRecord],
    #[spirv(storage_buffer, descriptor_set = 0, binding = 5)] previous_mask: &[u32],
    #[spirv(storage_buffer, descriptor_set = 0, binding = 6)] previous_atlas: &[StoredCell],
    #[spirv(storage_buffer, descriptor_set = 0, binding = 7)] records: &mut [ProbeRecord],
    #[spirv(storage_buffer, descriptor_set = 0, binding = 8)] mask: &mut [u32],
    #[spirv(storage_buffer, descriptor_set = 0, binding = 9)] atlas: &mut [StoredCell],
    #[spirv(storage_buffer, descriptor_set = 0, binding = 10)] empty_tiles: &mut [u32],
    #[spirv(storage_buffer, descriptor_set = 0, binding = 11)] counters: &mut [u32],
    #[spirv(descriptor_set = 0, binding = 12)] motion: &FloatImage,
    #[spirv(workgroup)] key: &mut [u32; 1],
    #[spirv(workgroup)] sources: &mut [u32; LANES],
    #[spirv(workgroup)] mapped: &mut [u32; LANES],
    #[spirv(workgroup)] moved: &mut [[f32; 4]; LANES],
    #[spirv(workgroup)] gathered: &mut [[f32; 4]; LANES],
    #[spirv(workgroup)] heads: &mut [u32; LANES],
    #[spirv(workgroup)] next: &mut [u32; LANES],
    #[spirv(workgroup)] backup: &mut [[f32; 4]; 1],
) {
    let tile = UVec2::new(group.x, group.y);
    // Uniform over the workgroup: the whole group leaves before any barrier.
    if tile.x >= frame.probe_grid[0] || tile.y >= frame.probe_grid[1] {
        return;
    }
    let tile_index = tile.y * frame.probe_grid[0] + tile.x;
    let lane = local % PROBE_CELLS;
    let l = lane as usize;
    let mut key = WorkgroupWords(key);
    if lane == 0 {
        key.store(0, NO_WINNER);
    }
    workgroup_memory_barrier_with_group_sync();

    // Phase 1: this lane's pixel offers the previous probe it may reuse.
    let pixel = lane_pixel(tile, lane);
    let (d, gn) = texel(camera, depth, geometric_normal, pixel);
    let own = ReprojectionTexel {
        depth: d,
        geometric_normal: gn,
        motion: motion_texel(camera, motion, pixel),
    };
    let previous = PreviousProbes {
        records: previous_records,
        mask: previous_mask,
        atlas: previous_atlas,
    };
    let candidate = reuse_candidate(frame, camera, pixel, lane, own, &previous);
    sources[l] = candidate.source;
    if candidate.key != NO_WINNER {
        key.fetch_min(0, candidate.key);
    }
    workgroup_memory_barrier_with_group_sync();

    // Phase 2: the winner's probe; this lane maps source cell `lane`.
    let r = match winner_lane(key.load(0)) {
        Some(w) => {
            let seed = lane_pixel(tile, w);
            let (sd, sgn) = texel(camera, depth, geometric_normal, seed);
            let source = sources[w as usize];
            reprojection(camera, seed, sd, sgn, source, previous_records)
        }
        None => Reprojection::NONE,
    };
    let cell = source_cell(previous_atlas, r.source, lane);
    let (target, moved_cell) = map_source_cell(frame, &r, lane, cell);
    mapped[l] = target;
    moved[l] = moved_cell;
    workgroup_memory_barrier_with_group_sync();

    // Phase 3: one lane links each cell's sources; this lane gathers target cell `lane`; one
    // lane takes the probe's backup; this lane backs its cell up and writes it.
    if lane == 0 {
        link_mapped(mapped, heads, next);
    }
    workgroup_memory_barrier_with_group_sync();
    gathered[l] = gather_linked(heads, next, moved, lane);
    workgroup_memory_barrier_with_group_sync();
    if lane == 0 {
        backup[0] = probe_backup(frame, gathered);
    }
    workgroup_memory_barrier_with_group_sync();
    let out = backed_up_cell(frame, gathered[l], backup[0]);
    let i = (tile_index * PROBE_CELLS + lane) as usize;
    if i < atlas.len() {
        atlas[i] = StoredCell::pack(out);
    }
    if lane == 0 {
        let spawn_seed = probe_tile_spawn_seed(frame, tile_index);
        let (seed_depth, seed_normal) = match spawn_seed {
            Some(seed) => texel(camera, depth, geometric_normal, seed),
            None => (0.0, Vec4::ZERO),
        };
        let spawned = !r.is_valid() && spawn_fills(spawn_seed.is_some(), seed_depth, seed_normal);
        finish_tile(
            tile_index,
            &r.record,
            spawned,
            records,
            mask,
            empty_tiles,
            &mut DeviceWords(counters),
        );
    }
}
