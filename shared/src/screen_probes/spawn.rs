//! Probe spawning (GI-1.0 step 4, SpawnScreenProbes): each frame one *spawn seed* per spawn tile
//! (`spawn_tile` pixels square, 8, 16 or 32) gets a freshly traced probe. All tiles share this
//! frame's Halton(2, 3) jitter ([`spawn_jitter`]), so over frames every pixel position of a spawn
//! tile is visited. A seed on the sky spawns nothing.
//!
//! Each spawn tile owns its slot of the spawn list: the seed goes to slot `sy · spawn_grid.x +
//! sx`, [`SEED_NONE`] where the seed sees the sky (counted in [`SPAWN_COUNT`]). Fixed slots,
//! not appended ones, key every random stream of the probe's rays (and of the cache queries they
//! make), so that a frame does not depend on the order the GPU ran the spawns in. A spawn whose
//! probe tile already holds a reprojected probe would only refresh it, so its slot of the
//! override words is opened ([`OVERRIDE_OPEN`], counted in [`OVERRIDE_COUNT`]):
//! PatchScreenProbes may hand such a slot to a disoccluded tile instead (`super::patch`).
//!
//! Kernel SpawnScreenProbes: one invocation per spawn tile, index `sy · spawn_grid.x + sx`.

use glam::{UVec2, Vec4};

use super::{GiFrameParams, OVERRIDE_COUNT, PROBE_SIZE, ProbeRecord, SPAWN_COUNT};
use crate::atomics::AtomicWords;
use crate::packing::{SEED_NONE, pack_seed};
use crate::random::spawn_jitter;

/// Whether a G-buffer texel (linear depth, geometric normal) sees a surface rather than the sky:
/// depth above 0 and normal `w` above 0.
#[inline]
pub fn sees_surface(depth: f32, geometric_normal: Vec4) -> bool {
    depth > 0.0 && geometric_normal.w > 0.0
}

/// The spawn seed of spawn tile `tile` (coordinates) this frame: `tile × spawn_tile` plus this
/// frame's jitter, or `None` when it falls outside the image.
#[inline]
pub fn spawn_seed(frame: &GiFrameParams, tile: UVec2) -> Option<UVec2> {
    let pixel = tile * frame.spawn_tile + spawn_jitter(frame.frame_index, frame.spawn_tile);
    if pixel.x < frame.image_size[0] && pixel.y < frame.image_size[1] {
        Some(pixel)
    } else {
        None
    }
}

/// The spawn seed of spawn tile number `index` (`sy · spawn_grid.x + sx`), or `None` beyond the
/// spawn grid or outside the image.
#[inline]
pub fn spawn_seed_of(frame: &GiFrameParams, index: u32) -> Option<UVec2> {
    let width = frame.spawn_grid[0];
    if width == 0 || index >= frame.spawn_capacity {
        return None;
    }
    let tile = UVec2::new(index % width, index / width);
    if tile.y >= frame.spawn_grid[1] {
        return None;
    }
    spawn_seed(frame, tile)
}

/// Whether `pixel` is the spawn seed of its spawn tile this frame (a seed that SpawnScreenProbes
/// may have written, as opposed to one PatchScreenProbes put into a spawn slot).
#[inline]
pub fn is_spawn_seed(frame: &GiFrameParams, pixel: UVec2) -> bool {
    if frame.spawn_tile == 0 {
        return false;
    }
    match spawn_seed(frame, pixel / frame.spawn_tile) {
        Some(seed) => seed == pixel,
        None => false,
    }
}

/// The spawn seed that falls into probe tile number `probe_tile` this frame, if any (whether it
/// sees a surface is the caller's test, [`sees_surface`]). ReprojectScreenProbes lists a tile
/// that fails reprojection as empty only when no spawn will fill it.
#[inline]
pub fn probe_tile_spawn_seed(frame: &GiFrameParams, probe_tile: u32) -> Option<UVec2> {
    let width = frame.probe_grid[0];
    if width == 0 || frame.spawn_tile == 0 || probe_tile >= frame.probe_count {
        return None;
    }
    let tile = UVec2::new(probe_tile % width, probe_tile / width);
    let first = tile * PROBE_SIZE;
    let last = first + UVec2::splat(PROBE_SIZE - 1);
    // Spawn tiles of at least 8 pixels: at most 2 × 2 of them overlap a probe tile (exactly one
    // for the usual 8, 16 and 32, which are multiples of 8).
    let lo = first / frame.spawn_tile;
    let hi = last / frame.spawn_tile;
    let mut sy = lo.y;
    while sy <= hi.y {
        let mut sx = lo.x;
        while sx <= hi.x {
            if let Some(seed) = spawn_seed(frame, UVec2::new(sx, sy))
                && seed / PROBE_SIZE == tile
            {
                return Some(seed);
            }
            sx += 1;
        }
        sy += 1;
    }
    None
}

/// [`Spawned`]'s slot marker for "none".
pub const NO_SLOT: u32 = u32::MAX;

/// An override word of a spawn that patching may take (its probe tile holds a reprojected
/// probe); PatchScreenProbes lowers it to the claiming tile's index + 1.
pub const OVERRIDE_OPEN: u32 = u32::MAX;
/// An override word of a spawn that patching must leave alone.
pub const OVERRIDE_CLOSED: u32 = 0;

/// What one spawn did (plain words: the kernel returns it through no `Option`).
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub struct Spawned {
    /// The spawn slot the seed went to, [`NO_SLOT`] when nothing was spawned (sky, or a slot
    /// past the list).
    pub slot: u32,
    /// The same slot when its override word was opened, else [`NO_SLOT`].
    pub override_slot: u32,
}

impl Spawned {
    /// Nothing spawned.
    pub const NONE: Self = Self {
        slot: NO_SLOT,
        override_slot: NO_SLOT,
    };
}

/// A spawn's seed pixel and its G-buffer texel; [`SpawnSeed::NONE`] (no surface) where the spawn
/// tile's seed falls outside the image.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct SpawnSeed {
    /// The seed pixel.
    pub pixel: UVec2,
    /// Its linear depth.
    pub depth: f32,
    /// Its geometric normal texel.
    pub geometric_normal: Vec4,
}

impl SpawnSeed {
    /// No seed: it sees no surface.
    pub const NONE: Self = Self {
        pixel: UVec2::ZERO,
        depth: 0.0,
        geometric_normal: Vec4::ZERO,
    };
}

/// Spawn tile `slot`'s spawn at `seed`: the packed seed in `spawns[slot]` ([`SEED_NONE`] for the sky
/// or no seed) and, when `records` (this frame's reprojected probes) hold a probe for the seed's
/// probe tile, [`OVERRIDE_OPEN`] in `overrides[slot]` (else [`OVERRIDE_CLOSED`]). Counts
/// [`SPAWN_COUNT`] and [`OVERRIDE_COUNT`].
#[inline]
pub fn spawn_probe<W: AtomicWords + ?Sized>(
    frame: &GiFrameParams,
    slot: u32,
    seed: SpawnSeed,
    records: &[ProbeRecord],
    spawns: &mut [u32],
    overrides: &mut [u32],
    counters: &mut W,
) -> Spawned {
    let s = slot as usize;
    if s >= spawns.len() || s >= overrides.len() {
        return Spawned::NONE;
    }
    spawns[s] = SEED_NONE;
    overrides[s] = OVERRIDE_CLOSED;
    let SpawnSeed {
        pixel: seed,
        depth,
        geometric_normal,
    } = seed;
    if !sees_surface(depth, geometric_normal) {
        return Spawned::NONE;
    }
    spawns[s] = pack_seed(seed);
    counters.fetch_add(SPAWN_COUNT, 1);
    let tile = frame.probe_tile_of(seed) as usize;
    let reprojected = tile < records.len() && {
        let record = records[tile];
        record.is_valid()
    };
    let mut override_slot = NO_SLOT;
    if reprojected {
        overrides[s] = OVERRIDE_OPEN;
        counters.fetch_add(OVERRIDE_COUNT, 1);
        override_slot = slot;
    }
    Spawned {
        slot,
        override_slot,
    }
}

/// The seed of spawn slot `slot` in `spawns`, if one was spawned there (and the slot exists).
#[inline]
pub fn spawned_seed(spawns: &[u32], slot: u32) -> Option<u32> {
    if (slot as usize) < spawns.len() && spawns[slot as usize] != SEED_NONE {
        Some(spawns[slot as usize])
    } else {
        None
    }
}

#[cfg(test)]
pub(crate) mod tests {
    use super::*;
    use crate::packing::unpack_seed;
    use crate::screen_probes::{
        GI_COUNTER_WORDS, SPAWN_TILE_FULL, SPAWN_TILE_QUARTER, SPAWN_TILE_SIXTEENTH,
    };

    /// A frame of `width × height` pixels with spawn tiles of `spawn_tile` pixels.
    pub(crate) fn frame(
        width: u32,
        height: u32,
        spawn_tile: u32,
        frame_index: u32,
    ) -> GiFrameParams {
        let probe_grid = [width.div_ceil(8), height.div_ceil(8)];
        let spawn_grid = [width.div_ceil(spawn_tile), height.div_ceil(spawn_tile)];
        GiFrameParams {
            image_size: [width, height],
            probe_grid,
            spawn_grid,
            spawn_tile,
            frame_index,
            probe_count: probe_grid[0] * probe_grid[1],
            spawn_capacity: spawn_grid[0] * spawn_grid[1],
            ..Default::default()
        }
    }

    #[test]
    fn seeds_share_the_jitter_and_stay_in_their_tile_and_the_image() {
        for spawn_tile in [SPAWN_TILE_FULL, SPAWN_TILE_QUARTER, SPAWN_TILE_SIXTEENTH] {
            for frame_index in [0, 1, 2, 7, 255, 256, 1000] {
                let f = frame(100, 37, spawn_tile, frame_index);
                let jitter = spawn_jitter(frame_index, spawn_tile);
                let mut seen = 0;
                for index in 0..f.spawn_capacity + 3 {
                    let seed = spawn_seed_of(&f, index);
                    if index >= f.spawn_capacity {
                        assert_eq!(seed, None);
                        continue;
                    }
                    let tile = UVec2::new(index % f.spawn_grid[0], index / f.spawn_grid[0]);
                    let expected = tile * spawn_tile + jitter;
                    if expected.x < 100 && expected.y < 37 {
                        assert_eq!(seed, Some(expected));
                        assert_eq!(expected / spawn_tile, tile);
                        assert!(is_spawn_seed(&f, expected));
                        assert!(!is_spawn_seed(&f, expected + UVec2::X));
                        seen += 1;
                    } else {
                        assert_eq!(seed, None, "{expected} outside the image");
                    }
                }
                assert!(seen > 0);
            }
        }
        // The jitter changes from frame to frame.
        assert_ne!(spawn_jitter(1, 16), spawn_jitter(2, 16));
    }

    #[test]
    fn probe_tiles_know_the_seed_that_falls_into_them() {
        for spawn_tile in [
            SPAWN_TILE_FULL,
            SPAWN_TILE_QUARTER,
            SPAWN_TILE_SIXTEENTH,
            12,
        ] {
            for frame_index in 0..20 {
                let f = frame(77, 45, spawn_tile, frame_index);
                // Brute force: every seed, by probe tile.
                let mut expected = vec![None; f.probe_count as usize];
                for index in 0..f.spawn_capacity {
                    if let Some(seed) = spawn_seed_of(&f, index) {
                        let t = f.probe_tile_of(seed) as usize;
                        assert_eq!(expected[t], None, "two seeds in one probe tile");
                        expected[t] = Some(seed);
                    }
                }
                for t in 0..f.probe_count {
                    assert_eq!(
                        probe_tile_spawn_seed(&f, t),
                        expected[t as usize],
                        "tile {t}, spawn tile {spawn_tile}, frame {frame_index}"
                    );
                }
                assert_eq!(probe_tile_spawn_seed(&f, f.probe_count), None);
                if spawn_tile == SPAWN_TILE_FULL {
                    // Rate 1 (where the jittered seed stays inside the image): every tile.
                    let inside = expected.iter().filter(|s| s.is_some()).count();
                    assert!(inside >= ((77 / 8) * (45 / 8)) as usize);
                }
            }
        }
    }

    #[test]
    fn spawning_fills_its_own_slot_and_opens_overrides() {
        let f = frame(32, 32, 16, 3);
        let mut records = [ProbeRecord::NONE; 16];
        let seed = UVec2::new(17, 5);
        let tile = f.probe_tile_of(seed) as usize;
        records[tile].seed = pack_seed(UVec2::new(20, 6));
        let mut spawns = [7u32; 4];
        let mut overrides = [7u32; 4];
        let mut counters = [0u32; GI_COUNTER_WORDS];
        let surface = Vec4::new(0.0, 0.0, 1.0, 1.0);
        let c: &mut [u32] = &mut counters;
        // Sky (depth 0, or normal w 0) and no seed: the slot is cleared, nothing counted.
        for (d, n) in [(0.0, surface), (2.0, Vec4::new(0.0, 0.0, 1.0, 0.0))] {
            let s = spawn_probe(
                &f,
                2,
                SpawnSeed {
                    pixel: seed,
                    depth: d,
                    geometric_normal: n,
                },
                &records,
                &mut spawns,
                &mut overrides,
                c,
            );
            assert_eq!(s, Spawned::NONE);
            assert_eq!((spawns[2], overrides[2]), (SEED_NONE, OVERRIDE_CLOSED));
        }
        let s = spawn_probe(
            &f,
            3,
            SpawnSeed::NONE,
            &records,
            &mut spawns,
            &mut overrides,
            c,
        );
        assert_eq!(s, Spawned::NONE);
        assert_eq!((spawns[3], overrides[3]), (SEED_NONE, OVERRIDE_CLOSED));
        assert_eq!(c[SPAWN_COUNT], 0);
        assert_eq!(spawned_seed(&spawns, 3), None);
        // A tile without a reprojected probe: a spawn in its own slot, its override closed.
        let other = UVec2::new(3, 30);
        let s = spawn_probe(
            &f,
            1,
            SpawnSeed {
                pixel: other,
                depth: 2.0,
                geometric_normal: surface,
            },
            &records,
            &mut spawns,
            &mut overrides,
            c,
        );
        assert_eq!(
            s,
            Spawned {
                slot: 1,
                override_slot: NO_SLOT
            }
        );
        assert_eq!(unpack_seed(spawns[1]), other);
        assert_eq!(overrides[1], OVERRIDE_CLOSED);
        // A tile with one: both, in the same slot whatever ran before.
        let s = spawn_probe(
            &f,
            0,
            SpawnSeed {
                pixel: seed,
                depth: 2.0,
                geometric_normal: surface,
            },
            &records,
            &mut spawns,
            &mut overrides,
            c,
        );
        assert_eq!(
            s,
            Spawned {
                slot: 0,
                override_slot: 0
            }
        );
        assert_eq!(spawned_seed(&spawns, 0), Some(pack_seed(seed)));
        assert_eq!(overrides[0], OVERRIDE_OPEN);
        assert_eq!(c[SPAWN_COUNT], 2);
        assert_eq!(c[OVERRIDE_COUNT], 1);
        // A slot past the list spawns nothing.
        let s = spawn_probe(
            &f,
            4,
            SpawnSeed {
                pixel: seed,
                depth: 2.0,
                geometric_normal: surface,
            },
            &records,
            &mut spawns,
            &mut overrides,
            c,
        );
        assert_eq!(s, Spawned::NONE);
        assert_eq!(spawned_seed(&spawns, 4), None);
    }
}
