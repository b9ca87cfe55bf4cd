//! Probe reprojection (GI-1.0 step 2, ReprojectScreenProbes): each probe tile looks for last
//! frame's probe that may stand for one of its 64 pixels, makes the best such pixel its new seed
//! and carries the old probe's cells over into the new seed's hemisphere.
//!
//! One workgroup of 64 lanes per probe tile, in phases separated by barriers:
//!
//! 1. Per lane = pixel ([`lane_pixel`], [`reuse_candidate`]): the pixel's surface point is
//!    reprojected into the previous frame; the previous probe of the probe tile it lands in, when
//!    the previous mask holds one, is tested with [`reuse_score`]. The workgroup keeps the
//!    minimum key ([`pack_score_lane`]): the lowest score, then the pixel that sees the previous
//!    seed itself (so that a still camera keeps its seeds), then the lowest lane.
//! 2. The winner ([`winner_lane`], [`reprojection`]): the new record (position and normal of the
//!    winner's surface, its depth, age + 1) and the old probe as the source. Per lane = source
//!    cell ([`source_cell`], [`map_source_cell`]): where the cell lands in the new hemisphere
//!    (parallax-corrected with [`FLAG_PARALLAX`]).
//! 3. One lane links each target cell's sources (`hemisphere::link_mapped`), then per lane =
//!    target cell: `hemisphere::gather_linked` (64 reads per workgroup, not 64 × 64), then
//!    the radiance backup of empty cells with [`FLAG_RADIANCE_BACKUP`](super::FLAG_RADIANCE_BACKUP)
//!    (`radiance_backup::probe_backup` once per probe, `radiance_backup::backed_up_cell` per
//!    lane); lane 0 writes the record and the mask texel and counts ([`finish_tile`]).
//!
//! A tile without a winner (or with reprojection or history off) gets no probe
//! ([`ProbeRecord::NONE`], [`NO_PROBE`], empty cells) and joins the empty-tile list when no spawn
//! seed with a surface falls into it this frame (PatchScreenProbes then lends it a spawn).
//!
//! [`reproject_tile`] runs a tile's phases serially on the CPU, with the same functions in the
//! same order.

use super::LANES;
use super::StoredCell;
use glam::{UVec2, Vec2, Vec3, Vec4};

use super::hemisphere::{ProbeFrame, UNMAPPED, map_cell, record_frame};
use super::reuse::reuse_score;
use super::spawn::{probe_tile_spawn_seed, sees_surface};
use super::{
    EMPTY, EMPTY_COUNT, FLAG_HISTORY, FLAG_OBJECT_MOTION, FLAG_PARALLAX, FLAG_REPROJECTION,
    GiFrameParams, NO_PROBE, PROBE_CELLS, PROBE_SIZE, ProbeRecord, REPROJECTED_COUNT,
};
use crate::append_list::append;
use crate::atomics::AtomicWords;
use crate::camera::CameraParams;
use crate::gbuffer::{ReprojectionTexel, previous_point};
use crate::math::min_u32;
use crate::math::to_u32_clamped;
use crate::packing::{pack_score_lane, pack_seed, pack_snorm10x3, unpack_score_lane};
use crate::primary_surface::primary_surface;

/// The workgroup's key before any lane found a probe: above every [`pack_score_lane`] key.
pub const NO_WINNER: u32 = u32::MAX;

/// The pixel of lane `lane` in probe tile `tile`: `tile × 8 + (lane % 8, lane / 8)`.
#[inline]
pub fn lane_pixel(tile: UVec2, lane: u32) -> UVec2 {
    tile * PROBE_SIZE + UVec2::new(lane % PROBE_SIZE, (lane / PROBE_SIZE) % PROBE_SIZE)
}

/// Whether reprojection runs this frame: [`FLAG_REPROJECTION`] and [`FLAG_HISTORY`].
#[inline]
pub fn reprojection_enabled(frame: &GiFrameParams) -> bool {
    frame.has(FLAG_REPROJECTION | FLAG_HISTORY)
}

/// One lane's offer in phase 1.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub struct ReuseCandidate {
    /// The key the workgroup minimises ([`NO_WINNER`] for none).
    pub key: u32,
    /// The previous probe tile whose probe the lane may reuse ([`NO_PROBE`] for none).
    pub source: u32,
}

impl ReuseCandidate {
    /// No offer.
    pub const NONE: Self = Self {
        key: NO_WINNER,
        source: NO_PROBE,
    };
}

/// Phase 1 for the lane `lane` at `pixel` (its G-buffer `texel`; the previous frame's pixel and
/// position from [`previous_point`]): the
/// previous probe that may stand for the pixel's surface and the key of that reuse, or
/// [`ReuseCandidate::NONE`]. The key is `pack_score_lane(score, lane)`, with 64 added to the
/// lane unless the pixel reprojects onto the previous probe's own seed pixel: among equal
/// (half-float) scores the probe's own seed wins, then the lowest lane.
#[inline]
pub fn reuse_candidate(
    frame: &GiFrameParams,
    camera: &CameraParams,
    pixel: UVec2,
    lane: u32,
    texel: ReprojectionTexel,
    previous: &PreviousProbes,
) -> ReuseCandidate {
    let ReprojectionTexel {
        depth,
        geometric_normal,
        motion,
    } = texel;
    let (previous_records, previous_mask) = (previous.records, previous.mask);
    if !reprojection_enabled(frame) || !sees_surface(depth, geometric_normal) {
        return ReuseCandidate::NONE;
    }
    let surface = primary_surface(camera, pixel, depth, geometric_normal, geometric_normal);
    if !surface.valid {
        return ReuseCandidate::NONE;
    }
    let previous = previous_point(
        camera,
        pixel,
        surface.position,
        motion,
        frame.has(FLAG_OBJECT_MOTION),
    );
    if !previous.valid {
        return ReuseCandidate::NONE;
    }
    let Some(previous_pixel) = pixel_of(camera, previous.pixel_position) else {
        return ReuseCandidate::NONE;
    };
    let source = frame.probe_tile_of(previous_pixel);
    let s = source as usize;
    if source >= frame.probe_count || s >= previous_mask.len() || s >= previous_records.len() {
        return ReuseCandidate::NONE;
    }
    if previous_mask[s] == NO_PROBE {
        return ReuseCandidate::NONE;
    }
    let record = previous_records[s];
    if !record.is_valid() {
        return ReuseCandidate::NONE;
    }
    let Some(score) = reuse_score(
        frame,
        record.world_position(),
        record.world_normal(),
        previous.position,
        surface.geometric_normal,
    ) else {
        return ReuseCandidate::NONE;
    };
    let own_seed = previous_pixel == record.seed_pixel();
    let lane = lane % PROBE_CELLS;
    ReuseCandidate {
        key: pack_score_lane(score, if own_seed { lane } else { lane + PROBE_CELLS }),
        source,
    }
}

/// The pixel holding the continuous pixel position `p` (pixel centres at integer coordinates),
/// `None` off `camera`'s image.
#[inline]
pub fn pixel_of(camera: &CameraParams, p: Vec2) -> Option<UVec2> {
    let q = p + Vec2::splat(0.5);
    let size = camera.image_size_f32();
    // False for NaN too.
    if !(q.x >= 0.0 && q.y >= 0.0 && q.x < size.x && q.y < size.y) {
        return None;
    }
    let pixel = UVec2::new(to_u32_clamped(q.x), to_u32_clamped(q.y));
    // Rounding can reach the size for positions just below it.
    if pixel.x >= camera.image_size[0] || pixel.y >= camera.image_size[1] {
        return None;
    }
    Some(pixel)
}

/// The winning lane of the workgroup's minimum key, `None` for [`NO_WINNER`].
#[inline]
pub fn winner_lane(key: u32) -> Option<u32> {
    if key == NO_WINNER {
        None
    } else {
        Some(unpack_score_lane(key).1 % PROBE_CELLS)
    }
}

/// A tile's reprojection: the new probe and where its cells come from.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct Reprojection {
    /// The tile's record this frame ([`ProbeRecord::NONE`] without a probe).
    pub record: ProbeRecord,
    /// The previous probe tile the cells come from ([`NO_PROBE`] for none).
    pub source: u32,
    /// The previous probe's hemisphere.
    pub source_frame: ProbeFrame,
    /// The new probe's hemisphere.
    pub target_frame: ProbeFrame,
}

impl Reprojection {
    /// No probe.
    pub const NONE: Self = Self {
        record: ProbeRecord::NONE,
        source: NO_PROBE,
        source_frame: ProbeFrame {
            position: Vec3::ZERO,
            normal: Vec3::Z,
        },
        target_frame: ProbeFrame {
            position: Vec3::ZERO,
            normal: Vec3::Z,
        },
    };

    /// Whether the tile reprojected a probe.
    #[inline]
    pub fn is_valid(&self) -> bool {
        self.record.is_valid()
    }
}

/// The reprojection of the previous probe of tile `source` to the new seed `seed` (G-buffer
/// texel `depth`, `geometric_normal`): the new record takes the seed's surface point and
/// geometric normal, its depth and the old probe's age + 1. [`Reprojection::NONE`] when `source`
/// holds no probe or the seed sees no surface.
#[inline]
pub fn reprojection(
    camera: &CameraParams,
    seed: UVec2,
    depth: f32,
    geometric_normal: Vec4,
    source: u32,
    previous_records: &[ProbeRecord],
) -> Reprojection {
    if source as usize >= previous_records.len() {
        return Reprojection::NONE;
    }
    let previous = previous_records[source as usize];
    let surface = primary_surface(camera, seed, depth, geometric_normal, geometric_normal);
    if !previous.is_valid() || !surface.valid {
        return Reprojection::NONE;
    }
    let record = ProbeRecord {
        position: surface.position.to_array(),
        normal: pack_snorm10x3(surface.geometric_normal),
        seed: pack_seed(seed),
        depth,
        age: min_u32(previous.age, u32::MAX - 1) + 1,
        _pad: 0,
    };
    Reprojection {
        record,
        source,
        source_frame: record_frame(&previous),
        target_frame: record_frame(&record),
    }
}

/// Cell `lane` of the previous probe of tile `source` in the previous atlas, [`EMPTY`] when out
/// of range.
#[inline]
pub fn source_cell(previous_atlas: &[StoredCell], source: u32, lane: u32) -> [f32; 4] {
    if source == NO_PROBE || lane >= PROBE_CELLS {
        return EMPTY;
    }
    let i = source as usize * PROBE_CELLS as usize + lane as usize;
    if i < previous_atlas.len() {
        previous_atlas[i].unpack()
    } else {
        EMPTY
    }
}

/// Phase 2 for source cell `lane` (`cell` as the previous atlas holds it) of a valid
/// `reprojection`: the target cell it lands in ([`UNMAPPED`] for none) and the cell as the new
/// probe sees it.
#[inline]
pub fn map_source_cell(
    frame: &GiFrameParams,
    reprojection: &Reprojection,
    lane: u32,
    cell: [f32; 4],
) -> (u32, [f32; 4]) {
    if !reprojection.is_valid() {
        return (UNMAPPED, EMPTY);
    }
    match map_cell(
        &reprojection.source_frame,
        &reprojection.target_frame,
        lane,
        cell,
        frame.has(FLAG_PARALLAX),
    ) {
        Some((target, moved)) => (target, moved),
        None => (UNMAPPED, EMPTY),
    }
}

/// Whether a spawn will fill a probe tile this frame: a spawn seed falls into it (`has_seed`,
/// see [`probe_tile_spawn_seed`]) and its G-buffer texel (`depth`, `geometric_normal`) sees a
/// surface.
#[inline]
pub fn spawn_fills(has_seed: bool, depth: f32, geometric_normal: Vec4) -> bool {
    has_seed && sees_surface(depth, geometric_normal)
}

/// Lane 0's part of phase 3 for probe tile `tile`: writes the tile's `record` and mask mip-0
/// texel (its seed) and counts [`REPROJECTED_COUNT`]; a tile without a probe joins
/// `empty_tiles` (counter [`EMPTY_COUNT`]) unless `spawned` (a spawn seed with a surface falls
/// into it).
#[inline]
pub fn finish_tile<W: AtomicWords + ?Sized>(
    tile: u32,
    record: &ProbeRecord,
    spawned: bool,
    records: &mut [ProbeRecord],
    mask: &mut [u32],
    empty_tiles: &mut [u32],
    counters: &mut W,
) {
    let t = tile as usize;
    if t < records.len() {
        records[t] = *record;
    }
    if t < mask.len() {
        mask[t] = record.seed;
    }
    if record.is_valid() {
        counters.fetch_add(REPROJECTED_COUNT, 1);
    } else if !spawned && let Some(slot) = append(counters, EMPTY_COUNT, empty_tiles.len() as u32) {
        empty_tiles[slot as usize] = tile;
    }
}

/// The previous frame's probes, as ReprojectScreenProbes reads them.
#[derive(Clone, Copy, Debug)]
pub struct PreviousProbes<'a> {
    /// Records, one per probe tile.
    pub records: &'a [ProbeRecord],
    /// The probe mask (mip 0 = the first `probe_count` words).
    pub mask: &'a [u32],
    /// The atlas, 64 cells per probe tile.
    pub atlas: &'a [StoredCell],
}

/// This frame's probes and empty-tile list, as ReprojectScreenProbes writes them.
#[derive(Debug)]
pub struct CurrentProbes<'a> {
    /// Records, one per probe tile.
    pub records: &'a mut [ProbeRecord],
    /// The probe mask (mip 0 = the first `probe_count` words).
    pub mask: &'a mut [u32],
    /// The atlas, 64 cells per probe tile.
    pub atlas: &'a mut [StoredCell],
    /// The empty-tile list.
    pub empty_tiles: &'a mut [u32],
}

/// The CPU model of one workgroup of ReprojectScreenProbes: probe tile `tile`'s phases, run
/// serially in the kernel's order with the kernel's functions. `gbuffer(pixel)` gives the
/// G-buffer's linear depth, geometric normal and motion of a pixel inside the image; `counters` are the
/// GI counter words.
pub fn reproject_tile<G: Fn(UVec2) -> (f32, Vec4, Vec4)>(
    frame: &GiFrameParams,
    camera: &CameraParams,
    tile: UVec2,
    gbuffer: &G,
    previous: &PreviousProbes,
    current: &mut CurrentProbes,
    counters: &mut [u32],
) {
    if tile.x >= frame.probe_grid[0] || tile.y >= frame.probe_grid[1] {
        return;
    }
    let tile_index = tile.y * frame.probe_grid[0] + tile.x;
    let texel = |pixel: UVec2| {
        if pixel.x < frame.image_size[0] && pixel.y < frame.image_size[1] {
            gbuffer(pixel)
        } else {
            (0.0, Vec4::ZERO, Vec4::ZERO)
        }
    };
    // Phase 1.
    let mut key = [NO_WINNER];
    let mut sources = [NO_PROBE; LANES];
    for lane in 0..PROBE_CELLS {
        let pixel = lane_pixel(tile, lane);
        let (depth, normal, motion) = texel(pixel);
        let texel = ReprojectionTexel {
            depth,
            geometric_normal: normal,
            motion,
        };
        let c = reuse_candidate(frame, camera, pixel, lane, texel, previous);
        sources[lane as usize] = c.source;
        if c.key != NO_WINNER {
            key[..].fetch_min(0, c.key);
        }
    }
    // Phase 2.
    let r = match winner_lane(key[0]) {
        Some(w) => {
            let seed = lane_pixel(tile, w);
            let (depth, normal, _) = texel(seed);
            reprojection(
                camera,
                seed,
                depth,
                normal,
                sources[w as usize],
                previous.records,
            )
        }
        None => Reprojection::NONE,
    };
    let mut mapped = [UNMAPPED; LANES];
    let mut moved = [EMPTY; LANES];
    for lane in 0..PROBE_CELLS {
        let cell = source_cell(previous.atlas, r.source, lane);
        let (m, c) = map_source_cell(frame, &r, lane, cell);
        mapped[lane as usize] = m;
        moved[lane as usize] = c;
    }
    // Phase 3.
    let (heads, next) = super::hemisphere::linked(&mapped);
    let mut gathered = [EMPTY; LANES];
    for (lane, cell) in gathered.iter_mut().enumerate() {
        *cell = super::hemisphere::gather_linked(&heads, &next, &moved, lane as u32);
    }
    let backup = super::radiance_backup::probe_backup(frame, &gathered);
    for lane in 0..PROBE_CELLS {
        let i = (tile_index * PROBE_CELLS + lane) as usize;
        if i < current.atlas.len() {
            current.atlas[i] = StoredCell::pack(super::radiance_backup::backed_up_cell(
                frame,
                gathered[lane as usize],
                backup,
            ));
        }
    }
    let spawn_seed = probe_tile_spawn_seed(frame, tile_index);
    let (seed_depth, seed_normal, _) = match spawn_seed {
        Some(seed) => texel(seed),
        None => (0.0, Vec4::ZERO, Vec4::ZERO),
    };
    let spawned = !r.is_valid() && spawn_fills(spawn_seed.is_some(), seed_depth, seed_normal);
    finish_tile(
        tile_index,
        &r.record,
        spawned,
        current.records,
        current.mask,
        current.empty_tiles,
        counters,
    );
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::camera::view_projection;
    use crate::hash_cells::cell_size_const;
    use crate::packing::unpack_seed;
    use crate::screen_probes::FLAG_RADIANCE_BACKUP;
    use crate::screen_probes::GI_COUNTER_WORDS;
    use crate::screen_probes::spawn::tests::frame as base_frame;
    use crate::screen_probes::{MISS_DISTANCE, cell_radiance, make_cell};

    const W: u32 = 64;
    const H: u32 = 48;
    const FOV: f32 = 1.0;

    fn camera_at(x: f32) -> CameraParams {
        CameraParams::new(Vec3::new(x, 0.0, 0.0), Vec3::NEG_Z, Vec3::Y, FOV, W, H)
    }

    fn gi_frame(camera: &CameraParams, flags: u32, frame_index: u32) -> GiFrameParams {
        GiFrameParams {
            flags,
            probe_cell_const: cell_size_const(FOV, W, H, 8.0),
            eye: camera.position,
            previous_eye: camera.position,
            ..base_frame(W, H, 16, frame_index)
        }
    }

    /// The G-buffer of a camera facing the plane `z = plane_z` (normal +z, toward the camera).
    fn plane(camera: CameraParams, plane_z: f32) -> impl Fn(UVec2) -> (f32, Vec4) {
        move |pixel| {
            let ray = crate::camera::primary_ray(&camera, pixel, camera.jitter());
            let d = Vec3::from_array(ray.direction);
            let o = Vec3::from_array(ray.origin);
            let t = (plane_z - o.z) / d.z;
            let hit = o + d * t;
            (
                (hit - o).dot(camera.forward()),
                Vec4::new(0.0, 0.0, 1.0, 1.0),
            )
        }
    }

    /// Owned probe buffers of the test image.
    struct Probes {
        records: Vec<ProbeRecord>,
        mask: Vec<u32>,
        atlas: Vec<StoredCell>,
        empty: Vec<u32>,
    }

    impl Probes {
        fn new(frame: &GiFrameParams) -> Self {
            let n = frame.probe_count as usize;
            Self {
                records: vec![ProbeRecord::NONE; n],
                mask: vec![NO_PROBE; super::super::mask_words(frame.probe_grid) as usize],
                atlas: vec![StoredCell::EMPTY; n * PROBE_CELLS as usize],
                empty: vec![0; n],
            }
        }

        /// A probe at `seed` of the G-buffer `gbuffer` seen by `camera`, with `cells`.
        fn put<G: Fn(UVec2) -> (f32, Vec4)>(
            &mut self,
            frame: &GiFrameParams,
            camera: &CameraParams,
            gbuffer: &G,
            seed: UVec2,
            age: u32,
            cells: &[[f32; 4]; 64],
        ) -> ProbeRecord {
            let (d, n) = gbuffer(seed);
            let s = primary_surface(camera, seed, d, n, n);
            let record = ProbeRecord {
                position: s.position.to_array(),
                normal: pack_snorm10x3(s.geometric_normal),
                seed: pack_seed(seed),
                depth: d,
                age,
                _pad: 0,
            };
            let t = frame.probe_tile_of(seed) as usize;
            self.records[t] = record;
            self.mask[t] = record.seed;
            for (i, &c) in cells.iter().enumerate() {
                self.atlas[t * 64 + i] = StoredCell::pack(c);
            }
            record
        }

        fn cells(&self, tile: u32) -> Vec<[f32; 4]> {
            self.atlas[tile as usize * 64..tile as usize * 64 + 64]
                .iter()
                .map(|c| c.unpack())
                .collect()
        }
    }

    /// Runs every tile of the image; returns the current probes and the counters.
    fn run<G: Fn(UVec2) -> (f32, Vec4)>(
        frame: &GiFrameParams,
        camera: &CameraParams,
        gbuffer: &G,
        previous: &Probes,
    ) -> (Probes, [u32; GI_COUNTER_WORDS]) {
        let mut current = Probes::new(frame);
        current.mask.fill(0xdead);
        let mut counters = [0u32; GI_COUNTER_WORDS];
        let prev = PreviousProbes {
            records: &previous.records,
            mask: &previous.mask,
            atlas: &previous.atlas,
        };
        for y in 0..frame.probe_grid[1] {
            for x in 0..frame.probe_grid[0] {
                let mut cur = CurrentProbes {
                    records: &mut current.records,
                    mask: &mut current.mask,
                    atlas: &mut current.atlas,
                    empty_tiles: &mut current.empty,
                };
                reproject_tile(
                    frame,
                    camera,
                    UVec2::new(x, y),
                    // No motion texels: the camera reprojects.
                    &|p| {
                        let (d, n) = gbuffer(p);
                        (d, n, Vec4::ZERO)
                    },
                    &prev,
                    &mut cur,
                    &mut counters,
                );
            }
        }
        (current, counters)
    }

    fn numbered_cells(distance: f32) -> [[f32; 4]; 64] {
        core::array::from_fn(|i| {
            let d = if i % 7 == 0 { MISS_DISTANCE } else { distance };
            make_cell(Vec3::new(i as f32, 2.0 * i as f32, 1.0), d)
        })
    }

    const ON: u32 = FLAG_HISTORY | FLAG_REPROJECTION | FLAG_PARALLAX;

    #[test]
    fn a_still_camera_reprojects_a_probe_onto_itself() {
        let camera = camera_at(0.0);
        let frame = gi_frame(&camera, ON | FLAG_RADIANCE_BACKUP, 5);
        let gbuffer = plane(camera, -5.0);
        let mut previous = Probes::new(&frame);
        let seed = UVec2::new(19, 21);
        let cells = numbered_cells(3.0);
        let old = previous.put(&frame, &camera, &gbuffer, seed, 3, &cells);
        let (current, counters) = run(&frame, &camera, &gbuffer, &previous);
        let t = frame.probe_tile_of(seed);
        let new = current.records[t as usize];
        assert_eq!(unpack_seed(new.seed), seed);
        assert_eq!(new.position, old.position);
        assert_eq!(new.normal, old.normal);
        assert_eq!(new.depth, old.depth);
        assert_eq!(new.age, 4);
        assert_eq!(current.mask[t as usize], old.seed);
        for (i, (a, b)) in current.cells(t).iter().zip(&cells).enumerate() {
            assert_eq!(cell_radiance(*a), cell_radiance(*b), "cell {i}");
            let tolerance = 1e-4 * b[3];
            assert!((a[3] - b[3]).abs() <= tolerance, "cell {i}: {a:?} vs {b:?}");
        }
        // No other tile had a probe: none reprojects one, and those that no spawn fills are
        // listed empty.
        assert_eq!(counters[REPROJECTED_COUNT], 1);
        let mut expected_empty = Vec::new();
        for other in 0..frame.probe_count {
            if other == t {
                continue;
            }
            assert_eq!(current.records[other as usize], ProbeRecord::NONE);
            assert_eq!(current.mask[other as usize], NO_PROBE);
            assert!(current.cells(other).iter().all(|c| *c == EMPTY));
            if probe_tile_spawn_seed(&frame, other).is_none() {
                expected_empty.push(other);
            }
        }
        let n = counters[EMPTY_COUNT] as usize;
        assert_eq!(&current.empty[..n], &expected_empty[..]);
        assert!(n > 0 && n < frame.probe_count as usize);
        // The mask beyond mip 0 is not this pass's.
        assert_eq!(current.mask[frame.probe_count as usize], 0xdead);

        // Reprojection off (or no history): nothing is reused.
        for flags in [FLAG_HISTORY | FLAG_PARALLAX, FLAG_REPROJECTION] {
            let off = GiFrameParams { flags, ..frame };
            let (current, counters) = run(&off, &camera, &gbuffer, &previous);
            assert_eq!(current.records[t as usize], ProbeRecord::NONE);
            assert_eq!(counters[REPROJECTED_COUNT], 0);
            assert!(current.cells(t).iter().all(|c| *c == EMPTY));
        }
    }

    #[test]
    fn a_moving_camera_keeps_the_probe_and_re_bins_with_parallax() {
        let before = camera_at(0.0);
        // Three pixels at depth 5.
        let pixel_size = 2.0 * 5.0 * before.tan_half_fov_y / H as f32;
        let mut after = camera_at(3.0 * pixel_size);
        after.view_proj = view_projection(&after);
        let after = after.with_previous(&before);
        let prev_frame = gi_frame(&before, ON, 4);
        let seed = UVec2::new(24, 20);
        // One filled cell: the one closest to the normal, hitting 0.3 away.
        let f = ProbeFrame {
            position: Vec3::ZERO,
            normal: Vec3::Z,
        };
        let up = (0..PROBE_CELLS)
            .max_by(|&a, &b| f.cell_direction(a).z.total_cmp(&f.cell_direction(b).z))
            .unwrap();
        let mut cells = [EMPTY; 64];
        cells[up as usize] = make_cell(Vec3::new(1.0, 2.0, 3.0), 0.3);
        let mut previous = Probes::new(&prev_frame);
        let old = previous.put(&prev_frame, &before, &plane(before, -5.0), seed, 0, &cells);
        let gbuffer = plane(after, -5.0);
        let hit = old.world_position() + record_frame(&old).cell_direction(up) * 0.3;
        for flags in [ON, ON & !FLAG_PARALLAX, ON | FLAG_RADIANCE_BACKUP] {
            let frame = GiFrameParams {
                eye: after.position,
                previous_eye: before.position,
                ..gi_frame(&after, flags, 5)
            };
            let (current, counters) = run(&frame, &after, &gbuffer, &previous);
            // The old seed is now 3 pixels to the left, in the tile before, which keeps the
            // probe at its own seed; the old tile reuses it too, from another pixel.
            let moved_seed = seed - UVec2::new(3, 0);
            let left = frame.probe_tile_of(moved_seed) as usize;
            assert_eq!(unpack_seed(current.records[left].seed), moved_seed);
            let t = frame.probe_tile_of(seed);
            let new = current.records[t as usize];
            assert!(new.is_valid());
            assert_eq!(new.age, 1);
            assert_eq!(counters[REPROJECTED_COUNT], 2);
            let new_seed = unpack_seed(new.seed);
            assert_eq!(new_seed / 8, seed / 8);
            // Seen from the new probe, the hit lies elsewhere.
            let target = record_frame(&new);
            let offset = hit - target.position;
            let expected = target.direction_cell(offset.normalize()).unwrap();
            let filled: Vec<usize> = (0..64)
                .filter(|&i| current.cells(t)[i][3] >= 0.0 && current.cells(t)[i][3] < 1e8)
                .collect();
            assert_eq!(filled.len(), 1, "{flags:b}");
            let cell = current.cells(t)[filled[0]];
            assert_eq!(cell_radiance(cell), Vec3::new(1.0, 2.0, 3.0));
            if flags & FLAG_PARALLAX != 0 {
                assert_ne!(expected, up, "the test must move the cell");
                assert_eq!(filled[0], expected as usize);
                let e = offset.length() * crate::packing::WIDE16_MAX_RELATIVE_ERROR;
                assert!((cell[3] - offset.length()).abs() <= 1e-4 + e, "{cell:?}");
            } else {
                assert_eq!(filled[0], up as usize);
                // The stored cell's rounding of 0.3.
                assert_eq!(
                    cell[3],
                    crate::packing::unpack_wide16(crate::packing::pack_wide16(0.3))
                );
            }
            let backed = current
                .cells(t)
                .iter()
                .filter(|c| c[3] == MISS_DISTANCE)
                .count();
            if flags & FLAG_RADIANCE_BACKUP != 0 {
                assert_eq!(backed, 63);
                let b = current.cells(t)[(filled[0] + 1) % 64];
                assert_eq!(cell_radiance(b), Vec3::new(1.0, 2.0, 3.0));
            } else {
                assert_eq!(backed, 0);
            }
        }
    }

    #[test]
    fn a_depth_jump_fails_and_lists_the_tile_empty_unless_a_spawn_fills_it() {
        let camera = camera_at(0.0);
        let seed = UVec2::new(19, 21);
        // Frames where the spawn seed falls into the probe's tile, and where it does not.
        let tile = gi_frame(&camera, ON, 0).probe_tile_of(seed);
        let spawned = (0..64)
            .find(|&i| probe_tile_spawn_seed(&gi_frame(&camera, ON, i), tile).is_some())
            .unwrap();
        let not_spawned = (0..64)
            .find(|&i| probe_tile_spawn_seed(&gi_frame(&camera, ON, i), tile).is_none())
            .unwrap();
        for (frame_index, listed) in [(spawned, false), (not_spawned, true)] {
            let frame = gi_frame(&camera, ON | FLAG_RADIANCE_BACKUP, frame_index);
            let mut previous = Probes::new(&frame);
            previous.put(
                &frame,
                &camera,
                &plane(camera, -5.0),
                seed,
                2,
                &numbered_cells(1.0),
            );
            // The same surface reprojects; a surface 2 units closer does not.
            let (current, _) = run(&frame, &camera, &plane(camera, -5.0), &previous);
            assert!(current.records[tile as usize].is_valid());
            let (current, counters) = run(&frame, &camera, &plane(camera, -3.0), &previous);
            assert_eq!(current.records[tile as usize], ProbeRecord::NONE);
            assert_eq!(current.mask[tile as usize], NO_PROBE);
            assert!(current.cells(tile).iter().all(|c| *c == EMPTY));
            assert_eq!(counters[REPROJECTED_COUNT], 0);
            let n = counters[EMPTY_COUNT] as usize;
            assert_eq!(
                current.empty[..n].contains(&tile),
                listed,
                "frame {frame_index}"
            );
            // A spawn seed on the sky does not fill the tile.
            let sky = |pixel: UVec2| {
                if pixel / 8 == seed / 8 && probe_tile_spawn_seed(&frame, tile) == Some(pixel) {
                    (0.0, Vec4::ZERO)
                } else {
                    plane(camera, -3.0)(pixel)
                }
            };
            let (current, counters) = run(&frame, &camera, &sky, &previous);
            let n = counters[EMPTY_COUNT] as usize;
            assert!(current.empty[..n].contains(&tile));
        }
    }

    #[test]
    fn the_winner_key_prefers_the_lowest_score_then_the_own_seed_then_the_lane() {
        assert_eq!(winner_lane(NO_WINNER), None);
        let keys = [
            pack_score_lane(0.5, 3),
            pack_score_lane(0.25, 9 + PROBE_CELLS),
            pack_score_lane(0.25, 40),
            pack_score_lane(0.25, 2 + PROBE_CELLS),
        ];
        let best = keys.iter().copied().min().unwrap();
        assert_eq!(winner_lane(best), Some(40));
        let ties = [
            pack_score_lane(0.0, 9 + PROBE_CELLS),
            pack_score_lane(0.0, 2 + PROBE_CELLS),
        ];
        assert_eq!(winner_lane(ties.iter().copied().min().unwrap()), Some(2));
        assert_eq!(lane_pixel(UVec2::new(2, 3), 9), UVec2::new(17, 25));
        assert_eq!(lane_pixel(UVec2::new(0, 0), 63), UVec2::new(7, 7));
    }
}
