//! Exclusive prefix sums of `u32` words on the GPU, the "scan" of append-scan-dispatch: the
//! `scan::scan_blocks` kernel scans blocks of [`SCAN_BLOCK`] words (subgroup scans combined
//! through workgroup memory) and writes one sum per block; the block sums are scanned the same
//! way, level by level, until one block remains; `scan::add_block_offsets` then adds each block's
//! offset back, from the top level down. [`exclusive_scan`] is the CPU reference; [`level_len`]
//! and [`level_count`] are the plan both sides agree on.
//!
//! Sums wrap on overflow, on both sides.

use crate::abi::WORKGROUP_SIZE;
use bytemuck::{Pod, Zeroable};

/// Words one workgroup scans: one per invocation.
pub const SCAN_BLOCK: u32 = WORKGROUP_SIZE;

/// A word index meaning "none" in [`ScanPush`].
pub const NO_WORD: u32 = u32::MAX;

/// Push constants of `scan::scan_blocks` and `scan::add_block_offsets` (one level of a scan).
#[repr(C)]
#[derive(Clone, Copy, Debug, Default, PartialEq, Eq, Pod, Zeroable)]
pub struct ScanPush {
    /// Words in this level.
    pub count: u32,
    /// Where this level's words start in the data binding.
    pub data_offset: u32,
    /// Where this level's block sums start in the sums binding (`scan_blocks` writes them,
    /// `add_block_offsets` reads them, scanned); [`NO_WORD`] at the top level.
    pub sums_offset: u32,
    /// The word of the total binding that receives the sum of all words ([`NO_WORD`]: none).
    /// Only the top level, a single block, sets it.
    pub total_index: u32,
}

/// Number of words of level `level` of a scan of `n` words: level 0 is the input, level `k + 1`
/// holds one sum per block of level `k`.
pub fn level_len(n: u32, level: u32) -> u32 {
    let mut len = n;
    let mut l = 0;
    while l < level {
        len = len.div_ceil(SCAN_BLOCK);
        l += 1;
    }
    len
}

/// Number of levels of a scan of `n` words: the top level is the first that fits in one block
/// (1 for `n <= SCAN_BLOCK`, including `n = 0`).
pub fn level_count(n: u32) -> u32 {
    let mut levels = 1;
    let mut len = n;
    while len > SCAN_BLOCK {
        len = len.div_ceil(SCAN_BLOCK);
        levels += 1;
    }
    levels
}

/// Replaces `words` by their exclusive prefix sums (wrapping) and returns their total.
pub fn exclusive_scan(words: &mut [u32]) -> u32 {
    let mut sum = 0u32;
    for w in words {
        let v = *w;
        *w = sum;
        sum = sum.wrapping_add(v);
    }
    sum
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn exclusive_scan_shifts_and_totals() {
        let mut w = [3, 0, 5, u32::MAX, 2];
        assert_eq!(exclusive_scan(&mut w), 9);
        assert_eq!(w, [0, 3, 3, 8, 7]);
        assert_eq!(exclusive_scan(&mut []), 0);
    }

    #[test]
    fn levels_shrink_by_a_block_until_one_block_remains() {
        let b = SCAN_BLOCK;
        assert_eq!(level_count(0), 1);
        assert_eq!(level_count(b), 1);
        assert_eq!(level_count(b + 1), 2);
        assert_eq!(level_count(b * b), 2);
        assert_eq!(level_count(b * b + 1), 3);
        assert_eq!(level_len(1_000_000, 0), 1_000_000);
        assert_eq!(level_len(1_000_000, 1), 1_000_000u32.div_ceil(b));
        let top = level_count(1_000_000) - 1;
        assert!(level_len(1_000_000, top) <= b);
        assert!(level_len(1_000_000, top - 1) > b);
    }
}
