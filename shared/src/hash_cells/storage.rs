//! Tile storage: the key buffer holds one `u32` per tile slot, 0 for an empty slot, else the
//! checksum of the tile living there. A descriptor's bucket owns `2^tiles_per_bucket_log2`
//! consecutive slots ([`super::tile_slot`]); the slot index is the tile index of every per-tile
//! and per-cell buffer.
//!
//! Concurrency contract: inside one pass, slots only go from 0 to a checksum (inserts);
//! evictions (a checksum back to 0, [`super::purge`]) run in an earlier pass. Under that contract
//! [`insert_tile`] is exact under any interleaving:
//! - no duplicates: every inserter of a key tries the bucket's slots in the same order, and a slot
//!   never changes once set, so the first successful compare-exchange for a key is seen as that key
//!   by every later inserter before it reaches a slot past it (which then returns `Found`);
//! - no lost insert: an inserter only moves past a slot that holds another key for good;
//! - `Full` only when all slots hold other keys (which they then keep for the rest of the pass).
//!
//! The one race left is between passes' readers and writers: [`find_tile`] run in the same pass
//! as inserts may miss a key inserted concurrently, so lookups that must see this frame's inserts
//! run in a later pass.

use super::layout::HashGridParams;
use super::{CellDescriptor, MAX_NUM_TILES_LOG2, tile_slot};
use crate::atomics::AtomicWords;
use crate::math::min_u32;

/// Outcome of [`insert_tile`].
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum TileInsert {
    /// The key was already there (possibly inserted concurrently by another invocation).
    Found(u32),
    /// This call stored the key: the caller owns the tile's initialisation (append it to the live
    /// list, zero its values).
    Inserted(u32),
    /// Every slot of the bucket holds another key: the query gets no cache cell this frame.
    Full,
}

impl TileInsert {
    /// The tile index, unless the bucket was full.
    #[inline]
    pub fn tile(self) -> Option<u32> {
        match self {
            TileInsert::Found(tile) | TileInsert::Inserted(tile) => Some(tile),
            TileInsert::Full => None,
        }
    }
}

/// Slots per bucket: `2^tiles_per_bucket_log2` (exponent clamped like [`tile_slot`] does).
#[inline]
pub fn slots_per_bucket(params: &HashGridParams) -> u32 {
    1 << min_u32(params.tiles_per_bucket_log2, MAX_NUM_TILES_LOG2)
}

/// Finds or inserts the tile of `desc` in `keys` (see the module's concurrency contract): scans
/// the bucket for the checksum first (keys that survive from earlier frames may sit behind holes
/// left by eviction), then claims the first empty slot with compare-exchange(0 → checksum); a
/// compare-exchange that returns the checksum means another invocation inserted it meanwhile.
/// Slots beyond the end of `keys` count as taken. [`CellDescriptor::NONE`] gives `Full` without
/// touching the buffer (callers skip such descriptors before, so `Full` counts real overflow).
#[inline]
pub fn insert_tile<W: AtomicWords + ?Sized>(
    keys: &mut W,
    desc: &CellDescriptor,
    params: &HashGridParams,
) -> TileInsert {
    let checksum = desc.checksum;
    if checksum == 0 {
        return TileInsert::Full;
    }
    if let Some(tile) = find_tile(keys, desc, params) {
        return TileInsert::Found(tile);
    }
    let slots = slots_per_bucket(params);
    let len = keys.word_count();
    let mut slot = 0;
    while slot < slots {
        let tile = tile_slot(desc.bucket, slot, params.tiles_per_bucket_log2);
        if (tile as usize) < len {
            let old = keys.compare_exchange(tile as usize, 0, checksum);
            if old == 0 {
                return TileInsert::Inserted(tile);
            }
            if old == checksum {
                return TileInsert::Found(tile);
            }
        }
        slot += 1;
    }
    TileInsert::Full
}

/// The tile of `desc`, if its checksum is in its bucket. Scans every slot: eviction leaves holes,
/// so an empty slot does not end the search (unlike the reference, which stops at the first).
#[inline]
pub fn find_tile<W: AtomicWords + ?Sized>(
    keys: &W,
    desc: &CellDescriptor,
    params: &HashGridParams,
) -> Option<u32> {
    let checksum = desc.checksum;
    if checksum == 0 {
        return None;
    }
    let slots = slots_per_bucket(params);
    let len = keys.word_count();
    let mut slot = 0;
    while slot < slots {
        let tile = tile_slot(desc.bucket, slot, params.tiles_per_bucket_log2);
        if (tile as usize) < len && keys.load(tile as usize) == checksum {
            return Some(tile);
        }
        slot += 1;
    }
    None
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::hash_cells::shared_words::{SharedWords, atomic_buffer};
    use core::sync::atomic::Ordering::SeqCst;
    use glam::Vec3;

    fn params(buckets_log2: u32) -> HashGridParams {
        let mut p = HashGridParams::new(Vec3::ZERO, 0.01, 0);
        p.num_buckets_log2 = buckets_log2;
        p
    }

    fn desc(bucket: u32, checksum: u32) -> CellDescriptor {
        CellDescriptor {
            bucket,
            checksum,
            ..CellDescriptor::NONE
        }
    }

    #[test]
    fn sequential_insert_find_and_holes() {
        let p = params(2);
        let mut keys = vec![0u32; p.tile_count() as usize];
        let k: &mut [u32] = &mut keys;
        assert_eq!(insert_tile(k, &desc(1, 7), &p), TileInsert::Inserted(16));
        assert_eq!(insert_tile(k, &desc(1, 8), &p), TileInsert::Inserted(17));
        assert_eq!(insert_tile(k, &desc(1, 7), &p), TileInsert::Found(16));
        assert_eq!(find_tile(k, &desc(1, 8), &p), Some(17));
        assert_eq!(find_tile(k, &desc(2, 8), &p), None);
        // Evicting slot 16 leaves a hole: key 8 is still found behind it, and is not re-inserted.
        k.store(16, 0);
        assert_eq!(find_tile(k, &desc(1, 8), &p), Some(17));
        assert_eq!(insert_tile(k, &desc(1, 8), &p), TileInsert::Found(17));
        // A new key fills the hole.
        assert_eq!(insert_tile(k, &desc(1, 9), &p), TileInsert::Inserted(16));
        // NONE never writes a 0 key and is never found.
        assert_eq!(insert_tile(k, &CellDescriptor::NONE, &p), TileInsert::Full);
        assert_eq!(find_tile(k, &CellDescriptor::NONE, &p), None);
        assert_eq!(TileInsert::Found(3).tile(), Some(3));
        assert_eq!(TileInsert::Inserted(4).tile(), Some(4));
        assert_eq!(TileInsert::Full.tile(), None);
    }

    #[test]
    fn a_full_bucket_reports_full_and_never_hangs() {
        let p = params(1);
        let mut keys = vec![0u32; p.tile_count() as usize];
        let k: &mut [u32] = &mut keys;
        for c in 1..=16 {
            assert!(matches!(
                insert_tile(k, &desc(0, c), &p),
                TileInsert::Inserted(_)
            ));
        }
        assert_eq!(insert_tile(k, &desc(0, 17), &p), TileInsert::Full);
        assert_eq!(find_tile(k, &desc(0, 17), &p), None);
        // The other bucket is unaffected; existing keys are still found.
        assert_eq!(insert_tile(k, &desc(1, 17), &p), TileInsert::Inserted(16));
        assert_eq!(insert_tile(k, &desc(0, 5), &p), TileInsert::Found(4));
        // A key buffer shorter than the parameters claim: missing slots count as taken.
        let mut short = [0u32; 2];
        let s: &mut [u32] = &mut short;
        assert_eq!(insert_tile(s, &desc(0, 1), &p), TileInsert::Inserted(0));
        assert_eq!(insert_tile(s, &desc(0, 2), &p), TileInsert::Inserted(1));
        assert_eq!(insert_tile(s, &desc(0, 3), &p), TileInsert::Full);
        assert_eq!(insert_tile(s, &desc(1, 3), &p), TileInsert::Full);
    }

    /// Many threads insert overlapping key sets into 4 buckets, with holes pre-punched: every key
    /// lands exactly once, `Inserted` is reported once per stored key, and `Full` only for keys of
    /// buckets that hold 16 other keys.
    #[test]
    fn concurrent_inserts_are_exact() {
        let p = params(2);
        for round in 0..20u32 {
            let keys = atomic_buffer(p.tile_count() as usize);
            // Survivors of an earlier frame behind holes: bucket b keeps key 1000 + b in slot 5.
            for b in 0..4 {
                keys[(b * 16 + 5) as usize].store(1000 + b, SeqCst);
            }
            // Bucket 0 and 1 get few keys, buckets 2 and 3 more than fit.
            let per_bucket = [6u32, 15, 16, 40];
            let all: Vec<CellDescriptor> = (0..4u32)
                .flat_map(|b| (1..=per_bucket[b as usize]).map(move |c| desc(b, c)))
                .chain((0..4).map(|b| desc(b, 1000 + b)))
                .collect();
            let results: Vec<Vec<(CellDescriptor, TileInsert)>> = std::thread::scope(|s| {
                let handles: Vec<_> = (0..8u32)
                    .map(|t| {
                        let mut view = SharedWords(&keys);
                        let all = &all;
                        s.spawn(move || {
                            // Each thread inserts every key, in its own rotated order, twice.
                            let n = all.len();
                            (0..2 * n)
                                .map(|i| {
                                    let d = all[(i * (t as usize + 1) + round as usize) % n];
                                    (d, insert_tile(&mut view, &d, &p))
                                })
                                .collect()
                        })
                    })
                    .collect();
                handles.into_iter().map(|h| h.join().unwrap()).collect()
            });
            let final_keys: Vec<u32> = keys.iter().map(|k| k.load(SeqCst)).collect();
            for b in 0..4u32 {
                let bucket = &final_keys[(b * 16) as usize..(b * 16 + 16) as usize];
                let stored: Vec<u32> = bucket.iter().copied().filter(|&k| k != 0).collect();
                let mut unique = stored.clone();
                unique.sort_unstable();
                unique.dedup();
                assert_eq!(unique.len(), stored.len(), "duplicate key in bucket {b}");
                let wanted = per_bucket[b as usize] + 1;
                assert_eq!(stored.len() as u32, wanted.min(16), "bucket {b}");
                assert!(stored.contains(&(1000 + b)), "the survivor was re-inserted");
            }
            let mut inserted = vec![0u32; final_keys.len()];
            for (d, r) in results.iter().flatten() {
                match *r {
                    TileInsert::Found(t) => assert_eq!(final_keys[t as usize], d.checksum),
                    TileInsert::Inserted(t) => {
                        assert_eq!(final_keys[t as usize], d.checksum);
                        inserted[t as usize] += 1;
                    }
                    TileInsert::Full => {
                        // Only when the bucket holds 16 other keys.
                        let bucket = &final_keys[(d.bucket * 16) as usize..][..16];
                        assert!(bucket.iter().all(|&k| k != 0 && k != d.checksum));
                    }
                }
            }
            for (t, &k) in final_keys.iter().enumerate() {
                // Every stored key but the pre-stored survivors was inserted exactly once.
                let survivor = k >= 1000;
                assert_eq!(inserted[t], u32::from(k != 0 && !survivor), "tile {t}");
            }
        }
    }
}
