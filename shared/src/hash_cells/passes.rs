//! The per-invocation bodies of the hash grid's passes, in frame order. The kernels and the CPU
//! model (`super::model`) call these very functions, so a GPU run and a CPU run of the same
//! batch end with the same integer state (up to slot order inside a bucket, which depends on the
//! order of concurrent inserts):
//!
//! 1. [`super::lists::begin_frame`], one invocation;
//! 2. [`purge_pass`], one invocation per entry of the previous live list;
//! 3. [`query_pass`], one invocation per query;
//! 4. [`update_pass`], one invocation per entry of the update list, with multi-bounce's bounce
//!    copy ([`super::update`] says how 64 invocations per entry could share it);
//! 5. reads with [`super::read::lookup`] in later passes.
//!
//! Buffers: `keys` and `last_touch` (one word per tile), `values` (85 [`HashCellValue`]s per tile),
//! `accumulators` (7 words per mip-0 cell), `lists` ([`super::lists`]).

use super::accumulate::accumulate_sample;
use super::layout::SAMPLE_WEIGHT_ONE;
use super::layout::{HashCellValue, HashGridParams, HashGridQuery};
use super::lists::{
    DROPPED_SAMPLES, EVICTED_TILES, FAILED_INSERTS, UPDATE_TILES, count, list_tile, live_list,
    previous_live_list, push_tile,
};
use super::purge::purge_tile;
use super::storage::{TileInsert, insert_tile};
use super::touch::{clear_tile_values, touch_tile};
use super::update::{blend_tile, tile_blend_cap, update_bounce_copy};
use super::{CellDescriptor, cell_descriptor};
use crate::atomics::AtomicWords;

/// The cell a query falls into, seen from `params.eye`.
#[inline]
pub fn query_descriptor(query: &HashGridQuery, params: &HashGridParams) -> CellDescriptor {
    cell_descriptor(
        params.eye(),
        query.hit_position(),
        query.direction(),
        query.hit_distance,
        params,
    )
}

/// Purge invocation `index`: entry `index` of the previous frame's live list is evicted or carried
/// over to this frame's list.
#[inline]
pub fn purge_pass<K, T, L>(
    keys: &mut K,
    last_touch: &T,
    lists: &mut L,
    params: &HashGridParams,
    index: u32,
) where
    K: AtomicWords + ?Sized,
    T: AtomicWords + ?Sized,
    L: AtomicWords + ?Sized,
{
    let frame = params.frame_index;
    let tile_count = params.tile_count();
    if let Some(tile) = list_tile(lists, previous_live_list(frame), tile_count, index) {
        if purge_tile(keys, last_touch, tile, frame) {
            push_tile(lists, live_list(frame), tile_count, tile);
        } else {
            count(lists, EVICTED_TILES);
        }
    }
}

/// One query: finds or inserts its tile (a new tile joins the live list with zeroed values),
/// touches it (the first touch of the frame lists it for the update), and adds its radiance to
/// its mip-0 cell. Queries without a cell (non-finite inputs) do nothing; full buckets and
/// non-finite radiance are counted.
#[inline]
pub fn query_pass<K, T, A, L>(
    keys: &mut K,
    last_touch: &mut T,
    values: &mut [HashCellValue],
    accumulators: &mut A,
    lists: &mut L,
    params: &HashGridParams,
    query: &HashGridQuery,
) where
    K: AtomicWords + ?Sized,
    T: AtomicWords + ?Sized,
    A: AtomicWords + ?Sized,
    L: AtomicWords + ?Sized,
{
    let desc = query_descriptor(query, params);
    if desc.is_none() {
        return;
    }
    let tile_count = params.tile_count();
    let tile = match insert_tile(keys, &desc, params) {
        TileInsert::Found(tile) => tile,
        TileInsert::Inserted(tile) => {
            push_tile(lists, live_list(params.frame_index), tile_count, tile);
            clear_tile_values(values, tile);
            tile
        }
        TileInsert::Full => {
            count(lists, FAILED_INSERTS);
            return;
        }
    };
    if touch_tile(last_touch, tile, params.frame_index) {
        push_tile(lists, UPDATE_TILES, tile_count, tile);
    }
    if !accumulate_sample(
        accumulators,
        tile,
        desc.cell,
        query.radiance(),
        SAMPLE_WEIGHT_ONE,
    ) {
        count(lists, DROPPED_SAMPLES);
    }
}

/// Tile of update invocation (or workgroup) `index`, if any.
#[inline]
pub fn update_list_tile<L: AtomicWords + ?Sized>(
    lists: &L,
    params: &HashGridParams,
    index: u32,
) -> Option<u32> {
    list_tile(lists, UPDATE_TILES, params.tile_count(), index)
}

/// Update invocation `index`: blends and re-mips entry `index` of the update list, and its bounce
/// copy in `bounce` where that holds one for every cell ([`update_bounce_copy`]; multi-bounce).
#[inline]
pub fn update_pass<A, L>(
    values: &mut [HashCellValue],
    bounce: &mut [HashCellValue],
    accumulators: &mut A,
    lists: &L,
    params: &HashGridParams,
    index: u32,
) where
    A: AtomicWords + ?Sized,
    L: AtomicWords + ?Sized,
{
    if let Some(tile) = update_list_tile(lists, params, index) {
        let cap = params.sample_cap;
        let blend_cap = tile_blend_cap(values, accumulators, tile, cap, params.adaptive_blend != 0);
        if bounce.len() >= values.len() {
            update_bounce_copy(
                bounce,
                values,
                accumulators,
                tile,
                cap,
                blend_cap,
                params.frame_index,
            );
        }
        blend_tile(
            values,
            accumulators,
            tile,
            cap,
            blend_cap,
            params.history_frames,
            params.frame_index,
        );
    }
}
