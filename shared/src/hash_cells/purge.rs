//! The purge pass, first of a frame: every tile of the previous frame's live list is either kept
//! (the caller appends it to this frame's live list) or evicted, its key zeroed so the slot can be
//! reused, when it was last touched [`TILE_DECAY_FRAMES`] or more frames ago. Ages are
//! differences modulo 2^32, so they stay right across the wrap of the frame index.

use super::TILE_DECAY_FRAMES;
use crate::atomics::AtomicWords;

/// Frames since a tile's last touch: `frame − last_touch` modulo 2^32.
#[inline]
pub fn tile_age(frame: u32, last_touch: u32) -> u32 {
    frame.wrapping_sub(last_touch)
}

/// Whether a tile last touched at `last_touch` is evicted at frame `frame`.
#[inline]
pub fn is_expired(frame: u32, last_touch: u32) -> bool {
    tile_age(frame, last_touch) >= TILE_DECAY_FRAMES
}

/// Purges live tile `tile` at frame `frame`: evicts it (zeroes its key) and returns false when it
/// expired or its key is already zero (a slot a full bucket took back,
/// [`super::full_buckets`]), else returns true (keep it). The tile's values and stamp stay as
/// they are; a later insert into the slot clears the values.
#[inline]
pub fn purge_tile<K: AtomicWords + ?Sized, T: AtomicWords + ?Sized>(
    keys: &mut K,
    last_touch: &T,
    tile: u32,
    frame: u32,
) -> bool {
    if keys.load(tile as usize) == 0 {
        false
    } else if is_expired(frame, last_touch.load(tile as usize)) {
        keys.store(tile as usize, 0);
        false
    } else {
        true
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn eviction_after_exactly_50_frames_across_the_wrap() {
        for touched in [0u32, 1000, u32::MAX - 20, u32::MAX] {
            let mut keys = [0u32, 77];
            let stamps = [0u32, touched];
            for age in 0..TILE_DECAY_FRAMES {
                let frame = touched.wrapping_add(age);
                assert_eq!(tile_age(frame, touched), age);
                assert!(
                    purge_tile(&mut keys[..], &stamps[..], 1, frame),
                    "age {age}"
                );
                assert_eq!(keys[1], 77);
            }
            let frame = touched.wrapping_add(TILE_DECAY_FRAMES);
            assert!(!purge_tile(&mut keys[..], &stamps[..], 1, frame));
            assert_eq!(keys, [0, 0]);
        }
        assert!(is_expired(10, 20)); // a stamp "from the future" is 2^32 − 10 frames old
    }
}
