//! 32-bit atomic operations on a buffer of words, as one trait so that the algorithms built on them
//! (hash-cell insert and find, append lists, fixed-point accumulation, bounds reductions) are
//! written once and run both on the GPU (the kernels implement the trait with SPIR-V atomics at
//! device scope) and on the CPU, where `[u32]` runs them sequentially (the CPU model of a pass)
//! and `[AtomicU32]` runs them from many threads (contention tests).
//!
//! Every operation returns the value the word held before it, as SPIR-V's do. Indices are not
//! checked here beyond what slice indexing does: callers guard them against the buffer length.

/// Atomic read-modify-write on word `i` of a buffer.
pub trait AtomicWords {
    /// The number of words.
    fn word_count(&self) -> usize;
    /// Atomic load of word `i`.
    fn load(&self, i: usize) -> u32;
    /// Atomic store of `value` into word `i`.
    fn store(&mut self, i: usize, value: u32);
    /// Wrapping add; returns the old value.
    fn fetch_add(&mut self, i: usize, value: u32) -> u32;
    /// Stores `value`; returns the old value.
    fn swap(&mut self, i: usize, value: u32) -> u32;
    /// Stores `new` if the word equals `current`; returns the old value either way.
    fn compare_exchange(&mut self, i: usize, current: u32, new: u32) -> u32;
    /// Unsigned minimum; returns the old value.
    fn fetch_min(&mut self, i: usize, value: u32) -> u32;
    /// Unsigned maximum; returns the old value.
    fn fetch_max(&mut self, i: usize, value: u32) -> u32;
}

/// A borrowed buffer is the buffer: structs that hold their buffers by value
/// (`hash_cells::layout::HashCellsInsert`) take `&mut [u32]` on the CPU.
impl<W: AtomicWords + ?Sized> AtomicWords for &mut W {
    #[inline]
    fn word_count(&self) -> usize {
        (**self).word_count()
    }
    #[inline]
    fn load(&self, i: usize) -> u32 {
        (**self).load(i)
    }
    #[inline]
    fn store(&mut self, i: usize, value: u32) {
        (**self).store(i, value)
    }
    #[inline]
    fn fetch_add(&mut self, i: usize, value: u32) -> u32 {
        (**self).fetch_add(i, value)
    }
    #[inline]
    fn swap(&mut self, i: usize, value: u32) -> u32 {
        (**self).swap(i, value)
    }
    #[inline]
    fn compare_exchange(&mut self, i: usize, current: u32, new: u32) -> u32 {
        (**self).compare_exchange(i, current, new)
    }
    #[inline]
    fn fetch_min(&mut self, i: usize, value: u32) -> u32 {
        (**self).fetch_min(i, value)
    }
    #[inline]
    fn fetch_max(&mut self, i: usize, value: u32) -> u32 {
        (**self).fetch_max(i, value)
    }
}

/// Sequential: the CPU model of a pass runs its invocations one after another.
impl AtomicWords for [u32] {
    #[inline]
    fn word_count(&self) -> usize {
        self.len()
    }
    #[inline]
    fn load(&self, i: usize) -> u32 {
        self[i]
    }
    #[inline]
    fn store(&mut self, i: usize, value: u32) {
        self[i] = value;
    }
    #[inline]
    fn fetch_add(&mut self, i: usize, value: u32) -> u32 {
        let old = self[i];
        self[i] = old.wrapping_add(value);
        old
    }
    #[inline]
    fn swap(&mut self, i: usize, value: u32) -> u32 {
        let old = self[i];
        self[i] = value;
        old
    }
    #[inline]
    fn compare_exchange(&mut self, i: usize, current: u32, new: u32) -> u32 {
        let old = self[i];
        if old == current {
            self[i] = new;
        }
        old
    }
    #[inline]
    fn fetch_min(&mut self, i: usize, value: u32) -> u32 {
        let old = self[i];
        if value < old {
            self[i] = value;
        }
        old
    }
    #[inline]
    fn fetch_max(&mut self, i: usize, value: u32) -> u32 {
        let old = self[i];
        if value > old {
            self[i] = value;
        }
        old
    }
}

/// Concurrent, for contention tests on the CPU (threads share `&[AtomicU32]`; `&mut` is only
/// what the trait asks for, the operations themselves are atomic).
#[cfg(not(target_arch = "spirv"))]
impl AtomicWords for [core::sync::atomic::AtomicU32] {
    #[inline]
    fn word_count(&self) -> usize {
        self.len()
    }
    #[inline]
    fn load(&self, i: usize) -> u32 {
        self[i].load(core::sync::atomic::Ordering::SeqCst)
    }
    #[inline]
    fn store(&mut self, i: usize, value: u32) {
        self[i].store(value, core::sync::atomic::Ordering::SeqCst)
    }
    #[inline]
    fn fetch_add(&mut self, i: usize, value: u32) -> u32 {
        self[i].fetch_add(value, core::sync::atomic::Ordering::SeqCst)
    }
    #[inline]
    fn swap(&mut self, i: usize, value: u32) -> u32 {
        self[i].swap(value, core::sync::atomic::Ordering::SeqCst)
    }
    #[inline]
    fn compare_exchange(&mut self, i: usize, current: u32, new: u32) -> u32 {
        use core::sync::atomic::Ordering::SeqCst;
        match self[i].compare_exchange(current, new, SeqCst, SeqCst) {
            Ok(old) | Err(old) => old,
        }
    }
    #[inline]
    fn fetch_min(&mut self, i: usize, value: u32) -> u32 {
        self[i].fetch_min(value, core::sync::atomic::Ordering::SeqCst)
    }
    #[inline]
    fn fetch_max(&mut self, i: usize, value: u32) -> u32 {
        self[i].fetch_max(value, core::sync::atomic::Ordering::SeqCst)
    }
}

/// A float's bits mapped to a `u32` whose unsigned order is the float's order (negative floats
/// reversed below positive ones), so that atomic `min`/`max` on words reduce floats.
#[inline]
pub fn ordered_bits(x: f32) -> u32 {
    let b = x.to_bits();
    if b & 0x8000_0000 != 0 {
        !b
    } else {
        b | 0x8000_0000
    }
}

/// Inverse of [`ordered_bits`].
#[inline]
pub fn from_ordered_bits(u: u32) -> f32 {
    f32::from_bits(if u & 0x8000_0000 != 0 {
        u & 0x7fff_ffff
    } else {
        !u
    })
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn ordered_bits_preserve_order_and_round_trip() {
        let xs = [
            f32::NEG_INFINITY,
            -1e30,
            -1.0,
            -1e-30,
            -0.0,
            0.0,
            1e-30,
            1.0,
            1e30,
            f32::INFINITY,
        ];
        for w in xs.windows(2) {
            assert!(ordered_bits(w[0]) <= ordered_bits(w[1]), "{w:?}");
        }
        for x in xs {
            assert_eq!(from_ordered_bits(ordered_bits(x)).to_bits(), x.to_bits());
        }
    }

    #[test]
    fn sequential_words_return_old_values() {
        let mut w = [5u32, 0, 7];
        let s: &mut [u32] = &mut w;
        assert_eq!(s.fetch_add(0, u32::MAX), 5);
        assert_eq!(s.load(0), 4);
        assert_eq!(s.compare_exchange(1, 0, 9), 0);
        assert_eq!(s.compare_exchange(1, 0, 3), 9);
        assert_eq!(s.fetch_min(2, 2), 7);
        assert_eq!(s.fetch_max(2, 1), 2);
        assert_eq!(AtomicWords::swap(s, 2, 8), 2);
        assert_eq!(w, [4, 9, 8]);
    }
}
