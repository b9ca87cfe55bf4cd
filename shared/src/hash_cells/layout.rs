//! The hash grid's buffer layouts: its capacities (tiles, cells, accumulator words), the cell
//! value and accumulator records, and the push constants and queries of its passes. Same rules as
//! the frame-wide layouts of [`crate::layout`], whose binding and push-constant limits these
//! respect.

use bytemuck::{Pod, Zeroable};
use glam::{Vec3, Vec4};

use super::{
    CELLS_PER_TILE, MAX_NUM_TILES_LOG2, MIN_CELL_SIZE, MIP0_CELLS_PER_TILE, NUM_BUCKETS_LOG2,
    TILES_PER_BUCKET_LOG2,
};
use crate::fixed_point;
use crate::layout::{MAX_PUSH_CONSTANT_BYTES, MAX_STORAGE_BUFFER_BYTES};

/// Largest hash-grid tile count the buffers allow (2^16 = 4096 buckets × 16 tiles by default).
pub const MAX_HASH_GRID_TILES: usize = 1 << MAX_NUM_TILES_LOG2;
/// Largest hash-grid cell count: tiles × 85 (5 570 560; the value buffer is 45 MB).
pub const MAX_HASH_GRID_CELLS: usize = MAX_HASH_GRID_TILES * CELLS_PER_TILE as usize;
/// `u32` words of one mip-0 cell's per-frame accumulator: `r`, `g`, `b` as 64-bit fixed point
/// (`lo`, `hi`, see [`crate::fixed_point`]) and the sample count. Seven, not a padded eight: eight
/// would fill the 128 MiB binding exactly at [`MAX_HASH_GRID_TILES`], and the pass that clears the
/// accumulators writes an eighth less.
pub const ACCUMULATOR_WORDS: usize = 7;
/// Offset, in a tile's accumulator words, of its luminance trend
/// ([`crate::hash_cells::adaptive_blend::TileTrend`], kept across frames): after its 64 cells.
pub const TREND_WORD: usize = MIP0_CELLS_PER_TILE as usize * ACCUMULATOR_WORDS;
/// `u32` words of one tile's accumulators: 64 mip-0 cells × 7, then the trend word.
pub const TILE_ACCUMULATOR_WORDS: usize = TREND_WORD + 1;
/// Largest accumulator buffer, in words: tiles × (64 mip-0 cells × 7 + 1) (118 MB).
pub const MAX_HASH_GRID_ACCUMULATOR_WORDS: usize = MAX_HASH_GRID_TILES * TILE_ACCUMULATOR_WORDS;

/// One hash-grid cell value: `(r · n, g · n, b · n, n)`, the running mean premultiplied by its
/// sample count `n` so that coarser mips are plain sums. Mip-0 counts are integers ≤
/// [`crate::hash_cells::MAX_SAMPLE_COUNT`]; a mip sums its children (≤ 16 · 4^mip). Stored as four
/// [`crate::packing::pack_wide16`]s, 8 bytes instead of 16: unlike half floats they neither
/// saturate at 65504 (a 10⁶ emitter's reflected light) nor lose a count's integrality below 1024
/// (10 significant bits); sums and counts keep 0.1 % of precision
/// ([`crate::packing::WIDE16_MAX_RELATIVE_ERROR`]), the mean 0.2 %. NaN and negative sums store 0.
#[repr(C)]
#[derive(Clone, Copy, Debug, Default, PartialEq, Pod, Zeroable)]
pub struct HashCellValue {
    /// `r · n | g · n << 16`, `b · n | n << 16`.
    words: [u32; 2],
}

impl HashCellValue {
    /// An empty cell.
    pub const ZERO: Self = Self { words: [0; 2] };

    /// A radiance sum `rgb · n` and its sample count `n`, rounded to nearest.
    #[inline]
    pub fn new(radiance_sum: Vec3, count: f32) -> Self {
        Self::new_dithered(radiance_sum, count, 0.5)
    }

    /// [`Self::new`] rounded with `dither` ([`crate::packing::pack_wide16_dithered`]): what a
    /// running mean stores, so that it keeps following a slow change.
    #[inline]
    pub fn new_dithered(radiance_sum: Vec3, count: f32, dither: f32) -> Self {
        Self {
            words: crate::packing::pack_wide16x4_dithered(radiance_sum.extend(count), dither),
        }
    }

    /// `(rgb · n, n)`.
    #[inline]
    pub fn sum_and_count(&self) -> Vec4 {
        crate::packing::unpack_wide16x4(self.words)
    }

    /// Radiance sum `rgb · n`.
    #[inline]
    pub fn radiance_sum(&self) -> Vec3 {
        self.sum_and_count().truncate()
    }

    /// Sample count `n`.
    #[inline]
    pub fn count(&self) -> f32 {
        crate::packing::unpack_wide16(self.words[1] >> 16)
    }

    /// Mean radiance, zero for an empty cell.
    #[inline]
    pub fn mean(&self) -> Vec3 {
        let v = self.sum_and_count();
        if v.w > 0.0 {
            v.truncate() / v.w
        } else {
            Vec3::ZERO
        }
    }
}

/// The weight of one sample drawn as often as uniform sampling would draw it, in the count word's
/// units: weights are counted in sixteenths.
pub const SAMPLE_WEIGHT_ONE: u32 = 16;

/// Largest weight of one sample, in [`SAMPLE_WEIGHT_ONE`]ths: 8 samples' worth (guiding's uniform
/// share bounds a guided ray's weight to 5).
pub const MAX_SAMPLE_WEIGHT: u32 = 8 * SAMPLE_WEIGHT_ONE;

/// One mip-0 cell's per-frame accumulator, as [`ACCUMULATOR_WORDS`] consecutive words of the flat
/// `u32` accumulator buffer (the GPU adds into the words with atomics; this is the loaded copy).
#[repr(C)]
#[derive(Clone, Copy, Debug, Default, PartialEq, Eq, Pod, Zeroable)]
pub struct HashCellAccumulator {
    /// Fixed-point red sum `[lo, hi]`.
    pub r: [u32; 2],
    /// Fixed-point green sum `[lo, hi]`.
    pub g: [u32; 2],
    /// Fixed-point blue sum `[lo, hi]`.
    pub b: [u32; 2],
    /// The added samples' weight, in
    /// [`SAMPLE_WEIGHT_ONE`]ths ([`Self::samples`]).
    pub count: u32,
}

impl HashCellAccumulator {
    /// Word offset of [`HashCellAccumulator::count`] inside a cell's words.
    pub const COUNT_WORD: usize = 6;

    /// The sum of the accumulated samples.
    #[inline]
    pub fn radiance_sum(&self) -> Vec3 {
        Vec3::new(
            fixed_point::decode(self.r),
            fixed_point::decode(self.g),
            fixed_point::decode(self.b),
        )
    }

    /// The samples' weight, in samples.
    #[inline]
    pub fn samples(&self) -> f32 {
        self.count as f32 * (1.0 / SAMPLE_WEIGHT_ONE as f32)
    }

    /// Weighted mean radiance of the accumulated samples, zero when there are none.
    #[inline]
    pub fn mean(&self) -> Vec3 {
        if self.count == 0 {
            return Vec3::ZERO;
        }
        self.radiance_sum() / self.samples()
    }
}

/// Push constants of the hash-grid passes.
#[repr(C)]
#[derive(Clone, Copy, Debug, Default, PartialEq, Pod, Zeroable)]
pub struct HashGridParams {
    /// Camera position (world space).
    pub eye: [f32; 3],
    /// `tan(fov_y · pixels · max(1/H, H/W²))`, see [`crate::hash_cells::cell_size_const`].
    pub cell_size_const: f32,
    /// Lower clamp of the world-space cell size.
    pub min_cell_size: f32,
    /// `log2` of the bucket count.
    pub num_buckets_log2: u32,
    /// `log2` of the tiles per bucket.
    pub tiles_per_bucket_log2: u32,
    /// Frame counter: touch stamps, tile decay and the live-list ping-pong (`frame_index & 1`).
    pub frame_index: u32,
    /// Work items of a directly dispatched pass (e.g. the queries of a batch), which invocations
    /// compare their index against; indirectly dispatched passes read their counts from buffers.
    pub item_count: u32,
    /// Sample-count cap of a cell's history (default [`crate::hash_cells::MAX_SAMPLE_COUNT`]; 0
    /// reads as 1).
    pub sample_cap: u32,
    /// 1: the blend adapts its cap to how much a tile's lighting changed
    /// ([`crate::hash_cells::adaptive_blend`]); 0: the fixed `sample_cap` (the reference).
    pub adaptive_blend: u32,
    /// Time constant, in updates of its tile, over which a cell's history fades: each update
    /// weighs the history `1 − 1/history_frames` before blending ([`crate::hash_cells::update`]);
    /// 0 keeps it whole (the reference: a history of `sample_cap` samples, however old).
    pub history_frames: u32,
}

impl HashGridParams {
    /// The count from which a read takes a cell rather than its parent mip
    /// ([`crate::hash_cells::read`]): the sample cap while the history never fades (the
    /// reference), [`crate::hash_cells::READ_MIN_SAMPLES`] when it does.
    #[inline]
    pub fn read_min_samples(&self) -> f32 {
        if self.history_frames == 0 {
            crate::math::max_u32(self.sample_cap, 1) as f32
        } else {
            crate::hash_cells::READ_MIN_SAMPLES
        }
    }

    /// Parameters with the GI-1.0 defaults (4096 buckets × 16 tiles, 0.1 minimum cell size).
    #[inline]
    pub fn new(eye: Vec3, cell_size_const: f32, frame_index: u32) -> Self {
        Self {
            eye: eye.to_array(),
            cell_size_const,
            min_cell_size: MIN_CELL_SIZE,
            num_buckets_log2: NUM_BUCKETS_LOG2,
            tiles_per_bucket_log2: TILES_PER_BUCKET_LOG2,
            frame_index,
            item_count: 0,
            sample_cap: crate::hash_cells::MAX_SAMPLE_COUNT,
            adaptive_blend: 1,
            history_frames: 0,
        }
    }

    /// Camera position.
    #[inline]
    pub fn eye(&self) -> Vec3 {
        Vec3::from_array(self.eye)
    }

    /// Whether the tile count `2^(buckets + tiles per bucket)` fits the buffers
    /// (≤ [`MAX_HASH_GRID_TILES`]); the host must check this before uploading.
    #[inline]
    pub fn fits_buffers(&self) -> bool {
        self.num_buckets_log2 <= MAX_NUM_TILES_LOG2
            && self.tiles_per_bucket_log2 <= MAX_NUM_TILES_LOG2 - self.num_buckets_log2
    }

    /// Tile count `2^(num_buckets_log2 + tiles_per_bucket_log2)`, for parameters that
    /// [fit the buffers](Self::fits_buffers): the length of the key and touch buffers and the
    /// capacity of the tile lists.
    #[inline]
    pub fn tile_count(&self) -> u32 {
        1 << (self.num_buckets_log2 + self.tiles_per_bucket_log2)
    }
}

/// One query of a hash-grid batch (the CPU model's input, uploaded as is by the GPU tests): a ray
/// from the camera side that hit `hit_position` after `hit_distance` along unit `direction`, and
/// the radiance sample to add to the cell it falls into.
#[repr(C)]
#[derive(Clone, Copy, Debug, Default, PartialEq, Pod, Zeroable)]
pub struct HashGridQuery {
    /// Hit position (world space).
    pub hit_position: [f32; 3],
    /// Ray length to the hit.
    pub hit_distance: f32,
    /// Unit ray direction.
    pub direction: [f32; 3],
    /// Explicit padding.
    pub _pad0: u32,
    /// Radiance sample.
    pub radiance: [f32; 3],
    /// Explicit padding.
    pub _pad1: u32,
}

impl HashGridQuery {
    /// A query.
    #[inline]
    pub fn new(hit_position: Vec3, direction: Vec3, hit_distance: f32, radiance: Vec3) -> Self {
        Self {
            hit_position: hit_position.to_array(),
            hit_distance,
            direction: direction.to_array(),
            _pad0: 0,
            radiance: radiance.to_array(),
            _pad1: 0,
        }
    }

    /// Hit position.
    #[inline]
    pub fn hit_position(&self) -> Vec3 {
        Vec3::from_array(self.hit_position)
    }

    /// Ray direction.
    #[inline]
    pub fn direction(&self) -> Vec3 {
        Vec3::from_array(self.direction)
    }

    /// Radiance sample.
    #[inline]
    pub fn radiance(&self) -> Vec3 {
        Vec3::from_array(self.radiance)
    }
}

// Every buffer below must fit one storage binding.
const _: () = assert!(
    MAX_HASH_GRID_CELLS * core::mem::size_of::<HashCellValue>() <= MAX_STORAGE_BUFFER_BYTES
);
const _: () = assert!(MAX_HASH_GRID_ACCUMULATOR_WORDS * 4 <= MAX_STORAGE_BUFFER_BYTES);
const _: () = assert!(core::mem::size_of::<HashCellAccumulator>() == ACCUMULATOR_WORDS * 4);
// Key (checksum) and touch buffers, and each live/update tile list: one u32 per tile.
const _: () = assert!(MAX_HASH_GRID_TILES * 4 <= MAX_STORAGE_BUFFER_BYTES);
const _: () = assert!(core::mem::size_of::<HashGridParams>() <= MAX_PUSH_CONSTANT_BYTES);

/// The hash grid as a lookup reads it: each slot's key and last touch (atomic words on the GPU,
/// any [`AtomicWords`](crate::atomics::AtomicWords) on the CPU) and the cells' values.
#[derive(Clone, Copy)]
pub struct HashCellsRead<'a, K: ?Sized, T: ?Sized> {
    /// The slots' keys (`storage`).
    pub keys: &'a K,
    /// The slots' last-touch frames (`touch`).
    pub last_touch: &'a T,
    /// The cells' blended values, [`CELLS_PER_TILE`] per tile.
    pub values: &'a [HashCellValue],
}

/// The buffers InsertRadianceCache writes for a query: the slots' keys and last touch, the cells'
/// values (cleared for a new tile), the frame's tile lists, the pass counters and the insert
/// marks that settle full buckets (`full_buckets`). The word buffers are held by value (`&mut
/// [u32]` on the CPU, the kernels' device words on the GPU): a struct of pointers to the kernels'
/// wrappers miscompiled (every insert failed).
pub struct HashCellsInsert<'a, K, T, L, C, M> {
    /// The slots' keys.
    pub keys: K,
    /// The slots' last-touch frames.
    pub last_touch: T,
    /// The cells' values.
    pub values: &'a mut [HashCellValue],
    /// The frame's tile lists (`lists`).
    pub lists: L,
    /// The world cache's counters.
    pub counters: C,
    /// The insert marks.
    pub marks: M,
}

#[cfg(test)]
mod tests {
    use super::*;
    use core::mem::{offset_of, size_of};

    #[test]
    fn sizes_and_offsets() {
        assert_eq!(size_of::<HashCellValue>(), 8);
        let v = HashCellValue::new(Vec3::new(3.0, 1e6, 0.0), 16.0);
        assert_eq!(v.count(), 16.0);
        assert_eq!(v.radiance_sum(), Vec3::new(3.0, 1_000_448.0, 0.0));
        assert_eq!(
            HashCellValue::new(v.radiance_sum() * 2.0, v.count() * 2.0).count(),
            32.0
        );
        assert_eq!(
            HashCellValue::new(Vec3::splat(f32::NAN), 1.0).mean(),
            Vec3::ZERO
        );

        assert_eq!(size_of::<HashCellAccumulator>(), 28);
        assert_eq!(offset_of!(HashCellAccumulator, r), 0);
        assert_eq!(offset_of!(HashCellAccumulator, g), 8);
        assert_eq!(offset_of!(HashCellAccumulator, b), 16);
        assert_eq!(
            offset_of!(HashCellAccumulator, count),
            4 * HashCellAccumulator::COUNT_WORD
        );

        assert_eq!(size_of::<HashGridQuery>(), 48);
        assert_eq!(offset_of!(HashGridQuery, hit_position), 0);
        assert_eq!(offset_of!(HashGridQuery, hit_distance), 12);
        assert_eq!(offset_of!(HashGridQuery, direction), 16);
        assert_eq!(offset_of!(HashGridQuery, radiance), 32);

        assert_eq!(size_of::<HashGridParams>(), 48);
        assert_eq!(offset_of!(HashGridParams, eye), 0);
        assert_eq!(offset_of!(HashGridParams, cell_size_const), 12);
        assert_eq!(offset_of!(HashGridParams, min_cell_size), 16);
        assert_eq!(offset_of!(HashGridParams, num_buckets_log2), 20);
        assert_eq!(offset_of!(HashGridParams, tiles_per_bucket_log2), 24);
        assert_eq!(offset_of!(HashGridParams, frame_index), 28);
        assert_eq!(offset_of!(HashGridParams, item_count), 32);
        assert_eq!(offset_of!(HashGridParams, sample_cap), 36);
        assert_eq!(offset_of!(HashGridParams, adaptive_blend), 40);
        assert_eq!(offset_of!(HashGridParams, history_frames), 44);
        // All alignments are 4: no implicit padding anywhere.
        assert_eq!(core::mem::align_of::<HashGridParams>(), 4);
    }

    #[test]
    fn capacities() {
        assert_eq!(MAX_HASH_GRID_CELLS, 5_570_560);
        // 45 MB of values and 117 MB of accumulators, each under the 128 MiB binding.
        assert_eq!(MAX_HASH_GRID_CELLS * size_of::<HashCellValue>(), 44_564_480);
        assert_eq!(MAX_HASH_GRID_ACCUMULATOR_WORDS * 4, 117_702_656);
        assert!(HashGridParams::new(Vec3::ZERO, 0.03, 0).fits_buffers());
        assert_eq!(
            HashGridParams::new(Vec3::ZERO, 0.03, 0).tile_count(),
            65_536
        );
        let mut p = HashGridParams::new(Vec3::ZERO, 0.03, 0);
        p.num_buckets_log2 = 16;
        p.tiles_per_bucket_log2 = 1;
        assert!(!p.fits_buffers());
        p.num_buckets_log2 = 40;
        assert!(!p.fits_buffers());
    }

    #[test]
    fn hash_cell_value_and_accumulator() {
        let v = HashCellValue::new(Vec3::new(8.0, 4.0, 2.0), 16.0);
        assert_eq!(v.radiance_sum(), Vec3::new(8.0, 4.0, 2.0));
        assert_eq!(v.mean(), Vec3::new(0.5, 0.25, 0.125));
        assert_eq!(v.sum_and_count(), Vec4::new(8.0, 4.0, 2.0, 16.0));
        assert_eq!(HashCellValue::ZERO, HashCellValue::default());
        assert_eq!(HashCellValue::ZERO.mean(), Vec3::ZERO);
        // Large sums do not saturate; they keep 2^-10 of precision.
        let big = HashCellValue::new(Vec3::splat(1e9), 1.0).radiance_sum();
        assert!(
            (big - 1e9).abs().max_element() <= 1e9 * crate::packing::WIDE16_MAX_RELATIVE_ERROR,
            "{big}"
        );

        let a = HashCellAccumulator {
            r: fixed_point::encode(3.0),
            g: fixed_point::encode(1.5),
            b: [0, 0],
            count: 2 * SAMPLE_WEIGHT_ONE,
        };
        assert_eq!(a.mean(), Vec3::new(1.5, 0.75, 0.0));
        assert_eq!(HashCellAccumulator::default().mean(), Vec3::ZERO);
        // The loaded copy is the cell's seven words, in order.
        let words: [u32; ACCUMULATOR_WORDS] = bytemuck::cast(a);
        assert_eq!(words[HashCellAccumulator::COUNT_WORD], a.count);
        assert_eq!([words[0], words[1]], a.r);
    }
}
