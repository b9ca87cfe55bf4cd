//! The hash grid's list buffer: one `u32` buffer, updated with atomics, that holds the frame's
//! counters followed by three tile lists of `T` = tile-count entries each (every list holds each
//! tile at most once, so `T` never overflows):
//!
//! `[counters (COUNTER_WORDS) | live tiles, even frames (T) | live tiles, odd frames (T) |
//! tiles to update (T)]`
//!
//! Each list is an [`crate::append_list`] whose counter is the counter word with the list's own
//! index. The live-tile list ping-pongs on the frame parity: frame `f` purges the list of parity
//! `(f + 1) & 1` (the previous frame's) and appends to the one of parity `f & 1`; the parity
//! alternates across the `u32` wrap of the frame index too (`u32::MAX` is odd, 0 even).

use crate::append_list::{append, clamped_count};
use crate::atomics::AtomicWords;

/// List (and counter) of the live tiles of even frames.
pub const LIVE_TILES_EVEN: u32 = 0;
/// List (and counter) of the live tiles of odd frames.
pub const LIVE_TILES_ODD: u32 = 1;
/// List (and counter) of the tiles touched this frame: the update pass's work.
pub const UPDATE_TILES: u32 = 2;
/// Counter: inserts refused this frame because the bucket was full.
pub const FAILED_INSERTS: u32 = 3;
/// Counter: tiles evicted this frame.
pub const EVICTED_TILES: u32 = 4;
/// Counter: samples dropped this frame because a channel was NaN or infinite.
pub const DROPPED_SAMPLES: u32 = 5;
/// Counter words at the start of the buffer (6 used, rounded up to 8).
pub const COUNTER_WORDS: u32 = 8;
/// Number of tile lists.
pub const LIST_COUNT: u32 = 3;

/// Words of the list buffer for `tile_count` tiles: `8 + 3 · tile_count`.
#[inline]
pub fn list_buffer_words(tile_count: u32) -> usize {
    COUNTER_WORDS as usize + LIST_COUNT as usize * tile_count as usize
}

/// Live-tile list frame `frame` appends to.
#[inline]
pub fn live_list(frame: u32) -> u32 {
    frame & 1
}

/// Live-tile list frame `frame` purges: the previous frame's.
#[inline]
pub fn previous_live_list(frame: u32) -> u32 {
    frame.wrapping_add(1) & 1
}

/// Word of entry `slot` of list `list`.
#[inline]
pub fn list_word(list: u32, tile_count: u32, slot: u32) -> usize {
    COUNTER_WORDS as usize + list as usize * tile_count as usize + slot as usize
}

/// Appends `tile` to list `list`; false when the list is full (cannot happen for the tile lists,
/// whose capacity is the tile count; the counter still counts the attempt).
#[inline]
pub fn push_tile<W: AtomicWords + ?Sized>(
    lists: &mut W,
    list: u32,
    tile_count: u32,
    tile: u32,
) -> bool {
    match append(lists, list as usize, tile_count) {
        Some(slot) => {
            lists.store(list_word(list, tile_count, slot), tile);
            true
        }
        None => false,
    }
}

/// Valid entries of list `list` (its counter clamped to the capacity).
#[inline]
pub fn list_len<W: AtomicWords + ?Sized>(lists: &W, list: u32, tile_count: u32) -> u32 {
    clamped_count(lists.load(list as usize), tile_count)
}

/// Entry `index` of list `list`, if `index` is below its length.
#[inline]
pub fn list_tile<W: AtomicWords + ?Sized>(
    lists: &W,
    list: u32,
    tile_count: u32,
    index: u32,
) -> Option<u32> {
    if index < list_len(lists, list, tile_count) {
        Some(lists.load(list_word(list, tile_count, index)))
    } else {
        None
    }
}

/// Increments counter `counter` (statistics).
#[inline]
pub fn count<W: AtomicWords + ?Sized>(lists: &mut W, counter: u32) {
    lists.fetch_add(counter as usize, 1);
}

/// Start of frame `frame` (one invocation, before any other pass): zeroes every counter but the
/// previous frame's live list, which the purge pass reads.
#[inline]
pub fn begin_frame<W: AtomicWords + ?Sized>(lists: &mut W, frame: u32) {
    let keep = previous_live_list(frame);
    let mut counter = 0;
    while counter < COUNTER_WORDS {
        if counter != keep {
            lists.store(counter as usize, 0);
        }
        counter += 1;
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn layout_ping_pong_and_reset() {
        for f in [0u32, 1, 2, 1000, u32::MAX - 1, u32::MAX] {
            assert_ne!(live_list(f), previous_live_list(f));
            assert_eq!(previous_live_list(f.wrapping_add(1)), live_list(f));
            assert!(live_list(f) <= LIVE_TILES_ODD);
        }
        assert_eq!(live_list(2), LIVE_TILES_EVEN);
        assert_eq!(list_buffer_words(16), 8 + 48);
        assert_eq!(list_word(UPDATE_TILES, 16, 15), list_buffer_words(16) - 1);

        let mut lists = vec![0u32; list_buffer_words(4)];
        let l: &mut [u32] = &mut lists;
        for t in [9, 8, 7, 6] {
            assert!(push_tile(l, LIVE_TILES_ODD, 4, t));
        }
        assert!(!push_tile(l, LIVE_TILES_ODD, 4, 5));
        assert_eq!(list_len(l, LIVE_TILES_ODD, 4), 4);
        assert_eq!(list_tile(l, LIVE_TILES_ODD, 4, 1), Some(8));
        assert_eq!(list_tile(l, LIVE_TILES_ODD, 4, 4), None);
        assert!(push_tile(l, UPDATE_TILES, 4, 3));
        count(l, FAILED_INSERTS);
        // Frame 2 purges the odd list: its counter survives, the others restart.
        begin_frame(l, 2);
        assert_eq!(list_len(l, LIVE_TILES_ODD, 4), 4);
        assert_eq!(list_len(l, UPDATE_TILES, 4), 0);
        assert_eq!(lists[FAILED_INSERTS as usize], 0);
    }
}
