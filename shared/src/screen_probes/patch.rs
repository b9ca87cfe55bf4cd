//! Probe patching (GI-1.0 step 5, PatchScreenProbes): adaptive sampling of disocclusions. A
//! spawn whose probe tile already holds a reprojected probe (an *override* slot, listed by
//! SpawnScreenProbes) is worth less than a probe for a tile that has none, so each empty tile
//! (listed by ReprojectScreenProbes) takes a random override slot and moves that spawn's seed
//! into itself.
//!
//! The new seed is the tile's own Halton-jittered pixel (`tile × 8 + spawn_jitter(frame, 8)`) or,
//! on the sky, the first surface pixel after it in row order (wrapping around the tile)
//! ([`patch_seed`]). The slot is taken with a compare-exchange from the seed read before, and
//! only from a seed that SpawnScreenProbes put there ([`is_spawn_seed`]: a patched seed never is
//! one, since it lies in a tile that no spawn seed with a surface falls into), so two tiles never
//! patch the same slot; a tile that loses tries up to [`PATCH_ATTEMPTS`] slots in all
//! ([`patch_tile`]).
//!
//! Kernel PatchScreenProbes: one invocation per entry of the empty-tile list, with
//! [`FLAG_PATCHING`].

use glam::UVec2;

use super::spawn::is_spawn_seed;
use super::{
    EMPTY_COUNT, FLAG_PATCHING, GiFrameParams, OVERRIDE_COUNT, PASS_PATCH, PATCHED_COUNT,
    PROBE_CELLS, PROBE_SIZE,
};
use crate::append_list::clamped_count;
use crate::atomics::AtomicWords;
use crate::cache_view::pass_random;
use crate::packing::{SEED_NONE, pack_seed, unpack_seed};
use crate::random::{Random, spawn_jitter};

/// Override slots an empty tile tries at most (the first and up to 3 more after lost races).
pub const PATCH_ATTEMPTS: u32 = 4;

/// The number of empty tiles to patch: the empty-tile counter clamped to the list, or 0 without
/// [`FLAG_PATCHING`].
#[inline]
pub fn patch_count<W: AtomicWords + ?Sized>(
    frame: &GiFrameParams,
    counters: &W,
    capacity: u32,
) -> u32 {
    if !frame.has(FLAG_PATCHING) || EMPTY_COUNT >= counters.word_count() {
        return 0;
    }
    clamped_count(counters.load(EMPTY_COUNT), capacity)
}

/// Candidate `k` (0..64) of probe tile `tile`'s patch seed: the tile's jittered pixel for
/// `k = 0`, then the following pixels in row order, wrapping around the tile. `None` outside the
/// image or the probe grid.
#[inline]
pub fn patch_candidate(frame: &GiFrameParams, tile: u32, k: u32) -> Option<UVec2> {
    let width = frame.probe_grid[0];
    if width == 0 || tile >= frame.probe_count || k >= PROBE_CELLS {
        return None;
    }
    let origin = UVec2::new(tile % width, tile / width) * PROBE_SIZE;
    let jitter = spawn_jitter(frame.frame_index, PROBE_SIZE);
    let i = (jitter.x + PROBE_SIZE * jitter.y + k) % PROBE_CELLS;
    let pixel = origin + UVec2::new(i % PROBE_SIZE, i / PROBE_SIZE);
    if pixel.x < frame.image_size[0] && pixel.y < frame.image_size[1] {
        Some(pixel)
    } else {
        None
    }
}

/// The seed that patching puts into probe tile `tile`: the first [`patch_candidate`] for which
/// `sees_surface(pixel)` holds, `None` when the whole tile is sky.
#[inline]
pub fn patch_seed<F: Fn(UVec2) -> bool>(
    frame: &GiFrameParams,
    tile: u32,
    sees_surface: F,
) -> Option<UVec2> {
    let mut k = 0;
    while k < PROBE_CELLS {
        if let Some(pixel) = patch_candidate(frame, tile, k)
            && sees_surface(pixel)
        {
            return Some(pixel);
        }
        k += 1;
    }
    None
}

/// The random stream of empty tile `tile`'s slot choices.
#[inline]
pub fn patch_random(frame: &GiFrameParams, tile: u32) -> Random {
    pass_random(frame.seed, tile, PASS_PATCH, frame.frame_index)
}

/// A uniform override slot below `count` (which must be above 0).
#[inline]
pub fn pick_override_slot(random: &mut Random, count: u32) -> u32 {
    random.next_u32() % count
}

/// What patching did for one empty tile.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub struct Patched {
    /// The override slot taken.
    pub override_slot: u32,
    /// The spawn slot whose seed was replaced.
    pub spawn: u32,
    /// The seed it held.
    pub replaced: u32,
}

/// Patches empty tile `tile` with `seed` (from [`patch_seed`]): up to [`PATCH_ATTEMPTS`] random
/// slots of `overrides` (valid count from `counters[OVERRIDE_COUNT]`), each taken only if its
/// spawn still holds a seed of SpawnScreenProbes, by compare-exchange from that seed; a success
/// counts [`PATCHED_COUNT`]. `None` when there is no override slot or every attempt lost.
#[inline]
pub fn patch_tile<S: AtomicWords + ?Sized, W: AtomicWords + ?Sized>(
    frame: &GiFrameParams,
    tile: u32,
    seed: UVec2,
    overrides: &[u32],
    spawns: &mut S,
    counters: &mut W,
) -> Option<Patched> {
    if OVERRIDE_COUNT >= counters.word_count() || PATCHED_COUNT >= counters.word_count() {
        return None;
    }
    let count = clamped_count(counters.load(OVERRIDE_COUNT), overrides.len() as u32);
    if count == 0 {
        return None;
    }
    let new = pack_seed(seed);
    let mut random = patch_random(frame, tile);
    let mut attempt = 0;
    while attempt < PATCH_ATTEMPTS {
        attempt += 1;
        let slot = pick_override_slot(&mut random, count);
        let spawn = overrides[slot as usize];
        if spawn as usize >= spawns.word_count() {
            continue;
        }
        let old = spawns.load(spawn as usize);
        if old == SEED_NONE || !is_spawn_seed(frame, unpack_seed(old)) {
            // Already patched by another tile.
            continue;
        }
        if spawns.compare_exchange(spawn as usize, old, new) == old {
            counters.fetch_add(PATCHED_COUNT, 1);
            return Some(Patched {
                override_slot: slot,
                spawn,
                replaced: old,
            });
        }
    }
    None
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::hash_cells::shared_words::SharedWords;
    use crate::screen_probes::spawn::spawn_seed_of;
    use crate::screen_probes::spawn::tests::frame as base_frame;
    use crate::screen_probes::{GI_COUNTER_WORDS, SPAWN_COUNT};
    use core::sync::atomic::{AtomicU32, Ordering};

    fn frame(frame_index: u32) -> GiFrameParams {
        GiFrameParams {
            flags: FLAG_PATCHING,
            seed: 99,
            ..base_frame(64, 64, 16, frame_index)
        }
    }

    /// The spawn list of `frame` (every spawn seed) and `n` override slots on its first spawns.
    fn spawn_list(frame: &GiFrameParams, n: u32) -> (Vec<u32>, Vec<u32>, [u32; GI_COUNTER_WORDS]) {
        let spawns: Vec<u32> = (0..frame.spawn_capacity)
            .map(|i| pack_seed(spawn_seed_of(frame, i).unwrap()))
            .collect();
        let overrides: Vec<u32> = (0..n).collect();
        let mut counters = [0u32; GI_COUNTER_WORDS];
        counters[SPAWN_COUNT] = spawns.len() as u32;
        counters[OVERRIDE_COUNT] = n;
        (spawns, overrides, counters)
    }

    #[test]
    fn the_seed_is_the_jittered_pixel_or_the_first_surface_after_it() {
        let f = frame(6);
        let tile = 9; // (1, 1)
        let jitter = spawn_jitter(6, 8);
        let first = UVec2::new(8, 8) + jitter;
        assert_eq!(patch_seed(&f, tile, |_| true), Some(first));
        // Sky at the jittered pixel: the next one in row order.
        let next_index = (jitter.x + 8 * jitter.y + 1) % 64;
        let next = UVec2::new(8 + next_index % 8, 8 + next_index / 8);
        assert_eq!(patch_seed(&f, tile, |p| p != first), Some(next));
        // Only the pixel before the jittered one: found after wrapping around.
        let before_index = (jitter.x + 8 * jitter.y + 63) % 64;
        let before = UVec2::new(8 + before_index % 8, 8 + before_index / 8);
        assert_eq!(patch_seed(&f, tile, |p| p == before), Some(before));
        assert_eq!(patch_seed(&f, tile, |_| false), None);
        // Every candidate lies in the tile, each pixel once.
        let mut seen: Vec<UVec2> = (0..64)
            .filter_map(|k| patch_candidate(&f, tile, k))
            .collect();
        assert!(seen.iter().all(|p| *p / 8 == UVec2::new(1, 1)));
        seen.sort_by_key(|p| (p.y, p.x));
        seen.dedup();
        assert_eq!(seen.len(), 64);
        // Outside the image (a 60-pixel image cuts the last tile column).
        let cut = GiFrameParams {
            image_size: [60, 64],
            ..f
        };
        let edge = 7; // (7, 0): x 56..63
        assert!(patch_seed(&cut, edge, |_| true).unwrap().x < 60);
    }

    #[test]
    fn a_patch_replaces_a_random_override_seed_once() {
        let f = frame(3);
        let (mut spawns, overrides, mut counters) = spawn_list(&f, 5);
        let original = spawns.clone();
        let seed = UVec2::new(42, 13);
        let p = patch_tile(&f, 20, seed, &overrides, &mut spawns[..], &mut counters[..]).unwrap();
        // The slot is the stream's first pick.
        let mut r = patch_random(&f, 20);
        assert_eq!(p.override_slot, pick_override_slot(&mut r, 5));
        assert_eq!(p.spawn, overrides[p.override_slot as usize]);
        assert_eq!(p.replaced, original[p.spawn as usize]);
        assert_eq!(spawns[p.spawn as usize], pack_seed(seed));
        assert_eq!(counters[PATCHED_COUNT], 1);
        let changed = spawns.iter().zip(&original).filter(|(a, b)| a != b).count();
        assert_eq!(changed, 1);
        // Other tiles draw other slots.
        let slots: std::collections::BTreeSet<u32> = (0..40)
            .map(|t| pick_override_slot(&mut patch_random(&f, t), 5))
            .collect();
        assert_eq!(slots.len(), 5);
        // Another frame, another stream.
        let g = frame(4);
        let differs = (0..40).any(|t| {
            pick_override_slot(&mut patch_random(&f, t), 1000)
                != pick_override_slot(&mut patch_random(&g, t), 1000)
        });
        assert!(differs);
    }

    #[test]
    fn a_patched_slot_is_never_patched_again() {
        let f = frame(3);
        // One override slot: the first tile takes it, every other tile finds it patched.
        let (mut spawns, overrides, mut counters) = spawn_list(&f, 1);
        let a = patch_tile(
            &f,
            20,
            UVec2::new(42, 13),
            &overrides,
            &mut spawns[..],
            &mut counters[..],
        );
        assert!(a.is_some());
        for t in 21..30 {
            let b = patch_tile(
                &f,
                t,
                UVec2::new(1, 50),
                &overrides,
                &mut spawns[..],
                &mut counters[..],
            );
            assert_eq!(b, None);
        }
        assert_eq!(spawns[0], pack_seed(UVec2::new(42, 13)));
        assert_eq!(counters[PATCHED_COUNT], 1);
        // Two slots: the loser of a slot retries another, and gets it.
        let (mut spawns, overrides, mut counters) = spawn_list(&f, 2);
        let mut patched = 0;
        for t in 0..10 {
            let seed = UVec2::new(8 * t + 1, 60);
            if patch_tile(&f, t, seed, &overrides, &mut spawns[..], &mut counters[..]).is_some() {
                patched += 1;
            }
        }
        assert_eq!(patched, 2);
        assert_eq!(counters[PATCHED_COUNT], 2);
        assert!(!is_spawn_seed(&f, unpack_seed(spawns[0])));
        assert!(!is_spawn_seed(&f, unpack_seed(spawns[1])));
    }

    #[test]
    fn a_compare_exchange_lost_between_the_read_and_the_write_is_retried() {
        /// Words whose first compare-exchange finds another tile's patch already there.
        struct Racing<'a> {
            words: &'a mut [u32],
            intruder: Option<u32>,
        }
        impl AtomicWords for Racing<'_> {
            fn word_count(&self) -> usize {
                self.words.len()
            }
            fn load(&self, i: usize) -> u32 {
                self.words[i]
            }
            fn store(&mut self, i: usize, value: u32) {
                self.words[i] = value;
            }
            fn fetch_add(&mut self, i: usize, value: u32) -> u32 {
                self.words.fetch_add(i, value)
            }
            fn swap(&mut self, i: usize, value: u32) -> u32 {
                AtomicWords::swap(self.words, i, value)
            }
            fn compare_exchange(&mut self, i: usize, current: u32, new: u32) -> u32 {
                if let Some(seed) = self.intruder.take() {
                    self.words[i] = seed;
                }
                self.words.compare_exchange(i, current, new)
            }
            fn fetch_min(&mut self, i: usize, value: u32) -> u32 {
                self.words.fetch_min(i, value)
            }
            fn fetch_max(&mut self, i: usize, value: u32) -> u32 {
                self.words.fetch_max(i, value)
            }
        }
        let f = frame(3);
        let (mut spawns, overrides, mut counters) = spawn_list(&f, 8);
        let intruder = pack_seed(UVec2::new(5, 5));
        let mut racing = Racing {
            words: &mut spawns,
            intruder: Some(intruder),
        };
        let p = patch_tile(
            &f,
            7,
            UVec2::new(30, 40),
            &overrides,
            &mut racing,
            &mut counters[..],
        )
        .unwrap();
        // The first pick was lost to the intruder, whose seed stays; another slot was taken.
        let mut r = patch_random(&f, 7);
        let first = pick_override_slot(&mut r, 8);
        assert_ne!(p.override_slot, first);
        assert_eq!(spawns[overrides[first as usize] as usize], intruder);
        assert_eq!(spawns[p.spawn as usize], pack_seed(UVec2::new(30, 40)));
        assert_eq!(counters[PATCHED_COUNT], 1);
    }

    #[test]
    fn without_override_slots_or_the_flag_nothing_is_patched() {
        let f = frame(3);
        let (mut spawns, overrides, mut counters) = spawn_list(&f, 0);
        let original = spawns.clone();
        assert_eq!(
            patch_tile(
                &f,
                3,
                UVec2::new(30, 40),
                &overrides,
                &mut spawns[..],
                &mut counters[..]
            ),
            None
        );
        assert_eq!(spawns, original);
        counters[EMPTY_COUNT] = 7;
        assert_eq!(patch_count(&f, &counters[..], 100), 7);
        assert_eq!(patch_count(&f, &counters[..], 5), 5);
        let off = GiFrameParams { flags: 0, ..f };
        assert_eq!(patch_count(&off, &counters[..], 100), 0);
    }

    #[test]
    fn concurrent_patches_take_distinct_slots() {
        let f = frame(11);
        let (spawns, overrides, counters) = spawn_list(&f, 6);
        let spawns: Vec<AtomicU32> = spawns.into_iter().map(AtomicU32::new).collect();
        let counters: Vec<AtomicU32> = counters.into_iter().map(AtomicU32::new).collect();
        let won: Vec<AtomicU32> = (0..64).map(|_| AtomicU32::new(u32::MAX)).collect();
        std::thread::scope(|s| {
            for thread in 0..4u32 {
                let (spawns, counters, overrides, won) = (&spawns, &counters, &overrides, &won);
                s.spawn(move || {
                    for tile in (thread..64).step_by(4) {
                        let seed = UVec2::new(tile % 8 * 8 + 3, tile / 8 * 8 + 5);
                        let p = patch_tile(
                            &f,
                            tile,
                            seed,
                            overrides,
                            &mut SharedWords(spawns),
                            &mut SharedWords(counters),
                        );
                        if let Some(p) = p {
                            won[tile as usize].store(p.spawn, Ordering::SeqCst);
                        }
                    }
                });
            }
        });
        let winners: Vec<(u32, u32)> = (0..64)
            .filter_map(|t| {
                let s = won[t as usize].load(Ordering::SeqCst);
                (s != u32::MAX).then_some((t, s))
            })
            .collect();
        let patched = counters[PATCHED_COUNT].load(Ordering::SeqCst);
        assert_eq!(winners.len() as u32, patched);
        assert!((1..=6).contains(&patched));
        let mut slots: Vec<u32> = winners.iter().map(|w| w.1).collect();
        slots.sort();
        slots.dedup();
        assert_eq!(slots.len(), winners.len(), "a slot patched twice");
        // Each patched spawn holds its winner's seed.
        for (tile, spawn) in winners {
            let seed = UVec2::new(tile % 8 * 8 + 3, tile / 8 * 8 + 5);
            assert_eq!(
                spawns[spawn as usize].load(Ordering::SeqCst),
                pack_seed(seed)
            );
        }
    }
}
