//! World-space ReSTIR (GI-1.0 talk, "perform the reuse in world space instead", after Boissé
//! 2021; Capsaicin's `world_space_restir.hlsl`, steps 9–12 of the frame): the light-grid
//! reservoirs of secondary hits ([`crate::light_grid`]) are stored in a spatial hash, the
//! *reservoir grid*, and the next frame's hits resample them temporally.
//!
//! # Reservoir grid
//!
//! A hit at `p` seen from the eye `e` falls in the cell of level
//! `L = uint(log2(1000 · |p − e| · cell_const))` ([`reservoir_cell`]; `cell_const` from
//! [`reservoir_cell_const`], the angle of [`RESERVOIR_CELL_SIZE_PIXELS`] pixels), of size
//! `0.001 · 2^L` and coordinates `c = floor(p / size)`. Its bucket is
//! `pcg(L + pcg(c.x + pcg(c.y + pcg(c.z)))) mod buckets` ([`RESERVOIR_GRID_BUCKETS`]) and its
//! checksum `max(1, xxhash chain)`; a bucket holds [`RESERVOIR_GRID_SLOTS_PER_BUCKET`] slots,
//! linearly probed ([`insert_reservoir_cell`], [`find_reservoir_cell`]). Before insertion and
//! lookup the position is jittered in the tangent plane by up to `√2 ×` the cell size
//! ([`jitter_in_tangent_plane`]), so neighbouring cells share reservoirs. The previous frame's
//! lookup uses the previous eye.
//!
//! # Temporal resampling
//!
//! [`TemporalResampling`]: the current reservoir (its `M` counted as [`CURRENT_M`]) is combined
//! with at most [`MAX_TEMPORAL_NEIGHBOURS`] reservoirs of the previous frame's cell, picked with a
//! random start and a stride over the cell's list ([`temporal_neighbour`]), each accepted when
//! `dot(n, n')⁴ ≥` [`MIN_NEIGHBOUR_NORMAL_WEIGHT`] and counted with `M` clamped to
//! [`TEMPORAL_M_CAP`]. Each is reweighted by the target `p̂` *at the current hit* (the
//! unshadowed contribution of its (light, `u`) sample, [`light_contribution`]) — streaming
//! weight `p̂(y) · W · M` ([`Reservoir::merge`]).
//!
//! # Bias
//!
//! This is ReSTIR's `1/M` combination. When every reservoir's target has the current one's
//! support — the same point and normal, as in a static scene's temporal history — it is
//! unbiased (tested below). A neighbour whose point sees fewer lights than the current one (a
//! light below its horizon, another position in the cell) never offers samples of those lights
//! while its `M` still counts, which darkens them: the normal test and the small cells bound
//! this, as in the reference. A changed light makes stored weights `W` stale for up to the
//! history length; the shadow ray is traced every frame, and occluded samples have their `W`
//! zeroed ("invalidate the stored reservoir").

use bytemuck::{Pod, Zeroable};
use glam::{Vec2, Vec3};

use crate::atomics::AtomicWords;
use crate::hash::{pcg_chain, xxhash32_chain};
use crate::light_grid::{
    DiffuseHit, LightContribution, LightGridParams, LightGridSample, light_contribution,
    sample_params_uv,
};
use crate::lights::LightSources;
use crate::math::{floor, max, min_u32, tan, to_i32_clamped, to_u32_clamped};
use crate::packing::{pack_snorm10x3, unpack_snorm10x3};
use crate::random::Random;
use crate::reservoir::Reservoir;
use crate::sampling::orthonormal_basis;
use crate::secondary_hits::diffuse_hit;
use crate::world_cache::{CacheFrameParams, CacheQuery, FLAG_RESTIR_HISTORY, ShadowRay};

/// Buckets of the reservoir grid (the `mod` of the bucket hash).
pub const RESERVOIR_GRID_BUCKETS: u32 = 262_144;
/// Linearly probed slots per bucket: the grid holds `buckets × 16` cells.
pub const RESERVOIR_GRID_SLOTS_PER_BUCKET: u32 = 16;
/// What [`insert_reservoir_cell`] and [`find_reservoir_cell`] return for no slot.
pub const RESERVOIR_GRID_NONE: u32 = u32::MAX;
/// Angular size of a reservoir cell, in pixels (the reference's 16).
pub const RESERVOIR_CELL_SIZE_PIXELS: f32 = 16.0;
/// The tangent-plane jitter reaches this many cell sizes along each tangent axis.
pub const RESERVOIR_JITTER_SCALE: f32 = core::f32::consts::SQRT_2;
/// Most previous-frame reservoirs a hit resamples.
pub const MAX_TEMPORAL_NEIGHBOURS: u32 = 4;
/// Cap on a previous-frame reservoir's `M`.
pub const TEMPORAL_M_CAP: f32 = 20.0;
/// The current reservoir's `M` in the combination (its light-grid candidates count as one).
pub const CURRENT_M: f32 = 1.0;
/// Smallest `dot(n, n')⁴` of a neighbour's normal with the hit's.
pub const MIN_NEIGHBOUR_NORMAL_WEIGHT: f32 = 0.5;

/// `tan(fov_y · RESERVOIR_CELL_SIZE_PIXELS · max(1/h, h/w²))`: the reservoir cell's size per
/// unit of distance from the eye, for a `width × height` image of vertical field of view `fov_y`.
#[inline]
pub fn reservoir_cell_const(fov_y: f32, width: u32, height: u32) -> f32 {
    let (w, h) = (max(width as f32, 1.0), max(height as f32, 1.0));
    tan(fov_y * RESERVOIR_CELL_SIZE_PIXELS * max(1.0 / h, h / (w * w)))
}

/// A reservoir-grid cell.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct ReservoirCell {
    /// Level `L`: the cell's size is `0.001 · 2^L`.
    pub level: u32,
    /// Edge of the cell.
    pub size: f32,
    /// Bucket: `pcg` chain mod the bucket count.
    pub bucket: u32,
    /// Checksum, never 0 (0 marks an empty slot).
    pub checksum: u32,
}

/// The cell of `p` seen from `eye` (see the [module](self)), in a grid of `buckets` buckets.
/// Levels truncate toward zero: points closer than a millimetre's worth are level 0. Non-finite
/// positions land in some cell without NaN.
#[inline]
pub fn reservoir_cell(p: Vec3, eye: Vec3, cell_const: f32, buckets: u32) -> ReservoirCell {
    let x = 1000.0 * (p - eye).length() * cell_const;
    // uint(log2(x)) from the exponent bits: exact, and 0 below 1 or for NaN.
    let level = if x >= 1.0 {
        min_u32((x.to_bits() >> 23) - 127, 127)
    } else {
        0
    };
    let size = 0.001 * f32::from_bits((level + 127) << 23);
    let c = |v: f32| to_i32_clamped(floor(v / size)) as u32;
    let words = [level, c(p.x), c(p.y), c(p.z)];
    let buckets = if buckets == 0 { 1 } else { buckets };
    let checksum = xxhash32_chain(words);
    ReservoirCell {
        level,
        size,
        bucket: pcg_chain(words) % buckets,
        checksum: if checksum == 0 { 1 } else { checksum },
    }
}

/// `p` moved in the plane of unit normal `n` by `(2u − 1) × √2 × cell_size` along the tangent
/// axes (`u` uniform in `[0, 1)²`).
#[inline]
pub fn jitter_in_tangent_plane(p: Vec3, n: Vec3, cell_size: f32, u: Vec2) -> Vec3 {
    let (t, b) = orthonormal_basis(n);
    let o = (u * 2.0 - Vec2::ONE) * (RESERVOIR_JITTER_SCALE * cell_size);
    p + t * o.x + b * o.y
}

/// Inserts `cell` into the grid whose checksum words start at `words[base]`
/// (`buckets × RESERVOIR_GRID_SLOTS_PER_BUCKET` of them, zeroed by the clear pass): the slot
/// already holding its checksum or the first empty one claimed by compare-exchange; the slot's
/// index, or [`RESERVOIR_GRID_NONE`] when the bucket is full of other cells.
#[inline]
pub fn insert_reservoir_cell<W: AtomicWords + ?Sized>(
    words: &mut W,
    base: usize,
    cell: &ReservoirCell,
) -> u32 {
    let first = cell.bucket * RESERVOIR_GRID_SLOTS_PER_BUCKET;
    let mut i = 0;
    while i < RESERVOIR_GRID_SLOTS_PER_BUCKET {
        let slot = first + i;
        let at = base + slot as usize;
        if at >= words.word_count() {
            return RESERVOIR_GRID_NONE;
        }
        let old = words.compare_exchange(at, 0, cell.checksum);
        if old == 0 || old == cell.checksum {
            return slot;
        }
        i += 1;
    }
    RESERVOIR_GRID_NONE
}

/// The slot of `cell` in the grid at `words[base]`, or [`RESERVOIR_GRID_NONE`]: probing stops
/// at the first empty slot (cells are never removed within a frame).
#[inline]
pub fn find_reservoir_cell<W: AtomicWords + ?Sized>(
    words: &W,
    base: usize,
    cell: &ReservoirCell,
) -> u32 {
    let first = cell.bucket * RESERVOIR_GRID_SLOTS_PER_BUCKET;
    let mut i = 0;
    while i < RESERVOIR_GRID_SLOTS_PER_BUCKET {
        let slot = first + i;
        let at = base + slot as usize;
        if at >= words.word_count() {
            return RESERVOIR_GRID_NONE;
        }
        let v = words.load(at);
        if v == cell.checksum {
            return slot;
        }
        if v == 0 {
            return RESERVOIR_GRID_NONE;
        }
        i += 1;
    }
    RESERVOIR_GRID_NONE
}

/// Index (within a cell's list of `count` reservoirs) of temporal neighbour `k`: all of them when
/// there are at most [`MAX_TEMPORAL_NEIGHBOURS`], else [`MAX_TEMPORAL_NEIGHBOURS`] evenly strided
/// ones from a random start (`u` uniform in `[0, 1)`), all distinct.
#[inline]
pub fn temporal_neighbour(count: u32, k: u32, u: f32) -> u32 {
    if count <= MAX_TEMPORAL_NEIGHBOURS {
        return k;
    }
    let start = min_u32(to_u32_clamped(u * count as f32), count - 1);
    let stride = count / MAX_TEMPORAL_NEIGHBOURS;
    (start + k * stride) % count
}

/// Number of temporal neighbours of a cell holding `count` reservoirs.
#[inline]
pub fn temporal_neighbour_count(count: u32) -> u32 {
    min_u32(count, MAX_TEMPORAL_NEIGHBOURS)
}

/// Whether a neighbour of unit normal `neighbour` may be reused at a hit of unit normal
/// `normal`: `dot⁴ ≥` [`MIN_NEIGHBOUR_NORMAL_WEIGHT`] (opposite normals never pass).
#[inline]
pub fn accepts_neighbour(normal: Vec3, neighbour: Vec3) -> bool {
    let d = normal.dot(neighbour);
    let d2 = d * d;
    d > 0.0 && d2 * d2 >= MIN_NEIGHBOUR_NORMAL_WEIGHT
}

/// A reservoir as stored between frames (16 bytes, a `uint4`).
///
/// | offset | field    |
/// |--------|----------|
/// | 0      | `light`  |
/// | 4      | `params` |
/// | 8      | `ucw`    |
/// | 12     | `m`      |
#[repr(C)]
#[derive(Clone, Copy, Debug, Default, PartialEq, Pod, Zeroable)]
pub struct PackedReservoir {
    /// Light index of the sample.
    pub light: u32,
    /// The sample's place on the light ([`sample_params_uv`]).
    pub params: u32,
    /// Unbiased contribution weight `W`; 0 for an invalidated (occluded) sample.
    pub ucw: f32,
    /// Candidates represented, `M`.
    pub m: f32,
}

impl crate::layout::FloatLayout for PackedReservoir {
    const FLOAT_WORDS: &'static [u32] = &[2, 3];
}

impl PackedReservoir {
    /// The stored form of `reservoir` (sample = light index) with sample bits `params`.
    #[inline]
    pub fn pack(reservoir: &Reservoir, params: u32) -> Self {
        Self {
            light: reservoir.sample,
            params,
            ucw: reservoir.ucw,
            m: reservoir.m,
        }
    }

    /// The reservoir to merge (`w_sum` is not stored: merging only reads `W` and `M`).
    #[inline]
    pub fn reservoir(&self) -> Reservoir {
        Reservoir {
            sample: self.light,
            w_sum: 0.0,
            m: self.m,
            ucw: self.ucw,
        }
    }
}

/// The hit a stored reservoir belongs to (16 bytes): what the neighbour test reads.
///
/// | offset | field      |
/// |--------|------------|
/// | 0      | `position` |
/// | 12     | `normal`   |
#[repr(C)]
#[derive(Clone, Copy, Debug, Default, PartialEq, Pod, Zeroable)]
pub struct ReservoirHit {
    /// World-space position.
    pub position: [f32; 3],
    /// Unit normal, [`pack_snorm10x3`].
    pub normal: u32,
}

impl crate::layout::FloatLayout for ReservoirHit {
    const FLOAT_WORDS: &'static [u32] = &[0, 1, 2];
}

impl ReservoirHit {
    /// The stored form of a hit.
    #[inline]
    pub fn new(position: Vec3, normal: Vec3) -> Self {
        Self {
            position: position.to_array(),
            normal: pack_snorm10x3(normal),
        }
    }

    /// The unit normal.
    #[inline]
    pub fn normal(&self) -> Vec3 {
        unpack_snorm10x3(self.normal).normalize_or_zero()
    }
}

/// Temporal resampling of one hit's reservoir (see the [module](self)):
/// [`TemporalResampling::begin`] with this frame's light-grid sample,
/// [`TemporalResampling::merge_neighbour`] for each previous-frame neighbour, then
/// [`TemporalResampling::finish`].
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct TemporalResampling {
    /// The combined reservoir (sample = light index).
    pub reservoir: Reservoir,
    /// The kept sample's bits ([`sample_params_uv`]).
    pub params: u32,
    /// The kept sample evaluated at the current hit.
    pub contribution: LightContribution,
}

impl TemporalResampling {
    /// Starts from this frame's sample, its `M` counted as [`CURRENT_M`] (`u` uniform in
    /// `[0, 1)`).
    #[inline]
    pub fn begin(current: &LightGridSample, u: f32) -> Self {
        let mut reservoir = Reservoir::EMPTY;
        reservoir.merge(
            &current.reservoir,
            current.contribution.target,
            u,
            CURRENT_M,
        );
        Self {
            reservoir,
            params: current.params,
            contribution: current.contribution,
        }
    }

    /// Merges the previous frame's reservoir `neighbour`, stored with the hit normal
    /// `neighbour_normal`, at the current `hit`: skipped (returns false, `M` unchanged) when the
    /// normals disagree ([`accepts_neighbour`]); else its sample is re-evaluated at `hit` and
    /// streamed with `M` clamped to [`TEMPORAL_M_CAP`] (`u` uniform in `[0, 1)`). Returns
    /// whether the neighbour's sample was kept.
    #[inline]
    pub fn merge_neighbour(
        &mut self,
        params: &LightGridParams,
        lighting: LightSources<'_>,
        hit: &DiffuseHit,
        neighbour: &PackedReservoir,
        neighbour_normal: Vec3,
        u: f32,
    ) -> bool {
        if !accepts_neighbour(hit.normal, neighbour_normal) {
            return false;
        }
        let c = light_contribution(
            params,
            lighting,
            hit,
            neighbour.light,
            sample_params_uv(neighbour.params),
        );
        let kept = self
            .reservoir
            .merge(&neighbour.reservoir(), c.target, u, TEMPORAL_M_CAP);
        if kept {
            self.params = neighbour.params;
            self.contribution = c;
        }
        kept
    }

    /// The combined sample: `W` computed, and the radiance it sends toward the probe when its
    /// shadow ray is unoccluded (`weight × radiance × W`), as [`LightGridSample`].
    #[inline]
    pub fn finish(&self) -> LightGridSample {
        let mut reservoir = self.reservoir;
        reservoir.finalize(self.contribution.target);
        let mut s = LightGridSample::NONE;
        s.reservoir = reservoir;
        if reservoir.ucw > 0.0 {
            s.params = self.params;
            s.contribution = self.contribution;
            s.radiance =
                self.contribution.weight * self.contribution.sample.radiance * reservoir.ucw;
        }
        s
    }
}

/// Buckets of the reservoir grid of a frame of `pixels` pixels: one slot per pixel
/// (`pixels / 16` buckets of [`RESERVOIR_GRID_SLOTS_PER_BUCKET`]), a power of two between 64 and
/// the reference's [`RESERVOIR_GRID_BUCKETS`].
#[inline]
pub fn reservoir_grid_buckets(pixels: u32) -> u32 {
    let wanted = pixels.div_ceil(RESERVOIR_GRID_SLOTS_PER_BUCKET);
    let mut b = 64;
    while b < wanted && b < RESERVOIR_GRID_BUCKETS {
        b *= 2;
    }
    b
}

/// The reservoir-grid cell of a query's hit seen from `eye`: its position jittered in the
/// tangent plane by up to √2 cells ([`jitter_in_tangent_plane`]), so neighbouring cells share
/// reservoirs.
#[inline]
pub fn reservoir_grid_cell(
    view: &CacheFrameParams,
    eye: Vec3,
    query: &CacheQuery,
    rng: &mut Random,
) -> ReservoirCell {
    let p = query.position();
    let n = query.shading_normal();
    let cell = reservoir_cell(p, eye, view.reservoir_cell_const, view.reservoir_buckets);
    let jittered = jitter_in_tangent_plane(p, n, cell.size, rng.next_vec2());
    reservoir_cell(
        jittered,
        eye,
        view.reservoir_cell_const,
        view.reservoir_buckets,
    )
}

/// GenerateReservoirs with ReSTIR: inserts the query's hit into this frame's reservoir grid
/// (`keys`, one checksum per slot) and claims its place in the slot's list (`counts`, one word per
/// slot): `[slot, index]`, slot [`RESERVOIR_GRID_NONE`] when the bucket is full.
#[inline]
pub fn insert_reservoir<K: AtomicWords + ?Sized, C: AtomicWords + ?Sized>(
    keys: &mut K,
    counts: &mut C,
    view: &CacheFrameParams,
    eye: Vec3,
    query: &CacheQuery,
    rng: &mut Random,
) -> [u32; 2] {
    let cell = reservoir_grid_cell(view, eye, query, rng);
    let slot = insert_reservoir_cell(keys, 0, &cell);
    if slot == RESERVOIR_GRID_NONE || slot as usize >= counts.word_count() {
        return [RESERVOIR_GRID_NONE, 0];
    }
    [slot, counts.fetch_add(slot as usize, 1)]
}

/// CompactReservoirs: the entry of the compacted list a shadow ray's reservoir goes to, from its
/// `[slot, index]` and the scanned slot counts `offsets`; `None` without a slot.
#[inline]
pub fn reservoir_entry(offsets: &[u32], place: [u32; 2]) -> Option<u32> {
    let [slot, index] = place;
    if slot == RESERVOIR_GRID_NONE || slot as usize >= offsets.len() {
        return None;
    }
    Some(offsets[slot as usize] + index)
}

/// CompactReservoirs's scatter holds, per entry, what [`ordered_reservoir_entry`] sorts its
/// shadow ray `ray` by: its query's `ray_index` (unique within a frame: a ray's query, or the one
/// query carried over from it, with [`CARRIED_QUERY_BIT`](crate::world_cache::CARRIED_QUERY_BIT)),
/// then the shadow ray's index (never reached, and what OrderReservoirs writes); past the lists,
/// last.
#[inline]
pub fn reservoir_order_key(
    queries: &[CacheQuery],
    shadow_rays: &[ShadowRay],
    ray: u32,
) -> [u32; 2] {
    if (ray as usize) < shadow_rays.len() {
        let q = shadow_rays[ray as usize].query as usize;
        if q < queries.len() {
            return [queries[q].ray_index, ray];
        }
    }
    [u32::MAX, u32::MAX]
}

/// OrderReservoirs: the entry of the ordered list that the shadow ray at `place` goes to, in its
/// slot's run sorted by key ([`reservoir_order_key`], read from CompactReservoirs's scatter
/// `unordered`, where each ray wrote its own once), so that the run's order, which the next
/// frame's ResampleReservoirs strides through, does not depend on the order in which
/// GenerateReservoirs's atomics ran. Reads every key of the run: one reservoir cell's hits (tens
/// to hundreds; cells span a fixed angle in pixels, so the run does not grow with the
/// resolution).
#[inline]
pub fn ordered_reservoir_entry(
    offsets: &[u32],
    unordered: &[[u32; 2]],
    place: [u32; 2],
) -> Option<u32> {
    let [slot, index] = place;
    if slot == RESERVOIR_GRID_NONE || slot as usize + 1 >= offsets.len() {
        return None;
    }
    let (first, end) = (
        offsets[slot as usize],
        min_u32(offsets[slot as usize + 1], unordered.len() as u32),
    );
    if first + index >= end {
        return None;
    }
    let own = unordered[(first + index) as usize];
    let mut rank = 0;
    let mut e = first;
    while e < end {
        let other = unordered[e as usize];
        if other[0] < own[0] || (other[0] == own[0] && other[1] < own[1]) {
            rank += 1;
        }
        e += 1;
    }
    Some(first + rank)
}

/// The previous frame's reservoir grid, as ResampleReservoirs reads it: the cells' keys, each
/// cell's run of entries (`offsets`, ordered by `ordered_reservoir_entry`), and the reservoirs
/// and hit records the entries index.
#[derive(Clone, Copy)]
pub struct PreviousReservoirGrid<'a> {
    /// The grid's cell keys ([`find_reservoir_cell`]).
    pub keys: &'a [u32],
    /// Each cell's first entry, and the end of the last.
    pub offsets: &'a [u32],
    /// The reservoirs' indices, cell after cell.
    pub entries: &'a [u32],
    /// The previous frame's reservoirs.
    pub reservoirs: &'a [PackedReservoir],
    /// The previous frame's hit records, one per reservoir.
    pub hits: &'a [ReservoirHit],
}

/// ResampleReservoirs for one query: its reservoir this frame (`current`, the light grid's) merged
/// with at most four reservoirs of the previous frame's cell (looked up from the previous eye,
/// normals checked, `M` capped at 20: [`TemporalResampling`]). The previous grid: slot checksums
/// `keys`, exclusive prefix sums of its slot counts `offsets` (`slots + 1` words, the last the
/// total), the compacted list `entries` of previous shadow-ray indices, slot after slot, and per
/// previous shadow ray its reservoir and hit. Returns the combined sample.
pub fn resample_reservoir(
    grid: &LightGridParams,
    lighting: LightSources<'_>,
    view: &CacheFrameParams,
    query: &CacheQuery,
    current: &PackedReservoir,
    previous: PreviousReservoirGrid<'_>,
    rng: &mut Random,
) -> LightGridSample {
    let PreviousReservoirGrid {
        keys,
        offsets,
        entries,
        reservoirs,
        hits,
    } = previous;
    let hit = diffuse_hit(query);
    let mut sample = LightGridSample::NONE;
    sample.reservoir = current.reservoir();
    sample.params = current.params;
    sample.contribution = light_contribution(
        grid,
        lighting,
        &hit,
        current.light,
        sample_params_uv(current.params),
    );
    let mut resampling = TemporalResampling::begin(&sample, rng.next_f32());
    if view.has(FLAG_RESTIR_HISTORY) {
        let cell = reservoir_grid_cell(view, Vec3::from_array(view.previous_eye), query, rng);
        let slot = find_reservoir_cell(keys, 0, &cell);
        if slot != RESERVOIR_GRID_NONE && (slot as usize) + 1 < offsets.len() {
            let first = offsets[slot as usize];
            let count = offsets[slot as usize + 1].wrapping_sub(first);
            let u = rng.next_f32();
            let n = temporal_neighbour_count(count);
            let mut k = 0;
            while k < n {
                let e = (first + temporal_neighbour(count, k, u)) as usize;
                if e < entries.len() {
                    let r = entries[e] as usize;
                    if r < reservoirs.len() && r < hits.len() {
                        let neighbour = reservoirs[r];
                        let normal = hits[r].normal();
                        resampling.merge_neighbour(
                            grid,
                            lighting,
                            &hit,
                            &neighbour,
                            normal,
                            rng.next_f32(),
                        );
                    }
                }
                k += 1;
            }
        }
    }
    resampling.finish()
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::color::luminance;
    use crate::hash_cells::shared_words::SharedWords;
    use crate::lights::{EMIT_FRONT, GpuLight};
    use crate::random::Random;
    use crate::world_cache::CARRIED_QUERY_BIT;
    use core::mem::{offset_of, size_of};
    use core::sync::atomic::{AtomicU32, Ordering};
    use glam::UVec2;

    #[test]
    fn layout() {
        use crate::layout::{FloatLayout, float_field_words};
        assert_eq!(
            ReservoirHit::FLOAT_WORDS,
            float_field_words(&[(offset_of!(ReservoirHit, position), 3)])
        );
        assert_eq!(
            PackedReservoir::FLOAT_WORDS,
            float_field_words(&[
                (offset_of!(PackedReservoir, ucw), 1),
                (offset_of!(PackedReservoir, m), 1)
            ])
        );
        assert_eq!(size_of::<PackedReservoir>(), 16);
        assert_eq!(offset_of!(PackedReservoir, light), 0);
        assert_eq!(offset_of!(PackedReservoir, params), 4);
        assert_eq!(offset_of!(PackedReservoir, ucw), 8);
        assert_eq!(offset_of!(PackedReservoir, m), 12);
        assert_eq!(size_of::<ReservoirHit>(), 16);
        assert_eq!(offset_of!(ReservoirHit, normal), 12);
    }

    #[test]
    fn cells_are_power_of_two_millimetres_by_distance() {
        // 1000 × 10 m × 0.01 = 100: level 6 (64 ≤ 100 < 128), 6.4 cm cells.
        let p = Vec3::new(0.0, 10.0, 0.0);
        let c = reservoir_cell(p, Vec3::ZERO, 0.01, RESERVOIR_GRID_BUCKETS);
        assert_eq!(c.level, 6);
        assert_eq!(c.size, 0.064);
        assert!(c.bucket < RESERVOIR_GRID_BUCKETS && c.checksum != 0);
        let words = [6, 0, 156, 0];
        assert_eq!(c.bucket, pcg_chain(words) % RESERVOIR_GRID_BUCKETS);
        assert_eq!(c.checksum, max_checksum(xxhash32_chain(words)));
        // Another point of the same cell, and one across its boundary.
        assert_eq!(
            reservoir_cell(
                p + Vec3::splat(0.01),
                Vec3::ZERO,
                0.01,
                RESERVOIR_GRID_BUCKETS
            ),
            c
        );
        assert_ne!(
            reservoir_cell(
                p - Vec3::splat(0.01),
                Vec3::ZERO,
                0.01,
                RESERVOIR_GRID_BUCKETS
            ),
            c
        );
        // Exactly 128: level 7; just below: 6 (truncation, not rounding).
        assert_eq!(
            reservoir_cell(Vec3::new(12.8, 0.0, 0.0), Vec3::ZERO, 0.01, 8).level,
            7
        );
        assert_eq!(
            reservoir_cell(Vec3::new(12.79, 0.0, 0.0), Vec3::ZERO, 0.01, 8).level,
            6
        );
        // Near the eye: level 0, millimetre cells; negative coordinates floor down.
        let near = reservoir_cell(Vec3::new(-0.0005, 0.0, 0.0), Vec3::ZERO, 0.01, 8);
        assert_eq!((near.level, near.size), (0, 0.001));
        assert_eq!(
            near.checksum,
            max_checksum(xxhash32_chain([0, u32::MAX, 0, 0]))
        );
        // The previous eye gives the previous frame's level.
        assert_eq!(
            reservoir_cell(p, Vec3::new(0.0, 5.0, 0.0), 0.01, 8).level,
            5
        );
        // NaN and infinity land somewhere without panicking.
        for bad in [Vec3::splat(f32::NAN), Vec3::splat(f32::INFINITY)] {
            let c = reservoir_cell(bad, Vec3::ZERO, 0.01, 8);
            assert!(c.bucket < 8 && c.checksum != 0 && c.size.is_finite());
        }
        // 16 pixels of a 90° field of view over 1080 rows.
        let k = reservoir_cell_const(core::f32::consts::FRAC_PI_2, 1920, 1080);
        assert!((k - (core::f32::consts::FRAC_PI_2 * 16.0 / 1080.0).tan()).abs() < 1e-7);
    }

    fn max_checksum(x: u32) -> u32 {
        if x == 0 { 1 } else { x }
    }

    #[test]
    fn jitter_stays_in_the_tangent_plane() {
        let n = Vec3::new(0.3, -0.8, 0.5).normalize();
        let p = Vec3::new(1.0, 2.0, 3.0);
        let mut rng = Random::new(4, 0);
        let mut reach = 0.0f32;
        for _ in 0..10_000 {
            let q = jitter_in_tangent_plane(p, n, 0.1, rng.next_vec2());
            assert!((q - p).dot(n).abs() < 1e-6);
            reach = reach.max((q - p).length());
        }
        // Corners of the square of half-side √2 × 0.1: up to 0.2.
        assert!(reach <= 0.2 + 1e-6 && reach > 0.19, "{reach}");
    }

    #[test]
    fn a_full_bucket_refuses_and_lookups_stop_at_empty_slots() {
        // One bucket: every cell collides.
        let mut words = vec![0u32; 3 + RESERVOIR_GRID_SLOTS_PER_BUCKET as usize];
        let cell = |i: u32| reservoir_cell(Vec3::new(i as f32, 0.0, 0.0), Vec3::ZERO, 0.001, 1);
        assert_eq!(
            find_reservoir_cell(&words[..], 3, &cell(0)),
            RESERVOIR_GRID_NONE
        );
        for i in 0..RESERVOIR_GRID_SLOTS_PER_BUCKET {
            assert_eq!(insert_reservoir_cell(&mut words[..], 3, &cell(i)), i);
        }
        assert_eq!(
            insert_reservoir_cell(&mut words[..], 3, &cell(16)),
            RESERVOIR_GRID_NONE
        );
        assert_eq!(insert_reservoir_cell(&mut words[..], 3, &cell(5)), 5);
        assert_eq!(find_reservoir_cell(&words[..], 3, &cell(7)), 7);
        assert_eq!(
            find_reservoir_cell(&words[..], 3, &cell(16)),
            RESERVOIR_GRID_NONE
        );
        assert_eq!(words[..3], [0; 3]);
        // A short buffer refuses rather than writing past it.
        assert_eq!(
            insert_reservoir_cell(&mut words[..10], 3, &cell(20)),
            RESERVOIR_GRID_NONE
        );
    }

    /// Four threads insert the same 300 cells in different orders: each cell gets one slot, the
    /// same for every thread, and lookups find it.
    #[test]
    fn concurrent_inserts_agree() {
        let buckets = 64;
        let words: Vec<AtomicU32> = (0..buckets * RESERVOIR_GRID_SLOTS_PER_BUCKET)
            .map(|_| AtomicU32::new(0))
            .collect();
        let cells: Vec<ReservoirCell> = (0..300)
            .map(|i| {
                let p = Vec3::new((i % 10) as f32, (i / 10) as f32, 0.5) * 0.37;
                reservoir_cell(p, Vec3::new(0.0, 0.0, -3.0), 0.002, buckets)
            })
            .collect();
        let slots: Vec<Vec<u32>> = std::thread::scope(|s| {
            let handles: Vec<_> = (0..4u32)
                .map(|t| {
                    let mut view = SharedWords(&words);
                    let cells = &cells;
                    s.spawn(move || {
                        let mut out = vec![RESERVOIR_GRID_NONE; cells.len()];
                        for k in 0..cells.len() {
                            // Each thread its own order (multipliers prime to 300).
                            let i =
                                (k * [7, 11, 13, 17][t as usize] + t as usize * 31) % cells.len();
                            out[i] = insert_reservoir_cell(&mut view, 0, &cells[i]);
                        }
                        out
                    })
                })
                .collect();
            handles.into_iter().map(|h| h.join().unwrap()).collect()
        });
        let mut distinct = slots[0].clone();
        for other in &slots[1..] {
            assert_eq!(other, &slots[0]);
        }
        assert!(distinct.iter().all(|&s| s != RESERVOIR_GRID_NONE));
        distinct.sort_unstable();
        distinct.dedup();
        assert_eq!(distinct.len(), cells.len());
        let filled = words
            .iter()
            .filter(|w| w.load(Ordering::SeqCst) != 0)
            .count();
        assert_eq!(filled, cells.len());
        let plain: Vec<u32> = words.iter().map(|w| w.load(Ordering::SeqCst)).collect();
        for (c, &slot) in cells.iter().zip(&slots[0]) {
            assert_eq!(find_reservoir_cell(&plain[..], 0, c), slot);
        }
    }

    #[test]
    fn neighbours_are_strided_and_filtered_by_normal() {
        assert_eq!(temporal_neighbour_count(3), 3);
        assert_eq!(temporal_neighbour_count(10), 4);
        let small: Vec<u32> = (0..3).map(|k| temporal_neighbour(3, k, 0.7)).collect();
        assert_eq!(small, [0, 1, 2]);
        let picks: Vec<u32> = (0..4).map(|k| temporal_neighbour(10, k, 0.95)).collect();
        assert_eq!(picks, [9, 1, 3, 5]);
        assert_eq!(temporal_neighbour(10, 0, f32::NAN), 0);
        let tilted = |c: f32| Vec3::new((1.0 - c * c).sqrt(), c, 0.0);
        // 0.85⁴ = 0.522, 0.84⁴ = 0.498.
        assert!(accepts_neighbour(Vec3::Y, tilted(0.85)));
        assert!(!accepts_neighbour(Vec3::Y, tilted(0.84)));
        assert!(!accepts_neighbour(Vec3::Y, -Vec3::Y));
        assert!(!accepts_neighbour(Vec3::Y, Vec3::splat(f32::NAN)));
        let hit = ReservoirHit::new(Vec3::ONE, tilted(0.85));
        assert!((hit.normal() - tilted(0.85)).length() < 3e-3);
    }

    /// A point light, a one-sided triangle, a sun: a small static scene.
    fn scene() -> (LightGridParams, Vec<GpuLight>) {
        let lights = vec![
            GpuLight::point(Vec3::new(1.0, 2.0, 0.0), Vec3::new(3.0, 2.0, 1.0)),
            GpuLight::triangle(
                0,
                0,
                [
                    Vec3::new(-1.0, 1.5, -1.0),
                    Vec3::new(-1.0, 1.5, 0.0),
                    Vec3::new(0.0, 1.5, -1.0),
                ],
                Vec3::splat(5.0),
                EMIT_FRONT,
            ),
            GpuLight::directional(Vec3::new(-0.5, -1.0, 0.0).normalize(), Vec3::splat(0.7)),
            GpuLight::point(Vec3::new(-3.0, 0.5, 2.0), Vec3::splat(0.5)),
        ];
        let params = crate::light_grid::light_grid_params(
            Vec3::ZERO,
            Vec3::ONE,
            lights.len() as u32,
            UVec2::ZERO,
            0.0,
            1.0,
        );
        (params, lights)
    }

    const HIT: DiffuseHit = DiffuseHit {
        position: Vec3::new(0.2, 0.0, -0.1),
        normal: Vec3::Y,
        albedo: Vec3::new(0.8, 0.6, 0.4),
    };

    /// This frame's reservoir: RIS over two uniformly chosen candidates (a weak sampler, so that
    /// reuse has something to improve).
    fn current(params: &LightGridParams, lights: &[GpuLight], rng: &mut Random) -> LightGridSample {
        let n = lights.len() as u32;
        let mut r = Reservoir::EMPTY;
        let mut chosen = LightGridSample::NONE;
        for _ in 0..2 {
            let l = to_u32_clamped(rng.next_f32() * n as f32);
            let bits = rng.next_u32();
            let c = light_contribution(
                params,
                LightSources {
                    lights,
                    ..LightSources::EMPTY
                },
                &HIT,
                l,
                sample_params_uv(bits),
            );
            if r.update(l, c.target * n as f32, rng.next_f32()) {
                chosen.params = bits;
                chosen.contribution = c;
            }
        }
        r.finalize(chosen.contribution.target);
        chosen.reservoir = r;
        chosen.radiance = chosen.contribution.weight * chosen.contribution.sample.radiance * r.ucw;
        chosen
    }

    /// Temporal reuse in a static scene: many independent chains of frames, each frame combining
    /// a fresh reservoir with the previous frame's (stored packed, then re-evaluated); the mean
    /// of the last frame's estimates is the brute-force sum, its variance far below one frame's,
    /// and `M` follows `1 + min(M_prev, 20)`.
    #[test]
    fn temporal_reuse_is_unbiased_in_a_static_scene() {
        let (params, lights) = scene();
        let mut rng = Random::new(8, 0);
        let mut exact = 0.0f64;
        for l in 0..lights.len() as u32 {
            let n = 100_000;
            let mut sum = 0.0f64;
            for _ in 0..n {
                let c = light_contribution(
                    &params,
                    LightSources {
                        lights: &lights,
                        ..LightSources::EMPTY
                    },
                    &HIT,
                    l,
                    rng.next_vec2(),
                );
                sum += f64::from(luminance(c.weight * c.sample.radiance));
            }
            exact += sum / n as f64;
        }
        let chains = 20_000;
        let frames = 25;
        let (mut first, mut first2, mut last, mut last2) = (0.0f64, 0.0f64, 0.0f64, 0.0f64);
        for _ in 0..chains {
            let mut stored: Option<PackedReservoir> = None;
            let normal = ReservoirHit::new(HIT.position, HIT.normal).normal();
            for frame in 1..=frames {
                let cur = current(&params, &lights, &mut rng);
                let mut t = TemporalResampling::begin(&cur, rng.next_f32());
                if let Some(prev) = stored {
                    t.merge_neighbour(
                        &params,
                        LightSources {
                            lights: &lights,
                            ..LightSources::EMPTY
                        },
                        &HIT,
                        &prev,
                        normal,
                        rng.next_f32(),
                    );
                }
                let out = t.finish();
                assert_eq!(out.reservoir.m, (frame as f32).min(1.0 + TEMPORAL_M_CAP));
                let v = f64::from(luminance(out.radiance));
                if frame == 1 {
                    first += v;
                    first2 += v * v;
                }
                if frame == frames {
                    last += v;
                    last2 += v * v;
                }
                stored = Some(PackedReservoir::pack(&out.reservoir, out.params));
            }
        }
        let n = f64::from(chains);
        let (m1, m2) = (first / n, last / n);
        let (v1, v2) = (first2 / n - m1 * m1, last2 / n - m2 * m2);
        let se = (v2 / n).sqrt();
        println!(
            "exact {exact:.5}; one frame {m1:.5} (variance {v1:.5}); after {frames} frames \
             {m2:.5} ± {se:.5} (variance {v2:.5})"
        );
        assert!((m1 - exact).abs() < 4.0 * (v1 / n).sqrt());
        assert!((m2 - exact).abs() < 4.0 * se, "{m2} vs {exact}");
        assert!(v2 < 0.2 * v1);
    }

    /// A neighbour with a disagreeing normal is skipped and does not count.
    #[test]
    fn rejected_neighbours_do_not_count() {
        let (params, lights) = scene();
        let mut rng = Random::new(3, 1);
        let cur = current(&params, &lights, &mut rng);
        let mut t = TemporalResampling::begin(&cur, 0.5);
        let prev = PackedReservoir {
            light: 0,
            params: 0,
            ucw: 1.0,
            m: 50.0,
        };
        let sources = LightSources {
            lights: &lights,
            ..LightSources::EMPTY
        };
        assert!(!t.merge_neighbour(&params, sources, &HIT, &prev, Vec3::X, 0.0));
        assert_eq!(t.reservoir.m, 1.0);
        // An agreeing one counts 20 at most, and a zero W never wins.
        let dead = PackedReservoir { ucw: 0.0, ..prev };
        assert!(!t.merge_neighbour(&params, sources, &HIT, &dead, Vec3::Y, 0.0));
        assert_eq!(t.reservoir.m, 21.0);
        assert_eq!(PackedReservoir::pack(&t.reservoir, 9).reservoir().m, 21.0);
    }

    #[test]
    fn reservoir_runs_are_ordered_the_same_whatever_the_scatter_order() {
        use itertools::Itertools;
        // Five shadow rays in two slots (three in slot 0, two in slot 1), one with no slot; the
        // queries' ray indices are unrelated to the shadow rays' and the queries' order.
        let ray_indices = [40u32, 7, CARRIED_QUERY_BIT | 7, 12, 3, 99];
        let queries: Vec<CacheQuery> = ray_indices
            .iter()
            .map(|&r| CacheQuery {
                ray_index: r,
                ..CacheQuery::default()
            })
            .collect();
        let query_of = [2u32, 0, 4, 1, 3, 5];
        let shadow_rays: Vec<ShadowRay> = query_of
            .iter()
            .map(|&q| ShadowRay {
                query: q,
                ..ShadowRay::default()
            })
            .collect();
        let slot_of = [0u32, 1, 0, 0, 1, RESERVOIR_GRID_NONE];
        let offsets = [0u32, 3, 5];
        let mut lists = Vec::new();
        for order in (0..shadow_rays.len()).permutations(shadow_rays.len()) {
            // GenerateReservoirs's atomics hand out places in this order.
            let mut counts = [0u32; 2];
            let mut places = [[0u32; 2]; 6];
            for &r in &order {
                let slot = slot_of[r];
                places[r] = [slot, 0];
                if slot != RESERVOIR_GRID_NONE {
                    places[r][1] = counts[slot as usize];
                    counts[slot as usize] += 1;
                }
            }
            let mut unordered = [[u32::MAX; 2]; 5];
            for (r, &place) in places.iter().enumerate() {
                if let Some(e) = reservoir_entry(&offsets, place) {
                    unordered[e as usize] = reservoir_order_key(&queries, &shadow_rays, r as u32);
                }
            }
            let mut ordered = [u32::MAX; 5];
            for (r, &place) in places.iter().enumerate() {
                let e = ordered_reservoir_entry(&offsets, &unordered, place);
                assert_eq!(e.is_none(), slot_of[r] == RESERVOIR_GRID_NONE);
                if let Some(e) = e {
                    assert_eq!(ordered[e as usize], u32::MAX, "{order:?}: entry {e} twice");
                    ordered[e as usize] = r as u32;
                }
            }
            lists.push(ordered);
        }
        assert!(lists.windows(2).all(|w| w[0] == w[1]));
        // Slot 0 holds rays 0, 2, 3 (ray indices 7 | CARRIED, 3, 7), slot 1 rays 1, 4 (40, 12).
        assert_eq!(lists[0], [2, 3, 0, 4, 1]);
    }
}
