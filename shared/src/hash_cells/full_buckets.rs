//! Full buckets, settled the same way whatever order the GPU ran the inserts in.
//!
//! A bucket holds `2^tiles_per_bucket_log2` tiles. When a frame brings it more new keys than it
//! has empty slots, the first inserts to arrive take the slots and the rest fail: which keys got
//! in depended on the order of the atomics, and with them the image (three runs of the indirect
//! room at 320 × 180, whose cache filled, gave three images). InsertRadianceCache therefore runs in
//! three steps over the frame's queries:
//!
//! 1. **Insert** (`crate::world_cache::insert_query`): as before, and each new key (inserted or
//!    refused) is noted ([`note_new_key`]): the bucket keeps the smallest new checksum, a refused
//!    key marks its bucket full, an inserted tile is marked new.
//! 2. **Settle** ([`settle_tile`]): in a bucket marked full, every tile inserted this frame is
//!    taken out again (its key zeroed), except the one with the bucket's smallest new checksum.
//!    Its queries get no tile.
//! 3. **Admit**: refused queries whose key is the bucket's smallest new checksum insert it again;
//!    step 2 emptied the slots the other new keys took, so it finds one when the bucket had any.
//!
//! The bucket then holds its old keys and, if a slot was free, the smallest new one: a function of
//! the frame's keys alone. A full bucket admits one new key per frame; the cache is sized so that
//! this is rare (`GiSettings::with_cache_for`). Slots taken out in step 2 stay on the frame's live
//! and update lists with a zero key (the frame's counts list them as inserted): the update finds
//! no sample in them, and the next purge drops them from the live list as evicted
//! (`super::purge::purge_tile`), so a later insert lists the slot once.
//!
//! Memory: one word per tile and two per bucket ([`marks_words`]), reset to [`MARKS_CLEAR`] before
//! each frame's inserts.

use super::layout::HashGridParams;
use super::{CellDescriptor, MAX_NUM_TILES_LOG2};
use crate::atomics::AtomicWords;
use crate::math::min_u32;

/// Value the marks buffer is filled with before a frame's inserts: no tile new, no bucket full,
/// no new key.
pub const MARKS_CLEAR: u32 = u32::MAX;
/// A tile's or a bucket's mark once set.
const MARKED: u32 = 0;

/// Where the marks of a grid of `2^num_buckets_log2` buckets of `2^tiles_per_bucket_log2` tiles
/// lie: one word per tile ([`new_tile_word`]), then per bucket its smallest new checksum, then its "a key was
/// refused" mark. The counts are clamped as [`super::cell_descriptor`] and [`super::tile_slot`]
/// clamp them.
#[derive(Clone, Copy)]
struct Layout {
    tiles_per_bucket_log2: u32,
    buckets: usize,
}

impl Layout {
    #[inline]
    fn new(num_buckets_log2: u32, tiles_per_bucket_log2: u32) -> Self {
        Self {
            tiles_per_bucket_log2: min_u32(tiles_per_bucket_log2, MAX_NUM_TILES_LOG2),
            buckets: 1usize << min_u32(num_buckets_log2, MAX_NUM_TILES_LOG2),
        }
    }

    #[inline]
    fn of(params: &HashGridParams) -> Self {
        Self::new(params.num_buckets_log2, params.tiles_per_bucket_log2)
    }

    #[inline]
    fn tiles(self) -> usize {
        self.buckets << self.tiles_per_bucket_log2
    }

    /// The bucket tile `tile` belongs to (the inverse of [`super::tile_slot`]).
    #[inline]
    fn bucket_of(self, tile: u32) -> u32 {
        tile >> self.tiles_per_bucket_log2
    }

    /// Word of bucket `bucket`'s smallest new checksum.
    #[inline]
    fn smallest_key(self, bucket: u32) -> usize {
        self.tiles() + bucket as usize
    }

    /// Word of bucket `bucket`'s "a key was refused" mark.
    #[inline]
    fn full(self, bucket: u32) -> usize {
        self.tiles() + self.buckets + bucket as usize
    }

    #[inline]
    fn words(self) -> usize {
        self.tiles() + 2 * self.buckets
    }
}

/// Word of tile `tile`'s "inserted this frame" mark (the first words, one per tile).
#[inline]
fn new_tile_word(tile: u32) -> usize {
    tile as usize
}

/// Words of the marks buffer for a grid of `2^num_buckets_log2` buckets of
/// `2^tiles_per_bucket_log2` tiles: one per tile, then two per bucket.
#[inline]
pub fn marks_words(num_buckets_log2: u32, tiles_per_bucket_log2: u32) -> usize {
    Layout::new(num_buckets_log2, tiles_per_bucket_log2).words()
}

/// Step 1: notes a key that was not in the cache: inserted into `tile`, or refused (`None`).
#[inline]
pub fn note_new_key<M: AtomicWords + ?Sized>(
    marks: &mut M,
    desc: &CellDescriptor,
    tile: Option<u32>,
    params: &HashGridParams,
) {
    let layout = Layout::of(params);
    let len = marks.word_count();
    let key_word = layout.smallest_key(desc.bucket);
    if key_word < len {
        marks.fetch_min(key_word, desc.checksum);
    }
    let mark = match tile {
        Some(t) => new_tile_word(t),
        None => layout.full(desc.bucket),
    };
    if mark < len {
        marks.store(mark, MARKED);
    }
}

/// Step 2, for a query whose tile is `tile`: whether the tile is taken out (its key zeroed),
/// being inserted this frame into a bucket that refused a key and not the bucket's smallest new
/// key.
#[inline]
pub fn settle_tile<K: AtomicWords + ?Sized, M: AtomicWords + ?Sized>(
    keys: &mut K,
    marks: &M,
    tile: u32,
    params: &HashGridParams,
) -> bool {
    let layout = Layout::of(params);
    let bucket = layout.bucket_of(tile);
    if (tile as usize) >= keys.word_count()
        || layout.full(bucket) >= marks.word_count()
        || marks.load(layout.full(bucket)) != MARKED
        || marks.load(new_tile_word(tile)) != MARKED
    {
        return false;
    }
    // Zero once another query of the tile took it out: its key was not the smallest either.
    if keys.load(tile as usize) == marks.load(layout.smallest_key(bucket)) {
        return false;
    }
    keys.store(tile as usize, 0);
    true
}

/// Step 3: whether a refused key `desc` is its bucket's smallest new key, which is admitted.
#[inline]
pub fn is_admitted<M: AtomicWords + ?Sized>(
    marks: &M,
    desc: &CellDescriptor,
    params: &HashGridParams,
) -> bool {
    let word = Layout::of(params).smallest_key(desc.bucket);
    word < marks.word_count() && marks.load(word) == desc.checksum
}

/// Whether tile `tile` was inserted this frame (so it is on the frame's lists already).
#[inline]
pub fn is_new_tile<M: AtomicWords + ?Sized>(marks: &M, tile: u32) -> bool {
    new_tile_word(tile) < marks.word_count() && marks.load(new_tile_word(tile)) == MARKED
}
