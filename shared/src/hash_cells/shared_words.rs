//! Tests only: a shared `&[AtomicU32]` seen through [`AtomicWords`], so that many threads can run
//! the same generic algorithm on one buffer without aliasing `&mut` references.

use core::sync::atomic::{AtomicU32, Ordering::SeqCst};

use crate::atomics::AtomicWords;

/// One thread's view of a shared atomic buffer (cheap to copy into every thread).
#[derive(Clone, Copy)]
pub(crate) struct SharedWords<'a>(pub &'a [AtomicU32]);

impl AtomicWords for SharedWords<'_> {
    fn word_count(&self) -> usize {
        self.0.len()
    }
    fn load(&self, i: usize) -> u32 {
        self.0[i].load(SeqCst)
    }
    fn store(&mut self, i: usize, value: u32) {
        self.0[i].store(value, SeqCst)
    }
    fn fetch_add(&mut self, i: usize, value: u32) -> u32 {
        self.0[i].fetch_add(value, SeqCst)
    }
    fn swap(&mut self, i: usize, value: u32) -> u32 {
        self.0[i].swap(value, SeqCst)
    }
    fn compare_exchange(&mut self, i: usize, current: u32, new: u32) -> u32 {
        match self.0[i].compare_exchange(current, new, SeqCst, SeqCst) {
            Ok(old) | Err(old) => old,
        }
    }
    fn fetch_min(&mut self, i: usize, value: u32) -> u32 {
        self.0[i].fetch_min(value, SeqCst)
    }
    fn fetch_max(&mut self, i: usize, value: u32) -> u32 {
        self.0[i].fetch_max(value, SeqCst)
    }
}

/// A zeroed atomic buffer of `n` words.
pub(crate) fn atomic_buffer(n: usize) -> Vec<AtomicU32> {
    (0..n).map(|_| AtomicU32::new(0)).collect()
}
