//! What the frame-machinery test kernels (`machinery_tests::*` in `kernels/`) and their CPU
//! models in `tests/tests/frame_machinery.rs` agree on: push constants, the word layout of the
//! atomics test, and the GPU-decided item counts of the append and dispatch test.

use crate::hash::pcg;
use crate::hash_cells::CellDescriptor;
use crate::hash_cells::storage::TileInsert;
use bytemuck::{Pod, Zeroable};

/// Push constants of the test kernels.
#[repr(C)]
#[derive(Clone, Copy, Debug, Default, PartialEq, Eq, Pod, Zeroable)]
pub struct MachineryPush {
    /// Invocations that take part (the rest of the last workgroup idles).
    pub count: u32,
    /// Varies the values between runs.
    pub seed: u32,
    /// Capacity of the list or table under test.
    pub capacity: u32,
    /// Explicit padding to 16 bytes.
    pub _pad: u32,
}

/// Word of the atomics test that every invocation adds `invocation + 1` to.
pub const WORD_SUM: usize = 0;
/// Word that every invocation takes the unsigned minimum of [`contention_value`] into
/// (starts at `u32::MAX`).
pub const WORD_MIN: usize = 1;
/// Word that every invocation takes the unsigned maximum of [`contention_value`] into.
pub const WORD_MAX: usize = 2;
/// Word that every invocation tries to compare-exchange from 0 to `invocation + 1`.
pub const WORD_CAS: usize = 3;
/// Word that every invocation swaps `invocation + 1` into.
pub const WORD_SWAP: usize = 4;
/// Word that every invocation increments, taking the old value as a ticket.
pub const WORD_TICKET: usize = 5;
/// First of the per-invocation words each invocation stores `contention_value` into and loads.
pub const WORD_STORE: usize = 6;

/// Per-invocation record of the atomics test: what each operation returned.
#[repr(C)]
#[derive(Clone, Copy, Debug, Default, PartialEq, Eq, Pod, Zeroable)]
pub struct AtomicsRecord {
    /// Old value returned by the compare-exchange on [`WORD_CAS`].
    pub cas_old: u32,
    /// Old value returned by the swap on [`WORD_SWAP`].
    pub swap_old: u32,
    /// Old value returned by the increment of [`WORD_TICKET`].
    pub ticket: u32,
    /// Value loaded back from the invocation's own word after storing.
    pub loaded: u32,
    /// Ticket from the workgroup-memory counter of the invocation's workgroup.
    pub workgroup_ticket: u32,
    /// Explicit padding to 32 bytes.
    pub _pad: [u32; 3],
}

/// Per-workgroup result of the workgroup-memory part of the atomics test.
#[repr(C)]
#[derive(Clone, Copy, Debug, Default, PartialEq, Eq, Pod, Zeroable)]
pub struct WorkgroupRecord {
    /// Invocations counted by the workgroup-memory counter.
    pub count: u32,
    /// Minimum of [`contention_value`] over the workgroup.
    pub min: u32,
    /// Maximum of [`contention_value`] over the workgroup.
    pub max: u32,
    /// Explicit padding to 16 bytes.
    pub _pad: u32,
}

/// The value invocation `invocation` contributes to the minimum and maximum.
#[inline]
pub fn contention_value(invocation: u32, seed: u32) -> u32 {
    pcg(invocation ^ pcg(seed))
}

/// Items (0 to 3) invocation `invocation` appends in the append and dispatch test.
#[inline]
pub fn appended_items(invocation: u32, seed: u32) -> u32 {
    contention_value(invocation, seed) % 4
}

/// The value of item `k` of invocation `invocation`: unique per (invocation, k).
#[inline]
pub fn item_value(invocation: u32, k: u32) -> u32 {
    invocation * 4 + k
}

/// Counter word of the append and dispatch test: attempted appends.
pub const COUNTER_ITEMS: usize = 0;
/// Counter word of the append and dispatch test: invocations the indirect dispatch ran.
pub const COUNTER_INVOCATIONS: usize = 1;

/// The hash cell invocation `invocation` inserts in the contention test: key
/// `invocation % keys` (so many invocations share each key), in a bucket drawn from
/// `2^buckets_log2` by hashing the key, with checksum `key + 1`.
#[inline]
pub fn contention_descriptor(
    invocation: u32,
    keys: u32,
    seed: u32,
    buckets_log2: u32,
) -> CellDescriptor {
    let key = if keys == 0 { 0 } else { invocation % keys };
    CellDescriptor {
        bucket: contention_value(key, seed) & ((1u32 << buckets_log2) - 1),
        checksum: key + 1,
        ..CellDescriptor::NONE
    }
}

/// Flag of [`encode_insert`]: `Inserted`.
pub const INSERTED: u32 = 1 << 31;
/// Flag of [`encode_insert`]: `Found`.
pub const FOUND: u32 = 1 << 30;
/// [`encode_insert`] of `Full`.
pub const FULL: u32 = u32::MAX;

/// A [`TileInsert`] as one word: the tile with [`INSERTED`] or [`FOUND`] set, or [`FULL`].
#[inline]
pub fn encode_insert(outcome: TileInsert) -> u32 {
    match outcome {
        TileInsert::Inserted(tile) => INSERTED | tile,
        TileInsert::Found(tile) => FOUND | tile,
        TileInsert::Full => FULL,
    }
}

/// Word of the point-bounds test's output after the six `light_grid` hit-bounds words: the number
/// of finite points reduced.
pub const BOUNDS_COUNT_WORD: usize = crate::light_grid::LIGHT_GRID_BOUNDS_WORDS;
