//! Append lists: a counter word plus a fixed capacity of items stored elsewhere. Invocations claim
//! a slot with one atomic add; a full list refuses the item but still counts the attempt.
//!
//! So a list's counter may end above its capacity: it is the number of attempted appends, which
//! makes overflow reportable. Every reader (the next pass, an indirect dispatch, the host) must
//! clamp it with [`clamped_count`]. Counters are reset at the start of each frame, long before the
//! 2^32 attempts that would wrap them.

use crate::atomics::AtomicWords;
use crate::math::min_u32;

/// Claims the next slot of the list whose counter is word `counter_index` of `counters`: the slot
/// index, or `None` when all `capacity` slots are taken (the attempt is counted anyway).
#[inline]
pub fn append<W: AtomicWords + ?Sized>(
    counters: &mut W,
    counter_index: usize,
    capacity: u32,
) -> Option<u32> {
    let slot = counters.fetch_add(counter_index, 1);
    if slot < capacity { Some(slot) } else { None }
}

/// Number of valid items of a list whose counter reads `count`.
#[inline]
pub fn clamped_count(count: u32, capacity: u32) -> u32 {
    min_u32(count, capacity)
}

/// Number of appends a full list refused.
#[inline]
pub fn overflow_count(count: u32, capacity: u32) -> u32 {
    count.saturating_sub(capacity)
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::hash_cells::shared_words::SharedWords;
    use core::sync::atomic::{AtomicU32, Ordering};

    #[test]
    fn sequential_append_and_overflow() {
        let mut counters = [0u32; 2];
        let c: &mut [u32] = &mut counters;
        assert_eq!(append(c, 1, 3), Some(0));
        assert_eq!(append(c, 1, 3), Some(1));
        assert_eq!(append(c, 1, 3), Some(2));
        assert_eq!(append(c, 1, 3), None);
        assert_eq!(append(c, 1, 3), None);
        assert_eq!(counters, [0, 5]);
        assert_eq!(clamped_count(5, 3), 3);
        assert_eq!(overflow_count(5, 3), 2);
        assert_eq!(clamped_count(2, 3), 2);
        assert_eq!(overflow_count(2, 3), 0);
        // A zero-capacity list refuses everything.
        assert_eq!(append(&mut [0u32][..], 0, 0), None);
    }

    #[test]
    fn concurrent_appends_claim_distinct_slots() {
        let counter = [AtomicU32::new(0)];
        let capacity = 10_000;
        let slots: Vec<AtomicU32> = (0..capacity).map(|_| AtomicU32::new(0)).collect();
        let refused = AtomicU32::new(0);
        std::thread::scope(|s| {
            for _ in 0..4 {
                let mut view = SharedWords(&counter);
                let (slots, refused) = (&slots, &refused);
                s.spawn(move || {
                    for _ in 0..3000 {
                        match append(&mut view, 0, capacity) {
                            Some(i) => {
                                slots[i as usize].fetch_add(1, Ordering::SeqCst);
                            }
                            None => {
                                refused.fetch_add(1, Ordering::SeqCst);
                            }
                        }
                    }
                });
            }
        });
        let count = counter[0].load(Ordering::SeqCst);
        assert_eq!(count, 12_000);
        assert!(slots.iter().all(|s| s.load(Ordering::SeqCst) == 1));
        assert_eq!(
            refused.load(Ordering::SeqCst),
            overflow_count(count, capacity)
        );
    }
}
