//! Probe patching (GI-1.0 step 5, PatchScreenProbes): adaptive sampling of disocclusions. A
//! spawn whose probe tile already holds a reprojected probe (its override word open,
//! [`OVERRIDE_OPEN`](super::spawn::OVERRIDE_OPEN), set by SpawnScreenProbes) is worth less than a probe for a tile that has
//! none, so each empty tile (listed by ReprojectScreenProbes) takes over such a spawn and moves
//! its seed into itself.
//!
//! The new seed is the tile's own Halton-jittered pixel (`tile × 8 + spawn_jitter(frame, 8)`) or,
//! on the sky, the first surface pixel after it in row order (wrapping around the tile)
//! ([`patch_seed`]). Each empty tile draws [`PATCH_ATTEMPTS`] spawn slots from a stream keyed by
//! the tile ([`patch_candidates`]). Two dispatches decide who gets a slot, whatever order the GPU
//! runs them in: the first claims every open candidate with an atomic minimum of `tile + 1`
//! ([`claim_override_slots`]), so each slot goes to the lowest tile that drew it; the second
//! lets each tile take the first of its candidates it won ([`patch_tile`]). A frame thus patches
//! the same tiles from the same spawns run after run (an appended override list and a
//! compare-exchange made the winners, and so the image, depend on the GPU's scheduling).
//!
//! Kernels (`kernels/src/screen_probes/patch.rs`): ClaimOverrideSlots, then PatchScreenProbes,
//! one invocation per entry of the empty-tile list, with [`FLAG_PATCHING`].

use glam::UVec2;

use super::spawn::OVERRIDE_CLOSED;
use super::{
    EMPTY_COUNT, FLAG_PATCHING, GiFrameParams, OVERRIDE_COUNT, PASS_PATCH, PATCHED_COUNT,
    PROBE_CELLS, PROBE_SIZE,
};
use crate::append_list::clamped_count;
use crate::atomics::AtomicWords;
use crate::packing::pack_seed;
use crate::random::{Random, spawn_jitter};
use crate::world_cache::pass_random;

/// Spawn slots an empty tile draws: it takes the first it wins. Each draw finds an open slot
/// with the share of spawns whose tile kept its probe (most of them while the camera moves
/// slowly), so 8 draws leave a tile unpatched only where few spawns are open or many empty
/// tiles compete.
pub const PATCH_ATTEMPTS: u32 = 8;

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

/// The [`PATCH_ATTEMPTS`] spawn slots empty tile `tile` draws this frame, uniform over the spawn
/// list (all zero without one).
#[inline]
pub fn patch_candidates(frame: &GiFrameParams, tile: u32) -> [u32; PATCH_ATTEMPTS as usize] {
    let mut slots = [0u32; PATCH_ATTEMPTS as usize];
    if frame.spawn_capacity == 0 {
        return slots;
    }
    let mut random = patch_random(frame, tile);
    let mut k = 0;
    while k < PATCH_ATTEMPTS as usize {
        slots[k] = random.next_u32() % frame.spawn_capacity;
        k += 1;
    }
    slots
}

/// Whether any spawn's override word is open this frame (else no tile can be patched).
#[inline]
pub fn any_override<W: AtomicWords + ?Sized>(counters: &W) -> bool {
    OVERRIDE_COUNT < counters.word_count()
        && PATCHED_COUNT < counters.word_count()
        && counters.load(OVERRIDE_COUNT) > 0
}

/// ClaimOverrideSlots for empty tile `tile`: each of its [`patch_candidates`] whose override word
/// is not closed takes the minimum of that word and `tile + 1`.
#[inline]
pub fn claim_override_slots<W: AtomicWords + ?Sized, C: AtomicWords + ?Sized>(
    frame: &GiFrameParams,
    tile: u32,
    overrides: &mut W,
    counters: &C,
) {
    if !any_override(counters) {
        return;
    }
    let candidates = patch_candidates(frame, tile);
    let mut k = 0;
    while k < PATCH_ATTEMPTS as usize {
        let c = candidates[k] as usize;
        if c < overrides.word_count() && overrides.load(c) != OVERRIDE_CLOSED {
            overrides.fetch_min(c, tile + 1);
        }
        k += 1;
    }
}

/// What patching did for one empty tile.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub struct Patched {
    /// Which of the tile's candidates it took (0..[`PATCH_ATTEMPTS`]).
    pub attempt: u32,
    /// The spawn slot whose seed was replaced.
    pub spawn: u32,
    /// The seed it held.
    pub replaced: u32,
}

/// PatchScreenProbes for empty tile `tile` with `seed` (from [`patch_seed`]), after every tile's
/// [`claim_override_slots`]: the first of its candidates whose override word holds `tile + 1`
/// gets the seed; a success counts [`PATCHED_COUNT`]. `None` when the tile won no slot. Only
/// the winner of a slot writes it, so plain stores suffice.
#[inline]
pub fn patch_tile<W: AtomicWords + ?Sized>(
    frame: &GiFrameParams,
    tile: u32,
    seed: UVec2,
    overrides: &[u32],
    spawns: &mut [u32],
    counters: &mut W,
) -> Option<Patched> {
    if !any_override(counters) {
        return None;
    }
    let candidates = patch_candidates(frame, tile);
    let mut k = 0;
    while k < PATCH_ATTEMPTS as usize {
        let c = candidates[k] as usize;
        if c < overrides.len() && c < spawns.len() && overrides[c] == tile + 1 {
            let replaced = spawns[c];
            spawns[c] = pack_seed(seed);
            counters.fetch_add(PATCHED_COUNT, 1);
            return Some(Patched {
                attempt: k as u32,
                spawn: c as u32,
                replaced,
            });
        }
        k += 1;
    }
    None
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::hash_cells::shared_words::SharedWords;
    use crate::packing::unpack_seed;
    use crate::screen_probes::spawn::OVERRIDE_OPEN;
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

    /// The spawn list of `frame` (every spawn seed), its override words open on the slots
    /// `open` selects.
    fn spawn_list(
        frame: &GiFrameParams,
        open: impl Fn(u32) -> bool,
    ) -> (Vec<u32>, Vec<u32>, [u32; GI_COUNTER_WORDS]) {
        let spawns: Vec<u32> = (0..frame.spawn_capacity)
            .map(|i| pack_seed(spawn_seed_of(frame, i).unwrap()))
            .collect();
        let overrides: Vec<u32> = (0..frame.spawn_capacity)
            .map(|i| {
                if open(i) {
                    OVERRIDE_OPEN
                } else {
                    OVERRIDE_CLOSED
                }
            })
            .collect();
        let mut counters = [0u32; GI_COUNTER_WORDS];
        counters[SPAWN_COUNT] = spawns.len() as u32;
        counters[OVERRIDE_COUNT] = overrides.iter().filter(|&&o| o == OVERRIDE_OPEN).count() as u32;
        (spawns, overrides, counters)
    }

    /// Claims then patches every tile of `tiles`, claims in `order`: what each tile took.
    fn patch_all(
        f: &GiFrameParams,
        tiles: &[u32],
        order: &[usize],
        spawns: &mut [u32],
        overrides: &mut [u32],
        counters: &mut [u32; GI_COUNTER_WORDS],
    ) -> Vec<Option<Patched>> {
        for &i in order {
            claim_override_slots(f, tiles[i], &mut overrides[..], &counters[..]);
        }
        tiles
            .iter()
            .map(|&t| {
                let seed = UVec2::new(t % 8 * 8 + 3, t / 8 * 8 + 5);
                patch_tile(f, t, seed, overrides, spawns, &mut counters[..])
            })
            .collect()
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
    fn a_tile_takes_the_first_candidate_it_won() {
        let f = frame(3);
        let (mut spawns, mut overrides, mut counters) = spawn_list(&f, |_| true);
        let original = spawns.clone();
        let p = patch_all(&f, &[20], &[0], &mut spawns, &mut overrides, &mut counters)[0].unwrap();
        // Alone, the tile wins its first draw.
        assert_eq!(p.attempt, 0);
        assert_eq!(p.spawn, patch_candidates(&f, 20)[0]);
        assert_eq!(p.replaced, original[p.spawn as usize]);
        assert_eq!(unpack_seed(spawns[p.spawn as usize]), UVec2::new(35, 21));
        assert_eq!(counters[PATCHED_COUNT], 1);
        let changed = spawns.iter().zip(&original).filter(|(a, b)| a != b).count();
        assert_eq!(changed, 1);
        // Closed slots are never drawn into: with only the third candidate open, it is taken.
        let third = patch_candidates(&f, 20)[2];
        let (mut spawns, mut overrides, mut counters) = spawn_list(&f, |i| i == third);
        let p = patch_all(&f, &[20], &[0], &mut spawns, &mut overrides, &mut counters)[0].unwrap();
        let first = patch_candidates(&f, 20)
            .iter()
            .position(|&c| c == third)
            .unwrap();
        assert_eq!((p.attempt, p.spawn), (first as u32, third));
        // Another frame, other draws.
        let g = frame(4);
        assert!((0..40).any(|t| patch_candidates(&f, t) != patch_candidates(&g, t)));
    }

    #[test]
    fn the_lowest_tile_wins_a_shared_slot_whatever_the_order() {
        let f = frame(3);
        // One open slot, drawn by several tiles: the lowest of them gets it.
        let tiles: Vec<u32> = (0..40).collect();
        let slot = patch_candidates(&f, 5)[0];
        let drawers: Vec<u32> = tiles
            .iter()
            .copied()
            .filter(|&t| patch_candidates(&f, t).contains(&slot))
            .collect();
        let forward: Vec<usize> = (0..tiles.len()).collect();
        let backward: Vec<usize> = forward.iter().rev().copied().collect();
        let mut results = vec![];
        for order in [&forward, &backward] {
            let (mut spawns, mut overrides, mut counters) = spawn_list(&f, |i| i == slot);
            let r = patch_all(
                &f,
                &tiles,
                order,
                &mut spawns,
                &mut overrides,
                &mut counters,
            );
            let winners: Vec<u32> = r
                .iter()
                .enumerate()
                .filter_map(|(t, p)| p.map(|_| t as u32))
                .collect();
            assert_eq!(winners, vec![drawers[0]]);
            assert_eq!(counters[PATCHED_COUNT], 1);
            results.push((spawns, overrides));
        }
        assert_eq!(results[0], results[1]);
    }

    #[test]
    fn without_open_slots_or_the_flag_nothing_is_patched() {
        let f = frame(3);
        let (mut spawns, mut overrides, mut counters) = spawn_list(&f, |_| false);
        let original = spawns.clone();
        let r = patch_all(&f, &[3], &[0], &mut spawns, &mut overrides, &mut counters);
        assert_eq!(r, vec![None]);
        assert_eq!(spawns, original);
        counters[EMPTY_COUNT] = 7;
        assert_eq!(patch_count(&f, &counters[..], 100), 7);
        assert_eq!(patch_count(&f, &counters[..], 5), 5);
        let off = GiFrameParams { flags: 0, ..f };
        assert_eq!(patch_count(&off, &counters[..], 100), 0);
    }

    #[test]
    fn concurrent_claims_give_the_same_patches_as_sequential_ones() {
        let f = frame(11);
        let tiles: Vec<u32> = (0..64).collect();
        let open = |i: u32| i.is_multiple_of(3);
        let (mut spawns, mut overrides, mut counters) = spawn_list(&f, open);
        let order: Vec<usize> = (0..64).collect();
        let sequential = patch_all(
            &f,
            &tiles,
            &order,
            &mut spawns,
            &mut overrides,
            &mut counters,
        );
        let (spawns2, overrides2, counters2) = spawn_list(&f, open);
        let claims: Vec<AtomicU32> = overrides2.into_iter().map(AtomicU32::new).collect();
        std::thread::scope(|s| {
            for thread in 0..4u32 {
                let claims = &claims;
                s.spawn(move || {
                    for tile in (thread..64).step_by(4).rev() {
                        claim_override_slots(&f, tile, &mut SharedWords(claims), &counters2[..]);
                    }
                });
            }
        });
        let claimed: Vec<u32> = claims.iter().map(|c| c.load(Ordering::SeqCst)).collect();
        assert_eq!(claimed, overrides);
        let mut spawns2 = spawns2;
        let mut counters2 = counters2;
        let concurrent: Vec<Option<Patched>> = tiles
            .iter()
            .map(|&t| {
                let seed = UVec2::new(t % 8 * 8 + 3, t / 8 * 8 + 5);
                patch_tile(&f, t, seed, &claimed, &mut spawns2, &mut counters2[..])
            })
            .collect();
        assert_eq!(concurrent, sequential);
        assert_eq!(spawns2, spawns);
        // Every patched slot went to one tile only.
        let mut slots: Vec<u32> = sequential.iter().flatten().map(|p| p.spawn).collect();
        let n = slots.len();
        slots.sort();
        slots.dedup();
        assert_eq!(slots.len(), n);
        // 6 of the 16 slots are open; 64 tiles drawing 8 each take nearly all of them.
        assert!((4..=6).contains(&n), "{n} tiles patched");
    }
}
