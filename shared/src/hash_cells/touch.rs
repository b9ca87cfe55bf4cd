//! Touching tiles: each frame a query lands in a tile, the tile's entry of the `last_touch` buffer
//! (one `u32` per tile) is set to the frame index. The first touch of the frame lists the tile for
//! the update pass, exactly once however many invocations touch it; [`super::purge`] evicts tiles
//! whose stamp grew old.
//!
//! Invariant: a tile's stamp differs from the current frame until its first touch of the frame.
//! Stamps only hold past frames, so this holds for 2^32 − [`super::TILE_DECAY_FRAMES`] frames after
//! a tile's last touch; a fresh buffer must start with [`initial_last_touch`] of the first frame
//! (zeros would make a first frame 0 look already touched).

use super::layout::HashCellValue;
use super::{CELLS_PER_TILE, cell_index};
use crate::atomics::AtomicWords;

/// The value a fresh `last_touch` buffer is filled with when the first frame is `first_frame`.
#[inline]
pub fn initial_last_touch(first_frame: u32) -> u32 {
    first_frame.wrapping_sub(1)
}

/// Stamps tile `tile` with `frame`; true for the frame's first touch of the tile (the caller then
/// appends it to the update list).
#[inline]
pub fn touch_tile<W: AtomicWords + ?Sized>(last_touch: &mut W, tile: u32, frame: u32) -> bool {
    last_touch.swap(tile as usize, frame) != frame
}

/// Zeroes the 85 values of a tile that [`super::storage::insert_tile`] just inserted: the slot may
/// hold an evicted tile's radiance. (The accumulators need nothing: the update pass clears them.)
#[inline]
pub fn clear_tile_values(values: &mut [HashCellValue], tile: u32) {
    let first = cell_index(tile, 0, 0, 0) as usize;
    let mut i = 0;
    while i < CELLS_PER_TILE as usize {
        values[first + i] = HashCellValue::ZERO;
        i += 1;
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::hash_cells::shared_words::{SharedWords, atomic_buffer};
    use glam::Vec3;

    #[test]
    fn first_touch_is_reported_once_per_frame() {
        for first in [0u32, 7, u32::MAX] {
            let mut stamps = vec![initial_last_touch(first); 4];
            let s: &mut [u32] = &mut stamps;
            assert!(touch_tile(s, 2, first));
            assert!(!touch_tile(s, 2, first));
            assert!(touch_tile(s, 2, first.wrapping_add(1)));
            assert!(!touch_tile(s, 2, first.wrapping_add(1)));
            assert!(touch_tile(s, 3, first.wrapping_add(1)));
            assert_eq!(stamps[2], first.wrapping_add(1));
        }
        // Concurrently: 8 threads touch the same 100 tiles; each is "first" exactly once.
        let stamps = atomic_buffer(100);
        let firsts: u32 = std::thread::scope(|s| {
            (0..8)
                .map(|_| {
                    let mut view = SharedWords(&stamps);
                    s.spawn(move || (0..100).filter(|&t| touch_tile(&mut view, t, 5)).count())
                })
                .collect::<Vec<_>>()
                .into_iter()
                .map(|h| h.join().unwrap() as u32)
                .sum()
        });
        assert_eq!(firsts, 100);
    }

    #[test]
    fn clearing_a_tile_touches_only_its_cells() {
        let one = HashCellValue::new(Vec3::ONE, 1.0);
        let mut values = vec![one; 3 * CELLS_PER_TILE as usize];
        clear_tile_values(&mut values, 1);
        for (i, v) in values.iter().enumerate() {
            let inside = (85..170).contains(&i);
            assert_eq!(*v, if inside { HashCellValue::ZERO } else { one }, "{i}");
        }
    }
}
